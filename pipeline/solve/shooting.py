"""The periodic steady state by shooting on the Poincare map of one period.

z = [q, q'/Omega, w_stuck] (`poincare_vector`) is mapped over one period by the
event-driven integration (`period_map`); `newton_step` solves P(z) - z = 0 with a
finite-difference monodromy, `rest_sliders` moves the stuck sliders of an
event-free cycle to the slider_rest convention.  `timesim.steady_state` drives them.
"""
from __future__ import annotations

import numpy as np

from .events import integrate
from .piecewise import STICK


def poincare_vector(mdl, x, w, st):
    """z = [q, q'/Omega, w of the stuck elements (0 for the others)] of a state."""
    return np.concatenate([x[: mdl.n], x[mdl.n:] / mdl.Om, np.where(st == STICK, w, 0.0)])


def period_map(mdl, x, w, st, t0=0.0):
    """The state one period after (x, w, st) at t0, unrecorded:
    (x, w, states, events, status, message) of `events.integrate`."""
    out = integrate(mdl, t0, x, w, st, t0 + mdl.T, False)
    return out["x"], out["w"], out["st"], out["n_events"], out["status"], out["message"]


def relative_defect(dz, z):
    """|dz| / |z| (z = 0 counts as tiny, not as zero)."""
    return float(np.linalg.norm(dz) / max(np.linalg.norm(z), 1e-300))


def rest_sliders(mdl, rest, x, w, st, per):
    """Shift the stuck sliders of an event-free cycle to the slider_rest convention.

    Only the static part moves: q_s(w) = K_s^-1 (p0 + Wm w) is affine in w, so the
    mean-u condition w_S = Bt_S q_s(w) is one small linear solve.
    """
    S = np.nonzero((st == STICK) & (mdl.kt > 0))[0]
    if S.size == 0:
        return x, w
    m = mdl.mode(st)
    G = mdl.Bt[S] @ m.Kinv                       # d(mean u_S)/d(static load)
    if rest is None:
        # w_S = mean u_S = Bt_S K_s^-1 (p0 + Wm w)  (harmonic parts have zero mean)
        A = np.eye(S.size) - G @ m.Wm[:, S]
        w_other = w.copy()
        w_other[S] = 0.0
        target = np.linalg.solve(A, G @ (m.p0 + m.Wm @ w_other))
    else:
        target = np.asarray(rest, float)[S]
    u = per.q @ mdl.Bt[S].T                     # admissible interval of a stuck cycle
    nrm = mdl.n0[S] + mdl.kv[S] * (per.q @ mdl.Bn[S].T)
    lo = (u - mdl.mu[S] * nrm / mdl.kt[S]).max(axis=0)
    hi = (u + mdl.mu[S] * nrm / mdl.kt[S]).min(axis=0)
    # clamp against the interval of the SHIFTED cycle: u and n move with w through q_s,
    # so the bounds move at the rates c_lo, c_hi (diagonal coupling per element)
    dq_dw = m.Kinv @ m.Wm[:, S]
    du = np.diag(mdl.Bt[S] @ dq_dw)
    dn = mdl.kv[S] * np.diag(mdl.Bn[S] @ dq_dw)
    c_lo, c_hi = du - mdl.mu[S] * dn / mdl.kt[S], du + mdl.mu[S] * dn / mdl.kt[S]
    w0 = w[S]
    d_lo = (lo - w0) / np.where(c_lo < 1, 1 - c_lo, np.inf)
    d_hi = (hi - w0) / np.where(c_hi < 1, 1 - c_hi, np.inf)
    pad = 1e-6 * np.maximum(d_hi - d_lo, 0.0)           # stay off the friction limit
    target = w0 + np.clip(target - w0, d_lo + pad, d_hi - pad)
    wn = w.copy()
    wn[S] = target
    xn = x.copy()
    xn[: mdl.n] += dq_dw @ (target - w[S])
    return xn, wn


def newton_step(mdl, P, x, w, st, r0, tol):
    """One Newton step on P(z) - z with a finite-difference Jacobian (and backtracking)."""
    n = mdl.n
    stick = np.nonzero(st == STICK)[0]
    stick = stick[mdl.kt[stick] > 0]
    xe, we, se, status, msg = P(x, w, st)
    if status:
        return False, x, w, st, r0, None, status, msg
    z = np.concatenate([x[:n], x[n:] / mdl.Om, w[stick]])

    def zout(xe, we, se):
        return np.concatenate([xe[:n], xe[n:] / mdl.Om, mdl.derived_w(xe, we, se)[stick]])

    def unpack(z):
        xx = np.concatenate([z[:n], z[n:2 * n] * mdl.Om])
        ww = mdl.derived_w(xx, w, st).copy()
        ww[stick] = z[2 * n:]
        return xx, ww

    f0 = zout(xe, we, se)
    R = f0 - z
    r = relative_defect(R, f0)
    if r < tol:
        return True, xe, we, se, r, None, 0, ""
    dim = z.size
    Jm = np.empty((dim, dim))
    zs = max(np.abs(z).max(), 1e-12)
    u = mdl.Bt @ x[:n]
    for k in range(dim):
        h = 1e-7 * max(abs(z[k]), zs)
        if k >= 2 * n:                      # move a stuck slider towards the interior
            e = stick[k - 2 * n]
            h = h if u[e] - w[e] > 0 else -h
        zp = z.copy()
        zp[k] += h
        xx, ww = unpack(zp)
        sp, ww = mdl.classify(xx, ww)
        fx, fw, fs, stt, _ = P(xx, ww, sp)
        Jm[:, k] = (zout(fx, fw, fs) - f0) / h
    mult = np.linalg.eigvals(Jm)
    dz = np.linalg.lstsq(Jm - np.eye(dim), -R, rcond=1e-12)[0]
    lam = 1.0
    for _ in range(6):
        zn = z + lam * dz
        xx, ww = unpack(zn)
        sn, ww = mdl.classify(xx, ww)
        fx, fw, fs, stt, msg = P(xx, ww, sn)
        if stt:
            return False, x, w, st, r0, mult, stt, msg
        zn_full = poincare_vector(mdl, xx, ww, sn)
        rn = relative_defect(poincare_vector(mdl, fx, fw, fs) - zn_full, zn_full)
        if rn < 0.5 * r:
            return True, xx, ww, sn, rn, mult, 0, ""
        lam *= 0.5
    return False, xe, we, se, r, mult, 0, ""
