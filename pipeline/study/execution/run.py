"""Run a study: grid of sweep cases -> response curves -> dataset -> figures.

    python -m pipeline run STUDY.toml [--out DIR] [--workers N] [--scheduler ADDRESS] [--quick]

Each grid case (one combination of the `[sweep]` axes) is one frequency
continuation `pipeline.solve.response.response.frequency_response(system, H, omega_start,
omega_stop, **solver.kwargs())`, or one direct solve per frequency for a linear
scene (`pipeline.solve.response.linear_response`).  Cases run in a process pool sized to the
machine (`--workers`, 1 = this process) or on a Dask cluster (`--scheduler`).

Nothing is lost: each finished case is kept at once in `DIR/.<name>.<key>.cases/`
(atomic writes of small netCDF files, `pipeline.study.execution.checkpoint`); a rerun after Ctrl-C, a killed worker or a restart computes only
the missing cases.  The dataset `DIR/<name>.nc` is written atomically when all
cases are done (then the checkpoints are removed), followed by the figures under
`DIR/<name>/`.  A case that raises is logged and kept as an empty branch; the run
then exits 1 (the dataset of the other cases is still written).

That is a response study (`response_study`); every kind of study is run through
its registry entry (`kinds`).
"""
from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import tempfile
import threading
from dataclasses import replace
from pathlib import Path

from ...errors import UsageError, interrupt_in_chain
from .cases import SchedulerUnreachable, WorkerLost, default_solver
from .checkpoint import kept_cases
from .optimum_search import dataset_warnings
from .run_parser import configure_logging, configure_run_parser
from ..files.documents import load_study, text_describes
from ..datasets.free_direction import free_direction_notes
from ..datasets.incomplete import (absent_effects, edge_peaks, hidden_peaks, incomplete_cases,
                                   window_edges)
from ..kinds import kind_of
from ..files.study_types import SWEEP_AXES, StudyResult

log = logging.getLogger("pipeline.study.execution.run")


def run_study(study, out_dir="results", *, workers: int = 1, scheduler: str | None = None,
              solver=None, figures: bool = True, progress: bool = True,
              checkpoints: bool = True) -> StudyResult:
    """Run a validated study of any kind (`kinds`), write `out_dir/<name>.nc` and its
    figures; a response study's options (`response_study.run_response_study`):
    `workers` processes or a Dask `scheduler`, the `solver` of its cases, `progress`,
    and `checkpoints` (each finished case kept, a rerun computes only the missing
    ones).  Other kinds take `figures` (and `progress`) only.  A study changed in
    Python after loading runs without its text (`files.documents.text_describes`): its
    dataset does not carry a text that describes another study, nor are the
    checkpoints of that other study reused."""
    if study.text and not text_describes(study):
        log.info("%s: changed after loading %s: its text is not written to the dataset",
                 study.name, study.file)
        study = replace(study, text="")
    return kind_of(study).run(study, out_dir, workers=workers, scheduler=scheduler,
                              solver=solver, figures=figures, progress=progress,
                              checkpoints=checkpoints)


WRITTEN = (".png", ".vtu", ".md")   # the suffixes of what a run writes in out/<name>/


def check_writable(file, out: Path, name: str | None = None, dataset: bool = True):
    """UsageError unless `out` is (or can be made) a directory we can write in and,
    for the study `name`, its dataset `out/<name>.nc` can be a file (`dataset`) and its
    folder `out/<name>/` (figures, mode shapes, tables: some kinds write there even
    without figures) a folder, not a file nor a broken link: checked before any
    computing, so that a blocked path never costs a run nor leaves a dataset alone.
    Inside that folder a folder named like the files a run writes there (`WRITTEN`:
    figures, mode shapes, tables; they replace files and links) is refused too."""
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
    if name is None:
        return
    nc, folder = out / f"{name}.nc", out / name
    if dataset and nc.exists() and not nc.is_file():
        raise UsageError(f"{file}: --out: {nc} (the dataset) exists and is not a file")
    if os.path.lexists(folder) and not folder.is_dir():
        raise UsageError(f"{file}: --out: {folder} (the study's folder of figures) exists and "
                         "is not a directory" + (" (a broken link)" if folder.is_symlink()
                                                 and not folder.exists() else ""))
    try:   # a figure, mode shapes or table of ours would be replaced there: not a folder
        taken = sorted(p.name for p in folder.iterdir() if p.suffix in WRITTEN
                       and p.is_dir()) if folder.is_dir() else []
    except OSError as exc:
        raise UsageError(f"{file}: --out: {folder} is not readable "
                         f"({exc.strerror or type(exc).__name__})") from None
    if taken:
        raise UsageError(f"{file}: --out: {folder / taken[0]} exists and is a folder")


