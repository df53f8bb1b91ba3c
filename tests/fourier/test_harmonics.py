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


def critical_extremes(X):
    """max and min of x(t) = X0 + sum Xc_j cos jt + Xs_j sin jt from every root of
    x'(t): with z = exp(i t), z^H x'(t) is a polynomial of degree 2H in z whose roots on
    the unit circle are the critical points (numpy's companion-matrix roots)."""
    H = (X.size - 1) // 2
    a, b = X[1::2], X[2::2]
    # x'(t) = sum_j j (b_j cos jt - a_j sin jt) = sum_j (j/2) [(b_j + i a_j) z^j + (b_j - i a_j) z^-j]
    c = np.zeros(2 * H + 1, complex)       # coefficient of z^(k - H), k = 0..2H
    for j in range(1, H + 1):
        c[H + j] += 0.5 * j * (b[j - 1] + 1j * a[j - 1])
        c[H - j] += 0.5 * j * (b[j - 1] - 1j * a[j - 1])
    z = np.roots(c[::-1])
    t = np.angle(z[np.abs(np.abs(z) - 1) < 1e-6])
    x = X[0] + sum(a[j - 1] * np.cos(j * t) + b[j - 1] * np.sin(j * t) for j in range(1, H + 1))
    return x.max(), x.min()


def test_half_peak_to_peak_equals_the_extrema_of_every_critical_point():
    """Random signals (H = 3, 5): the compiled search (samples + Newton) against the
    roots of the derivative's polynomial, to 1e-12 of the amplitude."""
    rng = np.random.default_rng(7)
    for H in (3, 5):
        X = rng.normal(size=(300, 2 * H + 1)) * np.r_[1.0, np.repeat(0.5 ** np.arange(H), 2)]
        amp = hm.amplitude_half_peak_to_peak(X)
        ref = np.array([0.5 * np.subtract(*critical_extremes(x)) for x in X])
        assert np.abs(amp - ref).max() <= 1e-12 * ref.max()
        assert hm.amplitude_half_peak_to_peak(X.reshape(3, 100, -1)).shape == (3, 100)


def test_half_peak_to_peak_amplitude_is_exact():
    X = np.zeros((2, 7))
    X[0, 0], X[0, 1], X[0, 4] = 5.0, 1.0, 0.5          # cos t + 0.5 sin 2t: +-1.299038...
    X[1, 2] = 2.0
    amp = hm.amplitude_half_peak_to_peak(X)
    assert amp[0] == pytest.approx(0.75 * np.sqrt(3), rel=1e-14)
    assert amp[1] == pytest.approx(2.0, rel=1e-14)
