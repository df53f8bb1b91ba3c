"""The optimum search of a study (`[output.optimum_preload]`, or
`[output.optimum_interference]`: every shroud pair's interference [m] on a linear grid,
the actual static contact load of each evaluation beside it): the study's systems at
each trial value, its cases' peaks reused as grid nodes, the evaluations kept on disk
as they come so that an interrupted search resumes (`peak_tracking.optimum_preload`,
`search_checkpoint`).  The result's `preload` is the optimum of the searched
variable (`study_types.optimum_variable`), in its unit (`study_types.OPTIMUM_UNITS`)."""
from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np

from ...solve.response.optimum import FLAT_SPREAD, MIN_NODES, grid_nodes
from ...solve.response.peak_tracking import band_peak, optimum_preload
from ...model.static_load import contact_owner, face_totals, static_state
from ...model.system import negative_stiffness
from ...errors import interrupt_in_chain
from ..files.declared import UndeclaredSeparation
from .cases import StaticDivergence, divergence, map_jobs, separation_guard
from .search_checkpoint import load_search, save_search
from ..files.study_types import OPTIMUM_UNITS, Study, optimum_variable

log = logging.getLogger("pipeline.study.execution.run")


def study_optimum(study: Study, solver, curves, cdir=None, workers=1, scheduler=None,
                  early=None) -> tuple:
    """(optimum dict or None, error text or None) of a study run whose cases gave
    `curves` with `solver`: `find_optimum` (its grid on the run's `workers` or
    `scheduler`, the `early` band evaluations run beside the cases reused), the cases
    reused when they are HBM curves; a search stopped by an undeclared separation, or by
    an evaluation that raises, is an error (the dataset of the cases is written without
    it), logged."""
    if study.output.optimum is None:
        return None, None
    hbm = getattr(solver, "__module__", "") == "pipeline.solve.response.response"
    try:
        return find_optimum(study, list(zip([c for _, c in study.sweep.cases()], curves))
                            if hbm else None, cdir, workers, scheduler, early), None
    except (UndeclaredSeparation, StaticDivergence) as exc:
        log.error("%s: optimum %s search stopped: %s", study.name, variable_of(study)[0], exc)
        return None, str(exc)
    except Exception as exc:  # a failing evaluation must not lose the cases
        if interrupt_in_chain(exc):
            raise
        log.exception("%s: optimum %s search failed", study.name, variable_of(study)[0])
        return None, f"{type(exc).__name__}: {exc}"


def optimum_figure_of(study: Study, optimum: dict, fig_dir):
    """`fig_dir/optimum_preload.png` (`optimum_interference.png`): the peak against the
    searched variable, the curve the optimum was found on."""
    from ..figures.optimum_figure import optimum_figure   # deferred: matplotlib

    return optimum_figure(Path(fig_dir) / f"optimum_{variable_of(study)[0]}.png", optimum,
                          study.output.optimum["dof"], study.title, variable_of(study))


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
    var, unit = variable_of(study)
    w2 = negative_stiffness(study.system({var: o["bounds"][0]}))
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
        system = study.system({var: n0})
        if guard is not None:  # each evaluation's continuation checked (declared.py)
            current["check"] = guard.callback(system, sv.harmonics)
        return system

    def keep(n0, peak, omega, Q=None):
        kept[n0] = (peak, omega)
        kept_states[n0] = Q
        log.info("%s: optimum search: %.6g %s: peak %.4g m at %.5g %s", study.name, n0, unit,
                 peak, omega / fr.to_rad_s, fr.unit)
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
                          log=var == "preload", min_nodes=o.get("nodes", MIN_NODES), **kw)
    res["variable"] = var
    if var == "interference":
        res["static"] = static_loads(study, [x for x, *_ in res["evaluations"]])
    res["wall_time"] = time.perf_counter() - t0
    log.info("%s: optimum %s %s (peak %.4g m at %.4g %s), %d evaluations (%d "
             "computed, %d reused), %d bracket(s) (%d not refined), %.1f s", study.name, var,
             optimum_words(res, unit), res["peak"], res["peak_omega"] / fr.to_rad_s, fr.unit,
             len(res["evaluations"]), res["computed"], res["reused"], len(res["brackets"]),
             len(res["skipped"]), res["wall_time"])
    return res


def optimum_words(res: dict, unit: str) -> str:
    """The optimum of a search's result as the console says it, with its unit and (an
    interference search) the static normal load there."""
    if res.get("independent"):
        return "none, the peak does not depend on it"
    if res.get("plateau") is not None:
        lo, hi = res["plateau"]
        return f"none, the smallest peak is the same from {lo:.6g} to {hi:.6g} {unit}"
    static = res.get("static", {}).get(float(res["preload"]))
    load = ("" if static is None else f", static normal load {float(sum(static[0])):.4g} N "
            f"on {int(sum(static[1]))} pair(s) in contact")
    return f"{res['preload']:.6g} {unit}{load}"


