"""Compiled (Numba) exact Yang-Menq forces and Jacobian over all elements (Eq. 9-11).

For each element in turn: its periodic state sequence
(`contact.exact_kernel`), then the Fourier coefficients of each state's force piece
in closed form (Eq. 11, `fourier.trigkernel.add_segment_integrals`, `gram_apply`):

  f_v = n on {n > 0};  f_u = ku (u - w) in stick, +-mu n in positive/negative slip,
  0 in separation (Eq. 9, 10).

Fully stuck and fully separated cycles keep their closed form (no segments).  The
Jacobian is the integral of the piecewise derivative plus, for each stick phase, the
derivative of its slider position w where it was set (Sec. 4.4): dw/dU = s(t_src),
dw/dV = s(t_src) aV with aV = -+ mu kv/ku on a band edge and -u'/v' at touchdown.
Forces are continuous at every transition, so no boundary terms appear.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .element import NSLIP, PSLIP, SEP, SRC_HI, SRC_LO, STICK
from .exact_kernel import (band_extreme, band_roots, basis_at, breakpoints, contact_state,
                           load_and_band, march, stuck_slider_one)
from ..fourier.trigkernel import TWO_PI, add_segment_integrals, eval012, gram_apply


def capacities(H: int):
    """(roots per polynomial, segments): a trigonometric polynomial of degree H has
    at most 2H sign changes; room is left for rounding near tangencies."""
    cap = 4 * H + 4
    return cap, 2 * (3 * cap + 1)


@njit(cache=True)
def workspace(H):
    """Scratch arrays of one element, reused from element to element: vectors
    (11, 2H+1) [Nc, Lc, Hc, s(t_lo), s(t_hi), dw/dU, dw/dV, p', Q, g, s], roots and
    slopes (3, cap), segments (4, S) [a, b, w, t_src] and (2, S) [state, src kind],
    breakpoints, integrals (4, 2(2H+1)) [contact, stick, slip, one segment], and
    each breakpoint's polynomial and slope (2, 3 cap + 2)."""
    nc = 2 * H + 1
    cap = 4 * H + 4  # as `capacities`
    S = 2 * (3 * cap + 1)
    return (np.empty((11, nc)), np.empty((3, cap)), np.empty((3, cap), np.int64),
            np.empty((4, S)), np.empty((2, S), np.int64), np.empty(3 * cap + 2),
            np.empty((4, 2 * nc)), np.empty((2, 3 * cap + 2), np.int64))


@njit(cache=True, error_model="numpy")
def periodic_state(Ue, Ve, ku, kv, mu, n0, rest, has_rest, H, T, B16, ws):
    """Regime and state segments of one element (see `contact.exact` for the logic).

    Fills, in the workspace ws: Nc, Lc, Hc, dw/dU, dw/dV of full stick, the roots
    and slopes of n, lo', hi', the segments.  Returns (regime 0 separated / 1 stuck
    / 2 transitions / 3 frictionless, n varies, segment count, r = mu/ku,
    n > 0 throughout, count of n roots).
    """
    wv, rt, sl, sf, si, bp = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5]
    Nc, Lc, Hc = wv[0], wv[1], wv[2]
    r, tang = load_and_band(Ue, Ve, ku, kv, mu, n0, Nc, Lc, Hc)
    varying, n_n, n_l, n_h = band_roots(Nc, Lc, Hc, H, T, rt[0], sl[0], rt[1], sl[1],
                                        rt[2], sl[2], wv[7])
    crosses, in_contact = contact_state(Nc, B16, n_n)
    # np.int64 / np.bool_: typed, not literal arguments (a literal compiles a copy per value)
    maxlo, tlo = band_extreme(Lc, H, rt[1], sl[1], n_l, np.int64(-1), np.bool_(True))
    minhi, thi = band_extreme(Hc, H, rt[2], sl[2], n_h, np.int64(1), np.bool_(False))
    if in_contact and maxlo <= minhi and tang:
        regime = 1
    elif crosses or in_contact:
        regime = 2 if tang else 3
    else:
        regime = 0
    if regime != 2:
        basis_at(tlo, H, wv[3])
        basis_at(thi, H, wv[4])
        w = stuck_slider_one(maxlo, minhi, wv[3], wv[4], r * kv, rest, has_rest, wv[5], wv[6])
        sf[0, 0], sf[1, 0], sf[2, 0] = 0.0, TWO_PI, w
        sf[3, 0] = 0.0 if np.isnan(tlo) else tlo
        si[0, 0] = STICK if regime == 1 else (SEP if regime == 0 else -1)
        si[1, 0] = SRC_LO
        return regime, varying, 1, r, in_contact, n_n
    thi = 0.0 if np.isnan(thi) else thi
    t0 = thi
    if crosses:
        for i in range(n_n):
            if sl[0, i] == 1:
                t0 = rt[0, i]
                break
    bi = ws[7]
    K = breakpoints(t0, rt, sl, n_n, n_l, n_h, bp, bi[0], bi[1])
    nseg = march(Ue, Lc, Hc, Nc, H, bp, bi[0], bi[1], K, crosses, t0, thi, minhi,
                 sf[0], sf[1], si[0], sf[2], sf[3], si[1], wv[8])
    return regime, varying, nseg, r, in_contact, n_n


