"""Compiled (Numba) kernels on one real trigonometric polynomial at a time.

p(tau) = P0 + sum_j Pc_j cos(j tau) + Ps_j sin(j tau) in the layout of
`harmonics.py`.  The same mathematics as `trigroots` (certified sign changes,
safeguarded Newton) and as the closed-form Fourier integrals of the exact contact
forces (paper Eq. 11), written for one polynomial so that a caller's loop over
elements runs without array overhead:

  * `sign_changes_one`: every sign change over one period, with the certificate of
    `trigroots` (Taylor bounds with D3 = sum_j j^3 |P_j| >= max |p'''|, cells split
    in four until certified or narrower than the resolution), so none is missed;
  * `polish_one`: safeguarded Newton (with Halley's correction) inside a bracket,
    to round-off, with the stopping rule of `trigroots.polish_root`;
  * `add_segment_integrals`: X += sign [C_0..C_2H, S_0..S_2H] of [a, b], in
    product form (sin mb - sin ma = 2 cos(m c) sin(m h), c = (a+b)/2,
    h = (b-a)/2), exact for the short stick arcs of a stiff contact;
  * `add_gram`: G += scale gram(X), the coefficients of f = s.P on a set are G @ P;
    `gram_apply`: G @ P (and G) without storing G.

cos(j x), sin(j x) come from one cos/sin pair by the recurrence of
exp(i j x) (relative error ~ j eps, inside the noise model of the root polish).
The fixed grids of the root search are tabulated once per H (`root_tables`).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from .harmonics import basis

TWO_PI = 2 * np.pi
GRID_OFFSET = 0.3819660112501051  # irrational fraction of a cell (see trigroots)
EPS = float(np.finfo(float).eps)


@lru_cache(maxsize=None)
def root_tables(H: int):
    """(nodes (N+1,), B (N+1, 2H+1), B0, B1, B2 (N, 2H+1)): the initial grid of
    `sign_changes_one` (N = max(16, 8H) cells, offset as in `trigroots`), the basis
    at its nodes and the basis and its first two derivatives at the cell centres."""
    N = max(16, 8 * H)
    nodes = TWO_PI * (np.arange(N + 1) + GRID_OFFSET) / N
    centers = nodes[:-1] + np.pi / N
    out = (nodes, basis(nodes, H)) + tuple(basis(centers, H, k) for k in range(3))
    for a in out:
        a.setflags(write=False)
    return out


@njit(cache=True, error_model="numpy")
def eval012(P, H, x):
    """p(x), p'(x), p''(x) from one cos/sin pair."""
    c1, s1 = np.cos(x), np.sin(x)
    cj, sj = c1, s1
    p0, p1, p2 = P[0], 0.0, 0.0
    for j in range(1, H + 1):
        a, b = P[2 * j - 1], P[2 * j]
        v = a * cj + b * sj
        p0 += v
        p1 += j * (b * cj - a * sj)
        p2 -= j * j * v
        cj, sj = cj * c1 - sj * s1, sj * c1 + cj * s1
    return p0, p1, p2


@njit(cache=True, error_model="numpy")
def secant_start(lo, hi, flo, fhi):
    """The secant point of [lo, hi] from the end values, else the midpoint."""
    xs = lo - flo * (hi - lo) / (fhi - flo)
    return xs if np.isfinite(xs) and lo < xs < hi else 0.5 * (lo + hi)


