"""The command line: its name, `check`, progress and log noise, the runtime dependencies."""
from __future__ import annotations

import io
import logging
import math
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import xarray as xr

from pipeline.__main__ import main as cli
from helpers import example1_study

ROOT = Path(__file__).resolve().parents[3]
STUDIES = ROOT / "studies"
BAD = Path(__file__).resolve().parents[2] / "bad_studies"


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "pipeline", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd or ROOT,   # this tree's pipeline from any cwd
                          env=dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(ROOT)),
                          timeout=300)


# ---------------------------------------------------------------------------
# Install and name
# ---------------------------------------------------------------------------

def test_tqdm_is_a_runtime_dependency():
    proj = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert any(re.match(r"tqdm\b", d) for d in proj["dependencies"])
    assert proj["scripts"]["shroud"] == "pipeline.__main__:main"


@pytest.mark.parametrize("argv0, prog", [("/venv/bin/shroud", "shroud"),
                                         (str(ROOT / "pipeline" / "__main__.py"),
                                          "python -m pipeline")])
def test_usage_names_the_command_as_invoked(monkeypatch, capsys, argv0, prog):
    monkeypatch.setattr(sys, "argv", [argv0, "--help"])
    with pytest.raises(SystemExit):
        cli(["--help"])
    assert capsys.readouterr().out.startswith(f"usage: {prog} ")


HEAVY = ("numba", "skfem", "meshio", "scipy", "xarray", "matplotlib", "dask")


@pytest.mark.parametrize("argv", [["--help"], ["run", "--help"], ["optimise", "--help"]])
def test_help_loads_nothing_that_computes(argv):
    """`--help` (and building the parser) imports argparse and the small modules only:
    the commands import the compiled kernels, scikit-fem, SciPy, xarray, matplotlib and
    Dask when they run.  A fresh interpreter: this one has loaded them all."""
    code = ("import sys, contextlib, io, pipeline.__main__ as m\n"
            "with contextlib.redirect_stdout(io.StringIO()) as out:\n"
            "    try:\n"
            f"        m.main({argv!r})\n"
            "    except SystemExit:\n"
            "        pass\n"
            "assert out.getvalue().startswith('usage: '), out.getvalue()\n"
            f"print(sorted({{k.split('.')[0] for k in sys.modules}} & set({HEAVY!r})))")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"


# ---------------------------------------------------------------------------
# check STUDY.toml
# ---------------------------------------------------------------------------

