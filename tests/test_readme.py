"""Every command README.md shows is run: the shell commands of its code blocks and every
inline `python -m pipeline ...` (or `shroud ...`) command are either run here, as shown,
from a folder holding the repository's studies (the further studies with their [quick]
overrides; as shown under `-m slow`), or listed in EXERCISED with what runs them (the
install and the test suite: `.ci/run`).  A command added to the README and run
by nothing fails `test_every_readme_command_is_run`.

The Python example under `<!-- python-example -->` is the public API's example file,
`studies/python_example.py`, tested with it; the xarray line is run here on the dataset
the first command wrote.
"""
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
SHELL_TAGS = ("", "sh", "bash", "shell", "console")
INLINE = re.compile(r"`((?:python -m pipeline|shroud) [^`]+)`")

# commands of the README run elsewhere: the fresh-machine install and the whole suite are
# what the CI entry point does (its lines are asserted in test_ci_runs_the_install_and_the_suite)
EXERCISED = {
    "python3 -m venv .venv": ".ci/run",
    ".venv/bin/pip install -e .": ".ci/run",
    '.venv/bin/pip install -e ".[test]"': ".ci/run",
    ".venv/bin/python -m pytest -q": ".ci/run",
}
# the commands this file runs: independent sequences, each in its own folder (the first
# writes the dataset the second command and the xarray line read), so that they can run
# in parallel test processes; with the files the README says they write
FIRST = [
    "python -m pipeline run studies/paper_example3.toml",
    "python -m pipeline check results/paper_example3.nc",
]
OTHERS = {
    "disks": ([
        "python -m pipeline run studies/disk_laxalde.toml",
        "python -m pipeline run studies/disk_nonlinear_modes.toml",
        "python -m pipeline hysteresis",
        "python -m pipeline keys",
        "python -m pipeline bench --help",
    ], ["disk_laxalde.nc", "hysteresis.png"]),
    "campbell_optimum": ([
        "python -m pipeline run studies/shrouded_disk_campbell.toml",
        "python -m pipeline check studies/disk_cyclic.toml",
        "python -m pipeline optimise studies/paper_example1.toml",
    ], ["paper_example1/optimum_preload.png"]),
}
RUN_HERE = FIRST + [cmd for cmds, _ in OTHERS.values() for cmd in cmds]


def _blocks(text):
    """[(tag, body, the line before the fence)] of the fenced code blocks."""
    out = []
    for m in re.finditer(r"(?m)^```([\w-]*)\n(.*?)^```", text, re.S):
        before = text[:m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        out.append((m.group(1), m.group(2), before))
    return out


def readme_commands(text=None):
    """Every command the README shows: the shell blocks' lines split at `&&`, and the
    inline `python -m pipeline ...` commands (`.venv/bin/python` read as `python`)."""
    text = README.read_text() if text is None else text
    cmds = []
    for tag, body, _ in _blocks(text):
        if tag in SHELL_TAGS:
            for line in body.splitlines():
                line = line.split(" #", 1)[0].strip()
                cmds += [c.strip() for c in line.split("&&") if c.strip()]
    prose = re.sub(r"(?ms)^```.*?^```", "", text)
    cmds += INLINE.findall(prose)
    return list(dict.fromkeys(cmds))


def _as_run_here(cmd):
    return cmd.replace(".venv/bin/python ", "python ", 1)


def test_every_readme_command_is_run():
    missing = [c for c in readme_commands()
               if c not in EXERCISED and _as_run_here(c) not in RUN_HERE]
    assert not missing, f"README commands no test runs: {missing} (run them in " \
                        "tests/test_readme.py or list them in EXERCISED)"


def test_the_lists_hold_only_readme_commands():
    shown = {_as_run_here(c) for c in readme_commands()} | set(readme_commands())
    assert set(RUN_HERE) <= shown and set(EXERCISED) <= shown


def test_ci_runs_the_install_and_the_suite():
    ci = (ROOT / ".ci" / "run").read_text()
    assert "python3 -m venv" in ci
    assert 'pip install -q -e ".[test]"' in ci
    assert re.search(r"(?m)^python -m pytest -q( --durations=5)?( +#.*)?$", ci)
    # the first command's install (without the test extras) is the same package install
    assert "[project.scripts]" in (ROOT / "pyproject.toml").read_text()


def _run(cmd, cwd, timeout=600):
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    args = shlex.split(cmd)
    assert args[:3] == ["python", "-m", "pipeline"]
    return subprocess.run([sys.executable, *args[1:]], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout)


def _run_all(cmds, here):
    """Run `cmds` in order in `here` (holding the repository's studies); every failure
    reported."""
    here.mkdir()
    (here / "studies").symlink_to(ROOT / "studies")
    failed = []
    for cmd in cmds:
        p = _run(cmd, here)
        if p.returncode != 0:
            failed.append(f"{cmd}: exit {p.returncode}\n{p.stderr[-2000:]}")
    assert not failed, "\n".join(failed)
    return here / "results"


def test_first_commands_succeed_and_the_xarray_line_draws_the_branch(tmp_path, monkeypatch):
    """The README's first study, its dataset check, the files it names and its xarray
    line on the dataset."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = _run_all(FIRST, tmp_path / "readme")
    for f in ("paper_example3.nc", "paper_example3/amplitude_u.png",
              "paper_example3/amplitude_v.png", "paper_example3/optimum_preload.png"):
        assert (out / f).is_file(), f
    (line,) = [body.strip() for tag, body, before in _blocks(README.read_text())
               if tag == "python" and "xr.open_dataset" in body
               and before.strip() != "<!-- python-example -->"]
    monkeypatch.chdir(out.parent)
    plt.close("all")   # as in a fresh session: no figure another test left open
    exec(compile(line, "README.md", "exec"), {})
    ax = plt.gca()
    assert ax.lines and len(ax.lines[0].get_xdata()) > 10
    plt.close("all")


def quick(cmd):
    """`cmd` with the study's [quick] overrides, when it runs a study."""
    return cmd + " --quick" if cmd.split()[3:4] in (["run"], ["optimise"]) else cmd


@pytest.mark.parametrize("group", list(OTHERS))
def test_other_commands_succeed_and_write_what_the_readme_says(group, tmp_path):
    """The README's further commands, each study with its [quick] overrides (the same
    command line, the same files written; as shown: `-m slow`)."""
    cmds, files = OTHERS[group]
    out = _run_all([quick(c) for c in cmds], tmp_path / "readme")
    for f in files:
        assert (out / f).is_file(), f


@pytest.mark.slow
@pytest.mark.parametrize("group", list(OTHERS))
def test_other_commands_as_shown_succeed_and_write_what_the_readme_says(group, tmp_path):
    cmds, files = OTHERS[group]
    out = _run_all(cmds, tmp_path / "readme")
    for f in files:
        assert (out / f).is_file(), f
