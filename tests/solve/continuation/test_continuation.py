"""Continuation against closed-form fold curves and the Duffing frequency response."""
from dataclasses import FrozenInstanceError

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from pipeline.solve.continuation.arclength import ContinuationOptions, Metric, automatic_scale, continuation_options
from pipeline.solve.continuation.branch import Branch
from pipeline.solve.continuation.pseudo_arclength import continue_branch
from pipeline.solve.continuation.newton import KeptFactors, newton
from pipeline.solve.continuation.tracer import Tracer

from helpers import scurve


def circle2(x, lam):
    """u^2 + lam^2 = 1, w = u lam (two unknowns): one fold at lam = 1, u = 0."""
    u, w = x
    R = np.array([u**2 + lam**2 - 1, w - u * lam])
    J = np.array([[2 * u, 0.0], [-lam, 1.0]])
    return R, J, np.array([2 * lam, -u])


def real_root(coeffs, pick):
    r = np.roots(coeffs)
    return pick(r[np.abs(r.imag) < 1e-9].real)


CASES = {
    # name: fun, x0, lam0, lam_end, exact fold lams (in branch order), status, max points
    # (measured: 21, 21, 40 points)
    "scurve-up": (scurve, [real_root([1, 0, -3, 3], min)], -3.0, 3.0, [2.0, -2.0], 0, 25),
    "scurve-down": (scurve, [real_root([1, 0, -3, -3], max)], 3.0, -3.0, [-2.0, 2.0], 0, 25),
    "circle": (circle2, [-0.8, 0.4], -0.5, 1.5, [1.0], 1, 45),
}


@pytest.mark.parametrize("case", CASES)
def test_closed_form_folds(case):
    fun, x0, lam0, lam_end, folds, status, max_len = CASES[case]
    b = continue_branch(fun, np.array(x0, float), lam0, lam_end, tol=1e-11)
    assert b.success and b.status == status, b.message
    np.testing.assert_allclose(b.fold_lam, folds, atol=1e-9)
    # every returned point satisfies the residual rule, recomputed here
    for x, lam in zip(b.x, b.lam):
        assert np.linalg.norm(fun(x, lam)[0]) <= 1e-11
    # the run ends exactly on the interval boundary it left through
    assert b.lam[-1] == (lam_end if status == 0 else lam0)
    assert np.all(b.converged) and b.residual_norm.max() <= 1e-11
    # cost budgets (measured: <= 5.8 fun calls per point incl. fold refinement)
    assert len(b) <= max_len
    assert b.nfev <= 6.5 * len(b)
    assert b.nit.max() <= 5


def test_scurve_fold_x_and_index():
    x0 = [real_root([1, 0, -3, 3], min)]
    b = continue_branch(scurve, x0, -3.0, 3.0, tol=1e-12)
    np.testing.assert_allclose(b.fold_x[:, 0], [-1.0, 1.0], atol=1e-6)
    for i in b.fold_index:  # lam-component of the tangent changes sign across i, i+1
        assert b.tangent[i, -1] * b.tangent[i + 1, -1] < 0


def test_hermite_only_fold_estimate_is_cheaper_and_close():
    x0 = [real_root([1, 0, -3, 3], min)]
    fine = continue_branch(scurve, x0, -3.0, 3.0, tol=1e-12)
    rough = continue_branch(scurve, x0, -3.0, 3.0, tol=1e-12, refine_folds=False)
    assert rough.nfev < fine.nfev
    np.testing.assert_allclose(rough.fold_lam, [2.0, -2.0], atol=5e-3)


# ------------------------------------------------------------------ Duffing (1 harmonic)
def duffing_1h(zeta, gamma, P, w0=1.0, m=1.0):
    """Single-harmonic HBM of m x'' + c x' + k x + gamma x^3 = P cos(Om t), x = qc cos + qs sin."""
    c, k, kap = 2 * zeta * w0 * m, m * w0**2, 0.75 * gamma

    def fun(q, Om):
        qc, qs = q
        a2 = qc**2 + qs**2
        s = k - m * Om**2 + kap * a2
        R = np.array([s * qc + c * Om * qs - P, s * qs - c * Om * qc])
        J = np.array([[s + 2 * kap * qc**2, c * Om + 2 * kap * qc * qs],
                      [2 * kap * qc * qs - c * Om, s + 2 * kap * qs**2]])
        dOm = np.array([-2 * m * Om * qc + c * qs, -2 * m * Om * qs - c * qc])
        return R, J, dOm
    return fun


