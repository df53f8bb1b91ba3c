"""Running studies: serial = process pool = Dask, resume after a kill, output errors
(output directory not writable, disk full, an existing dataset from an older version).
"""
from __future__ import annotations

import os
import pickle
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pipeline.dataset import read_dataset
from pipeline.scene import parse_study
from pipeline.study import checkpoint_dir, default_solver, run_study

ROOT = Path(__file__).resolve().parents[1]

# Example 1 with six preloads, H = 3, no stability: ~0.3-1 s a case
STUDY = (ROOT / "studies" / "paper_example1.toml").read_text()
STUDY = STUDY[:STUDY.index("[output.optimum_preload]")]
STUDY = STUDY.replace("preload = [0.0, 0.5, 1.0, 2.0, 5.0, 10.0, 1000.0]",
                      "preload = [0.5, 1.0, 2.0, 3.0, 5.0, 10.0]")
STUDY = STUDY.replace("harmonics = 7", "harmonics = 3").replace("stability = true",
                                                                "stability = false")
N_CASES = 6


def comparable(ds: xr.Dataset) -> xr.Dataset:
    """The dataset without what is meant to differ between runs (timing, creation)."""
    ds = ds.drop_vars([v for v in ("wall_time",) if v in ds])
    ds.attrs = {k: v for k, v in ds.attrs.items() if k != "created"}
    return ds


@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("study") / "six_preloads.toml"
    p.write_text(STUDY)
    return p


@pytest.fixture(scope="module")
def serial(study_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    study = parse_study(STUDY, file=str(study_file), name="six_preloads")
    res = run_study(study, out, workers=1, figures=False, progress=False)
    assert res.ok and res.computed == N_CASES and res.reused == 0
    assert not list(out.glob(".six_preloads.*.cases"))  # checkpoints removed once written
    return read_dataset(res.path)


def test_process_pool_equals_serial(serial, study_file, tmp_path):
    study = parse_study(STUDY, file=str(study_file), name="six_preloads")
    res = run_study(study, tmp_path, workers=2, figures=False, progress=False)
    assert res.ok
    xr.testing.assert_identical(comparable(read_dataset(res.path)), comparable(serial))


def test_dask_local_cluster_equals_serial(serial, study_file, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    study = parse_study(STUDY, file=str(study_file), name="six_preloads")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        res = run_study(study, tmp_path, scheduler=cluster.scheduler_address,
                        figures=False, progress=False)
    assert res.ok
    xr.testing.assert_identical(comparable(read_dataset(res.path)), comparable(serial))


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT], ids=["SIGKILL", "SIGINT"])
def test_interrupted_study_resumes_without_recomputing(serial, study_file, tmp_path, sig):
    out = tmp_path / "out"
    final = out / "six_preloads.nc"
    cmd = [sys.executable, "-m", "pipeline", "run", str(study_file), "--out", str(out),
           "--workers", "1", "--no-figures"]
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    cdirs = lambda: list(out.glob(".six_preloads.*.cases"))  # noqa: E731
    t_end = time.time() + 120
    while time.time() < t_end and proc.poll() is None:
        if cdirs() and list(cdirs()[0].glob("case-*.pkl")):
            break
        assert not final.exists()
        time.sleep(0.02)
    time.sleep(random.Random(int(sig)).uniform(0.0, 0.6))   # somewhere in a later case
    assert proc.poll() is None, "the study finished before it could be interrupted"
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == (130 if sig == signal.SIGINT else -signal.SIGKILL)
    if sig == signal.SIGINT:
        assert b"rerun the same command to resume" in err and b"Traceback" not in err
    assert not final.exists()                       # never a partial dataset
    assert not list(out.glob("*.nc")) and not list(out.glob("*.nc.*"))
    files = sorted(cdirs()[0].glob("case-*.pkl"))
    kept = len(files)
    assert 1 <= kept < N_CASES, "the signal must fall between the first and the last case"
    assert not list(cdirs()[0].glob(".case-*.tmp")) or sig == signal.SIGKILL
    for f in files:  # each kept case is complete and equals the uninterrupted run's
        rec = pickle.loads(f.read_bytes())
        k = int(f.stem.split("-")[1])
        assert rec["case"] == {"preload": float(serial["preload"][k])}
        np.testing.assert_array_equal(rec["curve"].peak(0)[0],
                                      serial["peak_amplitude"].isel(preload=k, dof=0).values)

    study = parse_study(STUDY, file=str(study_file), name="six_preloads")
    res = run_study(study, out, workers=1, figures=False, progress=False)
    assert res.ok and res.reused == kept and res.computed == N_CASES - kept
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
        cd = list(out.glob(".six_preloads.*.cases"))
        if cd and list(cd[0].glob("case-*.pkl")):
            break
        time.sleep(0.02)
    kids = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
    assert proc.poll() is None and kids, "no running worker to kill"
    os.kill(int(kids[-1]), signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    err = err.decode()
    assert proc.returncode == 1 and "Traceback" not in err
    assert "a worker process died" in err and "rerun the same command to resume" in err
    assert not (out / "six_preloads.nc").exists()
    kept = len(list(next(out.glob(".six_preloads.*.cases")).glob("case-*.pkl")))
    study = parse_study(STUDY, file=str(study_file), name="six_preloads")
    res = run_study(study, out, workers=2, figures=False, progress=False)
    assert res.ok and res.reused == kept and res.computed == N_CASES - kept
    xr.testing.assert_identical(comparable(read_dataset(res.path)), comparable(serial))


def test_changed_study_does_not_reuse_old_cases(study_file, tmp_path):
    a = parse_study(STUDY, file=str(study_file), name="six_preloads")
    b = parse_study(STUDY.replace("mu = 0.5", "mu = 0.4"), file=str(study_file), name="six_preloads")
    solver = default_solver(a)
    assert checkpoint_dir(a, tmp_path, solver) != checkpoint_dir(b, tmp_path, solver)
    assert checkpoint_dir(a, tmp_path, solver) == checkpoint_dir(
        parse_study(STUDY, file=str(study_file), name="six_preloads"), tmp_path, solver)


# ---------------------------------------------------------------------------
# Output problems: clear messages, nothing corrupted or lost
# ---------------------------------------------------------------------------

def run_cli(*args):
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "pipeline", "run", *map(str, args)],
                          capture_output=True, text=True, env=env, timeout=300)