def test_check_prints_cases_solver_and_cost_without_computing(tmp_path):
    r = run("check", STUDIES / "paper_example2.toml", "--workers", "2", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "valid response study (full variant; [quick] not checked" in out
    assert "cases: 6 = preload (6)" in out
    assert "preload [N]: 0, 100, 300, 1000, 3000, 100000" in out
    assert "frequency: 13 to 67 Hz (continuation)" in out
    assert "solver: H = 7, exact forces, tolerance 1e-09 (relative), stability monodromy+check" in out
    assert re.search(r"estimated cost: .* \(middle .*\) for 6 case\(s\) on 2 worker\(s\)", out), out
    m = re.search(r"assumes .*residual \+ Jacobian ([0-9.]+) ms and Newton solve ([0-9.]+) ms "
                  r"of 15 unknowns, timed now", out)
    assert m and float(m.group(1)) > 0 and float(m.group(2)) > 0, out
    assert not any(tmp_path.iterdir())             # nothing written, nothing computed


def test_check_quick_shows_the_quick_grid_and_only_then_checks_quick(tmp_path):
    r = run("check", STUDIES / "paper_example3.toml", "--quick")
    assert r.returncode == 0, r.stderr
    assert "(quick variant)" in r.stdout and "cases: 3 = preload (3)" in r.stdout
    assert "solver: H = 3," in r.stdout
    # a [quick] section that is wrong: the full check passes, --quick names the field
    doc = (STUDIES / "disk_cyclic.toml").read_text().replace("sectors = 24", "sectors = 12")
    doc = doc.replace("eo = [0, 3, 12]", "eo = [0, 3, 6]")
    f = tmp_path / "disk12.toml"
    f.write_text(doc)
    full, quick = run("check", f), run("check", f, "--quick")
    assert full.returncode == 0 and "eo: 0, 3, 6" in full.stdout, full.stderr
    assert quick.returncode == 2 and quick.stdout == ""
    assert quick.stderr.splitlines() == [l for l in quick.stderr.splitlines()
                                         if l.startswith(f"error: {f}: quick.sweep.eo[1]: ")]
    assert len(quick.stderr.splitlines()) == 1


@pytest.mark.parametrize("stem", ["sweep_misspelled_key_with_quick",
                                  "scene_varying_load_zero_preload_without_separation",
                                  "contact_negative_mu"])
def test_check_bad_study_is_one_line_exit_2(tmp_path, stem):
    path = BAD / f"{stem}.toml"
    field = re.match(r"# field: (.*)\n", path.read_text()).group(1)
    r = run("check", path, cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == "" and "Traceback" not in r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {path}: {field}: "), r.stderr
    if stem.startswith("sweep_"):
        assert "did you mean 'preload'?" in lines[0]
    if stem.startswith("scene_"):
        assert 'declare "separation"' in lines[0]
    assert not any(tmp_path.iterdir())


def test_check_missing_file(tmp_path):
    for name in ("nope.toml", "nope.nc"):
        r = run("check", tmp_path / name)
        assert r.returncode == 2 and r.stderr.splitlines() == [
            f"error: {tmp_path / name}: (file): no such file"]


def test_a_shipped_studys_bare_name_is_pointed_to_its_file(tmp_path, capsys):
    """`run paper_example1` (no folder, no suffix): still no such file, but the line
    names the shipped study's path; any other name gets no hint."""
    assert cli(["run", "paper_example1", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.strip() == ("error: paper_example1: (file): no such file "
                                               f"(a shipped study: {STUDIES / 'paper_example1.toml'})")
    assert cli(["check", "no_such_study"]) == 2
    assert capsys.readouterr().err.strip() == "error: no_such_study: (file): no such file"


def test_check_quick_of_a_study_without_a_quick_table_says_so(tmp_path, capsys):
    f = tmp_path / "plain.toml"
    f.write_text(example1_study("no quick table"))
    assert cli(["check", str(f), "--quick"]) == 0
    assert capsys.readouterr().out.splitlines()[0] == (
        f"{f}: valid response study (quick variant: no [quick] table, the full study)")


def test_check_linear_and_modes_studies_need_no_solver(capsys):
    assert cli(["check", str(STUDIES / "blade_modes.toml"), "--quick"]) == 0
    out = capsys.readouterr().out
    assert "valid modes study (quick variant)" in out and "estimated cost:" in out


# ---------------------------------------------------------------------------
# check FILE.nc (the contract checker is pipeline.study.datasets.conformance)
# ---------------------------------------------------------------------------

LINEAR = """
[study]
title = "one mass on a spring"
[scene]
model = "lumped"
effects = []
dofs = ["x"]
[scene.matrices]
M = [[1.0]]
C = [[0.3]]
K = [[3.55e4]]
[[scene.excitation]]
dof = "x"
amplitude = 1.0
[sweep]
frequency = { start = 150.0, stop = 250.0, unit = "rad/s" }
[output]
dofs = ["x"]
figures = []
"""


def test_check_dataset(tmp_path, capsys):
    """A dataset the pipeline wrote meets the contract; one without `amplitude` does
    not (exit 1, the variable named); a file that is not netCDF is exit 2."""
    study = tmp_path / "spring.toml"
    study.write_text(LINEAR)
    assert cli(["run", str(study), "--out", str(tmp_path), "--workers", "1"]) == 0
    good, bad, junk = tmp_path / "spring.nc", tmp_path / "bad.nc", tmp_path / "junk.nc"
    xr.open_dataset(good).load().drop_vars("amplitude").to_netcdf(bad)
    junk.write_text("not netCDF")
    capsys.readouterr()
    assert cli(["check", str(good)]) == 0
    assert cli(["check", str(bad)]) == 1
    out = capsys.readouterr().out
    assert f"{good}: meets the dataset contract" in out
    assert f"{bad}: " in out and "amplitude" in out
    assert cli(["check", str(junk)]) == 2
    assert "junk.nc" in capsys.readouterr().err


# ---------------------------------------------------------------------------
# Progress and log noise
# ---------------------------------------------------------------------------

def test_progress_shows_the_frequency_in_the_study_unit(monkeypatch):
    import tqdm.auto

    from pipeline.study.execution.cases import Progress

    stream = io.StringIO()
    real = tqdm.auto.tqdm
    monkeypatch.setattr(tqdm.auto, "tqdm", lambda *a, **k: real(*a, **{**k, "disable": False,
                                                                        "file": stream}))
    p = Progress(3, "ex2", unit="Hz")
    try:
        assert p.live
        p.frequency(2 * math.pi * 137.7)
        assert p.bar.postfix == "137.7 Hz"
        # log records go through tqdm while the bar is live, and back afterwards
        kinds = {type(h).__name__ for h in logging.getLogger().handlers}
        assert "_TqdmLoggingHandler" in kinds
    finally:
        p.close()
    assert "_TqdmLoggingHandler" not in {type(h).__name__ for h in logging.getLogger().handlers}
    q = Progress(1, "ex1", unit="rad/s")
    try:
        q.frequency(150.0)
        assert q.bar.postfix == "150 rad/s"
    finally:
        q.close()


def test_default_log_level_hides_solver_noise(tmp_path):
    """No continuation summary ('reached lam_end = ...') and no scikit-fem INFO lines at
    the default level; -v shows the continuation's."""
    from pipeline.study.execution.run_parser import configure_logging

    configure_logging(False)
    assert logging.getLogger("skfem").getEffectiveLevel() == logging.WARNING
    assert not logging.getLogger("pipeline.solve.continuation.pseudo_arclength").isEnabledFor(logging.INFO)
    text = (STUDIES / "paper_example1.toml").read_text()
    text = text[:text.index("[output.optimum_preload]")]
    # one case, Hill's stability alone: the log lines, not the grid or the checks, are tested
    text = text.replace("[quick.sweep]\npreload = [0.0, 2.0, 1000.0]", "[quick.sweep]\npreload = [2.0]")
    text = text.replace("stability = true", 'stability = "hill"')
    assert "preload = [2.0]" in text and 'stability = "hill"' in text
    f = tmp_path / "ex1.toml"
    f.write_text(text)
    quiet = run("run", f, "--quick", "--out", tmp_path / "a", "--workers", "1", "--no-figures")
    assert quiet.returncode == 0, quiet.stderr
    assert "reached lam_end" not in quiet.stderr and "pipeline.solve.continuation.pseudo_arclength" not in quiet.stderr
    loud = run("-v", "run", f, "--quick", "--out", tmp_path / "b", "--workers", "1",
               "--no-figures")
    assert loud.returncode == 0 and "reached lam_end" in loud.stderr


# ---------------------------------------------------------------------------
# hysteresis
# ---------------------------------------------------------------------------

def test_hysteresis_writes_into_a_folder_and_refuses_other_files(tmp_path, capsys):
    """--out a folder: hysteresis.png in it (a folder path once ended in a traceback);
    --out not a PNG: one error line, exit 2, nothing written."""
    assert cli(["hysteresis", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "hysteresis.png").stat().st_size > 1000
    capsys.readouterr()
    assert cli(["hysteresis", "--out", str(tmp_path / "loop.txt")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --out: "), err
    assert not (tmp_path / "loop.txt").exists()


@pytest.mark.parametrize("args, field", [(["--ku", "-1"], "--ku"), (["--ku", "0"], "--ku"),
                                         (["--mu", "nan"], "--mu"),
                                         (["--u", "inf"], "--u"), (["--v", "0", "nan"], "--v")])
def test_hysteresis_bad_parameters_are_one_line_and_write_nothing(tmp_path, capsys, args, field):
    assert cli(["hysteresis", "--out", str(tmp_path / "h.png"), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: hysteresis: {field}: "), err
    assert not (tmp_path / "h.png").exists()
    if args == ["--ku", "-1"]:   # the number as typed, not an array's repr
        assert err[0] == "error: hysteresis: --ku: ku must be >= 0 (stiffness), got -1"


def test_hysteresis_names_a_missing_output_folder(tmp_path, capsys):
    assert cli(["hysteresis", "--out", str(tmp_path / "new")]) == 2
    assert capsys.readouterr().err.strip() == (
        f"error: --out: {tmp_path / 'new'}: no such folder (give an existing folder, or a "
        "file name ending in .png)")
    assert not (tmp_path / "new").exists()


def test_negative_contact_parameters_name_the_first_element():
    from pipeline.contact import YangMenq
    with pytest.raises(ValueError, match=r"^kv must be >= 0 \(stiffness\), got -2 at element 1 "
                                         r"\(2 negative\)$"):
        YangMenq(ku=1.0, kv=[0.0, -2.0, -3.0], mu=0.3, n0=1.0)
    with pytest.raises(ValueError, match=r"^mu must be >= 0, got -0.3$"):
        YangMenq(ku=1.0, kv=0.0, mu=-0.3, n0=1.0)


def test_hysteresis_draws_the_motion_given(tmp_path, monkeypatch):
    """--u and --v set the motion the element sees (the default is the demonstration's:
    u = 3 cos tau, v = 0.5 cos tau + 2 sin tau [m])."""
    import pipeline.study.figures.plots as plots

    seen = {}
    real = plots.hysteresis_figure

    def spy(path, **kw):
        seen.update(kw)
        return real(path, **kw)

    monkeypatch.setattr(plots, "hysteresis_figure", spy)
    assert cli(["hysteresis", "--out", str(tmp_path / "a.png"), "--kv", "1e4", "--n0", "5",
                "--u", "1e-3", "--v", "0", "2e-4"]) == 0
    assert seen["U"][0, 1] == 1e-3 and list(seen["V"][0, 1:3]) == [0.0, 2e-4]
    assert (seen["kv"], seen["n0"]) == (1e4, 5.0)
    assert cli(["hysteresis", "--out", str(tmp_path / "b.png")]) == 0
    U, V = plots.demo_motion()
    assert (seen["U"] == U).all() and (seen["V"] == V).all()
