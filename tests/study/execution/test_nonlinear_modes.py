"""The nonlinear modes study kind: a lumped scene run end to end through the command
line (dataset against its contract and against the solver called directly, figures),
and one clear line, exit code 2, for each mistake in `[modes]`."""
import os
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

import pipeline

from pipeline.solve.nonlinear_modes import epmc
from pipeline.solve.nonlinear_modes.backbone import continue_mode
from pipeline.study.datasets.conformance import problems
from pipeline.study.files.documents import parse_study
from pipeline.errors import UsageError
from helpers import ROOT, example1_study

# the paper's Example 1 (k = 3.55e4, ku = 1e4 N/m, mu = 0.5, m = 1 kg) as a modes study
LUMPED = example1_study(
    "Jenkins oscillator: backbone and damping", study='kind = "nonlinear_modes"',
    preload="[1.0, 2.0]", extra="""
[modes]
amplitude = [0.1, 1000.0]
force_scales = [0.5, 1.0]
""")


def test_lumped_study_runs_and_its_dataset_is_the_solvers(tmp_path):
    """`pipeline run` writes a conforming dataset and both figures; its backbone is the
    one `continue_mode` gives for the same system and range (same code path, read back
    from netCDF), starting at the stuck frequency sqrt((k + ku)/m) and ending near the
    open one sqrt(k/m); the friction energy is positive only once the element slips."""
    f = tmp_path / "jenkins_modes.toml"
    f.write_text(LUMPED)
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "pipeline", "run", str(f), "--out", str(out)],
                       capture_output=True, text=True, cwd=ROOT,
                       env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin",   # a bare environment,
                            "NUMBA_CACHE_DIR": os.environ.get("NUMBA_CACHE_DIR",
                                                               pipeline.kernel_cache_dir())})  # the compiled kernels
    assert r.returncode == 0, r.stderr
    nc = out / "jenkins_modes.nc"
    assert problems(nc) == []
    assert (out / "jenkins_modes" / "backbones.png").stat().st_size > 10_000
    assert (out / "jenkins_modes" / "synthesis_x.png").stat().st_size > 10_000
    ds = xr.open_dataset(nc)
    study = parse_study(LUMPED)
    for n0 in (1.0, 2.0):
        mp = epmc.mode_problem(study.response.system({"preload": n0}), 3)
        onset = 0.5 * n0 / 1.0e4          # mu n0 / ku at a unit modal amplitude (m = 1)
        bb = continue_mode(mp, np.log10(0.1 * onset), np.log10(1000 * onset), tol_rel=1e-9)
        one = ds.sel(preload=n0)
        ok = one["converged"].values == 1
        assert float(one["slip_onset_amplitude"]) == pytest.approx(onset, rel=1e-12)
        assert np.array_equal(one["frequency"].values[ok], bb.omega / (2 * np.pi))
        stuck, free = np.sqrt(4.55e4), np.sqrt(3.55e4)     # rad/s: k + ku, k
        assert one["frequency"].values[ok][0] == pytest.approx(stuck / (2 * np.pi), rel=1e-5)
        assert one["frequency"].values[ok][-1] == pytest.approx(free / (2 * np.pi), rel=1e-3)
        e = one["dissipated_energy"].values[ok]
        a = one["modal_amplitude"].values[ok]
        assert np.all(e[a < 0.99 * onset] == 0) and np.all(e[a > 1.01 * onset] > 0)
        assert np.isfinite(one["synthesis_peak_frequency"].values).all()


@pytest.mark.parametrize("edit, field", [
    (('[modes]', '[modes]\nnodal_diameters = [1]'), "modes.nodal_diameters"),
    (('amplitude = [0.1, 1000.0]', 'amplitude = [1000.0, 0.1]'), "modes.amplitude"),
    (('force_scales = [0.5, 1.0]', 'force_scales = [0.0]'), "modes.force_scales[0]"),
    (('[modes]', '[modes]\nharmonics = 3'), "modes"),
    (('[modes]', '[modes]\ncompare = "yes"'), "modes.compare"),
    (('preload = [1.0, 2.0]', 'preload = [1.0]\nexcitation_scale = [1.0]'),
     "sweep.excitation_scale"),
    (('effects = ["friction"]', 'effects = []'), "scene"),
])
def test_a_mistake_is_one_line_naming_the_field(edit, field):
    with pytest.raises(UsageError) as exc:
        parse_study(LUMPED.replace(*edit), file="m.toml")
    msg = str(exc.value)
    assert msg.startswith(f"m.toml: {field}") and "\n" not in msg, msg


