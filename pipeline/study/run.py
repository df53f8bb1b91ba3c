"""Run a study: grid of sweep cases -> response curves -> dataset -> figures.

    python -m pipeline run STUDY.toml [--out DIR] [--workers N] [--scheduler ADDRESS] [--quick]

Each grid case (one combination of the `[sweep]` axes) is one frequency
continuation `pipeline.solve.response.frequency_response(system, H, omega_start,
omega_stop, **solver.kwargs())`, or one direct solve per frequency for a linear
scene (`pipeline.solve.linear_response`).  Cases run in a process pool sized to the
machine (`--workers`, 1 = this process) or on a Dask cluster (`--scheduler`).

Nothing is lost: each finished case is kept at once in `DIR/.<name>.<key>.cases/`
(atomic writes of small netCDF files, `pipeline.study.checkpoint`); a rerun after Ctrl-C, a killed worker or a restart computes only
the missing cases.  The dataset `DIR/<name>.nc` is written atomically when all
cases are done (then the checkpoints are removed), followed by the figures under
`DIR/<name>/`.  A case that raises is logged and kept as an empty branch; the run
then exits 1 (the dataset of the other cases is still written).
"""
from __future__ import annotations

import logging
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import UsageError, interrupt_in_chain
from .cases import default_solver, run_case, separation_guard
from .checkpoint import checkpoint_dir, kept_cases, load_cases, remove_stale, save_case
from .documents import load_study
from .incomplete import incomplete_cases
from .mistuned import tuned_references
from .optimum_search import optimum_figure_of, study_optimum
from .peak_shapes import write_peak_shapes
from .response_figures import sector_output_dofs, write_figures
from .spec import SWEEP_AXES, Study, StudyResult

log = logging.getLogger("pipeline.study.run")


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
            from tqdm.auto import tqdm
            self.bar = tqdm(total=total, initial=initial, desc=desc, unit="case",
                            disable=None, file=sys.stderr)
        except ImportError:
            self.bar = None
        if self.live:
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



def _execute(study, solver, workers, scheduler, progress, cdir=None):
    """Run the cases not found in `cdir`; each finished case is kept there at once.
    Returns (results aligned with the cases, number reused from checkpoints)."""
    cases = study.sweep.cases()
    H, fr = study.solver.harmonics, study.sweep.frequency
    kw = study.solver.kwargs(study.output.yscale)  # curves smooth on the figures' axis
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
    guard = separation_guard(study) if getattr(solver, "__module__", "") == "pipeline.solve.response" else None

    def job(k):
        return (solver, study.system(cases[k][1]), H, fr.omega_start, fr.omega_stop, kw, guard)

    def done(k, res):
        results[k] = res
        if cdir is not None and res[0] is not None:
            save_case(cdir, k, cases[k][1], res[0])
        if bar is not None:
            bar.update(cases[k][1], *res)

    try:
        if scheduler and todo:
            from dask.distributed import Client, as_completed

            try:
                client = Client(scheduler, timeout=SCHEDULER_TIMEOUT)
            except (OSError, TimeoutError) as exc:
                raise SchedulerUnreachable(f"cannot reach the Dask scheduler at {scheduler} "
                                           f"({type(exc).__name__}: {exc})") from None
            with client:
                futs = [client.submit(run_case, *job(k), pure=False) for k in todo]
                index = {f.key: k for k, f in zip(todo, futs)}
                for fut in as_completed(futs):
                    done(index[fut.key], fut.result())
        elif workers > 1 and len(todo) > 1:
            from concurrent.futures import ProcessPoolExecutor, as_completed

            pool = ProcessPoolExecutor(max_workers=min(workers, len(todo)))
            try:
                futs = {pool.submit(run_case, *job(k)): k for k in todo}
                for fut in as_completed(futs):
                    done(futs[fut], fut.result())
            except BaseException as exc:  # Ctrl-C or a lost worker: stop the running cases now
                for proc in list((getattr(pool, "_processes", None) or {}).values()):
                    proc.terminate()
                pool.shutdown(wait=False, cancel_futures=True)
                from concurrent.futures.process import BrokenProcessPool
                if isinstance(exc, BrokenProcessPool):
                    raise WorkerLost("a worker process died (killed, or out of memory)") from None
                raise
            pool.shutdown()
        else:
            for k in todo:
                kwk = dict(kw)
                if bar is not None and bar.live and getattr(solver, "__name__", "") == "frequency_response":
                    kwk["callback"] = lambda x, lam: bar.frequency(lam)
                solver_k, system, H_k, a, b, _, g = job(k)
                done(k, run_case(solver_k, system, H_k, a, b, kwk, g))
    finally:
        if bar is not None:
            bar.close()
    return results, len(reused)


