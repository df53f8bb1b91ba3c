"""Newton's method with an acceptance rule on the residual, and its core.

`newton` solves R(x) = 0 for `fun_x(x) -> (R, dR_dx)`; `newton_core` is the loop
shared with the continuation corrector (`arclength.ScaledEquations`), which solves
its bordered systems with `linear_solve`; `solve_on_plane` finds a branch point on
a hyperplane across the branch (the points `dense_output` and `exact_peaks` add, the
peak continued in preload).  A point is converged only if its recomputed residual meets the tolerance; numerical failure is reported in the
result (`NEWTON_MESSAGES`), never raised.
"""
from __future__ import annotations

import logging
import math
import warnings
import weakref
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..harmonic_balance.ring import ring_solver

log = logging.getLogger(__name__)

_REFINE_ITER = 6   # refinement steps on kept factors before factorising afresh
_REFINE_EPS = 16 * np.finfo(float).eps  # ... until the normwise backward error is below this
_DIAG_PIVOT = 1e-3  # a sparse LU keeps the diagonal pivot down to this share of its column
_SINGLE_MIN = 500  # dense systems this large are factorised in float32 and refined
_KEEP_MIN = 300    # smaller dense systems are solved afresh (an LU costs less than refining)


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


def scale_rows(w, J, in_place=False):
    """diag(w) J for a dense or scipy.sparse J (sparse stays sparse); in_place: a
    dense J is overwritten (for a fresh Jacobian only its caller holds)."""
    if sp.issparse(J):
        J = J.tocsr()
        data = J.data * np.repeat(w, np.diff(J.indptr))
        if in_place:
            J.data = data
            return J
        if not J.has_canonical_format:   # scipy may sort or sum it in place: a copy
            return sp.csr_matrix((data, J.indices.copy(), J.indptr.copy()), shape=J.shape)
        # a new matrix on J's (canonical) index arrays: a pattern's structures stay valid
        out = sp.csr_matrix((data, J.indices, J.indptr), shape=J.shape)
        out.has_canonical_format = True
        return out
    if in_place and J.flags.writeable:
        J *= w[:, None]
        return J
    return w[:, None] * J


def augment(J, col, row):
    """[[J, col], [row]] ((n+1) x (n+1)) for a dense or scipy.sparse J (CSC then)."""
    if sp.issparse(J):
        return bordered_sparse(J, col, row)
    n = J.shape[0]
    A = np.empty((n + 1, n + 1))
    A[:n, :n], A[:n, n], A[n] = J, col, row
    return A


def bordered_sparse(J, col, row, col_scale=None):
    """[[J diag(col_scale), col], [row]] as CSC (SuperLU's own format: no conversion
    before a factorisation), J scipy.sparse (n x n), col and row dense (n,) and
    (n+1,), all their entries stored: the structure depends on J's alone, so it is
    built once per structure (`_border_structure`) and each call only places the
    values.  A J with unsorted or repeated entries is made canonical first: the
    bordered matrix shares the kept structure, which SuperLU would otherwise sort or
    sum in place."""
    J = J if J.format == "csr" else J.tocsr()
    if not J.has_canonical_format:
        J = J.copy()
        J.sum_duplicates()
    n = J.shape[0]
    pos_j, pos_row, indices, indptr = _border_structure(J)
    data = np.empty(indices.size)
    data[pos_j] = J.data if col_scale is None else J.data * col_scale[J.indices]
    data[pos_row] = row
    data[indptr[n]:indptr[n] + n] = col
    return sp.csc_matrix((data, indices, indptr), shape=(n + 1, n + 1))


_BORDERS: dict = {}   # id(J.indptr) -> (weak reference to it, J.indices, structure)


