"""The (c, o) blocks of a sparse system's matrices, sliced once per problem.

The "sparse" strategy of `dynamic_stiffness` (a cyclic sector or a full wheel) needs
S_cc, S_co, S_oc and S_oo of S_h = K_h - w^2 M + i w C + sum a_t A_t at every
evaluation: slicing the assembled S each time cost about 1 ms per block and harmonic
(a full wheel's exact peak search recovers the eliminated DOFs ~20,000 times).  The
blocks of K_h, M, C and the terms' A_t are cut here once; `dynamic_stiffness` forms
each block of S from them, entry by entry the same sums as before.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp


@dataclass(frozen=True)
class SparseBlocks:
    """(cc dense, co CSR, oc CSR, oo CSC) of each matrix: K per harmonic, M, C, and
    the added terms' A_t in their order."""

    K: tuple
    M: tuple
    C: tuple
    extra: tuple


def cut(A, c, o) -> tuple:
    """(A_cc dense, A_co CSR, A_oc CSR, A_oo CSC) of a sparse (or dense) matrix."""
    if not sp.issparse(A):
        A = np.asarray(A)
        return A[np.ix_(c, c)], A[np.ix_(c, o)], A[np.ix_(o, c)], A[np.ix_(o, o)]
    A = sp.csr_matrix(A)
    rc, ro = A[c], A[o]
    return rc[:, c].toarray(), rc[:, o].tocsr(), ro[:, c].tocsr(), ro[:, o].tocsc()


def sparse_blocks(K, M, C, matrices, c, o) -> SparseBlocks | None:
    """The blocks of K (one per harmonic), M, C and the terms' `matrices`; None when
    a K_h is dense (a cyclic sector with a dense K_next coupling: sliced as formed)."""
    if not all(sp.issparse(k) for k in K):
        return None
    return SparseBlocks(tuple(cut(k, c, o) for k in K), cut(M, c, o), cut(C, c, o),
                        tuple(cut(A, c, o) for A in matrices))
