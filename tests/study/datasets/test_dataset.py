"""Study datasets: layout per the dataset contract (studies/README.md, Dataset), netCDF round
trip, the contract checker (and that it catches departures), atomic write, figures,
and the study runner's plumbing (with a linear reference solver)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pipeline.fourier import harmonics
from pipeline.study.datasets.dataset import read_dataset, write_netcdf
from pipeline.study.datasets.response_dataset import to_dataset
from pipeline.study.datasets.conformance import UnreadableDataset, main as check_main, problems
from pipeline.solve.response.response import ResponseCurve
from pipeline.study.files.documents import load_study
from pipeline.study.figures.response_figures import write_figures
from pipeline.study.execution.run import run_study
from pipeline.model.build import stiffness_factors

ROOT = Path(__file__).resolve().parents[3]
STUDIES = ROOT / "studies"


# ---------------------------------------------------------------------------
# One seeded data factory: linear harmonic response of a scene (contacts ignored)
# ---------------------------------------------------------------------------

def linear_curve(system, H, omega, *, converged=None, stable=None, folds=(), seed=0):
    """ResponseCurve of M q'' + C q' + K q = F(t) at the frequencies `omega` [rad/s]:
    exact for a scene without contact force, so peaks have closed forms."""
    P, n = omega.size, system.n_dof
    Q = np.zeros((P, n, 2 * H + 1))
    F = system.forcing
    for i, w in enumerate(omega):
        for h in range(1, min(H, F.shape[1] - 1) + 1):
            X = np.linalg.solve(system.K - (h * w) ** 2 * system.M + 1j * h * w * system.C, F[:, h])
            Q[i, :, 2 * h - 1], Q[i, :, 2 * h] = X.real, -X.imag
    if F.shape[1] == 2:                      # one harmonic: (max - min)/2 = |X_1| exactly
        amp = np.hypot(Q[:, :, 1], Q[:, :, 2])
    else:
        x = harmonics.evaluate(Q.reshape(P * n, -1), np.linspace(0, 2 * np.pi, 4096, endpoint=False))
        amp = (0.5 * (x.max(axis=1) - x.min(axis=1))).reshape(P, n)
    rng = np.random.default_rng(seed)
    return ResponseCurve(
        parameter=omega, omega=omega, Q=Q,
        converged=np.ones(P, bool) if converged is None else converged,
        residual=rng.uniform(0, 1e-10, P),
        stable=np.ones(P, bool) if stable is None else stable,
        amplitude=amp, fold_parameter=np.asarray(folds, float),
        newton_iterations=rng.integers(1, 5, P), nfev=4 * P, wall_time=0.01 * P,
        success=True, status=0, message="ok", H=H, tolerance=1e-9)


def linear_reference_solver(system, H, omega_start, omega_end, **kw):
    """Drop-in for frequency_response on linear scenes (exercises the plumbing)."""
    return linear_curve(system, H, np.linspace(omega_start, omega_end, 40))


def failing_solver(system, H, omega_start, omega_end, **kw):
    if system.contact.n0[0] == 2.0:
        raise FloatingPointError("singular Jacobian")
    return linear_reference_solver(system, H, omega_start, omega_end)


def curves_for(study, lengths=None, **kw):
    fr, H = study.sweep.frequency, study.solver.harmonics
    out = []
    for k, (_, case) in enumerate(study.sweep.cases()):
        P = lengths[k] if lengths else 50
        om = np.linspace(fr.omega_start, fr.omega_stop, P)
        out.append(linear_curve(study.system(case), H, om, seed=k, **kw))
    return out


@pytest.fixture(scope="module")
def ex1():
    return load_study(STUDIES / "paper_example1.toml", quick=True)


@pytest.fixture(scope="module")
def ex2():
    return load_study(STUDIES / "paper_example2.toml", quick=True)


# ---------------------------------------------------------------------------
# Layout and numbers
# ---------------------------------------------------------------------------

def test_layout_padding_and_flags(ex1):
    curves = curves_for(ex1, lengths=[30, 45, 20])
    conv = np.ones(45, bool)
    conv[7] = False
    amp = curves[1].amplitude.copy()
    amp[11] = np.nan                          # not finite: must not count as converged
    curves[1] = ResponseCurve(**{**vars(curves[1]), "converged": conv, "amplitude": amp})
    ds = to_dataset(ex1, curves)
    assert dict(ds.sizes) == {"preload": 3, "point": 45, "dof": 1, "harmonic": 4, "fold": 1, "mode": 1,
                              "bifurcation": 1, "component": 2, "contact": 1, "pair": 1}
    assert ds["amplitude"].dims == ("preload", "point", "dof")
    assert ds["harmonic_amplitude"].dims == ("preload", "point", "dof", "harmonic")
    assert ds["preload"].values.tolist() == [0.0, 2.0, 1000.0]
    assert ds["preload"].attrs["units"] == "N"
    assert ds["converged"].sum("point").values.tolist() == [30, 43, 20]
    assert np.isnan(ds["frequency"].values[0, 30:]).all()
    assert not ds["converged"].values[2, 20:].any() and np.isnan(ds["stable"].values[2, 20:]).all()
    assert np.isnan(ds["stable"].values[1, 7]) and ds["stable"].values[1, 6] == 1.0  # not converged
    assert (ds["newton_iterations"].values[0, 30:] == -1).all()
    conv = ds["converged"].values
    for name in ("frequency", "residual"):
        assert np.isfinite(ds[name].values[conv]).all()
    assert np.isfinite(ds["amplitude"].values[conv]).all()
    assert np.isfinite(ds["harmonic_amplitude"].values[conv]).all()
    pk = ds["amplitude"].where(ds["converged"]).max("point")
    np.testing.assert_array_equal(pk.values, ds["peak_amplitude"].values)
    assert ds["n_points"].values.tolist() == [30, 45, 20]
    assert ds["wall_time"].attrs["units"] == "s"
    # only h = 1 is excited in a linear scene: the other harmonics vanish
    ha = ds["harmonic_amplitude"].where(ds["converged"])
    assert float(ha.sel(harmonic=[0, 2, 3]).max()) == 0.0
    np.testing.assert_allclose(ha.sel(harmonic=1), ds["amplitude"].where(ds["converged"]),
                               rtol=1e-12)


def test_linear_peak_matches_closed_form(ex1):
    """preload 0: m x'' + c x' + k x = cos(w t); the amplitude peaks at
    w_n sqrt(1 - 2 z^2) with height F0 / (c w_n sqrt(1 - z^2)) (m = 1)."""
    k, c = 3.55e4, 0.3
    wn, z = np.sqrt(k), c / (2 * np.sqrt(k))
    om = np.linspace(188.0, 189.0, 4001)
    curve = linear_curve(ex1.system({"preload": 0.0}), 3, om)
    ds = to_dataset(ex1, [curve] * 3)
    pk = ds["peak_amplitude"].sel(preload=0.0, dof="x")
    assert float(pk) == pytest.approx(1 / (c * wn * np.sqrt(1 - z**2)), rel=1e-6)
    assert float(ds["peak_frequency"].sel(preload=0.0, dof="x")) == pytest.approx(
        wn * np.sqrt(1 - 2 * z**2), abs=2.5e-4)
    np.testing.assert_allclose(ds["natural_frequency_free"].values[:, 0], wn)  # every case
    np.testing.assert_allclose(ds["natural_frequency_stuck"].values[:, 0], np.sqrt(k + 1e4))


def test_hz_units_and_peaks_per_mode_window(ex2):
    """Example 2 without the damper (linear): the two window peaks sit at the
    paper's 19.67 and 51.50 Hz; frequencies are stored in Hz."""
    om = 2 * np.pi * np.concatenate([np.linspace(13, 67, 400), np.linspace(19.5, 19.8, 301),
                                     np.linspace(51.3, 51.7, 401)])
    om.sort()
    curve = linear_curve(ex2.system({"preload": 0.0}), 3, om)
    ds = to_dataset(ex2, [curve] * 3)
    assert ds["frequency"].attrs["units"] == "Hz"
    np.testing.assert_allclose(ds["frequency"].values[0], om / (2 * np.pi))
    f = ds["window_peak_frequency"].sel(preload=0.0, dof="x1").values
    np.testing.assert_allclose(f, [19.67, 51.50], atol=0.01)
    assert ds["peak_window_low"].values.tolist() == [13.0, 38.0]
    a = ds["window_peak_amplitude"].sel(preload=0.0).values
    assert np.all(a[0] > a[1])               # mode 1 responds more than mode 2
    assert ds["window_peak_complete"].sel(preload=0.0).values.tolist() == [True, True]
    # a branch that stops at 40 Hz spans the first window only: the second window's
    # largest amplitude is not its peak, and says so
    short = linear_curve(ex2.system({"preload": 0.0}), 3, om[om <= 2 * np.pi * 40.0])
    ds = to_dataset(ex2, [short] * 3)
    assert ds["window_peak_complete"].sel(preload=0.0).values.tolist() == [True, False]
    np.testing.assert_allclose(ds["natural_frequency_stuck"].values[0], [23.5255, 56.9745], atol=1e-3)


