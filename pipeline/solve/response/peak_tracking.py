"""The resonant peak continued in the preload, and the optimum preload searched with it.

A friction damper's peak moves smoothly with the preload n0 between two grid nodes of
the optimum search (`optimum.global_minimum`): its frequency and its state at n0 are
close to those at the nearest preload already evaluated.  `local_peak` therefore
finds the peak at n0 without tracing the whole band:

1. the branch at n0 met on the hyperplane through the known peak (Omega_k, Q_k) (all
   DOFs' coefficients at the nearby preload) normal to the branch's tangent there
   (`solve_on_plane`: robust where the peak lies beside a fold, where Newton at fixed
   Omega_k is not); if that fails, Newton at Omega_k from Q_k and then the linear
   guesses and homotopies (`response.first_point`);
2. the branch through that point traced both ways (`continue_branch`, the resonance
   guard on, lambda free over the whole band on either side) until the amplitude of
   the DOF falls below the largest it reached on that side: a local maximum along
   the branch is then enclosed;
3. that maximum located exactly (`insert_peaks`) and its state recovered on all DOFs,
   its full residual held to the tolerances like every point's (`curve_from_points`).

The result is a local maximum of the frequency response at n0: no larger than the
band's peak p(n0), and equal to it while the peak stays on the same resonance.  A side
that reaches the end of the band still rising, or a failed continuation, is no local
peak (success False).  `optimum_preload` uses it for Brent's trial preloads inside a
bracket and evaluates the whole band at the bracket's result: since every local value
is a lower bound, an optimum whose band peak equals its local one (VERIFY_REL) is the
best of all preloads tried with their band peaks too; otherwise the bracket is refined
again with band evaluations (`optimum.global_minimum`).  Petrov (J. Turbomach. 129,
2007) traces resonance peaks over a design parameter by an added peak equation; here
the peak is the same exact maximum the frequency response locates, only reached from
a nearby one.
"""
from __future__ import annotations

import dataclasses
import logging
import time

import numpy as np

from ..continuation.arclength import automatic_scale
from ..continuation.amplitudes import amplitudes_at
from ..continuation.exact_peaks import insert_peaks
from ..continuation.newton import solve_on_plane
from ..continuation.newton import augment, linear_solve
from ..continuation.pseudo_arclength import continue_branch
from ..continuation.restarts import join, piece
from .optimum import (MIN_NODES, PER_DECADE, PLATEAU_PER_TOL, PLATEAU_REL, VERIFY_REL,
                      global_minimum)
from .response import (ResponseCurve, branch_points, curve_from_points, frequency_problem,
                       frequency_response)
from .window import peak_points

logger = logging.getLogger(__name__)


def local_peak(system, H, omega, initial, dof, omega_start, omega_end, *, method="exact",
               n_samples=256, tol_rel=1e-10, ds=0.02, ds_max=0.1, max_points=1000,
               callback=None, contact=None, stability=None, dense_output=None,
               keep=None) -> ResponseCurve:
    """The local maximum of `dof`'s amplitude on the branch through the solution near
    `initial` (Fourier coefficients (n, 2H+1) of all DOFs, e.g. the peak of a nearby
    preload) at `omega` [rad/s], within [omega_start, omega_end] (module docstring).

    Returns a ResponseCurve of that one point (stability not decided); success False,
    with the reason in its message, when no local maximum is enclosed inside the band.
    Options as `frequency_response`'s; stability, dense_output and keep are accepted
    and ignored (one point, stability not decided)."""
    t_start = time.perf_counter()
    fp = frequency_problem(system, H, method, n_samples, tol_rel, contact)
    prob = fp.prob
    band = (min(omega_start, omega_end), max(omega_start, omega_end))
    x0, omega, tangent, spent = _start(fp, fp.checked_state(initial),
                                       min(max(omega, band[0]), band[1]), band)
    if x0 is None:
        return _failed(fp, "no solution near the start", t_start, spent)
    # both sides of the start, each ordered from omega_start to omega_end; a start at an
    # end of the band (the peak there at the preload it came from) has one side only
    sides = [(end, back, k == 0) for k, (end, back) in
             enumerate(((omega_start, omega_end), (omega_end, omega_start))) if end != omega]
    runs = [_side(fp, x0, omega, end, back, dof, min(ds, ds_max), ds_max, max_points,
                  callback, tangent) for end, back, _ in sides]
    parts = [piece(br, reverse=towards_start, drop_first=k > 0)
             for k, ((br, _), (_, _, towards_start)) in enumerate(zip(runs, sides))]
    br = join(parts, "local peak", all(stopped for _, stopped in runs), 0)
    pts = branch_points(br)
    pts = insert_peaks(prob, pts, fp.fun, 1.0, fp.elem, [dof], largest=True)
    amps = pts.get("amplitude")        # drawn by insert_peaks (fewer than 3 points: not)
    amps = (amps if amps is not None else amplitudes_at(prob, pts["x"], pts["lam"], [dof]))[:, 0]
    k = int(np.argmax(np.where(pts["converged"], amps, -np.inf)))
    enclosed = br.success and 0 < k < amps.size - 1
    pts = peak_points(prob, pts, [dof])
    pts["resonance_guard"] = fp.guard is not None
    curve = curve_from_points(prob, br, pts, lambda lam: fp.elem, fp.tols, False,
                              lambda lam: lam, time.perf_counter() - t_start, spent)
    if enclosed:
        return dataclasses.replace(curve, message="local peak enclosed")
    return dataclasses.replace(curve, success=False, status=1, message=(
        "no local maximum enclosed: the amplitude still rises at an end of the band "
        "or a side stopped short"))