@njit(cache=True, error_model="numpy")
def polish_one(P, H, lo, hi, plo, x):
    """Root of p in [lo, hi], where p changes sign, p(lo) having the sign plo,
    from the start x in (lo, hi).

    Safeguarded Newton with bisection and the stopping rule of
    `trigroots.polish_root`; the step takes Halley's correction (p'' comes with p'
    from the same cos/sin): cubic convergence, one evaluation fewer.
    """
    up = plo < 0
    noise = abs(P[0])
    for j in range(1, H + 1):
        noise += (abs(P[2 * j - 1]) + abs(P[2 * j])) * (1.0 + TWO_PI * j)
    noise *= 8 * EPS
    for _ in range(100):
        f, fp, fpp = eval012(P, H, x)
        if (f > 0) == up:
            hi = x
        else:
            lo = x
        newton = -f / fp
        # converged on the raw Newton step, or at noise level with a tiny step
        keep = abs(newton) < 1e-14 or (abs(f) <= noise and abs(newton) < 1e-11) or f == 0
        if keep:
            return x
        den = 1.0 + 0.5 * newton * fpp / fp
        xn = x + (newton / den if den > 0.5 else newton)
        if not np.isfinite(xn) or xn <= lo or xn >= hi:
            xn = 0.5 * (lo + hi)
        if hi - lo < 1e-13:
            return xn
        x = xn
    return x


@njit(cache=True, error_model="numpy")
def taylor_start(c, p0, p1, p2):
    """c + the root nearest 0 of p0 + p1 t + p2 t^2/2 (stable form; Newton's step
    where the quadratic has no real root)."""
    disc = p1 * p1 - 2.0 * p0 * p2
    if disc < 0:
        return c - p0 / p1
    root = np.sqrt(disc)
    return c - 2.0 * p0 / (p1 + root if p1 >= 0 else p1 - root)


@njit(cache=True, error_model="numpy")
def _certify(p0, p1, p2, d, D3):
    no_root = abs(p0) > d * abs(p1) + d * d / 2 * abs(p2) + d ** 3 / 6 * D3
    mono = abs(p1) > d * abs(p2) + d * d / 2 * D3
    return no_root, mono


@njit(cache=True, error_model="numpy")
def _push_root(P, H, lo, hi, slo, x0, roots, slopes, count):
    """Polish the root bracketed by [lo, hi] from x0 and append it (capacity
    permitting)."""
    if count < roots.size:
        roots[count] = polish_one(P, H, lo, hi, slo, x0) % TWO_PI
        slopes[count] = -slo
        return count + 1
    return count


_REFINE_CELLS = 20000  # cells one uncertified node cell may visit (a certified search
# visits tens; only a polynomial that is exactly zero on an interval needs more)


@njit(cache=True, error_model="numpy")
def _refine(P, H, c0, d0, D3, resolution, roots, slopes, count):
    """Depth-first split of the uncertified cell [c0 - d0, c0 + d0] in four until
    each part is certified root-free or monotone, or narrower than the resolution
    (there a sign change of the end values counts).  After _REFINE_CELLS cells
    every remaining cell counts as narrow: a bound on the work, reached only by a
    polynomial that vanishes exactly on a whole interval (no certificate holds
    there, at any width)."""
    depth = 64
    stc, std = np.empty(4 * depth), np.empty(4 * depth)
    stc[0], std[0] = c0, d0
    top = 1
    visits = 0
    while top > 0:
        top -= 1
        visits += 1
        c, d = stc[top], std[top]
        if d <= resolution or visits > _REFINE_CELLS:
            pl, ph = eval012(P, H, c - d)[0], eval012(P, H, c + d)[0]
            sl, sh = (1 if pl >= 0 else -1), (1 if ph >= 0 else -1)
            if sl != sh:
                count = _push_root(P, H, c - d, c + d, sl, secant_start(c - d, c + d, pl, ph),
                                   roots, slopes, count)
            continue
        d = d / 4
        for off in (-3.0, -1.0, 1.0, 3.0):
            cc = c + off * d
            p0, p1, p2 = eval012(P, H, cc)
            no_root, mono = _certify(p0, p1, p2, d, D3)
            if no_root:
                continue
            if mono:
                pl, ph = eval012(P, H, cc - d)[0], eval012(P, H, cc + d)[0]
                sl, sh = (1 if pl >= 0 else -1), (1 if ph >= 0 else -1)
                if sl != sh:
                    count = _push_root(P, H, cc - d, cc + d, sl,
                                       secant_start(cc - d, cc + d, pl, ph), roots, slopes,
                                       count)
            elif top < stc.size:
                stc[top], std[top] = cc, d
                top += 1
    return count