def test_failed_case_is_all_padding(ex1):
    curves = curves_for(ex1)
    curves[1] = None
    ds = to_dataset(ex1, curves, errors=[None, "FloatingPointError: singular", None])
    assert not ds["converged"].values[1].any()
    assert np.isnan(ds["peak_amplitude"].values[1]).all()
    assert ds["message"].values[1] == "failed: FloatingPointError: singular"
    assert ds["status"].values[1] == -1


def test_cf_attributes(ex2):
    ds = to_dataset(ex2, curves_for(ex2, folds=[200.0, 210.0]))
    for name, var in ds.variables.items():
        assert "long_name" in var.attrs, name
        if var.dtype.kind in "fiub":
            assert "units" in var.attrs, name
    for a in ("title", "study", "harmonics", "force_evaluation", "pipeline_version", "created"):
        assert a in ds.attrs
    assert ds.attrs["Conventions"] == "CF-1.10"
    assert ds.attrs["study"] == (STUDIES / "paper_example2.toml").read_text()
    assert ds.attrs["harmonics"] == 3 and ds.attrs["quick"] == 1
    np.testing.assert_allclose(ds["fold_frequency"].values[0], np.array([200.0, 210.0]) / (2 * np.pi))


# ---------------------------------------------------------------------------
# netCDF: round trip, checker, atomic write
# ---------------------------------------------------------------------------

