"""Compiled kernels on one trigonometric polynomial: the certified sign changes
against `trigroots`, the segment integrals and Gram matrices against numpy."""
import numpy as np
import pytest

from pipeline.contact import YangMenq, forces
from pipeline.contact.exact_reference import gram, segment_integrals
from pipeline.fourier.harmonics import basis
from pipeline.fourier.trigkernel import (add_gram, add_segment_integrals, gram_apply,
                                         root_tables, sign_changes_one)
from pipeline.fourier.trigroots import sign_changes


def compiled_sign_changes(P):
    H = (P.shape[1] - 1) // 2
    roots, slopes = np.full((len(P), 4 * H + 4), np.nan), np.zeros((len(P), 4 * H + 4), int)
    counts = [sign_changes_one(p, H, *root_tables(H), roots[i], slopes[i])
              for i, p in enumerate(P)]
    return roots, slopes, np.array(counts)


@pytest.mark.parametrize("H", [1, 4, 12, 40])
def test_sign_changes_as_trigroots(H):
    rng = np.random.default_rng(H)
    P = rng.normal(size=(60, 2 * H + 1)) * np.repeat(0.7 ** np.arange(H + 1), 2)[1:]
    ref, ref_slope = sign_changes(P)
    roots, slopes, counts = compiled_sign_changes(P)
    for i in range(len(P)):
        r = ref[i][~np.isnan(ref[i])]
        assert counts[i] == r.size
        np.testing.assert_allclose(roots[i, :r.size], r, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(slopes[i, :r.size], ref_slope[i, :r.size])


def test_tangencies_constants_and_seam():
    P = np.zeros((5, 5))
    P[0, :3] = [1.0, 1.0, 0.0]        # 1 + cos: touches 0 at pi, no sign change
    P[1] = [0.5, 0, 0, 0.5, 0]        # cos^2: touches 0 twice
    P[2] = [0.0, 0.0, 1.0, 0, 0]      # sin: roots at 0 and pi exactly
    P[3] = [2.0, 0, 0, 0, 0]          # constant
    P[4] = [0.0, 1e-300, 0, 0, 0]     # at the underflow limit: still two roots
    roots, slopes, counts = compiled_sign_changes(P)
    assert list(counts) == [0, 0, 2, 0, 2]
    seam = np.abs(np.mod(roots[2, :2] + 1.0, 2 * np.pi) - 1.0)  # distance to 0 on the circle
    assert seam.min() < 1e-14 and np.abs(roots[2, :2] - np.pi).min() < 1e-14



def test_subnormal_coefficients_have_the_roots_of_their_normal_scaling():
    """Coefficients near the underflow (or overflow) limit have the roots of the
    same polynomial scaled by a power of two (exact while no coefficient underflows),
    and are found as quickly.  Unscaled, -5e-324 +
    5e-324 cos evaluates to exactly 0 on a third of the period, where no certificate
    holds at any width: the search did not end.  The contact element that meets it
    (a touching contact of subnormal amplitude) now returns its zero forces."""
    P = np.array([[-1.0, 1.0, 0.0, 0.0, 0.5], [0.3, -1.0, 0.25, 0.0, 0.0]])
    ref_roots, ref_slopes, ref_counts = compiled_sign_changes(P)
    for k in (-1020, -600, 600, 1020):
        roots, slopes, counts = compiled_sign_changes(np.ldexp(P, k))
        np.testing.assert_array_equal(counts, ref_counts)
        np.testing.assert_array_equal(roots, ref_roots)
        np.testing.assert_array_equal(slopes, ref_slopes)
    U, V = np.zeros((1, 7)), np.zeros((1, 7))
    U[0, 1], V[0, 1] = 0.5, 5e-324
    f = forces(U, V, YangMenq(ku=0.2, kv=1.0, mu=1.0, n0=-5e-324))
    assert not np.any(f.Fu) and not np.any(f.Fv)

@pytest.mark.parametrize("H", [1, 7, 21])
def test_segment_integrals_and_gram_as_numpy(H):
    rng = np.random.default_rng(H)
    a = rng.uniform(0, 2 * np.pi, 20)
    b = a + rng.uniform(0, 2 * np.pi, 20) * rng.choice([1.0, 1e-7], 20)
    X = np.zeros((20, 2 * (2 * H + 1)))
    for i in range(20):
        add_segment_integrals(a[i], b[i], H, 1.0, X[i])
    np.testing.assert_allclose(X, segment_integrals(a, b, H), rtol=1e-12, atol=1e-15)
    P = rng.normal(size=2 * H + 1)
    for i in range(20):
        G = np.zeros((2 * H + 1, 2 * H + 1))
        add_gram(X[i], H, 1.0, G)
        np.testing.assert_allclose(G, gram(X[i], H), rtol=0, atol=1e-15)
        out, J = np.zeros(2 * H + 1), np.zeros_like(G)
        gram_apply(X[i], H, P, 2.0, out, 3.0, J, True)
        np.testing.assert_allclose(out, 2.0 * G @ P, rtol=0, atol=1e-14)
        np.testing.assert_allclose(J, 3.0 * G, rtol=0, atol=1e-15)
    # Eq. 11 by quadrature for one segment
    t = np.linspace(a[0], b[0], 20001)
    S = basis(t, 2 * H)
    Xq = np.trapezoid(S, t, axis=0) / np.pi
    np.testing.assert_allclose(X[0, 0], Xq[0], rtol=1e-12)
    np.testing.assert_allclose(X[0, 1:2 * H + 1], Xq[1::2], atol=1e-6)
    np.testing.assert_allclose(X[0, 2 * H + 2:], Xq[2::2], atol=1e-6)