def _start(fp, Q, omega, band):
    """(x, Omega, tangent, nfev) of the first point: on the hyperplane through (Q,
    omega) normal to the branch's tangent there (scaled unknowns: `automatic_scale`,
    Omega by the band's span) if it falls inside the band, with the branch's tangent
    there (physical units); else at fixed omega (`first_point`; tangent None); x None
    if neither."""
    prob = fp.prob
    x0 = Q[prob.c].ravel()
    scale = np.append(automatic_scale(np.abs(x0), fp.groups), band[1] - band[0])
    _, Jx, Jl = fp.fun(x0, omega)
    row = np.zeros(x0.size + 1)
    row[-1] = 1.0 / scale[-1]
    nfev = 1
    try:
        t = linear_solve(augment(Jx, Jl, row), row * scale[-1]) / scale
    except (np.linalg.LinAlgError, RuntimeError):
        t = None
    if t is not None and np.all(np.isfinite(t)):
        z, ok, n, tz = solve_on_plane(fp.fun, np.append(x0, omega) / scale,
                                      t / np.linalg.norm(t), scale, 1.0)
        nfev += n
        if ok and band[0] < z[-1] < band[1]:
            return z[:-1], float(z[-1]), tz, nfev
    nr, n = fp.start_at(omega, Q)
    return (nr.x if nr.success else None), omega, None, nfev + n


def _side(fp, x0, omega, end, back, dof, ds, ds_max, max_points, callback, tangent=None):
    """(Branch from (x0, omega) towards `end`, stopped once the amplitude of `dof`
    fell below the largest on this side?)."""
    prob, seen = fp.prob, {"top": -np.inf, "fell": False}

    def stop(x, lam):
        if callback is not None and callback(x, lam):
            return True
        a = float(amplitudes_at(prob, x[None], np.array([lam]), [dof])[0, 0])
        seen["fell"] = a < seen["top"]
        seen["top"] = max(seen["top"], a)
        return seen["fell"]

    br = continue_branch(fp.fun, x0, omega, end, tol=1.0, groups=fp.groups, ds=ds,
                         ds_max=ds_max, max_points=max_points, callback=stop,
                         segment_check=fp.guard, lam_back=back, tangent=tangent)
    return br, seen["fell"]


def _failed(fp, why, t_start, spent) -> ResponseCurve:
    n, nh = fp.prob.system.n_dof, fp.prob.nh
    e = np.zeros(0)
    return ResponseCurve(parameter=e, omega=e, Q=np.zeros((0, n, nh)),
                         converged=np.zeros(0, bool), residual=e, stable=np.zeros(0, bool),
                         amplitude=np.zeros((0, n)), fold_parameter=e,
                         newton_iterations=np.zeros(0, int), nfev=int(spent),
                         wall_time=time.perf_counter() - t_start, success=False, status=1,
                         message=why, H=fp.prob.H, tolerance=float(np.hypot(*fp.tols)))


def band_peak(system, H, omega_start, omega_end, dof, **kwargs) -> tuple:
    """(peak [m], its Omega [rad/s], all DOFs' coefficients there, notes) of `dof`
    over the band (its largest amplitude inside the band, `ResponseCurve.peak`):
    `frequency_response` keeping its peaks (stability off unless asked); (inf, NaN,
    None, notes) for an incomplete curve (it may miss its peak), logged.  notes:
    {"unresolved": the curve's steps across a resonance that could not be shortened to
    its half-power band (a peak may hide there), "outside": whether its largest
    amplitude traced lies outside the band (the branch followed beyond it)}."""
    kwargs.setdefault("stability", False)
    kwargs["keep"] = "peaks"  # only the peak is read, no curve is drawn
    c = frequency_response(system, H, omega_start, omega_end, peak_dofs=[dof], **kwargs)
    notes = {"unresolved": int(c.info.get("unresolved_resonance_steps", 0)),
             "outside": bool(c.info.get("outside_peak", False))}
    if not c.success:
        logger.warning("optimum search: curve incomplete (%s); skipped", c.message)
        return np.inf, np.nan, None, notes
    a, om, i = c.peak(dof)
    return a, om, c.Q[i], notes


