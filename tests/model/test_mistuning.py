"""Mistuned disk scenes (effect "mistuning"): the full N-sector assembly with random
sector stiffnesses, against the tuned one-sector reduction (zero mistuning), a
direct linear solve of independently assembled matrices (stuck contacts), and the
harmonic balance residual of the assembly; schema and cost rules."""
import copy
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as la

import pipeline.model.cyclic as cyclic
from pipeline.solve.harmonic_balance import hbm
from pipeline.study.datasets.conformance import problems
from pipeline.errors import UsageError
from pipeline.solve.response.response import frequency_response
from pipeline.study.files.documents import load_study, study_from_document, study_to_mapping
from pipeline.model.build import stiffness_factors

ROOT = Path(__file__).resolve().parents[2]
MISTUNED = ROOT / "studies" / "disk_mistuned.toml"
TUNED = ROOT / "studies" / "disk_cyclic.toml"
DOC = tomllib.loads(MISTUNED.read_text())
KU = 7.1e5


def study(N=6, eo=2, std=0.02, seed=None, n0=None, mistuned=True, H=1):
    """disk_mistuned.toml with N sectors, EO `eo`, H harmonics; tuned (no mistuning
    table, no seed axis) when `mistuned` is false."""
    doc = copy.deepcopy(DOC)
    doc.pop("quick")
    doc["scene"]["disk"].update(sectors=N, engine_order=eo)
    doc["solver"].update(harmonics=H, stability=False)
    if n0 is not None:
        doc["scene"]["contact"][0]["n0"] = n0
    if mistuned:
        doc["scene"]["disk"]["mistuning"] = {"stiffness_std": std, "seed": seed or 1}
        doc["sweep"].pop("mistuning_seed")
    else:
        del doc["scene"]["disk"]["mistuning"], doc["sweep"]["mistuning_seed"]
        doc["scene"]["effects"].remove("mistuning")
    return study_from_document(doc, file="mistuned.toml")


def curve(st, lo_hz, hi_hz, peak_dofs):
    s = st.system({})
    return s, frequency_response(s, st.solver.harmonics, 2 * np.pi * lo_hz, 2 * np.pi * hi_hz,
                                 stability=False, tol_rel=st.solver.tolerance,
                                 peak_dofs=peak_dofs)


def test_zero_mistuning_assembly_equals_the_tuned_sector():
    """std = 0: the 6-sector assembly (12 DOFs, 6 contacts) gives every sector the
    tuned one-sector peak, amplitude and frequency."""
    tuned, mis = study(std=0.0, mistuned=False), study(std=0.0)
    np.testing.assert_array_equal(stiffness_factors(mis.scene, {}), np.ones(6))
    st, a = curve(tuned, 400.0, 470.0, [0])
    sm, b = curve(mis, 400.0, 470.0, [mis.scene.dof_index(f"x1@{j}") for j in range(6)])
    assert st.n_dof == 2 and st.cyclic is not None
    assert sm.n_dof == 12 and sm.cyclic is None and sm.n_elements == 6
    assert a.success and b.success and a.converged.all() and b.converged.all()
    amp, om, _ = a.peak(0)
    for j in range(6):
        bj = b.peak(mis.scene.dof_index(f"x1@{j}"))
        assert bj[0] == pytest.approx(amp, rel=1e-9)
        assert bj[1] == pytest.approx(om, rel=1e-7)


def reference_matrices(st, seed_case):
    """M, C, K of the ring with stuck shroud springs, built here from the sector
    data and `default_rng(seed)`, independently of `cyclic.full_assembly`."""
    sc = st.scene
    N, n = sc.assembly.sectors, 2
    std, seed = sc.mistuning.stiffness_std, seed_case
    delta = np.random.default_rng(seed).normal(0.0, std, N)
    assert np.abs(delta).max() < 3 * std  # no truncation for these seeds
    M = np.zeros((N * n, N * n))
    C, K = M.copy(), M.copy()
    for j in range(N):
        s = slice(j * n, (j + 1) * n)
        M[s, s], C[s, s], K[s, s] = sc.structure.M, sc.structure.C, (1 + delta[j]) * sc.structure.K
    for j in range(N):
        b = np.zeros(N * n)
        b[((j + 1) % N) * n + 1], b[j * n + 1] = 1.0, -1.0  # u = x2_{j+1} - x2_j
        K += KU * np.outer(b, b)
    return M, C, K


