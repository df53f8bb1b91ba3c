"""`bench peers` runs without the peers installed: our rows with their numbers, the
peers reported as not installed; a peer that fails is a row, not an exception.
Correctness of the table's plumbing, never a timing."""
import sys

import numpy as np
import pytest

from pipeline.__main__ import main
from pipeline.bench import peers


@pytest.fixture
def no_peers(monkeypatch):
    monkeypatch.delenv("NLVIB_PATH", raising=False)
    monkeypatch.delenv("PYHARM_PYTHON", raising=False)


@pytest.mark.slow   # the whole `bench peers --quick` table, 17 s (our peak: by default, below)
def test_bench_peers_prints_our_rows_and_the_missing_peers(no_peers, capsys):
    assert main(["bench", "peers", "--quick"]) == 0
    out = capsys.readouterr().out
    assert "load average" in out
    for n in ("1", "2", "5"):
        ours = [line.split() for line in out.splitlines() if line.split()[:2] == [n, "ours"]]
        assert len(ours) == 1 and int(ours[0][2]) > 50        # points
        assert float(ours[0][4]) > 0                          # peak amplitude [m]
        aft = [line.split() for line in out.splitlines()
               if line.split()[:6] == [n, "ours,", "no", "Hill,", "AFT", "128"]]
        assert len(aft) == 1       # the same curve at pyHarm's samples: peak within 1e-3
        assert float(aft[0][8]) == pytest.approx(float(ours[0][4]), rel=1e-3)
        path = [line.split() for line in out.splitlines()
                if line.split()[:5] == [n, "ours,", "no", "dense", "output"]]
        assert len(path) == 1      # the continuation's points only: fewer, the same exact peak
        assert 20 < int(path[0][5]) < int(ours[0][2])
        assert float(path[0][7]) == pytest.approx(float(ours[0][4]), rel=1e-6)
        loop = [line.split() for line in out.splitlines()
                if line.split()[:4] == [n, "minimal", "numpy", "loop"]]
        assert len(loop) == 1      # the bare loop's largest point: the same peak to 1e-3
        assert int(loop[0][4]) > 20 and float(loop[0][5]) > 0
        assert float(loop[0][7]) == pytest.approx(float(ours[0][4]), rel=1e-3)
    for peer in ("NLvib", "pyHarm"):
        assert sum(line.split()[1:4] == [peer, "not", "installed"]
                   for line in out.splitlines()) == 3


def test_bench_peers_peak_matches_the_example1_bench():
    (r,) = [r for r in peers.table(loads=(2.0,), repeat=1) if r.tool == "ours"]
    assert r.status == "ok" and r.peak == pytest.approx(4.2456e-4, rel=1e-4)
    assert r.peak_omega == pytest.approx(193.12, abs=0.01)


def test_a_failing_peer_is_a_row():
    # this interpreter has no pyHarm: the script fails on its import
    row = peers.external(2.0, "pyHarm", [sys.executable, str(peers.SCRIPTS / "pyharm_example1.py"),
                                         "2.0"], cwd=None)
    assert row.status.startswith("failed:") and "pyHarm" in row.status


def test_parse_result_and_ratios():
    row = peers.parse_result(
        1.0, "NLvib", "noise\nRESULT 1 577 3.5 0.0065 188.44 3671 250.2 cpu=3.2\n", 4.0)
    assert (row.points, row.seconds, row.total, row.peak, row.peak_omega, row.cpu) == (
        577, 3.5, 4.0, 0.0065, 188.44, 3.2)
    ours = peers.Row(1.0, "ours", points=125, seconds=0.35, peak=0.0065, peak_omega=188.4,
                     cpu=0.32)
    line = peers.format_rows([ours, row])[2].split()
    assert line[1] == "NLvib" and float(line[-3]) == pytest.approx(10.0)   # time / ours
    assert float(line[-1]) == pytest.approx(10.0)                          # CPU / ours
    old = peers.parse_result(1.0, "NLvib", "RESULT 1 577 3.5 0.0065 188.44 3671 250.2\n", 4.0)
    assert old.seconds == 3.5 and np.isnan(old.cpu)     # a line without the CPU time
    assert peers.parse_result(1.0, "NLvib", "error", 1.0).status.startswith("failed")
    # a curve that stopped before the band's end (250 rad/s) is not timed as a curve
    short = peers.parse_result(1.0, "pyHarm", "RESULT 1 60 0.4 0.0065 188.4 201.5 cpu=0.4\n", 3.0)
    assert short.status == "failed: stopped at 201.50 rad/s, short of 250" and short.points == 0
    end = peers.parse_result(1.0, "pyHarm", "RESULT 1 110 0.7 0.0063 188.4 249.9 cpu=0.7\n", 3.0)
    assert end.status == "ok" and end.points == 110


def test_every_tool_is_timed_over_the_same_number_of_curves(monkeypatch):
    """The repeat count reaches NLvib's call and pyHarm's command line (the fine-step
    pyHarm row stays one curve, as the printed legend says)."""
    calls = []
    monkeypatch.setattr(peers, "available", lambda *a: {"NLvib": None, "pyHarm": None})
    monkeypatch.setattr(peers, "frequency_response", lambda *a, **k: None)
    monkeypatch.setattr(peers, "ours", lambda n, *a, **k: peers.Row(n, "ours"))
    monkeypatch.setattr(peers, "external",
                        lambda n, tool, cmd, cwd: calls.append((n, tool, cmd)) or
                        peers.Row(n, tool))
    peers.table("/nlvib", "/pyharm/python", loads=(1.0, 2.0), repeat=3)
    nlvib = [cmd for _, tool, cmd in calls if tool == "NLvib"]
    assert len(nlvib) == 2 and all(
        cmd[-1].endswith(f"{peers.NLVIB_TOL!r}, 3)") for cmd in nlvib)
    pyharm = [cmd for _, tool, cmd in calls if tool == "pyHarm"]
    assert len(pyharm) == 2 and all(cmd[-2:] == ["--repeat", "3"] for cmd in pyharm)
    fine = [cmd for _, tool, cmd in calls if tool.startswith("pyHarm ds")]
    assert len(fine) == 1 and "--repeat" not in fine[0]
    loop = [cmd for _, tool, cmd in calls if tool == peers.MINIMAL]
    assert len(loop) == 2 and all(cmd[-2:] == ["--repeat", "3"] for cmd in loop)


@pytest.mark.parametrize("script", ["pyharm_example1.py", "minimal_example1.py"])
@pytest.mark.parametrize("args", [["2.0", "--repeat"], ["2.0", "--repeat", "x"], [],
                                  ["two"]])
def test_the_python_scripts_refuse_bad_arguments_in_one_line(script, args):
    import subprocess
    p = subprocess.run([sys.executable, str(peers.SCRIPTS / script), *args],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
    assert "Traceback" not in p.stderr
