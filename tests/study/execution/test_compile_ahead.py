"""The kernels compiled before a parallel run's workers start (`compile_ahead`): the
groups a system meets, the marks that make a second run skip the step, and (slow, on
a cold cache) that a run compiles nothing further after it."""
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import pipeline
from pipeline import load_study
from pipeline.study.execution import compile_ahead as ca

ROOT = Path(__file__).resolve().parents[3]


def first_system(path):
    study = load_study(path, quick=True)
    return study.system(study.sweep.cases()[0][1])


def test_groups_follow_the_contact_law_and_the_force_evaluation():
    example3 = first_system(ROOT / "studies/paper_example3.toml")
    assert ca.groups_for(example3, "exact") == ("continuation", "exact")
    assert ca.groups_for(example3, "aft") == ("continuation", "sampled")
    plane = first_system(ROOT / "tests/studies/inplane_oscillator_2d_friction.toml")
    assert plane.contact.size == 0            # the 2D law's elements only
    assert ca.groups_for(plane, "aft") == ("continuation", "sampled")


def test_a_marked_group_is_skipped_and_an_unmarked_one_compiled_once(tmp_path, monkeypatch):
    # the machine's warm cache copied without its marks: the group loads from it
    cache = tmp_path / "cache"
    shutil.copytree(pipeline.kernel_cache_dir(), cache,
                    ignore=shutil.ignore_patterns("*.compiled-*"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(cache))
    assert not ca.marker("continuation").exists()
    assert ca.compile_ahead(("continuation",), workers=2) > 0.0
    assert ca.marker("continuation").exists()
    assert ca.marker("continuation").parent == cache
    assert ca.compile_ahead(("continuation",), workers=2) == 0.0   # marked: no process


@pytest.mark.slow
def test_after_it_a_parallel_run_compiles_nothing(tmp_path):
    """On a cold cache: compile ahead; then every group's entry points in that process
    and the Example 3 quick run with two workers (which finds the marks) compile
    nothing again: Numba's compile events (loads from the cache are none) and the
    cache's files, unchanged by the run."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cold"))
    script = textwrap.dedent("""
        import sys
        from numba.core import event
        from pipeline.study.execution import compile_ahead as ca
        ca.compile_ahead(tuple(ca.GROUPS), workers=2)
        compiled = []
        class Count(event.Listener):
            def on_start(self, ev):
                compiled.append(ev.data["dispatcher"].py_func.__qualname__)
            def on_end(self, ev):
                pass
        event.register("numba:compile", Count())
        for group in ca.GROUPS.values():
            group()
        print("compiled again:", compiled)
        sys.exit(1 if compiled else 0)
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         env=env, timeout=900)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]

    def files():
        return {p.name: p.stat().st_mtime_ns for p in (tmp_path / "cold").rglob("*")}

    before = files()
    assert any(name.startswith("exact.compiled-") for name in before)
    run = subprocess.run([sys.executable, "-m", "pipeline", "run",
                          str(ROOT / "studies/paper_example3.toml"), "--quick", "--no-figures",
                          "--workers", "2", "--out", str(tmp_path / "out")],
                         capture_output=True, text=True, env=env, timeout=900)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "compiling the kernels" not in run.stderr
    assert files() == before