def optimum_preload(build, H, omega_start, omega_end, dof, bounds, *, rtol=1e-3,
                    log=True, known=None, extra_nodes=(), on_evaluation=None,
                    per_decade=PER_DECADE, states=None, local=True, grid_map=None,
                    replay=None, min_nodes=MIN_NODES, **kwargs):
    """The preload [N] in `bounds` that minimises the resonant peak of `dof`, globally.

    build(n0) -> System.  Each band evaluation traces the frequency response over
    [omega_start, omega_end] and takes its exact peak (`band_peak`); an incomplete
    curve (it may miss its peak) is a failed evaluation, never a candidate.  The
    peak-vs-preload curve is sampled on a grid (`per_decade` nodes per decade, on
    log(n0) by default: preloads span decades), every local minimum of the grid is
    bracketed and refined by Brent (the optimum within `rtol` in log(n0)), the best taken
    (`optimum.global_minimum`, which states when a minimum can still be missed).  With
    `local`, Brent's trial preloads take the peak continued from the nearest preload
    evaluated (`local_peak`) and the bracket's result is verified by a band evaluation
    (module docstring).  The searched variable is whatever `build` reads: with
    log=False a linear grid of `min_nodes` nodes (a shroud interference [m], which
    crosses zero).  A smallest peak shared by grid nodes to PLATEAU_PER_TOL times the
    Newton tolerance `tol_rel` (their round-off) is a plateau, no optimum.
    known {n0: (peak, omega)} are reused, extra_nodes join the grid (the study's cases);
    replay {n0: (peak, omega)}: an interrupted search's evaluations (`global_minimum`);
    states {n0: (omega, Q)}: the peak states of known preloads (Q all DOFs'
    coefficients), where local peaks may start; on_evaluation(n0, peak, omega, Q)
    follows each new band evaluation (Q its peak state, None for a failed one); grid_map(list
    of n0, done): the grid nodes evaluated together (a caller's process pool), done(k,
    `band_peak` result) as each ends; else one by one here.  Returns
    the dict of `optimum.global_minimum`, with unresolved {n0: steps} of the band
    evaluations whose steps across a resonance were not resolved (a peak may hide
    there) and outside [n0], those whose largest amplitude traced lies outside the
    band (`band_peak` notes; the evaluations made in this call).
    """
    if log and not 0 < bounds[0] < bounds[1]:
        raise ValueError(f"bounds must satisfy 0 < low < high for a log search, got {bounds}")
    states, unresolved, outside = dict(states or {}), {}, set()

    def keep(n0, result):
        a, om, Q = result[:3]
        if Q is not None:
            states[float(n0)] = (om, Q)
        notes = result[3] if len(result) > 3 else {}
        if notes.get("unresolved"):
            unresolved[float(n0)] = int(notes["unresolved"])
        if notes.get("outside"):
            outside.add(float(n0))
        return a, om

    def peak(n0):
        return keep(n0, band_peak(build(n0), H, omega_start, omega_end, dof, **kwargs))

    def many(n0s, record):
        grid_map(n0s, lambda k, r: record(n0s[k], *keep(n0s[k], r)))

    def near_peak(n0, near):
        if near not in states:   # a value kept without its state (a resumed search)
            peak(near)
        if near not in states:
            return np.inf, np.nan
        om0, Q0 = states[near]
        c = local_peak(build(n0), H, om0, Q0, dof, omega_start, omega_end, **kwargs)
        if not c.success:
            logger.info("optimum search: no local peak at %.6g N from %.6g N (%s)", n0, near,
                     c.message)
            return np.inf, np.nan
        a, om, i = c.peak(dof)
        states[float(n0)] = (om, c.Q[i])
        return a, om

    def evaluated(n0, p, om):
        on_evaluation(n0, p, om, states.get(float(n0), (None, None))[1])

    res = global_minimum(peak, bounds, rtol=rtol, log=log, per_decade=per_decade,
                         min_nodes=min_nodes, plateau_rel=max(
                             PLATEAU_REL, PLATEAU_PER_TOL * kwargs.get("tol_rel", 0.0)),
                         known=known, extra_nodes=extra_nodes,
                         on_evaluation=evaluated if on_evaluation is not None else None,
                         local=near_peak if local else None, verify_rel=VERIFY_REL,
                         evaluate_many=many if grid_map is not None else None,
                         replay=replay)
    res["unresolved"], res["outside"] = dict(sorted(unresolved.items())), sorted(outside)
    return res

