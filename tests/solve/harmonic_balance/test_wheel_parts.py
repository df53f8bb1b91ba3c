"""A full wheel of independent blades (rigid disk) solved part by part: the sparse
condensed Jacobian filled on its fixed pattern (`parts.jacobian_pattern`) and the
natural frequencies near h Omega from the Wittrick-Williams count and a shift-invert
window (`part_spectrum`), each against the dense computation of the same System."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from pipeline.model.system import dense
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response import resonance
from pipeline.study.files.documents import load_study

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def wheel():
    """The quick 24-beam-blade mistuned wheel at a slipping state: its problem
    (H = 3, 1008 condensed unknowns: sparse) and a contact motion of 1e-5 m."""
    st = load_study(ROOT / "studies" / "shrouded_disk_mistuned.toml", quick=True)
    s = st.system({"preload": 3.0, "mistuning_seed": 1})
    prob = hbm.setup(s, 3)
    rng = np.random.default_rng(3)
    x = 1e-5 * rng.standard_normal(prob.size)
    return prob, x


def test_pattern_jacobian_equals_the_dense_one(wheel):
    """R, dR/dx and dR/dOm of the pattern-filled sparse Jacobian equal the dense
    assembly of the same condensed blocks to 1e-12 (every element slips at this x)."""
    prob, x = wheel
    assert prob.pattern is not None and prob.parts is not None
    R, J, dOm = hbm.residual(prob, x, 1700.0)
    Rd, Jd, dOmd = hbm.residual(replace(prob, pattern=None), x, 1700.0)
    assert sp.issparse(J) and not sp.issparse(Jd)
    assert J.nnz < 0.2 * J.shape[0] ** 2
    np.testing.assert_allclose(R, Rd, rtol=0, atol=1e-12 * np.abs(Rd).max())
    np.testing.assert_allclose(J.toarray(), Jd, rtol=0, atol=1e-12 * np.abs(Jd).max())
    np.testing.assert_allclose(dOm, dOmd, rtol=0, atol=1e-12 * np.abs(dOmd).max())
    _, _, f = hbm.contact_terms(prob, x.reshape(prob.c.size, prob.nh), jacobian=False)
    assert f.regimes["transitions"] == f.Fu.shape[0], f.regimes   # every element slips
    R0, J0, _ = hbm.residual(prob, x, 1700.0, jacobian=False)   # the pattern, no Jacobian
    assert J0 is None and np.array_equal(R0, R)
    with pytest.raises(ValueError, match="motion"):   # on the pattern dS~ needs the motion
        hbm.linear_part(prob, 1700.0, derivatives=True, pattern=prob.pattern)


def test_part_spectrum_equals_the_dense_eigen_solve(wheel):
    """At a slipping state: the Wittrick-Williams count equals the dense count of the
    linearised wheel at 15 frequencies across its first family, and the window's
    frequencies and modal damping ratios phi^H C phi / (2 w) equal the dense
    eigen-solve's to 1e-9."""
    prob, x = wheel
    s = prob.system
    rc = resonance.prepare(prob)
    assert rc.parts is not None and rc.K is None      # no dense matrix of the wheel
    Om = 1700.0
    (spec,) = resonance.natural_frequencies(rc, prob, x, s.contact, Om)
    Z = resonance.contact_stiffness(prob, x.reshape(prob.c.size, prob.nh), s.contact, 1)
    A = dense(s.K).astype(complex)
    A[np.ix_(prob.c, prob.c)] += 0.5 * (Z + Z.conj().T)
    import scipy.linalg as sla
    lam, phi = sla.eigh(A, dense(s.M))
    w = np.sign(lam) * np.sqrt(np.abs(lam))
    zeta = np.real(np.einsum("ik,ik->k", phi.conj(), dense(s.C) @ phi)) / (2 * w)
    for f in np.linspace(0.5, 1.5, 15) * Om:
        assert spec.count(f) == int(np.sum(w < f))
    k0 = spec.count(Om)
    assert 0 < k0 < w.size
    for k in range(max(k0 - 6, 0), min(k0 + 6, w.size)):
        wk, zk = spec.mode(k)
        assert wk == pytest.approx(w[k], rel=1e-9)
        assert zk == pytest.approx(zeta[k], rel=1e-6)


@pytest.mark.parametrize("kind", ["real", "complex"])
def test_inertia_count_equals_the_eigenvalue_count(kind):
    """The count of negative eigenvalues from the Bunch-Kaufman factor (1x1 and 2x2
    pivot blocks) equals numpy's Hermitian eigenvalue count on 600 random matrices,
    among them near-zero diagonals that force 2x2 pivots and shifted ones."""
    import scipy.linalg as sla

    from pipeline.solve.harmonic_balance.part_spectrum import negative_eigenvalues
    rng = np.random.default_rng(5)
    blocks = 0
    for t in range(600):
        n = int(rng.integers(1, 40))
        A = rng.standard_normal((n, n))
        if kind == "complex":
            A = A + 1j * rng.standard_normal((n, n))
        A = A + A.conj().T
        if t % 2:
            A[np.arange(n), np.arange(n)] = 1e-3 * rng.standard_normal(n)
        A -= rng.uniform(-3, 3) * np.eye(n)
        assert negative_eigenvalues(A) == int(np.sum(np.linalg.eigvalsh(A) < 0))
        trf = sla.get_lapack_funcs("hetrf" if kind == "complex" else "sytrf", (A,))
        blocks += int(np.sum(trf(A, lower=1)[1] < 0)) // 2
    assert blocks > 1000     # 2x2 pivot blocks counted
    # 2x2 blocks at the ends of the floating-point range: scaled, no inf - inf, no 0 - 0
    one = np.array([[-1e-3, 1.0], [1.0, -1e-3]]) * (1 if kind == "real" else 1 + 0j)
    for scale in (1e160, 1e-170):
        assert negative_eigenvalues(scale * one) == 1
