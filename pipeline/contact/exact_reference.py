"""Test reference only: the exact Yang-Menq forces in numpy (paper Sec. 4, Eq. 9-11);
at run time `contact.exact` evaluates the same mathematics compiled; tests compare them.

The element as a play operator.  With the band
    lo(tau) = u - (mu/ku) n,   hi(tau) = u + (mu/ku) n,   n = n0 + kv v   (Eq. 1)
the slider position w (f_u = ku (u - w), Eq. 9) obeys, in contact (n > 0),
w = clamp(w, lo, hi): stick while lo < w < hi, positive slip w = lo, negative slip
w = hi; in separation (n <= 0) f_u = f_v = 0 and the spring restarts unstrained at
touchdown, w = u(tau_td) (Sec. 4.1).  The paper's switching equations are the same
events: PS -> stick where lo' = u' - mu kv/ku v' = 0 (lo maximal, Sec. 4.2), NS ->
stick where hi' = 0 (Sec. 4.3), stick -> PS/NS where lo = w / hi = w, i.e.
ku u -+ mu kv v + (f0 -+ mu n0 - ku u0) = 0 with w = u0 - f0/ku (Sec. 4.4).

Transition times: the sign changes of n, lo' and hi' (trigonometric polynomials
of degree H) are found by `trigroots.sign_changes`, which provably misses none.
Between consecutive such breakpoints n keeps its sign and lo, hi are monotone, so
at most one stick -> slip event occurs in each (slips end only at breakpoints);
it is the single root of the monotone lo - w (or hi - w) on that interval.

The periodic (steady-state) history is found directly, not by marching to
convergence:
  * n changes sign: a touchdown erases all memory; start there.
  * n > 0 throughout and max lo <= min hi: every w in [max lo, min hi] is a
    periodic full-stick state; `YangMenq.slider_rest` picks one.
  * n > 0 throughout and max lo > min hi: any trajectory that passes argmax lo and
    then argmin hi leaves argmin hi with w = min hi (w can only decrease by being
    clamped to hi, and hi >= min hi), so the periodic state starts there in
    negative slip with w = hi(tau_b).
Fourier integrals (Eq. 11) of each piece (a trigonometric polynomial times the
basis) are closed form.  Forces are continuous at every transition, so the exact
Jacobian is the integral of the piecewise derivative plus the derivative of each
stick phase's w with respect to the coefficients, taken where it was set (lo, hi
stationary there; at touchdown dtau/dV = -s(tau)/v').
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .element import (NSLIP, PSLIP, SEP, SRC_HI, SRC_LO, SRC_TD, STICK, ContactForces,
                      YangMenq, check_coefficients, history_from_segments, stuck_forces,
                      stuck_slider)
from ..fourier.harmonics import basis, derivative, harmonics_of
from ..fourier.trigroots import TWO_PI, polish_root, sign_changes


# --------------------------------------------------------------------------
# closed-form Fourier integrals of piecewise trigonometric polynomials
# --------------------------------------------------------------------------

def segment_integrals(a, b, H):
    """X = [C_0..C_2H, S_0..S_2H] with C_m = 1/pi int_a^b cos(m t), S_m likewise.

    In product form, sin(mb) - sin(ma) = 2 cos(m c) sin(m h) and cos(ma) - cos(mb)
    = 2 sin(m c) sin(m h) with c = (a+b)/2, h = (b-a)/2: the plain differences lose
    all digits of a short segment (a stick arc of length ~ sqrt(mu n/(ku |u|))
    carries a force ~ ku |u| times them).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    mid, half = basis(0.5 * (a + b), 2 * H), basis(0.5 * (b - a), 2 * H)
    m = np.arange(1, 2 * H + 1, dtype=float)
    X = np.empty(np.shape(a) + (2 * (2 * H + 1),))
    n = 2 * H + 1
    X[..., 0] = (b - a) / np.pi
    X[..., 1:n] = 2 * mid[..., 1::2] * half[..., 2::2] / (m * np.pi)
    X[..., n] = 0.0
    X[..., n + 1:] = 2 * mid[..., 2::2] * half[..., 2::2] / (m * np.pi)
    return X


