"""The sweep cases of a response study: the solver they call for, one guarded
continuation each (`run_case`), and all of them mapped over the grid in this
process, a local process pool or a Dask cluster (`execute_cases`), each finished case
kept at once (`checkpoint`).  `disk_figures` and the optimum search reuse `run_case`."""
from __future__ import annotations

import ctypes
import logging
import signal
import sys
import time

import numpy as np

from ...solve.response import linear_response
from ...solve.response import response
from ...model.system import negative_stiffness
from .checkpoint import load_cases, save_case
from .compile_ahead import GROUPS, compile_ahead, groups_for, marker
from ...errors import interrupt_in_chain
from ..files.declared import SeparationGuard, UndeclaredSeparation, needs_guard
from ..files.study_types import Study, is_linear_scene


def default_solver(study: Study | None = None):
    """The solver of a study's cases: `linear_response.frequency_response` (direct
    solve per frequency) when the scene calls for neither friction nor separation,
    else `response.frequency_response` (HBM continuation)."""
    scene = getattr(study, "scene", None)  # an accuracy-cost study has one scene per case
    if scene is not None and is_linear_scene(scene):
        return linear_response.frequency_response
    fn = getattr(response, "frequency_response", None)
    if fn is None:
        raise RuntimeError("pipeline.solve.response.response.frequency_response is not available yet")
    return fn


def accepts_callback(solver) -> bool:
    """The HBM continuation (`response.frequency_response`) takes a point callback."""
    return getattr(solver, "__module__", "") == "pipeline.solve.response.response"


HEARTBEAT = 30.0   # [s] between a long case's progress lines (no live progress bar)


class Heartbeat:
    """A continuation callback that logs, at most every HEARTBEAT seconds, how far a
    case is (points, frequency, time): a case in a worker process or written to a log
    has no live bar, and a wheel's case runs for minutes."""

    def __init__(self, label):
        self.label, self.points = label, 0
        self.start = self.last = time.perf_counter()

    def __call__(self, x, lam):
        self.points += 1
        now = time.perf_counter()
        if now - self.last >= HEARTBEAT:
            self.last = now
            log.info("case %s: %d points, at %.6g Hz, %.0f s", self.label, self.points,
                     lam / (2.0 * np.pi), now - self.start)
        return False


def run_case(solver, system, H, omega_start, omega_stop, kwargs, guard=None, label=None):
    """One continuation; returns (ResponseCurve or None, error text or None).

    guard: a `declared.SeparationGuard` when the scene's normal load varies but
    separation is not declared: the continuation stops at the first point that
    separates, and every point of the finished curve is checked, so such a case
    fails instead of being solved with separation.  label: the case, for the
    progress lines of a continuation without another callback (`Heartbeat`)."""
    try:
        if label is not None and kwargs.get("callback") is None and accepts_callback(solver):
            kwargs = dict(kwargs, callback=Heartbeat(label))
        w2 = negative_stiffness(system)
        if w2 is not None:
            return None, divergence(w2)
        if guard is not None:
            kwargs = dict(kwargs)
            check, progress = guard.callback(system, H), kwargs.get("callback")
            kwargs["callback"] = (check if progress is None else
                                  lambda x, lam: check(x, lam) or progress(x, lam))
        curve = solver(system, H, omega_start, omega_stop, **kwargs)
        if guard is not None:
            guard.check_curve(system, curve)
        return curve, None
    except UndeclaredSeparation as exc:  # reported once, in the case's progress line
        return None, str(exc)
    except Exception as exc:  # numerical failures of one case must not lose the others
        logging.getLogger(__name__).exception("case failed")
        return None, f"{type(exc).__name__}: {exc}"


def failed_case(error: str):
    """The result of a case whose model could not be built (`execute_cases`): (None,
    error), as `run_case` returns for a case that fails."""
    return None, error


class StaticDivergence(RuntimeError):
    """The structure has a negative stiffness (`negative_stiffness`): not solved."""


def divergence(w2: float) -> str:
    """The case error of a structure with a negative stiffness (`negative_stiffness`)."""
    return (f"the structure is statically unstable about rest: at vanishing vibration "
            f"(preloaded contacts stuck, the others open) its stiffness has a negative "
            f"eigenvalue, omega^2 = {w2:.4g} rad^2/s^2 (spin softening beyond the speed of "
            "divergence?); not solved")


