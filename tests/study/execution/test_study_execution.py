"""Running studies: serial = process pool = Dask, resume after a kill, output errors
(output directory not writable, disk full, an existing dataset from an older version).
"""
from __future__ import annotations

import os
import re
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pipeline.study.execution import checkpoint
from pipeline.study.datasets.dataset import read_dataset
from pipeline.study.files.documents import parse_study
from pipeline.study.execution.checkpoint import checkpoint_dir
from pipeline.study.execution.run import run_study
from pipeline.study.execution.cases import default_solver
from helpers import example1_study

ROOT = Path(__file__).resolve().parents[3]

# Example 1 with four preloads, H = 7
STUDY = (ROOT / "studies" / "paper_example1.toml").read_text()
STUDY = STUDY[:STUDY.index("[output.optimum_preload]")]
STUDY = STUDY.replace("preload = [0.0, 0.5, 1.0, 2.0, 5.0, 10.0, 1000.0]",
                      "preload = [2.0, 3.0, 5.0, 10.0]")
# STUDY: cases of one to a few seconds each (stability checked by Floquet where in doubt),
# so that a run can be interrupted, or a worker killed, while its workers are busy
# FAST: Hill's stability, a fraction of a second a case, for the runs nobody interrupts
FAST = STUDY.replace("stability = true", 'stability = "hill"')
STUDY = STUDY.replace("stability = true", 'stability = "monodromy+check"')
assert 'stability = "monodromy+check"' in STUDY and 'stability = "hill"' in FAST
N_CASES = 4


def comparable(ds: xr.Dataset) -> xr.Dataset:
    """The dataset without what is meant to differ between runs (timing, creation)."""
    ds = ds.drop_vars([v for v in ("wall_time",) if v in ds])
    ds.attrs = {k: v for k, v in ds.attrs.items() if k != "created"}
    return ds


@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("study") / "four_preloads.toml"
    p.write_text(STUDY)
    return p


@pytest.fixture(scope="module")
def fast_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("fast") / "four_preloads.toml"
    p.write_text(FAST)
    return p


def _serial(text, file, out):
    study = parse_study(text, file=str(file), name="four_preloads")
    res = run_study(study, out, workers=1, figures=False, progress=False)
    assert res.ok and res.computed == N_CASES and res.reused == 0
    assert not list(out.glob(".four_preloads.*.cases"))  # checkpoints removed once written
    return read_dataset(res.path)


@pytest.fixture(scope="module")
def serial(study_file, tmp_path_factory):
    return _serial(STUDY, study_file, tmp_path_factory.mktemp("serial"))


@pytest.fixture(scope="module")
def fast_serial(fast_file, tmp_path_factory):
    return _serial(FAST, fast_file, tmp_path_factory.mktemp("fast_serial"))


def test_process_pool_equals_serial(fast_serial, fast_file, tmp_path):
    study = parse_study(FAST, file=str(fast_file), name="four_preloads")
    res = run_study(study, tmp_path, workers=2, figures=False, progress=False)
    assert res.ok
    xr.testing.assert_identical(comparable(read_dataset(res.path)), comparable(fast_serial))


