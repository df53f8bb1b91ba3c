"""Pseudo-arclength continuation of R(x, lam) = 0 (Keller; NLvib `solve_and_continue`).

Solves the n equations R(x, lam) = 0 for a branch of points (x, lam), x in R^n, by
predictor-corrector steps in the scaled unknowns y = [x; lam] / s:

    predictor   [dR/dx S_x, dR/dlam s_lam; t_prev^T] t = e_{n+1},  t <- t / |t|
                y_pred = y_k + ds t
    corrector   Newton on  R(x, lam) = 0,  t^T (y - y_pred) = 0

Continuation knows nothing about mechanics: `fun(x, lam) -> (R, dR_dx, dR_dlam)`
with R (n,), dR_dx (n, n) dense or scipy.sparse, dR_dlam (n,).

Convergence rule: a point is accepted only if its recomputed residual, in the
caller's units, satisfies ||R||_2 <= tol + tol_rel * r_ref.  Nothing else (Newton
step size, iteration count) ever accepts a point.

Options of `continue_branch` (defaults):
    tol        absolute residual tolerance in the units of R (required)
    tol_rel    0.0; tolerance relative to `r_ref` (a caller-given reference norm,
               e.g. the norm of the excitation)
    ds         0.05   initial step in the scaled metric (~ fraction of the magnitudes)
    ds_min     1e-6   smallest step; below it the run stops with a failure
    ds_max     0.5    largest step
    max_points 500    points including the first one
    max_newton 10     corrector iterations per attempt
    target_newton 4   iterations aimed at by the step control
    max_turn   pi/4   largest angle between successive tangents (scaled metric);
               larger turns are rejected (guards against branch jumping)
    scale      None   automatic: s_lam = |lam_end - lam0|, s_x = running maximum of
               |x| per component, floored at 1e-2 * its largest entry; or an array
               (n+1,) of positive fixed scales [x scales..., lam scale]
    max_deviation 0.3 largest distance of the corrected point from the predictor, in
                      step lengths (scaled metric); farther steps are rejected: the
                      secant left the tangent, i.e. the step crossed a feature
    kink_ds    0.01   below this step, a turn or deviation that persists when the step
                      is halved is accepted as a kink of the branch
    groups     None   (n,) group label per unknown: the automatic x scale is shared
                      within a group (e.g. all Fourier coefficients of one DOF)
    callback   None   callback(x, lam) after each accepted point; return True to stop
    refine_folds True  locate each fold by a few extra correctors (regula falsi on the
               lam-component of the tangent); False: cubic Hermite estimate only
    direction  +1     +1 starts towards lam_end, -1 reverses the initial tangent
               (useful at a fold, where the lam-component of the tangent vanishes,
               or with `lam_back`; otherwise the first step leaves the interval)
    lam_back   None   how far the run may go back beyond lam0 (on the side away from
               lam_end); default lam0.  With it, a branch that turns back past lam0
               (a start between two folds) is followed through its next fold.
    segment_check None  segment_check(x0, lam0, x1, lam1) -> None if a step from the
               current point to the corrected one may be taken, else the largest
               admissible |lam1 - lam0| (e.g. a resonance lies inside the step:
               `resonance.step_guard`); the step is shortened to fit.  A refused
               step that cannot shrink below ds_min is taken and counted in
               `n_unresolved`.

The run stops when lam leaves the interval between lam_back and lam_end (the last
point is then re-solved exactly on the boundary), at max_points, on a callback
request, or when ds < ds_min.

Limits: branch points (bifurcations) are neither detected nor switched (the
bordered system is singular there; the run usually steps over them).  The step
control reads Newton counts, so with an inexact Jacobian (linear convergence) set
target_newton to the count the solver needs, or steps keep shrinking.  The first
tangent is the null vector of [J, J_lam] by a dense QR (O(n^3), robust at a fold);
with a sparse J it is a bordered solve that needs dR/dx regular at lam0.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

log = logging.getLogger(__name__)

_SCALE_FLOOR = 1e-2  # components are weighted at most 100x above the largest one
_FIRST_POINT_ITER = 5  # the first Newton solve gets this many times max_newton
_CORNER_TURN = math.radians(20.0)  # one-sided tangents differing by more: try a corner


# --------------------------------------------------------------------------- Newton
@dataclass(frozen=True, eq=False)
class NewtonResult:
    """Outcome of `newton` (SciPy-style).

    status: 0 converged, 1 iteration limit, 2 singular Jacobian, 3 non-finite
    residual, 4 diverging.  `jac` is the Jacobian at `x` (for reuse, e.g. tangents).
    """

    x: np.ndarray
    success: bool
    status: int
    message: str
    nit: int
    nfev: int
    njev: int
    residual_norm: float
    jac: object = field(default=None, repr=False)


def _solve(A, b):
    """Dense or sparse linear solve; raises LinAlgError / RuntimeError if singular."""
    if sp.issparse(A):
        lu = spla.splu(sp.csc_matrix(A))
        return lu.solve(b)
    return np.linalg.solve(A, b)


def _newton_core(fun, z0, thresh, max_iter, measure, step=_solve, damped=False):
    """Newton on F(z) = 0 with F, dF = fun(z); converged iff measure(F) <= thresh.

    The Newton step is dz = step(dF, -F).  damped=True halves it (up to 6 times)
    until measure(F) decreases: plain Newton can cycle between the linearisations
    of a non-smooth residual (stick/slip, contact) or diverge from a cold start;
    backtracking breaks that.  The continuation corrector stays undamped (its step
    control handles failures, and a first step may rise and still converge).
    Returns (z, status, nit, nfev, njev, rnorm, dF, F).
    """
    z = np.array(z0, dtype=float)
    nfev = njev = 0
    F, dF = fun(z)
    nfev += 1
    r0 = None
    for k in range(max_iter + 1):
        if not np.all(np.isfinite(F)):
            return z, 3, k, nfev, njev, math.inf, dF, F
        r = measure(F)
        if r <= thresh:
            return z, 0, k, nfev, njev, r, dF, F
        r0 = r if r0 is None else r0
        if k >= 2 and r > 1e3 * r0:  # Newton is running away: stop paying for it
            return z, 4, k, nfev, njev, r, dF, F
        if k == max_iter:
            return z, 1, k, nfev, njev, r, dF, F
        try:
            dz = step(dF, -F)
        except (np.linalg.LinAlgError, RuntimeError):
            return z, 2, k, nfev, njev, r, dF, F
        njev += 1
        if not np.all(np.isfinite(dz)):
            return z, 2, k, nfev, njev, r, dF, F
        alpha = 1.0
        for _ in range(7 if damped else 1):
            zt = z + alpha * dz
            Ft, dFt = fun(zt)
            nfev += 1
            if np.all(np.isfinite(Ft)) and measure(Ft) < r:
                break
            alpha *= 0.5
        z, F, dF = zt, Ft, dFt
    raise AssertionError("unreachable")


_NEWTON_MESSAGES = {
    0: "converged: ||R|| <= tol",
    1: "iteration limit reached before ||R|| <= tol",
    2: "singular Jacobian",
    3: "non-finite residual",
    4: "Newton iterations diverging",
}


def newton(fun_x, x0, tol, max_iter=20, damped=True) -> NewtonResult:
    """Newton's method for R(x) = 0 with `fun_x(x) -> (R, dR_dx)`.

    Converged iff the residual evaluated at the returned x satisfies ||R||_2 <= tol
    (absolute, in the units of R).  damped: backtrack until ||R|| decreases (see
    `_newton_core`).  Numerical failure is reported in the result.
    """
    x0 = np.asarray(x0, dtype=float)
    if x0.ndim != 1 or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a finite 1-D array, got shape {x0.shape}")
    if not (np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a positive finite number, got {tol!r}")
    if int(max_iter) != max_iter or max_iter < 0:
        raise ValueError(f"max_iter must be a non-negative integer, got {max_iter!r}")
    n = x0.size

    def checked(x):
        R, J = fun_x(x)
        R = np.asarray(R, dtype=float)
        if R.shape != (n,) or J.shape != (n, n):
            raise ValueError(f"fun_x must return R ({n},) and dR_dx ({n}, {n}), "
                             f"got {R.shape} and {J.shape}")
        return R, J

    z, status, nit, nfev, njev, r, J, _ = _newton_core(
        checked, x0, tol, int(max_iter), np.linalg.norm, damped=damped)
    return NewtonResult(z, status == 0, status, _NEWTON_MESSAGES[status], nit, nfev,
                        njev, float(r), J)


# ---------------------------------------------------------------------- the branch
@dataclass(frozen=True, eq=False)
class Branch:
    """A traced branch (SciPy-style result; arrays are read-only).

    x (m, n), lam (m,)          accepted points, in order along the branch
    tangent (m, n+1)            unit tangents d[x; lam]/ds in physical units,
                                normalised in the final scaled metric
    converged (m,)              True for every returned point (the rule above holds)
    nit (m,)                    Newton iterations of the accepted corrector
    point_nfev (m,)             fun calls spent on each point, rejected attempts included
    residual_norm (m,)          ||R(x, lam)||_2 at each point
    fold_index (k,)             i such that a fold lies between points i and i+1
                                (sign change of the lam-component of the tangent)
    fold_lam (k,), fold_x (k, n)  fold location (refined, see `refine_folds`; not
                                one of the returned points)
    nfev, njev                  total fun calls; Jacobians factorised (Newton steps
                                and tangent solves)
    n_rejected                  rejected step attempts
    n_unresolved                steps taken at ds_min that `segment_check` refused
    scale (n+1,)                final scale [s_x, s_lam]
    status  0 reached lam_end, 1 left the interval on the lam0 side (at lam_back),
            2 max_points, 3 stopped by callback, -1 step below ds_min, -2 first point failed
    """

    x: np.ndarray
    lam: np.ndarray
    tangent: np.ndarray
    converged: np.ndarray
    nit: np.ndarray
    point_nfev: np.ndarray
    residual_norm: np.ndarray
    fold_index: np.ndarray
    fold_lam: np.ndarray
    fold_x: np.ndarray
    nfev: int
    njev: int
    n_rejected: int
    min_step: float          # smallest accepted step (scaled arclength); inf if none
    scale: np.ndarray
    success: bool
    status: int
    message: str
    n_unresolved: int = 0    # steps accepted at ds_min although segment_check refused them

    def __len__(self):
        return self.lam.size


def _frozen(a, dtype=float):
    a = np.array(a, dtype=dtype)
    a.setflags(write=False)
    return a


def _hermite(y0, y1, d0, d1, u):
    """Cubic Hermite point and derivative at u in [0, 1]."""
    h = (2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2)
    dh = (6 * u**2 - 6 * u, 3 * u**2 - 4 * u + 1, -6 * u**2 + 6 * u, 3 * u**2 - 2 * u)
    p = h[0] * y0 + h[1] * d0 + h[2] * y1 + h[3] * d1
    dp = dh[0] * y0 + dh[1] * d0 + dh[2] * y1 + dh[3] * d1
    return p, dp


def _fold_segments(Z, T, s):
    """Folds between scaled points: list of (i, u*, (y0, y1, d0, d1)) from Hermite cubics.

    A fold is a sign change of the lam-component of the tangent; u* is the root in
    [0, 1] of the derivative of the lam-component of the cubic through the two points.
    """
    out = []
    if len(Z) < 2:
        return out
    Y = Z / s
    Ts = T / s
    Ts /= np.linalg.norm(Ts, axis=1, keepdims=True)
    tl = Ts[:, -1]
    for i in np.nonzero(tl[:-1] * tl[1:] < 0)[0]:
        L = np.linalg.norm(Y[i + 1] - Y[i])
        seg = (Y[i], Y[i + 1], L * Ts[i], L * Ts[i + 1])
        y0, y1, d0, d1 = (v[-1] for v in seg)
        a = 6 * y0 + 3 * d0 - 6 * y1 + 3 * d1
        b = -6 * y0 - 4 * d0 + 6 * y1 - 2 * d1
        roots = np.roots([a, b, d0]) if abs(a) > 1e-14 * (abs(b) + abs(d0)) else (
            np.array([-d0 / b]) if b != 0 else np.array([0.5]))
        roots = roots[np.isreal(roots)].real
        roots = roots[(roots >= 0) & (roots <= 1)]
        u = roots[0] if roots.size else tl[i] / (tl[i] - tl[i + 1])
        out.append((int(i), float(u), seg))
    return out


def _check_positive(name, value):
    if not (isinstance(value, (int, float, np.floating, np.integer))
            and np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return float(value)


def _check_count(name, value, minimum):
    if isinstance(value, bool) or int(value) != value or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def continue_branch(fun, x0, lam0, lam_end, *, tol=None, tol_rel=0.0, r_ref=None,
                    ds=0.05, ds_min=1e-6, ds_max=0.5, max_points=500, max_newton=10,
                    target_newton=4, max_turn=math.pi / 4, scale=None, callback=None,
                    direction=+1, refine_folds=True, groups=None,
                    max_deviation=0.3, kink_ds=0.01, lam_back=None,
                    segment_check=None) -> Branch:
    """Trace the solution branch of R(x, lam) = 0 from (x0, lam0) towards lam_end.

    See the module docstring for the equations and the options.  Numerical failure
    is returned as a Branch with success False; bad arguments raise ValueError.
    """
    # ---- argument checks
    if not callable(fun):
        raise ValueError("fun must be callable: fun(x, lam) -> (R, dR_dx, dR_dlam)")
    x0 = np.asarray(x0, dtype=float)
    if x0.ndim != 1 or x0.size == 0 or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a non-empty finite 1-D array, got shape {x0.shape}")
    for name, v in (("lam0", lam0), ("lam_end", lam_end)):
        if not np.isfinite(v):
            raise ValueError(f"{name} must be finite, got {v!r}")
    lam0, lam_end = float(lam0), float(lam_end)
    if lam0 == lam_end:
        raise ValueError(f"lam_end must differ from lam0, both are {lam0}")
    if tol is None:
        raise ValueError("tol must be given: an absolute residual tolerance in the units of R")
    tol = _check_positive("tol", tol)
    if not (np.isfinite(tol_rel) and tol_rel >= 0):
        raise ValueError(f"tol_rel must be a non-negative finite number, got {tol_rel!r}")
    if tol_rel > 0:
        if r_ref is None:
            raise ValueError("r_ref (reference residual norm) is required when tol_rel > 0")
        r_ref = _check_positive("r_ref", r_ref)
    thresh = tol + tol_rel * (r_ref or 0.0)
    ds = _check_positive("ds", ds)
    ds_min = _check_positive("ds_min", ds_min)
    ds_max = _check_positive("ds_max", ds_max)
    if ds_min > ds_max:
        raise ValueError(f"ds_min ({ds_min}) must not exceed ds_max ({ds_max})")
    if not ds_min <= ds <= ds_max:
        raise ValueError(f"ds ({ds}) must lie in [ds_min, ds_max] = [{ds_min}, {ds_max}]")
    max_points = _check_count("max_points", max_points, 1)
    max_newton = _check_count("max_newton", max_newton, 1)
    target_newton = _check_count("target_newton", target_newton, 1)
    max_turn = _check_positive("max_turn", max_turn)
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if callback is not None and not callable(callback):
        raise ValueError("callback must be callable or None")
    n = x0.size
    if groups is not None:
        groups = np.asarray(groups, dtype=int)
        if groups.shape != (x0.size,) or groups.min() < 0:
            raise ValueError(f"groups must be {x0.size} non-negative integers (one per unknown)")
    auto_scale = scale is None
    if auto_scale:
        xmax = np.zeros(n)
        s = np.empty(n + 1)
        s[n] = abs(lam_end - lam0)
    else:
        s = np.array(scale, dtype=float)
        if s.shape != (n + 1,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ValueError(f"scale must be a positive finite array of shape ({n + 1},) "
                             f"[x scales..., lam scale], got {np.shape(scale)}")

    def update_scale():
        if auto_scale:
            xm = xmax
            if groups is not None:  # unknowns of one group share the group's scale
                gmax = np.zeros(groups.max() + 1)
                np.maximum.at(gmax, groups, xmax)
                xm = gmax[groups]
            top = xm.max()
            s[:n] = np.maximum(xm, _SCALE_FLOOR * top) if top > 0 else 1.0

    update_scale()
    lo, hi = min(lam0, lam_end), max(lam0, lam_end)
    if lam_back is not None:
        if not (np.isfinite(lam_back) and (lam_back - lam0) * (lam_end - lam0) <= 0):
            raise ValueError(f"lam_back must be finite and lie beyond lam0 = {lam0} away from "
                             f"lam_end = {lam_end}, got {lam_back!r}")
        lo, hi = min(lam_back, lam_end), max(lam_back, lam_end)
    cos_turn = math.cos(min(max_turn, math.pi))
    sparse = None

    def evaluate(x, lam):
        nonlocal sparse
        R, Jx, Jl = fun(x, lam)
        R = np.asarray(R, dtype=float)
        Jl = np.asarray(Jl, dtype=float).reshape(-1)
        if sparse is None:
            if R.shape != (n,) or Jx.shape != (n, n) or Jl.shape != (n,):
                raise ValueError(
                    f"fun must return R ({n},), dR_dx ({n}, {n}), dR_dlam ({n},); got "
                    f"{R.shape}, {getattr(Jx, 'shape', None)}, {Jl.shape}")
            sparse = sp.issparse(Jx)
        if not sparse:
            Jx = np.asarray(Jx, dtype=float)
        return R, Jx, Jl

    def bordered(Jx, Jl, row):
        """[[Jx S_x, Jl s_lam], [row]] in the scaled unknowns."""
        if sparse:
            return sp.bmat([[Jx @ sp.diags(s[:n]), (Jl * s[n])[:, None]],
                            [row[None, :n], row[None, n:]]], format="csc")
        A = np.empty((n + 1, n + 1))
        A[:n, :n] = Jx * s[:n]
        A[:n, n] = Jl * s[n]
        A[n] = row
        return A

    def tangent_from(Jx, Jl, t_prev_phys):
        """Unit scaled tangent oriented along t_prev, its cosine with t_prev, physical t."""
        tp = t_prev_phys / s
        tp /= np.linalg.norm(tp)
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        try:
            w = _solve(bordered(Jx, Jl, tp), rhs)
        except (np.linalg.LinAlgError, RuntimeError):
            return None
        nw = np.linalg.norm(w)
        if not np.isfinite(nw) or nw == 0:
            return None
        t = w / nw
        return t, float(t @ tp), t * s

    counters = {"nfev": 0, "njev": 0}
    Z, T, NIT, PNFEV, RN = [], [], [], [], []

    def result(status, message):
        m = len(Z)
        Zs = np.array(Z, float).reshape(m, n + 1)
        Ts = np.array(T, float).reshape(m, n + 1)
        if m:
            Ts = Ts / np.linalg.norm(Ts / s, axis=1, keepdims=True)
        folds = [refine_fold(*f) for f in _fold_segments(Zs, Ts, s)]
        fi = np.array([f[0] for f in folds], int)
        fl = np.array([f[1][n] for f in folds], float)
        fx = np.array([f[1][:n] for f in folds], float).reshape(len(folds), n)
        success = status >= 0 and status != 2
        log.debug("continuation: %d points, %d folds, nfev=%d: %s", m, fi.size,
                 counters["nfev"], message)
        return Branch(
            x=_frozen(Zs[:, :n]), lam=_frozen(Zs[:, n]), tangent=_frozen(Ts),
            converged=_frozen(np.ones(m, bool), bool), nit=_frozen(NIT, int),
            point_nfev=_frozen(PNFEV, int), residual_norm=_frozen(RN),
            fold_index=_frozen(fi, int), fold_lam=_frozen(fl), fold_x=_frozen(fx),
            nfev=counters["nfev"], njev=counters["njev"], n_rejected=n_rejected,
            min_step=min_step,
            scale=_frozen(s), success=success, status=status, message=message,
            n_unresolved=n_unresolved)

    n_rejected = 0
    n_unresolved = 0
    min_step = math.inf

    def refine_fold(i, u, seg):
        """Fold between points i, i+1: zero of the tangent's lam-component along the
        branch by Illinois regula falsi on u, each value from a corrector on the
        hyperplane through the Hermite point p(u) normal to p'(u).  Falls back to the
        Hermite point if a corrector fails."""
        y0, y1, d0, d1 = seg
        p, _ = _hermite(y0, y1, d0, d1, u)
        best = p * s
        if not refine_folds:
            return i, best

        def g(u):
            p, dp = _hermite(y0, y1, d0, d1, u)
            nrm = dp / np.linalg.norm(dp)

            def aug(zz):
                R, Jx, Jl = evaluate(zz[:n], zz[n])
                return np.append(R, nrm @ (zz / s - p)), (Jx, Jl)

            zc, st, _, nfev, njev, _, JJ, _ = _newton_core(
                aug, p * s, thresh, max_newton, lambda F: np.linalg.norm(F[:n]),
                lambda JJ, rhs: s * _solve(bordered(JJ[0], JJ[1], nrm), rhs))
            counters["nfev"] += nfev
            counters["njev"] += njev + 1
            tan = tangent_from(*JJ, dp * s) if st == 0 else None
            return (None, None) if tan is None else (tan[0][n], zc)

        a, b = 0.0, 1.0
        ga, gb = d0[-1] / np.linalg.norm(d0), d1[-1] / np.linalg.norm(d1)
        side = 0
        for _ in range(12):
            gu, zc = g(u)
            if gu is None:
                break
            best = zc
            if abs(gu) < 1e-9:
                break
            if np.sign(gu) == np.sign(ga):
                a, ga = u, gu
                if side == -1:
                    gb *= 0.5
                side = -1
            else:
                b, gb = u, gu
                if side == 1:
                    ga *= 0.5
                side = 1
            u = (a * gb - b * ga) / (gb - ga)
        return i, best

    def solve_fixed_lam(xg, lam):
        """Newton at fixed lam; also returns (R, Jx, Jl) at the last iterate."""
        def fx(x):
            R, Jx, Jl = evaluate(x, lam)
            return R, (R, Jx, Jl)
        z, st, nit, nfev, njev, r, RJJ, _ = _newton_core(
            fx, xg, thresh, _FIRST_POINT_ITER * max_newton, np.linalg.norm,
            lambda RJJ, rhs: _solve(RJJ[1], rhs))
        counters["nfev"] += nfev
        counters["njev"] += njev
        return z, st, nit, nfev, r, RJJ

    # ---- first point: Newton at fixed lam0
    x, st, nit, nfev, r, (R, Jx, Jl) = solve_fixed_lam(x0, lam0)
    if st != 0:
        return result(-2, f"first point at lam0 = {lam0} did not converge: "
                          f"{_NEWTON_MESSAGES[st]} (||R|| = {r:.3e}, tol = {thresh:.3e})")
    if auto_scale:  # from the solution, not from the caller's guess
        xmax = np.abs(x)
        update_scale()
    if sparse:
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        e = np.zeros(n + 1)
        e[n] = 1.0
        try:
            t = _solve(bordered(Jx, Jl, e), rhs)
        except (np.linalg.LinAlgError, RuntimeError):
            return result(-2, "tangent at the first point failed: singular dR_dx at lam0")
    else:  # null vector of [Jx S_x, Jl s_lam]: robust even at a fold
        A0 = np.hstack([Jx * s[:n], (Jl * s[n])[:, None]])
        Q, _ = sla.qr(A0.T)
        t = Q[:, -1].copy()
    counters["njev"] += 1
    t /= np.linalg.norm(t)
    sgn = np.sign(t[n] * (lam_end - lam0))
    if abs(t[n]) < 1e-12:  # start at a fold: orient by the growth of |x|
        sgn = np.sign(t[:n] @ (x / s[:n])) or 1.0
    t *= sgn * direction
    t_phys = t * s
    z = np.append(x, lam0)
    Z.append(z)
    T.append(t_phys)
    NIT.append(nit)
    PNFEV.append(nfev)
    RN.append(np.linalg.norm(R))
    if callback is not None and callback(x.copy(), lam0):
        return result(3, "stopped by callback")
    if max_points == 1:
        return result(2, "max_points reached before lam_end")

    # ---- predictor-corrector loop
    spent = 0
    last = {}
    if not auto_scale:
        xmax = None

    def is_kink(what, value):
        """A smooth curve's turn and predictor deviation shrink in proportion to the
        step; once the step is small (< kink_ds, while crossing a resonance needs a
        step of order one in the scaled metric), a rejection that survives three
        halvings there is a corner of the branch (e.g. a change of the stick/slip
        pattern), not a jump: it is accepted."""
        prev = last.get(what)
        last[what] = value
        if ds >= kink_ds:
            return False
        last["small"] = last.get("small", 0) + 1
        return last["small"] > 3 or (prev is not None and value > 0.75 * prev)

    def correct(y_pred, normal):
        """Corrector on the hyperplane through y_pred normal to `normal` (scaled)."""
        nonlocal spent

        def aug(zz):
            R, Jx, Jl = evaluate(zz[:n], zz[n])
            return np.append(R, normal @ (zz / s - y_pred)), (Jx, Jl)

        def scaled_step(JJ, rhs):  # Newton in the scaled unknowns: dz = S dy
            return s * _solve(bordered(JJ[0], JJ[1], normal), rhs)

        zn, st, nit, nfev, njev, r, JJ, F = _newton_core(
            aug, y_pred * s, thresh, max_newton, lambda F: np.linalg.norm(F[:n]),
            scaled_step)
        counters["nfev"] += nfev
        counters["njev"] += njev
        spent += nfev
        if st == 0 and abs(F[n]) > 1e-6 * max(np.linalg.norm(y_pred - z / s), 1e-12):
            st = -1  # arclength condition not met
        return zn, st, nit, nfev, r, JJ

    def oriented_tangent(JJ, along):
        """Unit scaled tangent at a point (Jacobians JJ) oriented along `along` (scaled)."""
        tan = tangent_from(JJ[0], JJ[1], along * s)
        counters["njev"] += 1
        return None if tan is None else tan[0]

    def pass_corner(ts, zn, JJn):
        """A corner of the branch between z and the rejected corrector point zn.

        The branch is piecewise smooth (stick/slip/separation patterns change at
        corners): where one-sided tangents differ, halving the step only creeps
        towards the corner.  Instead, the corner is located as the meeting point
        c = y + a t = y_n - b t_n of the line along the tangent t at z and the line
        back along the tangent t_n at zn (least squares, scaled metric), and two
        points are solved: y1 just before c (corrector normal to t at 0.98 a; its
        tangent must still be t) and y2 beyond it (predictor c + d t_n, corrector
        normal to t_n, d = min(ds, b)); y2 must lie near its predictor and its
        tangent near t_n.  A smooth turn fails these tests (its chords and middle
        tangents lie between t and t_n), so only genuine corners pass.  Returns the
        accepted points [(z, t_scaled, nit, r)] (possibly only y1), or None.
        """
        y0, yn = z / s, zn / s
        tn = oriented_tangent(JJn, yn - y0)
        if tn is None:
            return None
        (a, b), *_ = np.linalg.lstsq(np.column_stack([ts, tn]), yn - y0, rcond=None)
        if b < 0:
            tn, b = -tn, -b
        turn = math.acos(float(np.clip(ts @ tn, -1.0, 1.0)))
        gap = np.linalg.norm(y0 + a * ts + b * tn - yn)
        if not (turn > _CORNER_TURN and 0 < a <= ds and gap <= 0.25 * max(a, b)):
            return None
        tol_angle = max(0.2 * turn, math.radians(2.0))
        out = []
        c = y0 + a * ts
        if a > 0.05 * ds:  # a point just before the corner
            y1p = y0 + 0.98 * a * ts
            z1, st1, nit1, _, r1, JJ1 = correct(y1p, ts)
            if st1 != 0:
                return None
            t1 = oriented_tangent(JJ1, ts)
            if t1 is None or np.linalg.norm(z1 / s - y1p) > max_deviation * 0.98 * a:
                return None
            if math.acos(min(1.0, float(t1 @ ts))) > tol_angle:
                return None
            out.append((z1, t1, nit1, r1))
        d = min(ds, b)
        for _ in range(2):
            y2p = c + d * tn
            z2, st2, nit2, _, r2, JJ2 = correct(y2p, tn)
            t2 = oriented_tangent(JJ2, tn) if st2 == 0 else None
            if (t2 is not None and np.linalg.norm(z2 / s - y2p) <= max_deviation * d
                    and math.acos(min(1.0, float(t2 @ tn))) <= max_turn):
                out.append((z2, t2, nit2, r2))
                break
            d *= 0.25
        return out or None

    def commit(zn, t_new_phys, nit, r):
        """Append an accepted point; a Branch when the run ends there, else None."""
        nonlocal z, t_phys, spent, xmax
        lam_new = zn[n]
        if not lo <= lam_new <= hi:
            bound = hi if lam_new > hi else lo
            frac = (bound - z[n]) / (lam_new - z[n])
            xg = z[:n] + frac * (zn[:n] - z[:n])
            if not (bound == lam0 and len(Z) == 1):
                xb, stb, nitb, nfevb, rb, (R, Jx, Jl) = solve_fixed_lam(xg, bound)
                spent += nfevb
                if stb == 0:
                    tb = tangent_from(Jx, Jl, t_phys)
                    counters["njev"] += 1
                    if tb is not None:
                        zn, nit, t_new_phys = np.append(xb, bound), nitb, tb[2]
                        r = np.linalg.norm(R)
                Z.append(zn)
                T.append(t_new_phys)
                NIT.append(nit)
                PNFEV.append(spent)
                RN.append(r)
            if bound == lam_end:
                return result(0, f"reached lam_end = {lam_end}")
            return result(1, f"left the interval at lam = {bound} (branch turned back)")
        z, t_phys = zn, t_new_phys
        Z.append(z)
        T.append(t_phys)
        NIT.append(nit)
        PNFEV.append(spent)
        RN.append(r)
        spent = 0
        if auto_scale:
            xmax = np.maximum(xmax, np.abs(z[:n]))
            update_scale()
        if callback is not None and callback(z[:n].copy(), z[n]):
            return result(3, "stopped by callback")
        if len(Z) >= max_points:
            return result(2, "max_points reached before lam_end")
        return None

    while True:
        ts = t_phys / s
        ts /= np.linalg.norm(ts)
        y_pred = z / s + ds * ts
        zn, st, nit, nfev, r, JJ = correct(y_pred, ts)
        reason = None
        feature = False  # rejected for a turn or a deviation: possibly a corner
        if st == -1:
            reason = "arclength condition not met"
        elif st != 0:
            reason = _NEWTON_MESSAGES[st]
        if reason is None:
            # the corrector must stay near the predictor: a large deviation of the
            # secant from the tangent means the step jumped over a feature (e.g. a
            # resonance of a branch Newton finds easy), even if the tangents agree
            dev = np.linalg.norm(zn / s - y_pred) / ds
            if dev > max_deviation and ds > ds_min:
                if is_kink("deviation", dev):
                    log.debug("kink passed: deviation %.2f persists as ds shrinks", dev)
                else:
                    reason = f"corrector moved {dev:.2f} step lengths from the predictor"
                    feature = True
        if reason is None:
            Jx, Jl = JJ
            tan = tangent_from(Jx, Jl, t_phys)
            counters["njev"] += 1
            if tan is None:
                reason = "singular tangent system"
            elif tan[1] < cos_turn and ds > ds_min:
                angle = math.acos(min(1.0, tan[1]))
                if is_kink("turn", angle):
                    log.debug("kink passed: turn %.1f deg persists as ds shrinks",
                              math.degrees(angle))
                else:
                    reason = f"tangent turned by {math.degrees(angle):.1f} deg"
                    feature = True
        shrink = 0.5
        if reason is None and segment_check is not None:
            width = segment_check(z[:n], z[n], zn[:n], zn[n])
            if width is not None and ds > ds_min:
                step = abs(zn[n] - z[n])
                reason = f"a resonance inside the step (|dlam| = {step:.3g} > {width:.3g})"
                shrink = min(0.5, max(0.9 * width / step, 1e-3))
            elif width is not None:
                n_unresolved += 1
                log.debug("step at ds_min taken although segment_check refused it")
        if reason is not None:
            n_rejected += 1
            corner = pass_corner(ts, zn, JJ) if feature else None
            if corner:
                log.debug("corner passed with %d point(s) (%s)", len(corner), reason)
                last.clear()
                min_step = min(min_step, ds)
                for zc, tc, nitc, rc in corner:
                    done = commit(zc, tc * s, nitc, rc)
                    if done is not None:
                        return done
                continue
            ds *= shrink
            log.debug("step rejected (%s); ds -> %.3e", reason, ds)
            if shrink < 0.5 and ds < ds_min:  # try the smallest step before giving up
                ds = ds_min
            if ds < ds_min:
                return result(-1, f"step size below ds_min = {ds_min:g} at lam = "
                                  f"{z[n]:.6g} (last failure: {reason})")
            continue

        # accepted
        last.clear()
        min_step = min(min_step, ds)
        done = commit(zn, tan[2], nit, r)
        if done is not None:
            return done
        factor = math.sqrt(target_newton / max(nit, 1))
        ds = min(max(ds * min(max(factor, 0.5), 2.0), ds_min), ds_max)
