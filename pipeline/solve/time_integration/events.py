"""The event loop of the time integration: from piece to piece of `piecewise`.

The switching functions of a piece are located by sampling its closed form on a
grid that resolves the fastest eigenvalue, checking local maxima for grazing
crossings, and polishing the root with `brentq` to machine precision
(`_next_event`, `_first_crossing`); `integrate` then switches the triggered
elements (`piecewise.transition`) and starts the next piece.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from .piecewise import STICK, Piece, PiecewiseModel, graded_steps, transition

# one record of `integrate`'s events: time, element, old and new state
EVENT_DTYPE = np.dtype([("t", float), ("element", int), ("old", int), ("new", int)])


def integrate(mdl: PiecewiseModel, t0, x0, w0, st0, t_end, record, t_eval=None,
              max_events_per_period=2000, max_zero_length=50):
    """Event loop from (t0, x0, w0, st0) to t_end; returns a dict: the final t, x, w,
    st; with `record`, the pieces and the events (t, element, old, new) with the
    state at each (evq, evqd, evw: w before the switch); n_events, status (0 reached
    t_end, 1 event cap, -1 unsupported linear piece) and message."""
    T = mdl.T
    x, w, st, t = np.array(x0, float), np.array(w0, float), np.array(st0, int), float(t0)
    pieces, events, evq, evqd, evw = [], [], [], [], []
    n_events, zero_len, status, msg = 0, 0, 0, "reached t_end"
    period_events, period_id = 0, np.floor((t - t0) / T)
    while t < t_end - 1e-15 * max(1.0, abs(t_end)):
        mode = mdl.mode(st)
        if not mode.ok:
            status, msg = -1, f"unsupported linear piece: {mode.why}"
            break
        piece = Piece(mdl, mode, t, x, w)
        if record:
            pieces.append(piece)
        t_stop = min(t_end, t + T)
        tau_ev, trig = _next_event(mdl, piece, t, t_stop, x)
        if tau_ev is None:
            x = piece.x(np.array([t_stop]))[:, 0]
            t = t_stop
            zero_len = 0
            continue
        t_ev = t + tau_ev
        x = piece.x(np.array([t_ev]))[:, 0]
        zero_len = zero_len + 1 if tau_ev <= 1e-13 * T else 0
        pid = np.floor((t_ev - t0) / T)
        if pid != period_id:
            period_id, period_events = pid, 0
        wd = mdl.derived_w(x, w, st)
        switched = set()
        for j in trig:
            e = int(mode.elem[j])
            if e in switched:       # one switch per element and event: the other rows
                continue            # belong to the state it left (the next piece re-checks)
            old = st[e]
            new, w_e = transition(mdl, e, int(mode.kind[j]), x, old)
            if new == old:
                continue
            if record:
                events.append((t_ev, e, old, new))
                evq.append(x[: mdl.n].copy()), evqd.append(x[mdl.n:].copy()), evw.append(wd.copy())
            st[e], w[e] = new, w_e
            switched.add(e)
            n_events += 1
            period_events += 1
        w = np.where(st == STICK, w, mdl.derived_w(x, w, st))
        t = t_ev
        if period_events > max_events_per_period:
            status, msg = 1, (f"more than {max_events_per_period} events in one period at "
                              f"t = {t:.6g}: chattering (Zeno-like) motion, stopped")
            break
        if zero_len > max_zero_length:
            status, msg = 1, f"{zero_len} consecutive zero-length states at t = {t:.6g}: stopped"
            break
    return dict(t=t, x=x, w=w, st=st, pieces=pieces, events=events, evq=evq, evqd=evqd,
                evw=evw, n_events=n_events, status=status, message=msg)


def _next_event(mdl: PiecewiseModel, piece: Piece, t0, t1, x0):
    """Earliest time (tau from t0) in (0, t1 - t0] where a switching function becomes > 0.

    Returns (tau, [rows triggered]) or (None, []).
    """
    m = piece.mode
    J = m.Csw.shape[0]
    if J == 0:
        return None, []
    T = mdl.T
    span = t1 - t0
    fmax = max(np.abs(m.lam).max(), mdl.hmax_freq, 1e-300)
    ts = t0 + _sampling_grid(piece, x0, span, T, mdl.hmax_freq)
    G = piece.g(ts)
    Gp = piece.g(ts, 1)
    # magnitude of each function over the window (its start alone can be ~0, e.g. n0 = 0)
    scale = np.maximum(m.cabs @ np.abs(x0) + np.abs(piece.gconst),
                       np.abs(G).max(axis=1)
                       + np.abs(Gp).max(axis=1) * (span / (ts.size - 1))) + 1e-300
    # a just-switched function starts at 0 with a slope that is 0 up to rounding
    tol, tol_d = 1e-10 * scale, 1e-9 * scale * fmax
    best, trig = np.inf, []
    for j in range(J):
        g, gp = G[j], Gp[j]
        if _rising(piece, t0, j, g[0], gp[0], tol[j], tol_d[j]):
            tj = t0                                  # inconsistent start: fire now
        else:
            tj = _first_crossing(piece, j, ts, g, gp, scale[j])
        if tj is None:
            continue
        tj = tj - t0
        if tj < best - 1e-14 * T:
            best, trig = tj, [j]
        elif abs(tj - best) <= 1e-14 * T:
            trig.append(j)
    if not np.isfinite(best):
        return None, []
    # simultaneous switches (several elements at one instant): a function at zero
    # within its crossing tolerance that rises there, its slope read beyond rounding
    # or, where the slope is rounding itself, its curvature (as the start test)
    te = t0 + best
    gs, gps = piece.g(te)[:, 0], piece.g(te, 1)[:, 0]
    for j in range(J):
        if j not in trig and _rising(piece, te, j, gs[j], gps[j], 1e-9 * scale[j], tol_d[j]):
            trig.append(j)
    return best, trig


def _rising(piece: Piece, t, j, g, gp, tol, tol_d) -> bool:
    """Switching function j fires at t: positive beyond `tol`, or zero within `tol`
    and increasing (slope above `tol_d`; a slope within `tol_d` is rounding, and the
    second derivative decides).  At rest on a grazing contact (n = 0, v' = 0) every
    function and slope is rounding: only the curvature tells which one really rises,
    so that the states are not switched round in a circle by rounding noise."""
    if g > tol:
        return True
    if g <= -tol:
        return False
    if gp > tol_d:
        return True
    return abs(gp) <= tol_d and piece.g(t, 2, j)[0, 0] > 0


def _sampling_grid(piece: Piece, x0, span, T, hmax_freq):
    """Sample times (from the piece's start, up to `span`) of the switching functions:
    a step of (pi/6)/max|lambda| over the modes still present (`graded_steps`, each
    mode's share |C V a_k| of the functions' scale), so that a decayed stiff mode no
    longer sets it; the terms left out are below 1e-17 of the functions, far below
    the crossing tolerance 1e-10.  At least four intervals."""
    m = piece.mode
    base = m.cabs @ np.abs(x0) + np.abs(piece.gconst) + 1e-300              # (J,)
    share = (np.abs(m.CV) * np.abs(piece.a)[None, :] / base[:, None]).max(axis=0)
    grid = [np.zeros(1)]
    for start, end, dt in graded_steps(m.lam, share, span, T, hmax_freq, np.pi / 6):
        n = max(1, int(np.ceil((end - start) / dt)))
        grid.append(start + (end - start) * np.arange(1, n + 1) / n)
    ts = np.concatenate(grid)
    return ts if ts.size >= 5 else np.linspace(0.0, span, 5)


def _first_crossing(piece: Piece, j, ts, g, gp, scale):
    """Absolute time of the first upward zero crossing of g_j after ts[0], or None."""
    def f(t):
        return piece.g(t, 0, j)[0, 0]

    # positive beyond rounding (the level the start test and the grazing test ignore):
    # a function left at the friction limit by a switch sits at +1e-13 of its scale
    pos = np.nonzero(g[1:] > 1e-10 * scale)[0]
    k_pos = pos[0] + 1 if pos.size else len(g)
    # grazing: a local maximum between two non-positive samples may poke above zero
    k_max = len(g)
    cand = np.nonzero((gp[:-1] > 0) & (gp[1:] < 0))[0]
    for k in cand:
        if k + 1 >= k_pos:
            break
        h = ts[k + 1] - ts[k]
        # cubic Hermite bound of the peak; only polish peaks that may reach zero
        peak = max(g[k], g[k + 1]) + 0.25 * h * max(gp[k], -gp[k + 1])
        if peak < -1e-8 * scale:
            continue
        try:
            tm = brentq(lambda t: piece.g(t, 1, j)[0, 0], ts[k], ts[k + 1], xtol=1e-15 * h)
        except ValueError:
            continue
        if f(tm) > 1e-10 * scale:          # rounding-level bumps are not crossings
            k_max, t_hi = k, tm
            break
    if k_pos == len(g) and k_max == len(g):
        return None
    if k_max < k_pos:
        lo, hi = ts[k_max], t_hi
    else:
        lo, hi = ts[k_pos - 1], ts[k_pos]
    if f(lo) >= 0:                      # only at the start of a piece that just switched
        for s in 10.0 ** -np.arange(1, 12):
            tl = ts[0] + s * (hi - ts[0])
            if f(tl) < 0:
                lo = tl
                break
        else:
            return ts[0]
    return brentq(f, lo, hi, xtol=1e-15 * max(1.0, abs(hi)), rtol=4 * np.finfo(float).eps)