class sigint_interrupts:
    """Context manager: SIGINT raises KeyboardInterrupt for the whole block, also when
    the process started with SIGINT ignored (`nohup`, `cmd &` in a script), so an
    interrupt at any stage (cases, optimum search, final write, figures) stops the
    run the same way; the previous handler is restored on exit.  An interrupt that
    a compiled kernel's dispatcher wrapped in a SystemError leaves the block as the
    KeyboardInterrupt it is (`interrupt_in_chain`).  No-op outside the main thread
    (signal handlers can only be set there)."""

    def __enter__(self):
        self._old = None
        if threading.current_thread() is threading.main_thread():
            self._old = signal.signal(signal.SIGINT, signal.default_int_handler)
        return self

    def __exit__(self, exc_type, exc, tb):
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
        if isinstance(exc, SystemError) and interrupt_in_chain(exc):
            raise KeyboardInterrupt from exc
        return False


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


def warnings(file, study, ds) -> list:
    """The `warning: <file>: <where>: <what>` lines of a finished run: incomplete cases,
    largest amplitudes at the range's end, peaks that may hide between two points
    (resonance steps not resolved), declared effects no case shows, 1D shroud pairs
    whose faces move along the direction they leave free (`free_direction`), an
    optimum at its window's end (printed, so that no progress bar hides them)."""
    edges = edge_peaks(study, ds)
    out = [f"warning: {file}: case {_case_words(case)}: {what}"
           for case, what in (incomplete_cases(study, ds) + edges + window_edges(study, ds)
                              + hidden_peaks(study, ds, [c for c, _ in edges]))]
    out += [f"warning: {file}: scene.effects: {what}" for what in absent_effects(study, ds)]
    out += [f"warning: {file}: {field}: " + (f"case {_case_words(case)}: " if case else "") + what
            for field, case, what in free_direction_notes(study, ds)]
    out += [f"warning: {file}: {field}: {what}" for field, what in dataset_warnings(study, ds)]
    return out


def cmd_run(args) -> int:
    """`python -m pipeline run`: 0 ok, 1 a case failed or nothing converged, 2 bad input."""
    try:
        study = load_study(args.study, quick=getattr(args, "quick", False))
        workers = getattr(args, "workers", None)
        if workers is None:
            workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
        if workers < 1:
            raise UsageError(f"{args.study}: --workers: must be >= 1, got {workers}")
        out = Path(getattr(args, "out", "results"))
        check_writable(args.study, out, study.name)
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
    for case, why in res.stopped:    # a backbone cut short: its points are in the dataset
        print(f"warning: {args.study}: case {_case_words(case)}: {why}", file=sys.stderr)
    for line in warnings(args.study, study, res.dataset):
        print(line, file=sys.stderr)
    if res.reused:
        log.info("%s: %d case(s) reused from the interrupted run, %d computed",
                 study.name, res.reused, res.computed)
    log.info("%s: done in %.1f s", study.name, res.wall_time)
    return 0 if res.ok else 1


def main(argv=None) -> int:
    """`python -m pipeline.study.execution.run STUDY.toml ...` (same as `python -m pipeline run`)."""
    p = argparse.ArgumentParser(prog="python -m pipeline.study.execution.run", description=__doc__.splitlines()[0])
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
