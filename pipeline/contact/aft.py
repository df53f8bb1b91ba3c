"""Alternating frequency-time (AFT) Yang-Menq forces: the cross-check and fallback.

Samples u, v at N equispaced tau, marches the element law of Eq. 9-10 sample by
sample, and projects the forces back with the discrete Fourier transform.  The
law is the play operator of `contact.exact` on samples: in contact (n_i > 0)
w_i = clamp(w_{i-1}, lo_i, hi_i); separated samples reset w_i = u_i (spring
unstrained at touchdown).  The periodic history is found the same way, discretely:
start at a separated sample, or, in full contact, at argmin hi with w = min hi
(the discrete play operator forgets its start there too), or, where
max lo <= min hi, take the full-stick state fixed by `YangMenq.slider_rest`.
So one pass over N samples gives the periodic history, not a march to convergence.

Jacobian: f_u,i = ku (u_i - w_i) with w_i set at sample j(i) as lo_j, hi_j or u_j
(or the cycle mean), so df_u,i/dQ is a combination of the basis at samples i and
j(i); the stick history is carried by the index j(i).

`aft_forces` evaluates the elements with friction (mu, ku > 0) and the default stuck
rest by the compiled march of the 2D law with the second tangent at rest
(`friction2d.kernel.march`: the same rules sample for sample, its band middle the
centre of the stick discs), and the others (frictionless, or a given `slider_rest`)
by this module's play operator (`play_forces`), which also cross-checks the
compiled march (tests/contact/test_friction2d.py).
"""
from __future__ import annotations

import numpy as np

from .element import (SRC_HI, SRC_LO, SRC_TD, ContactForces, YangMenq, stuck_forces,
                      stuck_slider)
from ..fourier.harmonics import harmonics_of, time_grid
from .friction2d.kernel import march


def play_march(lo, hi, u, contact, i0, w0, k0):
    """Discrete play operator over one period from sample i0 with w = w0 (kind k0).

    lo, hi, u: (E, N); contact: (E, N) bool.  Returns w (E, N), and for each sample
    the sample index and kind (LO/HI/TD) where its w was set.  This is the one
    inherently sequential piece of the AFT evaluation.
    """
    E, N = u.shape
    order = (i0[:, None] + np.arange(N)) % N  # each element starts at its own i0
    # time-major copies so that each step reads contiguous rows
    L, Hh, Uu, C = (np.take_along_axis(x, order, 1).T.copy() for x in (lo, hi, u, contact))
    w, src, kind = np.empty((N, E)), np.empty((N, E), int), np.empty((N, E), int)
    wc, sc, kc = w0.astype(float).copy(), np.zeros(E, int), k0.copy()
    for i in range(N):
        c = C[i]
        low = c & (wc < L[i])
        high = c & (wc > Hh[i])
        sep = ~c
        wc = np.where(low, L[i], np.where(high, Hh[i], np.where(sep, Uu[i], wc)))
        moved = low | high | sep
        sc[moved] = i
        kc = np.where(low, SRC_LO, np.where(high, SRC_HI, np.where(sep, SRC_TD, kc)))
        w[i], src[i], kind[i] = wc, sc, kc
    back = np.argsort(order, axis=1)
    src = np.take_along_axis(order, src.T, 1)  # rolled sample index -> true index
    return (np.take_along_axis(w.T, back, 1), np.take_along_axis(src, back, 1),
            np.take_along_axis(kind.T, back, 1))


def aft_forces(U, V, elem: YangMenq, N: int, jacobian: bool = True) -> ContactForces:
    """AFT Fourier coefficients of f_u, f_v with N samples, and their Jacobian: the
    compiled march where it applies (module doc), else `play_forces`."""
    E, nc = U.shape
    fast = (elem.mu > 0) & (elem.ku > 0)
    if elem.slider_rest is not None or not fast.all():
        return play_forces(U, V, elem, N, jacobian)
    X = np.zeros((E, 3, nc))
    X[:, 0], X[:, 2] = U, V
    c = march(np.stack([elem.ku, elem.ku], axis=1), elem.kv, elem.mu, elem.n0, X, int(N),
              jacobian, planar=False)
    contact = c.state != 0
    stuck = (c.state == 1).all(axis=1)
    regimes = {"separated": int((~contact.any(1)).sum()), "stuck": int(stuck.sum()),
               "transitions": int((contact.any(1) & ~stuck).sum()), "frictionless": 0}
    if not jacobian:
        return ContactForces(c.F[:, 0], c.F[:, 2], None, None, None, regimes)
    return ContactForces(c.F[:, 0], c.F[:, 2], c.J[:, 0], c.J[:, 2], c.J[:, 6], regimes)