def duffing_fold_frequencies(zeta, gamma, P, w0=1.0, m=1.0):
    """Fold frequencies from the closed-form response Om_+(a) (extrema along a).

    a^2 [(k - m Om^2 + 3/4 gamma a^2)^2 + (c Om)^2] = P^2 solved for u = Om^2:
    m^2 u^2 - (2 m w - c^2) u + w^2 - P^2/a^2 = 0, w = k + 3/4 gamma a^2.
    """
    c, k = 2 * zeta * w0 * m, m * w0**2

    def disc(a):
        w = k + 0.75 * gamma * a**2
        return (2 * m * w - c**2) ** 2 - 4 * m**2 * (w**2 - P**2 / a**2)

    def Om_plus(a):
        w = k + 0.75 * gamma * a**2
        return np.sqrt((2 * m * w - c**2 + np.sqrt(np.maximum(disc(a), 0))) / (2 * m**2))

    a = np.linspace(1e-3 * P / k, 2 * P / (c * w0), 200001)
    a = a[disc(a) >= 0]
    Om = Om_plus(a)
    d = np.diff(Om)
    out = []
    for i in np.nonzero(d[:-1] * d[1:] < 0)[0]:
        sgn = 1 if d[i] < 0 else -1  # minimum: +1, maximum: -1
        r = minimize_scalar(lambda x: sgn * Om_plus(x), bounds=(a[i], a[i + 2]),
                            method="bounded", options={"xatol": 1e-14})
        out.append(Om_plus(r.x))
    return np.array(out)  # in increasing a: jump-up (min Om) then jump-down (max Om)


DUFFING = {
    # name: zeta, gamma, P, w0, m, x unit L, Om range
    "nondim": (0.02, 0.5, 0.05, 1.0, 1.0, 1.0, (0.5, 2.0)),
    "softer-damping": (0.05, 1.0, 0.1, 1.0, 1.0, 1.0, (0.5, 2.5)),
    # physical units: w0 = 1000 rad/s, m = 0.1 kg, amplitudes ~1e-5 m (no hand scaling)
    "SI-units": (0.02, 0.5, 0.05, 1000.0, 0.1, 1e-5, (500.0, 2000.0)),
}


@pytest.mark.parametrize("case", DUFFING)
@pytest.mark.parametrize("sweep", ["up", "down"])
def test_duffing_fold_frequencies(case, sweep):
    zeta, ghat, Phat, w0, m, L, (Om_lo, Om_hi) = DUFFING[case]
    k = m * w0**2
    gamma, P = ghat * k / L**2, Phat * k * L  # dimensional cubic stiffness and force
    fun = duffing_1h(zeta, gamma, P, w0, m)
    lam0, lam_end = (Om_lo, Om_hi) if sweep == "up" else (Om_hi, Om_lo)
    x0 = np.array([P / (k - m * lam0**2), 0.0])  # linear response as the guess
    tol, tol_rel = 1e-12 * P, 1e-10  # absolute part negligible: the relative rule governs
    b = continue_branch(fun, x0, lam0, lam_end, tol=tol, tol_rel=tol_rel, r_ref=P)
    assert b.success and b.status == 0 and b.lam[-1] == lam_end, b.message
    exact = duffing_fold_frequencies(zeta, gamma, P, w0, m)
    assert exact.size == 2
    assert b.fold_lam.size == 2
    np.testing.assert_allclose(np.sort(b.fold_lam), np.sort(exact), rtol=1e-9)
    # convergence rule, recomputed in the caller's units
    for x, Om in zip(b.x, b.lam):
        assert np.linalg.norm(fun(x, Om)[0]) <= tol + tol_rel * P
    # the peak amplitude equals the closed-form peak a = P / (c Om) at Om_peak
    a = np.hypot(b.x[:, 0], b.x[:, 1])
    assert a.max() <= P / (2 * zeta * w0 * m * w0) * 1.0001
    # cost budgets (measured: 29-38 points, 5.2-5.6 fun calls per point, <= 3 rejections)
    assert len(b) <= 45
    assert b.nfev <= 6 * len(b)
    assert b.n_rejected <= 4


def test_point_at_lam_end_and_callback_stop():
    fun = duffing_1h(0.02, 0.5, 0.05)
    seen = []
    b = continue_branch(fun, [0.05 / 0.75, 0.0], 0.5, 2.0, tol=1e-12,
                        callback=lambda x, lam: seen.append(lam) or len(seen) >= 5)
    assert b.status == 3 and b.success and len(b) == 5 == len(seen)
    np.testing.assert_allclose(b.lam, seen)


