"""Points added to a traced response branch for its output: where the drawn curves
bend (`densify`, the `dense_output` of `response.frequency_response`) and at the
exact resonance peaks (`insert_peaks`).

Both work on the branch points of `response`, a dict: x (P, nc (2H+1)) condensed
unknowns, lam (P,) parameter, nit (P,), converged (P,), extra_nfev (residual
evaluations of the peak search); `densify` adds dense_nfev and dense_points.  Every
added point solves R = 0 (Newton on a hyperplane across the branch), so it is a
converged solution, not an interpolation.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize_scalar

from . import hbm
from ..fourier.harmonics import amplitude_half_peak_to_peak
from .newton import augment, newton



def _dof_amplitude(prob, x, lam, dof, omega_of=lambda l: l):
    Q = hbm.recover(prob, x.reshape(prob.c.size, prob.nh), omega_of(lam))
    return float(amplitude_half_peak_to_peak(Q[dof]))


def _local_maxima(amps, converged, rel=0.05):
    """Interior local maxima of the amplitude along the branch above rel * max:
    the resonance peaks (several modes in one range), highest first."""
    a = np.where(converged, amps, -np.inf)
    top = a.max()
    idx = [i for i in range(1, a.size - 1)
           if a[i] >= a[i - 1] and a[i] > a[i + 1] and a[i] >= rel * top]
    return sorted(idx, key=lambda i: -a[i])


# how finely `densify` draws a curve (`test_dense_output` asserts the result)
PLOT_TURN = math.radians(8.0)   # largest turn of the drawn curve at a point
PLOT_TURN_LONG = math.radians(3.0)  # ... and at a point between long chords
PLOT_LONG_CHORD = 0.04          # a chord this long (plot units) shows a small corner
PLOT_MIN_CHORD = 2e-3           # segments shorter than this (plot units) are not split
PLOT_MAX_POINTS = 400           # points `densify` may add to one curve
PLOT_PASSES = 8


def _solve_on_plane(fun, p, d, scale, tol):
    """The branch point on the hyperplane through p normal to d (scaled unknowns
    z / scale, d unit): Newton on R = 0 plus that condition.  (z, ok, nfev)."""
    nfev = [0]

    def aug(z):
        R, Jx, Jl = fun(z[:-1], z[-1])
        nfev[0] += 1
        return (np.append(R, d @ (z / scale - p)),
                augment(Jx, Jl, d / scale))

    r = newton(aug, p * scale, tol, max_iter=20)  # converged: |R| <= tol at r.x
    return r.x, bool(r.success), nfev[0]


def _plot_coordinates(prob, X, L, dofs, omega_of):
    """(P, 1 + 2D) points of the drawn curves in axis units (one unit is one axis
    length of a figure): frequency over the range, then for each DOF its amplitude
    over its range (a linear axis) and log10 of it over its decades (a log axis, at
    least half a decade)."""
    om = np.array([omega_of(l) for l in L])
    cols = [om / max(np.ptp(om), 1e-300)]
    for dof in dofs:
        a = np.array([_dof_amplitude(prob, X[i], L[i], dof, omega_of) for i in range(L.size)])
        cols.append(a / max(np.ptp(a), 1e-300))
        la = np.log10(np.maximum(a, 1e-300))
        la = np.maximum(la, la.max() - 12.0)  # amplitudes near zero: a floor, not -inf
        cols.append(la / max(np.ptp(la), 0.5))
    return np.column_stack(cols)


def densify(prob, pts, fun, tol, dofs, omega_of=lambda l: l):
    """Add branch points where the drawn curves bend.

    A chord of a drawn curve (frequency against the amplitude of one DOF on a
    linear or a log axis, in axis units)
    that meets its neighbour at more than PLOT_TURN (PLOT_TURN_LONG if it is longer
    than PLOT_LONG_CHORD: a long chord shows a small corner) is split at its middle: the
    new point solves R = 0 on the hyperplane through the middle of the chord of
    scaled [x; lam], normal to it.  Straight stretches get no point, and a point
    on a linear stretch costs one Newton iteration.  Repeated until the curves
    turn by less than PLOT_TURN, chords are shorter than PLOT_MIN_CHORD, or
    PLOT_MAX_POINTS were added.
    """
    X, L = np.array(pts["x"]), np.array(pts["lam"])
    nit = np.array(pts["nit"])
    if L.size < 3 or not np.all(pts["converged"]):
        return pts
    dofs = list(dofs)
    scale = np.append(np.maximum(np.abs(X).max(0), 1e-12 * np.abs(X).max() + 1e-300),
                      max(np.ptp(L), abs(L).max() * 1e-9, 1e-300))
    added = 0
    failed = set()
    for _ in range(PLOT_PASSES):
        Pc = _plot_coordinates(prob, X, L, dofs, omega_of)
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
        for seg in split[:PLOT_MAX_POINTS - added]:
            za = np.append(X[seg], L[seg]) / scale
            zb = np.append(X[seg + 1], L[seg + 1]) / scale
            d = zb - za
            z, ok, nfev = _solve_on_plane(fun, 0.5 * (za + zb), d / np.linalg.norm(d), scale, tol)
            pts["dense_nfev"] = pts.get("dense_nfev", 0) + nfev
            if ok:
                new.append((seg + 0.5, z))
            else:
                failed.add((L[seg], L[seg + 1]))
        if not new:
            break
        added += len(new)
        pos = np.concatenate([np.arange(L.size, dtype=float), [q for q, _ in new]])
        order = np.argsort(pos, kind="stable")
        X = np.concatenate([X, [z[:-1] for _, z in new]])[order]
        L = np.concatenate([L, [z[-1] for _, z in new]])[order]
        nit = np.concatenate([nit, np.zeros(len(new), int)])[order]
    pts.update(x=X, lam=L, nit=nit, converged=np.ones(L.size, bool), dense_points=added)
    return pts


_AFT_PEAK_GRID = 9  # solves per bracket before Brent when forces are sampled (AFT)


def insert_peaks(prob, pts, fun, tol, elem, dofs, omega_of=lambda l: l):
    """Locate each DOF's resonance peaks (local amplitude maxima) along the branch
    exactly and insert them.

    Around each local maximum i, the branch is parametrised by sigma in [-1, 1] through
    the quadratic interpolant p(sigma) of points i-1, i, i+1; each trial point is the
    exact solution on the hyperplane through p(sigma) normal to p'(sigma) (Newton on
    R = 0 plus that condition) and the amplitude is maximised over sigma (bounded
    Brent).  The maximum is then a converged solution, not a sample of the curve.
    """
    X, L = pts["x"], pts["lam"]
    if L.size < 3:
        return pts
    scale = np.append(np.maximum(np.abs(X).max(0), 1e-12 * np.abs(X).max() + 1e-300),
                      max(np.ptp(L), abs(L).max() * 1e-9, 1e-300))
    todo = []
    for dof in dofs:
        amps = np.array([_dof_amplitude(prob, X[i], L[i], dof, omega_of) for i in range(L.size)])
        todo += [(dof, i, amps[i]) for i in _local_maxima(amps, pts["converged"])]
    found = []  # (position along the branch, z): i + sigma, sigma in [-1, 1]
    for dof, i, amp_i in todo:
        Z = np.column_stack([X[i - 1:i + 2], L[i - 1:i + 2]]) / scale
        nfev = [0]
        cache = {}

        def solve(sig):
            p = 0.5 * sig * (sig - 1) * Z[0] + (1 - sig * sig) * Z[1] + 0.5 * sig * (sig + 1) * Z[2]
            d = (sig - 0.5) * Z[0] - 2 * sig * Z[1] + (sig + 0.5) * Z[2]
            d /= np.linalg.norm(d)

            def aug(z):
                R, Jx, Jl = fun(z[:-1], z[-1])
                nfev[0] += 1
                return (np.append(R, d @ (z / scale - p)),
                        augment(Jx, Jl, d / scale))
            r = newton(aug, p * scale, tol, max_iter=20)
            ok = r.success and np.linalg.norm(fun(r.x[:-1], r.x[-1])[0]) <= tol
            amp = _dof_amplitude(prob, r.x[:-1], r.x[-1], dof, omega_of) if ok else 0.0
            cache[sig] = (r.x, ok, amp)
            # a failed solve ranks below any amplitude (finite: Brent cannot take inf)
            return -amp

        lo, hi = -1.0, 1.0
        if prob.method == "aft":
            # sampled forces alias: the amplitude ripples along the branch with
            # several maxima per bracket, so Brent starts from the best of a grid
            grid = np.linspace(-1.0, 1.0, _AFT_PEAK_GRID)
            vals = [solve(g) for g in grid]
            j = int(np.argmin(vals))
            lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
        minimize_scalar(solve, bounds=(lo, hi), method="bounded", options={"xatol": 1e-4})
        # the highest converged solve of the bracket (Brent's answer or a grid point)
        best = max(cache, key=lambda k: cache[k][2] if cache[k][1] else -np.inf)
        z, ok, amp = cache[best]
        pts["extra_nfev"] += nfev[0]
        if ok and amp > amp_i:
            found.append((i + float(best), z))
    if not found:
        return pts
    # merge in branch order (several DOFs' peaks may fall between the same two points)
    pos = np.concatenate([np.arange(L.size, dtype=float), [f[0] for f in found]])
    order = np.argsort(pos, kind="stable")
    pts["x"] = np.concatenate([X, [f[1][:-1] for f in found]])[order]
    pts["lam"] = np.concatenate([L, [f[1][-1] for f in found]])[order]
    pts["nit"] = np.concatenate([pts["nit"], np.zeros(len(found), int)])[order]
    pts["converged"] = np.concatenate([pts["converged"], np.ones(len(found), bool)])[order]
    return pts
