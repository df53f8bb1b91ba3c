"""Points added to a traced response branch where its drawn curves bend (`densify`,
the `dense_output` of `response.frequency_response`); `densify` adds dense_nfev,
dense_points and amplitude (P, D) of the DOFs it drew.

Works on the branch points of `response`, a dict: x (P, nc (2H+1)) condensed
unknowns, lam (P,) parameter, nit (P,), converged (P,), and optionally tangent (P
entries: the branch tangent, physical units, or None) and scale (the branch's metric).  Every
added point solves R = 0 (Newton on a hyperplane across the branch,
`newton.solve_on_plane`), so it is a converged solution, not an interpolation.
"""
from __future__ import annotations

import math

import numpy as np

from .amplitudes import amplitudes_at
from .branch import hermite_point
from .newton import KeptFactors, solve_on_plane

# how finely `densify` draws a curve (`test_dense_output` asserts the result)
PLOT_TURN = math.radians(8.0)   # largest turn of the drawn curve at a point
PLOT_TURN_LONG = math.radians(3.0)  # ... and at a point between long chords
PLOT_LONG_CHORD = 0.04          # a chord this long (plot units) shows a small corner
PLOT_MIN_CHORD = 2e-3           # segments shorter than this (plot units) are not split
PLOT_MAX_POINTS = 400           # points `densify` may add to one curve
PLOT_AXES = ("linear", "log")   # the amplitude axes a curve is drawn on
PLOT_PASSES = 8
_SMOOTH_COS = math.cos(math.radians(20.0))  # neighbours turning more: not in one curve


def _dense_start(Z, T, seg, d):
    """A start on the hyperplane through the middle m of the chord Z[seg] -> Z[seg+1]
    (scaled points Z, d the chord's unit direction), from the Hermite curve through
    the points around it and their tangents T (scaled, any length, or None):
    Z[seg-1 .. seg+2] where they exist with a tangent and turn by less than 20
    degrees (_SMOOTH_COS) from one to the next (a septic through four points, a quintic
    through three), else the cubic through the chord's two ends
    (`branch.hermite_point`).  Its distance from the branch is O(L^8), O(L^6) or
    O(L^4) against the chord middle's O(L^2), so Newton needs fewer iterations; None
    if the chord's end tangents do not point along it or the curve strays farther
    than L / 2 from m."""
    def unit(k):
        t = T[k] / np.linalg.norm(T[k])
        return t if t @ d > 0 else -t

    if T[seg] is None or T[seg + 1] is None:
        return None
    if T[seg] @ d <= 0 or T[seg + 1] @ d <= 0:
        return None  # a tangent against the chord: no curve to trust
    lo, hi = seg, seg + 1
    U = {lo: unit(lo), hi: unit(hi)}
    if lo > 0 and T[lo - 1] is not None and unit(lo - 1) @ U[lo] > _SMOOTH_COS:
        lo -= 1
        U[lo] = unit(lo)
    if hi + 1 < len(T) and T[hi + 1] is not None and unit(hi + 1) @ U[hi] > _SMOOTH_COS:
        hi += 1
        U[hi] = unit(hi)
    Y = np.ascontiguousarray(Z[lo:hi + 1])
    m = 0.5 * (Z[seg] + Z[seg + 1])
    L = np.linalg.norm(Z[seg + 1] - Z[seg])
    h = np.linalg.norm(Y[-1] - Y[-2])
    v = -(0.5 * L + (h if hi > seg + 1 else 0.0)) / h  # m's arclength from Y[-1], in h
    ok, p = hermite_point(Y, np.array([U[k] for k in range(lo, hi + 1)]),
                          np.ascontiguousarray(d), float(d @ m), v)
    return p if ok and np.linalg.norm(p - m) <= 0.5 * L else None


def _plot_coordinates(om, A, axes=PLOT_AXES):
    """(P, 1 + D len(axes)) points of the drawn curves in axis units (one unit is one
    axis length of a figure): frequency om (P,) over the range, then for each DOF
    its amplitude (a column of A (P, D)) over its range ("linear" in `axes`) and
    log10 of it over its decades ("log": at least half a decade)."""
    cols = [om / max(np.ptp(om), 1e-300)]
    for a in A.T:
        if "linear" in axes:
            cols.append(a / max(np.ptp(a), 1e-300))
        if "log" in axes:
            la = np.log10(np.maximum(a, 1e-300))
            la = np.maximum(la, la.max() - 12.0)  # amplitudes near zero: a floor, not -inf
            cols.append(la / max(np.ptp(la), 0.5))
    return np.column_stack(cols)


