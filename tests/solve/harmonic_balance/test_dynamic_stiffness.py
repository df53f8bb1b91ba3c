"""The linear-dynamics kernel (`dynamic_stiffness`): added linear terms.

A mass-proportional damping added as one term c' (i h Omega) M, Term(c' M, 1, True),
must give the problem whose damping matrix is C + c' M: residual, Jacobian, dR/dOmega,
the recovered DOFs, the full residual and Hill's operators, for every strategy
(dense blocks, dense, sparse, a wheel's parts).  Terms of other powers are checked
against central differences in Omega and in a parameter of their matrix."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from pipeline.contact import YangMenq
from pipeline.model.system import System
from pipeline.solve.harmonic_balance import full_operators
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.harmonic_balance.dynamic_stiffness import (Term, dense_stack, prepare, term_stiffness)
from pipeline.study.files.documents import load_study

ROOT = Path(__file__).resolve().parents[3]
CP = 0.37   # c' [1/s]


def chain4():
    """4-DOF chain with DOF 0 condensed, forcing on several DOFs and harmonics."""
    rng = np.random.default_rng(0)
    A = rng.normal(size=(4, 4))
    K = A @ A.T + 4 * np.eye(4)
    M = np.eye(4) + 0.1 * np.diag(rng.random(4))
    return System(M=M, C=0.02 * K, K=K, Bt=np.array([[0, 1.0, -1.0, 0]]),
                  Bn=np.array([[0, 0.3, 0, 0.9]]), contact=YangMenq(2.0, 1.5, 0.3, 0.2),
                  forcing=np.array([[0, 1.0, 0], [0, 0.5j, 0.2], [0, 0, 0], [0.1, 0.3, 0]]))


def sparse(s):
    return replace(s, M=sp.csr_matrix(s.M), C=sp.csr_matrix(s.C), K=sp.csr_matrix(s.K))


def close(a, b, rel=1e-12):
    a, b = (x.toarray() if sp.issparse(x) else np.asarray(x) for x in (a, b))
    assert a.shape == b.shape
    assert np.abs(a - b).max() <= rel * max(np.abs(b).max(), 1e-300)


def pair(s, H, strategy=None):
    """(problem with C + c' M, the same with C and the term c' (i h Om) M)."""
    with_c = hbm.setup(replace(s, C=s.C + CP * s.M), H)
    with_t = hbm.setup(s, H, extra=(Term(CP * s.M, 1, True),))
    if strategy is not None:
        with_c, with_t = (replace(p, linear=prepare(p.system, H, p.c, p.o, p.P, p.linear.extra,
                                                    strategy)) for p in (with_c, with_t))
    assert with_c.linear.strategy == with_t.linear.strategy
    return with_c, with_t


@pytest.mark.parametrize("case", ["blocks", "dense", "sparse"])
def test_mass_proportional_term_equals_added_damping(case):
    """chain4: every output of the residual, the recovery and the full operators."""
    s = chain4() if case != "sparse" else sparse(chain4())
    a, b = pair(s, 3, "dense" if case == "dense" else None)
    assert a.linear.strategy == case
    rng = np.random.default_rng(1)
    x = 0.3 * rng.standard_normal(a.size)
    for Om in (0.7, 1.1, 2.9):
        for u, v in zip(hbm.residual(b, x, Om), hbm.residual(a, x, Om)):
            close(u, v)
        Q = hbm.recover(b, x.reshape(a.c.size, a.nh), Om)
        close(Q, hbm.recover(a, x.reshape(a.c.size, a.nh), Om))
        close(hbm.full_residual(b, Q, Om), hbm.full_residual(a, Q, Om))
        close(full_operators.full_jacobian(b, Q, Om), full_operators.full_jacobian(a, Q, Om))
        (_, Jb, Mb, Cb), = full_operators.wave_jacobians(b, Q, Om)
        (_, Ja, Ma, Ca), = full_operators.wave_jacobians(a, Q, Om)
        close(Jb, Ja), close(Mb, Ma), close(Cb, Ca)


def test_mass_proportional_term_on_a_wheel_of_parts():
    """The quick mistuned 24-blade wheel (sparse, condensed blade by blade)."""
    st = load_study(ROOT / "studies" / "shrouded_disk_mistuned.toml", quick=True)
    a, b = pair(st.system({"preload": 3.0, "mistuning_seed": 1}), 3)
    assert a.linear.strategy == "parts" and b.pattern is not None
    x = 1e-5 * np.random.default_rng(3).standard_normal(a.size)
    for u, v in zip(hbm.residual(b, x, 1700.0), hbm.residual(a, x, 1700.0)):
        close(u, v, 1e-11)
    close(hbm.recover(b, x.reshape(a.c.size, a.nh), 1700.0),
          hbm.recover(a, x.reshape(a.c.size, a.nh), 1700.0), 1e-11)


@pytest.mark.parametrize("case", ["blocks", "dense", "sparse"])
def test_term_frequency_derivative_by_differences(case):
    """A gyroscopic-like i (h Om)^3 G, a real (h Om)^2 A and an EPMC-like damping
    i (h Om) Om B: dR/dOmega against central differences of the residual in Omega
    (1e-6); the full residual of the recovered motion vanishes off the contact DOFs
    and equals the condensed one on them; the full Jacobian against differences."""
    s = chain4() if case != "sparse" else sparse(chain4())
    G = 0.01 * np.array([[0, 1, 0, 0], [-1, 0, 2, 0], [0, -2, 0, 1], [0, 0, -1, 0.0]])
    A = 0.05 * np.diag([1.0, 2.0, 0.5, 1.0])
    terms = (Term(G, 3, True), Term(A, 2), Term(-0.02 * s.M, 1, True, 1))
    if case == "sparse":
        terms = tuple(Term(sp.csr_matrix(t.matrix), t.power, t.imag, t.omega_power)
                      for t in terms)
    p = hbm.setup(s, 3, extra=terms)
    if case == "dense":
        p = replace(p, linear=prepare(p.system, 3, p.c, p.o, p.P, terms, "dense"))
    assert p.linear.strategy == case
    x = 0.3 * np.random.default_rng(2).standard_normal(p.size)
    Om, d = 1.3, 1e-6
    _, _, dR = hbm.residual(p, x, Om)
    ref = (hbm.residual(p, x, Om + d, jacobian=False)[0]
           - hbm.residual(p, x, Om - d, jacobian=False)[0]) / (2 * d)
    assert np.abs(dR - ref).max() <= 1e-6 * np.abs(ref).max()
    # the real layout of the terms (full residual, full Jacobian): the recovered
    # motion leaves no residual on the eliminated DOFs and the condensed one on c
    R = hbm.residual(p, x, Om, jacobian=False)[0].reshape(p.c.size, p.nh)
    Q = hbm.recover(p, x.reshape(p.c.size, p.nh), Om)
    Rf = hbm.full_residual(p, Q, Om)
    assert np.abs(Rf[p.o]).max() <= 1e-12 * np.abs(Rf[p.c]).max()
    assert np.abs(Rf[p.c] - R).max() <= 1e-12 * np.abs(R).max()
    dQ = np.random.default_rng(5).standard_normal(Q.shape)
    ref = (hbm.full_residual(p, Q + d * dQ, Om) - hbm.full_residual(p, Q - d * dQ, Om)) / (2 * d)
    J = full_operators.full_jacobian(p, Q, Om) @ dQ.ravel()
    assert np.abs(J - ref.ravel()).max() <= 1e-6 * np.abs(ref).max()


@pytest.mark.parametrize("case", ["blocks", "sparse"])
def test_epmc_damping_equals_the_damping_at_that_frequency(case):
    """The extended periodic motion concept's -2 zeta Omega M q', Term(-2 zeta M, 1, True,
    1): at each Omega the residual, Jacobian and recovery of the problem with damping
    C - 2 zeta Omega M; Hill's M and C the same."""
    s = chain4() if case != "sparse" else sparse(chain4())
    zeta = 0.05
    b = hbm.setup(s, 3, extra=(Term(-2 * zeta * s.M, 1, True, 1),))
    x = 0.3 * np.random.default_rng(6).standard_normal(b.size)
    for Om in (0.7, 1.1):
        a = hbm.setup(replace(s, C=s.C - 2 * zeta * Om * s.M), 3)
        assert a.linear.strategy == b.linear.strategy == case
        for u, v in list(zip(hbm.residual(b, x, Om), hbm.residual(a, x, Om)))[:2]:
            close(u, v)
        Q = hbm.recover(b, x.reshape(a.c.size, a.nh), Om)
        close(Q, hbm.recover(a, x.reshape(a.c.size, a.nh), Om))
        (_, Jb, Mb, Cb), = full_operators.wave_jacobians(b, Q, Om)
        (_, Ja, Ma, Ca), = full_operators.wave_jacobians(a, Q, Om)
        close(Jb, Ja), close(Mb, Ma), close(Cb, Ca)


def test_parameter_derivative_hook_and_power_check():
    """dS_h/dp of terms whose matrix depends on a parameter p (A(p) = p A1 + p^2 A2, and
    an EPMC-like p Omega A1) is `term_stiffness` of the terms (dA/dp, ...), against
    central differences of S_h; a term of power 0 (a stiffness: K) is refused."""
    s, H, Om = chain4(), 3, 1.3
    A1, A2 = np.diag([1.0, 0.0, 2.0, 0.5]), np.full((4, 4), 0.1)
    c, o = np.array([1, 2, 3]), np.array([0])

    def S(p):
        terms = (Term(p * A1, 1, True), Term(p * p * A2, 2), Term(p * A1, 1, True, 1))
        return dense_stack(prepare(s, H, c, o, s.forcing_coefficients(H), terms), Om)

    p, d = 0.8, 1e-6
    hook = term_stiffness((Term(A1, 1, True), Term(2 * p * A2, 2), Term(A1, 1, True, 1)), H, Om)
    ref = (S(p + d) - S(p - d)) / (2 * d)
    assert np.abs(hook - ref).max() <= 1e-7 * np.abs(ref).max()
    with pytest.raises(ValueError, match="power"):
        Term(A1, 0)