def test_dask_local_cluster_equals_serial(fast_serial, fast_file, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    study = parse_study(FAST, file=str(fast_file), name="four_preloads")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        res = run_study(study, tmp_path, scheduler=cluster.scheduler_address,
                        figures=False, progress=False)
    assert res.ok
    xr.testing.assert_identical(comparable(read_dataset(res.path)), comparable(fast_serial))


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT], ids=["SIGKILL", "SIGINT"])
def test_interrupted_study_resumes_without_recomputing(serial, study_file, tmp_path, sig):
    out = tmp_path / "out"
    final = out / "four_preloads.nc"
    cmd = [sys.executable, "-m", "pipeline", "run", str(study_file), "--out", str(out),
           "--workers", "1", "--no-figures"]
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    cdirs = lambda: list(out.glob(".four_preloads.*.cases"))  # noqa: E731
    t_end = time.time() + 120
    while time.time() < t_end and proc.poll() is None:
        if cdirs() and list(cdirs()[0].glob("case-*.nc")):
            break
        assert not final.exists()
        time.sleep(0.02)
    time.sleep(random.Random(int(sig)).uniform(0.0, 0.6))   # somewhere in a later case
    assert proc.poll() is None, "the study finished before it could be interrupted"
    n_before = len(list(cdirs()[0].glob("case-*.nc")))      # finished when the signal left
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == (130 if sig == signal.SIGINT else -signal.SIGKILL)
    if sig == signal.SIGINT:
        assert b"rerun the same command to resume" in err and b"Traceback" not in err
    assert not final.exists()                       # never a partial dataset
    assert not list(out.glob("*.nc")) and not list(out.glob("*.nc.*"))
    files = sorted(cdirs()[0].glob("case-*.nc"))
    kept = len(files)
    # every case finished before the signal is kept; at most the one just ending joins them
    assert n_before >= 1 and n_before <= kept <= n_before + 1, (n_before, kept)
    assert kept < N_CASES
    assert not list(cdirs()[0].glob(".case-*.tmp")) or sig == signal.SIGKILL
    for f in files:  # each kept case is complete and equals the uninterrupted run's
        case, curve = checkpoint.read(f)
        k = int(f.stem.split("-")[1])
        assert case == {"preload": float(serial["preload"][k])}
        np.testing.assert_array_equal(curve.peak(0)[0],
                                      serial["peak_amplitude"].isel(preload=k, dof=0).values)

    study = parse_study(STUDY, file=str(study_file), name="four_preloads")
    res = run_study(study, out, workers=1, figures=False, progress=False)
    assert res.ok and res.reused == kept and res.computed == N_CASES - kept >= 1
    xr.testing.assert_identical(comparable(read_dataset(final)), comparable(serial))
    assert not cdirs()


def test_killed_pool_worker_loses_nothing(serial, study_file, tmp_path):
    """A worker of the process pool is killed (OOM killer, operator): the run stops
    with one error line, the finished cases stay, and the rerun completes them."""
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "pipeline", "run", str(study_file), "--out", str(out),
           "--workers", "2", "--no-figures"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=dict(os.environ, MPLBACKEND="Agg"))
    t_end = time.time() + 120
    while time.time() < t_end and proc.poll() is None:
        cd = list(out.glob(".four_preloads.*.cases"))
        if cd and list(cd[0].glob("case-*.nc")):
            break
        time.sleep(0.02)
    kids = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
    assert proc.poll() is None and kids, "no running worker to kill"
    os.kill(int(kids[-1]), signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    err = err.decode()
    assert proc.returncode == 1 and "Traceback" not in err
    assert "a worker process died" in err and "rerun the same command to resume" in err
    assert not (out / "four_preloads.nc").exists()
    kept = len(list(next(out.glob(".four_preloads.*.cases")).glob("case-*.nc")))
    study = parse_study(STUDY, file=str(study_file), name="four_preloads")
    res = run_study(study, out, workers=2, figures=False, progress=False)
    assert res.ok and res.reused == kept and res.computed == N_CASES - kept
    xr.testing.assert_identical(comparable(read_dataset(res.path)), comparable(serial))


def test_changed_study_does_not_reuse_old_cases(study_file, tmp_path):
    a = parse_study(STUDY, file=str(study_file), name="four_preloads")
    b = parse_study(STUDY.replace("mu = 0.5", "mu = 0.4"), file=str(study_file), name="four_preloads")
    solver = default_solver(a)
    assert checkpoint_dir(a, tmp_path, solver) != checkpoint_dir(b, tmp_path, solver)
    assert checkpoint_dir(a, tmp_path, solver) == checkpoint_dir(
        parse_study(STUDY, file=str(study_file), name="four_preloads"), tmp_path, solver)


# ---------------------------------------------------------------------------
# Output problems: clear messages, nothing corrupted or lost
# ---------------------------------------------------------------------------

def run_cli(*args):
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "pipeline", "run", *map(str, args)],
                          capture_output=True, text=True, env=env, timeout=300)


@pytest.mark.parametrize("where", ["/proc/pipeline-out", "file", "figures", "link",
                                   "dataset", "figure"],
                         ids=["read-only-fs", "a-file", "figures-folder-a-file",
                              "figures-folder-a-broken-link", "dataset-a-folder",
                              "a-figure-a-folder"])
