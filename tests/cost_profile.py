"""Where the suite's time goes: `python -m pytest --cost-profile=FILE` (a pytest plugin,
loaded by conftest.py) times, per test, what its cost is made of, and writes the table
of tests/README.md ("Where the time goes") to FILE (markdown) with the raw rows beside
it (FILE.json).

Measured per test (setup, call and teardown together), by wrapping the package's entry
points in every test process (each module attribute bound to the function, so that
`from ... import` names are wrapped too); a nested entry counts in both:
  * FE blades: meshes generated or read and assembled (`solid_blade`, `solid_from_mesh`,
    `beam_blade`, `read_volume`);
  * Craig-Bampton reductions (`reduction.reduce`);
  * Numba compilation (numba's own compile events, outermost only);
  * studies run in the test process through the command line (`pipeline.__main__.main`);
  * child processes (`subprocess.run`, and a `Popen` until its `wait`/`communicate`):
    the command line as a user runs it, kill and resume tests;
  * event-driven time integration (`events.integrate`).
"""
import functools
import importlib
import json
import os
import pkgutil
import subprocess
import time
from collections import defaultdict
from pathlib import Path

import pytest

ENTRIES = {
    "FE blades": ["pipeline.structure.solid:solid_blade", "pipeline.structure.solid:solid_from_mesh",
                  "pipeline.structure.beam:beam_blade", "pipeline.structure.mesh_io:read_volume"],
    "Craig-Bampton": ["pipeline.structure.reduction:reduce"],
    "CLI in process": ["pipeline.__main__:main"],
    "time integration": ["pipeline.solve.time_integration.events:integrate"],
}
COLUMNS = ["FE blades", "Craig-Bampton", "Numba compilation", "CLI in process",
           "child processes", "time integration"]

_costs = defaultdict(lambda: defaultdict(float))   # test id -> category -> seconds
_current = ["(collection)"]
_depth = defaultdict(int)


def _timed(category, fn):
    @functools.wraps(fn)
    def wrapper(*a, **k):
        _depth[category] += 1
        t0 = time.perf_counter()
        try:
            return fn(*a, **k)
        finally:
            _depth[category] -= 1
            if not _depth[category]:      # outermost call of this category only
                _costs[_current[0]][category] += time.perf_counter() - t0
    return wrapper


def _install():
    import pipeline
    for info in pkgutil.walk_packages(pipeline.__path__, "pipeline."):
        if ".bench" not in info.name:
            importlib.import_module(info.name)
    modules = [m for n, m in list(__import__("sys").modules.items())
               if n == "pipeline" or n.startswith("pipeline.")]
    for category, entries in ENTRIES.items():
        for entry in entries:
            mod, name = entry.split(":")
            original = getattr(importlib.import_module(mod), name)
            wrapped = _timed(category, original)
            for m in modules:
                for attr, value in list(vars(m).items()):
                    if value is original:
                        setattr(m, attr, wrapped)
    subprocess.run = _timed("child processes", subprocess.run)
    popen_init, popen_wait = subprocess.Popen.__init__, subprocess.Popen.wait

    def init(self, *a, **k):
        self._cost_t0 = time.perf_counter()
        popen_init(self, *a, **k)

    def wait(self, *a, **k):
        try:
            return popen_wait(self, *a, **k)
        finally:
            t0 = self.__dict__.pop("_cost_t0", None)
            if t0 is not None and not _depth["child processes"]:
                _costs[_current[0]]["child processes"] += time.perf_counter() - t0
    subprocess.Popen.__init__, subprocess.Popen.wait = init, wait

    from numba.core import event

    class Compile(event.Listener):
        depth, t0 = 0, 0.0

        def on_start(self, ev):
            if not self.depth:
                self.t0 = time.perf_counter()
            self.depth += 1

        def on_end(self, ev):
            self.depth -= 1
            if not self.depth:
                _costs[_current[0]]["Numba compilation"] += time.perf_counter() - self.t0
    event.register("numba:compile", Compile())


def pytest_configure(config):
    if config.getoption("cost_profile"):
        _install()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _current[0] = item.nodeid
    t0 = time.perf_counter()
    yield
    _costs[item.nodeid]["total"] += time.perf_counter() - t0
    _current[0] = "(between tests)"


def pytest_sessionfinish(session):
    target = session.config.getoption("cost_profile")
    if not target:
        return
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    rows = {k: dict(v) for k, v in _costs.items()}
    if worker:
        Path(f"{target}.{worker}.json").write_text(json.dumps(rows))
        return
    for part in sorted(Path(target).parent.glob(Path(target).name + ".gw*.json")):
        rows.update(json.loads(part.read_text()))
        part.unlink()
    Path(target + ".json").write_text(json.dumps(rows, indent=0))
    Path(target).write_text(table(rows))


def table(rows) -> str:
    """Markdown: per test folder the total and each category (seconds of test-process
    time, summed over the tests), then the 15 costliest tests."""
    folders = defaultdict(lambda: defaultdict(float))
    for test, cost in rows.items():
        if "::" not in test:
            continue
        folder = test.split("::")[0].rsplit("/", 1)[0]
        for k, v in cost.items():
            folders[folder][k] += v
            folders["all"][k] += v
    head = "| folder | tests, s | " + " | ".join(f"{c}, s" for c in COLUMNS) + " |"
    lines = [head, "|" + "---|" * (len(COLUMNS) + 2)]
    for folder, cost in sorted(folders.items(), key=lambda kv: -kv[1]["total"]):
        lines.append(f"| {folder} | {cost['total']:.0f} | "
                     + " | ".join(f"{cost[c]:.0f}" for c in COLUMNS) + " |")
    lines += ["", "| test | s | " + " | ".join(COLUMNS) + " |", "|" + "---|" * (len(COLUMNS) + 2)]
    top = sorted(((c.get("total", 0.0), t, c) for t, c in rows.items() if "::" in t), reverse=True)
    for total, test, cost in top[:15]:
        lines.append(f"| `{test}` | {total:.1f} | "
                     + " | ".join(f"{cost.get(c, 0.0):.1f}" for c in COLUMNS) + " |")
    return "\n".join(lines) + "\n"
