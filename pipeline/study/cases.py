"""One sweep case of a study: the solver it calls for and one guarded continuation.
`run` maps these over the grid; `disk_figures` and the optimum search reuse them."""
from __future__ import annotations

import logging

from ..solve import linear_response, response
from .declared import SeparationGuard, UndeclaredSeparation, needs_guard
from .spec import Study, is_linear_scene


def default_solver(study: Study | None = None):
    """The solver of a study's cases: `linear_response.frequency_response` (direct
    solve per frequency) when the scene calls for neither friction nor separation,
    else `response.frequency_response` (HBM continuation)."""
    scene = getattr(study, "scene", None)  # an accuracy-cost study has one scene per case
    if scene is not None and is_linear_scene(scene):
        return linear_response.frequency_response
    fn = getattr(response, "frequency_response", None)
    if fn is None:
        raise RuntimeError("pipeline.solve.response.frequency_response is not available yet")
    return fn


def run_case(solver, system, H, omega_start, omega_stop, kwargs, guard=None):
    """One continuation; returns (ResponseCurve or None, error text or None).

    guard: a `declared.SeparationGuard` when the scene's normal load varies but
    separation is not declared: the continuation stops at the first point that
    separates, and every point of the finished curve is checked, so such a case
    fails instead of being solved with separation."""
    try:
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
        return None, f"{type(exc).__name__}: {exc}"
    except Exception as exc:  # numerical failures of one case must not lose the others
        logging.getLogger(__name__).exception("case failed")
        return None, f"{type(exc).__name__}: {exc}"


def separation_guard(study):
    """The `declared.SeparationGuard` of a study's cases, or None."""
    scene = getattr(study, "scene", None)
    if scene is None or not needs_guard(scene):
        return None
    names = tuple(getattr(c, "name", "") for c in getattr(scene, "contacts", ()))
    return SeparationGuard(unit=study.sweep.frequency.unit, names=names)