@pytest.mark.parametrize("where", ["/proc/pipeline-out", "file"], ids=["read-only-fs", "a-file"])
def test_unwritable_output_directory_fails_before_computing(study_file, tmp_path, where):
    out = Path(where) if where.startswith("/") else tmp_path / "taken"
    if where == "file":
        out.write_text("not a directory")
    t0 = time.perf_counter()
    r = run_cli(study_file, "--out", out, "--workers", "1")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and f"{study_file}: --out: " in lines[0], r.stderr
    assert time.perf_counter() - t0 < 30   # refused up front, not after the cases


def test_disk_full_keeps_the_old_dataset_and_the_finished_cases(serial, study_file, tmp_path,
                                                                monkeypatch):
    import pipeline.dataset as dsmod

    study = parse_study(STUDY, file=str(study_file), name="six_preloads")
    target = tmp_path / "six_preloads.nc"
    serial.to_netcdf(target)             # a previous result of the same version
    before = target.read_bytes()

    def full_disk(self, path, *a, **k):
        Path(path).write_bytes(b"\0" * 1000)   # something half-written, then ENOSPC
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full_disk)
    with pytest.raises(OSError, match="No space left"):
        run_study(study, tmp_path, workers=1, figures=False, progress=False)
    assert target.read_bytes() == before                     # the old result intact
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    cdir = checkpoint_dir(study, tmp_path, default_solver(study))
    assert len(list(cdir.glob("case-*.pkl"))) == N_CASES     # nothing computed is lost
    monkeypatch.undo()
    res = run_study(study, tmp_path, workers=1, figures=False, progress=False)
    assert res.ok and res.reused == N_CASES and res.computed == 0
    assert dsmod.read_dataset(target).attrs["study_name"] == "six_preloads"


def test_dataset_of_an_older_version_is_kept_not_overwritten(serial, study_file, tmp_path):
    old = serial.copy()
    old.attrs["pipeline_version"] = "0.0.1"
    target = tmp_path / "six_preloads.nc"
    old.to_netcdf(target)
    garbage = tmp_path / "six_preloads.v0.0.1.nc"   # a backup name already taken
    garbage.write_bytes(b"keep me")
    r = run_cli(study_file, "--out", tmp_path, "--workers", "1", "--no-figures")
    assert r.returncode == 0, r.stderr
    assert "written by pipeline 0.0.1; kept it as six_preloads.v0.0.1.2.nc" in r.stderr
    kept = read_dataset(tmp_path / "six_preloads.v0.0.1.2.nc")
    assert kept.attrs["pipeline_version"] == "0.0.1"
    assert garbage.read_bytes() == b"keep me"
    new = read_dataset(target)
    assert new.attrs["pipeline_version"] != "0.0.1"
    np.testing.assert_array_equal(new["peak_amplitude"], serial["peak_amplitude"])


def test_unreachable_scheduler_is_one_line_exit_2(study_file, tmp_path, monkeypatch, capsys):
    import argparse
    import socket

    import pipeline.study as study_mod

    pytest.importorskip("dask.distributed")
    with socket.socket() as sock:           # a local port nobody listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    monkeypatch.setattr(study_mod, "SCHEDULER_TIMEOUT", "2s")
    args = argparse.Namespace(study=str(study_file), out=str(tmp_path / "out"), workers=1,
                              scheduler=f"tcp://127.0.0.1:{port}", quick=False, figures=False)
    assert study_mod.cmd_run(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        f"error: {study_file}: --scheduler: cannot reach the Dask scheduler at tcp://127.0.0.1:{port}")
    assert not list((tmp_path / "out").glob("*.nc"))