def _border_structure(J):
    """(positions of J's entries, of the row's, indices, indptr) of the bordered CSC
    matrix of `bordered_sparse`: column c < n holds J's column c (rows ascending) then
    row n, column n every row.  Kept while J's index arrays live (a Jacobian
    pattern fixed per problem)."""
    key = id(J.indptr)
    kept = _BORDERS.get(key)
    # scipy hands each matrix a new view of the index arrays it was given: the same
    # memory as the kept (referenced, so never reused) array is the same pattern
    if (kept is not None and kept[0]() is J.indptr and kept[1].size == J.indices.size
            and kept[1].dtype == J.indices.dtype
            and kept[1].ctypes.data == J.indices.ctypes.data):
        return kept[2]
    n, nnz = J.shape[0], J.indptr[-1]
    rows = np.repeat(np.arange(n), np.diff(J.indptr))
    cols = J.indices[:nnz]
    itype = np.int32 if nnz + 2 * n + 1 < 2 ** 31 else np.int64   # as scipy keeps them
    indptr = np.zeros(n + 2, dtype=itype)
    indptr[1:-1] = np.cumsum(np.bincount(cols, minlength=n) + 1)
    indptr[-1] = indptr[-2] + n + 1
    order = np.lexsort((rows, cols))   # J's entries column by column, rows ascending
    pos_j = np.empty(nnz, dtype=np.int64)   # column c starts after c border entries
    pos_j[order] = np.arange(nnz) + cols[order]
    pos_row = np.append(indptr[1:n + 1] - 1, indptr[-1] - 1)
    indices = np.empty(indptr[-1], dtype=itype)
    indices[pos_j], indices[pos_row[:n]] = rows, n
    indices[indptr[n]:] = np.arange(n + 1)
    out = (pos_j, pos_row, indices, indptr)
    if len(_BORDERS) > 64:
        _BORDERS.clear()
    _BORDERS[key] = (weakref.ref(J.indptr), J.indices, out)
    return out


def _sparse_solver(A):
    """The solve of a fresh sparse LU of A (SuperLU on its CSC form; factorising the
    CSR arrays as A^T and solving transposed left residuals 1e4 times larger on the
    mistuned wheel's bordered Jacobian).

    Our Jacobians are structurally symmetric (a wheel's blocks couple neighbours
    both ways; the border adds a full row and column), so the columns are ordered by
    minimum degree on A^T + A and the diagonal is kept as pivot while it is at least
    _DIAG_PIVOT of its column's largest entry: on the 24-blade wheel 27 % less fill
    and a 1.4-1.7x faster factorisation and solve than COLAMD with partial
    pivoting.  Such threshold pivoting bounds the growth less tightly, so its solves
    are refined to a partial-pivoting LU's backward error (`refined`); where that
    fails, A is factorised again with partial pivoting (`_partial_pivoting`).

    A wheel's matrix, a ring of blades each coupled only to its neighbours (bordered
    or not), is solved by block elimination instead (`ring`, blocks in float32): no
    fill beyond its blocks.  A singular block falls back to the sparse LU, solutions
    that do not refine to float64 blocks, then to the sparse LU (`_second_chance`)."""
    try:
        solve = ring_solver(A)
    except np.linalg.LinAlgError:
        log.debug("ring solve: a singular block; sparse LU")
        solve = None
    if solve is not None:
        return solve
    return _general_sparse(A)


def _general_sparse(A):
    """The solve of SuperLU's LU of A, minimum degree on A^T + A, threshold pivoting."""
    A = sp.csc_matrix(A)
    try:
        return spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=_DIAG_PIVOT).solve
    except RuntimeError:   # an exactly zero pivot in this order: partial pivoting decides
        log.debug("sparse LU: a zero pivot in the minimum-degree order; partial pivoting")
        return _partial_pivoting(A)


def _partial_pivoting(A):
    """The solve of SuperLU's LU of A with its default COLAMD order and partial pivoting."""
    return spla.splu(sp.csc_matrix(A)).solve


def _second_chance(A, b):
    """(solve, x) after the first sparse factorisation's solutions failed to refine:
    a ring in float64, refined, else SuperLU with partial pivoting."""
    try:
        solve = ring_solver(A, single=False)
    except np.linalg.LinAlgError:
        solve = None
    if solve is not None:
        x = refined(A, b, solve)
        if x is not None:
            return solve, x
        log.debug("ring solve: not refined to 16 eps in float64; sparse LU")
        solve = _general_sparse(A)
        x = refined(A, b, solve)
        if x is not None:
            return solve, x
    log.debug("sparse LU: threshold pivots not refined to 16 eps; partial pivoting")
    solve = _partial_pivoting(A)
    return solve, solve(b)


def linear_solve(A, b):
    """Dense or sparse linear solve; raises LinAlgError / RuntimeError if singular."""
    if sp.issparse(A):
        x = refined(A, b, _sparse_solver(A))
        return _second_chance(A, b)[1] if x is None else x
    return np.linalg.solve(A, b)


def _factorised(A, single=False):
    """The solve of a fresh LU of A (dense or sparse; single: of A in float32, the
    solve still in and out of float64); LinAlgError if singular."""
    if sp.issparse(A):
        return _sparse_solver(A)
    dtype = np.float32 if single else float
    with warnings.catch_warnings():  # an exactly singular A: raised below instead
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        lu, piv = sla.lu_factor(A.astype(dtype), overwrite_a=True, check_finite=False)
    if not np.all(np.diagonal(lu)):
        raise np.linalg.LinAlgError("singular matrix")
    return lambda b: sla.lu_solve((lu, piv), b.astype(dtype), check_finite=False).astype(float)


