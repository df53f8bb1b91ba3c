"""The parts of a pseudo-arclength run that take no step: its options, the metric
and the equations in the scaled unknowns.

`continuation_options` checks the options of `continuation.continue_branch` once
into a frozen `ContinuationOptions`; `Metric` holds the scale s of the unknowns
y = [x; lam] / s (`automatic_scale`); `ScaledEquations` evaluates R(x, lam) and
solves the bordered systems in y (tangents, Newton correctors), counting the costs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .branch import frozen_array
from .newton import KeptFactors, bordered_sparse, linear_solve, newton_core

_SCALE_FLOOR = 1e-2  # components are weighted at most 100x above the largest one
_FIRST_POINT_ITER = 5  # the first Newton solve gets this many times max_newton
_STALL = 4  # a corrector that has not cut its residual tenfold in this many iterations stops


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
    tangent: np.ndarray | None = None   # (n+1,) physical tangent at the first point, if known

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


def checked_start(x0):
    """The start vector x0 of `continue_branch` as floats; ValueError unless it is a
    non-empty finite 1-D array."""
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
        groups = frozen_array(groups, int)
    if scale is not None:
        s = np.array(scale, dtype=float)
        if s.shape != (n + 1,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ValueError(f"scale must be a positive finite array of shape ({n + 1},) "
                             f"[x scales..., lam scale], got {np.shape(scale)}")
        scale = frozen_array(s)
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
                         segment_check=None, tangent=None) -> ContinuationOptions:
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
    if tangent is not None:
        tangent = np.asarray(tangent, dtype=float)
        if tangent.shape != (n + 1,) or not np.all(np.isfinite(tangent)) or not tangent.any():
            raise ValueError(f"tangent must be a finite nonzero ({n + 1},) array, got shape "
                             f"{tangent.shape}")
    return ContinuationOptions(
        n=n, lam0=lam0, lam_end=lam_end, tol=tol, tol_rel=tol_rel, r_ref=r_ref, ds=ds,
        ds_min=ds_min, ds_max=ds_max, max_points=max_points, max_newton=max_newton,
        target_newton=target_newton, max_turn=max_turn, scale=scale, callback=callback,
        direction=int(direction), refine_folds=refine_folds, groups=groups,
        max_deviation=max_deviation, kink_ds=kink_ds, lam_back=lam_back,
        segment_check=segment_check, tangent=tangent)


# ---------------------------------------------------------------------- the metric
def automatic_scale(xmax, groups=None):
    """s_x from the running maximum |x| per unknown: shared within a group (the
    group's largest), floored at _SCALE_FLOOR times the largest entry; all ones
    while x = 0.  With groups, s_x is also multiplied by sqrt(number of groups): the
    state counts as a root mean square over its groups, so that a step's length
    does not grow with the number of contact DOFs that move together (an FE face
    of many nodes steps like one DOF)."""
    xm = xmax
    root = 1.0
    if groups is not None:
        gmax = np.zeros(groups.max() + 1)
        np.maximum.at(gmax, groups, xmax)
        xm = gmax[groups]
        root = np.sqrt(gmax.size)
    top = xm.max()
    return root * (np.maximum(xm, _SCALE_FLOOR * top) if top > 0 else np.ones_like(xm))


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
        self.factors = KeptFactors()  # the last factorisation: tangents, Newton steps

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
            return bordered_sparse(Jx, Jl * s[n], row, s[:n])
        A = np.empty((n + 1, n + 1))
        np.multiply(Jx, s[:n], out=A[:n, :n])
        A[:n, n] = Jl * s[n]
        A[n] = row
        return A

    def tangent_from(self, Jx, Jl, t_prev_phys):
        """Unit scaled tangent oriented along t_prev, its cosine with t_prev, physical t.
        Solved on the factors of the last Newton step where they are near enough
        (`KeptFactors.near`): at a converged point, its bordered matrix differs from
        the last step's only by that step's small change of the Jacobian."""
        n, s = self.n, self.s
        tp = t_prev_phys / s
        tp /= np.linalg.norm(tp)
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        try:
            w = self.factors.near(self.bordered(Jx, Jl, tp), rhs)
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
                t = linear_solve(self.bordered(Jx, Jl, e), e)
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
        z, st, nit, nfev, njev, r, RJJ, _ = newton_core(
            fx, xg, self.thresh, _FIRST_POINT_ITER * self.max_newton, np.linalg.norm,
            lambda RJJ, rhs: linear_solve(RJJ[1], rhs))
        self.nfev += nfev
        self.njev += njev
        return z, st, nit, nfev, r, RJJ

    def solve_on_plane(self, y, normal, start=None, history=None):
        """Newton on R(x, lam) = 0 and normal . (z / s - y) = 0 from z = y s, or from
        z = start s (scaled unknowns, a point of the same hyperplane); the
        `newton_core` tuple, its costs counted (`history`: its residual norms).  Each
        step is solved on the last factorisation (the previous step's or point's)
        where refinement converges to a fresh LU's backward error (`KeptFactors.near`:
        large systems only), else factorised afresh."""
        n, s = self.n, self.s

        def aug(zz):
            R, Jx, Jl = self.evaluate(zz[:n], zz[n])
            return np.append(R, normal @ (zz / s - y)), (Jx, Jl)

        def scaled_step(JJ, rhs):  # Newton in the scaled unknowns: dz = S dy
            return s * self.factors.near(self.bordered(JJ[0], JJ[1], normal), rhs)

        z0 = (y if start is None else start) * s
        out = newton_core(aug, z0, self.thresh, self.max_newton,
                          lambda F: np.linalg.norm(F[:n]), scaled_step, stall=_STALL,
                          history=history)
        self.nfev += out[3]
        self.njev += out[4]
        return out
