"""`check`: a study validated without computing, or a dataset against its contract.

    shroud check STUDY.toml [--quick] [--workers N]
    shroud check FILE.nc

A study prints its cases (the sweep grid), solver settings, output, the size of the
model it builds and an estimated cost; a bad study is the usual one line
`error: <file>: <field>: <what>` and exit 2.  The estimate (`pipeline.study.cost`)
times the residual and the Newton solve of the model the run builds (the quick one
with --quick) and multiplies by points per case and work per point calibrated on the
shipped studies (`python -m pipeline bench estimate`); it prints what it assumes.
A dataset is checked by `pipeline.study.dataset_check.problems`.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

from ..errors import UsageError


def check(path, quick: bool = False, workers: int | None = None, out=None) -> int:
    """0 valid, 1 a dataset with problems, 2 a bad study or unreadable file."""
    out = out or sys.stdout
    path = Path(path)
    if path.suffix == ".nc":
        return check_dataset(path, out)
    from .documents import load_study

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
    from .dataset_check import problems  # deferred: xarray (slow import)

    found = list(problems(path))  # each line names the file
    for p in found:
        print(p, file=out)
    if found:
        print(f"{path}: {len(found)} problem(s) against the dataset contract", file=out)
        return 1
    print(f"{path}: meets the dataset contract", file=out)
    return 0


def _has_quick(text: str) -> bool:
    import tomllib
    try:
        return "quick" in tomllib.loads(text)
    except Exception:
        return False


def _num(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def seconds(t: float) -> str:
    """A duration [s] as the estimates print it."""
    if t < 1.0:
        return "under 1 s"
    if t < 120.0:
        return f"{t:.0f} s"
    if t < 7200.0:
        return f"{t / 60:.0f} min"
    return f"{t / 3600:.1f} h"


def describe(study, workers: int = 1, has_quick: bool = False) -> list:
    """The lines `check` prints for a valid study."""
    kind = getattr(study, "kind", "response")
    variant = "quick variant" if study.quick else (
        "full variant; [quick] not checked (check --quick does)" if has_quick else "full variant")
    lines = [f"{study.file}: valid {kind} study ({variant})", f"title: {study.title}"]
    if kind == "modes":
        sc = study.scene
        lines.append(f"scene: {sc.model}, Craig-Bampton mode counts "
                     f"{', '.join(map(str, study.mode_counts))}; {study.n_frequencies} "
                     "frequencies compared with the full model")
        return lines + _kind_estimate(study)
    if kind == "disk_modes":
        sc = study.scene
        lines.append(f"scene: disk of {sc.assembly.sectors} sectors, {len(sc.sector_dofs)} DOF(s) "
                     f"per sector, {len(sc.contacts)} contact(s); nodal diameters "
                     f"{', '.join(map(str, study.nodal_diameters))}; {study.n_frequencies} "
                     "frequencies each, contacts open and stuck")
        return lines + _kind_estimate(study)
    if kind == "accuracy_cost":
        for c in study.cases:
            runs = c.runs()
            lines.append(f"case {c.name}: {c.scene.model}, dof {c.dof}, {c.frequency.start:g} to "
                         f"{c.frequency.stop:g} {c.frequency.unit}; {len(runs)} runs "
                         f"(reference, baseline, {len(runs) - 2} knob values) x {c.repeats} "
                         "timing repeat(s)")
        return lines + _kind_estimate(study)
    sc, sw, sv = study.scene, study.sweep, study.solver
    n_cases = len(sw.cases())
    contacts = getattr(sc, "contacts", ())
    ndof = len(getattr(sc, "dofs", ()) or ())
    lines.append(f"scene: {sc.model}, {ndof} DOF(s), {len(contacts)} contact(s); effects: "
                 f"{', '.join(sc.effects) or 'none (linear)'}")
    grid = " x ".join(f"{a} ({len(v)})" for a, v in sw.axes.items()) or "one case"
    lines.append(f"cases: {n_cases} = {grid}")
    from .spec import SWEEP_AXES
    for a, v in sw.axes.items():
        unit = SWEEP_AXES[a][0]
        lines.append(f"  {a}{'' if unit == '1' else f' [{unit}]'}: {', '.join(_num(x) for x in v)}")
    fr = sw.frequency
    lines.append(f"frequency: {fr.start:g} to {fr.stop:g} {fr.unit} (continuation)")
    from .spec import is_linear_scene
    linear = is_linear_scene(sc)
    if linear:
        lines.append("solver: direct linear solve per frequency (no contact: no Newton, "
                     "no continuation)")
    else:
        steps = ", ".join(f"{k.replace('_', ' ')} {getattr(sv, k):g}" for k in
                          ("initial_step", "max_step") if getattr(sv, k) is not None)
        lines.append(f"solver: H = {sv.harmonics}, {sv.force_evaluation} forces"
                     + (f" ({sv.samples} samples per period)" if sv.force_evaluation == "aft" else "")
                     + f", tolerance {sv.tolerance:g} (relative), stability "
                     f"{sv.stability or 'off'}, at most {sv.max_points} points per case"
                     + (f", {steps}" if steps else ""))
    o = study.output
    lines.append(f"output: dofs {', '.join(o.dofs)}; figures {', '.join(o.figures) or 'none'}"
                 + (f"; optimum-preload search on {o.optimum['dof']} in "
                    f"[{o.optimum['bounds'][0]:g}, {o.optimum['bounds'][1]:g}] N"
                    if o.optimum else ""))
    lines += estimate(study, n_cases, workers, linear)
    return lines


def _kind_estimate(study) -> list:
    """The cost line of a modes, disk-modes or accuracy-cost study (`kind_costs`)."""
    from .kind_costs import estimate_kind

    e = estimate_kind(study)
    return [f"estimated cost: {_range(e.lo, e.hi)} (middle {seconds(e.mid)}): {e.detail}; "
            "calibrated on the shipped studies (bench estimate)"]


def estimate(study, n_cases: int, workers: int, linear: bool) -> list:
    """The model and cost lines (`pipeline.study.cost`: what they assume)."""
    if linear:
        return [f"estimated cost: {n_cases} direct solve sweep(s), well under 1 s each"]
    from .cost import estimate as cost_estimate, model_line

    lines = [model_line(study)]
    e = cost_estimate(study, workers)
    tm = e.timing
    search = (f", of which the optimum-preload search {_range(*e.search)}" if e.search else "")
    lines.append(
        f"estimated cost: {_range(e.lo, e.hi)} (middle {seconds(e.mid)}) for {n_cases} case(s) "
        f"on {e.workers} worker(s){search}")
    lines.append(
        f"  assumes {e.points[0]:.0f}-{e.points[1]:.0f} points per case ({e.modes} natural "
        f"frequencies in the range) at {e.per_point[0] * 1e3:.3g}-{e.per_point[1] * 1e3:.3g} "
        f"ms each (residual + Jacobian {tm.t_residual * 1e3:.3g} ms and Newton solve "
        f"{tm.t_solve * 1e3:.3g} ms of {tm.unknowns} unknowns, timed now on this model, "
        f"{e.pairs[0]:g}-{e.pairs[1]:g} times a point, plus bookkeeping and stability {study.solver.stability or 'off'}) = "
        f"{_range(*e.case)} per case; model build and reduction {seconds(tm.setup)}; this "
        f"machine {tm.slowdown:.2g}x slower than an idle core now; "
        "calibrated on the shipped studies (bench estimate), compiled kernels cached; a "
        "curve with many more folds costs more")
    return lines


def _range(lo: float, hi: float) -> str:
    a, b = seconds(lo), seconds(hi)
    if a == b:
        return a
    return f"up to {b}" if lo < 1.0 else f"{a} to {b}"
