"""The optimum-preload search of a study (`[output.optimum_preload]`): the study's
systems at each trial preload, its cases' peaks reused as grid nodes, the evaluations
kept on disk as they come so that an interrupted search resumes
(`peak_tracking.optimum_preload`, `search_checkpoint`)."""
from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np

from ...solve.response.optimum import FLAT_SPREAD, grid_nodes
from ...solve.response.peak_tracking import band_peak, optimum_preload
from ...model.system import negative_stiffness
from ...errors import interrupt_in_chain
from .cases import StaticDivergence, divergence, map_jobs, separation_guard
from .search_checkpoint import load_search, save_search
from ..files.spec import Study

log = logging.getLogger("pipeline.study.execution.run")


def study_optimum(study: Study, solver, curves, cdir=None, workers=1, scheduler=None,
                  early=None) -> tuple:
    """(optimum dict or None, error text or None) of a study run whose cases gave
    `curves` with `solver`: `find_optimum` (its grid on the run's `workers` or
    `scheduler`, the `early` band evaluations run beside the cases reused), the cases
    reused when they are HBM curves; a search stopped by an undeclared separation, or by
    an evaluation that raises, is an error (the dataset of the cases is written without
    it), logged."""
    from ..files.declared import UndeclaredSeparation

    if study.output.optimum is None:
        return None, None
    hbm = getattr(solver, "__module__", "") == "pipeline.solve.response.response"
    try:
        return find_optimum(study, list(zip([c for _, c in study.sweep.cases()], curves))
                            if hbm else None, cdir, workers, scheduler, early), None
    except (UndeclaredSeparation, StaticDivergence) as exc:
        log.error("%s: optimum preload search stopped: %s", study.name, exc)
        return None, str(exc)
    except Exception as exc:  # a failing evaluation must not lose the cases
        if interrupt_in_chain(exc):
            raise
        log.exception("%s: optimum preload search failed", study.name)
        return None, f"{type(exc).__name__}: {exc}"


def optimum_figure_of(study: Study, optimum: dict, fig_dir):
    """`fig_dir/optimum_preload.png`: the peak-versus-preload curve of the search."""
    from ..figures.optimum_figure import optimum_figure   # deferred: matplotlib

    return optimum_figure(Path(fig_dir) / "optimum_preload.png", optimum,
                          study.output.optimum["dof"], study.title)


def find_optimum(study: Study, cases=None, cdir=None, workers=1, scheduler=None,
                 early=None) -> dict:
    """The preload that minimises the resonant peak (`peak_tracking.optimum_preload`): a
    grid over the bounds, Brent in every bracketed minimum, the best taken; the other
    sweep axes keep the scene's own values.

    cases: [(grid case, ResponseCurve)] of the study's HBM cases; their peaks are
    reused as grid nodes where they are the search's own curve (a preload-only case,
    complete, over the search's window, its peak located exactly).  cdir: a checkpoint
    folder where the evaluations are kept as they come (`search_checkpoint`), so an
    interrupted search resumes where it stopped.  The grid's band evaluations run
    together on a local pool of `workers` processes or the Dask `scheduler`
    (`cases.map_jobs`), those in `early` ({n0: `band_peak` result}, run beside the
    cases: `planned_grid`) taken as they are; Brent's trials, continued from them,
    run here."""
    o, sv = study.output.optimum, study.solver
    w2 = negative_stiffness(study.system({"preload": o["bounds"][0]}))
    if w2 is not None:   # a structure that diverges has no resonant peak to minimise
        raise StaticDivergence(divergence(w2))
    identity, window, dof = search_identity(study)
    kw = {k: v for k, v in sv.kwargs().items() if k not in ("stability",)}
    guard, current = separation_guard(study), {}
    kept, kept_states = load_search(cdir, identity, True) if cdir is not None else ({}, {})
    free, states = case_peaks(study, cases or [], window, dof)
    states.update({n0: (kept[n0][1], q) for n0, q in kept_states.items()})
    early = {n0: r for n0, r in (early or {}).items() if r is not None}
    fr = study.sweep.frequency

    def build(n0):
        system = study.system({"preload": n0})
        if guard is not None:  # each evaluation's continuation checked (declared.py)
            current["check"] = guard.callback(system, sv.harmonics)
        return system

    def keep(n0, peak, omega, Q=None):
        kept[n0] = (peak, omega)
        kept_states[n0] = Q
        log.info("%s: optimum search: %.6g N: peak %.4g m at %.5g %s", study.name, n0, peak,
                 omega / fr.to_rad_s, fr.unit)
        if cdir is not None:
            save_search(cdir, identity, kept, kept_states)

    plain = dict(kw)   # picklable: a worker makes its own guard callback

    def grid_map(n0s, done):
        for k, n0 in enumerate(n0s):   # evaluated beside the cases
            if n0 in early:
                done(k, early[n0])
        map_jobs(search_peak, [k for k, n0 in enumerate(n0s) if n0 not in early],
                 lambda k: grid_job(study, n0s[k], plain, guard)[1:], done, workers, scheduler)

    if guard is not None:
        kw["callback"] = lambda x, lam: current["check"](x, lam)
    if kept:
        log.info("%s: optimum search resumes with %d evaluation(s) kept in %s", study.name,
                 len(kept), cdir)
    t0 = time.perf_counter()
    res = optimum_preload(build, sv.harmonics, window.omega_start, window.omega_stop, dof,
                          o["bounds"], rtol=o["rtol"], known=free, replay=kept,
                          extra_nodes=list(free), on_evaluation=keep, states=states,
                          grid_map=grid_map if (workers > 1 or scheduler or early) else None,
                          **kw)
    res["wall_time"] = time.perf_counter() - t0
    log.info("%s: optimum preload %.4g N (peak %.4g m at %.4g %s), %d evaluations (%d "
             "computed, %d reused), %d bracket(s) (%d not refined), %.1f s", study.name,
             res["preload"], res["peak"], res["peak_omega"] / fr.to_rad_s, fr.unit,
             len(res["evaluations"]), res["computed"], res["reused"], len(res["brackets"]),
             len(res["skipped"]), res["wall_time"])
    return res