@njit(cache=True, error_model="numpy")
def contact_integrals(nr, ns, n_n, in_contact, H, X):
    """X = segment integrals over {n > 0}: the full period, or from each upward
    sign change of n to the next sign change."""
    X[:] = 0.0
    if in_contact:
        X[0] = 2.0  # C_0 of the full period: 2 pi / pi
        return
    for i in range(n_n):
        if ns[i] == 1:
            b = nr[(i + 1) % n_n]
            if b <= nr[i]:
                b += TWO_PI
            add_segment_integrals(nr[i], b, H, 1.0, X)


@njit(cache=True, error_model="numpy")
def stick_source_terms(g, w, t, kind, Ue, Ve, ku, kv, r, H, jac, Fu, JU, JV, sx):
    """Subtract one stick phase's ku w g (g = its coefficients of a unit constant)
    and, for the Jacobian, ku g (x) dw/dQ with dw/dU = s(t), dw/dV = aV s(t)."""
    for c in range(g.size):
        Fu[c] -= ku * w * g[c]
    if not jac:
        return
    basis_at(t, H, sx)
    if kind == SRC_LO:
        aV = -r * kv
    elif kind == SRC_HI:
        aV = r * kv
    else:  # touchdown: d tau/dV = -s/v', so dw/dV = -u'/v' s
        aV = -eval012(Ue, H, t)[1] / eval012(Ve, H, t)[1]
    for c in range(g.size):
        for d in range(g.size):
            JU[c, d] -= ku * g[c] * sx[d]
            JV[c, d] -= ku * aV * g[c] * sx[d]


@njit(cache=True, error_model="numpy")
def switching_forces(Ue, Ve, ku, kv, mu, r, H, nseg, ws, jac, Fu, JU, JV):
    """f_u of a cycle with transitions: ku G_stick U + mu G_slip N - sum ku w g."""
    wv, sf, si, X = ws[0], ws[3], ws[4], ws[6]
    Nc, g, sx = wv[0], wv[9], wv[10]
    nc = Ue.size
    X_st, X_sl, Xs = X[1], X[2], X[3]
    X_st[:] = 0.0
    X_sl[:] = 0.0
    g[:] = 0.0
    pending, pw, pt, pk = False, 0.0, 0.0, np.int64(-1)  # typed, not a literal
    for i in range(nseg):
        st, a, b = si[0, i], sf[0, i], sf[1, i]
        if st < 0 or not b > a:
            continue
        if st == PSLIP or st == NSLIP:
            add_segment_integrals(a, b, H, 1.0 if st == PSLIP else -1.0, X_sl)
        elif st == STICK:
            Xs[:] = 0.0
            add_segment_integrals(a, b, H, 1.0, Xs)
            X_st += Xs
            w, t, k = sf[2, i], sf[3, i], si[1, i]
            if pending and not (w == pw and t == pt and k == pk):  # a new stick phase
                stick_source_terms(g, pw, pt, pk, Ue, Ve, ku, kv, r, H, jac, Fu, JU, JV, sx)
                g[:] = 0.0
            pending, pw, pt, pk = True, w, t, k
            g[0] += 0.5 * Xs[0]
            for p in range(1, H + 1):
                g[2 * p - 1] += Xs[p]
                g[2 * p] += Xs[nc + p]
    if pending:
        stick_source_terms(g, pw, pt, pk, Ue, Ve, ku, kv, r, H, jac, Fu, JU, JV, sx)
    gram_apply(X_st, H, Ue, ku, Fu, ku, JU, jac)
    gram_apply(X_sl, H, Nc, mu, Fu, mu * kv, JV, jac)


