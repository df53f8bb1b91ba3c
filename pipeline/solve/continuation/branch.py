"""The result of a continuation run, `Branch`, and the location of its folds.

A fold is a sign change of the lam-component of the tangent between two points:
`fold_segments` finds it on the cubic Hermite curve through them, and `refine_fold`
locates it by correctors of the run's `arclength.ScaledEquations`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit


@dataclass(frozen=True, eq=False)
class Branch:
    """A traced branch (SciPy-style result; arrays are read-only).

    x (m, n), lam (m,)          accepted points, in order along the branch
    tangent (m, n+1)            unit tangents d[x; lam]/ds in physical units,
                                normalised in the final scaled metric
    converged (m,)              True for every returned point (the convergence rule of
                                `continuation` holds)
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


def frozen_array(a, dtype=float):
    """A read-only copy of `a` as `dtype` (the arrays of a `Branch` and of the options)."""
    a = np.array(a, dtype=dtype)
    a.setflags(write=False)
    return a


def hermite(y0, y1, d0, d1, u):
    """Cubic Hermite point and derivative at u in [0, 1]."""
    h = (2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2)
    dh = (6 * u**2 - 6 * u, 3 * u**2 - 4 * u + 1, -6 * u**2 + 6 * u, 3 * u**2 - 2 * u)
    p = h[0] * y0 + h[1] * d0 + h[2] * y1 + h[3] * d1
    dp = dh[0] * y0 + dh[1] * d0 + dh[2] * y1 + dh[3] * d1
    return p, dp


@njit(cache=True)
def _lu_pivoted(A):
    """In-place LU with partial pivoting of a small square A; the row order."""
    n = A.shape[0]
    perm = np.arange(n)
    for k in range(n):
        p = k + np.argmax(np.abs(A[k:, k]))
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            perm[k], perm[p] = perm[p], perm[k]
        if A[k, k] != 0.0:
            for i in range(k + 1, n):
                A[i, k] /= A[k, k]
                for j in range(k + 1, n):
                    A[i, j] -= A[i, k] * A[k, j]
    return perm