def variable_of(study: Study) -> tuple:
    """(the variable the study's optimum search varies, its unit): ("preload", "N") or
    ("interference", "m")."""
    var = optimum_variable(study.output.optimum)
    return var, OPTIMUM_UNITS[var]


def static_loads(study: Study, values) -> dict:
    """{interference [m]: (static normal load [N], pairs in contact [1]) per contact}
    of the search's evaluations: the unilateral static contact state of each
    (`static_load.static_state`, the dataset's `static_normal_load`, face totals of the
    compressive pairs); NaN and -1 where it cannot be solved."""
    owner, C = contact_owner(study.scene), len(study.scene.contacts)
    out = {}
    for x in values:
        try:
            st = static_state(study.system({"interference": float(x)}))
            out[float(x)] = (face_totals(st.load, owner, C),
                             np.bincount(owner[st.closed], minlength=C))
        except ValueError as exc:
            log.warning("%s: no static contact state at interference %.6g m (%s)", study.name,
                        x, exc)
            out[float(x)] = (np.full(C, np.nan), np.full(C, -1))
    return out


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
    var = variable_of(study)[0]
    return (f"at the optimum {var} the largest amplitude is its value at an end of the "
            f"search's window, {peak_omega / u:.6g} {window.unit}: not a resonant peak (a "
            f"peak inside {lo / u:.6g}-{hi / u:.6g} {window.unit}, if any, is lower), so the "
            f"optimum minimises an off-resonance amplitude (widen [output.optimum_{var}] "
            "frequency, or [sweep] frequency)")


def search_warnings(study: Study, res: dict) -> list:
    """The end-of-search warnings of `optimise` (`find_optimum`'s result): a peak that
    does not depend on the preload, else an optimum whose largest amplitude lies at an
    end of the window; band evaluations with steps across a resonance not resolved;
    unless the optimum lies at the window's end (said already), those whose largest
    amplitude traced lies outside the window."""
    end = window_end(study, res["peak_omega"])
    what = (independence(study, res.get("independent"), res.get("spread"))
            or plateau_warning(study, res.get("plateau"), res["peak"]) or end)
    more = [hidden_search_peaks(res.get("unresolved", {}), variable_of(study)),
            None if end else outside_search_peaks(study, res.get("outside", []))]
    return [w for w in [what] + more if w]


def dataset_warnings(study: Study, ds) -> list:
    """[(field, what)] of a finished run's dataset `ds` with an optimum search: no
    optimum (the peak independent of the variable, or the same over a stretch of it),
    else its peak at an end of the window; evaluations with a resonance not resolved,
    or (the optimum not at the window's end) their largest amplitude outside it."""
    if ds is None or "optimum_peak_frequency" not in ds:
        return []
    var, field = variable_of(study)[0], f"output.optimum_{variable_of(study)[0]}"
    attrs = ds[f"optimum_{var}"].attrs
    end = window_end(study, float(ds["optimum_peak_frequency"]) * study.sweep.frequency.to_rad_s)
    plateau = ((attrs["plateau_low"], attrs["plateau_high"]) if "plateau_low" in attrs
               else None)
    what = (independence(study, attrs.get(f"independent_of_{var}", 0),
                         attrs.get("peak_relative_spread", float("nan")))
            or plateau_warning(study, plateau, float(ds["optimum_peak_amplitude"])) or end)
    out = [(field, what)] if what else []
    if "optimum_search_outside_peak" in ds:
        x = ds[f"optimum_search_{var}"].values
        more = [hidden_search_peaks(dict(zip(x, ds["optimum_search_unresolved_steps"].values)),
                                    variable_of(study)),
                None if end else outside_search_peaks(
                    study, x[ds["optimum_search_outside_peak"].values == 1])]
        out += [(field, w) for w in more if w]
    return out


def outside_search_peaks(study: Study, preloads) -> str | None:
    """The warning for the band evaluations at `preloads` [N] (or interferences [m])
    whose largest amplitude traced lies outside the window (their band peak is the
    largest inside), else None."""
    if not len(preloads):
        return None
    window = study.output.optimum["window"] or study.sweep.frequency
    lo, hi = sorted((window.start, window.stop))
    var, unit = variable_of(study)
    return (f"at {var}(s) {', '.join(f'{float(n0):.6g} {unit}' for n0 in preloads)} the largest "
            f"amplitude traced lies outside the window {lo:g}-{hi:g} {window.unit} (the "
            "branch followed beyond it): the band peak there is the largest inside the "
            "window, not that resonance")