@lru_cache(maxsize=None)
def _gram_tables(H):
    """Index tables so that gram(X)[k, j] = w_k/pi-normalised int s_k s_j (see gram)."""
    n = 2 * H + 1
    i1 = np.zeros((n, n), int); i2 = np.zeros((n, n), int)
    a1 = np.zeros((n, n)); a2 = np.zeros((n, n))
    C = lambda m: abs(m)            # noqa: E731  index of C_|m|
    S = lambda m: n + abs(m)        # noqa: E731  index of S_|m|
    sgn = lambda m: float(np.sign(m))  # noqa: E731
    for k in range(n):
        p, kc = (k + 1) // 2, (k % 2 == 1)
        for j in range(n):
            q, jc = (j + 1) // 2, (j % 2 == 1)
            if k == 0 and j == 0:
                i1[k, j], a1[k, j] = C(0), 0.5
            elif k == 0:
                i1[k, j], a1[k, j] = (C(q) if jc else S(q)), 0.5
            elif j == 0:
                i1[k, j], a1[k, j] = (C(p) if kc else S(p)), 1.0
            elif kc and jc:
                i1[k, j], a1[k, j], i2[k, j], a2[k, j] = C(p - q), 0.5, C(p + q), 0.5
            elif kc and not jc:
                i1[k, j], a1[k, j], i2[k, j], a2[k, j] = S(q + p), 0.5, S(q - p), 0.5 * sgn(q - p)
            elif not kc and jc:
                i1[k, j], a1[k, j], i2[k, j], a2[k, j] = S(p + q), 0.5, S(p - q), 0.5 * sgn(p - q)
            else:
                i1[k, j], a1[k, j], i2[k, j], a2[k, j] = C(p - q), 0.5, C(p + q), -0.5
    for t in (i1, i2, a1, a2):
        t.setflags(write=False)
    return i1, i2, a1, a2


def gram(X, H):
    """G (..., 2H+1, 2H+1): coefficients of f = s.P on a set with integrals X are G @ P.

    G[k, j] = c_k int s_k s_j, c_0 = 1/(2 pi), c_k = 1/pi (Eq. 11 normalised to the
    layout of harmonics.py).
    """
    i1, i2, a1, a2 = _gram_tables(H)
    return a1 * X[..., i1] + a2 * X[..., i2]


def gram_column0(X, H):
    """gram(X)[..., :, 0]: the coefficients of a unit constant on the set."""
    n = 2 * H + 1
    g = np.empty(X.shape[:-1] + (n,))
    g[..., 0] = 0.5 * X[..., 0]
    g[..., 1::2] = X[..., 1:H + 1]
    g[..., 2::2] = X[..., n + 1:n + H + 1]
    return g


# --------------------------------------------------------------------------
# periodic state sequence
# --------------------------------------------------------------------------

def _ev(P, tau, order=0):
    H = harmonics_of(P.shape[-1])
    return np.einsum("ec,ec->e", basis(tau, H, order), P)


def _crossing(P, w, a, b):
    """First tau in [a, b] where the increasing p(tau) = s.P reaches w (p(b) >= w)."""
    Q = P.copy()
    Q[:, 0] -= w
    at_start = _ev(Q, a) >= 0
    t = a.copy()
    idx = np.flatnonzero(~at_start)
    if idx.size:
        t[idx] = polish_root(Q[idx], a[idx].copy(), b[idx].copy(), -np.ones(idx.size, int))
    return t


def _first_root(roots, slope, want):
    """First root (in tau order) with the given slope sign, NaN where none."""
    ok = (slope == want) & ~np.isnan(roots)
    first = np.argmax(ok, axis=1)
    return np.where(ok.any(1), roots[np.arange(len(roots)), first], np.nan)


def _extreme(P, roots, slope, want, pick):
    """Value and location of the extremum of p over its stationary points (derivative
    roots with slope `want`); p constant -> (p0, NaN): the extremum is attained
    everywhere (see `_extreme_basis`)."""
    if roots.shape[1] == 0:
        return P[:, 0].copy(), np.full(len(P), np.nan)
    vals = np.full(roots.shape, np.nan)
    ok = (slope == want) & ~np.isnan(roots)
    r, c = np.nonzero(ok)
    vals[r, c] = _ev(P[r], roots[r, c])
    has = ok.any(1)
    idx = np.where(has, pick(np.where(ok, vals, -np.inf if pick is np.argmax else np.inf), axis=1), 0)
    rows = np.arange(len(P))
    val = np.where(has, vals[rows, idx], P[:, 0])
    loc = np.where(has, roots[rows, idx], np.nan)
    return val, loc


