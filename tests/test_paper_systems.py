"""The paper's systems written in code (pipeline.paper_systems) and the shipped study
files that describe them (studies/paper_example{1,2,3}.toml, blade3_stability.toml)
are the same systems: every matrix, contact map, contact parameter and the
excitation, for every preload the study sweeps (full and quick)."""
import numpy as np
import pytest

from pipeline import paper_systems
from pipeline.model.system import dense
from pipeline.study.files.documents import load_study

from helpers import STUDIES, study_doc

PAIRS = [("paper_example1.toml", paper_systems.example1),
         ("paper_example2.toml", paper_systems.example2),
         ("paper_example3.toml", paper_systems.example3),
         ("blade3_stability.toml", lambda n0: paper_systems.blade3())]


def cases(name):
    """Every case of the study's full and quick sweeps."""
    out = []
    for quick in (False, True):
        st = load_study(STUDIES / name, quick=quick)
        out += [(st, case) for _, case in st.sweep.cases()]
    return out


def sym(A):
    """(A + A^T) / 2: what a study does to the matrices it forms from modal data,
    Phi^-T diag(d) Phi^-1, against round-off; exact (the identity) on a symmetric A."""
    return 0.5 * (A + A.T)


def assert_same_system(study, code, H, modal):
    """Equal bit for bit: M, C, K (the code's symmetrised as the study does its
    modal ones), Bt, Bn, the contact parameters and the excitation's harmonics."""
    a, b = study, code
    for k in ("M", "C", "K"):
        B = dense(getattr(b, k))
        np.testing.assert_array_equal(dense(getattr(a, k)), sym(B) if modal else B, err_msg=k)
    for k in ("Bt", "Bn"):
        np.testing.assert_array_equal(dense(getattr(a, k)), dense(getattr(b, k)), err_msg=k)
    for k in ("ku", "kv", "mu", "n0"):
        np.testing.assert_array_equal(getattr(a.contact, k), getattr(b.contact, k), err_msg=k)
    np.testing.assert_array_equal(a.forcing_coefficients(H), b.forcing_coefficients(H))
    assert a.cyclic is None and b.cyclic is None


@pytest.mark.parametrize("name, build", PAIRS, ids=[p[0] for p in PAIRS])
def test_study_file_and_code_build_the_same_system(name, build):
    modal = "modal" in study_doc(name)["scene"]     # Example 3: [scene.modal]
    seen = set()
    for st, case in cases(name):
        n0 = case["preload"]
        assert_same_system(st.system(case), build(n0), st.solver.harmonics, modal)
        seen.add(n0)
    assert seen, name
    if name == "blade3_stability.toml":   # blade3() carries its one preload
        assert seen == {paper_systems.blade3().contact.n0[0]}
