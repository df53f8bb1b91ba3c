"""Newton's method with an acceptance rule on the residual, and its core.

`newton` solves R(x) = 0 for `fun_x(x) -> (R, dR_dx)`; `newton_core` is the loop
shared with the continuation corrector (`arclength.ScaledEquations`), which solves
its bordered systems with `linear_solve`.  A point is converged only if its
recomputed residual meets the tolerance; numerical failure is reported in the
result (`NEWTON_MESSAGES`), never raised.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


@dataclass(frozen=True, eq=False)
class NewtonResult:
    """Outcome of `newton` (SciPy-style).

    status: 0 converged, 1 iteration limit, 2 singular Jacobian, 3 non-finite
    residual, 4 diverging (or stalled, `newton_core`).  `jac` is the Jacobian at `x`
    (for reuse, e.g. tangents).
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


def scale_rows(w, J):
    """diag(w) J for a dense or scipy.sparse J (sparse stays sparse)."""
    return (sp.diags(w) @ J).tocsr() if sp.issparse(J) else w[:, None] * J


def augment(J, col, row):
    """[[J, col], [row]] ((n+1) x (n+1)) for a dense or scipy.sparse J."""
    if sp.issparse(J):
        return sp.bmat([[J, np.asarray(col)[:, None]], [np.asarray(row)[None, :-1],
                                                         np.asarray(row)[None, -1:]]],
                       format="csc")
    return np.vstack([np.column_stack([J, col]), row])


def linear_solve(A, b):
    """Dense or sparse linear solve; raises LinAlgError / RuntimeError if singular."""
    if sp.issparse(A):
        lu = spla.splu(sp.csc_matrix(A))
        return lu.solve(b)
    return np.linalg.solve(A, b)


def newton_core(fun, z0, thresh, max_iter, measure, step=linear_solve, damped=False,
                stall=None, history=None):
    """Newton on F(z) = 0 with F, dF = fun(z); converged iff measure(F) <= thresh.

    The Newton step is dz = step(dF, -F).  damped=True halves it (up to 6 times)
    until measure(F) decreases: plain Newton can cycle between the linearisations
    of a non-smooth residual (stick/slip, contact) or diverge from a cold start;
    backtracking breaks that.  The continuation corrector stays undamped (its step
    control handles failures, and a first step may rise and still converge); it
    stops instead after `stall` iterations that have not cut the first residual
    tenfold (cycling between linearisations: the remaining iterations of
    max_iter would be wasted, a shorter step is cheaper).  Linear convergence, even
    slow, passes that test.  `history`, a list, receives measure(F) of every
    iterate.
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
        if history is not None:
            history.append(r)
        if r <= thresh:
            return z, 0, k, nfev, njev, r, dF, F
        r0 = r if r0 is None else r0
        if k >= 2 and r > 1e3 * r0:  # Newton is running away: stop paying for it
            return z, 4, k, nfev, njev, r, dF, F
        if stall is not None and k >= stall and r > 0.1 * r0:
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


# the message of each status of `newton_core`
NEWTON_MESSAGES = {
    0: "converged: ||R|| <= tol",
    1: "iteration limit reached before ||R|| <= tol",
    2: "singular Jacobian",
    3: "non-finite residual",
    4: "Newton iterations diverging or stalled",
}


def newton(fun_x, x0, tol, max_iter=20, damped=True) -> NewtonResult:
    """Newton's method for R(x) = 0 with `fun_x(x) -> (R, dR_dx)`.

    Converged iff the residual evaluated at the returned x satisfies ||R||_2 <= tol
    (absolute, in the units of R).  damped: backtrack until ||R|| decreases (see
    `newton_core`).  Numerical failure is reported in the result.
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

    z, status, nit, nfev, njev, r, J, _ = newton_core(
        checked, x0, tol, int(max_iter), np.linalg.norm, damped=damped)
    return NewtonResult(z, status == 0, status, NEWTON_MESSAGES[status], nit, nfev,
                        njev, float(r), J)