def _extreme_basis(t, H):
    """d(extremum)/d(coefficients) = basis at its location t; where p is constant
    (t NaN, e.g. zero motion) the extremum is attained everywhere and the
    derivative consistent with small symmetric motion is the mean, e0."""
    B = basis(np.nan_to_num(t), H)
    B[np.isnan(t)] = np.eye(2 * H + 1)[0]
    return B


def periodic_segments(U, V, elem: YangMenq):
    """Steady-state state sequence of every element over one period.

    Returns a dict of arrays (E, S): `a`, `b` (segment limits, tau in
    [t0, t0 + 2 pi)), `state` (SEP/STICK/PSLIP/NSLIP, -1 = unused), `w` (slider
    position of stick segments), `src_tau`, `src_kind` (where w was set), plus per
    element `regime` (0 separated, 1 stuck, 2 transitions) and the band/normal-load
    coefficients `Lc`, `Hc`, `Nc`.
    """
    E, nc = U.shape
    H = harmonics_of(nc)
    ku, kv, mu, n0 = elem.ku, elem.kv, elem.mu, elem.n0
    Nc = kv[:, None] * V
    Nc[:, 0] += n0
    tang = (mu > 0) & (ku > 0)
    r = np.where(tang, mu / np.where(ku > 0, ku, 1.0), 0.0)
    Lc, Hc = U - r[:, None] * Nc, U + r[:, None] * Nc

    # Only a varying normal load n(t) = n0 + kv v(t) is searched for zeros (separation);
    # with a constant one (kv = 0: the Jenkins path) the band edges lo, hi move with
    # u(t) alone, so their extremes are the roots of u'(t), found once.
    iv = np.flatnonzero(np.any(Nc[:, 1:] != 0.0, axis=1))
    roots, slope = sign_changes(np.concatenate([Nc[iv], derivative(Lc), derivative(Hc)[iv]]))
    m = iv.size
    nr, ns = np.full((E, roots.shape[1]), np.nan), np.zeros((E, roots.shape[1]), dtype=int)
    nr[iv], ns[iv] = roots[:m], slope[:m]
    lr, ls = roots[m:m + E], slope[m:m + E]
    hr, hs = lr.copy(), ls.copy()
    hr[iv], hs[iv] = roots[m + E:], slope[m + E:]
    crosses = ~np.isnan(nr).all(1)
    grid = TWO_PI * np.arange(16) / 16
    nvals = Nc @ basis(grid, H).T
    positive = nvals[np.arange(E), np.argmax(np.abs(nvals), 1)] > 0
    in_contact = ~crosses & positive

    maxlo, tlo = _extreme(Lc, lr, ls, -1, np.argmax)
    minhi, thi = _extreme(Hc, hr, hs, +1, np.argmin)
    stuck = in_contact & (maxlo <= minhi) & tang
    # 0 separated, 1 stuck, 2 transitions, 3 frictionless contact (f_u = 0)
    regime = np.where(stuck, 1, np.where(crosses | in_contact, np.where(tang, 2, 3), 0))

    # full stick: w in [max lo, min hi] by the convention of YangMenq.slider_rest
    w_st, dwdU, dwdV = stuck_slider(elem, maxlo, minhi, _extreme_basis(tlo, H),
                                    _extreme_basis(thi, H))
    kind = np.full(E, SRC_LO)
    src_tau = np.nan_to_num(tlo)
    thi = np.nan_to_num(thi)

    march = np.flatnonzero(regime == 2)
    out = dict(regime=regime, Lc=Lc, Hc=Hc, Nc=Nc, tang=tang, H=H, normal_searched=m,
               contact_all=in_contact, n_roots=nr, n_slope=ns,
               stuck_w=w_st, stuck_dwdU=dwdU, stuck_dwdV=dwdV)
    S_st = dict(a=np.zeros((E, 1)), b=np.full((E, 1), TWO_PI),
                state=np.where(regime == 1, STICK, np.where(regime == 0, SEP, -1))[:, None],
                w=w_st[:, None], src_tau=src_tau[:, None], src_kind=kind[:, None])
    if march.size == 0:
        out.update(S_st)
        return out
    seg = _march(U[march], Lc[march], Hc[march], Nc[march], nr[march], ns[march],
                 lr[march], hr[march], crosses[march], thi[march], minhi[march])
    S = seg["a"].shape[1]
    for k, v in S_st.items():
        full = np.zeros((E, S), dtype=v.dtype)
        if k == "state":
            full[:] = -1
        full[:, :1] = v
        full[march] = seg[k]
        out[k] = full
    return out