def test_stuck_mistuned_assembly_is_the_direct_linear_solve():
    """n0 = 1e6 N (never slips): every point of the mistuned assembly's branch is
    the linear solve (K_ring - w^2 M + i w C) X = F with K_ring assembled here, to
    1e-9; the sectors' peaks differ (mistuning localises the response)."""
    st = study(N=6, eo=2, std=0.02, seed=3, n0=1e6)
    s, c = curve(st, 490.0, 520.0, [0])
    assert c.success and c.converged.all()
    M, C, K = reference_matrices(st, 3)
    F = np.concatenate([np.exp(1j * j * 2 * np.pi * 2 / 6) * np.array([1.0, 0.0])
                        for j in range(6)])
    f = 1 + np.random.default_rng(3).normal(0.0, 0.02, 6)
    np.testing.assert_allclose(s.K, np.kron(np.diag(f), st.scene.structure.K), rtol=0, atol=1e-9)
    for Q, om in zip(c.Q[::7], c.omega[::7]):
        X = np.linalg.solve(K - om**2 * M + 1j * om * C, F)
        Xh = Q[:, 1] - 1j * Q[:, 2]       # x = a cos + b sin  ->  X = a - i b
        assert np.abs(Xh - X).max() <= 1e-9 * np.abs(X).max()
    peaks = np.array([c.peak(i)[0] for i in range(0, 12, 2)])
    assert np.ptp(peaks) > 1e-2 * peaks.max()


def test_mistuned_friction_branch_satisfies_the_assembly_residual():
    """Friction slips (n0 = 2 N): every converged point of the assembly's branch,
    residual recomputed here on the uncondensed assembly, is within tolerance; the
    sectors' blade peaks differ, the tuned sector's lies within their range."""
    st = study(N=6, eo=2, std=0.02, seed=1)
    s, c = curve(st, 380.0, 480.0, range(0, 12, 2))
    assert c.success and c.converged.all()
    prob = hbm.setup(s, st.solver.harmonics)
    for Q, om in zip(c.Q[::5], c.omega[::5]):
        assert np.linalg.norm(hbm.full_residual(prob, Q, om)) <= c.tolerance
    peaks = np.array([c.peak(i)[0] for i in range(0, 12, 2)])
    assert np.ptp(peaks) > 1e-2 * peaks.max()
    _, t = curve(study(N=6, eo=2, mistuned=False), 380.0, 480.0, [0])
    assert peaks.min() < t.peak(0)[0] < peaks.max()


def test_a_tuned_disk_never_assembles_and_a_mistuned_one_once_per_case(monkeypatch):
    calls = {"full": 0, "sector": 0}
    full, sector = cyclic.full_assembly, cyclic.sector_system

    def forbidden(*a, **k):
        raise AssertionError("a tuned disk must not assemble all sectors")

    monkeypatch.setattr(cyclic, "full_assembly", forbidden)
    tuned = load_study(TUNED)
    for _, case in tuned.sweep.cases():
        assert tuned.system(case).cyclic is not None

    def counted_full(*a, **k):
        calls["full"] += 1
        return full(*a, **k)

    def counted_sector(*a, **k):
        calls["sector"] += 1
        return sector(*a, **k)

    monkeypatch.setattr(cyclic, "full_assembly", counted_full)
    monkeypatch.setattr(cyclic, "sector_system", counted_sector)
    mis = load_study(MISTUNED)
    calls.update(full=0, sector=0)
    systems = [mis.system(case) for _, case in mis.sweep.cases()]
    assert calls == {"full": 2, "sector": 0}
    for s in systems:
        assert s.cyclic is None and s.n_dof == 24 and s.dof_names == mis.scene.dofs
    assert not np.array_equal(systems[0].K, systems[1].K)  # seeds 1 and 2


def test_mistuned_scene_labels_every_sector():
    st = load_study(MISTUNED)
    sc = st.scene
    assert sc.sector_dofs == ("x1", "x2") and len(sc.dofs) == 24
    assert st.output.dofs == tuple(f"x1@{j}" for j in range(12))
    for i, label in enumerate(sc.dofs):
        assert sc.dof_index(label) == i
    assert sc.dof_index("x2@3") == 7
    with pytest.raises(ValueError, match="sector below 12"):
        sc.dof_index("x1@12")
    f = stiffness_factors(sc, {"mistuning_seed": 2})
    np.testing.assert_array_equal(f, 1 + np.random.default_rng(2).normal(0, 0.02, 12))
    # the canonical document round-trips (explicit labels are accepted back)
    u = study_from_document(study_to_mapping(st), file="canonical.toml")
    assert (u.sweep, u.solver, u.output) == (st.sweep, st.solver, st.output)
    assert u.scene.mistuning == sc.mistuning
    assert study_to_mapping(u) == study_to_mapping(st)


