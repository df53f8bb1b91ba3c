"""Many right-hand sides through a symmetric SuperLU factor, by dense supernode blocks.

For a symmetric positive definite A factorised without pivoting off the diagonal
(`reduction.factorize`: symmetric ordering P, diagonal pivots),

    P A P^T = L U = L D L^T,   D = diag(U),

so A^{-1} B = P^T L^{-T} D^{-1} L^{-1} P B needs only L.  SuperLU's own solve runs
the L half as dense blocks but the U half column by column, one right-hand side at
a time; here both halves run on the supernodes of L (runs of columns sharing one
row pattern): per supernode a unit triangular solve with its diagonal block and one
matrix product with the rows below it, for all right-hand sides at once.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la


@dataclass(frozen=True, eq=False)
class SupernodalFactor:
    """L D L^T of P A P^T as supernodes.  cols[s] = (first, stop) column range,
    rows[s]: row indices below the diagonal block, diag[s]: the unit lower
    (w, w) diagonal block, below[s]: the (len(rows[s]), w) block under it; d: D;
    perm: `SuperLU.perm_c`, P given as an index array: y = P x is y[perm] = x."""

    cols: tuple
    rows: tuple
    diag: tuple
    below: tuple
    d: np.ndarray
    perm: np.ndarray

    @property
    def n(self) -> int:
        return self.d.size


def supernodes(lu) -> SupernodalFactor:
    """Split the L of a symmetric SuperLU factor `lu` (perm_r == perm_c, U = D L^T)
    into dense supernode blocks."""
    if not np.array_equal(lu.perm_r, lu.perm_c):
        raise ValueError("lu must come from a symmetric ordering with diagonal pivots "
                         "(perm_r == perm_c)")
    L = lu.L.tocsc()
    L.sort_indices()
    n = L.shape[0]
    ptr, idx = L.indptr, L.indices
    cnt = np.diff(ptr)
    # column j + 1 continues the supernode of j if its pattern is that of j less row j
    nxt = np.where(cnt > 1, idx[np.minimum(ptr[:-1] + 1, idx.size - 1)], -1)
    same = (cnt[1:] == cnt[:-1] - 1) & (nxt[:-1] == np.arange(1, n))
    c0 = np.concatenate([[0], np.nonzero(~same)[0] + 1])
    c1 = np.append(c0[1:], n)
    w = c1 - c0
    h = cnt[c0]  # rows of the supernode's (h, w) block, diagonal block included
    base = np.concatenate([[0], np.cumsum(h * w)])
    # one flat buffer holds every block in column-major order: the entries of column
    # j (k-th of its supernode s) start at base[s] + k * h[s] + k
    s = np.repeat(np.arange(c0.size), w)
    k = np.arange(n) - c0[s]
    start = base[s] + k * h[s] + k
    buf = np.zeros(base[-1])
    buf[np.repeat(start - ptr[:-1], cnt) + np.arange(idx.size)] = L.data
    blocks = [buf[base[t]:base[t + 1]].reshape(h[t], w[t], order="F") for t in range(c0.size)]
    cols = tuple(zip(c0.tolist(), c1.tolist()))
    rows = tuple(idx[ptr[a] + b - a:ptr[a + 1]] for a, b in cols)
    diag = tuple(B[:B.shape[1]] for B in blocks)
    below = tuple(B[B.shape[1]:] for B in blocks)
    return SupernodalFactor(cols, rows, diag, below,
                            lu.U.diagonal().copy(), np.asarray(lu.perm_c))


def solve_into(F: SupernodalFactor, B, out: np.ndarray) -> np.ndarray:
    """out = A^{-1} B for dense or sparse B (n, k), k right-hand sides in one pass
    over the supernodes; out (n, k) is written in place (it may be a view)."""
    X = np.empty((F.n, B.shape[1]))
    X[F.perm] = B.toarray() if hasattr(B, "toarray") else B
    for (c0, c1), r, Ld, Lb in zip(F.cols, F.rows, F.diag, F.below):
        if c1 - c0 > 1:
            X[c0:c1] = la.solve_triangular(Ld, X[c0:c1], lower=True, unit_diagonal=True,
                                           check_finite=False)
        if r.size:
            X[r] -= Lb @ X[c0:c1]
    X /= F.d[:, None]
    for (c0, c1), r, Ld, Lb in zip(reversed(F.cols), reversed(F.rows), reversed(F.diag),
                                   reversed(F.below)):
        if r.size:
            X[c0:c1] -= Lb.T @ X[r]
        if c1 - c0 > 1:
            X[c0:c1] = la.solve_triangular(Ld, X[c0:c1], trans="T", lower=True,
                                           unit_diagonal=True, check_finite=False)
    out[...] = X[F.perm]
    return out