def separation_guard(study):
    """The `declared.SeparationGuard` of a study's cases, or None."""
    scene = getattr(study, "scene", None)
    if scene is None or not needs_guard(scene):
        return None
    names = tuple(getattr(c, "name", "") for c in getattr(scene, "contacts", ()))
    return SeparationGuard(unit=study.sweep.frequency.unit, names=names)


log = logging.getLogger("pipeline.study.execution.run")
SCHEDULER_TIMEOUT = "20s"   # connecting to a --scheduler address


class SchedulerUnreachable(RuntimeError):
    """--scheduler names no reachable Dask scheduler (nothing was computed)."""


class WorkerLost(RuntimeError):
    """A worker process of the local pool died; the finished cases are kept."""


class Progress:
    """tqdm when it is installed (cases done, and the current case's frequency in the
    study's unit when cases run in this process), otherwise one log line per
    finished case.  While the bar is live, log records are written through tqdm
    (`logging_redirect_tqdm`) so they do not break it."""

    def __init__(self, total, desc, initial=0, unit="rad/s"):
        self.total, self.desc, self.done = total, desc, initial
        self.unit, self.to_rad_s = unit, (2.0 * np.pi if unit == "Hz" else 1.0)
        self._redirect = None
        try:
            # deferred: tqdm, only for a progress bar (and optional)
            from tqdm.auto import tqdm
            self.bar = tqdm(total=total, initial=initial, desc=desc, unit="case",
                            disable=None, file=sys.stderr)
        except ImportError:
            self.bar = None
        if self.live:
            # deferred: tqdm, only for a live bar
            from tqdm.contrib.logging import logging_redirect_tqdm
            self._redirect = logging_redirect_tqdm()
            self._redirect.__enter__()

    @property
    def live(self) -> bool:
        return self.bar is not None and not self.bar.disable

    def frequency(self, omega):
        """Callback of the continuation in this process: show where the case is."""
        if self.live:
            self.bar.set_postfix_str(f"{omega / self.to_rad_s:.5g} {self.unit}", refresh=False)
            self.bar.update(0)
        return False

    def update(self, case, curve, err):
        self.done += 1
        what = (f"failed ({err})" if curve is None else
                f"{curve.n_points} points, {int(np.sum(curve.converged))} converged, "
                f"{curve.wall_time:.2f} s")
        if self.live:
            self.bar.update(1)
            log.debug("case %s: %s", case, what)
        else:
            log.info("%s: %d/%d done, case %s: %s", self.desc, self.done, self.total, case, what)

    def close(self):
        if self.bar is not None:
            self.bar.close()
        if self._redirect is not None:
            self._redirect.__exit__(None, None, None)
            self._redirect = None



def execute_cases(study, solver, workers, scheduler, progress, cdir=None, extra=None):
    """Run the cases not found in `cdir`; each finished case is kept there at once.
    extra {key: (fn, *args)}: other jobs run beside the cases on the same workers
    (after them in the queue; e.g. the optimum search's grid, `planned_grid`).
    Returns (results aligned with the cases, number reused from checkpoints, {key:
    fn(*args)} of the extra jobs)."""
    cases = study.sweep.cases()
    H, fr = study.solver.harmonics, study.sweep.frequency
    kw = study.solver.kwargs(study.output.yscale, study.output.curves)  # curves smooth on the figures' axis
    if study.scene.model != "lumped":  # FE scenes: exact peaks of the reported DOFs only
        kw["peak_dofs"] = [study.scene.dof_index(d) for d in study.output.dofs]
    results = [None] * len(cases)
    reused = load_cases(cdir, cases) if cdir is not None else {}
    for k, res in reused.items():
        results[k] = res
    todo = [k for k in range(len(cases)) if k not in reused]
    if reused:
        log.info("%s: resuming: %d of %d case(s) finished earlier (kept in %s), %d to compute",
                 study.name, len(reused), len(cases), cdir, len(todo))
    bar = (Progress(len(cases), study.name, initial=len(reused), unit=fr.unit)
           if progress else None)
    guard = separation_guard(study) if getattr(solver, "__module__", "") == "pipeline.solve.response.response" else None

    extra, more = dict(extra or {}), {}

    def job(k):
        if k in extra:
            return extra[k]
        try:
            system = study.system(cases[k][1])
        except Exception as exc:  # a case whose model cannot be built fails alone
            if interrupt_in_chain(exc):
                raise
            log.exception("case %s: its model cannot be built", cases[k][1])
            return failed_case, f"{type(exc).__name__}: {exc}"
        return (run_case, solver, system, H, fr.omega_start, fr.omega_stop, kw, guard,
                cases[k][1])

    def done(k, res):
        if k in extra:
            more[k] = res
            return
        results[k] = res
        if cdir is not None and res[0] is not None:
            save_case(cdir, k, cases[k][1], res[0])
        if bar is not None:
            bar.update(cases[k][1], *res)

    def serial(k):
        kwk = dict(kw)
        if bar is not None and bar.live and getattr(solver, "__name__", "") == "frequency_response":
            kwk["callback"] = lambda x, lam: bar.frequency(lam)
        if k in extra:
            return call(*extra[k])
        fn, *args = job(k)
        if fn is not run_case:
            return fn(*args)
        solver_k, system, H_k, a, b, _, g, label = args
        return run_case(solver_k, system, H_k, a, b, kwk, g, label)

    if workers > 1 and not scheduler and len(todo) + len(extra) > 1 and todo and \
            getattr(solver, "__module__", "") == "pipeline.solve.response.response":
        compile_kernels(study, cases[todo[0]][1], kw.get("method", "exact"), workers)
    try:
        map_jobs(call, todo + list(extra), job, done, workers, scheduler, serial)
    finally:
        if bar is not None:
            bar.close()
    return results, len(reused), more