def keep_older_dataset(target: Path):
    """A dataset at `target` written by another pipeline version (or not readable as
    ours) is renamed, never overwritten: `<name>.v<version>.nc` / `<name>.unreadable.nc`."""
    from .. import __version__

    if not target.exists():
        return None
    try:
        import xarray as xr
        with xr.open_dataset(target, engine="netcdf4") as old:
            version = str(old.attrs.get("pipeline_version", "unknown"))
    except Exception:
        version = None
    if version == __version__:
        return None
    tag = f"v{version}" if version is not None else "unreadable"
    backup = target.with_name(f"{target.stem}.{tag}{target.suffix}")
    n = 1
    while backup.exists():
        n += 1
        backup = target.with_name(f"{target.stem}.{tag}.{n}{target.suffix}")
    target.rename(backup)
    log.warning("%s was written by %s; kept it as %s", target,
                f"pipeline {version}" if version else "something else (not readable as netCDF)",
                backup.name)
    return backup


def run_study(study: Study, out_dir="results", *, workers: int = 1, scheduler: str | None = None,
              solver=None, figures: bool = True, progress: bool = True,
              checkpoints: bool = True) -> StudyResult:
    """Run every case of `study`, write `out_dir/<name>.nc` and the figures.

    With `checkpoints`, each finished case is kept in `checkpoint_dir` as soon as
    it ends; a rerun after an interruption computes only the missing cases, and
    the directory is removed once the dataset is written."""
    from .dataset import to_dataset, write_netcdf

    if getattr(study, "kind", "response") == "disk_modes":  # per nodal diameter (disk_modes.py)
        from .disk_modes import run_disk_modes_study
        return run_disk_modes_study(study, out_dir, figures=figures)
    if getattr(study, "kind", "response") == "modes":  # blade modal study (modes.py)
        from .modes import run_modes_study
        return run_modes_study(study, out_dir, figures=figures)
    if getattr(study, "kind", "response") == "accuracy_cost":  # pipeline/study/accuracy_cost.py
        from .accuracy_cost import run_accuracy_study
        return run_accuracy_study(study, out_dir, figures=figures, progress=progress)
    t0 = time.perf_counter()
    solver = solver or default_solver(study)
    out_dir = Path(out_dir)
    log.info("%s: %d case(s) %s, H = %d, %s forces%s", study.name, len(study.sweep.cases()),
             dict(zip(study.sweep.axes, study.sweep.shape)), study.solver.harmonics,
             study.solver.force_evaluation, " (quick)" if study.quick else "")
    fresh_out = not out_dir.exists()
    cdir = checkpoint_dir(study, out_dir, solver) if checkpoints else None
    if cdir is not None:
        remove_stale(out_dir, study.name, cdir)
    results, reused = _execute(study, solver, workers, scheduler, progress, cdir)
    curves = [c for c, _ in results]
    errors = [e for _, e in results]
    failures = sum(c is None for c in curves)
    optimum, optimum_error = study_optimum(study, solver, curves, cdir)
    tuned = None
    if getattr(study.scene, "mistuning", None) is not None and int(sum(
            c is not None for c in curves)):   # the tuned disk the mistuning is read against
        tuned = tuned_references(study, sector_output_dofs(study), solver)
    ds = to_dataset(study, curves, errors, optimum=optimum, tuned=tuned)
    res = StudyResult(study=study, dataset=ds, path=None, failures=failures,
                      reused=reused, computed=len(curves) - reused, optimum_error=optimum_error,
                      failed=[(case, err) for (_, case), c, err in zip(study.sweep.cases(), curves,
                                                                       errors) if c is None])
    if int(ds["converged"].sum()) == 0:
        log.error("%s: no converged point in any case; nothing written", study.name)
        if cdir is not None:  # nothing worth resuming
            import shutil
            shutil.rmtree(cdir, ignore_errors=True)
            if fresh_out and out_dir.is_dir() and not any(out_dir.iterdir()):
                out_dir.rmdir()
        res.wall_time = time.perf_counter() - t0
        return res
    target = out_dir / f"{study.name}.nc"
    keep_older_dataset(target)
    res.path = write_netcdf(ds, target)
    log.info("wrote %s", res.path)
    if cdir is not None and failures == 0:
        import shutil
        shutil.rmtree(cdir, ignore_errors=True)
    elif cdir is not None:
        log.info("%s: %d case(s) failed; the finished ones stay in %s, a rerun retries "
                 "only the failed ones", study.name, failures, cdir)
    if figures:
        res.figures = (write_figures(study, ds, out_dir / study.name, tuned)
                       + write_peak_shapes(study, ds, curves, out_dir / study.name))
        if optimum is not None:   # the peak-versus-preload curve the optimum was found on
            res.figures.append(optimum_figure_of(study, optimum, out_dir / study.name))
        for p in res.figures:
            log.info("wrote %s", p)
    res.wall_time = time.perf_counter() - t0
    return res