def play_forces(U, V, elem: YangMenq, N: int, jacobian: bool = True) -> ContactForces:
    """AFT Fourier coefficients of f_u, f_v with N samples, and their Jacobian, by the
    play operator (module doc): every element, frictionless and given rests too."""
    E, nc = U.shape
    H = harmonics_of(nc)
    tau, S, W = time_grid(H, N)
    ku, kv, mu, n0 = elem.ku, elem.kv, elem.mu, elem.n0
    tang = (mu > 0) & (ku > 0)
    r = np.where(tang, mu / np.where(ku > 0, ku, 1.0), 0.0)
    u, v = U @ S.T, V @ S.T
    n = n0[:, None] + kv[:, None] * v
    contact = n > 0
    lo, hi = u - r[:, None] * n, u + r[:, None] * n
    rows = np.arange(E)

    any_sep = ~contact.all(1)
    maxlo, minhi = lo.max(1), hi.min(1)
    stuck = ~any_sep & (maxlo <= minhi) & tang
    i_lo, i_hi = lo.argmax(1), hi.argmin(1)
    # where lo (hi) is constant its extremum is everywhere: derivative e0 (mean)
    e0 = np.eye(nc)[0]
    s_lo = np.where((np.ptp(lo, axis=1) == 0)[:, None], e0, S[i_lo])
    s_hi = np.where((np.ptp(hi, axis=1) == 0)[:, None], e0, S[i_hi])
    w_st, dwdU, dwdV = stuck_slider(elem, maxlo, minhi, s_lo, s_hi)

    i0 = np.where(any_sep, np.argmax(~contact, axis=1), i_hi)
    w0 = np.where(any_sep, u[rows, i0], minhi)
    k0 = np.where(any_sep, SRC_TD, SRC_HI)
    mar = np.flatnonzero(tang & ~stuck & contact.any(1))
    w = np.broadcast_to(w_st[:, None], (E, N)).copy()
    src = np.broadcast_to(i_lo[:, None], (E, N)).copy()
    kind = np.full((E, N), SRC_LO)
    if mar.size:
        w[mar], src[mar], kind[mar] = play_march(lo[mar], hi[mar], u[mar], contact[mar],
                                                 i0[mar], w0[mar], k0[mar])
    act = contact & tang[:, None]
    fu = np.where(act, ku[:, None] * (u - w), 0.0)
    fv = np.where(contact, n, 0.0)
    Fu, Fv = fu @ W.T, fv @ W.T
    regimes = {"separated": int((~contact.any(1)).sum()), "stuck": int(stuck.sum()),
               "transitions": int(mar.size),
               "frictionless": int((~tang & contact.any(1)).sum())}
    if not jacobian:
        return ContactForces(Fu, Fv, None, None, None, regimes)

    # df_u,i/dU = ku (s_i - dw_i/dU), df_u,i/dV = -ku dw_i/dV, with dw_i = a * s_src
    aV = np.where(kind == SRC_LO, -(r * kv)[:, None], np.where(kind == SRC_HI, (r * kv)[:, None], 0.0))
    Ssrc = S[src]  # (E, N, 2H+1)
    WA = W.T[None] * (act * ku[:, None])[..., None]  # (E, N, 2H+1): row weights
    dFu_dU = np.einsum("enk,nj->ekj", WA, S) - np.einsum("enk,enj->ekj", WA, Ssrc)
    dFu_dV = -np.einsum("enk,enj->ekj", WA * aV[..., None], Ssrc)
    WC = W.T[None] * (contact * kv[:, None])[..., None]
    dFv_dV = np.einsum("enk,nj->ekj", WC, S)
    st_rows = np.flatnonzero(stuck)
    if st_rows.size:  # fully stuck: closed form, w from the convention (two sources)
        _, dFu_dU[st_rows], dFu_dV[st_rows] = stuck_forces(U, elem, w_st, dwdU, dwdV, st_rows)
    return ContactForces(Fu, Fv, dFu_dU, dFu_dV, dFv_dV, regimes)