def _ev_grid(P, tau, order=0):
    """p^(order) at tau (E, K) for rows P (E, 2H+1): (E, K)."""
    H = harmonics_of(P.shape[-1])
    return np.matmul(basis(tau, H, order), P[:, :, None])[..., 0]


def _ev_many(Ps, tau, orders):
    """Several polynomials (rows (E, 2H+1) each) at the same tau (E, K), sharing one
    cos/sin table: [p^(order) for p, order in zip(Ps, orders)], each (E, K)."""
    H = harmonics_of(Ps[0].shape[-1])
    B0 = basis(tau, H)
    out = []
    for P, o in zip(Ps, orders):
        if o == 0:
            out.append(np.matmul(B0, P[:, :, None])[..., 0])
        else:  # first derivative from the same table: d/dtau (c, s) = j (-s, c)
            j = np.arange(1, H + 1, dtype=float)
            D = np.zeros_like(P)
            D[:, 1::2], D[:, 2::2] = j * P[:, 2::2], -j * P[:, 1::2]
            out.append(np.matmul(B0, D[:, :, None])[..., 0])
    return out


_PROBES = (0.5, 0.5 - 0.5 / np.sqrt(5), 0.5 + 0.5 / np.sqrt(5))


def _interval_signs(Ps, orders, bp):
    """Sign (+1/-1/0) of each p^(order) on each interval between breakpoints bp.

    The sign is constant inside an interval (no sign change there), but p may touch
    zero at isolated points (tangencies), possibly at the midpoint; so p is probed at
    three interior points and the value of largest magnitude decides.
    """
    a, b = bp[:, :-1], bp[:, 1:]
    vals = [_ev_many(Ps, a + f * (b - a), orders) for f in _PROBES]  # [probe][poly]
    out = []
    for k in range(len(Ps)):
        v = np.stack([vals[i][k] for i in range(len(_PROBES))])
        pick = np.argmax(np.abs(v), axis=0)
        out.append(np.sign(np.take_along_axis(v, pick[None], 0)[0]))
    return out


