"""Input guards of study files: what `[solver] stability = true` selects per scene kind,
the plausibility of FE disk dimensions, the size of the model `--quick` builds."""
import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

from pipeline.study.documents import load_study, study_from_document
from pipeline.study.run import run_study

STUDIES = Path(__file__).resolve().parent.parent / "studies"


def _doc(name):
    return tomllib.loads((STUDIES / name).read_text())


# ---------------------------------------------------------------------------
# [solver] stability = true
# ---------------------------------------------------------------------------

def _small_example1(stability):
    """Example 1 at n0 = 2 N (stick-slip), H = 3, through its resonance."""
    doc = _doc("paper_example1.toml")
    doc["sweep"] = {"preload": [2.0],
                    "frequency": {"start": 185.0, "stop": 200.0, "unit": "rad/s"}}
    doc["solver"] = {"harmonics": 3, "tolerance": 1e-9}
    if stability is not None:
        doc["solver"]["stability"] = stability
    doc["output"].pop("optimum_preload")
    doc.pop("quick")
    return study_from_document(doc, file="ex1.toml", name="ex1")


def test_stability_true_is_the_default_of_a_lumped_scene(tmp_path):
    """`true` and the absent key give the same method at every point: the orbit
    monodromy checked by Floquet, not Hill's method."""
    absent, true = _small_example1(None), _small_example1(True)
    assert absent.solver.stability == true.solver.stability == "monodromy+check"
    methods = []
    for k, st in enumerate((absent, true)):
        res = run_study(st, tmp_path / str(k), workers=1, figures=False, progress=False,
                        checkpoints=False)
        m = res.dataset["stability_method"].values
        methods.append(m[m >= 0])
    assert methods[0].size > 10
    np.testing.assert_array_equal(methods[0], methods[1])
    assert set(np.unique(methods[1])) <= {1, 2}   # Floquet or monodromy: never Hill (0)


def test_stability_true_per_scene_kind():
    """lumped -> monodromy+check; lumped disk -> hill (its default); FE blade and FE
    disk -> monodromy+check (run as the orbit monodromy, or Hill beyond its size)."""
    disk = _doc("disk_cyclic.toml")
    assert disk["solver"]["stability"] is True
    assert study_from_document(disk, file="d.toml").solver.stability == "hill"
    del disk["solver"]["stability"]
    assert study_from_document(disk, file="d.toml").solver.stability == "hill"
    for name in ("blade_shroud_contact.toml", "shrouded_disk.toml"):
        doc = _doc(name)
        assert study_from_document(copy.deepcopy(doc), file="b.toml",
                                   quick=True).solver.stability is False   # absent: off
        doc["solver"]["stability"] = True
        st = study_from_document(doc, file="b.toml", quick=True)
        assert st.solver.stability == "monodromy+check"
    assert load_study(STUDIES / "paper_example1.toml").solver.stability == "monodromy+check"