def window_end(study: Study, peak_omega: float) -> str | None:
    """The warning for an optimum whose largest amplitude lies at an end of the
    search's frequency window (peak_omega [rad/s], to 1e-9 of it), else None: that
    value is no resonant peak, so the optimum would minimise an off-resonance
    amplitude."""
    window = study.output.optimum["window"] or study.sweep.frequency
    lo, hi = sorted((window.omega_start, window.omega_stop))
    if not np.isfinite(peak_omega) or min(abs(peak_omega - lo), abs(peak_omega - hi)) > 1e-9 * hi:
        return None
    u = window.to_rad_s
    return (f"at the optimum preload the largest amplitude is its value at an end of the "
            f"search's window, {peak_omega / u:.6g} {window.unit}: not a resonant peak (a "
            f"peak inside {lo / u:.6g}-{hi / u:.6g} {window.unit}, if any, is lower), so the "
            "optimum minimises an off-resonance amplitude (widen [output.optimum_preload] "
            "frequency, or [sweep] frequency)")


def search_warnings(study: Study, res: dict) -> list:
    """The end-of-search warnings of `optimise` (`find_optimum`'s result): a peak that
    does not depend on the preload, else an optimum whose largest amplitude lies at an
    end of the window; band evaluations with steps across a resonance not resolved;
    unless the optimum lies at the window's end (said already), those whose largest
    amplitude traced lies outside the window."""
    end = window_end(study, res["peak_omega"])
    what = independence(study, res.get("independent"), res.get("spread")) or end
    more = [hidden_search_peaks(res.get("unresolved", {})),
            None if end else outside_search_peaks(study, res.get("outside", []))]
    return [w for w in [what] + more if w]


def outside_search_peaks(study: Study, preloads) -> str | None:
    """The warning for the band evaluations at `preloads` [N] whose largest amplitude
    traced lies outside the window (their band peak is the largest inside), else None."""
    if not len(preloads):
        return None
    window = study.output.optimum["window"] or study.sweep.frequency
    lo, hi = sorted((window.start, window.stop))
    return (f"at preload(s) {', '.join(f'{float(n0):.6g} N' for n0 in preloads)} the largest "
            f"amplitude traced lies outside the window {lo:g}-{hi:g} {window.unit} (the "
            "branch followed beyond it): the band peak there is the largest inside the "
            "window, not that resonance")


def hidden_search_peaks(unresolved: dict) -> str | None:
    """The warning for the band evaluations {n0 [N]: steps} whose steps across a
    resonance could not be shortened to its half-power band, else None."""
    bad = {float(n0): int(k) for n0, k in unresolved.items() if k}
    if not bad:
        return None
    where = ", ".join(f"{n0:.6g} N ({k})" for n0, k in sorted(bad.items()))
    return (f"at preload(s) {where} the band's continuation took step(s) across a resonance "
            "that could not be shortened to its half-power band: a peak may hide there "
            "(its band peak, and so the optimum, may be too low)")