def configure_run_parser(r):
    r.add_argument("study", metavar="STUDY.toml", help="study file (see studies/README.md)")
    r.add_argument("--out", default="results", metavar="DIR",
                   help="output directory: DIR/<name>.nc and DIR/<name>/*.png (default: results)")
    r.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes (default: one per CPU core; 1 = run in this process)")
    r.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address, e.g. tcp://host:8786 (overrides --workers)")
    r.add_argument("--quick", action="store_true",
                   help="use the study's [quick] overrides (fewer cases, fewer harmonics)")
    r.add_argument("--no-figures", dest="figures", action="store_false", help="skip the figures")
    r.set_defaults(func=cmd_run)


def check_writable(file, out: Path):
    """UsageError unless `out` is (or can be made) a directory we can write in,
    checked before any computing."""
    import os
    import tempfile

    if out.exists() and not out.is_dir():
        raise UsageError(f"{file}: --out: {out} exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".write-test.", dir=out)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise UsageError(f"{file}: --out: {out} is not writable "
                         f"({exc.strerror or type(exc).__name__})") from None


class sigint_interrupts:
    """Context manager: SIGINT raises KeyboardInterrupt for the whole block, also when
    the process started with SIGINT ignored (`nohup`, `cmd &` in a script), so an
    interrupt at any stage (cases, optimum search, final write, figures) stops the
    run the same way; the previous handler is restored on exit.  An interrupt that
    a compiled kernel's dispatcher wrapped in a SystemError leaves the block as the
    KeyboardInterrupt it is (`interrupt_in_chain`).  No-op outside the main thread
    (signal handlers can only be set there)."""

    def __enter__(self):
        import signal
        import threading

        self._old = None
        if threading.current_thread() is threading.main_thread():
            self._old = signal.signal(signal.SIGINT, signal.default_int_handler)
        return self

    def __exit__(self, exc_type, exc, tb):
        import signal

        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
        if isinstance(exc, SystemError) and interrupt_in_chain(exc):
            raise KeyboardInterrupt from exc
        return False