def test_max_points_and_step_failure_are_results():
    b = continue_branch(scurve, [real_root([1, 0, -3, 3], min)], -3.0, 3.0, tol=1e-12,
                        max_points=4)
    assert (b.status, b.success, len(b)) == (2, False, 4)

    def ends(x, lam):  # the branch x = lam stops existing at lam = 0.5
        if lam > 0.5:
            return np.array([x[0] ** 2 + 1.0]), np.array([[2 * x[0]]]), np.array([0.0])
        return np.array([x[0] - lam]), np.array([[1.0]]), np.array([-1.0])
    b = continue_branch(ends, [0.0], 0.0, 1.0, tol=1e-12, ds_min=1e-4)
    assert isinstance(b, Branch) and not b.success and b.status == -1, b.message
    assert "ds_min" in b.message
    assert 0.5 - 2e-4 <= b.lam[-1] <= 0.5
    np.testing.assert_allclose(b.x[:, 0], b.lam, atol=1e-12)


def test_first_point_failure():
    def nosol(x, lam):
        return np.array([x[0] ** 2 + 1.0]), np.array([[2 * x[0]]]), np.array([0.0])
    b = continue_branch(nosol, [0.3], 0.0, 1.0, tol=1e-10)
    assert (b.status, b.success, len(b)) == (-2, False, 0)
    assert "first point" in b.message


def test_newton_rule_is_residual_only():
    res = newton(lambda x: (x**2 - 2.0, np.diag(2 * x)), np.array([1.0]), 1e-14, 20)
    assert res.success and abs(res.x[0] ** 2 - 2) <= 1e-14 and res.nfev == res.nit + 1
    assert res.nit <= 6
    res = newton(lambda x: (x**2 - 2.0, np.diag(2 * x)), np.array([1.0]), 1e-14, 2)
    assert not res.success and res.status == 1 and res.residual_norm > 1e-14
    res = newton(lambda x: (x**2 + 1.0, np.diag(2 * x)), np.array([0.0]), 1e-10, 10)
    assert not res.success and res.status == 2


@pytest.mark.parametrize("sparse", [False, True])
def test_kept_factors_refine_near_matrices_to_a_fresh_solves_accuracy(sparse):
    import scipy.sparse as sp
    rng = np.random.default_rng(3)
    n = 320    # dense systems below 300 rows are solved afresh, nothing kept
    A = rng.standard_normal((n, n)) + 8 * np.eye(n)
    b = rng.standard_normal(n)
    f = KeptFactors()
    x0 = f.solve(sp.csc_matrix(A) if sparse else A, b)
    np.testing.assert_allclose(A @ x0, b, atol=1e-12)
    # a matrix one small Newton step away: refined on the kept factors, not factorised
    B = A + 1e-4 * rng.standard_normal((n, n))
    x = f.near(sp.csc_matrix(B) if sparse else B, b)
    assert (f.refined, f.factorised) == (1, 0)
    berr = np.linalg.norm(b - B @ x) / (np.linalg.norm(B) * np.linalg.norm(x) + np.linalg.norm(b))
    assert berr <= 16 * np.finfo(float).eps
    y = np.linalg.solve(B, b)
    assert np.abs(x - y).max() <= 1e-11 * np.abs(y).max()
    # a far matrix (refinement cannot converge): factorised afresh, and kept
    C = A + 3 * rng.standard_normal((n, n))
    x = f.near(sp.csc_matrix(C) if sparse else C, b)
    assert (f.refined, f.factorised) == (1, 1)
    np.testing.assert_allclose(x, np.linalg.solve(C, b), rtol=1e-9)
    x = f.near(sp.csc_matrix(C) if sparse else C, 2 * b)
    assert f.refined == 2
    np.testing.assert_allclose(x, 2 * np.linalg.solve(C, b), rtol=1e-9)
    # another size, nothing kept, or a small dense system: solved afresh; singular: raises
    assert KeptFactors().near(np.eye(3), np.ones(3)).tolist() == [1.0, 1.0, 1.0]
    small = KeptFactors()
    small.solve(A[:60, :60], b[:60])
    small.near(B[:60, :60], b[:60])
    assert small.last is None and small.refined == 0
    with pytest.raises((np.linalg.LinAlgError, RuntimeError)):
        KeptFactors().solve(sp.csc_matrix((3, 3)) if sparse else np.zeros((3, 3)), np.ones(3))