def hidden_search_peaks(unresolved: dict, variable=("preload", "N")) -> str | None:
    """The warning for the band evaluations {n0 [N]: steps} whose steps across a
    resonance could not be shortened to its half-power band, else None; `variable`:
    the searched one and its unit (`variable_of`)."""
    bad = {float(n0): int(k) for n0, k in unresolved.items() if k}
    if not bad:
        return None
    where = ", ".join(f"{n0:.6g} {variable[1]} ({k})" for n0, k in sorted(bad.items()))
    return (f"at {variable[0]}(s) {where} the band's continuation took step(s) across a resonance "
            "that could not be shortened to its half-power band: a peak may hide there "
            "(its band peak, and so the optimum, may be too low)")


def independence(study: Study, independent, spread) -> str | None:
    """The warning for a search whose peak is the same at every preload of its grid
    (`optimum.global_minimum`: relative spread below FLAT_SPREAD), else None."""
    if not independent:
        return None
    var = variable_of(study)[0]
    return (f"the peak of {study.output.optimum['dof']} is the same at every {var} of the "
            f"search's grid (relative spread {float(spread):.3g}, below {FLAT_SPREAD:g}): it "
            f"does not depend on the {var}, so no optimum {var} is reported "
            f"(optimum_{var} NaN)")


def plateau_warning(study: Study, plateau, peak) -> str | None:
    """The warning for a smallest peak shared by a stretch [low, high] of the bounds
    (`optimum.flat_minimum`), else None."""
    if plateau is None or not np.all(np.isfinite(plateau)):
        return None
    var, unit = variable_of(study)
    return (f"the smallest peak of {study.output.optimum['dof']}, {float(peak):.6g} m, is the "
            f"same from {plateau[0]:.6g} to {plateau[1]:.6g} {unit} (an open shroud gap, or "
            f"stuck contacts): no single {var} is optimal (optimum_{var} NaN)")


def search_identity(study: Study) -> tuple:
    """(identity of the search for its checkpoint, its frequency window, the index of
    its DOF)."""
    o, sv = study.output.optimum, study.solver
    window = o["window"] or study.sweep.frequency
    identity = {"dof": o["dof"], "bounds": list(o["bounds"]), "rtol": o["rtol"],
                "window": [window.omega_start, window.omega_stop], "harmonics": sv.harmonics}
    if variable_of(study)[0] != "preload":   # a preload search's identity as before
        identity.update(variable=variable_of(study)[0], nodes=o.get("nodes", MIN_NODES))
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
    o = study.output.optimum
    lo, hi = o["bounds"]
    return [float(n0) for n0 in grid_nodes(lo, hi, log=variable_of(study)[0] == "preload",
                                            min_nodes=o.get("nodes", MIN_NODES), extra=own)
            if float(n0) not in own and float(n0) not in kept]


def grid_job(study: Study, n0, kwargs=None, guard=None, fn=None) -> tuple:
    """(fn, its arguments) of the band evaluation at n0 [N] (`map_jobs`): fn
    `search_peak`, or `early_peak` (the default without `kwargs`: run beside the
    cases, the study's own solver settings and guard)."""
    _, window, dof = search_identity(study)
    if kwargs is None:
        kwargs = {k: v for k, v in study.solver.kwargs().items() if k != "stability"}
        guard, fn = separation_guard(study), fn or early_peak
    return (fn or search_peak, study.system({variable_of(study)[0]: n0}), study.solver.harmonics,
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
    """Preloads [N] (interferences [m]) of the cases that can be the optimum search's own
    curve: only the searched variable varies and the curve is over the search's window with the peak of `dof`
    located exactly (lumped scenes: every DOF; others: output DOFs)."""
    fr = study.sweep.frequency
    if (window.omega_start, window.omega_stop) != (fr.omega_start, fr.omega_stop):
        return []
    if study.scene.model != "lumped" and study.scene.dofs[dof] not in study.output.dofs:
        return []
    var = variable_of(study)[0]
    return [float(case[var]) for _, case in study.sweep.cases() if set(case) == {var}]


def case_peaks(study: Study, cases, window, dof) -> tuple:
    """({preload: (peak, omega)}, {preload: (omega, Q)}) of the cases that are the
    optimum search's own curve (`own_cases`, complete); Q: all DOFs' coefficients at
    that peak (where the peak continued in preload may start)."""
    own, var = set(own_cases(study, window, dof)), variable_of(study)[0]
    out, states = {}, {}
    for case, curve in cases:
        if set(case) == {var} and float(case[var]) in own and curve is not None \
                and curve.success:
            a, om, i = curve.peak(dof)
            if np.isfinite(a):
                out[float(case[var])] = (a, om)
                states[float(case[var])] = (om, curve.Q[i])
    return out, states