@njit(cache=True, error_model="numpy")
def _sort_roots(roots, slopes, count):
    for i in range(1, count):  # insertion sort: a handful of roots
        r, s = roots[i], slopes[i]
        k = i - 1
        while k >= 0 and roots[k] > r:
            roots[k + 1], slopes[k + 1] = roots[k], slopes[k]
            k -= 1
        roots[k + 1], slopes[k + 1] = r, s


@njit(cache=True, error_model="numpy")
def _row_dot(B, k, P):
    v = 0.0
    for c in range(P.size):
        v += B[k, c] * P[c]
    return v


@njit(cache=True, error_model="numpy")
def sign_changes_one(P, H, nodes, B, B0, B1, B2, roots, slopes):
    """Sign-changing roots of p in [0, 2 pi), sorted, written to roots/slopes
    (slope +1 upward, -1 downward); returns their count.  Certified as in
    `trigroots.sign_changes` (resolution 1e-12); tables from `root_tables(H)`.

    The certificates need p, p', p'' at a cell's centre; since |p'| <= D1 and
    |p''| <= D2 (D_k = sum_j j^k |P_j|), a cell with |p| > d D1 + d^2/2 D2 + d^3/6 D3
    is root-free by the same bound without them, and node values are needed only
    where a root is possible: the same cells, classified alike, for less work.
    """
    if H == 0:
        return 0
    D1, D2, D3, scale, amax = 0.0, 0.0, 0.0, abs(P[0]), 0.0
    for j in range(1, H + 1):
        amp = np.hypot(P[2 * j - 1], P[2 * j])
        D1 += j * amp
        D2 += j * j * amp
        D3 += j ** 3 * amp
        scale += amp
        amax = max(amax, amp)
    if not amax > 1e-14 * scale:  # constant: no roots
        return 0
    if not 2.0 ** -500 < scale < 2.0 ** 500:  # the same roots, at a scale that cannot
        # underflow to exact zeros over an interval (subnormal coefficients)
        k = -int(np.floor(np.log2(scale)))
        return sign_changes_one(np.ldexp(P, k), H, nodes, B, B0, B1, B2, roots, slopes)
    N = nodes.size - 1
    d = np.pi / N
    cheap = d * D1 + d * d / 2 * D2 + d ** 3 / 6 * D3
    count = np.int64(0)  # typed, not a literal (a literal compiles its callees twice)
    for i in range(N):
        p0 = _row_dot(B0, i, P)
        if abs(p0) > cheap:
            continue
        p1, p2 = _row_dot(B1, i, P), _row_dot(B2, i, P)
        no_root, mono = _certify(p0, p1, p2, d, D3)
        if no_root:
            continue
        if mono:  # one point of the circle, one sign: node N is node 0
            pl, ph = _row_dot(B, i, P), _row_dot(B, (i + 1) % N, P)
            sl, sh = (1 if pl >= 0 else -1), (1 if ph >= 0 else -1)
            if sl != sh:  # start: the root of the Taylor quadratic at the centre
                x0 = taylor_start(nodes[i] + d, p0, p1, p2)
                if not nodes[i] < x0 < nodes[i + 1]:
                    x0 = secant_start(nodes[i], nodes[i + 1], pl, ph)
                count = _push_root(P, H, nodes[i], nodes[i + 1], sl, x0, roots, slopes, count)
        else:
            count = _refine(P, H, nodes[i] + d, d, D3, 1e-12, roots, slopes, count)
    _sort_roots(roots, slopes, count)
    return count