def test_sparse_factors_with_threshold_pivots_are_checked_and_replaced_where_they_fail(
        monkeypatch):
    """A fresh sparse LU keeps diagonal pivots down to _DIAG_PIVOT of their column
    (minimum degree on A^T + A): on a block-cyclic, indefinite matrix like a wheel's
    Newton system its solution meets a partial-pivoting LU's backward error.  Where
    such factors are too poor for refinement to reach it, the matrix is factorised
    again with partial pivoting, in `KeptFactors.solve` and in `linear_solve`."""
    import scipy.sparse as sp
    from pipeline.solve.continuation import newton as nt
    rng = np.random.default_rng(8)
    nb, b = 24, 10
    A = np.zeros((nb * b, nb * b))
    for k in range(nb):    # indefinite diagonal blocks, both neighbours coupled
        j, i = slice(k * b, k * b + b), slice(((k + 1) % nb) * b, ((k + 1) % nb) * b + b)
        A[j, j] = rng.standard_normal((b, b)) + np.diag(rng.choice([-1.0, 1.0], b))
        A[j, i], A[i, j] = rng.standard_normal((b, b)), rng.standard_normal((b, b))
    rhs = rng.standard_normal(nb * b)

    def berr(M, x, y):
        return np.linalg.norm(y - M @ x) / (np.linalg.norm(M) * np.linalg.norm(x)
                                           + np.linalg.norm(y))

    eps16 = 16 * np.finfo(float).eps
    f = KeptFactors()
    assert berr(A, f.solve(sp.csc_matrix(A), rhs), rhs) <= eps16
    assert berr(A, nt.linear_solve(sp.csc_matrix(A), rhs), rhs) <= eps16
    calls = []
    exact = nt._partial_pivoting

    def counted(M):
        calls.append(1)
        return exact(M)

    def poor(M):   # factors of a matrix 30 % away: refinement cannot converge
        return nt.spla.splu(sp.csc_matrix(M + 0.3 * np.abs(M).max() * sp.eye(M.shape[0]))).solve

    monkeypatch.setattr(nt, "_sparse_solver", poor)
    monkeypatch.setattr(nt, "_partial_pivoting", counted)
    f = KeptFactors()
    assert berr(A, f.solve(sp.csc_matrix(A), rhs), rhs) <= eps16
    assert berr(A, nt.linear_solve(sp.csc_matrix(A), rhs), rhs) <= eps16
    assert len(calls) == 2
    assert berr(A, f.near(sp.csc_matrix(A), rhs), rhs) <= eps16 and f.refined == 1


def test_a_sparse_jacobian_with_repeated_entries_keeps_the_bordered_structure_intact():
    """A Jacobian whose CSR holds a (row, column) twice is summed before it is bordered:
    SuperLU would otherwise sum the shared, kept structure in place and corrupt every
    later system of that pattern (each solve checked against a dense one)."""
    import scipy.sparse as sp
    from pipeline.solve.continuation.newton import bordered_sparse, linear_solve
    rng = np.random.default_rng(9)
    n = 6
    rows = np.concatenate([np.arange(n), [0, 2]])
    cols = np.concatenate([np.arange(n), [0, 3]])
    order = np.argsort(rows, kind="stable")
    # int32 index arrays, as a problem's pattern keeps them: every J shares them
    indptr = np.searchsorted(rows[order], np.arange(n + 1)).astype(np.int32)
    indices = cols[order].astype(np.int32)
    for _ in range(3):
        vals = rng.standard_normal(rows.size) + 4.0 * (rows == cols)
        J = sp.csr_matrix((vals[order], indices, indptr), shape=(n, n))
        assert J.indptr is indptr
        assert not J.has_canonical_format
        col, row = rng.standard_normal(n), rng.standard_normal(n + 1)
        A = bordered_sparse(J, col, row)
        dense = np.block([[J.toarray(), col[:, None]], [row[None, :]]])
        b = rng.standard_normal(n + 1)
        assert np.abs(linear_solve(A, b) - np.linalg.solve(dense, b)).max() <= 1e-12


def test_kept_factors_give_up_at_once_when_refinement_cannot_arrive_in_time():
    """B = A (I + 0.3 Q), Q orthogonal: refinement on A's factors contracts by 0.3 a
    step and would need about 30 steps to a fresh LU's backward error: it stops after
    its first step (two solves on the kept factors, not seven) and B is factorised."""
    rng = np.random.default_rng(4)
    n = 320
    A = rng.standard_normal((n, n)) + 8 * np.eye(n)
    b = rng.standard_normal(n)
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    B = A @ (np.eye(n) + 0.3 * Q)
    f = KeptFactors()
    f.solve(A, b)
    kept, calls = f.last, [0]

    def counted(r):
        calls[0] += 1
        return kept(r)

    f.last = counted
    x = f.near(B, b)
    assert calls[0] == 2 and (f.refined, f.factorised) == (0, 1)
    np.testing.assert_allclose(x, np.linalg.solve(B, b), rtol=1e-9)