def test_unwritable_output_directory_fails_before_computing(study_file, tmp_path, where):
    """--out itself, or the study's folder out/<name>/ (a file, a broken link),
    dataset out/<name>.nc (a folder) or a figure's file in out/<name>/ (a folder)
    taken by the wrong kind of entry: refused in one line, nothing run nor written."""
    out = Path(where) if where.startswith("/") else tmp_path / "taken"
    if where == "file":
        out.write_text("not a directory")
    elif where in ("figures", "link"):
        out.mkdir()
        if where == "figures":
            (out / "four_preloads").write_text("not the figures' folder")
        else:
            (out / "four_preloads").symlink_to(tmp_path / "nowhere" / "x")
    elif where == "dataset":
        (out / "four_preloads.nc").mkdir(parents=True)
    elif where == "figure":
        (out / "four_preloads" / "amplitude_x.png").mkdir(parents=True)
    r = run_cli(study_file, "--out", out, "--workers", "1")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and f"{study_file}: --out: " in lines[0], r.stderr
    assert " done, case " not in r.stderr, r.stderr   # refused up front, before any case
    if where != "/proc/pipeline-out" and where != "file":   # left as it was, nothing added
        assert sorted(p.name for p in out.iterdir()) == ["four_preloads.nc" if where == "dataset"
                                                         else "four_preloads"]
        assert (out / "four_preloads.nc").is_dir() == (where == "dataset")
    if where == "figure":
        assert "four_preloads/amplitude_x.png exists and is a folder" in lines[0]
        assert [p.name for p in (out / "four_preloads").iterdir()] == ["amplitude_x.png"]


def test_a_modes_study_without_figures_still_needs_its_folder(tmp_path):
    """`--no-figures` does not free out/<name>/: a modes study writes its mode shapes
    there anyway, so a file in its place is refused before computing."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "blade_modes").write_text("not a folder")
    r = run_cli(ROOT / "studies" / "blade_modes.toml", "--quick", "--no-figures", "--out", out)
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("error:")]
    assert r.returncode == 2 and len(lines) == 1 and "--out: " in lines[0], r.stderr
    assert sorted(p.name for p in out.iterdir()) == ["blade_modes"]


def test_disk_full_keeps_the_old_dataset_and_the_finished_cases(fast_serial, fast_file,
                                                                tmp_path, monkeypatch):
    import pipeline.study.datasets.dataset as dsmod

    study = parse_study(FAST, file=str(fast_file), name="four_preloads")
    target = tmp_path / "four_preloads.nc"
    fast_serial.to_netcdf(target)             # a previous result of the same version
    before = target.read_bytes()

    real_to_netcdf = xr.Dataset.to_netcdf

    def full_disk(self, path, *a, **k):
        if ".cases" in str(path):   # the case checkpoints fit; the final dataset does not
            return real_to_netcdf(self, path, *a, **k)
        Path(path).write_bytes(b"\0" * 1000)   # something half-written, then ENOSPC
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full_disk)
    with pytest.raises(OSError, match="No space left"):
        run_study(study, tmp_path, workers=1, figures=False, progress=False)
    assert target.read_bytes() == before                     # the old result intact
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    cdir = checkpoint_dir(study, tmp_path, default_solver(study))
    assert len(list(cdir.glob("case-*.nc"))) == N_CASES     # nothing computed is lost
    monkeypatch.undo()
    res = run_study(study, tmp_path, workers=1, figures=False, progress=False)
    assert res.ok and res.reused == N_CASES and res.computed == 0
    assert dsmod.read_dataset(target).attrs["study_name"] == "four_preloads"


def test_dataset_of_an_older_version_is_kept_not_overwritten(fast_serial, fast_file, tmp_path):
    old = fast_serial.copy()
    old.attrs["pipeline_version"] = "0.0.1"
    target = tmp_path / "four_preloads.nc"
    old.to_netcdf(target)
    garbage = tmp_path / "four_preloads.v0.0.1.nc"   # a backup name already taken
    garbage.write_bytes(b"keep me")
    r = run_cli(fast_file, "--out", tmp_path, "--workers", "1", "--no-figures")
    assert r.returncode == 0, r.stderr
    assert "written by pipeline 0.0.1; kept it as four_preloads.v0.0.1.2.nc" in r.stderr
    # the progress line whose absence shows a refusal before any case (above)
    assert r.stderr.count(" done, case ") == N_CASES, r.stderr
    kept = read_dataset(tmp_path / "four_preloads.v0.0.1.2.nc")
    assert kept.attrs["pipeline_version"] == "0.0.1"
    assert garbage.read_bytes() == b"keep me"
    new = read_dataset(target)
    assert new.attrs["pipeline_version"] != "0.0.1"
    np.testing.assert_array_equal(new["peak_amplitude"], fast_serial["peak_amplitude"])


def test_unreachable_scheduler_is_one_line_exit_2(study_file, tmp_path, monkeypatch, capsys):
    import argparse
    import socket

    import pipeline.study.execution.cases as cases_mod
    import pipeline.study.execution.run as study_mod

    pytest.importorskip("dask.distributed")
    with socket.socket() as sock:           # a local port nobody listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    monkeypatch.setattr(cases_mod, "SCHEDULER_TIMEOUT", "2s")
    args = argparse.Namespace(study=str(study_file), out=str(tmp_path / "out"), workers=1,
                              scheduler=f"tcp://127.0.0.1:{port}", quick=False, figures=False)
    assert study_mod.cmd_run(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        f"error: {study_file}: --scheduler: cannot reach the Dask scheduler at tcp://127.0.0.1:{port}")
    assert not list((tmp_path / "out").glob("*.nc"))


# ---------------------------------------------------------------------------
# Checkpoints are data (netCDF), never code
# ---------------------------------------------------------------------------

def _curve_of(serial_study):
    from pipeline.solve.response.response import frequency_response
    return frequency_response(serial_study.system({"preload": 2.0}), 3, 150.0, 250.0,
                              stability=False, tol_rel=1e-9)


def test_checkpoint_round_trip_keeps_every_field(study_file, tmp_path):
    import dataclasses

    study = parse_study(STUDY, file=str(study_file), name="four_preloads")
    curve = _curve_of(study)
    curve = dataclasses.replace(curve, info={**curve.info, "note": "é", "big": float("inf")})
    path = checkpoint.write(tmp_path / "case-00003.nc", curve, {"preload": 2.0})
    case, back = checkpoint.read(path)
    assert case == {"preload": 2.0} and type(back) is type(curve)
    for f in dataclasses.fields(curve):
        a, b = getattr(curve, f.name), getattr(back, f.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape, f.name
            np.testing.assert_array_equal(a, b, err_msg=f.name)
        else:
            assert type(a) is type(b) and a == b, f.name
    assert not list(tmp_path.glob("*.tmp"))


class _Payload:
    """Would create `marker` if a checkpoint were ever unpickled."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (Path.touch, (Path(self.marker),))