@pytest.mark.parametrize("std, match", [(0.5, "0 <= std < 0.5"), (-0.01, ">= 0")])
def test_stiffness_std_bounds(std, match):
    doc = copy.deepcopy(DOC)
    doc["scene"]["disk"]["mistuning"]["stiffness_std"] = std
    with pytest.raises(UsageError, match=r"scene\.disk\.mistuning\.stiffness_std: .*" + match):
        study_from_document(doc, file="m.toml")


def test_mistuning_factors_arguments_are_named():
    with pytest.raises(ValueError, match="stiffness_std"):
        cyclic.mistuning_factors(12, 0.6, 1)
    with pytest.raises(ValueError, match="seed"):
        cyclic.mistuning_factors(12, 0.02, -1)
    f = cyclic.mistuning_factors(4, 0.49, 7)     # truncation keeps every K_j positive
    assert np.all(f >= 0.1) and np.all(np.abs(f - 1) <= 3 * 0.49)


def test_mistuned_study_dataset(quick_run):
    """disk_mistuned.toml (quick, the run shared through conftest) end to end: the
    dataset reports x1 of every sector on the sector dimension, passes the contract
    checker, and its per-sector peaks differ; the mode dimension is that of the 24-DOF
    assembly."""
    st = load_study(MISTUNED, quick=True)
    _, nc, ds = quick_run("disk_mistuned")
    assert list(ds["dof"].values) == ["x1"] and list(ds["sector"].values) == list(range(12))
    np.testing.assert_array_equal(ds["mistuning_factor"].sel(mistuning_seed=1),
                                  stiffness_factors(st.scene, {"mistuning_seed": 1}))
    assert ds.sizes["mode"] == 24 and ds.attrs["mistuning_stiffness_std"] == 0.02
    assert int(ds["converged"].sum()) > 50
    peaks = ds["peak_amplitude"].isel(mistuning_seed=0).sel(dof="x1").values
    assert np.all(np.isfinite(peaks)) and np.ptp(peaks) > 1e-2 * peaks.max()
    assert problems(nc) == []


def factors_study(factors, N=6, **extra):
    doc = copy.deepcopy(DOC)
    doc.pop("quick")
    doc["scene"]["disk"].update(sectors=N, engine_order=2)
    doc["scene"]["disk"]["mistuning"] = {"factors": list(factors), **extra}
    doc["sweep"].pop("mistuning_seed")
    return study_from_document(doc, file="given.toml")


def test_given_factors_scale_each_sector_and_round_trip():
    """`mistuning = { factors = [...] }`: sector j gets f_j K, exactly the factors
    given; all ones is the zero-mistuning assembly; the canonical document keeps them."""
    f = [1.0, 1.05, 0.97, 1.0, 1.02, 0.99]
    st = factors_study(f)
    np.testing.assert_array_equal(stiffness_factors(st.scene, {}), f)
    s, K = st.system({}), st.scene.structure.K
    n = K.shape[0]
    for j in range(6):
        blk = slice(j * n, (j + 1) * n)
        np.testing.assert_array_equal(s.K[blk, blk], f[j] * K)
    ones, zero = factors_study([1.0] * 6).system({}), study(std=0.0).system({})
    for name in ("M", "C", "K", "Bt", "Bn", "forcing"):
        np.testing.assert_array_equal(getattr(ones, name), getattr(zero, name))
    u = study_from_document(study_to_mapping(st), file="canonical.toml")
    assert u.scene.mistuning.factors == tuple(f) and u.system({}).K.tolist() == s.K.tolist()
    assert st.scene.dofs[n] == "x1@1"


@pytest.mark.parametrize("factors,extra,field", [
    ([1.0] * 5, {}, "scene.disk.mistuning.factors"),
    ([1.0, 1.0, 0.0, 1.0, 1.0, 1.0], {}, "scene.disk.mistuning.factors[2]"),
    ([1.0] * 6, {"seed": 3}, "scene.disk.mistuning.seed"),
    ([1.0] * 6, {"stiffness_std": 0.02}, "scene.disk.mistuning.stiffness_std"),
])
def test_given_factors_are_checked(factors, extra, field):
    with pytest.raises(UsageError, match=re.escape(f"given.toml: {field}:")):
        factors_study(factors, **extra)