def test_large_dense_systems_factorised_in_single_precision_solve_to_double_accuracy():
    rng = np.random.default_rng(5)
    n = 600
    b = rng.standard_normal(n)
    U, _ = np.linalg.qr(rng.standard_normal((n, n)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    eps = np.finfo(float).eps

    def berr(A, x):
        return np.linalg.norm(b - A @ x) / (np.linalg.norm(A) * np.linalg.norm(x) + np.linalg.norm(b))

    # condition 1e3: the float32 factors suffice, refined to float64's backward error
    A = (U * np.logspace(0, -3, n)) @ V.T
    f = KeptFactors()
    x = f.solve(A, b)
    assert f.single == 1 and berr(A, x) <= 16 * eps
    y = np.linalg.solve(A, b)
    assert np.abs(x - y).max() <= 1e-10 * np.abs(y).max()
    # condition 1e12: beyond float32's refinement, factorised again in float64
    A = (U * np.logspace(0, -12, n)) @ V.T
    x = f.solve(A, b)
    assert f.single == 1 and berr(A, x) <= 16 * eps   # float64's backward error, as LAPACK's
    assert berr(A, x) <= 4 * berr(A, np.linalg.solve(A, b)) + 2 * eps


@pytest.mark.parametrize("kwargs, match", [
    (dict(tol=None), "tol"),
    (dict(tol=-1.0), "tol"),
    (dict(tol=1e-8, ds=0.0), "ds"),
    (dict(tol=1e-8, ds_min=1.0, ds_max=0.1), "ds_min"),
    (dict(tol=1e-8, ds=1.0, ds_max=0.5), "ds"),
    (dict(tol=1e-8, max_points=0), "max_points"),
    (dict(tol=1e-8, max_newton=2.5), "max_newton"),
    (dict(tol=1e-8, direction=0), "direction"),
    (dict(tol=1e-8, scale=[1.0]), "scale"),
    (dict(tol=1e-8, scale=[1.0, -1.0]), "scale"),
    (dict(tol=1e-8, tol_rel=1e-6), "r_ref"),
    (dict(tol=1e-8, callback=3), "callback"),
    (dict(tol=1e-8, lam_back=0.0), "lam_back"),
    (dict(tol=1e-8, lam_back=np.nan), "lam_back"),
])
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        continue_branch(scurve, [-2.1], -3.0, 3.0, **kwargs)


@pytest.mark.parametrize("args, match", [
    (([np.nan], -3.0, 3.0), "x0"),
    (([[1.0]], -3.0, 3.0), "x0"),
    (([-2.1], -3.0, -3.0), "lam_end"),
    (([-2.1], np.inf, 3.0), "lam0"),
])
def test_bad_positional_arguments(args, match):
    with pytest.raises(ValueError, match=match):
        continue_branch(scurve, *args, tol=1e-8)


def test_fun_with_wrong_shapes_is_named():
    with pytest.raises(ValueError, match="fun must return"):
        continue_branch(lambda x, lam: (np.zeros(2), np.eye(2), np.zeros(2)),
                        [1.0], 0.0, 1.0, tol=1e-8)


def test_rule_holds_with_an_inexact_jacobian():
    """A Jacobian off by 1.3x makes Newton converge linearly (rate 0.23): points must
    still meet ||R|| <= tol, paid for with iterations, never accepted on a flag."""
    def fun(x, lam):
        R, J, Jl = scurve(x, lam)
        return R, 1.3 * J, 1.3 * Jl
    b = continue_branch(fun, [real_root([1, 0, -3, 3], min)], -3.0, 3.0, tol=1e-10,
                        max_newton=40, target_newton=12)
    assert b.success, b.message
    np.testing.assert_allclose(b.fold_lam, [2.0, -2.0], atol=1e-9)
    for x, lam in zip(b.x, b.lam):
        assert abs(scurve(x, lam)[0][0]) <= 1e-10
    assert b.nit.max() > 10  # the slow convergence is visible in the counts
    assert len(b) <= 150  # measured 136
    b = continue_branch(fun, [real_root([1, 0, -3, 3], min)], -3.0, 3.0, tol=1e-10,
                        max_newton=5, ds_min=1e-3)
    assert not b.success and b.status in (-1, -2)
    for x, lam in zip(b.x, b.lam):
        assert abs(scurve(x, lam)[0][0]) <= 1e-10


@pytest.mark.parametrize("direction, status, x_end, folds", [
    (+1, 0, real_root([1, 0, -3, 3], min), []),
    (-1, 1, 2.0, [-2.0]),
])
def test_start_at_a_fold(direction, status, x_end, folds):
    """Start exactly at the fold (x, lam) = (-1, 2) of x^3 - 3x = lam (singular dR/dx)."""
    b = continue_branch(scurve, [-1.0], 2.0, -3.0, tol=1e-12, direction=direction)
    assert b.status == status, b.message
    assert b.x[-1, 0] == pytest.approx(x_end, abs=1e-10)
    np.testing.assert_allclose(b.fold_lam, folds, atol=1e-9)


def test_sparse_jacobian_matches_dense():
    import scipy.sparse as sp
    fun = duffing_1h(0.02, 0.5, 0.05)
    dense = continue_branch(fun, [0.05 / 0.75, 0.0], 0.5, 2.0, tol=1e-12)
    sparse = continue_branch(lambda x, lam: (lambda R, J, Jl: (R, sp.csr_matrix(J), Jl))(
        *fun(x, lam)), [0.05 / 0.75, 0.0], 0.5, 2.0, tol=1e-12)
    assert sparse.success and len(sparse) == len(dense)
    np.testing.assert_allclose(sparse.fold_lam, dense.fold_lam, rtol=1e-12)


def test_user_scale_is_kept():
    fun = duffing_1h(0.02, 0.5, 0.05)
    b = continue_branch(fun, [0.05 / 0.75, 0.0], 0.5, 2.0, tol=1e-12, scale=[1.0, 1.0, 1.5])
    assert b.success
    np.testing.assert_array_equal(b.scale, [1.0, 1.0, 1.5])
    np.testing.assert_allclose(np.sort(b.fold_lam), np.sort(duffing_fold_frequencies(0.02, 0.5, 0.05)),
                               rtol=1e-9)


@pytest.mark.parametrize("direction,status,folds", [(+1, 1, [2.0]), (-1, 0, [-2.0])])
def test_start_between_folds_followed_back_past_lam0(direction, status, folds):
    """x^3 - 3x = lam from the middle branch (x = 0, lam = 0) towards lam = 3, allowed
    back to lam = -3: towards lam_end the branch turns at the fold (-1, 2) and leaves
    at lam_back; the reversed start passes the fold (1, -2) behind lam0 and reaches
    lam_end on the upper branch."""
    b = continue_branch(scurve, [0.0], 0.0, 3.0, tol=1e-12, lam_back=-3.0,
                        direction=direction)
    assert b.success and b.status == status, b.message
    assert b.lam[-1] == (3.0 if status == 0 else -3.0)
    np.testing.assert_allclose(b.fold_lam, folds, atol=1e-9)
    assert np.all((b.lam >= -3.0) & (b.lam <= 3.0))


def corner(x, lam):
    """x = 10 max(lam - 1, 0) (scaled: a corner of ~85 deg at lam = 1) plus a smooth
    second unknown, as at the onset of stick or slip."""
    R = np.array([x[0] - 10 * max(lam - 1.0, 0.0), x[1] - np.sin(lam)])
    J = np.eye(2)
    return R, J, np.array([-10.0 * (lam > 1.0), -np.cos(lam)])


@pytest.mark.parametrize("lam0,lam_end", [(0.0, 2.0), (2.0, 0.0)])
def test_corner_passed_without_the_step_collapsing(lam0, lam_end):
    """The corner is located from the two one-sided tangents and passed without the
    step collapsing.  Measured: 4 / 1 rejected steps, smallest step 0.025 / 0.05,
    20 / 15 points (by halving alone: 10 / 11 rejected, 5.5e-4 / 7.8e-4, 29 / 31)."""
    x0 = np.array([10 * max(lam0 - 1.0, 0.0), np.sin(lam0)])
    b = continue_branch(corner, x0, lam0, lam_end, tol=1e-12, ds=0.05, ds_max=0.2,
                        scale=[10.0, 1.0, 2.0])
    assert b.success and b.status == 0, b.message
    for x, lam in zip(b.x, b.lam):
        assert np.linalg.norm(corner(x, lam)[0]) <= 1e-12
    assert b.n_rejected <= 5 and b.min_step >= 0.02 and len(b) <= 22
    assert np.all(np.diff(b.lam) * np.sign(lam_end - lam0) > 0)
    before = (b.lam - 1.0) * np.sign(lam_end - lam0) < 0  # incoming side of the corner
    assert np.abs(b.lam[before] - 1.0).min() < 0.01      # a point just before it
    assert np.abs(b.lam[~before] - 1.0).min() < 0.05


# ------------------------------------------------------------------ the pieces
def unit_circle(x, lam):
    """x^2 + lam^2 = 1: from (1, 0) the corrector normal to the tangent (0, 1) at the
    step ds lands on lam = ds, x = sqrt(1 - ds^2) (scale [1, 1])."""
    return np.array([x[0] ** 2 + lam**2 - 1]), np.array([[2 * x[0]]]), np.array([2 * lam])


def test_options_are_validated_once_and_frozen():
    o = continuation_options(2, -1, 1, tol=1e-8, tol_rel=1e-6, r_ref=10.0, lam_back=-2.0,
                             max_turn=4.0)
    assert isinstance(o, ContinuationOptions) and (o.lam0, o.lam_end) == (-1.0, 1.0)
    assert o.thresh == 1e-8 + 1e-6 * 10.0 and o.bounds == (-2.0, 1.0)
    assert o.cos_turn == pytest.approx(-1.0)  # turns are capped at pi
    assert continuation_options(2, 1.0, -1.0, tol=1.0).bounds == (-1.0, 1.0)
    with pytest.raises(FrozenInstanceError):
        o.ds = 0.1
    with pytest.raises(ValueError, match="groups must be 2"):
        continuation_options(2, 0.0, 1.0, tol=1.0, groups=[0])
    with pytest.raises(ValueError, match="target_newton"):
        continuation_options(2, 0.0, 1.0, tol=1.0, target_newton=0)


def test_automatic_scale_groups_and_floor():
    np.testing.assert_array_equal(automatic_scale(np.zeros(3)), np.ones(3))
    np.testing.assert_array_equal(automatic_scale(np.array([1.0, 1e-5, 0.5])),
                                  [1.0, 1e-2, 0.5])  # floored at 1e-2 of the largest
    np.testing.assert_array_equal(
        automatic_scale(np.array([1e-5, 2.0, 0.3, 1e-3]), np.array([0, 0, 1, 1])),
        np.sqrt(2) * np.array([2.0, 2.0, 0.3, 0.3]))  # shared within a group; RMS over 2


def test_step_lengths_do_not_grow_with_the_number_of_groups_moving_together():
    """g identical copies of one forced oscillator (one group each, as the nodes of
    an FE contact face that move together) trace in the same points as one copy:
    the state's scaled size is a root mean square over the groups."""
    from pipeline.solve.continuation.pseudo_arclength import continue_branch

    def curve(g):
        def fun(x, lam):
            d = 1.0 - lam**2 + 0.1j * lam
            z = x[0::2] + 1j * x[1::2]
            r = d * z - 1.0
            R = np.empty(2 * g)
            R[0::2], R[1::2] = r.real, r.imag
            J = np.zeros((2 * g, 2 * g))
            for k in range(g):
                J[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[d.real, -d.imag], [d.imag, d.real]]
            dd = -2 * lam + 0.1j
            dz = dd * z
            dl = np.empty(2 * g)
            dl[0::2], dl[1::2] = dz.real, dz.imag
            return R, J, dl
        z0 = 1 / (0.75 + 0.05j)          # the solution at lam = 0.5
        x0 = np.tile([z0.real, z0.imag], g)
        br = continue_branch(fun, x0, 0.5, 1.5, tol=1e-10, groups=np.repeat(np.arange(g), 2))
        assert br.success
        return br.lam.size
    assert abs(curve(1) - curve(16)) <= 1


def test_metric_keeps_the_running_maximum_in_place():
    m = Metric(2, 4.0)
    s = m.s
    np.testing.assert_array_equal(s, [1.0, 1.0, 4.0])
    m.observe(np.array([-2.0, 1.0]))
    m.observe(np.array([0.5, -3.0]))
    np.testing.assert_array_equal(s, [2.0, 3.0, 4.0])  # the same array, updated
    fixed = Metric(2, 4.0, fixed=[1.0, 2.0, 3.0])
    fixed.observe(np.array([10.0, 10.0]))
    np.testing.assert_array_equal(fixed.s, [1.0, 2.0, 3.0])


def circle_tracer(lam_end=0.5, **kw):
    opts = continuation_options(1, 0.0, lam_end, tol=1e-13, scale=[1.0, 1.0], **kw)
    tracer = Tracer(unit_circle, opts)
    assert tracer.first_point(np.array([0.9])) is None
    return tracer


def test_first_point_and_one_step_on_the_circle():
    tr = circle_tracer(ds=0.1)
    np.testing.assert_allclose(tr.z, [1.0, 0.0], atol=1e-13)
    np.testing.assert_allclose(tr.t_phys, [0.0, 1.0], atol=1e-12)
    ts, y_pred = tr.predict()
    np.testing.assert_allclose(y_pred, [1.0, 0.1], atol=1e-12)
    assert tr.step() is None
    np.testing.assert_allclose(tr.z, [np.sqrt(1 - 0.01), 0.1], rtol=1e-12)
    np.testing.assert_allclose(tr.t_phys, [-0.1, np.sqrt(0.99)], rtol=1e-12)
    nit = tr.points[-1][2]
    assert len(tr.points) == 2 and nit <= 3 and tr.n_rejected == 0
    assert tr.ds == pytest.approx(min(0.1 * min(np.sqrt(4 / nit), 2.0), 0.5))
    assert tr.eq.nfev == sum(p[3] for p in tr.points)  # every call counted on a point


def test_a_turn_too_large_is_rejected_and_the_step_halved():
    tr = circle_tracer(ds=0.1, max_turn=0.06)  # a step ds turns the tangent by asin(ds)
    assert tr.step() is None
    assert len(tr.points) == 1 and tr.n_rejected == 1 and tr.ds == 0.05
    assert tr.step() is None  # asin(0.05) is within the limit
    assert len(tr.points) == 2


def test_a_step_past_lam_end_is_resolved_on_it():
    tr = circle_tracer(lam_end=0.3, ds=0.4)
    b = tr.step()
    assert isinstance(b, Branch) and b.status == 0 and b.lam[-1] == 0.3 and len(b) == 2
    np.testing.assert_allclose(b.x[-1], [np.sqrt(0.91)], rtol=1e-13)


def test_is_kink_needs_small_persistent_rejections():
    tr = circle_tracer(ds=0.1, kink_ds=0.01)
    assert not tr.is_kink("turn", 1.0)  # the step is not small
    tr.ds = 0.005
    assert not tr.is_kink("turn", 0.5)  # halved with the step: smooth
    assert tr.is_kink("turn", 0.45)     # persists as the step shrinks: a corner
    tr.recent.clear()
    assert [tr.is_kink("deviation", 0.5 ** k) for k in range(4)] == [False] * 3 + [True]


def test_segment_check_shortens_the_step_to_fit():
    widths = []

    def check(x0, lam0, x1, lam1):
        widths.append(lam1 - lam0)
        return 0.02 if lam1 - lam0 > 0.02 else None
    tr = circle_tracer(ds=0.1, segment_check=check)
    assert tr.step() is None and tr.n_rejected == 1 and len(tr.points) == 1
    assert tr.ds == pytest.approx(0.1 * 0.9 * 0.02 / widths[0])
    assert tr.step() is None and len(tr.points) == 2 and tr.z[1] <= 0.02


def test_a_given_first_tangent_gives_the_branch_the_computed_one_gives():
    """The S-curve x^3 - 3x = lam from x = -2.5 over its two folds: with the first
    tangent given (any length, either sign, in physical units) the branch is the one
    traced with the tangent computed (points equal to 1e-12); a tangent of the wrong
    shape is refused."""
    x0 = np.array([-2.5])
    lam0 = x0[0] ** 3 - 3 * x0[0]
    ref = continue_branch(scurve, x0, lam0, 20.0, tol=1e-12, ds=0.05)
    dxdl = 1.0 / (3 * x0[0] ** 2 - 3)                # along the branch: dx = dlam / R_x
    for t in ([dxdl, 1.0], [-3 * dxdl, -3.0]):
        br = continue_branch(scurve, x0, lam0, 20.0, tol=1e-12, ds=0.05, tangent=t)
        assert br.success and len(br.lam) == len(ref.lam) and len(br.fold_lam) == 2
        np.testing.assert_allclose(br.x, ref.x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(br.lam, ref.lam, rtol=1e-12)
    with pytest.raises(ValueError, match="tangent"):
        continue_branch(scurve, x0, lam0, 20.0, tol=1e-12, tangent=[1.0])
