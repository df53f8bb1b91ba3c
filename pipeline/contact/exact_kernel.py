"""Compiled (Numba) periodic state sequence of one Yang-Menq element (paper Sec. 4).

The steps of `contact.exact` for one element at a time, so that the loop over
elements runs without array overhead (`contact.exact_integrals` integrates the
forces, Eq. 9-11):

  * `band_roots`: the transition candidates, sign changes of the normal load
    n = n0 + kv v (Eq. 1; searched only where it varies) and of the band edges'
    derivatives lo' = u' - (mu kv/ku) v' and hi' (Sec. 4.2, 4.3), by the certified
    search of `fourier.trigkernel`;
  * `contact_state`, `band_extreme`, `stuck_slider_one`: separation throughout,
    full stick (max lo <= min hi, the slider placed by `YangMenq.slider_rest`);
  * `march`: the periodic start (touchdown, else argmin hi in negative slip) and
    the march over the intervals between breakpoints, with the stick -> slip
    crossings lo = w / hi = w (Sec. 4.4) solved inside their interval.

States and slider sources are those of `contact.element` (SEP, STICK, PSLIP, NSLIP;
SRC_LO, SRC_HI, SRC_TD).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .element import NSLIP, PSLIP, SEP, SRC_HI, SRC_LO, SRC_TD, STICK
from ..fourier.trigkernel import TWO_PI, eval012, polish_one, secant_start, sign_changes_one

PROBES = (0.5, 0.5 - 0.5 / np.sqrt(5), 0.5 + 0.5 / np.sqrt(5))


@njit(cache=True, error_model="numpy")
def load_and_band(Ue, Ve, ku, kv, mu, n0, Nc, Lc, Hc):
    """Nc = n0 + kv V (Eq. 1) and the band edges Lc, Hc = U -+ (mu/ku) Nc; returns
    (r = mu/ku, tangential: mu > 0 and ku > 0)."""
    tang = mu > 0 and ku > 0
    r = mu / ku if tang else 0.0
    for c in range(Ue.size):
        Nc[c] = kv * Ve[c]
    Nc[0] += n0
    for c in range(Ue.size):
        Lc[c] = Ue[c] - r * Nc[c]
        Hc[c] = Ue[c] + r * Nc[c]
    return r, tang


@njit(cache=True, error_model="numpy")
def derivative_into(P, H, D):
    """D = coefficients of p' (d/dtau (c, s)_j = j (-s, c)_j)."""
    D[0] = 0.0
    for j in range(1, H + 1):
        D[2 * j - 1] = j * P[2 * j]
        D[2 * j] = -j * P[2 * j - 1]


@njit(cache=True, error_model="numpy")
def band_roots(Nc, Lc, Hc, H, T, nr, ns, lr, ls, hr, hs, D):
    """Sign changes of n (if it varies), lo' and hi' (= lo' when n is constant: the
    Jenkins path); returns (n varies, count n, count lo', count hi').  D: scratch."""
    nodes, B, B0, B1, B2 = T[0], T[1], T[2], T[3], T[4]
    varying = False
    for c in range(1, Nc.size):
        varying = varying or Nc[c] != 0.0
    n_n = sign_changes_one(Nc, H, nodes, B, B0, B1, B2, nr, ns) if varying else 0
    derivative_into(Lc, H, D)
    n_l = sign_changes_one(D, H, nodes, B, B0, B1, B2, lr, ls)
    if varying:
        derivative_into(Hc, H, D)
        n_h = sign_changes_one(D, H, nodes, B, B0, B1, B2, hr, hs)
    else:
        n_h = n_l
        for i in range(n_l):  # element by element: a slice copy compiles a shape check
            hr[i], hs[i] = lr[i], ls[i]
    return varying, n_n, n_l, n_h


@njit(cache=True, error_model="numpy")
def contact_state(Nc, B16, n_n):
    """(n crosses zero, n > 0 throughout): without a sign change the sign of n is
    that of its largest value of magnitude on a 16-point grid."""
    crosses = n_n > 0
    best, val = -1.0, 0.0
    for k in range(B16.shape[0]):
        v = 0.0
        for c in range(Nc.size):
            v += B16[k, c] * Nc[c]
        if abs(v) > best:
            best, val = abs(v), v
    return crosses, (not crosses) and val > 0