@njit(cache=True, error_model="numpy")
def element_forces(Ue, Ve, ku, kv, mu, n0, rest, has_rest, H, T, B16, ws, jac, Fu, Fv, JU,
                   JV, JVv):
    """Fu, Fv (zeroed on entry) and, with `jac`, dFu/dU, dFu/dV, dFv/dV of one
    element; returns (regime, n varies)."""
    nc = Ue.size
    regime, varying, nseg, r, in_contact, n_n = periodic_state(
        Ue, Ve, ku, kv, mu, n0, rest, has_rest, H, T, B16, ws)
    wv, rt, sl, sf, X = ws[0], ws[1], ws[2], ws[3], ws[6]
    Nc = wv[0]
    if in_contact:  # f_v = n over the whole period: the Gram matrix is the identity
        for c in range(nc):
            Fv[c] = Nc[c]
            if jac:
                JVv[c, c] = kv
    elif n_n > 0:
        contact_integrals(rt[0], sl[0], n_n, False, H, X[0])
        gram_apply(X[0], H, Nc, 1.0, Fv, kv, JVv, jac)
    if regime == 1:  # fully stuck: f_u = ku (u - w), w from the slider convention
        for c in range(nc):
            Fu[c] = ku * Ue[c]
        Fu[0] -= ku * sf[2, 0]
        if jac:
            for c in range(nc):
                JU[c, c] = ku
                JU[0, c] -= ku * wv[5, c]
                JV[0, c] = -ku * wv[6, c]
    elif regime == 2:
        switching_forces(Ue, Ve, ku, kv, mu, r, H, nseg, ws, jac, Fu, JU, JV)
    return regime, varying


@njit(cache=True, nogil=True, error_model="numpy")
def forces_all(U, V, ku, kv, mu, n0, rest, has_rest, T, B16, jac, F, J, regime, varying):
    """`element_forces` for every element (rows of U, V) into F (E, 2, 2H+1) = (f_u,
    f_v) and J (E, 3, 2H+1, 2H+1) = (dFu/dU, dFu/dV, dFv/dV); J written only with
    `jac` (else it may be a (1, 3, 2H+1, 2H+1) placeholder).  Serial (a `prange`
    loop was slower on a shared 2-core machine); the GIL is released, so threads may
    evaluate separate batches at once."""
    H = (U.shape[1] - 1) // 2
    ws = workspace(H)
    for e in range(U.shape[0]):
        j = e if jac else 0
        regime[e], varying[e] = element_forces(
            U[e], V[e], ku[e], kv[e], mu[e], n0[e], rest[e], has_rest, H, T, B16, ws, jac,
            F[e, 0], F[e, 1], J[j, 0], J[j, 1], J[j, 2])


@njit(cache=True, nogil=True, error_model="numpy")
def segments_all(U, V, ku, kv, mu, n0, rest, has_rest, T, B16, a, b, state, w, regime):
    """Periodic state segments of every element, rows (E, S) padded with state -1."""
    H = (U.shape[1] - 1) // 2
    ws = workspace(H)
    sf, si = ws[3], ws[4]
    for e in range(U.shape[0]):
        regime[e], _v, nseg, _r, _c, _n = periodic_state(
            U[e], V[e], ku[e], kv[e], mu[e], n0[e], rest[e], has_rest, H, T, B16, ws)
        for i in range(nseg):  # element by element: a slice copy compiles a shape check
            a[e, i], b[e, i], w[e, i], state[e, i] = sf[0, i], sf[1, i], sf[2, i], si[0, i]