def test_foreign_or_corrupt_checkpoints_are_recomputed_not_executed(fast_serial, fast_file,
                                                                    tmp_path):
    study = parse_study(FAST, file=str(fast_file), name="four_preloads")
    cdir = checkpoint_dir(study, tmp_path, default_solver(study))
    cdir.mkdir(parents=True)
    marker = tmp_path / "executed"
    payload = pickle_bytes = __import__("pickle").dumps({"case": {"preload": 0.5},
                                                         "curve": _Payload(marker)})
    (cdir / "case-00000.nc").write_bytes(payload)          # a pickle under the new name
    (cdir / "case-00001.pkl").write_bytes(pickle_bytes)    # a checkpoint of the old format
    (cdir / "case-00002.nc").write_bytes(b"CDF\x01 truncated")
    good = _curve_of(study)
    checkpoint.write(cdir / "case-00003.nc", good, {"preload": 999.0})   # another case's data
    xr.Dataset({"frequency": ("p", [1.0])}).to_netcdf(cdir / "case-00004.nc")  # foreign netCDF
    res = run_study(study, tmp_path, workers=1, figures=False, progress=False)
    assert not marker.exists()
    assert res.ok and res.reused == 0 and res.computed == N_CASES
    xr.testing.assert_identical(comparable(read_dataset(res.path)), comparable(fast_serial))


# ---------------------------------------------------------------------------
# SIGINT at any stage, also when the process started with SIGINT ignored
# ---------------------------------------------------------------------------

def test_sigint_during_the_optimum_search_with_sigint_ignored_at_start(tmp_path):
    """`cmd &` in a script starts the run with SIGINT ignored: an interrupt after the
    cases (in the optimum search) still stops it with 130, the case kept, no dataset."""
    text = (ROOT / "studies" / "paper_example1.toml").read_text()
    text = text.replace("preload = [0.0, 0.5, 1.0, 2.0, 5.0, 10.0, 1000.0]", "preload = [2.0]")
    text = text.replace("stability = true", "stability = false")
    f = tmp_path / "one_case.toml"
    f.write_text(text)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "run", str(f), "--out", str(out),
                             "--workers", "1", "--no-figures"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=dict(os.environ, MPLBACKEND="Agg"),
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    t_end = time.time() + 120
    while time.time() < t_end and proc.poll() is None:
        if list(out.glob(".one_case.*.cases/case-*.nc")):
            break
        time.sleep(0.02)
    time.sleep(0.05)                    # the optimum search (about 0.5 s) is running
    assert proc.poll() is None, "the run ended before the optimum search was interrupted"
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    err = err.decode()
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "1 finished case(s) are kept in" in err
    assert not list(out.glob("*.nc")) and not list(out.glob(".*.tmp"))
    assert len(list(out.glob(".one_case.*.cases/case-*.nc"))) == 1


