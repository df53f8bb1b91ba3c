"""The periodic steady state by shooting on the Poincare map of one period.

z = [q, q'/Omega, w_stuck] (`poincare_vector`) is mapped over one period by the
event-driven integration (`period_map`, counted by a `PoincareMap`); `shoot`
alternates plain periods and Newton phases, `newton_step` solving P(z) - z = 0
with a finite-difference monodromy; `rest_sliders` moves the stuck sliders of an
event-free cycle to the slider_rest convention.  `timesim.steady_state` drives them.
"""
from __future__ import annotations

import logging

import numpy as np

from .events import integrate
from .piecewise import STICK

log = logging.getLogger(__name__)


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


class PoincareMap:
    """P(x, w, st) -> (x, w, st, status, message) one period later (`period_map`),
    counting the periods integrated and the events met; `plain` iterates it.
    tol and periods_max: when plain iteration stops."""

    def __init__(self, mdl, tol, periods_max):
        self.mdl, self.tol, self.periods_max = mdl, tol, periods_max
        self.periods = self.n_events = 0

    def __call__(self, x, w, st):
        self.periods += 1
        xe, we, se, ne, stt, mm = period_map(self.mdl, x, w, st)
        self.n_events += ne
        return xe, we, se, stt, mm

    def plain(self, x, w, st, k):
        """Up to k plain periods, until the map changes z by less than tol (relative)
        or periods_max periods are spent: (x, w, st, last change, status, message)."""
        mdl = self.mdl
        r = np.inf
        for _ in range(k):
            xe, we, se, stt, mm = self(x, w, st)
            if stt != 0:
                return x, w, st, r, stt, mm
            r = relative_defect(poincare_vector(mdl, xe, we, se) - poincare_vector(mdl, x, w, st),
                                poincare_vector(mdl, xe, we, se))
            x, w, st = xe, we, se
            if r < self.tol or self.periods >= self.periods_max:
                break
        return x, w, st, r, 0, ""


def shoot(P: PoincareMap, x, w, st, transient_periods, newton_max, accept_unstable):
    """A fixed point of P from (x, w, st): transient periods, then Newton phases
    (`newton_step`).  Newton phases start from the physical trajectory; when a phase
    stalls (no orbit nearby: past a fold, long transient) or lands on an unstable
    orbit (unless accept_unstable), integration goes on from the physical state for
    twice as long as before.  (x, w, st, multipliers or None, status, message)."""
    mdl, tol = P.mdl, P.tol
    mult = None
    x, w, st, r, status, msg = P.plain(x, w, st, transient_periods)
    n_plain = 8
    while status == 0 and r >= tol and P.periods < P.periods_max:
        xn, wn, sn, rn, mult_n = x, w, st, r, None
        for it in range(newton_max):
            ok, xn, wn, sn, rn, mult_n, status, msg = newton_step(mdl, P, xn, wn, sn, rn, tol)
            log.debug("Omega=%g Newton %d: ok=%s residual=%.3e periods=%d", mdl.Om, it, ok,
                      rn, P.periods)
            if not ok or status or rn < tol or P.periods >= P.periods_max:
                break
        if status:
            break
        if rn < tol and (accept_unstable or mult_n is None
                         or np.abs(mult_n).max() <= 1 + 1e-6):
            x, w, st, r, mult = xn, wn, sn, rn, mult_n
            break
        if rn < tol:
            log.info("Omega=%g: shooting found an unstable orbit (|mult| = %.4g)",
                     mdl.Om, np.abs(mult_n).max())
        x, w, st, r, status, msg = P.plain(x, w, st, n_plain)
        n_plain *= 2
    return x, w, st, mult, status, msg


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