def test_a_disk_needs_its_nodal_diameters():
    text = (ROOT / "studies" / "disk_nonlinear_modes.toml").read_text()
    with pytest.raises(UsageError, match=r"^d.toml: modes.nodal_diameters: missing"):
        parse_study(text.replace("nodal_diameters = [3, 6, 12]\n", "")
                    .replace("nodal_diameters = [3, 12]\n", ""), file="d.toml")
    with pytest.raises(UsageError, match=r"^d.toml: modes.nodal_diameters: .* 0 ... 12"):
        parse_study(text.replace("[3, 6, 12]", "[3, 13]"), file="d.toml")


def fail_at(monkeypatch, preload, how):
    """The case at `preload` [N] fails: its backbone does not start (Newton from a NaN
    linear mode: no converged first point) or its mode problem raises."""
    from pipeline.solve.nonlinear_modes import backbone
    import pipeline.study.execution.nonlinear_modes_study as nm

    def at(mp_or_system):
        system = getattr(getattr(mp_or_system, "hbm", None), "system", mp_or_system)
        return float(np.ravel(system.contact.n0)[0]) == preload

    if how == "start":
        real = backbone.linear_guess
        monkeypatch.setattr(backbone, "linear_guess",
                            lambda mp: real(mp) * (np.nan if at(mp) else 1.0))
    else:
        real = nm.mode_problem

        def raising(system, *args):
            if at(system):
                raise ValueError("singular mass matrix")
            return real(system, *args)
        monkeypatch.setattr(nm, "mode_problem", raising)


@pytest.mark.parametrize("how, why", [
    ("start", "failed: no converged point at the start log10 a = "),
    ("raises", "failed: ValueError: singular mass matrix")])
def test_a_failing_case_is_recorded_and_the_others_written(tmp_path, monkeypatch, capsys,
                                                           how, why):
    """One case of two fails (its backbone does not start, or it raises): the run writes
    the dataset and figures with the other case's backbone, from the stuck frequency
    sqrt((k + ku)/m) to near the open one sqrt(k/m), and the failed case as padding
    with status -1 and why in `message`; its slip onset mu n0 / ku where its mode was
    set up; one error line names it, exit code 1."""
    from pipeline.__main__ import main as cli

    f = tmp_path / "jenkins_modes.toml"
    f.write_text(LUMPED.replace("[modes]", "[modes]\ncompare = false"))
    fail_at(monkeypatch, 2.0, how)
    out = tmp_path / "out"
    assert cli(["run", str(f), "--out", str(out), "--workers", "1"]) == 1
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert lines == [f"error: {f}: case preload = 2 N: {why}" + lines[0].split(why)[1]]
    nc = out / "jenkins_modes.nc"
    assert problems(nc) == []
    assert (out / "jenkins_modes" / "backbones.png").stat().st_size > 10_000
    ds = xr.open_dataset(nc)
    assert ds["status"].values.tolist() == [0, -1]
    assert ds["message"].values[0] == "" and ds["message"].values[1].startswith(why)
    ok, failed = ds.sel(preload=1.0), ds.sel(preload=2.0)
    f_ok = ok["frequency"].values[ok["converged"].values == 1]
    assert f_ok.size > 10
    assert f_ok[0] == pytest.approx(np.sqrt(4.55e4) / (2 * np.pi), rel=1e-5)
    assert f_ok[-1] == pytest.approx(np.sqrt(3.55e4) / (2 * np.pi), rel=1e-3)
    assert float(ok["slip_onset_amplitude"]) == pytest.approx(0.5 * 1.0 / 1.0e4, rel=1e-12)
    assert not failed["converged"].values.any() and np.isnan(failed["frequency"].values).all()
    assert np.isnan(failed["synthesis_peak_frequency"].values).all()
    onset = float(failed["slip_onset_amplitude"])
    assert onset == pytest.approx(0.5 * 2.0 / 1.0e4, rel=1e-12) if how == "start" \
        else np.isnan(onset)