def test_interrupt_before_any_case_does_not_promise_kept_cases(study_file, tmp_path,
                                                               monkeypatch, capsys):
    import argparse
    import signal as sg

    import pipeline.study.execution.response_study as response_mod
    import pipeline.study.execution.run as study_mod

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(response_mod, "execute_cases", interrupted)
    before = sg.getsignal(sg.SIGINT)
    args = argparse.Namespace(study=str(study_file), out=str(tmp_path / "out"), workers=1,
                              scheduler=None, quick=False, figures=False)
    assert study_mod.cmd_run(args) == 130
    err = capsys.readouterr().err
    assert "kept in" not in err and "no finished case was kept" in err
    assert sg.getsignal(sg.SIGINT) is before        # the handler is restored


def _kernel_dispatcher_interrupted(*a, **k):
    """What an interrupt inside a compiled kernel's call looks like to its caller: the
    dispatcher ran Python code (unpickling its constants) when SIGINT arrived."""
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as exc:
        raise SystemError("CPUDispatcher(<function hermite_point>) returned a result "
                          "with an exception set") from exc


def test_interrupt_wrapped_by_a_compiled_kernel_exits_130(study_file, tmp_path,
                                                          monkeypatch, capsys):
    import argparse

    import pipeline.study.execution.response_study as response_mod
    import pipeline.study.execution.run as study_mod

    monkeypatch.setattr(response_mod, "execute_cases", _kernel_dispatcher_interrupted)
    args = argparse.Namespace(study=str(study_file), out=str(tmp_path / "out"), workers=1,
                              scheduler=None, quick=False, figures=False)
    assert study_mod.cmd_run(args) == 130
    err = capsys.readouterr().err
    assert err.startswith("interrupted: ") and "Traceback" not in err


def test_a_system_error_without_an_interrupt_is_not_called_one(study_file, tmp_path,
                                                               monkeypatch):
    import argparse

    import pipeline.study.execution.response_study as response_mod
    import pipeline.study.execution.run as study_mod

    def broken(*a, **k):
        raise SystemError("a real fault")

    monkeypatch.setattr(response_mod, "execute_cases", broken)
    args = argparse.Namespace(study=str(study_file), out=str(tmp_path / "out"), workers=1,
                              scheduler=None, quick=False, figures=False)
    with pytest.raises(SystemError, match="a real fault"):
        study_mod.cmd_run(args)


# ---------------------------------------------------------------------------
# What is declared is solved: no silent separation
# ---------------------------------------------------------------------------

EX3_CLOSED = (ROOT / "studies" / "paper_example3.toml").read_text()
EX3_CLOSED = EX3_CLOSED[:EX3_CLOSED.index("[quick.sweep]")]
EX3_CLOSED = EX3_CLOSED.replace('effects = ["friction", "normal_load_variation", "separation"]',
                                'effects = ["friction", "normal_load_variation"]')
EX3_CLOSED = EX3_CLOSED.replace("preload = [-100.0, -20.0, 10.0, 500.0]", "preload = [10.0, 500.0]")
EX3_CLOSED = EX3_CLOSED.replace("harmonics = 14", "harmonics = 3").replace("stability = true",
                                                                           "stability = false")


