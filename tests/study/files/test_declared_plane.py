"""Undeclared separation on FE shroud pairs with 2D friction: the run's guard reads the
2D law's normal load (`declared.separating` on the `contact_set`), not the empty
Yang-Menq set, so a scene that does not declare "separation" cannot separate there
unnoticed.  Checked against the normal load n0 + kv v sampled finely from the
structure's maps (`contact_dataset.set_motions`, another path to the same motion)."""
from pathlib import Path

import numpy as np
import pytest

from pipeline.fourier.harmonics import basis
from pipeline.model.build import build_system
from pipeline.model.system import contact_set
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response.response import frequency_response
from pipeline.study.datasets.contact_dataset import set_motions
from pipeline.study.files.declared import SeparationGuard, UndeclaredSeparation, separating
from pipeline.study.files.documents import load_study

ROOT = Path(__file__).resolve().parents[3]
SCENE = load_study(ROOT / "studies" / "shrouded_disk_2d.toml", quick=True).scene


def curve_at(preload):
    s = build_system(SCENE, {"preload": preload})
    dof = s.dof_names.index("response.y")
    c = frequency_response(s, 1, 260 * 2 * np.pi, 300 * 2 * np.pi, method="aft",
                           n_samples=64, stability=False, tol_rel=1e-8, peak_dofs=[dof])
    assert c.success
    return s, c


def sampled_minimum(system, Q):
    """min over 4096 instants of each element's n0 + kv v [N] (P, E)."""
    el = contact_set(system).elements
    V = set_motions(system, np.asarray(Q, float))[:, :, -1]
    tau = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    n = el.n0[None, :, None] + el.kv[None, :, None] * (V @ basis(tau, 1).T)
    return n.min(axis=-1)


@pytest.mark.parametrize("preload, separates", [(0.3, True), (30.0, False)])
def test_guard_sees_the_2d_pairs_separate(preload, separates):
    s, c = curve_at(preload)
    prob = hbm.setup(s, 1)
    el = contact_set(s).elements
    guard = np.array([separating(prob, q[prob.c], el).any() for q in c.Q])
    sampled = (sampled_minimum(s, c.Q) <= 0).any(axis=1)
    assert guard.any() == separates
    np.testing.assert_array_equal(guard, sampled)
    if separates:
        with pytest.raises(UndeclaredSeparation, match="separates at"):
            SeparationGuard(unit="Hz").check_curve(s, c)
    else:
        SeparationGuard(unit="Hz").check_curve(s, c)