def configure_logging(verbose: bool):
    """Root logging for the command line; scikit-fem's per-step INFO lines and the
    continuation's per-branch summary only with --verbose."""
    logging.basicConfig(level=logging.DEBUG if verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s")
    quiet = logging.NOTSET if verbose else logging.WARNING
    for name in ("skfem", "pipeline.solve.continuation"):
        logging.getLogger(name).setLevel(quiet)


def _kept(out, name) -> str:
    """Where the finished cases are, said only when a folder holds some."""
    d, n = kept_cases(out, name)
    if d is None:
        return "no finished case was kept"
    return f"{n} finished case(s) are kept in {d}, rerun the same command to resume"


def _case_words(case: dict) -> str:
    """'preload = 10 N, ...': a case's sweep values with their units."""
    return ", ".join(f"{k} = {v:g}" + ("" if SWEEP_AXES[k][0] == "1" else f" {SWEEP_AXES[k][0]}")
                     for k, v in case.items())


def cmd_run(args) -> int:
    """`python -m pipeline run`: 0 ok, 1 a case failed or nothing converged, 2 bad input."""
    try:
        study = load_study(args.study, quick=getattr(args, "quick", False))
        workers = getattr(args, "workers", None)
        if workers is None:
            import os
            workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
        if workers < 1:
            raise UsageError(f"{args.study}: --workers: must be >= 1, got {workers}")
        out = Path(getattr(args, "out", "results"))
        check_writable(args.study, out)
        scheduler = getattr(args, "scheduler", None)
        if scheduler:
            try:
                import dask.distributed  # noqa: F401
            except ImportError:
                raise UsageError(f"{args.study}: --scheduler: dask.distributed is not installed "
                                 "(pip install 'dask[distributed]')") from None
    except UsageError as exc:
        # printed here too so the one-line contract holds however `run` is wired
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        solver = default_solver(study)
    except RuntimeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    try:
        with sigint_interrupts():
            res = run_study(study, out, workers=workers, scheduler=scheduler, solver=solver,
                            figures=getattr(args, "figures", True))
    except OSError as exc:
        print(f"error: {args.study}: --out: cannot write: {exc}; {_kept(out, study.name)}",
              file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"interrupted: {_kept(out, study.name)}", file=sys.stderr)
        return 130
    except SchedulerUnreachable as exc:
        print(f"error: {args.study}: --scheduler: {exc}", file=sys.stderr)
        return 2
    except WorkerLost as exc:
        print(f"error: {args.study}: {exc}; {_kept(out, study.name)}", file=sys.stderr)
        return 1
    for case, reason in res.failed:  # one line each, whether or not a progress bar hid the log
        print(f"error: {args.study}: case {_case_words(case)}: {reason}", file=sys.stderr)
    for case, what in incomplete_cases(study, res.dataset):  # a peak that may lie beyond
        print(f"warning: {args.study}: case {_case_words(case)}: {what}", file=sys.stderr)
    if res.reused:
        log.info("%s: %d case(s) reused from the interrupted run, %d computed",
                 study.name, res.reused, res.computed)
    log.info("%s: done in %.1f s", study.name, res.wall_time)
    return 0 if res.ok else 1


def main(argv=None) -> int:
    """`python -m pipeline.study.run STUDY.toml ...` (same as `python -m pipeline run`)."""
    import argparse

    p = argparse.ArgumentParser(prog="python -m pipeline.study.run", description=__doc__.splitlines()[0])
    p.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    configure_run_parser(p)
    args = p.parse_args(argv)
    configure_logging(args.verbose)
    try:
        return cmd_run(args)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())


# ---------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------

def add_run_parser(subparsers):
    """Register `run` on the CLI's subparsers (`pipeline/__main__.py`)."""
    r = subparsers.add_parser("run", help="run a study file: dataset (netCDF) and figures")
    configure_run_parser(r)
    return r
