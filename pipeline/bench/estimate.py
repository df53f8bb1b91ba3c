"""`bench estimate`: `shroud check`'s cost estimate against the measured run, per study.

    python -m pipeline bench estimate [STUDY ...] [--quick]

Each study (default: every one in studies/) is estimated as `check` does (its
kind's estimate, `study.kinds`: `study.execution.cost` for a response, which times the model;
`study.execution.kind_costs` for the other kinds), the model caches are cleared (the
run builds and reduces its model again, as a fresh `run` does), and the study is run
in this process (`--workers 1`, figures included, no checkpoints), after one
unmeasured run of a small study that loads what every run loads (`warm_up`: the
estimates leave out a process's start-up).  Printed: the
estimate's range and its geometric middle, the measured wall time, and their ratio
measured / middle; the exit code is 1 if a ratio leaves [1/3, 3] (ACCEPT).

The estimate predicts wall time on a machine as loaded as when it timed the model;
the load may change before the run ends (other processes start or stop).  So the
CPU ratio is printed beside it: the run's CPU time (the work done, whatever the
load) over the estimate's middle divided by the slowdown measured when estimating
(`cost.slowdown`, wall / CPU time of one thread then: the estimate as work).  It is
the ratio that stays meaningful on a shared machine (the tests check it).
"""
from __future__ import annotations

import functools
import logging
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ..model import blade_cache
from ..study.execution.cost import seconds, slowdown
from ..study.execution.run import run_study
from ..study.files.documents import load_study
from ..study.kinds import kind_of

ACCEPT = 3.0       # the estimate's middle within this factor of the measured time
STUDIES = Path(__file__).resolve().parents[2] / "studies"


@dataclass(frozen=True)
class Measured:
    name: str
    quick: bool
    n_cases: int
    estimate: object       # the kind's estimate: .lo, .hi, .mid [s]
    wall: float            # [s] measured
    cpu: float             # [s] the run's CPU time (this process: the run is serial)
    slowdown: float        # wall / CPU time of one thread when estimating (`cost.slowdown`)

    @property
    def ratio(self) -> float:
        """Measured wall time over the estimate's middle."""
        return self.wall / self.estimate.mid

    @property
    def cpu_ratio(self) -> float:
        """The run's CPU time over the estimate's middle as work (divided by the
        slowdown it was made at): independent of load changes during the run."""
        return self.cpu / (self.estimate.mid / self.slowdown)


WARM_UP = "disk_laxalde"   # a study of about 0.5 s that writes a dataset and a figure


@functools.cache
def warm_up():
    """Run the WARM_UP study's quick variant once in this process, unmeasured: the
    estimates assume the modules a run loads already loaded (xarray and its duck-array
    backends, netCDF4, matplotlib and its fonts: about 2 s of a process's first run,
    which would otherwise depend on what ran before in it)."""
    with tempfile.TemporaryDirectory() as tmp:
        run_study(load_study(STUDIES / f"{WARM_UP}.toml", quick=True), tmp, workers=1,
                  progress=False, checkpoints=False)


def measure(path, quick: bool = False, out_dir=None) -> Measured:
    """Estimate, then run, the study at `path` (serially), after `warm_up`; `Measured`."""
    warm_up()
    study = load_study(path, quick=quick)
    kind = kind_of(study)
    load = slowdown()
    est = kind.estimate(study, workers=1)
    blade_cache.timed_blade_model.cache_clear()   # the run builds its model, as `run` does
    blade_cache.reduced_model.cache_clear()
    blade_cache.blade_at_speed.cache_clear()
    with tempfile.TemporaryDirectory() as tmp:
        t0, c0 = time.perf_counter(), time.process_time()
        run_study(study, out_dir or tmp, workers=1, progress=False, checkpoints=False)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return Measured(Path(path).stem, quick, kind.cases(study), est, wall, cpu, load)


def shipped_studies() -> list:
    """Every shipped study (`check` estimates each kind)."""
    return sorted(STUDIES.glob("*.toml"))


def run(quick: bool = False, studies=()) -> int:
    paths = [Path(s) if Path(s).suffix == ".toml" else STUDIES / f"{s}.toml" for s in studies] \
        or shipped_studies()
    for p in paths:   # a missing study is one line before the table, not in its middle
        if not p.is_file():
            print(f"error: {p}: (file): no such file", file=sys.stderr)
            return 2
    for name in ("pipeline", "distributed"):
        logging.getLogger(name).setLevel(logging.WARNING)
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"check's estimate against the measured run (--workers 1{', --quick' if quick else ''}); "
          f"load average {load}")
    print(f"{'study':<28} {'cases':>5} | {'estimate':>19} {'middle':>7} | {'measured':>8} | "
          f"{'ratio':>5} in range | CPU ratio")
    bad = 0
    for p in paths:
        m = measure(p, quick)
        e = m.estimate
        inside = e.lo <= m.wall <= e.hi
        ok = 1 / ACCEPT <= m.ratio <= ACCEPT
        bad += not ok
        print(f"{m.name:<28} {m.n_cases:>5} | {seconds(e.lo):>8} - {seconds(e.hi):<8} "
              f"{seconds(e.mid):>7} | {m.wall:7.1f}s | {m.ratio:5.2f} {'yes' if inside else 'no':>8}"
              f" | {m.cpu_ratio:9.2f}{'' if ok else f'  (outside 1/{ACCEPT:g}-{ACCEPT:g})'}",
              flush=True)
    print("ratio = measured / geometric middle of the estimate; CPU ratio = the run's CPU "
          "time / (middle / the slowdown measured when estimating): the same without the "
          "load's changes during the run")
    return 1 if bad else 0