@njit(cache=True, error_model="numpy")
def add_segment_integrals(a, b, H, sign, X):
    """X += sign [C_0..C_2H, S_0..S_2H], C_m = 1/pi int_a^b cos(m t), S_m likewise
    (Eq. 11), in product form: no difference of nearly equal terms."""
    n = 2 * H + 1
    mid, half = 0.5 * (a + b), 0.5 * (b - a)
    cm1, sm1 = np.cos(mid), np.sin(mid)
    ch1, sh1 = np.cos(half), np.sin(half)
    cm, sm, ch, sh = cm1, sm1, ch1, sh1
    X[0] += sign * (b - a) / np.pi
    for m in range(1, n):
        f = sign * 2.0 * sh / (m * np.pi)
        X[m] += f * cm
        X[n + m] += f * sm
        cm, sm = cm * cm1 - sm * sm1, sm * cm1 + cm * sm1
        ch, sh = ch * ch1 - sh * sh1, sh * ch1 + ch * sh1


@njit(cache=True, error_model="numpy")
def add_gram(X, H, scale, G):
    """G += scale gram(X): G[k, j] = c_k int s_k s_j over the set with integrals X,
    c_0 = 1/(2 pi), c_k = 1/pi (Eq. 11 in the layout of harmonics.py)."""
    n = 2 * H + 1
    G[0, 0] += scale * 0.5 * X[0]
    for q in range(1, H + 1):
        G[0, 2 * q - 1] += scale * 0.5 * X[q]
        G[0, 2 * q] += scale * 0.5 * X[n + q]
        G[2 * q - 1, 0] += scale * X[q]
        G[2 * q, 0] += scale * X[n + q]
    for p in range(1, H + 1):
        for q in range(1, H + 1):
            dm, sm = abs(p - q), p + q
            sgn = 1.0 if q > p else (-1.0 if q < p else 0.0)
            cdiff, csum = X[dm], X[sm]
            sdiff, ssum = X[n + dm], X[n + sm]
            G[2 * p - 1, 2 * q - 1] += scale * 0.5 * (cdiff + csum)
            G[2 * p - 1, 2 * q] += scale * 0.5 * (ssum + sgn * sdiff)
            G[2 * p, 2 * q - 1] += scale * 0.5 * (ssum - sgn * sdiff)
            G[2 * p, 2 * q] += scale * 0.5 * (cdiff - csum)


@njit(cache=True, error_model="numpy")
def gram_apply(X, H, P, scale, out, jscale, J, jac):
    """out += scale G P and, with `jac`, J += jscale G, for G = gram(X) of `add_gram`,
    without storing G."""
    n = 2 * H + 1
    out[0] += scale * 0.5 * X[0] * P[0]
    if jac:
        J[0, 0] += jscale * 0.5 * X[0]
    for q in range(1, H + 1):
        c0, s0 = X[q], X[n + q]
        out[0] += scale * 0.5 * (c0 * P[2 * q - 1] + s0 * P[2 * q])
        out[2 * q - 1] += scale * c0 * P[0]
        out[2 * q] += scale * s0 * P[0]
        if jac:
            J[0, 2 * q - 1] += jscale * 0.5 * c0
            J[0, 2 * q] += jscale * 0.5 * s0
            J[2 * q - 1, 0] += jscale * c0
            J[2 * q, 0] += jscale * s0
    for p in range(1, H + 1):
        acc_c, acc_s = 0.0, 0.0
        for q in range(1, H + 1):
            dm, sm = abs(p - q), p + q
            sgn = 1.0 if q > p else (-1.0 if q < p else 0.0)
            cc = 0.5 * (X[dm] + X[sm])
            cs = 0.5 * (X[n + sm] + sgn * X[n + dm])
            sc = 0.5 * (X[n + sm] - sgn * X[n + dm])
            ss = 0.5 * (X[dm] - X[sm])
            acc_c += cc * P[2 * q - 1] + cs * P[2 * q]
            acc_s += sc * P[2 * q - 1] + ss * P[2 * q]
            if jac:
                J[2 * p - 1, 2 * q - 1] += jscale * cc
                J[2 * p - 1, 2 * q] += jscale * cs
                J[2 * p, 2 * q - 1] += jscale * sc
                J[2 * p, 2 * q] += jscale * ss
        out[2 * p - 1] += scale * acc_c
        out[2 * p] += scale * acc_s