@njit(cache=True, error_model="numpy")
def band_extreme(P, H, roots, slopes, count, want, is_max):
    """(value, location) of the maximum (is_max) or minimum of p over its stationary
    points where p' changes sign with slope `want`; p constant: (P0, NaN)."""
    found, best, loc = False, P[0], np.nan
    for i in range(count):
        if slopes[i] == want:
            v = eval012(P, H, roots[i])[0]
            if not found or (v > best if is_max else v < best):
                found, best, loc = True, v, roots[i]
    return best, loc


@njit(cache=True, error_model="numpy")
def basis_at(t, H, out):
    """out = s(t); t NaN (extremum attained everywhere) -> e0, the derivative of the
    extremum consistent with a small symmetric motion."""
    out[:] = 0.0
    out[0] = 1.0
    if np.isnan(t):
        return
    c1, s1 = np.cos(t), np.sin(t)
    cj, sj = c1, s1
    for j in range(1, H + 1):
        out[2 * j - 1], out[2 * j] = cj, sj
        cj, sj = cj * c1 - sj * s1, sj * c1 + cj * s1


@njit(cache=True, error_model="numpy")
def stuck_slider_one(maxlo, minhi, s_lo, s_hi, rk, rest, has_rest, dU, dV):
    """Slider w of a fully stuck cycle (`element.stuck_slider`): the middle of
    [max lo, min hi], or `rest` clamped into it; dU, dV = dw/dU, dw/dV."""
    if not has_rest:
        for c in range(dU.size):
            dU[c] = 0.5 * (s_lo[c] + s_hi[c])
            dV[c] = 0.5 * rk * (s_hi[c] - s_lo[c])
        return 0.5 * (maxlo + minhi)
    below, above = rest < maxlo, (not rest < maxlo) and rest > minhi
    for c in range(dU.size):  # element by element: a slice copy compiles a shape check
        dU[c] = s_lo[c] if below else (s_hi[c] if above else 0.0)
        dV[c] = -rk * s_lo[c] if below else (rk * s_hi[c] if above else 0.0)
    if rest < maxlo:
        return maxlo
    if rest > minhi:
        return minhi
    return rest


@njit(cache=True, error_model="numpy")
def breakpoints(t0, rt, sl, n_n, n_l, n_h, bp, bsrc, bslope):
    """bp = t0 + sorted([0, (roots - t0) mod 2 pi, 2 pi]); for each root breakpoint
    i (1..m) the polynomial it belongs to, bsrc[i] (0 n, 1 lo', 2 hi'), and its
    slope, bslope[i].  Returns the interval count m + 1."""
    m = 0
    for p, cnt in ((0, n_n), (1, n_l), (2, n_h)):
        for i in range(cnt):
            m += 1
            bp[m], bsrc[m], bslope[m] = (rt[p, i] - t0) % TWO_PI, p, sl[p, i]
    for i in range(2, m + 1):  # insertion sort: a few dozen values
        x, xs, xl = bp[i], bsrc[i], bslope[i]
        k = i - 1
        while k >= 1 and bp[k] > x:
            bp[k + 1], bsrc[k + 1], bslope[k + 1] = bp[k], bsrc[k], bslope[k]
            k -= 1
        bp[k + 1], bsrc[k + 1], bslope[k + 1] = x, xs, xl
    bp[0] = t0
    for i in range(1, m + 1):
        bp[i] = t0 + bp[i]
    bp[m + 1] = t0 + TWO_PI
    return m + 1


@njit(cache=True, error_model="numpy")
def steady_sign(P, H, order, t0):
    """Sign of p (order 0) or p' (order 1) that does not change sign: it may touch 0
    at isolated points, so the largest of three values over the period decides."""
    best, val = -1.0, 0.0
    for f in PROBES:
        v = eval012(P, H, t0 + f * TWO_PI)[order]
        if abs(v) > best:
            best, val = abs(v), v
    return np.sign(val)


