"""Compiled march of the 2D friction law (`contact.friction2d`): one element, one
period of samples at a time, the return mapping of the Coulomb disc per sample.

State per sample: 0 separated (n <= 0: no force, the slider follows, w = u), 1 stick
(|K (u - w)| <= mu n, K = diag(ku, ku2)), 2 slip (the force returned onto the circle
|f| = mu n, the slider moved along it: `return_gamma`; one stiffness:
w = u - (mu n / ku) e, e the unit trial force)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ...fourier.harmonics import harmonics_of, time_grid
from .centre import centre_derivative, stick_centres

PERIOD_RTOL = 1e-13      # the slider's return to its start, of the largest motion
MAX_PERIODS = 500
CENTRE_RTOL = 1e-11      # a sample inside the stick discs' centre, of the motion + radius:
                         # the Apollonius point of near samples carries ~1e-14 of round-off


@njit(cache=True, error_model="numpy")
def return_gamma(t1, t2, k1, k2, cap):
    """The return mapping onto the disc |f| <= cap from the trial force t outside it:
    f_i = t_i / (1 + g k_i), g >= 0 the root of |f(g)| = cap (the slider moves along
    the force, dw = g f: the closest point to t in the energy norm f K^-1 f).  One
    stiffness: g = (|t| / cap - 1) / k; else Newton on 1 / |f(g)| - 1 / cap (linear in
    g when t lies along one tangent), kept inside the bracket (|t| / cap - 1) / k_i."""
    x = np.sqrt(t1 * t1 + t2 * t2) / cap - 1.0
    lo, hi = x / max(k1, k2), x / min(k1, k2)
    g = lo
    if k1 == k2:
        return g
    for _ in range(100):
        d1, d2 = 1.0 / (1.0 + g * k1), 1.0 / (1.0 + g * k2)
        f1, f2 = t1 * d1, t2 * d2
        size = np.sqrt(f1 * f1 + f2 * f2)
        psi = 1.0 / size - 1.0 / cap
        if psi < 0.0:
            lo = g
        else:
            hi = g
        step = psi * size ** 3 / (k1 * d1 * f1 * f1 + k2 * d2 * f2 * f2)
        new = g - step
        if not lo <= new <= hi:
            new = 0.5 * (lo + hi)
        if abs(new - g) <= 4e-16 * new or hi - lo <= 4e-16 * hi:
            return new
        g = new
    return g


@njit(cache=True, error_model="numpy")
def sample(u1, u2, n, k1, k2, mu, w):
    """The law at one sample from the slider w (2,), updated in place; returns
    (f1, f2, state)."""
    if n <= 0.0:
        w[0], w[1] = u1, u2
        return 0.0, 0.0, 0
    t1, t2 = k1 * (u1 - w[0]), k2 * (u2 - w[1])
    cap = mu * n
    if t1 * t1 + t2 * t2 > cap * cap:
        g = return_gamma(t1, t2, k1, k2, cap)
        f1, f2 = t1 / (1.0 + g * k1), t2 / (1.0 + g * k2)
        w[0], w[1] = u1 - f1 / k1, u2 - f2 / k2
        return f1, f2, 2
    return t1, t2, 1


@njit(cache=True, error_model="numpy")
def slip_derivative(t1, t2, k1, k2, cap, G, h):
    """Linearised return mapping at a slipping sample (trial force t outside the disc):
    dw = du - K^-1 df, df = M dt + h dcap with dt = K (du - dw_prev), M = D - (K D f)
    (D f)^T / q, h = (K D f) cap / q, q = f . K D f, D = diag(1 / (1 + g k_i)).  Writes
    G = K^-1 M K (2, 2) (dw / dw_prev) and h / k_i into h (2,); returns the force and
    the new slider offset from u: (f1, f2)."""
    if k1 == k2:            # the radial return: G = (cap / |t|) P, P = I - e e^T, h = e / k
        size = np.sqrt(t1 * t1 + t2 * t2)
        e1, e2, d = t1 / size, t2 / size, cap / size
        G[0, 0], G[0, 1], G[1, 0], G[1, 1] = d * (1.0 - e1 * e1), -d * e1 * e2, -d * e1 * e2, \
            d * (1.0 - e2 * e2)
        h[0], h[1] = e1 / k1, e2 / k1
        return cap * e1, cap * e2
    g = return_gamma(t1, t2, k1, k2, cap)
    d1, d2 = 1.0 / (1.0 + g * k1), 1.0 / (1.0 + g * k2)
    f1, f2 = t1 * d1, t2 * d2
    a1, a2 = d1 * f1, d2 * f2                  # D f
    b1, b2 = k1 * a1, k2 * a2                  # K D f
    q = f1 * b1 + f2 * b2
    G[0, 0] = d1 - b1 * a1 / q
    G[0, 1] = (-b1 * a2 / q) * k2 / k1
    G[1, 0] = (-b2 * a1 / q) * k1 / k2
    G[1, 1] = d2 - b2 * a2 / q
    h[0], h[1] = a1 * cap / q, a2 * cap / q     # (K D f) cap / (q k_i)
    return f1, f2


@njit(cache=True, error_model="numpy")
def period_map(u1, u2, n, k1, k2, mu, start, ws, A):
    """One period of samples from the slider ws (updated in place to w_N) and
    A = dw_N/dw_0 (2, 2): stick keeps it, slip maps it through G = K^-1 M K
    (`slip_derivative`; one stiffness: (mu n / (ku rho)) P, P = I - e e^T, rho =
    |u - w|), separation zeroes it."""
    N = u1.size
    G = np.empty((2, 2))
    h = np.empty(2)
    A[0, 0], A[0, 1], A[1, 0], A[1, 1] = 1.0, 0.0, 0.0, 1.0
    for k in range(N):
        i = (start + k) % N
        if n[i] <= 0.0:
            ws[0], ws[1] = u1[i], u2[i]
            A[0, 0] = A[0, 1] = A[1, 0] = A[1, 1] = 0.0
            continue
        t1, t2 = k1 * (u1[i] - ws[0]), k2 * (u2[i] - ws[1])
        cap = mu * n[i]
        if t1 * t1 + t2 * t2 > cap * cap:
            f1, f2 = slip_derivative(t1, t2, k1, k2, cap, G, h)
            a00 = G[0, 0] * A[0, 0] + G[0, 1] * A[1, 0]
            a01 = G[0, 0] * A[0, 1] + G[0, 1] * A[1, 1]
            a10 = G[1, 0] * A[0, 0] + G[1, 1] * A[1, 0]
            a11 = G[1, 0] * A[0, 1] + G[1, 1] * A[1, 1]
            A[0, 0], A[0, 1], A[1, 0], A[1, 1] = a00, a01, a10, a11
            ws[0], ws[1] = u1[i] - f1 / k1, u2[i] - f2 / k2


@njit(cache=True, error_model="numpy")
def periodic_cycles(u, n, k, mu, w0, start, iterate, max_periods, tol, w, f, state, periods):
    """For each element e (tangential stiffnesses k[e] (2,)): from the slider w0[e] at
    sample start[e], find the periodic
    start when iterate[e] -- period maps w_0 -> w_N, each followed by a Newton step
    w_0 += (I - A)^-1 (w_N - w_0) while I - A is regular and the steps gain (else the
    plain step w_0 = w_N), until the slider returns to its start (to tol[e]), at most
    max_periods; then one more period stored in w (E, 2, N), f[:, :2] (f: E, >= 2, N),
    state (E, N).  w0 is
    updated to the periodic start; periods (E,) counts the periods marched."""
    E, _, N = u.shape
    ws = np.empty(2)
    A = np.empty((2, 2))
    for e in range(E):
        b = np.array([w0[e, 0], w0[e, 1]])
        p = 0
        if iterate[e]:
            last = np.inf
            while p < max_periods:
                ws[0], ws[1] = b[0], b[1]
                period_map(u[e, 0], u[e, 1], n[e], k[e, 0], k[e, 1], mu[e], start[e], ws, A)
                p += 1
                r0, r1 = ws[0] - b[0], ws[1] - b[1]
                res = max(abs(r0), abs(r1))
                if res <= tol[e]:
                    break
                m00, m01, m10, m11 = 1.0 - A[0, 0], -A[0, 1], -A[1, 0], 1.0 - A[1, 1]
                det = m00 * m11 - m01 * m10
                # Newton while it gains (a slip that barely contracts, det ~ 1e-3, takes
                # thousands of plain periods); a step that did not: the plain one
                if abs(det) > 1e-12 and res < last:
                    b[0] += (m11 * r0 - m01 * r1) / det
                    b[1] += (-m10 * r0 + m00 * r1) / det
                else:
                    b[0], b[1] = ws[0], ws[1]
                last = res
        periods[e] = p
        ws[0], ws[1] = b[0], b[1]
        w0[e, 0], w0[e, 1] = ws[0], ws[1]
        for j in range(N):
            i = (start[e] + j) % N
            f1, f2, s = sample(u[e, 0, i], u[e, 1, i], n[e, i], k[e, 0], k[e, 1], mu[e], ws)
            w[e, 0, i], w[e, 1, i] = ws[0], ws[1]
            f[e, 0, i], f[e, 1, i], state[e, i] = f1, f2, s


@njit(cache=True, error_model="numpy")
def sample_derivative(u1, u2, n, k1, k2, kv, mu, Si, planar, w, dX, d0, G, h):
    """`sample` with forward derivatives of the slider: dX (2, 3 nh) w.r.t. the motion's
    coefficients (tangent 1, tangent 2, normal blocks; not `planar`: the second block
    is left alone) and d0 (2, 2) w.r.t. the start; all updated in place (G (2, 2),
    h (2,): work space).  Returns the state."""
    nh = Si.size
    if n <= 0.0:
        w[0], w[1] = u1, u2
        for j in range(nh):
            dX[0, j], dX[1, j] = Si[j], 0.0
            dX[0, 2 * nh + j] = dX[1, 2 * nh + j] = 0.0
            if planar:
                dX[0, nh + j], dX[1, nh + j] = 0.0, Si[j]
        d0[0, 0] = d0[0, 1] = d0[1, 0] = d0[1, 1] = 0.0
        return 0
    t1, t2 = k1 * (u1 - w[0]), k2 * (u2 - w[1])
    cap = mu * n
    if not t1 * t1 + t2 * t2 > cap * cap:
        return 1
    f1, f2 = slip_derivative(t1, t2, k1, k2, cap, G, h)
    # dw = du - G (du - dw_prev) - (h / k) mu dn, block by block of the columns
    g00, g01, g10, g11 = G[0, 0], G[0, 1], G[1, 0], G[1, 1]
    c0, c1 = h[0] * mu * kv, h[1] * mu * kv
    for j in range(nh):
        s = Si[j]
        r1, r2 = s - dX[0, j], -dX[1, j]                      # tangent 1: du = (s, 0)
        dX[0, j] = s - (g00 * r1 + g01 * r2)
        dX[1, j] = -(g10 * r1 + g11 * r2)
        q = 2 * nh + j                                         # normal: du = 0, dn = kv s
        r1, r2 = -dX[0, q], -dX[1, q]
        dX[0, q] = -(g00 * r1 + g01 * r2) - c0 * s
        dX[1, q] = -(g10 * r1 + g11 * r2) - c1 * s
        if planar:
            q = nh + j                                         # tangent 2: du = (0, s)
            r1, r2 = -dX[0, q], s - dX[1, q]
            dX[0, q] = -(g00 * r1 + g01 * r2)
            dX[1, q] = s - (g10 * r1 + g11 * r2)
    for j in range(2):
        r1, r2 = d0[0, j], d0[1, j]
        d0[0, j] = g00 * r1 + g01 * r2
        d0[1, j] = g10 * r1 + g11 * r2
    w[0], w[1] = u1 - f1 / k1, u2 - f2 / k2
    return 2


@njit(cache=True, error_model="numpy")
def tangential_jacobian(u, n, k, kv, mu, w0, start, fixed, dw0, S, W, planar, J):
    """J[e, p] (p = 0..5: (t1, t1), (t1, t2), (t1, n), (t2, t1), (t2, t2), (t2, n)) of
    the tangential forces over the periodic cycle from w0 at `start`: the start's
    sensitivity is dw0[e] (2, 3 nh), or, where `fixed`, the fixed point (I - A)^-1 B
    of one period (A = dw_N/dw0, B = dw_N/dX), written into dw0 (a first pass).  Not
    `planar` (motion along tangent 1 only, the 1D element): only the blocks (t1, t1)
    and (t1, n), the others being zero."""
    E, _, N = u.shape
    nh = S.shape[1]
    m = 3 * nh
    cols = np.arange(m) if planar else np.concatenate((np.arange(nh), np.arange(2 * nh, m)))
    rows, mc = (2 if planar else 1), cols.size
    w, dX, d0 = np.empty(2), np.empty((2, m)), np.empty((2, 2))
    G, h = np.empty((2, 2)), np.empty(2)
    buf = np.empty((N, rows * mc))      # df of each sample: rows of the product with W
    for e in range(E):
        for rep in range(2 if fixed[e] else 1):
            w[0], w[1] = w0[e, 0], w0[e, 1]
            dX[:] = 0.0
            d0[:] = 0.0
            d0[0, 0] = d0[1, 1] = 1.0
            last = rep == (1 if fixed[e] else 0)
            for step in range(N):
                i = (start[e] + step) % N
                s = sample_derivative(u[e, 0, i], u[e, 1, i], n[e, i], k[e, 0], k[e, 1],
                                      kv[e], mu[e], S[i], planar, w, dX, d0, G, h)
                if not last:
                    continue
                for a in range(rows):
                    ka = k[e, a]
                    if s == 0:
                        buf[i, a * mc:(a + 1) * mc] = 0.0
                        continue
                    da0, da1 = d0[a, 0], d0[a, 1]
                    for c in range(mc):
                        j = c if planar else cols[c]
                        buf[i, a * mc + c] = -ka * (dX[a, j] + da0 * dw0[e, 0, j]
                                                    + da1 * dw0[e, 1, j])
                    for jj in range(nh):      # + ka du_a: column a nh + jj (at c = jj for a = 0)
                        buf[i, a * mc + a * nh + jj] += ka * S[i, jj]
            if not last:      # the fixed point of the period map
                M = np.eye(2) - d0
                if abs(M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]) > 1e-10:
                    Minv = np.linalg.inv(M)
                else:   # a neutral direction (slip one way only): the slider stays put there
                    Minv = np.linalg.pinv(M)
                for j in cols:
                    dw0[e, 0, j] = Minv[0, 0] * dX[0, j] + Minv[0, 1] * dX[1, j]
                    dw0[e, 1, j] = Minv[1, 0] * dX[0, j] + Minv[1, 1] * dX[1, j]
        out = np.dot(W, buf)         # (nh, rows mc): W df
        for a in range(rows):
            for c in range(mc):
                b, jj = cols[c] // nh, cols[c] % nh
                for r in range(nh):
                    J[e, 3 * a + b, r, jj] = out[r, a * mc + c]


# -- the march of one period: periodic start, forces, Jacobian ----------------------

@dataclass(frozen=True)
class Cycle2D:
    """One evaluated period: samples u (E, 2, N), v (E, N), slider w (E, 2, N),
    forces f (E, 3, N), state (E, N) (0 separated, 1 stick, 2 slip), periods marched
    (E,), F (E, 3, 2H+1), J (E, 7, 2H+1, 2H+1) or None, regimes."""

    u: np.ndarray
    v: np.ndarray
    w: np.ndarray
    f: np.ndarray
    state: np.ndarray
    periods: np.ndarray
    F: np.ndarray
    J: np.ndarray | None
    regimes: dict


@njit(cache=True, error_model="numpy")
def cycle_kernel(u, n, k, kv, mu, S, W, jacobian, planar, w, f, state, periods, J):
    """The whole evaluation of `march` past the synthesis, compiled: per element the
    start (a separated sample, else the centre of the stick discs in force units,
    `centre.stick_centres`), the periodic cycle (`periodic_cycles`) into w, f (E, 3, N)
    (the normal force max(n, 0) in row 2), state, periods, and with `jacobian` the
    tangential blocks of J (`tangential_jacobian`, the stuck start's sensitivity from
    `centre.centre_derivative`; not `planar`: the 1D element's blocks only).  Returns
    (separating, stuck, slipping) counts."""
    E, _, N = u.shape
    m = 3 * S.shape[1]
    touch = np.ones(E, np.bool_)
    start = np.zeros(E, np.int64)
    cap, p = np.empty((E, N)), np.empty((E, 2, N))
    ptol, ftol = np.empty(E), np.empty(E)
    for e in range(E):
        umax = pmax = cmax = 0.0
        for i in range(N):
            c = mu[e] * max(n[e, i], 0.0)
            cap[e, i] = c
            f[e, 2, i] = max(n[e, i], 0.0)
            if n[e, i] <= 0.0 and touch[e]:
                touch[e], start[e] = False, i
            for d in range(2):
                p[e, d, i] = k[e, d] * u[e, d, i]
                umax, pmax = max(umax, abs(u[e, d, i])), max(pmax, abs(p[e, d, i]))
            cmax = max(cmax, c)
        ptol[e] = PERIOD_RTOL * (umax + cmax / min(k[e, 0], k[e, 1]) + 1e-300)
        ftol[e] = CENTRE_RTOL * (pmax + cmax + 1e-300)
    y, depth, support = np.empty((E, 2)), np.empty(E), np.empty((E, 3), np.int64)
    stick_centres(p, cap, ftol, y, depth, support)
    stuck = touch & (depth < 0.0)
    iterate = touch & ~stuck
    w0 = np.empty((E, 2))
    for e in range(E):
        for d in range(2):
            w0[e, d] = y[e, d] / k[e, d] if touch[e] else u[e, d, start[e]]
    periodic_cycles(u, n, k, mu, w0, start, iterate, MAX_PERIODS, ptol, w, f, state, periods)
    if jacobian:
        dw0 = np.zeros((E, 2, m))
        centre_derivative(p, y, support, S, k, mu * kv, stuck, dw0)
        tangential_jacobian(u, n, k, kv, mu, w0, start, iterate, dw0, S, W, planar, J)
    return E - touch.sum(), stuck.sum(), iterate.sum()


def march(k, kv, mu, n0, X, N: int, jacobian: bool = True, planar: bool = True) -> "Cycle2D":
    """The periodic cycle of elements with the tangential stiffnesses k (E, 2) [N/m]
    along the two tangents, kv, mu, n0 (E,) for the motion X (E, 3, 2H+1) on N samples
    (`friction2d.law`'s module docstring): also the 1D element's AFT (`contact.aft`),
    with X[:, 1] = 0 and not `planar` (the Jacobian's blocks of tangent 1 and the
    normal only: the others vanish for such motion)."""
    E, _, nh = X.shape
    _, S, W = time_grid(harmonics_of(nh), N)
    u = np.ascontiguousarray(X[:, :2] @ S.T)               # (E, 2, N)
    v = X[:, 2] @ S.T                                      # (E, N)
    n = n0[:, None] + kv[:, None] * v
    w, f, state = np.empty((E, 2, N)), np.empty((E, 3, N)), np.empty((E, N), np.int64)
    periods = np.zeros(E, np.int64)
    J = np.zeros((E, 7, nh, nh)) if jacobian else np.zeros((0, 7, nh, nh))
    sep, stuck, slip = cycle_kernel(u, n, np.ascontiguousarray(k, float), kv, mu, S, W,
                                    bool(jacobian), bool(planar), w, f, state, periods, J)
    if slip and periods.max() >= MAX_PERIODS:
        raise RuntimeError(f"2D friction: the slider did not return to its start in "
                           f"{MAX_PERIODS} periods")
    if jacobian:
        J[:, 6] = (W[None] * ((n > 0.0) * kv[:, None])[:, None, :]) @ S
    regimes = {"separating": int(sep), "stuck": int(stuck), "slipping": int(slip),
               "periods_max": int(periods.max(initial=0))}
    return Cycle2D(u, v, w, f, state, periods, f @ W.T, J if jacobian else None, regimes)
