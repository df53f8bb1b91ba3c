"""Linear solves on a ring of blocks: the Newton matrix of a bladed wheel.

The unknowns of a wheel of N blades, condensed onto the shroud contact DOFs, fall
blade by blade into N equal blocks of m rows, and a blade's block couples only to its
two neighbours' (through the shroud pairs between them):

    J = | D_0      U_0                      L_0     |    D_b    (m, m) the blade's own
        | L_1      D_1      U_1                     |           condensed dynamic
        |          ...      ...       ...           |           stiffness, dense
        |                   L_{N-2}  D_{N-2} U_{N-2}|    U_b, L_b  the pairs towards
        | U_{N-1}                    L_{N-1} D_{N-1}|           blade b+1 and b-1.

A general sparse LU of that ring fills far beyond its blocks (33 GB for 48 blades of
306 contact DOFs at H = 3).  Here blade N-1 is the separator and the chain 0..N-2 is
eliminated block by block (block LU; pivoting inside each dense block):

    Dt_0 = D_0,  X_b = Dt_b^-1 U_b,  Dt_{b+1} = D_{b+1} - L_{b+1} X_b,

the separator's coupling columns E (L_0 at block 0, U_{N-2} at block N-2) are carried
through the chain, W = T^-1 E, and the separator solves its Schur complement

    S = D_{N-1} - L_{N-1} W_{N-2} - U_{N-1} W_0.

The memory is that of the blocks (N m^2 and a few m-by-face panels per blade); the
work about ten dense LUs of one block per block, done in float32 (half the time) and
refined in float64 by the caller.  A continuation's bordered matrix
[[J, c], [r, d]] is solved by block elimination of the border (J y = b, J z = c), its
solutions refined by the caller against the whole matrix (`newton.refined`), which
factorises it by a general sparse LU where the refinement fails (a singular block).

`layout` finds the ring in a matrix's pattern (the largest N), kept per pattern.
"""
from __future__ import annotations

import warnings
import weakref
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

MIN_BLOCKS = 4         # a ring of fewer blocks is a general sparse matrix
MIN_ROWS = 4000        # smaller matrices: a sparse LU costs less than the bookkeeping
MIN_FILL = 0.2         # the diagonal blocks at least this dense (a blade's condensed
#                        stiffness: 30-60 %; else the sparse LU wins)
MIN_INERTIA_ROWS = 500  # a Hermitian count: the dense one costs more from here
MAX_BLOCK = 6000       # rows of a block at most (a dense LU of 6000 rows: 0.3 GB)
_LAYOUTS: dict = {}    # id(indptr) -> (weak reference, indices' address, N or None)


def layout(A, min_rows: int | None = None, keep: bool = True) -> tuple | None:
    """(N, bordered) if the sparse square matrix A (CSC or CSR) is a ring of
    N >= MIN_BLOCKS equal blocks (each couples only to its neighbours, module doc), the
    largest such N, or is one bordered by a last row and column (bordered True); else
    None.  Kept per pattern (index arrays) unless keep=False (a matrix built once: it
    would push the Newton matrices' patterns out); None below min_rows rows (MIN_ROWS)."""
    min_rows = MIN_ROWS if min_rows is None else min_rows
    key = id(A.indptr)
    kept = _LAYOUTS.get(key)
    if A.shape[0] - 1 < min_rows:
        return None
    if kept is not None and kept[0]() is A.indptr and kept[1] == A.indices.ctypes.data:
        return kept[2]
    found = None
    if A.format in ("csr", "csc"):
        rings = [(N, bordered) for bordered in (True, False)
                 if (N := _find_ring(A, A.shape[0] - bordered)) is not None]
        found = max(rings, default=None)   # the finer cut: a coarse one can hide in it
    if keep:
        if len(_LAYOUTS) > 64:
            _LAYOUTS.clear()
        _LAYOUTS[key] = (weakref.ref(A.indptr), A.indices.ctypes.data, found)
    return found