def independence(study: Study, independent, spread) -> str | None:
    """The warning for a search whose peak is the same at every preload of its grid
    (`optimum.global_minimum`: relative spread below FLAT_SPREAD), else None."""
    if not independent:
        return None
    return (f"the peak of {study.output.optimum['dof']} is the same at every preload of the "
            f"search's grid (relative spread {float(spread):.3g}, below {FLAT_SPREAD:g}): it "
            "does not depend on the preload, so no optimum preload is reported "
            "(optimum_preload NaN)")


def search_identity(study: Study) -> tuple:
    """(identity of the search for its checkpoint, its frequency window, the index of
    its DOF)."""
    o, sv = study.output.optimum, study.solver
    window = o["window"] or study.sweep.frequency
    identity = {"dof": o["dof"], "bounds": list(o["bounds"]), "rtol": o["rtol"],
                "window": [window.omega_start, window.omega_stop], "harmonics": sv.harmonics}
    return identity, window, study.scene.dofs.index(o["dof"])


def planned_grid(study: Study, cdir=None) -> list:
    """The preloads [N] whose band evaluations the search will need, as far as known
    before the cases end: the grid over the bounds (`optimum.grid_nodes`, the cases
    that can be the search's own curve standing for their nodes), without those cases
    and the evaluations kept in `cdir`.  A case that then fails leaves its node to the
    search itself."""
    if study.output.optimum is None:
        return []
    identity, window, dof = search_identity(study)
    own = own_cases(study, window, dof)
    kept = load_search(cdir, identity) if cdir is not None else {}
    lo, hi = study.output.optimum["bounds"]
    return [float(n0) for n0 in grid_nodes(lo, hi, extra=own)
            if float(n0) not in own and float(n0) not in kept]


def grid_job(study: Study, n0, kwargs=None, guard=None, fn=None) -> tuple:
    """(fn, its arguments) of the band evaluation at n0 [N] (`map_jobs`): fn
    `search_peak`, or `early_peak` (the default without `kwargs`: run beside the
    cases, the study's own solver settings and guard)."""
    _, window, dof = search_identity(study)
    if kwargs is None:
        kwargs = {k: v for k, v in study.solver.kwargs().items() if k != "stability"}
        guard, fn = separation_guard(study), fn or early_peak
    return (fn or search_peak, study.system({"preload": n0}), study.solver.harmonics,
            window.omega_start, window.omega_stop, dof, kwargs, guard)


def early_peak(*args):
    """`search_peak` run beside the cases: None instead of an exception (the search
    then evaluates that preload itself, where a failure is reported as usual), so that
    it never stops the cases."""
    try:
        return search_peak(*args)
    except Exception:   # noqa: BLE001 -- reported by the search's own evaluation
        return None


def search_peak(system, H, omega_start, omega_end, dof, kwargs, guard=None):
    """`band_peak` of one preload's system (in a worker of `map_jobs`), its continuation
    checked by the separation guard (`declared.SeparationGuard`) when there is one."""
    w2 = negative_stiffness(system)
    if w2 is not None:   # unstable about rest: no peak to search (find_optimum says so)
        raise StaticDivergence(divergence(w2))
    kwargs = dict(kwargs)
    if guard is not None:
        kwargs["callback"] = guard.callback(system, H)
    return band_peak(system, H, omega_start, omega_end, dof, **kwargs)


def own_cases(study: Study, window, dof) -> list:
    """Preloads [N] of the cases that can be the optimum search's own curve: only the
    preload varies and the curve is over the search's window with the peak of `dof`
    located exactly (lumped scenes: every DOF; others: output DOFs)."""
    fr = study.sweep.frequency
    if (window.omega_start, window.omega_stop) != (fr.omega_start, fr.omega_stop):
        return []
    if study.scene.model != "lumped" and study.scene.dofs[dof] not in study.output.dofs:
        return []
    return [float(case["preload"]) for _, case in study.sweep.cases() if set(case) == {"preload"}]


def case_peaks(study: Study, cases, window, dof) -> tuple:
    """({preload: (peak, omega)}, {preload: (omega, Q)}) of the cases that are the
    optimum search's own curve (`own_cases`, complete); Q: all DOFs' coefficients at
    that peak (where the peak continued in preload may start)."""
    own = set(own_cases(study, window, dof))
    out, states = {}, {}
    for case, curve in cases:
        if set(case) == {"preload"} and float(case["preload"]) in own and curve is not None \
                and curve.success:
            a, om, i = curve.peak(dof)
            if np.isfinite(a):
                out[float(case["preload"])] = (a, om)
                states[float(case["preload"])] = (om, curve.Q[i])
    return out, states
