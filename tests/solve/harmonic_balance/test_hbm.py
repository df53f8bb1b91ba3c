"""Harmonic balance residual: Jacobians, condensation, linear limits."""
import pickle
from dataclasses import replace

import numpy as np
import pytest

from pipeline.solve.harmonic_balance import full_operators
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.continuation.newton import newton
from pipeline.contact import YangMenq
from pipeline.model.system import System

from helpers import fd


def chain4(kv=1.5, n0=0.2, mu=0.3):
    """4-DOF random chain; element between DOFs 1 and 2 (+ normal on 1 and 3), so
    DOF 0 is condensed; forcing on several DOFs and harmonics incl. a static load."""
    rng = np.random.default_rng(0)
    A = rng.normal(size=(4, 4))
    K = A @ A.T + 4 * np.eye(4)
    M = np.eye(4) + 0.1 * np.diag(rng.random(4))
    return System(M=M, C=0.02 * K, K=K, Bt=np.array([[0, 1.0, -1.0, 0]]),
                  Bn=np.array([[0, 0.3, 0, 0.9]]), contact=YangMenq(2.0, kv, mu, n0),
                  forcing=np.array([[0, 1.0, 0], [0, 0.5j, 0.2], [0, 0, 0], [0.1, 0.3, 0]]))


@pytest.mark.parametrize("H", [1, 3, 6])
@pytest.mark.parametrize("method", ["exact", "aft"])
def test_condensed_jacobian_and_frequency_derivative(H, method):
    s = chain4()
    prob = hbm.setup(s, H, method, n_samples=128)
    assert list(prob.c) == [1, 2, 3] and list(prob.o) == [0]
    x = np.random.default_rng(H).normal(size=prob.size) * 0.3
    R, J, dOm = hbm.residual(prob, x, 1.3)
    Jfd = fd(lambda y: hbm.residual(prob, y, 1.3, jacobian=False)[0], x)
    dfd = fd(lambda o: hbm.residual(prob, x, o[0], jacobian=False)[0], np.array([1.3]))[:, 0]
    assert np.max(np.abs(Jfd - J)) < 1e-6 * np.max(np.abs(J))
    assert np.max(np.abs(dfd - dOm)) < 1e-6 * np.max(np.abs(dOm))


@pytest.mark.parametrize("H", [1, 4])
def test_condensed_solution_satisfies_full_residual_and_full_jacobian(H):
    s = chain4()
    prob = hbm.setup(s, H)
    tol = 1e-10 * hbm.force_scale(prob)
    nr = newton(lambda x: hbm.residual(prob, x, 1.3)[:2], np.zeros(prob.size), tol)
    assert nr.success
    Q = hbm.recover(prob, nr.x.reshape(prob.c.size, -1), 1.3)
    assert np.linalg.norm(hbm.full_residual(prob, Q, 1.3)) < 2 * tol
    Jf = full_operators.full_jacobian(prob, Q, 1.3)
    Jfd = fd(lambda q: hbm.full_residual(prob, q.reshape(4, -1), 1.3).ravel(), Q.ravel())
    assert np.max(np.abs(Jfd - Jf)) < 1e-6 * np.max(np.abs(Jf))


def test_open_contact_gives_linear_frf_on_every_dof():
    s = chain4(n0=-50.0)  # separated throughout: linear system
    prob = hbm.setup(s, 3)
    Om = 0.9
    nr = newton(lambda x: hbm.residual(prob, x, Om)[:2], np.zeros(prob.size), 1e-12)
    Q = hbm.recover(prob, nr.x.reshape(prob.c.size, -1), Om)
    K, M, C = s.K, s.M, s.C
    for h in (1, 2):
        Fh = s.forcing[:, h]
        X = np.linalg.solve(K - (h * Om) ** 2 * M + 1j * h * Om * C, Fh)
        np.testing.assert_allclose(Q[:, 2 * h - 1] - 1j * Q[:, 2 * h], X, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(Q[:, 0], np.linalg.solve(K, s.forcing[:, 0].real), rtol=1e-10)


def test_setup_rejects_bad_arguments():
    with pytest.raises(ValueError, match="H"):
        hbm.setup(chain4(), 0)
    with pytest.raises(ValueError, match="method"):
        hbm.setup(chain4(), 2, method="fem")


def test_sparse_matrices_give_the_dense_residual_and_jacobian():
    import scipy.sparse as sp
    from dataclasses import replace
    s = chain4()
    ssp = replace(s, M=sp.csr_matrix(s.M), C=sp.csr_matrix(s.C), K=sp.csr_matrix(s.K))
    x = np.random.default_rng(3).normal(size=hbm.setup(s, 3).size) * 0.3
    for a, b in zip(hbm.residual(hbm.setup(s, 3), x, 1.1), hbm.residual(hbm.setup(ssp, 3), x, 1.1)):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)
    Qd = hbm.recover(hbm.setup(s, 3), x.reshape(3, -1), 1.1)
    Qs = hbm.recover(hbm.setup(ssp, 3), x.reshape(3, -1), 1.1)
    np.testing.assert_allclose(Qs, Qd, rtol=1e-12, atol=1e-14)


def test_contact_terms_are_kept_by_their_exact_input():
    """A problem keeps the contact terms it evaluated: asked again at the same
    coefficients and elements, it returns them (read-only), bit for bit what a fresh
    problem evaluates; a Jacobian asked after a force-only call, other coefficients
    (by one ulp) or other elements are evaluated."""
    s = chain4()
    prob = hbm.setup(s, 3)
    Qc = np.random.default_rng(5).normal(size=(prob.c.size, prob.nh)) * 0.3
    G0, J0, _ = hbm.contact_terms(prob, Qc, jacobian=False)
    assert J0 is None
    G1, J1, _ = hbm.contact_terms(prob, Qc)            # the Jacobian was not kept: evaluated
    G2, J2, _ = hbm.contact_terms(hbm.setup(s, 3), Qc)
    assert np.array_equal(G0, G2) and np.array_equal(G1, G2) and np.array_equal(J1, J2)
    assert hbm.contact_terms(prob, Qc.copy())[0] is G1   # kept: the same array
    with pytest.raises(ValueError):
        G1[0, 0] = 1.0
    Qd = Qc.copy()
    Qd[0, 1] = np.nextafter(Qd[0, 1], np.inf)
    Gd, Jd, _ = hbm.contact_terms(prob, Qd)
    Ge, Je, _ = hbm.contact_terms(hbm.setup(s, 3), Qd)
    assert np.array_equal(Gd, Ge) and np.array_equal(Jd, Je)
    other = YangMenq(2.0, 1.5, 0.3, 0.05)
    Go, _, _ = hbm.contact_terms(prob, Qc, other)
    Gf, _, _ = hbm.contact_terms(hbm.setup(replace(s, contact=other), 3), Qc)
    assert np.array_equal(Go, Gf) and not np.array_equal(Go, G1)


def test_kept_contact_terms_stay_within_their_bytes():
    memo = hbm.ContactMemo(max_bytes=3000)
    G = np.zeros((2, 7))
    for k in range(20):
        memo.put(None, np.full((2, 7), float(k)), (G.copy(), None, None))
    assert memo.bytes <= 3000 and 0 < len(memo.entries) < 20
    assert memo.get(None, np.full((2, 7), 19.0), False) is not None    # the newest kept
    assert memo.get(None, np.full((2, 7), 0.0), False) is None         # the oldest dropped
    assert memo.get(None, np.full((2, 7), 19.0), True) is None         # no Jacobian kept
    assert pickle.loads(pickle.dumps(memo)).entries == {}              # not sent along
