"""A scene pays only for the effects it calls for: counted, not just results.

1. constant normal load (Jenkins path): the normal load is never searched for zeros;
2. no friction, no separation: a direct linear solve per frequency, no Newton;
3. one blade: no cyclic assembly (see tests/study/scenes/test_blade_studies.py / test_cyclic.py);
4. elements fully stuck or fully open over the cycle: no transition search (march).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pipeline.contact.laws as laws
import pipeline.solve.harmonic_balance.hbm as hbm
from pipeline.contact import YangMenq, forces
from pipeline.solve.response.response import frequency_response
from pipeline.study.files.documents import parse_study
from pipeline.study.execution.cases import default_solver
from pipeline.study.execution.run import run_study
from pipeline.model.blade_cache import reduced_model
from pipeline.paper_systems import example1, example3

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def counted(monkeypatch):
    """Every contact evaluation of the HBM, with the regime counts the compiled kernel
    reports summed ("transitions": elements that went through the transition search)."""
    seen = {"evaluations": 0, "normal_load_searched": 0, "stuck": 0, "separated": 0,
            "transitions": 0}
    def counting(real):
        def counted_call(*a, **k):
            f = real(*a, **k)
            regimes = f[-1] if isinstance(f, tuple) else f.regimes   # `stacked_forces`: a tuple
            seen["evaluations"] += 1
            for key in ("normal_load_searched", "stuck", "separated", "transitions"):
                seen[key] += regimes.get(key, 0)
            return f
        return counted_call

    # the HBM evaluates the Yang-Menq law (`contact.laws`): the exact forces directly
    # (`stacked_forces`), `yang_menq_forces` for AFT
    monkeypatch.setattr(laws, "yang_menq_forces", counting(laws.yang_menq_forces))
    monkeypatch.setattr(laws, "stacked_forces", counting(laws.stacked_forces))
    return seen


# -- 1. Jenkins path ------------------------------------------------------------

def test_constant_normal_load_never_searches_for_separation(counted):
    # Example 1 (kv = 0) at a stick-slip preload: transitions on most points
    c = frequency_response(example1(2.0), 3, 150.0, 250.0, stability=False)
    assert c.success and c.converged.all()
    assert counted["evaluations"] > 20 and counted["transitions"] > 20  # not vacuous
    assert counted["normal_load_searched"] == 0


def test_varying_normal_load_is_searched(counted):
    c = frequency_response(example3(10.0), 5, 0.9, 1.6, stability=False)
    assert c.success
    assert counted["normal_load_searched"] == counted["evaluations"]  # one element, every time


def test_jenkins_forces_identical_to_a_formally_varying_normal_load():
    """The shortcut changes the work, not the numbers: kv = 0 vs kv > 0 with v = 0."""
    rng = np.random.default_rng(3)
    E, H = 200, 5
    U = rng.normal(size=(E, 2 * H + 1)) * rng.uniform(0.01, 3, (E, 1))
    V = np.zeros_like(U)
    n0 = rng.uniform(0.1, 2, E)
    a = forces(U, V, YangMenq(ku=1.0, kv=0.0, mu=0.4, n0=n0))
    V1 = V.copy()
    V1[:, 1] = 1e-300  # formally varying: the normal-load search runs, finds nothing
    b = forces(U, V1, YangMenq(ku=1.0, kv=5.0, mu=0.4, n0=n0))
    assert a.regimes["normal_load_searched"] == 0 and b.regimes["normal_load_searched"] == E
    assert a.regimes["transitions"] > E // 2
    np.testing.assert_allclose(a.Fu, b.Fu, rtol=0, atol=1e-12 * np.abs(a.Fu).max())
    np.testing.assert_allclose(a.dFu_dU, b.dFu_dU, rtol=0, atol=1e-12 * np.abs(a.dFu_dU).max())


# -- 2. linear scenes -------------------------------------------------------------

LINEAR = """
[study]
title = "one-DOF linear oscillator"
[scene]
model = "lumped"
effects = []
dofs = ["x"]
[scene.matrices]
M = [[2.0]]
C = [[0.8]]
K = [[5.0e4]]
[[scene.excitation]]
dof = "x"
amplitude = 3.0
[sweep]
excitation_scale = [1.0, 0.5]
frequency = { start = 100.0, stop = 250.0, unit = "rad/s" }
[solver]
harmonics = 3
[output]
dofs = ["x"]
"""


def test_linear_scene_is_solved_directly_without_newton(tmp_path, monkeypatch):
    import pipeline.solve.continuation.pseudo_arclength as cont
    import pipeline.solve.continuation.newton as nwt
    import pipeline.solve.response.response as resp

    def forbidden(*a, **k):
        raise AssertionError("a linear scene must not run Newton, continuation or the HBM")

    for mod, name in ((nwt, "newton"), (cont, "continue_branch"), (hbm, "residual"),
                      (laws, "yang_menq_forces"), (laws, "exact_forces"),
                      (laws, "stacked_forces"), (resp, "frequency_response")):
        monkeypatch.setattr(mod, name, forbidden)
    study = parse_study(LINEAR, file="linear.toml")
    assert default_solver(study).__module__ == "pipeline.solve.response.linear_response"
    res = run_study(study, tmp_path, figures=False, progress=False)
    assert res.ok
    ds = res.dataset
    assert ds.attrs["effects"] == "none (linear)"
    assert ds.attrs["solution_method"].startswith("direct linear solve per frequency")
    assert (ds["newton_iterations"].fillna(0) <= 0).all() and (ds["residual_evaluations"] == 0).all()
    # closed form: peak at wn sqrt(1 - 2 zeta^2), amplitude F / (k 2 zeta sqrt(1 - zeta^2))
    m, c, k = 2.0, 0.8, 5.0e4
    wn, zeta = np.sqrt(k / m), c / (2 * np.sqrt(k * m))
    for scale in (1.0, 0.5):
        d = ds.sel(excitation_scale=scale, dof="x")
        # the location of a maximum: Brent's bounded search stops at sqrt(eps) |x| = 1.5e-8
        assert float(d["peak_frequency"]) == pytest.approx(wn * np.sqrt(1 - 2 * zeta**2), rel=3e-8)
        assert float(d["peak_amplitude"]) == pytest.approx(
            3.0 * scale / (k * 2 * zeta * np.sqrt(1 - zeta**2)), rel=1e-10)
        assert bool(d["converged"].sum() > 200)
        assert bool((d["stable"] == 1).where(d["converged"], True).all())   # Hill: 1, not NaN
        assert float(d["residual"].max()) <= 1e-10 * 3.0 * scale


# -- 4. provably linear elements --------------------------------------------------

def test_only_switching_elements_are_marched(counted):
    """A batch of stuck, separated and slipping elements: the transition search sees
    exactly the slipping ones; the linear ones get closed-form forces."""
    H, E = 3, 30
    U = np.zeros((E, 2 * H + 1)); V = np.zeros((E, 2 * H + 1))
    U[:, 1] = np.r_[np.full(10, 1e-3), np.full(10, 1.0), np.full(10, 1.0)]   # small / large motion
    n0 = np.r_[np.full(10, 10.0), np.full(10, -5.0), np.full(10, 1.0)]       # stuck / open / slip
    V[:, 1] = 0.1
    f = forces(U, V, YangMenq(ku=1.0, kv=1.0, mu=0.5, n0=n0))
    assert f.regimes["stuck"] == 10 and f.regimes["separated"] == 10
    assert f.regimes["transitions"] == 10
    # the linear ones: stuck force ku (u - w) with zero mean here, open force zero
    np.testing.assert_allclose(f.Fu[10:20], 0.0, atol=0)
    np.testing.assert_allclose(f.Fu[:10, 1], 1e-3, rtol=1e-12)


@pytest.mark.parametrize("system, H, lo, hi", [
    (example1(1000.0), 3, 150.0, 250.0),      # damper stuck everywhere
    (example3(-100.0), 5, 0.8, 1.6),          # gap never closes
], ids=["fully-stuck", "fully-open"])
def test_linear_regimes_never_reach_the_transition_search(counted, system, H, lo, hi):
    c = frequency_response(system, H, lo, hi, stability=False)
    assert c.success and c.converged.all()
    assert counted["evaluations"] > 10
    assert counted["transitions"] == 0 and counted["stuck"] + counted["separated"] > 10


def test_dataset_says_what_the_scene_included():
    from pipeline.study.datasets.describe import solution_method
    from pipeline.study.files.documents import load_study

    ex1 = load_study(ROOT / "studies" / "paper_example1.toml", quick=True)
    ex3 = load_study(ROOT / "studies" / "paper_example3.toml", quick=True)
    assert "Jenkins path: no separation search" in solution_method(ex1)
    assert "searched for separation" in solution_method(ex3)


# -- 3. assembly: one blade builds no cyclic assembly; a disk builds one sector -----

def test_one_blade_builds_no_cyclic_assembly_and_a_disk_only_one_sector():
    from pipeline.study.files.documents import load_study

    blade = load_study(ROOT / "studies" / "blade_shroud_contact.toml", quick=True)
    sb = blade.system(blade.sweep.cases()[0][1])
    assert sb.cyclic is None                                   # no cyclic operator at all
    red = reduced_model(blade.scene.structure, blade.scene.reduction)[0]
    assert sb.n_dof == red.M.shape[0]        # one reduced blade, nothing more

    disk = load_study(ROOT / "studies" / "disk_cyclic.toml", quick=True)
    n_sector = len(disk.scene.dofs)
    for _, case in disk.sweep.cases():
        sd = disk.system(case)
        assert sd.cyclic is not None and sd.n_dof == n_sector  # 1 of 24 sectors assembled
        assert sd.M.shape == (n_sector, n_sector)
