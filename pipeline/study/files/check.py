"""`check`: a study validated without computing, or a dataset against its contract.

    shroud check STUDY.toml [--quick] [--workers N]
    shroud check FILE.nc

A study prints what its kind says of it (`kinds`: a response study its cases, the
sweep grid, solver settings, output, the size of the model it builds) and an
estimated cost; a bad study is the usual one line `error: <file>: <field>: <what>`
and exit 2.  The estimate of a response study (`pipeline.study.execution.cost`) times the residual and the Newton solve of the model the run builds (the quick one
with --quick) and multiplies by points per case and work per point calibrated on the
shipped studies (`python -m pipeline bench estimate`); it prints what it assumes.
A dataset is checked by `pipeline.study.datasets.conformance.problems`.
"""
from __future__ import annotations

import os
import sys
import tomllib
from pathlib import Path

from ...errors import UsageError
from ..datasets.conformance import problems
from ..kinds import kind_of
from .documents import load_study


def check(path, quick: bool = False, workers: int | None = None, out=None) -> int:
    """0 valid, 1 a dataset with problems, 2 a bad study or unreadable file."""
    out = out or sys.stdout
    path = Path(path)
    if path.suffix == ".nc":
        return check_dataset(path, out)

    try:
        study = load_study(path, quick=quick)
        if workers is not None and workers < 1:
            raise UsageError(f"{path}: --workers: must be >= 1, got {workers}")
    except UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if workers is None:
        workers = (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                   else (os.cpu_count() or 1))
    for line in describe(study, workers, has_quick=_has_quick(study.text)):
        print(line, file=out)
    return 0


def check_dataset(path: Path, out) -> int:
    if not path.is_file():
        print(f"error: {path}: (file): no such file", file=sys.stderr)
        return 2

    found = list(problems(path))  # each line names the file
    for p in found:
        print(p, file=out)
    if found:
        print(f"{path}: {len(found)} problem(s) against the dataset contract", file=out)
        return 1
    print(f"{path}: meets the dataset contract", file=out)
    return 0


def _has_quick(text: str) -> bool:
    try:
        return "quick" in tomllib.loads(text)
    except Exception:
        return False


def describe(study, workers: int = 1, has_quick: bool = False) -> list:
    """The lines `check` prints for a valid study: what it is, then what its kind says
    of it (`kinds`), the cost estimate included."""
    variant = ("quick variant" if has_quick else "quick variant: no [quick] table, the "
               "full study") if study.quick else (
        "full variant; [quick] not checked (check --quick does)" if has_quick else "full variant")
    lines = [f"{study.file}: valid {study.kind} study ({variant})", f"title: {study.title}"]
    return lines + kind_of(study).describe(study, workers)