def densify(prob, pts, fun, tol, dofs, omega_of=lambda l: l, axes=PLOT_AXES):
    """Add branch points where the drawn curves bend.

    A chord of a drawn curve (frequency against the amplitude of one DOF on the
    amplitude `axes`, "linear" and / or "log", in axis units)
    that meets its neighbour at more than PLOT_TURN (PLOT_TURN_LONG if it is longer
    than PLOT_LONG_CHORD: a long chord shows a small corner) is split at its middle: the
    new point solves R = 0 on the hyperplane through the middle of the chord of
    scaled [x; lam], normal to it (Newton from the Hermite curve through the points
    around the chord and their tangents, `_dense_start`).  Straight stretches get no
    point, and a point on a linear stretch costs one Newton iteration.  Repeated until the curves
    turn by less than PLOT_TURN, chords are shorter than PLOT_MIN_CHORD, or
    PLOT_MAX_POINTS were added.
    """
    X, L = np.array(pts["x"]), np.array(pts["lam"])
    nit = np.array(pts["nit"])
    if L.size < 3 or not np.all(pts["converged"]):
        return pts
    T = list(pts.get("tangent", [None] * L.size))
    dofs = list(dofs)
    scale = np.append(np.maximum(np.abs(X).max(0), 1e-12 * np.abs(X).max() + 1e-300),
                      max(np.ptp(L), abs(L).max() * 1e-9, 1e-300))
    if pts.get("scale") is not None:
        scale = np.array(pts["scale"], float)
    added = 0
    failed = set()
    A = amplitudes_at(prob, X, L, dofs, omega_of)  # kept up to date: new points only
    for _ in range(PLOT_PASSES):
        Pc = _plot_coordinates(np.array([omega_of(l) for l in L]), A, axes)
        chord = np.diff(Pc, axis=0)
        length = np.linalg.norm(chord, axis=1)
        turn = np.zeros(L.size)  # at each interior point, largest over the drawn curves
        for k in range(1, Pc.shape[1]):
            c2 = chord[:, [0, k]]
            n2 = np.linalg.norm(c2, axis=1)
            cosang = np.einsum("ij,ij->i", c2[:-1], c2[1:]) / np.maximum(n2[:-1] * n2[1:], 1e-300)
            turn[1:-1] = np.maximum(turn[1:-1], np.arccos(np.clip(cosang, -1.0, 1.0)))
        # a corner shows where chords turn sharply, or turn a little but are long
        split = sorted({seg for i in np.flatnonzero(turn > PLOT_TURN_LONG) for seg in (i - 1, i)
                        if (length[seg] > PLOT_MIN_CHORD and (L[seg], L[seg + 1]) not in failed
                            and (turn[i] > PLOT_TURN or length[seg] > PLOT_LONG_CHORD))})
        if not split or added >= PLOT_MAX_POINTS:
            break
        new = []
        factors = KeptFactors()  # the last solve's, near the next one's along the branch
        Z = np.column_stack([X, L]) / scale
        Ts = [None if t is None else t / scale for t in T]
        for seg in split[:PLOT_MAX_POINTS - added]:
            za, zb = Z[seg], Z[seg + 1]
            d = (zb - za) / np.linalg.norm(zb - za)
            z, ok, nfev, t = solve_on_plane(fun, 0.5 * (za + zb), d, scale, tol,
                                             _dense_start(Z, Ts, seg, d), factors)
            pts["dense_nfev"] = pts.get("dense_nfev", 0) + nfev
            if ok:
                new.append((seg + 0.5, z, t))
            else:
                failed.add((L[seg], L[seg + 1]))
        if not new:
            break
        added += len(new)
        pos = np.concatenate([np.arange(L.size, dtype=float), [q for q, _, _ in new]])
        order = np.argsort(pos, kind="stable")
        X = np.concatenate([X, [z[:-1] for _, z, _ in new]])[order]
        L = np.concatenate([L, [z[-1] for _, z, _ in new]])[order]
        nit = np.concatenate([nit, np.zeros(len(new), int)])[order]
        T = [(T + [t for _, _, t in new])[k] for k in order]
        Znew = np.array([z for _, z, _ in new])
        A = np.concatenate([A, amplitudes_at(prob, Znew[:, :-1], Znew[:, -1], dofs, omega_of)])
        A = A[order]
    pts.update(x=X, lam=L, nit=nit, converged=np.ones(L.size, bool), dense_points=added,
               amplitude=A, amplitude_dofs=dofs)
    if "tangent" in pts:
        pts["tangent"] = T
    return pts