@njit(cache=True, error_model="numpy")
def start_signs(Nc, Lc, Hc, H, t0, bsrc, bslope, m, signs):
    """signs = signs of n, lo', hi' just after t0: the slope of each one's last
    sign change before t0 + 2 pi (that is, before t0), else its steady sign."""
    signs[:] = 2
    for i in range(1, m + 1):
        signs[bsrc[i]] = bslope[i]
    for p, P, order in ((0, Nc, 0), (1, Lc, 1), (2, Hc, 1)):
        if signs[p] == 2:
            signs[p] = steady_sign(P, H, order, t0)


@njit(cache=True, error_model="numpy")
def crossing(P, H, sign, w, a, b, Q):
    """First tau in [a, b] where the increasing sign*p reaches sign*w (Sec. 4.4)."""
    for c in range(P.size):
        Q[c] = sign * P[c]
    Q[0] -= sign * w
    qa = eval012(Q, H, a)[0]
    if qa >= 0:
        return a
    return polish_one(Q, H, a, b, np.int64(-1), secant_start(a, b, qa, eval012(Q, H, b)[0]))


@njit(cache=True, error_model="numpy")
def march(Ue, Lc, Hc, Nc, H, bp, bsrc, bslope, K, crosses, t0, thi, minhi, seg_a, seg_b,
          seg_st, seg_w, seg_t, seg_k, Q):
    """State sequence over [t0, t0 + 2 pi) as segments 2k, 2k+1 of each interval k
    (the second only after a stick -> slip crossing, else state -1); returns 2K.

    Start: touchdown (crosses) with memory erased, else argmin hi in negative slip
    with w = min hi.  Slip ends only at breakpoints (lo', hi' change sign there);
    in contact, stick -> slip at most once per interval (lo, hi monotone there).
    The signs of n, lo', hi' on each interval follow from the slopes of their sign
    changes at the breakpoints (`breakpoints`, `start_signs`).  Q: scratch.
    """
    sg = np.empty(3, np.int64)
    start_signs(Nc, Lc, Hc, H, t0, bsrc, bslope, K - 1, sg)
    state = SEP if crosses else NSLIP
    w = 0.0 if crosses else minhi
    src_t, src_k = (t0, SRC_TD) if crosses else (thi, SRC_HI)
    for k in range(K):
        a, b = bp[k], bp[k + 1]
        if k > 0:
            sg[bsrc[k]] = bslope[k]
        seg_st[2 * k] = seg_st[2 * k + 1] = -1
        seg_a[2 * k], seg_b[2 * k], seg_a[2 * k + 1], seg_b[2 * k + 1] = a, b, b, b
        if not b > a:
            continue
        sn, lp, hp = sg[0], sg[1], sg[2]
        if sn > 0:
            if state == SEP:  # touchdown: the spring restarts unstrained (Sec. 4.1)
                w, src_t, src_k = eval012(Ue, H, a)[0], a, SRC_TD
                state = PSLIP if lp > 0 else (NSLIP if hp < 0 else STICK)
            elif state == PSLIP and lp <= 0:  # lo maximal: PS -> stick (Sec. 4.2)
                w, src_t, src_k, state = eval012(Lc, H, a)[0], a, SRC_LO, STICK
            elif state == NSLIP and hp >= 0:  # hi minimal: NS -> stick (Sec. 4.3)
                w, src_t, src_k, state = eval012(Hc, H, a)[0], a, SRC_HI, STICK
        else:
            state = SEP
        to_ps = state == STICK and lp > 0 and eval012(Lc, H, b)[0] >= w
        to_ns = state == STICK and hp < 0 and eval012(Hc, H, b)[0] <= w
        te = b
        if to_ps and to_ns:  # band closing on w from both sides: the first wins
            to_ps = crossing(Lc, H, 1.0, w, a, b, Q) <= crossing(Hc, H, -1.0, w, a, b, Q)
            to_ns = not to_ps
        if to_ps:
            te = crossing(Lc, H, 1.0, w, a, b, Q)
        elif to_ns:
            te = crossing(Hc, H, -1.0, w, a, b, Q)
        seg_st[2 * k] = state
        seg_b[2 * k], seg_a[2 * k + 1] = te, te
        for s in (2 * k, 2 * k + 1):
            seg_w[s], seg_t[s], seg_k[s] = w, src_t, src_k
        if to_ps or to_ns:
            state = PSLIP if to_ps else NSLIP
            seg_st[2 * k + 1] = state
    return 2 * K
