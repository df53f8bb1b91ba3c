"""The ring solve of a wheel's Newton matrix against dense LAPACK solves: blocks of a
ring found in the pattern, block elimination exact to round-off, float32 blocks refined
to a float64 LU's backward error, a singular block left to the sparse LU."""
import numpy as np
import pytest
import scipy.sparse as sp

from pipeline.solve.continuation import newton
from pipeline.solve.harmonic_balance import ring


def ring_matrix(N, m, faces=5, seed=0, singular_block=None):
    """A ring of N dense (m, m) blocks, each coupled to its neighbours through `faces`
    columns (the shroud DOFs), diagonally dominant enough to be well conditioned."""
    rng = np.random.default_rng(seed)
    A = sp.lil_matrix((N * m, N * m))
    for b in range(N):
        D = rng.standard_normal((m, m)) + 4 * np.sqrt(m) * np.eye(m)
        if b == singular_block:
            D[:, 0] = 0.0               # this block alone is singular
        A[b * m:(b + 1) * m, b * m:(b + 1) * m] = D
        for j, rows in (((b + 1) % N, slice(m - faces, m)), ((b - 1) % N, slice(0, faces))):
            cols = slice(0, faces) if j == (b + 1) % N else slice(m - faces, m)
            A[b * m:(b + 1) * m, j * m:(j + 1) * m] = 0
            block = np.zeros((m, m))
            block[rows, cols] = rng.standard_normal((faces, faces))
            A[b * m:(b + 1) * m, j * m:(j + 1) * m] = block
    return A.tocsr()


def bordered(J, seed=1):
    rng = np.random.default_rng(seed)
    n = J.shape[0]
    return newton.bordered_sparse(J, rng.standard_normal(n), rng.standard_normal(n + 1))


@pytest.mark.parametrize("N", [4, 7])
def test_block_elimination_equals_dense_solve(N):
    J = ring_matrix(N, 30)
    b = np.random.default_rng(2).standard_normal((J.shape[0], 3))
    x = ring.RingFactors(J, N).solve(b)
    ref = np.linalg.solve(J.toarray(), b)
    assert np.abs(x - ref).max() <= 1e-12 * np.abs(ref).max()
    A = bordered(J)
    rhs = np.random.default_rng(3).standard_normal(A.shape[0])
    x = ring.bordered_solver(A, N)(rhs)
    ref = np.linalg.solve(A.toarray(), rhs)
    assert np.abs(x - ref).max() <= 1e-11 * np.abs(ref).max()


def test_float32_blocks_refined_to_float64_backward_error():
    N = 6
    A = bordered(ring_matrix(N, 40))
    rhs = np.random.default_rng(4).standard_normal(A.shape[0])
    approx = ring.bordered_solver(A, N, np.float32)
    first = approx(rhs)
    x = newton.refined(A, rhs, approx)
    ref = np.linalg.solve(A.toarray(), rhs)
    assert np.abs(first - ref).max() > 1e-9 * np.abs(ref).max()   # float32 alone is not it
    assert np.abs(x - ref).max() <= 1e-11 * np.abs(ref).max()


def is_ring(A, N, bordered):
    """Every entry of A's (n, n) part (n = rows - bordered) in its own block of N or a
    neighbour's."""
    n = A.shape[0] - bordered
    A = A.tocoo()
    keep = (A.row < n) & (A.col < n)
    off = (A.col[keep] // (n // N) - A.row[keep] // (n // N)) % N
    return n % N == 0 and bool(np.all((off == 0) | (off == 1) | (off == N - 1)))


def test_layout_found_in_the_pattern(monkeypatch):
    monkeypatch.setattr(ring, "MIN_ROWS", 100)
    J = ring_matrix(8, 25)
    N, is_bordered = ring.layout(bordered(J))
    assert is_bordered and N >= 8 and is_ring(J, N, False)   # 8 blades or a finer cut
    assert ring.layout(J) == (N, False)
    mixed = (J + sp.random(200, 200, density=0.05, random_state=5)).tocsr()  # far couplings
    assert ring.layout(bordered(mixed)) is None
    assert ring.layout(bordered(ring_matrix(8, 25, seed=6)))[0] >= 8   # a new pattern


def test_linear_solve_of_a_wheel_matrix_uses_the_ring(monkeypatch):
    monkeypatch.setattr(ring, "MIN_ROWS", 100)
    A = bordered(ring_matrix(8, 25))
    calls = []
    factors = ring.RingFactors
    monkeypatch.setattr(ring, "RingFactors",
                        lambda *a, **k: calls.append(a[1]) or factors(*a, **k))
    rhs = np.random.default_rng(7).standard_normal(A.shape[0])
    kept = newton.KeptFactors()
    x = kept.solve(A, rhs)
    assert len(calls) == 1 and calls[0] >= 8
    ref = np.linalg.solve(A.toarray(), rhs)
    assert np.abs(x - ref).max() <= 1e-11 * np.abs(ref).max()


def test_a_singular_block_falls_back_to_the_sparse_lu(monkeypatch):
    monkeypatch.setattr(ring, "MIN_ROWS", 100)
    J = ring_matrix(8, 25, singular_block=0)
    A = bordered(J)
    with pytest.raises(np.linalg.LinAlgError):
        ring.bordered_solver(A, 8)
    rhs = np.random.default_rng(8).standard_normal(A.shape[0])
    x = newton.linear_solve(A, rhs)
    ref = np.linalg.solve(A.toarray(), rhs)
    assert np.abs(x - ref).max() <= 1e-10 * np.abs(ref).max()


def test_inertia_over_the_ring_equals_the_eigenvalues(monkeypatch):
    """The negative eigenvalues of a Hermitian ring (a wheel's S(s) on its contact
    DOFs), counted over the pivot blocks of its elimination, equal those of a dense
    eigen-solve, at shifts through its spectrum."""
    monkeypatch.setattr(ring, "MIN_INERTIA_ROWS", 50)
    from pipeline.solve.harmonic_balance.part_spectrum import negative_eigenvalues
    N, m = 6, 12
    J = ring_matrix(N, m, faces=4, seed=9).toarray()
    rng = np.random.default_rng(10)
    H = (J + J.T) + 1j * (J * rng.standard_normal(J.shape) - (J * rng.standard_normal(J.shape)).T)
    H = 0.5 * (H + H.conj().T)
    lam = np.linalg.eigvalsh(H)
    shifts = np.quantile(lam, [0.0, 0.1, 0.37, 0.5, 0.81, 1.0]) + 1e-3
    kept = (dict(ring._LAYOUTS), dict(ring._GATHERS))
    for s in shifts:
        S = sp.csr_matrix(H - s * np.eye(N * m))
        got = ring.negative_eigenvalues(S, negative_eigenvalues)
        assert got == int(np.sum(lam < s))
    # each count's S is new: nothing kept of it (the Newton matrices' patterns stay)
    assert (ring._LAYOUTS, ring._GATHERS) == kept