def _find_ring(A, n: int) -> int | None:
    """The largest N of a ring layout of the leading (n, n) part of A (CSR or CSC: a
    ring by rows is one by columns), or None.  Each N is tried on a sample of the
    entries first, then on all of them, block of rows by block of rows."""
    ptr, idx = A.indptr, A.indices
    pos = np.linspace(0, ptr[n] - 1, min(int(ptr[n]), 20000)).astype(np.int64)
    major, minor = np.searchsorted(ptr, pos, side="right") - 1, idx[pos]
    inner = minor < n
    major, minor = major[inner], minor[inner]
    for N in range(n // 16, MIN_BLOCKS - 1, -1):     # blocks of >= 16 rows
        if n % N or n // N > MAX_BLOCK:
            continue
        m = n // N
        if not _neighbours((minor // m - major // m) % N, N):
            continue
        diagonal = 0
        for b in range(N):
            seg = idx[ptr[b * m]:ptr[(b + 1) * m]]
            off = (seg[seg < n] // m - b) % N
            if not _neighbours(off, N):
                break
            diagonal += np.count_nonzero(off == 0)
        else:
            return N if diagonal >= MIN_FILL * N * m * m else None
    return None


def _neighbours(off, N) -> bool:
    return bool(np.all((off == 0) | (off == 1) | (off == N - 1)))


class RingFactors:
    """The block elimination of the module doc of a ring of N blocks, the (n, n) part
    of the sparse A (CSR or CSC; bordered: A has a last row and column more);
    `solve(b)` gives J^-1 b.  LinAlgError if a block is singular."""

    def __init__(self, A, N: int, dtype=float, pivots=None, bordered: bool = False,
                 keep: bool = True):
        g = _gather(A, N, bordered, keep)
        self.N, self.m, self.dtype, self.pivots = N, g.m, dtype, pivots
        blocks = np.zeros((N, 3, g.m, g.m), dtype)       # D_b, U_b (b -> b+1), L_b (b -> b-1)
        blocks.reshape(-1)[g.flat] = A.data[g.inner]
        self.border = ((A.data[g.col_pos], A.data[g.row_pos], A.data[g.corner])
                       if bordered else None)
        self.U = [_Panel(blocks[b, 1], g.cols[b, 1]) for b in range(N)]
        self.L = [_Panel(blocks[b, 2], g.cols[b, 2]) for b in range(N)]
        self.lu, self.X = [], []
        for b in range(N - 1):
            Dt = blocks[b, 0]
            if b:
                Dt[:, self.U[b - 1].cols] -= self.L[b].on(self.X[b - 1])
            self.lu.append(_lu(Dt, self.pivots))
            if b < N - 2:
                self.X.append(self._solve(b, self.U[b].dense))   # (m, |cols of U_b|)
        self._separator(blocks[N - 1, 0])

    def _solve(self, b, rhs):
        return sla.lu_solve(self.lu[b], rhs, check_finite=False)

    def _separator(self, S):
        """W = T^-1 E, the chain's response to the separator's columns (W0: L_0's at
        block 0, WN: U_{N-2}'s at block N-2), and the LU of the Schur complement S."""
        N, L, U = self.N, self.L, self.U
        W0 = [self._solve(0, L[0].dense)]                     # forward through the chain
        for b in range(1, N - 1):
            W0.append(self._solve(b, -L[b].on(W0[-1])))
        WN = [None] * (N - 1)
        WN[N - 2] = self._solve(N - 2, U[N - 2].dense)
        for b in range(N - 3, -1, -1):                        # backward
            W0[b] -= self.X[b] @ W0[b + 1][U[b].cols]
            WN[b] = -(self.X[b] @ WN[b + 1][U[b].cols])
        self.W0, self.WN, self.k0, self.kN = W0, WN, L[0].cols, U[N - 2].cols
        for W, k in ((W0, self.k0), (WN, self.kN)):
            S[:, k] -= L[N - 1].on(W[N - 2]) + U[N - 1].on(W[0])
        self.S = _lu(S, self.pivots)

    def solve(self, r):
        """J^-1 r, r (n,) or (n, k)."""
        N, m, L, U = self.N, self.m, self.L, self.U
        r = np.asarray(r, dtype=self.dtype)
        z = [self._solve(0, r[:m])]
        for b in range(1, N - 1):
            z.append(self._solve(b, r[b * m:(b + 1) * m] - L[b].on(z[-1])))
        for b in range(N - 3, -1, -1):
            z[b] = z[b] - self.X[b] @ z[b + 1][U[b].cols]
        xs = sla.lu_solve(self.S, r[(N - 1) * m:] - L[N - 1].on(z[N - 2]) - U[N - 1].on(z[0]),
                          check_finite=False)
        x0, xN = xs[self.k0], xs[self.kN]
        return np.concatenate([z[b] - self.W0[b] @ x0 - self.WN[b] @ xN
                               for b in range(N - 1)] + [xs]).astype(float)


def _lu(A, pivots=None):
    if pivots is not None:
        pivots(A)
    with warnings.catch_warnings():  # an exactly singular block: raised below instead
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        lu = sla.lu_factor(A, overwrite_a=True, check_finite=False)
    if not np.all(np.diagonal(lu[0])):
        raise np.linalg.LinAlgError("singular block of a ring")
    return lu


class _Panel:
    """An off-diagonal block (m, m): its nonzero columns `cols` and the block on them
    (`dense`, (m, |cols|))."""

    def __init__(self, block, cols):
        self.cols, self.dense = cols, block[:, cols]

    def on(self, V):
        """The block times V (m, k), V's rows at `cols` only."""
        return self.dense @ V[self.cols]


@dataclass(frozen=True, eq=False)
class _Gather:
    """Where a pattern's entries go in the (N, 3, m, m) blocks of its ring: `flat`, the
    positions of the entries `inner` (indices into the data); the nonzero columns
    `cols[b, k]` of each off-diagonal block; the border's column, row and corner
    entries (data indices, ascending)."""

    m: int
    inner: np.ndarray
    flat: np.ndarray
    cols: np.ndarray
    col_pos: np.ndarray
    row_pos: np.ndarray
    corner: np.ndarray


_GATHERS: dict = {}   # (id(indptr), N, bordered) -> (weak reference, indices' address, _Gather)


def _gather(A, N: int, bordered: bool, keep: bool = True) -> _Gather:
    """The `_Gather` of A's pattern (CSR or CSC, canonical), kept per pattern."""
    key = (id(A.indptr), N, bordered)
    kept = _GATHERS.get(key)
    if kept is not None and kept[0]() is A.indptr and kept[1] == A.indices.ctypes.data:
        return kept[2]
    n = A.shape[0] - bordered
    m = n // N
    major = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    minor = A.indices[:A.indptr[-1]]
    row, col = (major, minor) if A.format == "csr" else (minor, major)
    inner = np.flatnonzero((row < n) & (col < n))
    r, c = row[inner], col[inner]
    br, slot = r // m, ((c // m - r // m) % N)
    slot = np.where(slot == 0, 0, np.where(slot == 1, 1, 2))
    flat = ((br * 3 + slot) * m + r % m) * m + c % m
    off = slot > 0
    used = np.unique((br[off] * 3 + slot[off]) * m + c[off] % m)   # sorted by block
    bounds = np.searchsorted(used, np.arange(3 * N + 1) * m)
    cols = np.empty((N, 3), dtype=object)
    for b in range(N):
        for k in (1, 2):
            j = 3 * b + k
            cols[b, k] = used[bounds[j]:bounds[j + 1]] - j * m
    on_col = np.flatnonzero((col == n) & (row < n)) if bordered else np.zeros(0, int)
    on_row = np.flatnonzero((row == n) & (col < n)) if bordered else np.zeros(0, int)
    corner = np.flatnonzero((row == n) & (col == n)) if bordered else np.zeros(0, int)
    g = _Gather(m, inner, flat, cols, on_col[np.argsort(row[on_col])],
                on_row[np.argsort(col[on_row])], corner)
    if keep:
        if len(_GATHERS) > 16:
            _GATHERS.clear()
        _GATHERS[key] = (weakref.ref(A.indptr), A.indices.ctypes.data, g)
    return g


def bordered_solver(A, N: int, dtype=float):
    """The solve of the bordered matrix A = [[J, c], [r, d]] ((n+1) square, sparse
    CSR or CSC) whose J is a ring of N blocks: J y = b, J z = c,
    x_n = (b_n - r y)/(d - r z), x = y - x_n z.  LinAlgError if a block or the
    border's pivot is singular."""
    A = _canonical(A)
    n = A.shape[0] - 1
    F = RingFactors(A, N, dtype, bordered=True)
    g = _gather(A, N, True)
    c, r = np.zeros(n), np.zeros(n)
    rows = A.indices[g.col_pos] if A.format == "csc" else _major(A, g.col_pos)
    cols = A.indices[g.row_pos] if A.format == "csr" else _major(A, g.row_pos)
    c[rows], r[cols] = F.border[0], F.border[1]
    d = F.border[2].sum()
    z = F.solve(c)
    pivot = d - r @ z
    if pivot == 0 or not np.isfinite(pivot):
        raise np.linalg.LinAlgError("singular border of a ring")

    def solve(b):
        b = np.asarray(b, dtype=float)
        y = F.solve(b[:n])
        xn = (b[n] - r @ y) / pivot
        return np.append(y - xn * z, xn)

    return solve


def _major(A, pos):
    """The major index (row of a CSR, column of a CSC) of the data positions pos."""
    return np.searchsorted(A.indptr, pos, side="right") - 1


def _canonical(A):
    """A as CSR or CSC with sorted, unrepeated indices (a copy only if needed)."""
    if A.format not in ("csr", "csc"):
        A = A.tocsr()
    if not A.has_canonical_format:
        A = A.copy()
        A.sum_duplicates()
    return A


def negative_eigenvalues(S, count) -> int | None:
    """The number of negative eigenvalues of the Hermitian sparse S whose pattern is a
    ring (`layout`, from MIN_INERTIA_ROWS rows), by Sylvester's law of inertia over its block
    elimination (Haynsworth: the inertia of S is the sum of its pivot blocks', each
    counted by `count` (dense)); None if S has no ring layout or a pivot block is
    singular."""
    found = layout(S, min_rows=MIN_INERTIA_ROWS, keep=False)   # S is new at every count
    if found is None or found[1]:
        return None
    total = []
    try:
        RingFactors(_canonical(S), found[0], complex, keep=False,
                    pivots=lambda D: total.append(count(D)))
    except np.linalg.LinAlgError:
        return None
    return int(sum(total))


def ring_solver(A, single: bool = True):
    """The solve of a sparse square A by its ring layout (`layout`), or None if it
    has none; single: its blocks factorised in float32 (half the time; the caller
    refines the solutions in float64 against A, `newton.refined`).  LinAlgError if a
    block is singular."""
    found = layout(A)
    if found is None:
        return None
    N, bordered = found
    dtype = np.float32 if single else float
    return (bordered_solver(A, N, dtype) if bordered
            else RingFactors(_canonical(A), N, dtype).solve)
