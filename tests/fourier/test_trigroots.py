"""Certified sign changes of trigonometric polynomials."""
import numpy as np
import pytest

from pipeline.fourier.harmonics import basis
from pipeline.fourier.trigroots import sign_changes


@pytest.mark.parametrize("H", [1, 4, 12, 40])
def test_every_sign_change_found_against_dense_sampling(H):
    rng = np.random.default_rng(H)
    P = rng.normal(size=(60, 2 * H + 1))
    roots, slope = sign_changes(P)
    tau = np.linspace(0, 2 * np.pi, 200_001)[:-1]
    x = P @ basis(tau, H).T
    for i in range(len(P)):
        s = np.sign(x[i])
        n_dense = int(np.sum(s != np.roll(s, 1)))
        r = roots[i][~np.isnan(roots[i])]
        assert r.size == n_dense
        assert np.all(np.abs(basis(r, H) @ P[i]) < 1e-12 * np.abs(P[i]).sum())
        # slopes alternate and match the derivative sign
        d = basis(r, H, 1) @ P[i]
        assert np.all(np.sign(d) == slope[i][: r.size])


def test_tangencies_are_not_sign_changes_and_seam_roots_are_kept():
    P = np.zeros((4, 5))
    P[0, :3] = [1.0, 1.0, 0.0]        # 1 + cos: touches 0 at pi
    P[1] = [0.5, 0, 0, 0.5, 0]        # cos^2: touches 0 at pi/2, 3pi/2
    P[2, 2] = -1.0                    # -sin: crosses at 0 and pi (on the seam)
    P[3, 0] = 2.0                     # constant
    roots, slope = sign_changes(P)
    assert np.isnan(roots[0]).all() and np.isnan(roots[1]).all() and np.isnan(roots[3]).all()
    np.testing.assert_allclose(np.sort(roots[2]), [0.0, np.pi], atol=1e-13)  # polish: 1e-13 rad
    # near-double roots 2e-6 apart are still two crossings
    P2 = np.array([[-np.cos(1e-6), 1.0, 0.0]])  # cos(t) - cos(1e-6): roots at +-1e-6
    r2, s2 = sign_changes(P2)
    # conditioning: coefficient rounding 1e-16 over slope 1e-6 gives 1e-10 in tau
    np.testing.assert_allclose(np.sort(np.mod(r2[0] + 1, 2 * np.pi) - 1), [-1e-6, 1e-6], atol=3e-10)
