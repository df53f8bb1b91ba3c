"""What each Yang-Menq element does over one steady-state period, from the exact
transition times (`exact.periodic_segments`; paper Sec. 4, Eq. 1, 9).

Fractions of the period in stick, slip (either direction) and separation: the
lengths of the state segments / 2 pi, exactly (no sampling).

Dissipated energy per cycle [J]: the work of the friction force on the slider,
W = contour integral f_u dw (the tangential spring stores and returns ku (u - w)^2/2,
the normal spring n^2/(2 kv) with n = 0 at both ends of every contact phase, so W
is also the loop integral of f_u du + f_v dv).  Stick phases have dw = 0 and
separation f_u = 0; on a slip phase [a, b]

    positive slip: f_u = mu n, w = u - (mu/ku) n:
        W = mu int_a^b n u' dtau - mu^2/(2 ku) (n(b)^2 - n(a)^2),
    negative slip: f_u = -mu n, w = u + (mu/ku) n:
        W = -mu int_a^b n u' dtau - mu^2/(2 ku) (n(b)^2 - n(a)^2),

both >= 0.  n u' is a trigonometric polynomial of degree 2H: with complex
coefficients x(tau) = sum_k c_k exp(i k tau), int_a^b n u' = sum_p P_p I_p with
P = c^n * (i k c^u) (a convolution) and I_p = (exp(i p b) - exp(i p a))/(i p),
I_0 = b - a: closed form.

Normal contact force f_v = max(n, 0): its mean (1/2 pi) int_{n > 0} n dtau (closed
form on the contact phases) and its half peak-to-peak (max f_v - min f_v)/2 with
the extrema of n refined by Newton on n' = 0.
"""
from __future__ import annotations

import numpy as np

from .element import NSLIP, PSLIP, SEP, STICK, YangMenq, check_coefficients
from .exact import periodic_segments
from ..fourier.harmonics import basis, harmonics_of
from ..fourier.trigroots import TWO_PI, sign_changes


def complex_coefficients(X) -> np.ndarray:
    """c_k, k = -H..H (..., 2H+1) of x = sum_k c_k exp(i k tau), X in the real layout."""
    X = np.asarray(X, dtype=float)
    H = harmonics_of(X.shape[-1])
    c = np.empty(X.shape, dtype=complex)
    half = 0.5 * (X[..., 1::2] - 1j * X[..., 2::2])      # k = 1..H
    c[..., H] = X[..., 0]
    c[..., H + 1:] = half
    c[..., :H] = np.conj(half[..., ::-1])
    return c


def interval_integrals(C, a, b) -> np.ndarray:
    """int_a^b of the trigonometric polynomials with complex coefficients C (K, 2M+1)
    (k = -M..M) over the intervals [a, b] (K, S) -> (K, S), closed form; only the
    intervals with b > a are evaluated (the others are 0)."""
    M = (C.shape[-1] - 1) // 2
    out = np.zeros(a.shape)
    rows, cols = np.nonzero(b > a)
    if rows.size == 0:
        return out
    p = np.arange(1, M + 1)
    ta, tb = a[rows, cols], b[rows, cols]
    ea, eb = np.exp(1j * np.outer(ta, p)), np.exp(1j * np.outer(tb, p))
    # conjugate pairs k = +-p: 2 Re(c_p (e^{ipb} - e^{ipa}) / (ip)), and c_0 (b - a)
    pos = C[rows, M + 1:]
    out[rows, cols] = (C[rows, M].real * (tb - ta)
                       + 2.0 * np.sum((pos * (eb - ea) / (1j * p)).real, axis=1))
    return out


def product_coefficients(A, B) -> np.ndarray:
    """Complex coefficients (K, 4H+1) of the product of two trigonometric polynomials
    given by complex coefficients (K, 2H+1)."""
    return np.array([np.convolve(x, y) for x, y in zip(A, B)])


