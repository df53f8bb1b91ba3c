"""Supernode-block solves through a symmetric SuperLU factor against dense solves."""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from pipeline.structure.reduction import factorize
from pipeline.structure.supernodal import solve_into, supernodes


def laplacian_3d(n, shift=0.1):
    """SPD 7-point Laplacian on an n^3 grid, shifted and with a random symmetric
    perturbation of its values (same pattern)."""
    d = sp.diags([-1.0, 2.0 + shift, -1.0], [-1, 0, 1], shape=(n, n))
    eye = sp.eye(n)
    A = (sp.kron(sp.kron(d, eye), eye) + sp.kron(sp.kron(eye, d), eye)
         + sp.kron(sp.kron(eye, eye), d)).tocsr()
    A.data *= 1 + 0.1 * np.random.default_rng(0).random(A.nnz)
    return ((A + A.T) / 2).tocsc()


@pytest.mark.parametrize("sparse_rhs", [False, True])
def test_solve_matches_dense(sparse_rhs):
    A = laplacian_3d(7)
    B = sp.random(A.shape[0], 9, density=0.05, random_state=1, format="csc")
    F = supernodes(factorize(A))
    assert max(c1 - c0 for c0, c1 in F.cols) > 1  # dense blocks, not only columns
    out = np.zeros((A.shape[0], 12))
    solve_into(F, B if sparse_rhs else B.toarray(), out[:, 2:11])
    X = np.linalg.solve(A.toarray(), B.toarray())
    np.testing.assert_allclose(out[:, 2:11], X, rtol=0, atol=1e-12 * abs(X).max())
    assert not out[:, :2].any() and not out[:, 11:].any()


def test_row_pivoting_is_refused():
    A = sp.csc_matrix([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    lu = sla.splu(A, permc_spec="NATURAL")  # rows 0 and 1 swap: perm_r != perm_c
    with pytest.raises(ValueError, match="perm_r == perm_c"):
        supernodes(lu)