class KeptFactors:
    """`linear_solve` that keeps its last factorisation (`solve`), and solves a
    system whose matrix is near the kept one (the Jacobian one converged Newton
    step further) by iterative refinement on the kept factors (`near`).

    A refined solution is accepted only once its normwise backward error
    ||b - A x|| / (||A||_F ||x|| + ||b||) is below _REFINE_EPS (16 eps: what a
    fresh LU with partial pivoting in float64 reaches), so it is as exact as a
    fresh solve; otherwise (a far matrix, e.g. after a change of the contact
    pattern, or stagnation) A is factorised afresh.  A dense refinement step costs
    a product and two triangular solves, O(n^2), against the O(n^3) of a
    factorisation.  Dense matrices of fewer than _KEEP_MIN rows are solved afresh
    each time (an LU costs less there).  Those of _SINGLE_MIN rows or more are
    factorised in float32 (half the time) and every solve refined to that same
    backward error in float64 (mixed-precision refinement); a matrix too
    ill-conditioned for it is factorised again in float64.  `refined` and
    `factorised` count the two outcomes of `near`, `single` the float32
    factorisations that sufficed.
    """

    def __init__(self):
        self.last, self.size = None, -1
        self.refined = self.factorised = self.single = 0

    def solve(self, A, b):
        """A x = b by a fresh factorisation of A, which is kept (a dense A of fewer
        than _KEEP_MIN rows: solved, nothing kept)."""
        n = A.shape[0]
        if not sp.issparse(A) and n < _KEEP_MIN:
            self.last, self.size = None, -1
            return np.linalg.solve(A, b)
        if not sp.issparse(A) and n >= _SINGLE_MIN:
            try:
                self.last, self.size = _factorised(A, single=True), n
                x = self._refined(A, b)
                if x is not None:
                    self.single += 1
                    return x
            except np.linalg.LinAlgError:
                pass  # singular in float32 only: float64 decides
        self.last, self.size = _factorised(A), n
        if not sp.issparse(A):
            return self.last(b)
        x = self._refined(A, b)
        if x is None:   # float32 blocks or threshold pivots not enough
            self.last, x = _second_chance(A, b)
        return x

    def near(self, A, b):
        """A x = b from the kept factors by refinement, else as `solve`."""
        if self.last is not None and self.size == A.shape[0]:
            x = self._refined(A, b)
            if x is not None:
                self.refined += 1
                return x
        self.factorised += 1
        return self.solve(A, b)

    def _refined(self, A, b):
        """x from the kept factors refined to the backward error _REFINE_EPS, or None."""
        return refined(A, b, self.last)


def refined(A, b, solve):
    """x = solve(b) (an LU of A or of a matrix near it) refined to the normwise
    backward error _REFINE_EPS, or None (no convergence within _REFINE_ITER steps,
    stagnation, or a contraction too slow to get there in the steps left: then a
    fresh LU is cheaper)."""
    x = solve(b)
    scale = np.linalg.norm(A.data if sp.issparse(A) else A)
    bn = np.linalg.norm(b)
    r = b - A @ x
    rn = np.linalg.norm(r)
    for k in range(_REFINE_ITER + 1):
        if not np.isfinite(rn):
            return None
        target = _REFINE_EPS * (scale * np.linalg.norm(x) + bn)
        if rn <= target:
            return x
        if k == _REFINE_ITER:
            return None
        x = x + solve(r)
        r = b - A @ x
        rn, before = np.linalg.norm(r), rn
        if not rn < 0.5 * before:  # stagnating: not near enough
            return None
        # at this rate the target lies beyond the remaining steps: stop paying
        if rn > 0 and rn > target * (before / rn) ** (_REFINE_ITER - k):
            return None
    return None


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


def newton(fun_x, x0, tol, max_iter=20, damped=True, step=linear_solve) -> NewtonResult:
    """Newton's method for R(x) = 0 with `fun_x(x) -> (R, dR_dx)`.

    Converged iff the residual evaluated at the returned x satisfies ||R||_2 <= tol
    (absolute, in the units of R).  damped: backtrack until ||R|| decreases (see
    `newton_core`); `step(dR_dx, rhs)` solves the Newton systems (e.g.
    `KeptFactors().solve`).  Numerical failure is reported in the result.
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
        checked, x0, tol, int(max_iter), np.linalg.norm, step, damped=damped)
    return NewtonResult(z, status == 0, status, NEWTON_MESSAGES[status], nit, nfev,
                        njev, float(r), J)


_START_ITER = 4                 # Newton iterations from a curved start before the chord's


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
