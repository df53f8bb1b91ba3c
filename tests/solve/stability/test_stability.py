"""Hill's method against linear closed forms, the Duffing fold structure and monodromy."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pipeline.solve.continuation.pseudo_arclength import continue_branch
from pipeline.fourier.harmonics import derivative_matrix, time_grid
from pipeline.solve.stability import hill
from pipeline.solve.stability.hill import (companion, harmonic_centroid, hill_eigenvalues,
                                          hill_matrices, is_stable, time_invariant)

from helpers import assert_same_multiset


def linear_J(K, C, M, Om, H):
    I, D = np.eye(2 * H + 1), derivative_matrix(H)
    return np.kron(K, I) + Om * np.kron(C, D) + Om**2 * np.kron(M, D @ D)


# ------------------------------------------------------------------ linear oscillator
@pytest.mark.parametrize("solver", ["dense", "qz", "sparse", "auto"])
@pytest.mark.parametrize("w, zeta", [(0.3, 0.05), (0.45, 0.01), (1.7, 0.1), (3.2, 0.3)])
def test_linear_oscillator_exponents(w, zeta, solver):
    """Floquet exponents of m x'' + c x' + k x = f are -zeta w +- i w sqrt(1 - zeta^2),
    whatever Om and H (w > Om/2 included: the centroid rule returns the unshifted copy)."""
    H, Om = 3, 1.0
    M, K, C = np.array([[2.0]]), np.array([[2.0 * w * w]]), np.array([[2.0 * 2 * zeta * w]])
    lam = hill_eigenvalues(linear_J(K, C, M, Om, H), M, C, Om, H, solver=solver)
    wd = w * np.sqrt(1 - zeta**2)
    exact = np.array([-zeta * w + 1j * wd, -zeta * w - 1j * wd])
    assert_same_multiset(lam, exact, atol=1e-10)
    stable, max_real, _ = is_stable(linear_J(K, C, M, Om, H), M, C, Om, H, solver=solver)
    assert stable and max_real == pytest.approx(-zeta * w, abs=1e-10)
    if solver in ("dense", "auto"):   # the whole Hill matrix (not its time-invariant shortcut)
        full = hill_eigenvalues(linear_J(K, C, M, Om, H), M, C, Om, H, full_output=True)
        assert_same_multiset(full.exponents, exact, atol=1e-10)


@pytest.mark.parametrize("select", ["centroid", "imag"])
def test_two_dof_exponents_and_selection_rules(select):
    """2-DOF chain, both modes (0.74, 1.79) below Om/2: both rules return the 4 modal
    eigenvalues."""
    H, Om = 4, 4.0
    M = np.diag([1.0, 2.0])
    K = np.array([[3.0, -1.0], [-1.0, 1.5]])
    C = 0.02 * K + 0.01 * M
    lam = hill_eigenvalues(linear_J(K, C, M, Om, H), M, C, Om, H, select=select)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    exact = np.linalg.eigvals(A)
    assert_same_multiset(lam, exact, atol=1e-10)


@pytest.mark.parametrize("seed", range(4))
def test_time_invariant_jacobian_is_solved_as_the_state_matrix(seed):
    """Every contact stuck: the rows of the harmonics h >= 1 are those of a linear
    system (K'' = K + k_stuck), the static rows K' on harmonic 0 plus couplings to every
    harmonic (a slider's rest position moving with the motion).  The exponents from the
    2n x 2n state matrix of K' are those the whole Hill matrix selects (its eigenvalues
    and centroids, `full_output`; damped, so that no two families cross), and a coupling between harmonics above the round-off
    is not taken as time-invariant (a complex stiffness per harmonic is)."""
    rng = np.random.default_rng(seed)
    n, H, Om = 3, 4, 1.3 + rng.random()
    A = rng.normal(size=(n, n))
    M = A @ A.T + n * np.eye(n)
    K0 = rng.normal(size=(n, n)) + 5 * n * np.eye(n)
    K1 = K0 + np.diag(rng.random(n) * 4)
    C = 0.05 * K1 + 0.02 * M
    J = linear_J(K1, C, M, Om, H)
    J4 = J.reshape(n, 2 * H + 1, n, 2 * H + 1)
    J4[:, 0, :, 0] = K0
    J4[:, 0, :, 1:] = rng.normal(size=(n, n, 2 * H))
    assert np.array_equal(time_invariant(J, n, H), K0)
    quick = hill_eigenvalues(J, M, C, Om, H)
    full = hill_eigenvalues(J, M, C, Om, H, full_output=True)
    assert_same_multiset(quick, full.exponents, atol=1e-9 * np.abs(full.exponents).max())
    np.testing.assert_allclose(full.centroid[full.selected], 0.0, atol=1e-9)
    state = np.block([[np.zeros((n, n)), np.eye(n)],
                      [-np.linalg.solve(M, K0), -np.linalg.solve(M, C)]])
    assert_same_multiset(quick, np.linalg.eigvals(state), atol=1e-12 * np.abs(quick).max())
    J4[1, 3, 0, 5] += 1e-9 * np.abs(J).max()   # harmonics 2 and 3 coupled: not time-invariant
    assert time_invariant(J, n, H) is None
    J4[1, 3, 0, 5] -= 1e-9 * np.abs(J).max()
    J4[2, 1, 1, 1] += 1e-9 * np.abs(J).max()   # cos and sin rows of harmonic 1 unlike
    assert time_invariant(J, n, H) is None
    J4[2, 1, 1, 1] -= 1e-9 * np.abs(J).max()
    for h in range(1, H + 1):   # a complex stiffness per harmonic (hysteretic): time-invariant
        A, B = rng.normal(size=(2, n, n))
        c, s = 2 * h - 1, 2 * h
        J4[:, c, :, c] += A
        J4[:, s, :, s] += A
        J4[:, c, :, s] += B
        J4[:, s, :, c] -= B
    assert np.array_equal(time_invariant(J, n, H), K0)
    full = hill_eigenvalues(J, M, C, Om, H, full_output=True)
    assert_same_multiset(hill_eigenvalues(J, M, C, Om, H), full.exponents,
                         atol=1e-9 * np.abs(full.exponents).max())


def test_companion_is_the_kronecker_linearisation():
    """The companion matrix, built from parts kept per (M, C, H), equals
    [[0, I], [-Delta2^-1 J, -Delta2^-1 Delta1]] of `hill_matrices` for one system after
    another and back (the parts of one are never taken for another's)."""
    rng = np.random.default_rng(2)
    systems = []
    for n, H in ((2, 3), (2, 3), (3, 2), (1, 4)):
        A = rng.normal(size=(n, n))
        systems.append((A @ A.T + n * np.eye(n), rng.normal(size=(n, n)), H))
    for M, C, H in systems + systems[::-1]:
        N = M.shape[0] * (2 * H + 1)
        J, Om = rng.normal(size=(N, N)), 0.5 + rng.random()
        D1, D2 = hill_matrices(M, C, Om, H)
        ref = np.block([[np.zeros((N, N)), np.eye(N)],
                        [-np.linalg.solve(D2, J), -np.linalg.solve(D2, D1)]])
        np.testing.assert_allclose(companion(J, M, C, Om, H), ref, rtol=0,
                                   atol=1e-13 * np.abs(ref).max())


def test_companion_parts_kept_only_for_small_systems():
    """Along a branch the parts are kept (the same arrays again); a system whose parts
    exceed KEEP_BYTES (N = 303 here) gets them afresh, nothing kept, at most 8 kept."""
    M, C = np.eye(1), np.zeros((1, 1))
    assert hill._companion_parts(M, C, 7)[2] is hill._companion_parts(M, C, 7)[2]
    Mb, Cb = np.eye(101), np.eye(101)
    assert 32 * (101 * 3) ** 2 > hill.KEEP_BYTES
    assert hill._companion_parts(Mb, Cb, 1)[2] is not hill._companion_parts(Mb, Cb, 1)[2]
    for k in range(12):
        hill._companion_parts(M * (1 + k), C, 2)
    assert len(hill._PARTS) <= 8
    assert all(key[0] != (101, 101) for key in hill._PARTS)


def test_imag_rule_returns_a_shifted_copy_above_half_Om():
    """For w > Om/2 the smallest-|Im| copy is lam - i Om: same real part, other Im."""
    H, Om, w, zeta = 3, 1.0, 0.8, 0.05
    M, K, C = np.eye(1), np.array([[w * w]]), np.array([[2 * zeta * w]])
    lam = hill_eigenvalues(linear_J(K, C, M, Om, H), M, C, Om, H, select="imag")
    np.testing.assert_allclose(lam.real, -zeta * w, atol=1e-12)
    np.testing.assert_allclose(np.sort(np.abs(lam.imag)), 2 * [Om - w * np.sqrt(1 - zeta**2)],
                               atol=1e-12)


def test_singular_mass_matrix():
    """Mass m on spring k1, joined by k2 to a massless node grounded by a damper c2:
    det(lam^2 M + lam C + K) is a cubic; Hill (QZ and sparse) returns its 3 roots."""
    m, k1, k2, c2, H, Om = 1.0, 4.0, 2.0, 0.5, 3, 1.3
    M = np.diag([m, 0.0])
    C = np.diag([0.0, c2])
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    # (m lam^2 + k1 + k2)(c2 lam + k2) - k2^2
    exact = np.roots(np.polymul([m, 0, k1 + k2], [c2, k2]) - np.array([0, 0, 0, k2**2]))
    J = linear_J(K, C, M, Om, H)
    for solver in ("qz", "auto"):
        lam = hill_eigenvalues(J, M, C, Om, H, solver=solver)
        assert_same_multiset(lam, exact, atol=1e-10)
    lam = hill_eigenvalues(J, M, C, Om, H, solver="sparse", k=30)
    assert_same_multiset(lam, exact, atol=1e-10)
    with pytest.raises(ValueError, match="singular"):
        hill_eigenvalues(J, M, C, Om, H, solver="dense")


def test_centroid_of_shifted_vectors():
    H = 3
    # p(tau) = exp(2 i tau): complex harmonic +2 only -> centroid 2
    P = np.zeros((1, 7), complex)
    P[0, 3], P[0, 4] = 1.0, 1.0j  # cos 2tau + i sin 2tau
    assert harmonic_centroid(P.reshape(-1, 1), 1, H)[0] == pytest.approx(2.0)
    assert harmonic_centroid(P.conj().reshape(-1, 1), 1, H)[0] == pytest.approx(-2.0)


# ------------------------------------------------------------------ Duffing, H >= 3
def duffing_hbm(m, c, k, gamma, P, H, n_samples=None):
    """HBM residual of m x'' + c x' + k x + gamma x^3 = P cos(Om t) by AFT (exact for
    the cubic if n_samples >= 4H+1): R(Q, Om) with Q (1, 2H+1) flattened."""
    tau, S, W = time_grid(H, n_samples or 8 * H + 4)
    D = derivative_matrix(H)
    I = np.eye(2 * H + 1)
    F = np.zeros(2 * H + 1)
    F[1] = P

    def fun(q, Om):
        x = S @ q
        L = k * I + Om * c * D + Om**2 * m * D @ D
        R = L @ q + W @ (gamma * x**3) - F
        J = L + W @ (3 * gamma * x[:, None] ** 2 * S)
        return R, J, (c * D + 2 * Om * m * D @ D) @ q
    return fun


DUFFING = {  # m, zeta, w0, gamma, P, Om range, H
    "H3": (1.0, 0.02, 1.0, 0.5, 0.05, (0.5, 2.0), 3),
    "H5": (1.0, 0.02, 1.0, 0.5, 0.05, (0.5, 2.0), 5),
    "H3-SI": (0.1, 0.03, 1000.0, 0.4 * 1e5 / 1e-10, 0.06 * 1e5 * 1e-5, (500.0, 2000.0), 3),
}


@pytest.fixture(scope="module", params=DUFFING)
def duffing_branch(request):
    m, zeta, w0, gamma, P, (lo, hi), H = DUFFING[request.param]
    k, c = m * w0**2, 2 * zeta * m * w0
    fun = duffing_hbm(m, c, k, gamma, P, H)
    x0 = np.zeros(2 * H + 1)
    x0[1] = P / (k - m * lo**2)
    b = continue_branch(fun, x0, lo, hi, tol=1e-10 * P)
    assert b.success, b.message
    return fun, b, np.array([[m]]), np.array([[c]]), H


def test_duffing_unstable_exactly_between_folds(duffing_branch):
    fun, b, M, C, H = duffing_branch
    assert b.fold_index.size == 2
    i1, i2 = b.fold_index
    verdicts = []
    for x, Om in zip(b.x, b.lam):
        stable, max_real, lam = is_stable(fun(x, Om)[1], M, C, Om, H)
        assert lam.size == 2
        verdicts.append(stable)
    verdicts = np.array(verdicts)
    expected = np.ones(len(b), bool)
    expected[i1 + 1:i2 + 1] = False  # points strictly between the two folds
    np.testing.assert_array_equal(verdicts, expected)
    # the unstable exponent is real (saddle-node), and the change happens at the folds:
    # stability flips exactly where the lam-component of the tangent changes sign
    flips = np.nonzero(verdicts[:-1] != verdicts[1:])[0]
    np.testing.assert_array_equal(flips, b.fold_index)


def test_duffing_fold_is_a_zero_exponent(duffing_branch):
    """At the refined fold J is singular: one Floquet exponent is 0 (to tolerance)."""
    fun, b, M, C, H = duffing_branch
    for x, Om in zip(b.fold_x, b.fold_lam):
        lam = hill_eigenvalues(fun(x, Om)[1], M, C, Om, H)
        assert np.min(np.abs(lam)) <= 1e-6 * np.max(np.abs(lam))
        assert np.max(lam.real) == pytest.approx(0.0, abs=1e-6 * np.max(np.abs(lam)))


def test_duffing_solvers_and_rules_agree(duffing_branch):
    fun, b, M, C, H = duffing_branch
    i = (b.fold_index[0] + b.fold_index[1]) // 2  # an unstable point
    for j in (i, 0, len(b) - 1):
        J, Om = fun(b.x[j], b.lam[j])[1], b.lam[j]
        ref = hill_eigenvalues(J, M, C, Om, H, solver="dense")
        for kw in (dict(solver="qz"), dict(solver="sparse"), dict(select="imag")):
            got = hill_eigenvalues(J, M, C, Om, H, **kw)
            np.testing.assert_allclose(np.sort(got.real), np.sort(ref.real),
                                       atol=1e-9 * np.abs(ref).max())


def monodromy_max_real(m, c, k, gamma, P, Om, q, H):
    """max Re of the Floquet exponents by integrating the variational equation over T."""
    x0 = q[0] + q[1::2].sum()
    v0 = Om * np.arange(1, H + 1) @ q[2::2]

    def rhs(t, y):
        x, v = y[0], y[1]
        Phi = y[2:].reshape(2, 2)
        A = np.array([[0.0, 1.0], [-(k + 3 * gamma * x * x) / m, -c / m]])
        return np.concatenate([[v, (P * np.cos(Om * t) - c * v - k * x - gamma * x**3) / m],
                               (A @ Phi).ravel()])
    T = 2 * np.pi / Om
    sol = solve_ivp(rhs, (0, T), np.concatenate([[x0, v0], np.eye(2).ravel()]),
                    method="DOP853", rtol=1e-11, atol=1e-13)
    mu = np.linalg.eigvals(sol.y[2:, -1].reshape(2, 2))
    return np.log(np.abs(mu)).max() / T


@pytest.mark.parametrize("where", ["below", "between", "above"])
def test_duffing_against_monodromy(where):
    m, zeta, w0, gamma, P, _, H = DUFFING["H5"]
    H = 7
    k, c = m * w0**2, 2 * zeta * m * w0
    fun = duffing_hbm(m, c, k, gamma, P, H)
    x0 = np.zeros(2 * H + 1)
    x0[1] = P / (k - 0.25)
    b = continue_branch(fun, x0, 0.5, 2.0, tol=1e-12)
    i1, i2 = b.fold_index
    j = {"below": i1 // 2, "between": (i1 + i2) // 2, "above": (i2 + len(b)) // 2}[where]
    q, Om = b.x[j], b.lam[j]
    stable, max_real, _ = is_stable(fun(q, Om)[1], np.array([[m]]), np.array([[c]]), Om, H)
    ref = monodromy_max_real(m, c, k, gamma, P, Om, q, H)
    assert stable == (where != "between")
    assert max_real == pytest.approx(ref, rel=1e-5, abs=1e-7)


# ------------------------------------------------------------------ arguments
@pytest.mark.parametrize("kwargs, match", [
    (dict(H=-1), "H"),
    (dict(H=2), "J must have shape"),
    (dict(Omega=0.0), "Omega"),
    (dict(C=np.eye(2)), "C must"),
    (dict(M=np.ones((1, 2))), "M must be square"),
    (dict(select="abs"), "select"),
    (dict(solver="lapack"), "solver"),
])
def test_bad_arguments(kwargs, match):
    args = dict(J=np.eye(7), M=np.eye(1), C=np.eye(1), Omega=1.0, H=3)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        hill_eigenvalues(**args)