def compile_kernels(study, case, method, workers):
    """The kernels the cases meet, compiled once before the pool's workers start
    (`compile_ahead`), from the first case's system; nothing if every group is marked
    compiled already (no system built) or if it cannot be built (that case then fails
    alone, as it would)."""
    if all(marker(g).exists() for g in GROUPS):
        return
    try:
        system = study.system(case)
    except Exception as exc:
        if interrupt_in_chain(exc):
            raise
        return
    compile_ahead(groups_for(system, method), workers)


def end_with_parent():
    """A pool worker's initializer: on Linux the worker is sent SIGTERM when the run's
    process ends (prctl PR_SET_PDEATHSIG), so that no worker outlives an interrupted
    run holding its output pipes; elsewhere nothing."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)   # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError, TypeError):
        pass


def call(fn, *args):
    """fn(*args): one job of `map_jobs` given as (fn, *args)."""
    return fn(*args)


def map_jobs(fn, todo, job, done, workers=1, scheduler=None, serial=None):
    """fn(*job(k)) for every k of `todo` on the Dask scheduler at `scheduler`, else in a
    local pool of `workers` processes (when more than one job), else here in turn
    (serial(k) instead, if given); done(k, result) as each ends, in this process.  A
    Ctrl-C or a lost worker stops the running jobs at once (`WorkerLost`)."""
    if scheduler and todo:
        # deferred: Dask is optional (pip install -e ".[dask]")
        from dask.distributed import Client, as_completed

        try:
            client = Client(scheduler, timeout=SCHEDULER_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise SchedulerUnreachable(f"cannot reach the Dask scheduler at {scheduler} "
                                       f"({type(exc).__name__}: {exc})") from None
        with client:
            futs = [client.submit(fn, *job(k), pure=False) for k in todo]
            index = {f.key: k for k, f in zip(todo, futs)}
            for fut in as_completed(futs):
                done(index[fut.key], fut.result())
    elif workers > 1 and len(todo) > 1:
        # here: its as_completed, not Dask's above
        from concurrent.futures import ProcessPoolExecutor, as_completed

        pool = ProcessPoolExecutor(max_workers=min(workers, len(todo)),
                                   initializer=end_with_parent)
        try:
            futs = {pool.submit(fn, *job(k)): k for k in todo}
            for fut in as_completed(futs):
                done(futs[fut], fut.result())
        except BaseException as exc:  # Ctrl-C or a lost worker: stop the running jobs now
            import multiprocessing   # the pool's workers, and one it was still starting
            for proc in {*(getattr(pool, "_processes", None) or {}).values(),
                         *multiprocessing.active_children()}:
                proc.terminate()
            pool.shutdown(wait=False, cancel_futures=True)
            from concurrent.futures.process import BrokenProcessPool
            if isinstance(exc, BrokenProcessPool):
                raise WorkerLost("a worker process died (killed, or out of memory)") from None
            raise
        pool.shutdown()
    else:
        for k in todo:
            done(k, serial(k) if serial is not None else fn(*job(k)))
