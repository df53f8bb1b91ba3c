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

Pieces: `continuation_options` checks the options once into a frozen
`ContinuationOptions`; `Metric` holds the scale s (`automatic_scale`);
`ScaledEquations` evaluates R and solves the bordered systems in y, counting the
costs; a `Tracer` runs the steps (first point, predict, correct, assess, accept or
reject, pass corner, commit) and returns the `Branch`, whose folds `refine_fold`
locates.  `continue_branch` builds the options and runs a Tracer.
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


# ---------------------------------------------------------------------- the options
def _check_positive(name, value):
    if not (isinstance(value, (int, float, np.floating, np.integer))
            and np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return float(value)


def _check_count(name, value, minimum):
    if isinstance(value, bool) or int(value) != value or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


@dataclass(frozen=True, eq=False)
class ContinuationOptions:
    """The validated options of `continue_branch` (module docstring), for a branch of
    n unknowns from lam0 towards lam_end.  Build it with `continuation_options`."""

    n: int
    lam0: float
    lam_end: float
    tol: float
    tol_rel: float
    r_ref: float | None
    ds: float
    ds_min: float
    ds_max: float
    max_points: int
    max_newton: int
    target_newton: int
    max_turn: float
    scale: np.ndarray | None    # (n+1,) fixed scales, or None: automatic
    callback: object
    direction: int
    refine_folds: bool
    groups: np.ndarray | None
    max_deviation: float
    kink_ds: float
    lam_back: float | None
    segment_check: object

    @property
    def thresh(self) -> float:
        """The residual bound of the convergence rule, tol + tol_rel * r_ref."""
        return self.tol + self.tol_rel * (self.r_ref or 0.0)

    @property
    def cos_turn(self) -> float:
        return math.cos(min(self.max_turn, math.pi))

    @property
    def bounds(self) -> tuple:
        """(lo, hi): the run stops where lam leaves [lo, hi] (lam_back to lam_end)."""
        far = self.lam0 if self.lam_back is None else self.lam_back
        return min(far, self.lam_end), max(far, self.lam_end)


def _check_start(x0):
    x0 = np.asarray(x0, dtype=float)
    if x0.ndim != 1 or x0.size == 0 or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a non-empty finite 1-D array, got shape {x0.shape}")
    return x0


def _check_interval(lam0, lam_end):
    for name, v in (("lam0", lam0), ("lam_end", lam_end)):
        if not np.isfinite(v):
            raise ValueError(f"{name} must be finite, got {v!r}")
    lam0, lam_end = float(lam0), float(lam_end)
    if lam0 == lam_end:
        raise ValueError(f"lam_end must differ from lam0, both are {lam0}")
    return lam0, lam_end


def _check_tolerance(tol, tol_rel, r_ref):
    if tol is None:
        raise ValueError("tol must be given: an absolute residual tolerance in the units of R")
    tol = _check_positive("tol", tol)
    if not (np.isfinite(tol_rel) and tol_rel >= 0):
        raise ValueError(f"tol_rel must be a non-negative finite number, got {tol_rel!r}")
    if tol_rel > 0:
        if r_ref is None:
            raise ValueError("r_ref (reference residual norm) is required when tol_rel > 0")
        r_ref = _check_positive("r_ref", r_ref)
    return tol, tol_rel, r_ref


def _check_steps(ds, ds_min, ds_max):
    ds = _check_positive("ds", ds)
    ds_min = _check_positive("ds_min", ds_min)
    ds_max = _check_positive("ds_max", ds_max)
    if ds_min > ds_max:
        raise ValueError(f"ds_min ({ds_min}) must not exceed ds_max ({ds_max})")
    if not ds_min <= ds <= ds_max:
        raise ValueError(f"ds ({ds}) must lie in [ds_min, ds_max] = [{ds_min}, {ds_max}]")
    return ds, ds_min, ds_max


def _check_metric(n, groups, scale):
    if groups is not None:
        groups = np.asarray(groups, dtype=int)
        if groups.shape != (n,) or groups.min() < 0:
            raise ValueError(f"groups must be {n} non-negative integers (one per unknown)")
        groups = _frozen(groups, int)
    if scale is not None:
        s = np.array(scale, dtype=float)
        if s.shape != (n + 1,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ValueError(f"scale must be a positive finite array of shape ({n + 1},) "
                             f"[x scales..., lam scale], got {np.shape(scale)}")
        scale = _frozen(s)
    return groups, scale


def _check_lam_back(lam_back, lam0, lam_end):
    if lam_back is not None and not (
            np.isfinite(lam_back) and (lam_back - lam0) * (lam_end - lam0) <= 0):
        raise ValueError(f"lam_back must be finite and lie beyond lam0 = {lam0} away from "
                         f"lam_end = {lam_end}, got {lam_back!r}")


def continuation_options(n, lam0, lam_end, *, tol=None, tol_rel=0.0, r_ref=None, ds=0.05,
                         ds_min=1e-6, ds_max=0.5, max_points=500, max_newton=10,
                         target_newton=4, max_turn=math.pi / 4, scale=None, callback=None,
                         direction=+1, refine_folds=True, groups=None, max_deviation=0.3,
                         kink_ds=0.01, lam_back=None,
                         segment_check=None) -> ContinuationOptions:
    """The options of `continue_branch` for n unknowns, checked: a ValueError names
    the first bad argument (in the order of the signature)."""
    lam0, lam_end = _check_interval(lam0, lam_end)
    tol, tol_rel, r_ref = _check_tolerance(tol, tol_rel, r_ref)
    ds, ds_min, ds_max = _check_steps(ds, ds_min, ds_max)
    max_points = _check_count("max_points", max_points, 1)
    max_newton = _check_count("max_newton", max_newton, 1)
    target_newton = _check_count("target_newton", target_newton, 1)
    max_turn = _check_positive("max_turn", max_turn)
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if callback is not None and not callable(callback):
        raise ValueError("callback must be callable or None")
    groups, scale = _check_metric(n, groups, scale)
    _check_lam_back(lam_back, lam0, lam_end)
    return ContinuationOptions(
        n=n, lam0=lam0, lam_end=lam_end, tol=tol, tol_rel=tol_rel, r_ref=r_ref, ds=ds,
        ds_min=ds_min, ds_max=ds_max, max_points=max_points, max_newton=max_newton,
        target_newton=target_newton, max_turn=max_turn, scale=scale, callback=callback,
        direction=int(direction), refine_folds=refine_folds, groups=groups,
        max_deviation=max_deviation, kink_ds=kink_ds, lam_back=lam_back,
        segment_check=segment_check)


# ---------------------------------------------------------------------- the metric
def automatic_scale(xmax, groups=None):
    """s_x from the running maximum |x| per unknown: shared within a group (the
    group's largest), floored at _SCALE_FLOOR times the largest entry; all ones
    while x = 0."""
    xm = xmax
    if groups is not None:
        gmax = np.zeros(groups.max() + 1)
        np.maximum.at(gmax, groups, xmax)
        xm = gmax[groups]
    top = xm.max()
    return np.maximum(xm, _SCALE_FLOOR * top) if top > 0 else np.ones_like(xm)


class Metric:
    """The scale s = [s_x, s_lam] of the unknowns y = [x; lam] / s.

    Fixed: the caller's scale.  Automatic: s_lam = |lam_end - lam0| and s_x from the
    points seen so far (`automatic_scale`).  `s` is updated in place, so every
    holder of it sees the current scale.
    """

    def __init__(self, n, lam_span, groups=None, fixed=None):
        self.groups = groups
        self.automatic = fixed is None
        if self.automatic:
            self.xmax = np.zeros(n)
            self.s = np.empty(n + 1)
            self.s[n] = lam_span
            self.s[:n] = automatic_scale(self.xmax, groups)
        else:
            self.s = np.array(fixed, dtype=float)

    def observe(self, x):
        """Widen the automatic x scale by a new point's |x|."""
        if self.automatic:
            self.xmax = np.maximum(self.xmax, np.abs(x))
            self.s[:x.size] = automatic_scale(self.xmax, self.groups)


# ---------------------------------------------------------------------- the equations
class ScaledEquations:
    """R(x, lam) = 0 in the scaled unknowns y = [x; lam] / s: the evaluations, bordered
    systems, tangents and Newton solves of a continuation run, and their costs
    (nfev: fun calls; njev: Jacobians factorised, Newton steps and tangent solves)."""

    def __init__(self, fun, opts: ContinuationOptions):
        self.fun, self.n = fun, opts.n
        self.thresh, self.max_newton = opts.thresh, opts.max_newton
        self.metric = Metric(opts.n, abs(opts.lam_end - opts.lam0), opts.groups, opts.scale)
        self.sparse = None  # dR_dx sparse? known from the first evaluation
        self.nfev = self.njev = 0

    @property
    def s(self):
        return self.metric.s

    def evaluate(self, x, lam):
        """fun(x, lam) with its shapes checked once; dense Jacobians as arrays."""
        n = self.n
        R, Jx, Jl = self.fun(x, lam)
        R = np.asarray(R, dtype=float)
        Jl = np.asarray(Jl, dtype=float).reshape(-1)
        if self.sparse is None:
            if R.shape != (n,) or Jx.shape != (n, n) or Jl.shape != (n,):
                raise ValueError(
                    f"fun must return R ({n},), dR_dx ({n}, {n}), dR_dlam ({n},); got "
                    f"{R.shape}, {getattr(Jx, 'shape', None)}, {Jl.shape}")
            self.sparse = sp.issparse(Jx)
        if not self.sparse:
            Jx = np.asarray(Jx, dtype=float)
        return R, Jx, Jl

    def bordered(self, Jx, Jl, row):
        """[[Jx S_x, Jl s_lam], [row]] in the scaled unknowns."""
        n, s = self.n, self.s
        if self.sparse:
            return sp.bmat([[Jx @ sp.diags(s[:n]), (Jl * s[n])[:, None]],
                            [row[None, :n], row[None, n:]]], format="csc")
        A = np.empty((n + 1, n + 1))
        A[:n, :n] = Jx * s[:n]
        A[:n, n] = Jl * s[n]
        A[n] = row
        return A

    def tangent_from(self, Jx, Jl, t_prev_phys):
        """Unit scaled tangent oriented along t_prev, its cosine with t_prev, physical t."""
        n, s = self.n, self.s
        tp = t_prev_phys / s
        tp /= np.linalg.norm(tp)
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        try:
            w = _solve(self.bordered(Jx, Jl, tp), rhs)
        except (np.linalg.LinAlgError, RuntimeError):
            return None
        nw = np.linalg.norm(w)
        if not np.isfinite(nw) or nw == 0:
            return None
        t = w / nw
        return t, float(t @ tp), t * s

    def null_vector(self, Jx, Jl):
        """Unit null vector (sign arbitrary) of [Jx S_x, Jl s_lam]: by a dense QR
        (robust even at a fold), or with a sparse Jx a bordered solve (needs Jx
        regular); None if singular."""
        n, s = self.n, self.s
        if self.sparse:
            e = np.zeros(n + 1)
            e[n] = 1.0
            try:
                t = _solve(self.bordered(Jx, Jl, e), e)
            except (np.linalg.LinAlgError, RuntimeError):
                return None
        else:
            Q, _ = sla.qr(np.hstack([Jx * s[:n], (Jl * s[n])[:, None]]).T)
            t = Q[:, -1].copy()
        self.njev += 1
        t /= np.linalg.norm(t)
        return t

    def oriented_tangent(self, JJ, along):
        """Unit scaled tangent at a point (Jacobians JJ) oriented along `along` (scaled)."""
        tan = self.tangent_from(JJ[0], JJ[1], along * self.s)
        self.njev += 1
        return None if tan is None else tan[0]

    def solve_fixed_lam(self, xg, lam):
        """Newton at fixed lam; also returns (R, Jx, Jl) at the last iterate."""
        def fx(x):
            R, Jx, Jl = self.evaluate(x, lam)
            return R, (R, Jx, Jl)
        z, st, nit, nfev, njev, r, RJJ, _ = _newton_core(
            fx, xg, self.thresh, _FIRST_POINT_ITER * self.max_newton, np.linalg.norm,
            lambda RJJ, rhs: _solve(RJJ[1], rhs))
        self.nfev += nfev
        self.njev += njev
        return z, st, nit, nfev, r, RJJ

    def solve_on_plane(self, y, normal):
        """Newton on R(x, lam) = 0 and normal . (z / s - y) = 0 from z = y s (scaled
        unknowns); the `_newton_core` tuple, its costs counted."""
        n, s = self.n, self.s

        def aug(zz):
            R, Jx, Jl = self.evaluate(zz[:n], zz[n])
            return np.append(R, normal @ (zz / s - y)), (Jx, Jl)

        def scaled_step(JJ, rhs):  # Newton in the scaled unknowns: dz = S dy
            return s * _solve(self.bordered(JJ[0], JJ[1], normal), rhs)

        out = _newton_core(aug, y * s, self.thresh, self.max_newton,
                           lambda F: np.linalg.norm(F[:n]), scaled_step)
        self.nfev += out[3]
        self.njev += out[4]
        return out


# ---------------------------------------------------------------------- folds
def refine_fold(eq, i, u, seg, refine=True):
    """Fold between points i, i+1: zero of the tangent's lam-component along the
    branch by Illinois regula falsi on u, each value from a corrector on the
    hyperplane through the Hermite point p(u) normal to p'(u) (`fold_corrector`).
    Falls back to the Hermite point if a corrector fails."""
    y0, y1, d0, d1 = seg
    p, _ = _hermite(y0, y1, d0, d1, u)
    best = p * eq.s
    if not refine:
        return i, best
    a, b = 0.0, 1.0
    ga, gb = d0[-1] / np.linalg.norm(d0), d1[-1] / np.linalg.norm(d1)
    side = 0
    for _ in range(12):
        gu, zc = fold_corrector(eq, seg, u)
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


def fold_corrector(eq, seg, u):
    """(lam-component of the unit scaled tangent, point) of the branch point on
    the hyperplane through the Hermite point p(u) normal to p'(u); (None, None)
    if the corrector fails."""
    p, dp = _hermite(*seg, u)
    zc, st, _, _, _, _, JJ, _ = eq.solve_on_plane(p, dp / np.linalg.norm(dp))
    eq.njev += 1
    tan = eq.tangent_from(*JJ, dp * eq.s) if st == 0 else None
    return (None, None) if tan is None else (tan[0][eq.n], zc)


# ---------------------------------------------------------------------- the tracer
class Tracer:
    """One run of `continue_branch`: the state its steps share, and the steps.

    State: the current point z = [x; lam] and its tangent t_phys (physical units),
    the step ds, the accepted points, the rejections; the equations `eq` hold the
    metric and count the costs.  `run` solves the
    first point, then repeats `step` (predict, correct, assess, then accept or
    reject, a rejection possibly passing a corner) until one returns the Branch.
    """

    def __init__(self, fun, opts: ContinuationOptions):
        self.opts, self.n = opts, opts.n
        self.eq = ScaledEquations(fun, opts)
        self.ds = opts.ds
        self.z = self.t_phys = None
        self.points = []    # (z, t_phys, nit, nfev, ||R||) of each accepted point
        self.n_rejected = self.n_unresolved = 0
        self.min_step = math.inf
        self.spent = 0      # fun calls since the last accepted point
        self.recent = {}    # turn / deviation of the rejections since the last acceptance

    @property
    def s(self):
        return self.eq.s

    def run(self, x0) -> Branch:
        done = self.first_point(x0)
        while done is None:
            done = self.step()
        return done

    # ---- the first point
    def first_point(self, x0):
        """Newton at fixed lam0 and the first tangent; the Branch if the run ends there."""
        o = self.opts
        x, st, nit, nfev, r, (R, Jx, Jl) = self.eq.solve_fixed_lam(x0, o.lam0)
        if st != 0:
            return self.result(-2, f"first point at lam0 = {o.lam0} did not converge: "
                                   f"{_NEWTON_MESSAGES[st]} (||R|| = {r:.3e}, "
                                   f"tol = {o.thresh:.3e})")
        self.eq.metric.observe(x)  # from the solution, not from the caller's guess
        t = self.first_tangent(x, Jx, Jl)
        if t is None:
            return self.result(-2, "tangent at the first point failed: singular dR_dx at lam0")
        self.z, self.t_phys = np.append(x, o.lam0), t * self.s
        self.points.append((self.z, self.t_phys, nit, nfev, np.linalg.norm(R)))
        if o.callback is not None and o.callback(x.copy(), o.lam0):
            return self.result(3, "stopped by callback")
        if o.max_points == 1:
            return self.result(2, "max_points reached before lam_end")
        return None

    def first_tangent(self, x, Jx, Jl):
        """Unit scaled tangent at the first point, towards lam_end times `direction`
        (at a fold, where its lam-component vanishes: towards growing |x|)."""
        n, s, o = self.n, self.s, self.opts
        t = self.eq.null_vector(Jx, Jl)
        if t is None:
            return None
        sgn = np.sign(t[n] * (o.lam_end - o.lam0))
        if abs(t[n]) < 1e-12:
            sgn = np.sign(t[:n] @ (x / s[:n])) or 1.0
        t *= sgn * o.direction
        return t

    # ---- one step
    def step(self):
        """One predictor-corrector step; the Branch if the run ends with it, else None."""
        ts, y_pred = self.predict()
        zn, st, nit, _, r, JJ = self.correct(y_pred, ts)
        reason, feature, tan, shrink = self.assess(zn, st, JJ, y_pred)
        if reason is not None:
            return self.reject(reason, feature, shrink, ts, zn, JJ)
        return self.accept(zn, tan, nit, r)

    def predict(self):
        """(unit scaled tangent ts, predictor y_k + ds ts) in the scaled unknowns."""
        ts = self.t_phys / self.s
        ts /= np.linalg.norm(ts)
        return ts, self.z / self.s + self.ds * ts

    def correct(self, y_pred, normal):
        """Corrector on the hyperplane through y_pred normal to `normal` (scaled):
        (z, status, nit, nfev, ||R||, (Jx, Jl)); status -1: the hyperplane condition
        is not met although ||R|| is."""
        zn, st, nit, nfev, _, r, JJ, F = self.eq.solve_on_plane(y_pred, normal)
        self.spent += nfev
        if st == 0 and abs(F[self.n]) > 1e-6 * max(
                np.linalg.norm(y_pred - self.z / self.s), 1e-12):
            st = -1  # arclength condition not met
        return zn, st, nit, nfev, r, JJ

    def assess(self, zn, st, JJ, y_pred):
        """The tests a corrected point must pass, in order: convergence, deviation
        from the predictor, turn of the tangent, `segment_check`.  Returns (reason
        for rejection or None, rejected for a feature (possibly a corner)?, tangent
        triple of `tangent_from` or None, factor for the step if rejected)."""
        if st != 0:
            return ("arclength condition not met" if st == -1 else _NEWTON_MESSAGES[st],
                    False, None, 0.5)
        reason = self.deviation_test(zn, y_pred)
        if reason is not None:
            return reason, True, None, 0.5
        tan = self.eq.tangent_from(JJ[0], JJ[1], self.t_phys)
        self.eq.njev += 1
        if tan is None:
            return "singular tangent system", False, None, 0.5
        reason = self.turn_test(tan[1])
        if reason is not None:
            return reason, True, tan, 0.5
        reason, shrink = self.segment_test(zn)
        return reason, False, tan, shrink

    def deviation_test(self, zn, y_pred):
        """The corrector must stay near the predictor: a large deviation of the secant
        from the tangent means the step jumped over a feature (e.g. a resonance of a
        branch Newton finds easy), even if the tangents agree."""
        o = self.opts
        dev = np.linalg.norm(zn / self.s - y_pred) / self.ds
        if dev > o.max_deviation and self.ds > o.ds_min:
            if not self.is_kink("deviation", dev):
                return f"corrector moved {dev:.2f} step lengths from the predictor"
            log.debug("kink passed: deviation %.2f persists as ds shrinks", dev)
        return None

    def turn_test(self, cos_angle):
        """The tangent may turn by at most max_turn in one step (no branch jumping)."""
        if cos_angle < self.opts.cos_turn and self.ds > self.opts.ds_min:
            angle = math.acos(min(1.0, cos_angle))
            if not self.is_kink("turn", angle):
                return f"tangent turned by {math.degrees(angle):.1f} deg"
            log.debug("kink passed: turn %.1f deg persists as ds shrinks", math.degrees(angle))
        return None

    def segment_test(self, zn):
        """(reason or None, step factor) from the caller's `segment_check`."""
        o, z, n = self.opts, self.z, self.n
        if o.segment_check is None:
            return None, 0.5
        width = o.segment_check(z[:n], z[n], zn[:n], zn[n])
        if width is not None and self.ds > o.ds_min:
            step = abs(zn[n] - z[n])
            return (f"a resonance inside the step (|dlam| = {step:.3g} > {width:.3g})",
                    min(0.5, max(0.9 * width / step, 1e-3)))
        if width is not None:
            self.n_unresolved += 1
            log.debug("step at ds_min taken although segment_check refused it")
        return None, 0.5

    def is_kink(self, what, value):
        """A smooth curve's turn and predictor deviation shrink in proportion to the
        step; once the step is small (< kink_ds, while crossing a resonance needs a
        step of order one in the scaled metric), a rejection that survives three
        halvings there is a corner of the branch (e.g. a change of the stick/slip
        pattern), not a jump: it is accepted."""
        prev = self.recent.get(what)
        self.recent[what] = value
        if self.ds >= self.opts.kink_ds:
            return False
        self.recent["small"] = self.recent.get("small", 0) + 1
        return self.recent["small"] > 3 or (prev is not None and value > 0.75 * prev)

    def accept(self, zn, tan, nit, r):
        """Take the corrected point; the next step aims at target_newton iterations."""
        o = self.opts
        self.recent.clear()
        self.min_step = min(self.min_step, self.ds)
        done = self.commit(zn, tan[2], nit, r)
        if done is not None:
            return done
        factor = math.sqrt(o.target_newton / max(nit, 1))
        self.ds = min(max(self.ds * min(max(factor, 0.5), 2.0), o.ds_min), o.ds_max)
        return None

    def reject(self, reason, feature, shrink, ts, zn, JJ):
        """Pass a corner if the rejection may be one, else shorten the step; the
        Branch (failure) once the step falls below ds_min."""
        o = self.opts
        self.n_rejected += 1
        corner = self.pass_corner(ts, zn, JJ) if feature else None
        if corner:
            log.debug("corner passed with %d point(s) (%s)", len(corner), reason)
            return self.commit_corner(corner)
        self.ds *= shrink
        log.debug("step rejected (%s); ds -> %.3e", reason, self.ds)
        if shrink < 0.5 and self.ds < o.ds_min:  # try the smallest step before giving up
            self.ds = o.ds_min
        if self.ds < o.ds_min:
            return self.result(-1, f"step size below ds_min = {o.ds_min:g} at lam = "
                                   f"{self.z[self.n]:.6g} (last failure: {reason})")
        return None

    # ---- corners
    def pass_corner(self, ts, zn, JJn):
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
        found = self.locate_corner(ts, zn, JJn)
        if found is None:
            return None
        a, b, tn, turn = found
        out = []
        if a > 0.05 * self.ds:  # a point just before the corner
            before = self.point_before_corner(ts, a, max(0.2 * turn, math.radians(2.0)))
            if before is None:
                return None
            out.append(before)
        beyond = self.point_beyond_corner(self.z / self.s + a * ts, tn, b)
        if beyond is not None:
            out.append(beyond)
        return out or None

    def locate_corner(self, ts, zn, JJn):
        """(a, b, t_n, turn) of the corner c = y + a t = y_n - b t_n, or None if the
        two tangents do not meet like a corner's."""
        y0, yn = self.z / self.s, zn / self.s
        tn = self.eq.oriented_tangent(JJn, yn - y0)
        if tn is None:
            return None
        (a, b), *_ = np.linalg.lstsq(np.column_stack([ts, tn]), yn - y0, rcond=None)
        if b < 0:
            tn, b = -tn, -b
        turn = math.acos(float(np.clip(ts @ tn, -1.0, 1.0)))
        gap = np.linalg.norm(y0 + a * ts + b * tn - yn)
        if not (turn > _CORNER_TURN and 0 < a <= self.ds and gap <= 0.25 * max(a, b)):
            return None
        return a, b, tn, turn

    def point_before_corner(self, ts, a, tol_angle):
        """The point at 0.98 a along the tangent ts, if its tangent is still ts."""
        y1p = self.z / self.s + 0.98 * a * ts
        z1, st1, nit1, _, r1, JJ1 = self.correct(y1p, ts)
        if st1 != 0:
            return None
        t1 = self.eq.oriented_tangent(JJ1, ts)
        if (t1 is None or np.linalg.norm(z1 / self.s - y1p)
                > self.opts.max_deviation * 0.98 * a):
            return None
        if math.acos(min(1.0, float(t1 @ ts))) > tol_angle:
            return None
        return z1, t1, nit1, r1

    def point_beyond_corner(self, c, tn, b):
        """The point at c + d tn, near its predictor with its tangent near tn
        (d = min(ds, b), once more at d / 4), or None."""
        o = self.opts
        d = min(self.ds, b)
        for _ in range(2):
            y2p = c + d * tn
            z2, st2, nit2, _, r2, JJ2 = self.correct(y2p, tn)
            t2 = self.eq.oriented_tangent(JJ2, tn) if st2 == 0 else None
            if (t2 is not None and np.linalg.norm(z2 / self.s - y2p) <= o.max_deviation * d
                    and math.acos(min(1.0, float(t2 @ tn))) <= o.max_turn):
                return z2, t2, nit2, r2
            d *= 0.25
        return None

    def commit_corner(self, corner):
        """Commit the points of a passed corner; the Branch if the run ends there."""
        self.recent.clear()
        self.min_step = min(self.min_step, self.ds)
        for zc, tc, nitc, rc in corner:
            done = self.commit(zc, tc * self.s, nitc, rc)
            if done is not None:
                return done
        return None

    # ---- accepted points and the end of the run
    def commit(self, zn, t_new_phys, nit, r):
        """Append an accepted point; a Branch when the run ends there, else None."""
        o, n = self.opts, self.n
        lo, hi = o.bounds
        if not lo <= zn[n] <= hi:
            return self.finish_at_bound(zn, t_new_phys, nit, r)
        self.z, self.t_phys = zn, t_new_phys
        self.points.append((zn, t_new_phys, nit, self.spent, r))
        self.spent = 0
        self.eq.metric.observe(zn[:n])
        if o.callback is not None and o.callback(zn[:n].copy(), zn[n]):
            return self.result(3, "stopped by callback")
        if len(self.points) >= o.max_points:
            return self.result(2, "max_points reached before lam_end")
        return None

    def finish_at_bound(self, zn, t_new_phys, nit, r):
        """The step left [lo, hi]: the last point is re-solved on the boundary it
        crossed (from the linear interpolation) and the Branch returned."""
        o, n, z = self.opts, self.n, self.z
        lo, hi = o.bounds
        bound = hi if zn[n] > hi else lo
        frac = (bound - z[n]) / (zn[n] - z[n])
        xg = z[:n] + frac * (zn[:n] - z[:n])
        if not (bound == o.lam0 and len(self.points) == 1):
            xb, stb, nitb, nfevb, rb, (R, Jx, Jl) = self.eq.solve_fixed_lam(xg, bound)
            self.spent += nfevb
            if stb == 0:
                tb = self.eq.tangent_from(Jx, Jl, self.t_phys)
                self.eq.njev += 1
                if tb is not None:
                    zn, nit, t_new_phys = np.append(xb, bound), nitb, tb[2]
                    r = np.linalg.norm(R)
            self.points.append((zn, t_new_phys, nit, self.spent, r))
        if bound == o.lam_end:
            return self.result(0, f"reached lam_end = {o.lam_end}")
        return self.result(1, f"left the interval at lam = {bound} (branch turned back)")

    def result(self, status, message) -> Branch:
        """The Branch of the points so far, its folds located."""
        n, s, m = self.n, self.s, len(self.points)
        Z, T, NIT, PNFEV, RN = (list(c) for c in zip(*self.points)) if m else ([],) * 5
        Zs = np.array(Z, float).reshape(m, n + 1)
        Ts = np.array(T, float).reshape(m, n + 1)
        if m:
            Ts = Ts / np.linalg.norm(Ts / s, axis=1, keepdims=True)
        folds = [refine_fold(self.eq, *f, refine=self.opts.refine_folds)
                 for f in _fold_segments(Zs, Ts, s)]
        fi = np.array([f[0] for f in folds], int)
        fl = np.array([f[1][n] for f in folds], float)
        fx = np.array([f[1][:n] for f in folds], float).reshape(len(folds), n)
        log.debug("continuation: %d points, %d folds, nfev=%d: %s", m, fi.size, self.eq.nfev,
                  message)
        return Branch(
            x=_frozen(Zs[:, :n]), lam=_frozen(Zs[:, n]), tangent=_frozen(Ts),
            converged=_frozen(np.ones(m, bool), bool), nit=_frozen(NIT, int),
            point_nfev=_frozen(PNFEV, int), residual_norm=_frozen(RN),
            fold_index=_frozen(fi, int), fold_lam=_frozen(fl), fold_x=_frozen(fx),
            nfev=self.eq.nfev, njev=self.eq.njev, n_rejected=self.n_rejected,
            min_step=self.min_step, scale=_frozen(s), success=status >= 0 and status != 2,
            status=status, message=message, n_unresolved=self.n_unresolved)


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
    if not callable(fun):
        raise ValueError("fun must be callable: fun(x, lam) -> (R, dR_dx, dR_dlam)")
    x0 = _check_start(x0)
    opts = continuation_options(
        x0.size, lam0, lam_end, tol=tol, tol_rel=tol_rel, r_ref=r_ref, ds=ds, ds_min=ds_min,
        ds_max=ds_max, max_points=max_points, max_newton=max_newton,
        target_newton=target_newton, max_turn=max_turn, scale=scale, callback=callback,
        direction=direction, refine_folds=refine_folds, groups=groups,
        max_deviation=max_deviation, kink_ds=kink_ds, lam_back=lam_back,
        segment_check=segment_check)
    return Tracer(fun, opts).run(x0)