def test_round_trip_and_checker(tmp_path, ex2):
    curves = curves_for(ex2, lengths=[50, 20, 35], folds=[150.0])
    ds = to_dataset(ex2, curves)
    path = write_netcdf(ds, tmp_path / "sub" / "ex2.nc")
    back = read_dataset(path)
    xr.testing.assert_identical(ds, back)
    assert back["converged"].dtype == bool and back["dof"].values.tolist() == ["x1", "x2"]
    enc = xr.open_dataset(path).__enter__()["harmonic_amplitude"].encoding
    assert enc.get("zlib") is True
    assert problems(path) == []
    assert [p.name for p in path.parent.iterdir()] == ["ex2.nc"]


# ---------------------------------------------------------------------------
# The contract's layout: frequency coordinate, stable flag, sectors, checker
# ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def ex3():
    return load_study(STUDIES / "paper_example3.toml", quick=True)


def test_frequency_is_a_coordinate_and_a_branch_plots_in_one_line(tmp_path, ex3):
    """Branches are multivalued in frequency: a non-index coordinate on
    (preload, point), so one line draws amplitude against frequency."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ds = read_dataset(write_netcdf(to_dataset(ex3, curves_for(ex3, lengths=[30, 45, 20])),
                                   tmp_path / "ex3.nc"))
    assert "frequency" in ds.coords and "frequency" not in ds.indexes
    assert ds["frequency"].dims == ("preload", "point")
    line, = ds.amplitude.sel(preload=10, dof="u").plot(x="frequency")
    np.testing.assert_array_equal(line.get_xdata(), ds["frequency"].sel(preload=10).values)
    np.testing.assert_array_equal(line.get_ydata(),
                                  ds["amplitude"].sel(preload=10, dof="u").values)
    plt.close("all")


def test_fold_dimension_has_a_coordinate(ex2):
    ds = to_dataset(ex2, curves_for(ex2, folds=[150.0, 160.0]))
    assert ds["fold"].values.tolist() == [0, 1] and "long_name" in ds["fold"].attrs


def test_stable_is_nan_where_stability_was_not_computed(tmp_path, ex1):
    """solver.stability = false: the solver reports True everywhere; the dataset
    says NaN (not computed), never True, and the checker accepts it."""
    from dataclasses import replace

    off = replace(ex1, solver=replace(ex1.solver, stability=False))
    ds = to_dataset(off, curves_for(off))
    assert ds["stable"].dtype == float and np.isnan(ds["stable"].values).all()
    assert ds["stable"].attrs["stability_computed"] == 0
    assert "NOT computed" in ds["stable"].attrs["long_name"]
    assert ds.attrs["stability"].startswith("not computed")
    on = to_dataset(ex1, curves_for(ex1))
    assert on["stable"].attrs["stability_computed"] == 1
    assert set(np.unique(on["stable"].values[on["converged"].values])) == {1.0}
    assert on["stable"].attrs["flag_meanings"] == "unstable stable"
    assert problems(write_netcdf(ds, tmp_path / "off.nc")) == []


def test_mistuned_disk_reports_per_sector_on_a_sector_dimension(tmp_path):
    """A mistuned disk: dof holds the sector's DOF names, sector the sector
    numbers; peaks per sector and dof; the stiffness factors per seed and sector."""
    import copy
    import tomllib

    from pipeline.study.files.documents import study_from_document
    from pipeline.study.figures.response_figures import write_figures

    path = STUDIES / "disk_mistuned.toml"
    doc = tomllib.loads(path.read_text())
    doc["output"]["dofs"] = ["x1@3", "x2@5"]
    st = study_from_document(copy.deepcopy(doc), file=str(path), name="disk_mistuned",
                            text=path.read_text(), quick=True)
    curves = curves_for(st, lengths=[30, 25])
    ds = to_dataset(st, curves)
    assert ds["dof"].values.tolist() == ["x1", "x2"] and ds["sector"].values.tolist() == [3, 5]
    assert ds["amplitude"].dims == ("mistuning_seed", "sector", "point", "dof")
    assert ds["peak_amplitude"].dims == ("mistuning_seed", "sector", "dof")
    sc = st.scene
    for k, seed in enumerate(ds["mistuning_seed"].values):
        np.testing.assert_array_equal(ds["mistuning_factor"].sel(mistuning_seed=seed),
                                      stiffness_factors(sc, {"mistuning_seed": int(seed)})[[3, 5]])
        for j in (3, 5):
            for d in ("x1", "x2"):
                row = sc.dof_index(f"{d}@{j}")
                pk = float(ds["peak_amplitude"][k].sel(sector=j, dof=d))
                assert pk == curves[k].amplitude[:, row].max()
    assert ds["mistuning_factor"].attrs["units"] == "1"
    assert problems(write_netcdf(ds, tmp_path / "mis.nc")) == []
    doc["sweep"]["mistuning_seed"] = [1]
    st1 = study_from_document(copy.deepcopy(doc), file=str(path), name="disk_mistuned")
    figs = write_figures(st1, to_dataset(st1, curves_for(st1, lengths=[30])), tmp_path / "fig")
    assert sorted(p.name for p in figs) == [
        "amplitude_x1_mistuning_seed=1.png", "amplitude_x2_mistuning_seed=1.png",
        "peak_per_sector_x1.png", "peak_per_sector_x2.png"]


def _conforming(tmp_path, ex2):
    ds = to_dataset(ex2, curves_for(ex2, lengths=[50, 20, 35], folds=[150.0]))
    assert problems(write_netcdf(ds, tmp_path / "good.nc")) == []
    return ds


def _without_units(ds):
    del ds["amplitude"].attrs["units"]
    return ds


def _stable_true_not_computed(ds):
    """The old layout: a boolean flag, True everywhere the solver did not check."""
    ds["stable"] = ds["converged"].copy()
    ds["stable"].attrs.update(long_name="stable", units="1", stability_computed=0)
    return ds


def _stable_one_not_computed(ds):
    ds["stable"].values[:] = np.where(ds["converged"].values, 1.0, np.nan)
    ds["stable"].attrs["stability_computed"] = 0
    return ds


def _stable_at_padding(ds):
    ds["stable"].values[1, 30] = 1.0           # case 1 has 20 points
    return ds


def _method_where_not_computed(ds):
    ds["stability_method"].values[1, 30] = 1   # case 1 has 20 points: padding
    return ds


def _multiplier_contradicts_stable(ds):
    ds["max_multiplier"].values[:] = np.where(ds["converged"].values, 1.2, np.nan)
    return ds


def _multiplier_where_propagated(ds):
    conv = ds["converged"].values
    ds["stability_method"].values[:] = np.where(conv, 3, -1)   # propagated ("stretch")
    ds["max_multiplier"].values[:] = np.where(conv, 0.5, np.nan)
    return ds


def _unknown_method(ds):
    ds["stability_method"].values[:] = np.where(ds["converged"].values, 5, -1)
    return ds


def _complete_without_points(ds):
    ds["converged"].values[0] = False
    ds["peak_complete"].values[0] = True
    return ds


def _incomplete_without_reason(ds):
    ds["peak_complete"].values[0] = False
    ds["message"].values[0] = ""
    return ds


def _bifurcation_without_frequency(ds):
    ds["bifurcation_type"].values[0, 0] = 2
    return ds


def _double_peak(ds):
    ds["peak_amplitude"].values *= 2
    return ds


def _without_attribute(ds):
    del ds.attrs["force_evaluation"]
    return ds


def _flag_without_units(ds):
    del ds["converged"].attrs["units"]
    return ds


BREAKS = {  # how a dataset departs from the contract -> what the checker must say
    "missing units": (_without_units,
                      "variable 'amplitude' holds numbers without a units attribute"),
    "frequency as a data variable": (lambda ds: ds.reset_coords("frequency"),
                                     "'frequency' is a data variable"),
    "True stable, not computed": (_stable_true_not_computed, "variable 'stable' is a boolean"),
    "1 stable, not computed": (_stable_one_not_computed, "stability_computed attribute is 0"),
    "stable at a padded point": (_stable_at_padding,
                                 "'stable' is 1 at a point that did not converge"),
    "method where not computed": (_method_where_not_computed,
                                  "'stability_method' is not -1 exactly where 'stable' is NaN"),
    "multiplier contradicts stable": (_multiplier_contradicts_stable,
                                      "'max_multiplier' contradicts 'stable'"),
    "multiplier where propagated": (_multiplier_where_propagated,
                                    "'max_multiplier' has a value where no method decided"),
    "unknown method": (_unknown_method, "'stability_method' holds values other than -1, 0, 1, "
                                        "2, 3 and 4"),
    "complete without points": (_complete_without_points,
                                 "'peak_complete' is 1 for a case without converged points"),
    "incomplete without a reason": (_incomplete_without_reason,
                                    "'peak_complete' is 0 where 'message' does not say"),
    "bifurcation without frequency": (_bifurcation_without_frequency,
                                      "'bifurcation_frequency' is not finite exactly where"),
    "dof label with a sector": (lambda ds: ds.assign_coords(
        dof=("dof", ["x1@0", "x1@1"], {"long_name": "dof"})), "dof label 'x1@0' encodes a sector"),
    "fold without coordinate": (lambda ds: ds.drop_vars("fold"),
                                "dimension 'fold' has no coordinate"),
    "peak not the largest amplitude": (_double_peak, "'peak_amplitude' differs"),
    "missing global attribute": (_without_attribute,
                                 "global attribute 'force_evaluation' is missing"),
    "flag without units": (_flag_without_units,
                           "variable 'converged' holds numbers without a units attribute"),
}


def test_checker_accepts_propagated_flags(tmp_path, ex2):
    """stability_method 3 (the flag propagated over a stretch between folds) with no
    multiplier of its own conforms."""
    ds = _conforming(tmp_path, ex2).copy(deep=True)
    conv = ds["converged"].values
    ds["stability_method"].values[:] = np.where(conv, 3, -1)
    ds["max_multiplier"].values[:] = np.nan
    assert problems(write_netcdf(ds, tmp_path / "prop.nc")) == []


@pytest.mark.parametrize("name", list(BREAKS))
def test_checker_reports_each_departure(tmp_path, ex2, name):
    breaker, expected = BREAKS[name]
    ds = breaker(_conforming(tmp_path, ex2).copy(deep=True))
    path = write_netcdf(ds, tmp_path / "bad.nc")
    found = problems(path)
    assert any(expected in line for line in found), found
    assert all(line.startswith(f"{path}: ") for line in found)


def test_checker_command_line(tmp_path, ex2, capsys):
    """0 and one summary line per conforming file; 1 and the problems otherwise; 2
    and one line naming the file when it is missing or not netCDF."""
    ds = _conforming(tmp_path, ex2)
    good = tmp_path / "good.nc"
    assert check_main([str(good)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 1 and out[0].startswith(f"{good}: ok: sweeps ['preload']")
    broken = ds.copy(deep=True)
    broken["frequency"].attrs.pop("units")
    bad = write_netcdf(broken, tmp_path / "bad.nc")
    assert check_main([str(good), str(bad)]) == 1
    assert capsys.readouterr().out.splitlines() == [
        f"{bad}: coordinate 'frequency' holds numbers without a units attribute"]
    text = tmp_path / "notes.nc"
    text.write_text("not netCDF")
    for path in (tmp_path / "missing.nc", text):
        assert check_main([str(path)]) == 2
        out = capsys.readouterr().out.splitlines()
        assert len(out) == 1 and out[0].startswith(f"{path}: "), out
        with pytest.raises(UnreadableDataset, match="missing.nc: no such file|notes.nc: not a"):
            problems(path)


class Boom(Exception):
    pass


@pytest.mark.parametrize("exc", [Boom, KeyboardInterrupt])
def test_atomic_write_leaves_no_partial_file(tmp_path, ex1, monkeypatch, exc):
    ds = to_dataset(ex1, curves_for(ex1))
    target = tmp_path / "ex1.nc"
    write_netcdf(ds, target)
    before = target.read_bytes()
    real = xr.Dataset.to_netcdf

    def half_then_fail(self, path, *a, **k):
        real(self, path, *a, **k)
        with open(path, "r+b") as f:          # a truncated file, as if killed mid-write
            f.truncate(100)
        raise exc("disk full")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", half_then_fail)
    with pytest.raises(exc):
        write_netcdf(ds, target)
    assert target.read_bytes() == before      # the old complete file is untouched
    with pytest.raises(exc):
        write_netcdf(ds, tmp_path / "new.nc")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ex1.nc"]   # no temp, no partial


# ---------------------------------------------------------------------------
# Study runner plumbing and figures
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("workers", [1, 2])
def test_run_study_writes_dataset_and_figures(tmp_path, ex2, workers):
    res = run_study(ex2, tmp_path, workers=workers, solver=linear_reference_solver, progress=False)
    assert res.ok and res.path == tmp_path / "paper_example2.nc"
    assert sorted(p.name for p in res.figures) == ["amplitude_x1.png", "amplitude_x2.png",
                                                   "optimum_preload.png"]
    assert all(p.parent == tmp_path / "paper_example2" and p.stat().st_size > 10_000
               for p in res.figures)
    back = read_dataset(res.path)
    assert int(back["n_points"].sum()) == 3 * 40
    assert problems(res.path) == []


def test_a_failing_case_is_kept_and_reported(tmp_path, ex1, caplog):
    res = run_study(ex1, tmp_path, solver=failing_solver, progress=False, figures=False)
    assert res.failures == 1 and not res.ok and res.path.exists()
    ds = read_dataset(res.path)
    assert ds["message"].sel(preload=2.0).item().startswith("failed: FloatingPointError")
    assert ds["converged"].sel(preload=0.0).all()


def test_nothing_converged_writes_nothing(tmp_path, ex1):
    def never(system, H, w0, w1, **kw):
        c = linear_reference_solver(system, H, w0, w1)
        return ResponseCurve(**{**vars(c), "converged": np.zeros(c.n_points, bool)})

    res = run_study(ex1, tmp_path / "out", solver=never, progress=False)
    assert res.path is None and not (tmp_path / "out").exists()


def test_figure_marks_folds_and_dashes_unstable_parts(tmp_path):
    from pipeline.study.figures.plots import fold_indices, true_runs, response_curves_figure

    s = np.linspace(0, 1, 61)                 # an S-shaped (folded) branch
    f = s + 0.25 * np.sin(2 * np.pi * s)
    a = 1 + s
    stable = ~((s > 0.36) & (s < 0.64))
    # df/ds = 0 where cos(2 pi s) = -2/pi: s = 0.360, 0.640 (points 21.6, 38.4)
    assert fold_indices(f).tolist() == [22, 38]
    assert true_runs(stable) == [(0, 22), (39, 61)]
    p = response_curves_figure(tmp_path / "fig.png", [("n0 = 10 N", f, a, stable, np.ones(61, bool))],
                               title="folded")
    assert p.exists() and p.stat().st_size > 5_000


# ---------------------------------------------------------------------------
# Figures of a sweep over two axes (the paper studies' key numbers, quick: see
# test_shipped_studies.py)
# ---------------------------------------------------------------------------

def test_two_axis_grid_gives_one_figure_per_other_axis_value(tmp_path):
    import copy
    import tomllib

    from pipeline.study.files.documents import study_from_document

    doc = tomllib.loads((STUDIES / "paper_example3.toml").read_text())
    doc = copy.deepcopy(doc)
    doc["sweep"] = {"mu": [0.2, 0.4], "preload": [-100.0, 10.0],
                    "frequency": {"start": 0.5, "stop": 1.6, "unit": "rad/s"}}
    study = study_from_document(doc, file="grid.toml", name="grid")
    ds = to_dataset(study, curves_for(study))
    assert ds["amplitude"].dims == ("mu", "preload", "point", "dof")
    paths = write_figures(study, ds, tmp_path / "grid")
    assert sorted(p.name for p in paths) == ["amplitude_u_mu=0.2.png", "amplitude_u_mu=0.4.png",
                                             "amplitude_v_mu=0.2.png", "amplitude_v_mu=0.4.png"]
    back = read_dataset(write_netcdf(ds, tmp_path / "grid.nc"))
    xr.testing.assert_identical(ds, back)


def test_a_branch_followed_beyond_the_range_keeps_the_ranges_peak(tmp_path, ex1):
    """A curve with points beyond the study's 150-250 rad/s (a branch followed out of
    its window, `solve.response.window`), the largest amplitude at one of them (set
    here 10x the rest): `peak_amplitude` is the largest over the points inside the
    range (by hand), the global attribute `frequency_range` says which, and the
    contract checker accepts it; without that attribute it reads every point and
    refuses the peak."""
    curves = curves_for(ex1, lengths=[40, 40, 40])
    c = curves[1]
    om = np.linspace(150.0, 270.0, c.n_points)   # the last 7 points beyond 250 rad/s
    amp = c.amplitude.copy()
    amp[-1] = 10 * amp.max()
    curves[1] = ResponseCurve(**{**vars(c), "omega": om, "parameter": om, "amplitude": amp,
                                 "info": {**c.info, "window": (150.0, 250.0)}})
    ds = to_dataset(ex1, curves)
    inside = om <= 250.0
    k = int(np.argmax(np.where(inside, amp[:, 0], -np.inf)))
    assert float(ds["peak_amplitude"].values[1, 0]) == amp[k, 0] < amp[-1, 0]
    assert float(ds["peak_frequency"].values[1, 0]) == om[k]
    assert ds.attrs["frequency_range"].tolist() == [150.0, 250.0]
    assert problems(write_netcdf(ds, tmp_path / "beyond.nc")) == []
    old = ds.copy()
    del old.attrs["frequency_range"]
    assert any("'peak_amplitude' differs" in p
               for p in problems(write_netcdf(old, tmp_path / "old.nc")))