def test_given_factors_study_dataset(tmp_path):
    """A 6-sector disk with one sector 5 % stiffer, end to end: the dataset carries
    the factors given (no seed dimension), says how they were set, passes the contract
    checker, and the stiff sector's peak stands apart from the others'."""
    from pipeline.study.execution.run import run_study

    f = [1.0, 1.0, 1.0, 1.05, 1.0, 1.0]
    doc = copy.deepcopy(DOC)
    doc.pop("quick")
    doc["scene"]["disk"].update(sectors=6, engine_order=2, mistuning={"factors": f})
    doc["sweep"] = {"frequency": {"start": 400.0, "stop": 470.0, "unit": "Hz"}}
    doc["solver"].update(harmonics=1, stability=False)
    st = study_from_document(doc, file=str(tmp_path / "given.toml"), name="given")
    res = run_study(st, tmp_path, workers=1, figures=False, progress=False)
    assert res.ok
    ds = res.dataset
    assert "mistuning_seed" not in ds.dims and list(ds["sector"].values) == list(range(6))
    np.testing.assert_array_equal(ds["mistuning_factor"].values, f)
    assert "given in the study" in ds.attrs["mistuning"]
    assert "mistuning_stiffness_std" not in ds.attrs
    K, M = st.scene.structure.K, st.scene.structure.M       # assembled here, independently
    w = np.sqrt(la.eigh(np.kron(np.diag(f), K), np.kron(np.eye(6), M), eigvals_only=True))
    np.testing.assert_allclose(ds["natural_frequency_free"].values, w / (2 * np.pi), rtol=1e-10)
    peaks = ds["peak_amplitude"].sel(dof="x1").values
    assert np.all(np.isfinite(peaks)) and np.ptp(peaks) > 1e-2 * peaks.max()
    assert problems(res.path) == []


def monte_carlo_study(tmp_path, std, seeds, preloads, N=4):
    """disk_mistuned.toml as a Monte-Carlo: N sectors, EO 1, seeds x preloads, H = 1."""
    doc = copy.deepcopy(DOC)
    doc.pop("quick")
    doc["scene"]["disk"].update(sectors=N, engine_order=1, mistuning={"stiffness_std": std})
    del doc["scene"]["contact"][0]["n0"]
    doc["sweep"] = {"preload": list(preloads), "mistuning_seed": list(seeds),
                    "frequency": {"start": 360.0, "stop": 470.0, "unit": "Hz"}}
    doc["solver"].update(harmonics=1, stability=False)
    return study_from_document(doc, file=str(tmp_path / "mc.toml"), name="mc")


def tuned_peak(st, preload):
    """The tuned disk's blade peak from an independent one-sector continuation."""
    from dataclasses import replace as repl
    scene = repl(st.scene, assembly=repl(st.scene.assembly, mistuning=None))
    from pipeline.model.build import build_system
    s = build_system(scene, {"preload": preload})
    c = frequency_response(s, 1, 2 * np.pi * 360.0, 2 * np.pi * 470.0, stability=False,
                           tol_rel=st.solver.tolerance, peak_dofs=[0])
    return c.amplitude[c.converged, 0].max()


def test_monte_carlo_amplification_per_preload_on_dask(tmp_path):
    """Seeds as a sweep axis, run on a local Dask cluster (2 workers): the dataset
    reports the tuned peak per preload and the amplification factor per (preload,
    seed) = largest sector peak / tuned peak, against an independent tuned solve;
    the figure draws its distribution per preload."""
    from pipeline.study.execution.run import run_study

    st = monte_carlo_study(tmp_path, 0.05, [1, 2, 3], [1.0, 4.0])
    res = run_study(st, tmp_path, workers=2, progress=False)
    ds = res.dataset
    a = ds["amplification_factor"].sel(dof="x1")
    assert a.dims == ("preload", "mistuning_seed") and np.all(np.isfinite(a))
    for i, p in enumerate([1.0, 4.0]):
        ref = tuned_peak(st, p)
        assert np.isclose(float(ds["tuned_peak_amplitude"].sel(dof="x1")[i]), ref, rtol=1e-6)
        top = ds["peak_amplitude"].sel(dof="x1").isel(preload=i).max("sector")
        np.testing.assert_allclose(a.isel(preload=i), top / ref, rtol=1e-6)
    assert float(np.abs(a - 1).max()) > 1e-3          # 5 % mistuning shows
    assert problems(res.path) == []
    assert (tmp_path / "mc" / "amplification_x1.png").stat().st_size > 10_000


def test_zero_mistuning_amplification_is_one(tmp_path):
    from pipeline.study.execution.run import run_study

    st = monte_carlo_study(tmp_path, 0.0, [7], [2.0])
    ds = run_study(st, tmp_path, figures=False, progress=False).dataset
    np.testing.assert_allclose(ds["amplification_factor"], 1.0, rtol=1e-6)
    np.testing.assert_allclose(ds["peak_amplitude"].sel(dof="x1").squeeze(),
                               float(ds["tuned_peak_amplitude"].squeeze()), rtol=1e-6)
