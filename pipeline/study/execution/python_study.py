"""A response study built in Python (the `Study` and scene objects handed to
`run.run_study`, `studies/python_example.py`) meets the study file's rules, read on
the objects themselves: the declared effects against the scene's contacts under
every law (`files.rules.check_scene_rules`), its disk and its 2D friction, the
harmonics (an integer H >= 1 covering the excitation), the solver's cross-field rules
and every sweep axis (a known name, not empty, finite real numbers: Python, numpy).
What the file's syntax limits (a DOF count, a range of ku) is not a rule of the
objects.  Nothing is built (no mesh, no reduction, no system), so it costs
microseconds; misuse raises one `UsageError("<name: built in Python>: <field>:
<what>")` before any case runs or anything is written.
"""
from __future__ import annotations

import math
import numbers

import numpy as np

from ...contact.registry import study_laws
from ...model.scene import Lumped
from ..files.rules import check_optimum_axes, check_scene_rules, contact_rules
from ..files.study_types import EFFECTS, INTEGER_SWEEP_AXES, SWEEP_AXES, solver_rule_violations
from ..files.validation import Checker
from ..scenes import blade_wheel_scene as blade_disk
from ..scenes import lumped_disk_scene as disk_scene
from ..scenes.law_scene import check_law_effects, check_law_methods, check_law_solvers


def check_python_study(study) -> None:
    """Raise the `UsageError` of the first rule a response study built in Python
    breaks (see the module docstring); a study read from its file (it has its text)
    was checked when it was read."""
    if study.text:
        return
    ck = Checker(f"<{study.name}: built in Python>")
    sc, sv = study.scene, study.solver
    for i, e in enumerate(sc.effects):
        if e not in EFFECTS:
            ck.fail(f"scene.effects[{i}]", f"unknown effect {e!r} (known: {', '.join(EFFECTS)})")
    axes = sweep_axes(ck, study.sweep.axes)
    if isinstance(sv.harmonics, bool) or not isinstance(sv.harmonics, numbers.Integral) \
            or sv.harmonics < 1:
        ck.fail("solver.harmonics", f"must be an integer >= 1, got {sv.harmonics!r}")
    for k, what in solver_rule_violations(sv):
        ck.fail(f"solver.{k}", what)
    if isinstance(sc.structure, Lumped):
        check_law_solvers(ck, sc.laws, sv.stability, "solver.stability")
        check_law_methods(ck, sc.laws, sv.force_evaluation, "solver.force_evaluation")
        check_law_effects(ck, {table: any(isinstance(le.law, cls) for le in sc.laws)
                               for table, cls in study_laws().items()}, sc.effects)
    else:
        blade_disk.check_interference(ck, sc.contacts, axes, "sweep")
        blade_disk.check_interference_search(ck, sc.contacts, study.output.optimum, axes, "sweep")
        blade_disk.check_friction(ck, sc, sv, "solver")
    check_scene_rules(ck, sc.effects, contact_rules(sc), excited_harmonic(sc.loads),
                      int(sv.harmonics), axes, "solver", "sweep", disk=sc.cyclic,
                      can_turn=blade_disk.can_turn(sc),
                      speed=getattr(sc.structure, "speed", 0.0) or 0.0)
    if sc.cyclic:
        optimum = {"optimum_preload": True} if study.output.optimum is not None else {}
        disk_scene.check_disk_rules(ck, sc, axes, "sweep", {"output": optimum})
    check_optimum_axes(ck, study.output, axes, "sweep")


def sweep_axes(ck, axes) -> dict:
    """{axis: tuple of floats} of a Python-built sweep: known axis names, each a
    non-empty sequence of finite real numbers (numpy scalars too), integers on the
    integer axes (`study_types.INTEGER_SWEEP_AXES`)."""
    if not isinstance(axes, dict):
        ck.fail("sweep", f"axes must be a dict {{axis: values}}, got {type(axes).__name__}")
    out = {}
    for a, values in axes.items():
        f = f"sweep.{a}"
        if a not in SWEEP_AXES:
            ck.fail(f, f"unknown sweep axis (known: {', '.join(SWEEP_AXES)})")
        try:
            values = tuple(values)
        except TypeError:
            ck.fail(f, f"must be a sequence of numbers, got {type(values).__name__}")
        if not values:
            ck.fail(f, "must not be empty")
        for i, v in enumerate(values):
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real) \
                    or not math.isfinite(v):
                ck.fail(f"{f}[{i}]", f"must be a finite number, got {v!r}")
            if a in INTEGER_SWEEP_AXES and v != int(v):
                ck.fail(f"{f}[{i}]", f"must be an integer, got {v!r}")
        out[a] = tuple(int(v) if a in INTEGER_SWEEP_AXES else float(v) for v in values)
    return out


def excited_harmonic(loads) -> int:
    """The highest harmonic any load carries: a `PointLoad`'s own, a `Forcing`'s highest
    column with a non-zero amplitude."""
    h = 0
    for ld in loads:
        if hasattr(ld, "harmonic"):
            h = max(h, int(ld.harmonic))
        else:
            cols = np.flatnonzero(np.any(np.asarray(ld.amplitudes) != 0, axis=0))
            h = max(h, int(cols[-1]) if cols.size else 0)
    return h