def _march(U, Lc, Hc, Nc, nr, ns, lr, hr, crosses, thi, minhi):
    """State sequence over one period for elements that switch (see module doc).

    Everything that does not depend on the state (signs at interval midpoints,
    lo/hi/u at breakpoints) is evaluated for all intervals at once; the loop over
    intervals is cheap logic; all stick -> slip crossings are solved in one batch.
    """
    E = U.shape[0]
    t0 = np.where(crosses, _first_root(nr, ns, +1), thi)
    allr = np.concatenate([nr, lr, hr], axis=1)
    rel = np.sort(np.where(np.isnan(allr), TWO_PI, np.mod(allr - t0[:, None], TWO_PI)), axis=1)
    bp = np.concatenate([np.zeros((E, 1)), rel, np.full((E, 1), TWO_PI)], axis=1)
    nonempty = (np.diff(bp, axis=1) > 0).any(0)
    K = int(np.flatnonzero(nonempty).max()) + 1 if nonempty.any() else 1
    bp = t0[:, None] + bp[:, :K + 1]
    act_all = bp[:, 1:] > bp[:, :-1]
    n_sign, lp_all, hp_all = _interval_signs((Nc, Lc, Hc), (0, 1, 1), bp)
    contact_all = n_sign > 0
    lo_bp, hi_bp, u_bp = _ev_many((Lc, Hc, U), bp, (0, 0, 0))

    state = np.where(crosses, SEP, NSLIP)
    w = np.where(crosses, 0.0, minhi)
    src_t = np.where(crosses, t0, thi)
    src_k = np.where(crosses, SRC_TD, SRC_HI)
    st1, w1, srt, srk = (np.empty((E, K), int), np.empty((E, K)), np.empty((E, K)),
                         np.empty((E, K), int))
    st2 = np.full((E, K), -1, dtype=int)
    for k in range(K):
        act, contact = act_all[:, k], contact_all[:, k]
        lp, hp = lp_all[:, k], hp_all[:, k]
        on = act & contact
        td = on & (state == SEP)
        end_ps = on & (state == PSLIP) & (lp <= 0)
        end_ns = on & (state == NSLIP) & (hp >= 0)
        w = np.where(td, u_bp[:, k], np.where(end_ps, lo_bp[:, k], np.where(end_ns, hi_bp[:, k], w)))
        src_t = np.where(td | end_ps | end_ns, bp[:, k], src_t)
        src_k = np.where(td, SRC_TD, np.where(end_ps, SRC_LO, np.where(end_ns, SRC_HI, src_k)))
        state = np.where(td, np.where(lp > 0, PSLIP, np.where(hp < 0, NSLIP, STICK)), state)
        state = np.where(end_ps | end_ns, STICK, state)
        state = np.where(act & ~contact, SEP, state)
        st = act & (state == STICK)
        to_ps = st & (lp > 0) & (lo_bp[:, k + 1] >= w)
        to_ns = st & (hp < 0) & (hi_bp[:, k + 1] <= w)
        both = np.flatnonzero(to_ps & to_ns)  # band closing on w from both sides: rare
        if both.size:
            a, b = bp[both, k], bp[both, k + 1]
            first_ps = (_crossing(Lc[both], w[both], a, b)
                        <= _crossing(-Hc[both], -w[both], a, b))
            to_ps[both], to_ns[both] = first_ps, ~first_ps
        st1[:, k] = np.where(act, state, -1)
        w1[:, k], srt[:, k], srk[:, k] = w, src_t, src_k
        st2[:, k] = np.where(to_ps, PSLIP, np.where(to_ns, NSLIP, -1))
        state = np.where(to_ps, PSLIP, np.where(to_ns, NSLIP, state))

    te = bp[:, 1:].copy()  # crossing times, solved together
    for target, sign, P in ((PSLIP, 1.0, Lc), (NSLIP, -1.0, Hc)):
        e, k = np.nonzero(st2 == target)
        if e.size:
            te[e, k] = _crossing(sign * P[e], sign * w1[e, k], bp[e, k], bp[e, k + 1])
    a2 = np.stack([bp[:, :-1], te], axis=2).reshape(E, 2 * K)
    b2 = np.stack([te, bp[:, 1:]], axis=2).reshape(E, 2 * K)
    return dict(a=a2, b=b2,
                state=np.stack([st1, st2], axis=2).reshape(E, 2 * K),
                w=np.repeat(w1, 2, axis=1), src_tau=np.repeat(srt, 2, axis=1),
                src_kind=np.repeat(srk, 2, axis=1))


# --------------------------------------------------------------------------
# forces and Jacobian
# --------------------------------------------------------------------------

def _contact_integrals(nr, ns, contact_all, H):
    """Sum of segment integrals over {n > 0} from the sign changes of n; (E, 2(2H+1))."""
    E = nr.shape[0]
    X = np.zeros((E, 2 * (2 * H + 1)))
    X[contact_all, 0] = 2.0  # full period: C_0 = 2 pi / pi
    idx = np.flatnonzero(~np.isnan(nr).all(1))
    if idx.size:
        roots, slope = nr[idx], ns[idx]
        cnt = (~np.isnan(roots)).sum(1)
        R = roots.shape[1]
        nxt = (np.arange(R)[None, :] + 1) % np.maximum(cnt, 1)[:, None]
        rows = np.arange(idx.size)[:, None]
        b = roots[rows, nxt]
        b = np.where(b <= roots, b + TWO_PI, b)
        up = (slope == 1) & ~np.isnan(roots)
        Xs = segment_integrals(np.where(up, roots, 0.0), np.where(up, b, 0.0), H)
        X[idx] = Xs.sum(1)
    return X


def _rowsum(values, rows, E):
    """out[e] = sum of values[i] with rows[i] == e, for rows sorted ascending."""
    out = np.zeros((E,) + values.shape[1:])
    if rows.size:
        starts = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]])
        out[rows[starts]] = np.add.reduceat(values, starts, axis=0)
    return out


def _mv(A, x):
    """Batched matrix-vector product (E, m, n) @ (E, n) -> (E, m)."""
    return np.matmul(A, x[..., None])[..., 0]


