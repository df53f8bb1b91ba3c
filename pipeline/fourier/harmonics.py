"""Real Fourier layout shared by every layer (paper Eq. 2-3).

A periodic signal x(tau), tau = Omega*t in [0, 2*pi), with H harmonics is stored as
the 2H+1 real coefficients

    X = [X0, Xc1, Xs1, Xc2, Xs2, ..., XcH, XsH]
    x(tau) = X0 + sum_j Xc_j cos(j tau) + Xs_j sin(j tau)

so index 2j-1 holds cos(j tau) and 2j holds sin(j tau), as in the paper.  The DC
term is a real unknown (a complex h = 0 unknown would leave a free direction).
Arrays of signals put the coefficient index last: shape (..., 2H+1).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit


def n_coeffs(H: int) -> int:
    """Number of real coefficients, 2H+1."""
    return 2 * H + 1


def harmonics_of(n: int) -> int:
    """H from a coefficient count 2H+1 (ValueError if n is even or < 1)."""
    if n < 1 or n % 2 == 0:
        raise ValueError(f"coefficient count must be 2H+1 (odd, >= 1), got {n}")
    return (n - 1) // 2


def basis(tau, H: int, order: int = 0) -> np.ndarray:
    """Basis s(tau) or its `order`-th tau-derivative, shape tau.shape + (2H+1,).

    x(tau) = basis(tau, H) @ X and d^k x/dtau^k = basis(tau, H, k) @ X.
    """
    tau = np.asarray(tau, dtype=float)
    out = np.empty(tau.shape + (2 * H + 1,))
    out[..., 0] = 1.0 if order == 0 else 0.0
    if H == 0:
        return out
    j = np.arange(1, H + 1, dtype=float)
    if tau.size * H > 20000:  # large tables: powers of exp(i tau), 2 trig calls not 2H
        z = np.cumprod(np.broadcast_to(np.exp(1j * tau)[..., None], tau.shape + (H,)), axis=-1)
        c, s = z.real, z.imag
    else:
        arg = tau[..., None] * j
        c, s = np.cos(arg), np.sin(arg)
    # d^k/dtau^k [cos, sin](j tau) = j^k [cos, sin](j tau + k pi/2)
    rot = order % 4
    if rot == 1:
        c, s = -s, c
    elif rot == 2:
        c, s = -c, -s
    elif rot == 3:
        c, s = s, -c
    if order:
        c, s = c * j**order, s * j**order
    out[..., 1::2] = c
    out[..., 2::2] = s
    return out


@lru_cache(maxsize=64)
def derivative_matrix(H: int) -> np.ndarray:
    """D with d/dtau x <-> D @ X (block diag of [[0, j], [-j, 0]]); read-only, cached."""
    D = np.zeros((2 * H + 1, 2 * H + 1))
    for j in range(1, H + 1):
        D[2 * j - 1, 2 * j] = j
        D[2 * j, 2 * j - 1] = -j
    D.setflags(write=False)
    return D


def derivative(X: np.ndarray, order: int = 1) -> np.ndarray:
    """Coefficients of d^order x / dtau^order, for X of shape (..., 2H+1)."""
    X = np.asarray(X, dtype=float)
    H = harmonics_of(X.shape[-1])
    j = np.arange(1, H + 1, dtype=float)
    c, s = X[..., 1::2], X[..., 2::2]
    for _ in range(order):
        c, s = j * s, -j * c
    out = np.zeros_like(X)
    out[..., 1::2] = c
    out[..., 2::2] = s
    return out


def shift_tables(theta, H: int):
    """(c, s), each theta.shape + (2H+1,): cos(h theta), sin(h theta) at the layout
    positions of harmonic h (c = 1, s = 0 at the DC entry), for `turn`."""
    h = np.repeat(np.arange(H + 1), 2)[1:]                        # 0, 1, 1, 2, 2, ...
    a = np.asarray(theta, dtype=float)[..., None] * h
    return np.cos(a), np.sin(a)


def turn(X: np.ndarray, c, s, axis: int = -1) -> np.ndarray:
    """T X along `axis`, T = c I + s J with (J X)c_h = Xs_h and (J X)s_h = -Xc_h;
    c, s from `shift_tables`, broadcastable against X.  With c, s of theta this is
    the time shift x(tau) -> x(tau + theta) (complex amplitudes Xc_h - i Xs_h times
    exp(i h theta)); T is orthogonal and T(theta)^T = T(-theta): pass -s."""
    X = np.moveaxis(np.asarray(X, dtype=float), axis, -1)
    c, s = np.moveaxis(np.asarray(c), axis, -1), np.moveaxis(np.asarray(s), axis, -1)
    out = X * c
    out[..., 1::2] += s[..., 1::2] * X[..., 2::2]
    out[..., 2::2] -= s[..., 2::2] * X[..., 1::2]
    return np.moveaxis(out, -1, axis)


def shift(X: np.ndarray, theta) -> np.ndarray:
    """Coefficients of x(tau + theta) for X (..., 2H+1), theta broadcast over (...)."""
    X = np.asarray(X, dtype=float)
    return turn(X, *shift_tables(theta, harmonics_of(X.shape[-1])))


def evaluate(X: np.ndarray, tau, order: int = 0) -> np.ndarray:
    """x(tau) for X of shape (E, 2H+1) and tau of shape (E, K) or (K,): shape (E, K)."""
    X = np.asarray(X, dtype=float)
    H = harmonics_of(X.shape[-1])
    S = basis(tau, H, order)
    if S.ndim == 2:
        return X @ S.T
    return np.einsum("ekc,ec->ek", S, X)


@lru_cache(maxsize=64)
def _dft(H: int, N: int):
    tau = 2 * np.pi * np.arange(N) / N
    S = basis(tau, H)  # (N, 2H+1): coefficients -> samples
    W = S.T * (2.0 / N)  # samples -> coefficients (valid for N >= 2H+1)
    W[0] *= 0.5
    S.setflags(write=False)
    W.setflags(write=False)
    return tau, S, W


def time_grid(H: int, N: int):
    """(tau, S, W): N equispaced samples, synthesis S (N, 2H+1), analysis W (2H+1, N).

    x_samples = S @ X, X = W @ x_samples (exact for x with <= H harmonics, N >= 2H+1;
    a non-smooth x is projected with the aliasing error of the rectangle rule).
    """
    if N < 2 * H + 1:
        raise ValueError(f"n_samples must be >= 2H+1 = {2 * H + 1}, got {N}")
    return _dft(H, N)


@lru_cache(maxsize=32)
def _sample_table(H: int, N: int) -> np.ndarray:
    """basis(tau, H).T at N equidistant samples (2H+1, N), read-only, cached."""
    out = basis(2 * np.pi * np.arange(N) / N, H).T.copy()
    out.setflags(write=False)
    return out


def amplitude_half_peak_to_peak(X: np.ndarray, n_samples: int = 0) -> np.ndarray:
    """(max x - min x)/2 over one period for X (..., 2H+1) (the dataset's `amplitude`).

    Sampled finely (default 64*H+64 points) and refined by the exact extrema:
    the extrema of a trigonometric polynomial are roots of its derivative, polished
    by Newton steps from the best sample, so the value is exact to rounding
    (`extrema_rows`, compiled: one signal costs microseconds, as the exact peak
    search asks for it thousands of times).
    """
    X = np.asarray(X, dtype=float)
    H = harmonics_of(X.shape[-1])
    flat = np.ascontiguousarray(X.reshape(-1, X.shape[-1]))
    N = n_samples or 64 * H + 64
    out = np.empty(flat.shape[0])
    extrema_rows(flat, _sample_table(H, N), out)
    return out.reshape(X.shape[:-1])


@njit(cache=True, error_model="numpy")
def extrema_rows(flat, table, out):
    """out[r] = (max - min) / 2 of the signal of coefficients flat[r] (2H+1): the
    largest and smallest of the N samples (table = basis at the samples, (2H+1, N)),
    each polished by four Newton steps on x'(t) = 0 (a step at most half a sample
    spacing), the better of polished and sampled value kept."""
    R, nh = flat.shape
    H, N = (nh - 1) // 2, table.shape[1]
    dt = 2.0 * np.pi / N
    for r in range(R):
        hi, lo, ihi, ilo = -np.inf, np.inf, 0, 0
        for i in range(N):
            x = 0.0
            for k in range(nh):
                x += flat[r, k] * table[k, i]
            if x > hi:
                hi, ihi = x, i
            if x < lo:
                lo, ilo = x, i
        ends = np.empty(2)
        for side in range(2):
            t = (ihi if side == 0 else ilo) * dt
            for _ in range(4):
                d1 = d2 = 0.0
                for j in range(1, H + 1):
                    c, s = np.cos(j * t), np.sin(j * t)
                    a, b = flat[r, 2 * j - 1], flat[r, 2 * j]
                    d1 += j * (b * c - a * s)
                    d2 -= j * j * (a * c + b * s)
                step = d1 / d2 if d2 != 0.0 else 0.0
                t -= min(max(step, -0.5 * dt), 0.5 * dt)
            val = flat[r, 0]
            for j in range(1, H + 1):
                val += flat[r, 2 * j - 1] * np.cos(j * t) + flat[r, 2 * j] * np.sin(j * t)
            ends[side] = max(val, hi) if side == 0 else min(val, lo)
        out[r] = 0.5 * (ends[0] - ends[1])


def complex_harmonics(Qc):
    """(H+1, nc) complex harmonics q_h = c_h - i s_h of real coefficients Qc (nc, 2H+1)
    (q_0 = the mean), the layout of `hbm.linear_part`."""
    return np.concatenate([Qc[:, :1].T.astype(complex), (Qc[:, 1::2] - 1j * Qc[:, 2::2]).T])


def real_blocks(St, nh):
    """Real matrix (nc*nh, nc*nh), DOF-major, of complex per-harmonic blocks St[h]."""
    St = np.asarray(St)
    nc = St.shape[1]
    L = np.zeros((nc, nh, nc, nh))
    L[:, 0, :, 0] = St[0].real
    if nc <= 64:    # all harmonics at once (per harmonic, strided copies: faster when large)
        c, s = np.arange(1, nh, 2), np.arange(2, nh, 2)
        A, B = St[1:].real, St[1:].imag
        L[:, c, :, c], L[:, c, :, s], L[:, s, :, c], L[:, s, :, s] = A, B, -B, A
        return L.reshape(nc * nh, nc * nh)
    for h in range(1, St.shape[0]):
        c, s = 2 * h - 1, 2 * h      # cos, sin of harmonic h
        A, B = St[h].real, St[h].imag
        L[:, c, :, c] = A
        L[:, c, :, s] = B
        np.negative(B, out=L[:, s, :, c])
        L[:, s, :, s] = A
    return L.reshape(nc * nh, nc * nh)


def real_vector(Pt, nh):
    """Real layout (nc, nh) of complex per-harmonic vectors Pt (H+1, nc)."""
    nc = Pt.shape[1]
    out = np.zeros((nc, nh))
    out[:, 0] = Pt[0].real
    out[:, 1::2] = Pt[1:].real.T
    out[:, 2::2] = -Pt[1:].imag.T
    return out