def test_a_backbone_cut_short_is_a_warning_its_points_kept(tmp_path, monkeypatch, capsys):
    """A backbone that stops before the amplitude range's end (here: said to meet an
    internal resonance) keeps its points with status 1 and why in `message`; the run
    prints a warning line naming the case (not an error: nothing failed) and exits 0."""
    from dataclasses import replace

    from pipeline.__main__ import main as cli
    import pipeline.study.execution.nonlinear_modes_study as nm

    why = "stopped at an internal 2:1 resonance (constructed)"
    monkeypatch.setattr(nm, "continue_mode", lambda *a, **k: replace(
        continue_mode(*a, **k), message=why))
    f = tmp_path / "jenkins_modes.toml"
    f.write_text(LUMPED.replace("[modes]", "[modes]\ncompare = false"))
    out = tmp_path / "out"
    assert cli(["run", str(f), "--out", str(out), "--workers", "1"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert not [ln for ln in err if ln.startswith("error:")]
    assert [ln for ln in err if why in ln] == [
        f"warning: {f}: case preload = {p:g} N: {why}" for p in (1.0, 2.0)]
    ds = xr.open_dataset(out / "jenkins_modes.nc")
    assert ds["status"].values.tolist() == [1, 1] and ds["converged"].values.any()


def test_no_case_with_a_backbone_point_writes_nothing(tmp_path, monkeypatch):
    """Every case fails: no dataset, both cases reported failed."""
    from pipeline.study.execution.run import run_study

    fail_at(monkeypatch, 1.0, "start")
    fail_at(monkeypatch, 2.0, "raises")
    study = parse_study(LUMPED.replace("[modes]", "[modes]\ncompare = false"), name="none")
    res = run_study(study, tmp_path / "out", workers=1, figures=False)
    assert res.path is None and res.dataset is None and not res.ok
    assert [c for c, _ in res.failed] == [{"preload": 1.0}, {"preload": 2.0}]
    assert not (tmp_path / "out" / "none.nc").exists()


def test_an_interrupt_in_a_case_is_no_failed_case(monkeypatch):
    """Ctrl-C inside a compiled kernel reaches the case as a SystemError caused by the
    KeyboardInterrupt: it stops the run (`pipeline.errors.interrupt_in_chain`) instead
    of being recorded as the case's failure."""
    import pipeline.study.execution.nonlinear_modes_study as nm

    def interrupted(*args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("returned a result with an exception set") from exc

    monkeypatch.setattr(nm, "mode_problem", interrupted)
    study = parse_study(LUMPED)
    with pytest.raises(SystemError):
        nm.run_case(study, {"preload": 1.0})


def test_a_comparison_that_raises_keeps_the_backbone(monkeypatch):
    """The full harmonic balance compared with a case raises: the case keeps its
    backbone (from the stuck frequency sqrt((k + ku)/m)), status 1 and the comparison's
    error in its message; the dataset has no compared curve."""
    import pipeline.study.execution.nonlinear_modes_study as nm
    from pipeline.study.datasets.nonlinear_modes_dataset import modes_dataset

    def raising(*args, **kw):
        raise FloatingPointError("overflow in the Jacobian")

    monkeypatch.setattr(nm, "default_solver", lambda resp: raising)
    study = parse_study(LUMPED.replace("preload = [1.0, 2.0]", "preload = [1.0]"), name="cmp")
    ds = modes_dataset(study, [nm.run_case(study, case) for _, case in study.cases()])
    assert ds["status"].values.tolist() == [1]
    assert str(ds["message"].values[0]) == ("the full harmonic balance failed: "
                                            "FloatingPointError: overflow in the Jacobian")
    f = ds["frequency"].values[0][ds["converged"].values[0] == 1]
    assert f.size > 10 and f[0] == pytest.approx(np.sqrt(4.55e4) / (2 * np.pi), rel=1e-5)
    assert "hbm_frequency" not in ds


class Killed(BaseException):
    """The run's process ends here (nothing after it runs, as after SIGKILL)."""


def test_a_killed_run_resumes_with_the_kept_backbones(tmp_path, monkeypatch):
    """Killed just after its first case was kept (its backbone and compared curve), the
    rerun computes only the second case and writes the uninterrupted run's dataset in
    every variable but the wall times; the folder of kept cases is then removed."""
    import pipeline.study.execution.nonlinear_modes_checkpoint as kept
    from pipeline.study.execution.run import run_study

    study = parse_study(LUMPED, name="jenkins")
    whole = run_study(study, tmp_path / "whole", figures=False)
    assert whole.ok and whole.computed == 2
    real = kept.save_kept

    def kill_after(*args):
        real(*args)
        raise Killed

    out = tmp_path / "out"
    with monkeypatch.context() as mp:
        mp.setattr(kept, "save_kept", kill_after)
        with pytest.raises(Killed):
            run_study(study, out, figures=False)
    assert not (out / "jenkins.nc").exists()
    assert len(list(out.glob(".jenkins.*.cases/case-*.nc"))) == 1
    res = run_study(study, out, figures=False)
    assert res.ok and res.reused == 1 and res.computed == 1
    a, b = (xr.open_dataset(r.path).drop_vars(["synthesis_time", "backbone_time", "hbm_time"])
            for r in (res, whole))
    a.attrs.pop("created"), b.attrs.pop("created")
    xr.testing.assert_identical(a, b)
    assert not list(out.glob(".jenkins.*.cases"))


# a 1 kg mass (x tangential, y normal) on two contacts pressing y: 30 N opens the 10 N one
TWO_CONTACTS = """
[study]
title = "two contacts, one opened by the other's preload"
kind = "nonlinear_modes"

[scene]
model = "lumped"
effects = ["friction", "normal_load_variation", "separation"]
dofs = ["x", "y"]

[scene.matrices]
M = [[1.0, 0.0], [0.0, 1.0]]
C = [[0.5, 0.0], [0.0, 0.5]]
K = [[1.0e4, 0.0], [0.0, 1.0e4]]

[[scene.contact]]
name = "a"
tangential = ["x"]
normal = ["y"]
ku = 2.0e4
kv = 1.0e5
mu = 0.3
n0 = 30.0

[[scene.contact]]
name = "b"
tangential = ["x"]
normal = ["y"]
ku = 2.0e4
kv = 1.0e5
mu = 0.3
n0 = 10.0

[[scene.excitation]]
dof = "x"
amplitude = 0.1

[sweep]
mu = [0.3]
frequency = { start = 150.0, stop = 200.0, unit = "rad/s" }

[solver]
harmonics = 3

[output]
dofs = ["x"]

[modes]
amplitude = [0.01, 3.0]
compare = false
"""


def test_the_dataset_says_the_mode_starts_from_the_unilateral_static_state(tmp_path):
    """As `test_epmc.test_the_mode_starts_from_the_unilateral_static_state`, by hand: b
    is open (10 + 1e5 y < 0 with y = -30 / 1.1e5 m), a carries s_a = 30 * 1e4 / 1.1e5 =
    2.7273 N; the linear frequency is sqrt(3e4) / (2 pi) = 27.566 Hz (a stuck; both
    stuck: 35.588 Hz) and the slip onset 0.3 s_a / 2e4 = 4.0909e-5 kg^0.5 m."""
    from pipeline.study.execution.run import run_study

    f = tmp_path / "two_contacts.toml"
    f.write_text(TWO_CONTACTS)
    ds = run_study(parse_study(TWO_CONTACTS, file=str(f), name="two_contacts"),
                   out_dir=tmp_path, figures=False).dataset.sel(mu=0.3)
    s_a = 30.0 * 1.0e4 / 1.1e5
    assert float(ds["linear_frequency"]) == pytest.approx(np.sqrt(3.0e4) / (2 * np.pi),
                                                          rel=1e-12)
    assert float(ds["slip_onset_amplitude"]) == pytest.approx(0.3 * s_a / 2.0e4, rel=1e-12)
    np.testing.assert_allclose(ds["static_normal_load_pair"].values, [s_a, 0.0], rtol=1e-12)
    assert int(ds["static_pairs_in_contact"]) == 1
    assert ds["static_normal_load_pair"].attrs["units"] == "N"
    assert "unilateral static state" in ds.attrs["starting_state"]
    ok = ds["converged"].values == 1
    assert float(ds["frequency"].values[ok][0]) == pytest.approx(np.sqrt(3.0e4) / (2 * np.pi),
                                                                 rel=1e-6)