def exact_forces(U, V, elem: YangMenq, jacobian: bool = True) -> ContactForces:
    """Exact Fourier coefficients of f_u, f_v (Eq. 9-11) and their Jacobian."""
    E, nc = U.shape
    H = harmonics_of(nc)
    seg = periodic_segments(U, V, elem)
    ku, kv, mu = elem.ku, elem.kv, elem.mu
    Nc, regime = seg["Nc"], seg["regime"]
    # normal force: on {n > 0}
    Xc = _contact_integrals(seg["n_roots"], seg["n_slope"], seg["contact_all"], H)
    Gc = gram(Xc, H)
    Fv = _mv(Gc, Nc)

    # tangential force: integrals only over the segments in use (padding skipped)
    state, a, b, tang = seg["state"], seg["a"], seg["b"], seg["tang"]
    used = (state >= 0) & (b > a) & tang[:, None] & (regime == 2)[:, None]
    e_i, s_i = np.nonzero(used)
    st_u = state[e_i, s_i]
    Xs = segment_integrals(a[e_i, s_i], b[e_i, s_i], H)        # (Nu, n2)
    sign = np.where(st_u == PSLIP, 1.0, np.where(st_u == NSLIP, -1.0, 0.0))
    stick = st_u == STICK
    X_st = _rowsum(Xs[stick], e_i[stick], E)
    X_sl = _rowsum(Xs * sign[:, None], e_i, E)
    G_st, G_sl = gram(X_st, H), gram(X_sl, H)
    es, ss = e_i[stick], s_i[stick]
    g = gram_column0(Xs[stick], H)                             # (Nst, 2H+1)
    Fu = ku[:, None] * _mv(G_st, U) + mu[:, None] * _mv(G_sl, Nc)
    Fu -= _rowsum((ku[es] * seg["w"][es, ss])[:, None] * g, es, E)
    regimes = {"separated": int((regime == 0).sum()), "stuck": int((regime == 1).sum()),
               "transitions": int((regime == 2).sum()), "frictionless": int((regime == 3).sum()),
               "normal_load_searched": int(seg["normal_searched"])}
    st_rows = np.flatnonzero(regime == 1)
    if not jacobian:
        if st_rows.size:
            Fu[st_rows] = stuck_forces(U, elem, seg["stuck_w"], seg["stuck_dwdU"],
                                       seg["stuck_dwdV"], st_rows)[0]
        return ContactForces(Fu, Fv, None, None, None, regimes)

    # dw/dU = s(t_src), dw/dV = s(t_src) * aV for the stick phases of switching cycles
    kind, ts = seg["src_kind"][es, ss], seg["src_tau"][es, ss]
    r = np.where(tang, mu / np.where(ku > 0, ku, 1.0), 0.0)[es]
    Sx = basis(ts, H)                                          # (Nst, 2H+1)
    aV = np.where(kind == SRC_LO, -r * kv[es], np.where(kind == SRC_HI, r * kv[es], 0.0))
    td = np.flatnonzero(kind == SRC_TD)
    if td.size:
        B1 = basis(ts[td], H, 1)
        ud = np.einsum("kc,kc->k", B1, U[es[td]])
        vd = np.einsum("kc,kc->k", B1, V[es[td]])
        aV[td] = -ud / vd
    outer = g[:, :, None] * Sx[:, None, :] * ku[es][:, None, None]   # ku g (x) s(t_src)
    dFu_dU = ku[:, None, None] * G_st
    dFu_dV = (mu * kv)[:, None, None] * G_sl
    dFu_dU -= _rowsum(outer, es, E)
    dFu_dV -= _rowsum(outer * aV[:, None, None], es, E)
    dFv_dV = kv[:, None, None] * Gc
    if st_rows.size:  # fully stuck: closed form, w from the convention (two sources)
        Fu[st_rows], dFu_dU[st_rows], dFu_dV[st_rows] = stuck_forces(
            U, elem, seg["stuck_w"], seg["stuck_dwdU"], seg["stuck_dwdV"], st_rows)
    return ContactForces(Fu, Fv, dFu_dU, dFu_dV, dFv_dV, regimes)


def history(U, V, elem: YangMenq, tau) -> dict:
    """Periodic time history of every element at the instants `tau` (K,), from this
    module's `periodic_segments` (`element.history_from_segments`)."""
    E = elem.size
    U = check_coefficients("U", U, E)
    V = check_coefficients("V", V, E)
    return history_from_segments(U, V, elem, tau, periodic_segments(U, V, elem))