@njit(cache=True)
def _lu_solve(A, perm, b):
    """x with A x = b from `_lu_pivoted`'s factors: L y = P b, then U x = y."""
    n = b.size
    x = np.empty(n)
    for i in range(n):
        x[i] = b[perm[i]]
        for j in range(i):
            x[i] -= A[i, j] * x[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            x[i] -= A[i, j] * x[j]
        x[i] /= A[i, i]
    return x


@njit(cache=True)
def _lu_solve_transposed(A, perm, b):
    """x with A^T x = b from `_lu_pivoted`'s factors: U^T y = b, L^T z = y, x = P^T z
    (element by element: a fancy-index assignment compiles a shape check)."""
    n = b.size
    y = np.empty(n)
    for i in range(n):
        y[i] = b[i]
        for j in range(i):
            y[i] -= A[j, i] * y[j]
        y[i] /= A[i, i]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            y[i] -= A[j, i] * y[j]
    x = np.empty(n)
    for i in range(n):
        x[perm[i]] = y[i]
    return x


@njit(cache=True)
def hermite_point(Y, T, normal, target, v):
    """The point of the Hermite polynomial p through the m points Y (m, N) with their
    unit tangents T (m, N) (degree 2m - 1: the cubic for two points, the quintic for
    three, the septic for four) where it meets the hyperplane normal . p = target,
    moved exactly onto it; (False, .) if Newton on the parameter fails.

    The parameter is the arclength in units of the last chord's, 0 at Y[-1], and
    Newton on it starts from v.  Each chord's arc is that of the circle through its
    ends with the angle phi between their tangents, chord (phi / 2) / sin(phi / 2),
    so that the unit tangents are the derivatives p must match: on a circle its
    error is O(h^(2m)) for chords h (on other curves the arc's own error,
    O(h^5), may limit it).  With R = [Y; h T] and the
    confluent Vandermonde matrix V of the nodes, p(v) = w(v)^T V^-1 R, and
    normal . p(v) is the polynomial of the coefficients V^-1 (R normal)."""
    m, N = Y.shape
    n2 = 2 * m
    u = np.zeros(m)
    h = 0.0
    for i in range(m - 2, -1, -1):
        c = min(1.0, max(-1.0, np.dot(T[i], T[i + 1])))
        phi = np.arccos(c)
        a = np.sqrt(np.sum((Y[i + 1] - Y[i]) ** 2))
        if phi > 1e-4:  # the arc of the circle through both points with these tangents
            a *= 0.5 * phi / np.sin(0.5 * phi)
        else:
            a *= 1.0 + phi * phi / 24.0
        if i == m - 2:
            h = a
        if h == 0.0:
            return False, np.zeros(N)
        u[i] = u[i + 1] - a / h
    V = np.zeros((n2, n2))
    for i in range(m):
        for j in range(n2):
            V[i, j] = u[i] ** j
            if j > 0:
                V[m + i, j] = j * u[i] ** (j - 1)
    perm = _lu_pivoted(V)
    for k in range(n2):
        if V[k, k] == 0.0:
            return False, np.zeros(N)
    rn = np.empty(n2)
    for i in range(m):
        rn[i] = np.dot(Y[i], normal)
        rn[m + i] = h * np.dot(T[i], normal)
    a = _lu_solve(V, perm, rn)  # normal . p(v) = sum_j a_j v^j
    v0 = v
    for _ in range(6):
        g, dg, vj = a[0] - target, 0.0, 1.0
        for j in range(1, n2):
            dg += j * a[j] * vj
            vj *= v
            g += a[j] * vj
        if dg == 0.0 or not np.isfinite(g) or abs(v - v0) > 4.0 * abs(v0) + 1.0:
            return False, np.zeros(N)
        v -= g / dg
    w = np.empty(n2)
    vj = 1.0
    for j in range(n2):
        w[j] = vj
        vj *= v
    b = _lu_solve_transposed(V, perm, w)  # p(v) = b . R
    p = np.zeros(N)
    for i in range(m):
        p += b[i] * Y[i] + (b[m + i] * h) * T[i]
    p += (target - np.dot(normal, p)) * normal
    return np.all(np.isfinite(p)), p


def hermite_on_plane(Y, T, normal, ds):
    """`hermite_point` extrapolated beyond Y[-1] to the hyperplane normal . (p -
    Y[-1]) = ds (on a smooth arc its error is O(ds^(2m))); None if it fails."""
    Y, T, normal = (np.ascontiguousarray(a, dtype=float) for a in (Y, T, normal))
    h = np.linalg.norm(Y[-1] - Y[-2])
    ok, p = hermite_point(Y, T, normal, normal @ Y[-1] + ds, ds / h if h > 0 else 0.0)
    return p if ok else None


def fold_segments(Z, T, s):
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


def refine_fold(eq, i, u, seg, refine=True):
    """Fold between points i, i+1: zero of the tangent's lam-component along the
    branch by Illinois regula falsi on u, each value from a corrector on the
    hyperplane through the Hermite point p(u) normal to p'(u) (`fold_corrector`),
    started from the previous corrector's point moved along its tangent onto that
    hyperplane.  Falls back to the Hermite point if a corrector fails."""
    y0, y1, d0, d1 = seg
    p, _ = hermite(y0, y1, d0, d1, u)
    best = p * eq.s
    if not refine:
        return i, best
    a, b = 0.0, 1.0
    ga, gb = d0[-1] / np.linalg.norm(d0), d1[-1] / np.linalg.norm(d1)
    side = 0
    near = None
    for _ in range(12):
        gu, zc, near = fold_corrector(eq, seg, u, near)
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


def fold_corrector(eq, seg, u, near=None):
    """(lam-component of the unit scaled tangent, point, (point, tangent) scaled) of
    the branch point on the hyperplane through the Hermite point p(u) normal to
    p'(u), Newton started from `near` (an earlier corrector's scaled point and unit
    tangent) moved along its tangent onto the hyperplane, else from p(u); (None,
    None, None) if the corrector fails."""
    p, dp = hermite(*seg, u)
    d = dp / np.linalg.norm(dp)
    start = None
    if near is not None and abs(d @ near[1]) > 0.5:
        start = near[0] + (d @ (p - near[0])) / (d @ near[1]) * near[1]
    zc, st, _, _, _, _, JJ, _ = eq.solve_on_plane(p, d, start)
    eq.njev += 1
    tan = eq.tangent_from(*JJ, dp * eq.s) if st == 0 else None
    if tan is None:
        return None, None, None
    return tan[0][eq.n], zc, (zc / eq.s, tan[0])