def test_separation_not_declared_fails_the_case_that_separates(tmp_path):
    """Example 3 without "separation": n0 = 500 N stays closed and is solved; n0 = 10 N
    separates near resonance, so that case fails (never stored as a solution with
    separation) and the run exits 1 saying what to declare."""
    from pipeline.study.files.declared import SeparationGuard, separating
    from pipeline.solve.harmonic_balance import hbm

    study = parse_study(EX3_CLOSED, file="ex3_closed.toml", name="ex3_closed")
    res = run_study(study, tmp_path, workers=1, figures=False, progress=False)
    assert res.failures == 1 and not res.ok
    ds = read_dataset(res.path)
    assert int(ds["converged"].sel(preload=10.0).sum()) == 0
    assert int(ds["converged"].sel(preload=500.0).sum()) > 10
    assert "separation" not in ds.attrs["effects"]
    assert "kept closed (a case that separates fails)" in ds.attrs["solution_method"]
    assert "searched for separation" not in ds.attrs["solution_method"]
    # the kept case really stays closed at every point
    from pipeline.solve.response.response import frequency_response
    sysm = study.system({"preload": 500.0})
    curve = frequency_response(sysm, 3, 0.5, 1.6, stability=False)
    SeparationGuard().check_curve(sysm, curve)
    prob = hbm.setup(sysm, 3)
    assert not any(separating(prob, q[prob.c], sysm.contact).any() for q in curve.Q)
    # and the same scene with separation declared solves n0 = 10 N with separation
    sys10 = study.system({"preload": 10.0})
    c10 = frequency_response(sys10, 3, 0.5, 1.6, stability=False)
    assert any(separating(prob, q[prob.c], sys10.contact).any() for q in c10.Q)


def test_separation_not_declared_is_one_error_line_from_the_cli(tmp_path):
    f = tmp_path / "ex3_closed.toml"
    f.write_text(EX3_CLOSED.replace("preload = [10.0, 500.0]", "preload = [10.0]"))
    r = run_cli(f, "--out", tmp_path / "out", "--workers", "1", "--no-figures")
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert re.search(r"contact 'shroud' separates at [0-9.]+ rad/s .*does not declare "
                     r"\"separation\"", r.stderr), r.stderr
    # with a case that stays closed the dataset is written, and the failed case is
    # still one error line, naming it (also where a progress bar hides the log)
    f.write_text(EX3_CLOSED)
    r = run_cli(f, "--out", tmp_path / "out2", "--workers", "1", "--no-figures")
    errors = [line for line in r.stderr.splitlines() if line.startswith("error:")]
    assert r.returncode == 1 and (tmp_path / "out2" / "ex3_closed.nc").is_file()
    assert len(errors) == 1 and errors[0].startswith(f"error: {f}: case preload = 10 N: ")
    assert "contact 'shroud' separates at" in errors[0]


# ---------------------------------------------------------------------------
# killed at any write, resumed: the dataset of the uninterrupted run
# ---------------------------------------------------------------------------

# two cases and an optimum search over [1, 10] N (grid, brackets, Brent's local trials,
# the band check of each bracket) on Example 1 at H = 1: about 2 s a run
TINY = example1_study(
    "Example 1 at H = 1 with an optimum search", preload="[2.0, 5.0]",
    solver="harmonics = 1\ntolerance = 1e-7\nstability = false\nmax_step = 0.5",
    output='dofs = ["x"]\nfigures = []',
    extra="[output.optimum_preload]\ndof = \"x\"\nbounds = [1.0, 10.0]\nrtol = 1e-2\n",
).replace("C = [[0.3]]", "C = [[3.0]]")


class Killed(BaseException):
    """The run's process ends here (nothing after it runs, as after SIGKILL)."""


class KillAtWrite:
    """The run's writes to its checkpoint folder (each finished case, each optimum-search
    evaluation) counted; at write `at` the process is killed, `before` it (the write
    interrupted: a partial temporary file left, the kept file unchanged) or just after
    it (the computing that follows is lost: a SIGKILL anywhere up to the next write
    leaves the same files)."""

    def __init__(self, monkeypatch, at=None, before=False):
        import pipeline.study.execution.cases as cases_mod
        import pipeline.study.execution.optimum_search as search_mod

        self.at, self.before, self.writes = at, before, 0
        for mod, name in ((cases_mod, "save_case"), (search_mod, "save_search")):
            monkeypatch.setattr(mod, name, self.wrap(getattr(mod, name)))

    def wrap(self, real):
        def write(cdir, *args):
            self.writes += 1
            if self.writes == self.at and self.before:
                Path(cdir).mkdir(parents=True, exist_ok=True)
                (Path(cdir) / ".optimum-search.0badf00d.tmp").write_bytes(b"\x89HDF\r\n")
                raise Killed
            out = real(cdir, *args)
            if self.writes == self.at:
                raise Killed
            return out
        return write


def tiny_run(out, monkeypatch, at=None, before=False):
    """The tiny study run into `out`, killed at write `at` (None: not killed); the
    number of writes it made."""
    study = parse_study(TINY, file="tiny.toml", name="tiny")
    with monkeypatch.context() as mp:
        kill = KillAtWrite(mp, at, before)
        try:
            res = run_study(study, out, workers=1, figures=False, progress=False)
        except Killed:
            return None, kill.writes
    assert res.ok
    return read_dataset(res.path), kill.writes