def extremes(X) -> tuple:
    """(max x, min x) over one period for rows X (K, 2H+1): the best of 64 H + 64
    samples, refined by Newton on x' = 0."""
    H = harmonics_of(X.shape[-1])
    N = 64 * H + 64
    tau = TWO_PI * np.arange(N) / N
    x = X @ basis(tau, H).T
    out = []
    for pick, better in ((np.argmax, np.maximum), (np.argmin, np.minimum)):
        i = pick(x, axis=1)
        t = tau[i]
        for _ in range(4):
            d1 = np.einsum("kc,kc->k", basis(t, H, 1), X)
            d2 = np.einsum("kc,kc->k", basis(t, H, 2), X)
            step = np.where(d2 != 0, d1 / np.where(d2 == 0, 1.0, d2), 0.0)
            t = t - np.clip(step, -np.pi / N, np.pi / N)
        val = np.einsum("kc,kc->k", basis(t, H), X)
        out.append(better(val, x[np.arange(len(X)), i]))
    return out[0], out[1]


def _positive_intervals(Nc):
    """Intervals (K, S) [a, b] where n > 0 (padded with a = b = 0), for rows Nc."""
    roots, slope = sign_changes(Nc)
    K = Nc.shape[0]
    S = max(1, roots.shape[1])
    a, b = np.zeros((K, S)), np.zeros((K, S))
    for k in range(K):
        r = roots[k][np.isfinite(roots[k])]
        s = slope[k][:r.size]
        if r.size == 0:
            if Nc[k, 0] + np.sum(Nc[k, 1::2]) > 0:       # n(0) > 0: in contact throughout
                a[k, 0], b[k, 0] = 0.0, TWO_PI
            continue
        for j in np.flatnonzero(s > 0):
            a[k, j] = r[j]
            b[k, j] = r[(j + 1) % r.size] + (TWO_PI if j + 1 >= r.size else 0.0)
    return a, b


def cycle_results(U, V, elem: YangMenq) -> dict:
    """Per element (E,): `stick`, `slip`, `separation` (fractions of the period [-],
    summing to 1), `energy` (dissipated per cycle [J]), `normal_mean` and
    `normal_amplitude` (of f_v = max(n, 0) [N]).  U, V (E, 2H+1) [m]."""
    E = elem.size
    U = check_coefficients("U", U, E)
    V = check_coefficients("V", V, E)
    seg = periodic_segments(U, V, elem)
    a, b, st, regime, Nc = seg["a"], seg["b"], seg["state"], seg["regime"], seg["Nc"]
    used = (st >= 0) & (b > a)
    length = np.where(used, b - a, 0.0)
    frac = {name: np.sum(np.where(np.isin(st, states), length, 0.0), axis=1) / TWO_PI
            for name, states in (("stick", (STICK,)), ("slip", (PSLIP, NSLIP)),
                                 ("separation", (SEP,)))}
    cn = complex_coefficients(Nc)
    H = harmonics_of(U.shape[1])
    k = np.arange(-H, H + 1)
    cdu = 1j * k * complex_coefficients(U)
    slip = used & ((st == PSLIP) | (st == NSLIP))
    nu = interval_integrals(product_coefficients(cn, cdu), a, np.where(slip, b, a))
    rows, cols = np.nonzero(slip)
    na = np.einsum("mc,mc->m", basis(a[rows, cols], H), Nc[rows])
    nb = np.einsum("mc,mc->m", basis(b[rows, cols], H), Nc[rows])
    mu, ku = elem.mu[rows], elem.ku[rows]
    r2 = np.where(ku > 0, mu * mu / (2.0 * np.where(ku > 0, ku, 1.0)), 0.0)
    sgn = np.where(st[rows, cols] == PSLIP, 1.0, -1.0)
    energy = np.bincount(rows, weights=sgn * mu * nu[rows, cols] - r2 * (nb**2 - na**2),
                         minlength=E)
    contact_phase = used & (st != SEP)
    load = np.sum(interval_integrals(cn, a, np.where(contact_phase, b, a)), axis=1)
    # fully stuck and fully separated elements: one segment, their state set above
    frictionless = regime == 3
    if np.any(frictionless):
        fa, fb = _positive_intervals(Nc[frictionless])
        inside = np.sum(fb - fa, axis=1) / TWO_PI
        frac["slip"][frictionless] = inside
        frac["stick"][frictionless] = 0.0
        frac["separation"][frictionless] = 1.0 - inside
        energy[frictionless] = 0.0
        load[frictionless] = np.sum(interval_integrals(cn[frictionless], fa, fb), axis=1)
    nmax, nmin = extremes(Nc)
    return dict(**frac, energy=energy, normal_mean=load / TWO_PI,
                normal_amplitude=0.5 * (np.maximum(nmax, 0.0) - np.maximum(nmin, 0.0)))
