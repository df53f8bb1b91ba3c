"""Points added to a traced response branch for its output: where the drawn curves
bend (`densify`, the `dense_output` of `response.frequency_response`) and at the
exact resonance peaks (`insert_peaks`).

Both work on the branch points of `response`, a dict: x (P, nc (2H+1)) condensed
unknowns, lam (P,) parameter, nit (P,), converged (P,), extra_nfev (residual
evaluations of the peak search), and optionally tangent (P entries: the branch
tangent, physical units, or None) and scale (the branch's metric); `densify` adds
dense_nfev, dense_points and amplitude (P, D) of the DOFs it drew.  Every
added point solves R = 0 (Newton on a hyperplane across the branch), so it is a
converged solution, not an interpolation.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from .amplitudes import AmplitudeCache, amplitudes_at
from .branch import hermite_point
from .newton import KeptFactors, augment, linear_solve, newton


def _local_maxima(amps, converged, rel=0.05, inside=None):
    """Interior local maxima of the amplitude along the branch above rel * max:
    the resonance peaks (several modes in one range), highest first; only at the
    points `inside` (bool, P) if given, the max over those."""
    a = np.where(converged, amps, -np.inf)
    inside = np.ones(a.size, bool) if inside is None else inside
    top = a[inside].max() if inside.any() else -np.inf
    idx = [i for i in range(1, a.size - 1)
           if inside[i] and a[i] >= a[i - 1] and a[i] > a[i + 1] and a[i] >= rel * top]
    return sorted(idx, key=lambda i: -a[i])


# how finely `densify` draws a curve (`test_dense_output` asserts the result)
PLOT_TURN = math.radians(8.0)   # largest turn of the drawn curve at a point
PLOT_TURN_LONG = math.radians(3.0)  # ... and at a point between long chords
PLOT_LONG_CHORD = 0.04          # a chord this long (plot units) shows a small corner
PLOT_MIN_CHORD = 2e-3           # segments shorter than this (plot units) are not split
PLOT_MAX_POINTS = 400           # points `densify` may add to one curve
PLOT_AXES = ("linear", "log")   # the amplitude axes a curve is drawn on
PLOT_PASSES = 8
_START_ITER = 4                 # Newton iterations from a curved start before the chord's
_SMOOTH_COS = math.cos(math.radians(20.0))  # neighbours turning more: not in one curve


def solve_on_plane(fun, p, d, scale, tol, start=None, factors=None):
    """The branch point on the hyperplane through p normal to d (scaled unknowns
    z / scale, d unit): Newton on R = 0 plus that condition, from `start` (scaled),
    else from p.  Newton from `start` gets _START_ITER iterations, undamped: a start
    that does not converge at once (a non-smooth stretch) is abandoned for p, so
    that it cannot wander to another part of the branch.  (z, ok, nfev, tangent):
    the tangent at z in physical units, along d, from the last Jacobian (no
    further evaluation).  Every step is solved on `factors` (`KeptFactors.near`:
    the last factorisation where refinement converges, as exact as a fresh LU; a
    caller's, to start from the previous point's)."""
    nfev = [0]

    def aug(z):
        R, Jx, Jl = fun(z[:-1], z[-1])
        nfev[0] += 1
        return (np.append(R, d @ (z / scale - p)),
                augment(Jx, Jl, d / scale))

    r = None
    factors = KeptFactors() if factors is None else factors
    if start is not None:
        r = newton(aug, start * scale, tol, max_iter=_START_ITER, damped=False,
                   step=factors.near)
    if r is None or not r.success:
        r = newton(aug, p * scale, tol, max_iter=20, step=factors.near)
    return r.x, bool(r.success), nfev[0], _tangent(r.jac, factors) if r.success else None


def _tangent(jac, factors=None):
    """The null direction of the branch equations R = 0 at a point, from the Jacobian
    [dR/dx, dR/dlam; d / scale] of a hyperplane corrector there: its row d / scale
    times the tangent is 1, so the tangent points along d.  With the corrector's
    `KeptFactors`, solved on its last step's factors where near enough.  None if
    singular."""
    e = np.zeros(jac.shape[0])
    e[-1] = 1.0
    try:
        t = linear_solve(jac, e) if factors is None else factors.near(jac, e)
    except (np.linalg.LinAlgError, RuntimeError):
        return None
    return t if np.all(np.isfinite(t)) else None


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


_AFT_PEAK_GRID = 9  # solves per bracket before Brent when forces are sampled (AFT)
_PEAK_XTOL = 1e-6   # the finest sigma the exact peak search resolves (`sigma_tolerance`)
_PEAK_SOLVES = 24   # ... or after this many solves (then Brent's minimiser takes over:
#                     near the root the slope is noise of the trials' convergence, and
#                     12 solves left 4 of a 24-blade wheel's peaks to the coarser Brent)
_NEAR_SIGMA = 0.1   # a trial this close to an earlier one starts from it
LARGEST_MARGIN = 0.8  # `insert_peaks(largest=True)` skips local maxima below this share


def insert_peaks(prob, pts, fun, tol, elem, dofs, omega_of=lambda l: l, largest=False,
                 window=None):
    """Locate each DOF's resonance peaks (local amplitude maxima) along the branch
    exactly and insert them (only those at points with lam in `window` (lo, hi), if
    given: the points outside are read neither as peaks nor as the largest known);
    with `largest`, only those that can be the DOF's largest:
    a local maximum whose three points stay below LARGEST_MARGIN times the largest
    amplitude known of that DOF (its highest point, or a peak located) is left as it
    is (the curve would have to be 1 / LARGEST_MARGIN - 1 = 25 % low there to matter).

    Around each local maximum i, the branch is parametrised by sigma in [-1, 1] through
    the quadratic interpolant p(sigma) of points i-1, i, i+1; each trial point is the
    exact solution on the hyperplane through p(sigma) normal to p'(sigma) (Newton on
    R = 0 plus that condition, `PeakTrials`) and the amplitude is maximised over
    sigma: by a root search for the zero of its derivative along the branch
    (`slope_root_peak`), or by bounded Brent (with sampled forces, or if the root
    search fails).  The maximum is then a converged solution, not a sample of the
    curve.
    """
    X, L = pts["x"], pts["lam"]
    if L.size < 3:
        return pts
    scale = np.append(np.maximum(np.abs(X).max(0), 1e-12 * np.abs(X).max() + 1e-300),
                      max(np.ptp(L), abs(L).max() * 1e-9, 1e-300))
    todo = []
    dofs = list(dofs)
    A = pts.get("amplitude")  # from `densify`, if it drew these DOFs at these points
    if A is None or pts.get("amplitude_dofs") != dofs or len(A) != L.size:
        A = amplitudes_at(prob, X, L, dofs, omega_of)
    best = {}  # dof -> the largest amplitude known of it (`largest`)
    conv = np.asarray(pts["converged"], bool)
    inside = (np.ones(L.size, bool) if window is None
              else (L >= window[0]) & (L <= window[1]))
    for dof, amps in zip(dofs, A.T):
        todo += [(dof, i, amps[i], amps[i - 1:i + 2])
                 for i in _local_maxima(amps, conv, inside=inside)]
        best[dof] = np.max(np.where(conv & inside, amps, -np.inf))
    found = []  # (position along the branch, z): i + sigma, sigma in [-1, 1]
    tangents = list(pts.get("tangent", [None] * L.size))
    solved = {}  # i -> the trials solved around point i, shared by the DOFs peaking there
    amplitude = AmplitudeCache(prob, dofs, omega_of)   # each trial recovered once
    Zall = np.column_stack([X, L]) / scale
    for dof, i, amp_i, amps3 in todo:
        if largest and amps3.max() < LARGEST_MARGIN * best[dof]:
            continue
        Z = np.column_stack([X[i - 1:i + 2], L[i - 1:i + 2]]) / scale
        trials = PeakTrials(prob, fun, tol, scale, Z, dof, omega_of, solved.setdefault(i, {}),
                            amplitude)
        for k in (-1, 0, 1):  # the three points, with their slopes where tangents are known
            trials.known(k, np.append(X[i + k], L[i + k]), tangents[i + k], amps3[k + 1])
        trials.adopt()
        if prob.method == "aft" or not slope_root_peak(trials):
            _brent_peak(trials, prob.method == "aft")
        # the highest converged trial (Brent's answer, the root or a grid point)
        tried = trials.cache
        best_sig = max(tried, key=lambda k: tried[k][2] if tried[k][1] else -np.inf)
        z, ok, amp = tried[best_sig][:3]
        pts["extra_nfev"] += trials.nfev
        if ok and amp > amp_i:
            found.append((_branch_position(Zall, i, best_sig, z / scale), z))
            best[dof] = max(best[dof], amp)
    pts["amplitude"], pts["amplitude_dofs"] = A, dofs
    if not found:
        return pts
    # merge in branch order (several DOFs' peaks may fall between the same two points)
    pos = np.concatenate([np.arange(L.size, dtype=float), [f[0] for f in found]])
    order = np.argsort(pos, kind="stable")
    Zf = np.array([f[1] for f in found])   # their amplitudes: what `largest` reads next
    pts["amplitude"] = (np.concatenate([A, amplitudes_at(prob, Zf[:, :-1], Zf[:, -1], dofs,
                                                         omega_of)])[order] if largest else None)
    pts["x"] = np.concatenate([X, [f[1][:-1] for f in found]])[order]
    pts["lam"] = np.concatenate([L, [f[1][-1] for f in found]])[order]
    pts["nit"] = np.concatenate([pts["nit"], np.zeros(len(found), int)])[order]
    pts["converged"] = np.concatenate([pts["converged"], np.ones(len(found), bool)])[order]
    if "tangent" in pts:
        pts["tangent"] = [(list(pts["tangent"]) + [None] * len(found))[k] for k in order]
    return pts


def _branch_position(Z, i, sigma, z):
    """Position of the branch point z (scaled) found at sigma around point i of the
    branch points Z (scaled): k + f in the segment k -> k + 1 it falls into (the
    side of i that sigma gives), f its projection on that chord.  Peaks found from
    different triples of points (several DOFs) are so ordered alike."""
    k = i - 1 if sigma < 0 else i
    if k < 0 or k + 1 >= len(Z):
        return i + float(sigma)
    d = Z[k + 1] - Z[k]
    f = float((z - Z[k]) @ d) / max(float(d @ d), 1e-300)
    return k + min(max(f, 1e-9), 1.0 - 1e-9)


class PeakTrials:
    """The trial points of one peak search: the branch point on the hyperplane
    through p(sigma) normal to p'(sigma) (p the quadratic through the scaled points
    Z (3, n+1) at sigma = -1, 0, 1), its DOF amplitude and the amplitude's
    derivative in sigma along the branch.  `cache` maps sigma to (z, ok, amplitude,
    derivative, tangent); `nfev` counts the residual evaluations.  `solved` maps
    sigma to (z, ok, tangent) of every trial solved on this quadratic, for any DOF:
    the searches of several DOFs peaking between the same points share them."""

    def __init__(self, prob, fun, tol, scale, Z, dof, omega_of, solved=None, amplitude=None):
        self.prob, self.fun, self.tol, self.scale, self.Z = prob, fun, tol, scale, Z
        self.dof, self.omega_of = dof, omega_of
        self.amplitude_of = amplitude or AmplitudeCache(prob, [dof], omega_of)
        self.cache, self.nfev = {}, 0
        self.solved = {} if solved is None else solved
        self.factors = KeptFactors()  # the last trial's: the next one is near it

    def curve(self, sig):
        Z = self.Z
        p = 0.5 * sig * (sig - 1) * Z[0] + (1 - sig * sig) * Z[1] + 0.5 * sig * (sig + 1) * Z[2]
        dp = (sig - 0.5) * Z[0] - 2 * sig * Z[1] + (sig + 0.5) * Z[2]
        return p, dp

    def amplitude(self, z):
        return self.amplitude_of(z, self.dof)

    def slope(self, sig, z, t):
        """dA/dsigma at the branch point z (physical) with tangent t (physical, any
        length, oriented along p'(sigma) here): A's difference quotient along the unit
        scaled tangent times |p'(sigma)|.  No residual evaluation."""
        dp = self.curve(sig)[1]
        u = t / np.linalg.norm(t / self.scale)
        if u / self.scale @ dp < 0:
            u = -u
        h = 1e-6
        dA = (self.amplitude(z + h * u) - self.amplitude(z - h * u)) / (2 * h)
        return dA * np.linalg.norm(dp)

    def known(self, sig, z, t, amp):
        """Enter a point of the branch at sigma (one of the interpolated points)."""
        self.cache[sig] = (z, True, amp, None if t is None else self.slope(sig, z, t), t)

    def solve(self, sig, near=None):
        """The trial at sigma; Newton starts from the trial at sigma `near` moved along
        its tangent onto the hyperplane, if given, else from p(sigma)."""
        p, dp = self.curve(sig)
        d = dp / np.linalg.norm(dp)
        start = None
        if near is not None and self.cache[near][1] and self.cache[near][4] is not None:
            z0, t0 = self.cache[near][0] / self.scale, self.cache[near][4] / self.scale
            start = z0 + (d @ (p - z0)) / (d @ t0) * t0
        z, ok, nfev, t = solve_on_plane(self.fun, p, d, self.scale, self.tol, start,
                                         self.factors)
        self.nfev += nfev
        self.solved[sig] = (z, ok, t)
        return self.enter(sig, z, ok, t)

    def enter(self, sig, z, ok, t):
        """Cache a solved trial with this DOF's amplitude and slope there."""
        amp = self.amplitude(z) if ok else 0.0
        slope = self.slope(sig, z, t) if ok and t is not None else 0.0
        self.cache[sig] = (z, ok, amp, slope, t)
        return self.cache[sig]

    def adopt(self):
        """Enter the trials other DOFs' searches solved on this quadratic (no
        residual evaluation: their amplitude and slope for this DOF only)."""
        for sig, (z, ok, t) in self.solved.items():
            if sig not in self.cache:
                self.enter(sig, z, ok, t)

    def sigma_tolerance(self, lo, hi):
        """(xtol, curvature): how finely sigma must locate the peak, the parameter to
        1e-8 of its value and the amplitude (stationary there: its error is
        A'' dsigma^2 / 2) to 1e-12, at least _PEAK_XTOL; and A'' = |dA/dsigma|'s
        change over the bracket (lo, hi) per unit sigma."""
        (_, _, a_lo, g_lo, _), (_, _, a_hi, g_hi, _) = self.cache[lo], self.cache[hi]
        p, dp = self.curve(0.5 * (lo + hi))
        lam, dlam = abs(p[-1] * self.scale[-1]), abs(dp[-1] * self.scale[-1])
        curv = abs(g_lo - g_hi) / (hi - lo)
        by_lam = 1e-8 * lam / dlam if dlam > 0 else math.inf
        by_amp = math.sqrt(2e-12 * max(a_lo, a_hi) / curv) if curv > 0 else math.inf
        return max(_PEAK_XTOL, min(by_lam, by_amp, 1e-3 * (hi - lo))), curv


class _TrialFailed(Exception):
    pass


class _PeakFound(Exception):
    pass


def slope_root_peak(trials):
    """The amplitude's maximum on sigma in [-1, 1] as the zero of its derivative
    (Brent's root finder, to _PEAK_XTOL in sigma), bracketed by the known points'
    slopes (`PeakTrials.known`): the middle point's and that of its neighbour on
    the uphill side.  Each trial starts from the nearest trial or point before it
    (`PeakTrials.solve`), so trials close together cost one or two evaluations.
    False (nothing decided) without the slopes, without a bracket, or if a trial
    fails."""
    g = {k: trials.cache[k][3] for k in (-1, 0, 1)}
    if any(v is None for v in g.values()):
        return False
    side = 1 if g[0] > 0 else -1
    if not g[side] * g[0] < 0:
        return False

    lo, hi = _narrowed(trials.cache, *sorted((0.0, float(side))))
    xtol, curv = trials.sigma_tolerance(lo, hi)

    def slope(sig):
        if sig in trials.cache:
            if not trials.cache[sig][1]:
                raise _TrialFailed  # (another DOF's trial that did not converge)
            return trials.cache[sig][3]
        near = min(trials.cache, key=lambda k: abs(k - sig))
        z, ok, amp, g_sig, t = trials.solve(sig, near if abs(near - sig) < _NEAR_SIGMA else None)
        if not ok or t is None:
            raise _TrialFailed
        if abs(g_sig) <= 0.5 * curv * xtol:  # the root is nearer than xtol / 2
            raise _PeakFound
        return g_sig

    try:
        first = _cubic_stationary(trials, lo, hi)
        if first is not None:  # a first trial inside, and the bracket narrowed by it
            lo, hi = (first, hi) if slope(first) > 0 else (lo, first)
        brentq(slope, lo, hi, xtol=xtol, maxiter=_PEAK_SOLVES)
    except _PeakFound:
        return True
    except (_TrialFailed, RuntimeError):
        return False
    return True


def _narrowed(cache, lo, hi):
    """The bracket (lo, hi) of the slope's root (positive at lo, negative at hi)
    narrowed by the trials already inside it (another DOF's search)."""
    inside = {k: v[3] for k, v in cache.items() if lo < k < hi and v[1] and v[3] is not None}
    lo = max([k for k, g in inside.items() if g > 0], default=lo)
    hi = min([k for k, g in inside.items() if g < 0 and k > lo], default=hi)
    return lo, hi


def _cubic_stationary(trials, lo, hi):
    """The stationary point in (lo, hi) of the cubic through the amplitudes and
    slopes of the trials at sigma = lo and hi (a better first trial than the secant
    of the slopes where the amplitude is far from a parabola, near a fold); None if
    it has none there."""
    h = hi - lo
    a0, a1 = trials.cache[lo][2], trials.cache[hi][2]
    g0, g1 = trials.cache[lo][3] * h, trials.cache[hi][3] * h
    # A(v) = a0 + g0 v + c v^2 + e v^3 on v in [0, 1]
    c = 3 * (a1 - a0) - 2 * g0 - g1
    e = g0 + g1 - 2 * (a1 - a0)
    roots = np.roots([3 * e, 2 * c, g0]) if abs(e) > 1e-300 or abs(c) > 1e-300 else []
    v = [r.real for r in roots if abs(r.imag) < 1e-12 and 0.02 < r.real < 0.98]
    return lo + h * v[0] if len(v) == 1 else None


def _brent_peak(trials, grid_first):
    """The amplitude's maximum on sigma in [-1, 1] by bounded Brent (starting from
    the best of a grid, if grid_first: sampled forces alias, the amplitude ripples
    along the branch with several maxima per bracket)."""
    def solve(sig):  # a failed solve ranks below any amplitude (finite: Brent cannot take inf)
        return -trials.solve(sig)[2]

    lo, hi = -1.0, 1.0
    if grid_first:
        grid = np.linspace(-1.0, 1.0, _AFT_PEAK_GRID)
        vals = [solve(g) for g in grid]
        j = int(np.argmin(vals))
        lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
    minimize_scalar(solve, bounds=(lo, hi), method="bounded", options={"xatol": 1e-4})
