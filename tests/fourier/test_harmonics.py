"""Real Fourier layout of paper Eq. 2-3."""
import numpy as np
import pytest

from pipeline.fourier import harmonics as hm


@pytest.mark.parametrize("order", [1, 2, 3, 4])
def test_basis_derivatives_match_coefficient_derivatives(order):
    rng = np.random.default_rng(order)
    H = 6
    X = rng.normal(size=2 * H + 1)
    tau = rng.uniform(0, 7, 50)
    np.testing.assert_allclose(hm.basis(tau, H, order) @ X, hm.basis(tau, H) @ hm.derivative(X, order),
                               atol=1e-12 * H**order)
    np.testing.assert_allclose(np.linalg.matrix_power(hm.derivative_matrix(H), order) @ X,
                               hm.derivative(X, order), atol=1e-12 * H**order)


def test_layout_is_cos_then_sin_per_harmonic():
    tau = np.array([0.3])
    s = hm.basis(tau, 2)[0]
    np.testing.assert_allclose(s, [1, np.cos(0.3), np.sin(0.3), np.cos(0.6), np.sin(0.6)], atol=1e-15)


def test_dft_round_trip_and_minimum_samples():
    H = 5
    X = np.arange(2 * H + 1, dtype=float)
    tau, S, W = hm.time_grid(H, 2 * H + 1)
    np.testing.assert_allclose(W @ (S @ X), X, atol=1e-12)
    with pytest.raises(ValueError, match="n_samples"):
        hm.time_grid(H, 2 * H)


def test_half_peak_to_peak_amplitude_is_exact():
    X = np.zeros((2, 7))
    X[0, 0], X[0, 1], X[0, 4] = 5.0, 1.0, 0.5          # cos t + 0.5 sin 2t: +-1.299038...
    X[1, 2] = 2.0
    amp = hm.amplitude_half_peak_to_peak(X)
    assert amp[0] == pytest.approx(0.75 * np.sqrt(3), rel=1e-14)
    assert amp[1] == pytest.approx(2.0, rel=1e-14)
