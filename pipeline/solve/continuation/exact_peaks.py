"""The exact resonance peaks of a traced response branch, inserted as branch points
(`insert_peaks`): each local amplitude maximum located by a search along the branch.

Works on the branch points of `response`, a dict: x (P, nc (2H+1)) condensed
unknowns, lam (P,) parameter, nit (P,), converged (P,), extra_nfev (residual
evaluations of the peak search), and optionally tangent (P entries: the branch
tangent, physical units, or None) and scale (the branch's metric).  Every
added point solves R = 0 (Newton on a hyperplane across the branch,
`newton.solve_on_plane`), so it is a converged solution, not an interpolation.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from .amplitudes import AmplitudeCache, amplitudes_at
from .newton import KeptFactors, solve_on_plane


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
        known = trials.cache.get(sig)   # the branch points, other DOFs' trials (`adopt`)
        return -(trials.solve(sig) if known is None else known)[2]

    lo, hi = -1.0, 1.0
    if grid_first:
        grid = np.linspace(-1.0, 1.0, _AFT_PEAK_GRID)
        vals = [solve(g) for g in grid]
        j = int(np.argmin(vals))
        lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
    minimize_scalar(solve, bounds=(lo, hi), method="bounded", options={"xatol": 1e-4})
