"""`check`: a study validated without computing, or a dataset against its contract.

    shroud check STUDY.toml [--quick] [--workers N]
    shroud check FILE.nc

A study prints its cases (the sweep grid), solver settings, output and an
estimated cost; a bad study is the usual one line `error: <file>: <field>: <what>`
and exit 2.  The estimate of a lumped or disk scene times a few residual
evaluations (with Jacobian) of its first case at the study's H, at the middle of
the frequency range from the linear response, and multiplies by the ratio of a
whole case's wall time to that evaluation measured on the paper examples (serial
runs of their studies, `--workers 1`, against the same timing: Example 1 at H = 7,
0.10-0.32 s per case for 0.12 ms, 840-2600; Example 2 at H = 7, 0.39-0.57 s for
0.20 ms, 1950-2850; Example 3 at H = 14, 0.13-1.7 s for 0.15 ms, 880-11100, the most
where the exact flow checks the stability of a separating contact: EVALS_PER_CASE
evaluations' worth per case, continuation, dense output for the figures, recovery,
stability and peak refinement included).  An optimum-preload search costs about
OPTIMUM_CURVES cases: its grid and refinement take 19-20 evaluations on the paper
examples (Example 1 once took 0.7 s for the 10 of a bounded Brent).  It is a rough
guide: a case with many more points or folds costs more.  An FE blade is not built for the estimate (that alone
takes seconds to minutes); its figure is the measured time per case of
studies/blade_shroud_contact.toml (full mesh: 8.7-14.4 s; quick mesh: 2.7 s).  A
dataset is checked by `pipeline.study.dataset_check.problems`.
"""
from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from ..solve import hbm
from ..errors import UsageError
from ..solve.response import initial_guess

EVALS_PER_CASE = (800, 12000)  # a case's wall time / one residual evaluation (docstring)
OPTIMUM_CURVES = 12             # an optimum-preload search: about 12 cases' worth (docstring)
BLADE_CASE_S = (9.0, 15.0)      # studies/blade_shroud_contact.toml, H = 3, per case, 2 cores
BLADE_QUICK_CASE_S = (2.0, 4.0)  # the same with its [quick] mesh


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


def _seconds(t: float) -> str:
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
        lines.append("estimated cost: one full and one reduced eigen-solve per mode count "
                     "(no timing without building the mesh)")
        return lines
    if kind == "disk_modes":
        sc = study.scene
        lines.append(f"scene: disk of {sc.assembly.sectors} sectors, {len(sc.sector_dofs)} DOF(s) "
                     f"per sector, {len(sc.contacts)} contact(s); nodal diameters "
                     f"{', '.join(map(str, study.nodal_diameters))}; {study.n_frequencies} "
                     "frequencies each, contacts open and stuck")
        lines.append(f"estimated cost: {2 * len(study.nodal_diameters)} sector eigen-solves")
        return lines
    if kind == "accuracy_cost":
        for c in study.cases:
            runs = c.runs()
            lines.append(f"case {c.name}: {c.scene.model}, dof {c.dof}, {c.frequency.start:g} to "
                         f"{c.frequency.stop:g} {c.frequency.unit}; {len(runs)} runs "
                         f"(reference, baseline, {len(runs) - 2} knob values) x {c.repeats} "
                         "timing repeat(s)")
        lines.append("estimated cost: see README 'Accuracy vs cost' (measured wall times)")
        return lines
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


def estimate(study, n_cases: int, workers: int, linear: bool) -> list:
    """Cost lines (see the module docstring for what they are based on)."""
    w = max(1, min(workers, n_cases))
    if linear:
        return [f"estimated cost: {n_cases} direct solve sweep(s), well under 1 s each"]
    bound = f"at most {n_cases * study.solver.max_points} points in all"
    if study.scene.model in ("beam_blade", "solid_blade"):
        lo, hi = BLADE_QUICK_CASE_S if study.quick else BLADE_CASE_S
        return [f"estimated cost: {n_cases} case(s) x {lo:.0f}-{hi:.0f} s (measured per case "
                f"of studies/blade_shroud_contact.toml{' --quick' if study.quick else ''} at "
                "H = 3 on the 2-core machine; grows with H and the mesh) = "
                f"{_range(n_cases * lo / w, n_cases * hi / w)} on {w} worker(s); {bound}"]
    t_eval = time_residual(study)
    lo, hi = (k * t_eval for k in EVALS_PER_CASE)
    extra = OPTIMUM_CURVES if study.output.optimum is not None else 0
    search = (f", plus the optimum-preload search {_range(extra * lo, extra * hi)}"
              if extra else "")
    return [f"estimated cost: one residual evaluation {t_eval * 1e3:.3g} ms (timed now), "
            f"a case as long as {EVALS_PER_CASE[0]}-{EVALS_PER_CASE[1]} of them (measured on the "
            f"paper examples) = {_range(lo, hi)} per case, "
            f"{_range(n_cases * lo / w, n_cases * hi / w)} for {n_cases} case(s) on {w} "
            f"worker(s){search} (a rough guide; {bound})"]


def _range(lo: float, hi: float) -> str:
    a, b = _seconds(lo), _seconds(hi)
    if a == b:
        return a
    return f"up to {b}" if lo < 1.0 else f"{a} to {b}"


def time_residual(study, repeats: int = 5) -> float:
    """Median wall time [s] of one residual + Jacobian of the first case at the
    middle of the frequency range, from the linear response there."""
    sv, fr = study.solver, study.sweep.frequency
    system = study.system(study.sweep.cases()[0][1])
    prob = hbm.setup(system, sv.harmonics, sv.force_evaluation, sv.samples)
    om = math.sqrt(fr.omega_start * fr.omega_stop)
    x = initial_guess(prob, om, system.contact)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        hbm.residual(prob, x, om, system.contact)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))