@pytest.fixture(scope="module")
def tiny_whole(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        return tiny_run(tmp_path_factory.mktemp("tiny_whole"), mp)


def untimed(ds: xr.Dataset) -> xr.Dataset:
    return comparable(ds.drop_vars([v for v in ("optimum_search_wall_time",) if v in ds]))


def resumed_equals_uninterrupted(whole, writes, at, before, out, monkeypatch):
    ds, n = tiny_run(out, monkeypatch, at, before)
    assert ds is None and n == at and not (out / "tiny.nc").exists()
    ds, _ = tiny_run(out, monkeypatch)
    xr.testing.assert_identical(untimed(ds), untimed(whole))
    assert not list(out.glob(".tiny.*.cases"))


@pytest.mark.parametrize("at, before", [(4, True), (-1, False)],
                         ids=["inside-the-grid", "after-the-last-check"])
def test_killed_at_a_write_and_resumed_equals_the_uninterrupted_run(tiny_whole, tmp_path,
                                                                    monkeypatch, at, before):
    """Killed in the search's grid (a write cut short) or after the search's last band
    evaluation (the last bracket's check: only the dataset was left to write), the
    rerun's dataset is the uninterrupted run's in every variable (wall times aside):
    the optimum, every preload the search evaluated, its peak, whether it was a grid
    node and whether it was valued over the band (a resumed search that knew the last
    check's band value from the start took it for Brent's trial at that preload)."""
    whole, writes = tiny_whole
    assert writes == 8 and int(whole["optimum_search_band"].sum()) < whole[
        "optimum_search_preload"].size           # Brent's local trials are in the search
    resumed_equals_uninterrupted(whole, writes, at % (writes + 1), before, tmp_path / "out",
                                 monkeypatch)


@pytest.mark.slow
def test_killed_at_random_writes_and_resumed_equals_the_uninterrupted_run(
        tiny_whole, tmp_path, monkeypatch):
    """Twelve seeded random moments among the run's writes (each write cut short or just
    done; every one after the second inside the optimum search): each resumed dataset is
    the uninterrupted one."""
    whole, writes = tiny_whole
    moments = random.Random(20261207).sample(
        [(at, before) for at in range(1, writes + 1) for before in (False, True)], 12)
    assert sum(at > 2 for at, _ in moments) >= 8
    for i, (at, before) in enumerate(moments):
        resumed_equals_uninterrupted(whole, writes, at, before, tmp_path / f"out{i}",
                                     monkeypatch)


# the same over the shroud interference: the quick FE disk at 8,000 rpm, one case, a
# grid of 3 interferences over [-30, -5] um (about 15 s a run)
INTERFERENCE = re.sub(
    r"\[output\.optimum_interference\]\n(.+\n)+",
    '[output.optimum_interference]\ndof = "response.y"\nbounds = [-3e-5, -5e-6]\nnodes = 3\n'
    'rtol = 0.05\n', (ROOT / "studies" / "shrouded_disk_interference.toml").read_text()
    ).replace("interference = [-2e-4, -5e-5, 1e-4]", "interference = [-2e-5]").replace(
    'figures = ["amplitude"]', "figures = []")


@pytest.mark.slow
def test_an_interference_search_killed_at_a_seeded_write_resumes(tmp_path, monkeypatch):
    """Killed at one seeded moment of its writes (a case, a search evaluation; cut short
    or just done), the interference study's rerun equals the uninterrupted run in every
    variable (wall times aside): the optimum interference [m], every interference
    evaluated, its peak and its static contact load."""
    study = parse_study(INTERFERENCE, file="tiny_interference.toml", name="tiny", quick=True)

    def run(out, at=None, before=False):
        with monkeypatch.context() as mp:
            kill = KillAtWrite(mp, at, before)
            try:
                res = run_study(study, out, workers=1, figures=False, progress=False)
            except Killed:
                return None, kill.writes
        assert res.ok
        return read_dataset(res.path), kill.writes

    whole, writes = run(tmp_path / "whole")
    assert whole["optimum_interference"].attrs["units"] == "m" and writes >= 4
    at, before = random.Random(20261207).choice(
        [(k, b) for k in range(2, writes + 1) for b in (False, True)])   # in the search
    out = tmp_path / "out"
    ds, n = run(out, at, before)
    assert ds is None and n == at and not (out / "tiny.nc").exists()
    ds, _ = run(out)
    xr.testing.assert_identical(untimed(ds), untimed(whole))


# ---------------------------------------------------------------------------
# a failing case, or a failing optimum search, loses nothing else
# ---------------------------------------------------------------------------

def cases_only(text: str) -> str:
    return text[:text.index("[output.optimum_preload]")]


@pytest.mark.parametrize("workers", [1, 2])
def test_a_case_whose_model_cannot_be_built_fails_alone(tmp_path, monkeypatch, workers):
    """The system of the 3 N case cannot be built (a singular static solve): that case
    is recorded failed with its error, the dataset holds the other two exactly as a
    study of those two alone gives them."""
    import pipeline.study.files.study_types as spec

    text = cases_only(TINY).replace("preload = [2.0, 5.0]", "preload = [2.0, 3.0, 5.0]")
    real = spec.case_system

    def singular(scene, case=None):
        if (case or {}).get("preload") == 3.0:
            raise np.linalg.LinAlgError("Singular matrix")
        return real(scene, case)

    monkeypatch.setattr(spec, "case_system", singular)
    study = parse_study(text, file="three.toml", name="three")
    res = run_study(study, tmp_path / "a", workers=workers, figures=True, progress=False)
    assert res.path is not None and not res.ok and res.failures == 1
    assert res.failed == [({"preload": 3.0}, "LinAlgError: Singular matrix")]
    ds = read_dataset(res.path)
    assert str(ds["message"].sel(preload=3.0).values) == "failed: LinAlgError: Singular matrix"
    assert int(ds["n_points"].sel(preload=3.0)) == 0
    assert np.isnan(ds["preload_pair"].sel(preload=3.0).values).all()
    two = parse_study(cases_only(TINY), file="three.toml", name="three")
    alone = read_dataset(run_study(two, tmp_path / "b", workers=1, figures=False,
                                   progress=False).path)
    both = comparable(ds.sel(preload=[2.0, 5.0]))
    for name, var in comparable(alone).data_vars.items():
        np.testing.assert_array_equal(both[name].values, var.values, err_msg=name)


def test_an_optimum_search_that_raises_keeps_the_dataset_of_the_cases(tmp_path, monkeypatch):
    """A band evaluation of the search raises: the search is reported failed (not ok,
    its error kept) and the dataset of the cases is written, equal to the same study's
    without a search."""
    import pipeline.solve.response.peak_tracking as tracking

    real = tracking.band_peak

    def raising(system, *args, **kw):
        if float(system.contact.n0[0]) == 10.0:
            raise FloatingPointError("overflow in the Jacobian")
        return real(system, *args, **kw)

    monkeypatch.setattr(tracking, "band_peak", raising)
    res = run_study(parse_study(TINY, file="tiny.toml", name="tiny"), tmp_path / "a",
                    workers=1, figures=True, progress=False)
    assert res.path is not None and not res.ok and res.failures == 0
    assert res.optimum_error == "FloatingPointError: overflow in the Jacobian"
    ds = read_dataset(res.path)
    assert "optimum_preload" not in ds and (ds["n_points"] > 0).all()
    plain = read_dataset(run_study(parse_study(cases_only(TINY), file="tiny.toml", name="tiny"),
                                   tmp_path / "b", workers=1, figures=False,
                                   progress=False).path)
    xr.testing.assert_identical(comparable(ds).drop_attrs(), comparable(plain).drop_attrs())


def test_a_long_case_logs_its_progress(monkeypatch, caplog):
    """A case without a live bar logs its points, frequency [Hz] and time at most every
    HEARTBEAT seconds; the callback never stops the continuation."""
    import logging

    from pipeline.study.execution import cases
    beat = cases.Heartbeat({"preload": 1.0})
    monkeypatch.setattr(cases, "HEARTBEAT", 0.0)
    with caplog.at_level(logging.INFO, logger="pipeline.study.execution.run"):
        assert beat(None, 2 * np.pi * 100.0) is False
        assert beat(None, 2 * np.pi * 120.0) is False
    lines = [r.getMessage() for r in caplog.records]
    assert lines[-1].startswith("case {'preload': 1.0}: 2 points, at 120 Hz")
    monkeypatch.setattr(cases, "HEARTBEAT", 1e9)
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="pipeline.study.execution.run"):
        beat(None, 1.0)
    assert not caplog.records
