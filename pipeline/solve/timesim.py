"""Event-driven time integration of a `System` with Yang-Menq contacts (paper Sec. 2, 4, 5).

    M q'' + C q' + K q + Bt^T f_u + Bn^T f_v = F(t),  F(t) = Re sum_h F_h exp(i h Omega t)
    u = Bt q, v = Bn q, n = n0 + kv v                          (Eq. 1, 5-6)
    separation (n <= 0):  f_u = f_v = 0, slider follows (w = u)
    contact:              f_v = n                              (Eq. 10)
      stick               f_u = ku (u - w), w constant, |f_u| < mu n
      positive slip (PS)  f_u = +mu n,  w = u - mu n/ku,  w' > 0  (Eq. 9)
      negative slip (NS)  f_u = -mu n,  w = u + mu n/ku,  w' < 0

The system is integrated as a Filippov system, event by event.  In every discrete
state (one of separation / stick / PS / NS per element) the equation is LINEAR with
harmonic forcing, so each piece is solved in closed form:

    x = [q; q'],  x' = A_s x + c_s(w) + b(t)
    x(t) = Re V exp(Lambda (t - t0)) a + x_p(t),   x_p = [q_s; 0] + Re sum_h X_h e^{ih Om t}

(eigen-decomposition A_s = V Lambda V^-1, static part K_s q_s = F_0 - g_s(w), harmonic
part (K_s - (h Om)^2 M + i h Om C) Q_h = F_h).  The switching functions are affine in
x and are located by sampling the closed form on a grid that resolves the fastest
eigenvalue, checking local maxima for grazing crossings, and polishing the root with
`brentq` to machine precision.  Transitions follow the paper:

    stick -> PS/NS   when ku (u - w) reaches +-mu n                (Sec. 4.4)
    PS/NS -> stick   when the slider velocity u' -+ mu kv v'/ku changes sign (4.2, 4.3)
    contact -> sep.  when n crosses 0 downwards
    sep. -> contact  when n crosses 0 upwards; the spring restarts unstrained (w = u)
                     and f1 = u', f2 = mu kv/ku v' select PS (f1 > f2), NS (f1 < -f2)
                     or stick (Sec. 4.1)

kv = 0 is a constant normal load n0 (Jenkins element); mu = 0 or ku = 0 gives no
tangential force (the element is labelled stick with a zero spring).

This module is the INDEPENDENT reference for the harmonic-balance code: it evaluates
no force through `pipeline.contact`, only reads the parameters.

Public API: `simulate` (time history), `steady_state` (periodic steady state by
shooting on the Poincare map, or plain integration), `sweep` (stepped sine),
`work_per_period` (energy balance).  Numerical failures are reported in the result
objects (`success`, `status`, `message`), never raised.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from ..model.system import System

log = logging.getLogger(__name__)

SEP, STICK, PS, NS = 0, 1, 2, 3
STATE_NAMES = ("separation", "stick", "positive slip", "negative slip")
# switching-function kinds: which transition fires when the function becomes > 0
_TD, _LO, _TPS, _TNS, _TST = 0, 1, 2, 3, 4

_EVENT_DTYPE = np.dtype([("t", float), ("element", int), ("old", int), ("new", int)])


# --------------------------------------------------------------------------- model
class _Mode:
    """Closed-form solution data of one discrete state (tuple of element states)."""

    def __init__(self, mdl: "_Model", states: tuple):
        n, E = mdl.n, mdl.E
        s = np.asarray(states)
        K = mdl.K.copy()
        g0 = np.zeros(n)                      # constant contact force (w-free part)
        Wm = np.zeros((n, E))                 # RHS += Wm @ w (stuck springs)
        for e in range(E):
            if s[e] == SEP:
                continue
            bt, bn = mdl.Bt[e], mdl.Bn[e]
            K += mdl.kv[e] * np.outer(bn, bn)
            g0 += mdl.n0[e] * bn
            if s[e] == STICK:
                K += mdl.kt[e] * np.outer(bt, bt)
                Wm[:, e] = mdl.kt[e] * bt
            else:
                sg = 1.0 if s[e] == PS else -1.0
                K += sg * mdl.mu[e] * mdl.kv[e] * np.outer(bt, bn)
                g0 += sg * mdl.mu[e] * mdl.n0[e] * bt
        self.states = tuple(int(v) for v in s)
        self.K, self.Wm = K, Wm
        self.p0 = mdl.F0 - g0
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -mdl.Minv @ K
        A[n:, n:] = -mdl.Minv @ mdl.C
        lam, V = np.linalg.eig(A)
        self.ok, self.why = True, ""
        cV = np.linalg.cond(V)
        cK = np.linalg.cond(K)
        if not np.isfinite(cV) or cV > 1e10:
            self.ok, self.why = False, f"defective state matrix (cond(V) = {cV:.1e})"
        elif not np.isfinite(cK) or cK > 1e13:
            self.ok, self.why = False, f"singular stiffness in state {self.states} (cond = {cK:.1e})"
        if not self.ok:
            return
        self.lam, self.V = lam, V
        self.Vinv = np.linalg.inv(V)
        self.Kinv = np.linalg.inv(K)
        # harmonic particular solution (q part and q' part)
        Om = mdl.Om
        Xh = np.zeros((2 * n, mdl.hs.size), dtype=complex)
        for k, h in enumerate(mdl.hs):
            S = K - (h * Om) ** 2 * mdl.M + 1j * h * Om * mdl.C
            Q = np.linalg.solve(S, mdl.Fh[:, k])
            Xh[:n, k] = Q
            Xh[n:, k] = 1j * h * Om * Q
        self.Xh = Xh
        # switching functions g_j(x, w) = c_j . x + d0_j + dw_j w_e ; event when g_j > 0
        rows, d0, dw, elem, kind = [], [], [], [], []

        def add(e, kd, cq, cqd, d, dwe):
            c = np.zeros(2 * n)
            c[:n], c[n:] = cq, cqd
            rows.append(c), d0.append(d), dw.append(dwe), elem.append(e), kind.append(kd)

        z = np.zeros(n)
        for e in range(E):
            bt, bn = mdl.Bt[e], mdl.Bn[e]
            kt, kv, mu, n0, r = mdl.kt[e], mdl.kv[e], mdl.mu[e], mdl.n0[e], mdl.r[e]
            if s[e] == SEP:
                if kv > 0:
                    add(e, _TD, kv * bn, z, n0, 0.0)
                continue
            if kv > 0:
                add(e, _LO, -kv * bn, z, -n0, 0.0)
            if kt == 0:
                continue
            if s[e] == STICK:
                add(e, _TPS, kt * bt - mu * kv * bn, z, -mu * n0, -kt)
                add(e, _TNS, -kt * bt - mu * kv * bn, z, -mu * n0, kt)
            elif s[e] == PS:
                add(e, _TST, z, -(bt - r * bn), 0.0, 0.0)
            else:
                add(e, _TST, z, bt + r * bn, 0.0, 0.0)
        J = len(rows)
        self.Csw = np.array(rows).reshape(J, 2 * n)
        self.d0, self.dw = np.array(d0, float), np.array(dw, float)
        self.elem, self.kind = np.array(elem, int), np.array(kind, int)
        self.CV = self.Csw @ V
        self.CXh = self.Csw @ Xh
        self.cabs = np.abs(self.Csw)


class _Model:
    """System matrices, element parameters and a cache of `_Mode`s for one Omega."""

    def __init__(self, system: System, Om: float):
        self.M = np.asarray(system.M, float)
        self.C = np.asarray(system.C, float)
        self.K = np.asarray(system.K, float)
        self.Bt = np.atleast_2d(np.asarray(system.Bt, float))
        self.Bn = np.atleast_2d(np.asarray(system.Bn, float))
        self.n, self.E = self.M.shape[0], self.Bt.shape[0]
        cp = system.contact
        self.ku, self.kv = np.asarray(cp.ku, float), np.asarray(cp.kv, float)
        self.mu, self.n0 = np.asarray(cp.mu, float), np.asarray(cp.n0, float)
        self.kt = np.where((self.mu > 0) & (self.ku > 0), self.ku, 0.0)
        self.r = np.where(self.kt > 0, self.mu * self.kv / np.where(self.ku > 0, self.ku, 1), 0.0)
        Fc = np.atleast_2d(np.asarray(system.forcing, complex))
        if Fc.shape[0] != self.n:
            Fc = Fc.reshape(self.n, -1)
        self.F0 = Fc[:, 0].real.copy()
        hs = np.arange(1, Fc.shape[1])
        keep = np.any(Fc[:, 1:] != 0, axis=0)
        self.hs, self.Fh = hs[keep], Fc[:, 1:][:, keep]
        self.Om = float(Om)
        self.T = 2 * np.pi / self.Om
        self.Minv = np.linalg.inv(self.M)
        self._cache: dict = {}
        self.hmax_freq = (self.hs.max() if self.hs.size else 0) * self.Om

    def mode(self, states) -> _Mode:
        key = tuple(int(v) for v in states)
        m = self._cache.get(key)
        if m is None:
            m = self._cache[key] = _Mode(self, key)
        return m

    # -- element kinematics ---------------------------------------------------------
    def uv(self, x):
        q, qd = x[: self.n], x[self.n:]
        return self.Bt @ q, self.Bn @ q, self.Bt @ qd, self.Bn @ qd

    def derived_w(self, x, w, states):
        """Slider positions: w for stick, u -+ mu n/ku in slip, u in separation.

        x (2n,) or (2n, N); w, states (E,) or (E, N).
        """
        x = np.asarray(x)
        q = x[: self.n]
        u, v = self.Bt @ q, self.Bn @ q
        if x.ndim == 2:
            w = np.asarray(w).reshape(self.E, -1)
            states = np.asarray(states).reshape(self.E, -1)
            kv, n0, mu, kt = (a[:, None] for a in (self.kv, self.n0, self.mu, self.kt))
        else:
            kv, n0, mu, kt = self.kv, self.n0, self.mu, self.kt
        nrm = n0 + kv * v
        ku = np.where(kt > 0, kt, 1.0)
        out = np.where(states == STICK, w, u)
        out = np.where(states == PS, u - mu * nrm / ku, out)
        out = np.where(states == NS, u + mu * nrm / ku, out)
        return out

    def classify(self, x, w, hint=None):
        """Consistent element states and slider positions for a state (q, q', w)."""
        u, v, ud, vd = self.uv(x)
        w = np.array(u if w is None else w, float, copy=True)
        st = np.empty(self.E, int)
        for e in range(self.E):
            kv, n0, kt, mu = self.kv[e], self.n0[e], self.kt[e], self.mu[e]
            n = n0 + kv * v[e]
            if n < 0 or (n == 0 and kv * vd[e] <= 0):
                st[e], w[e] = SEP, u[e]
                continue
            if kt == 0:
                st[e] = STICK
                continue
            if n == 0:                      # touching down now: Sec. 4.1 rule
                w[e] = u[e]
                f1, f2 = ud[e], self.r[e] * vd[e]
                st[e] = PS if f1 > f2 else (NS if f1 < -f2 else STICK)
                continue
            f, lim = kt * (u[e] - w[e]), mu * n
            tol = 1e-12 * lim
            if f >= lim - tol and ud[e] - self.r[e] * vd[e] > 0:
                st[e], w[e] = PS, u[e] - lim / kt
            elif f <= -lim + tol and ud[e] + self.r[e] * vd[e] < 0:
                st[e], w[e] = NS, u[e] + lim / kt
            else:
                st[e] = STICK
                w[e] = min(max(w[e], u[e] - lim / kt), u[e] + lim / kt)
        return st, w


# --------------------------------------------------------------------------- pieces
class _Piece:
    """Closed-form solution from (t0, x0) in one mode with slider positions w."""

    __slots__ = ("mode", "mdl", "t0", "w", "qs", "a", "gconst", "t1")

    def __init__(self, mdl: _Model, mode: _Mode, t0, x0, w):
        self.mdl, self.mode, self.t0, self.w = mdl, mode, float(t0), np.array(w, float)
        n = mdl.n
        self.qs = mode.Kinv @ (mode.p0 + mode.Wm @ self.w)
        xp0 = self._xp(np.array([self.t0]), 0)[:, 0]
        self.a = mode.Vinv @ (x0 - xp0)
        self.gconst = mode.Csw[:, :n] @ self.qs + mode.d0 + mode.dw * self.w[mode.elem]
        self.t1 = np.inf

    def _xp(self, t, order):
        m, mdl = self.mode, self.mdl
        out = np.zeros((2 * mdl.n, t.size))
        if order == 0:
            out[: mdl.n] = self.qs[:, None]
        if mdl.hs.size:
            iw = 1j * mdl.hs * mdl.Om
            E = np.exp(np.outer(iw, t)) * (iw[:, None] ** order)
            out += (m.Xh @ E).real
        return out

    def x(self, t, order=0):
        """State (2n, len(t)) or its order-th time derivative at absolute times t."""
        t = np.atleast_1d(np.asarray(t, float))
        lam = self.mode.lam
        Eh = np.exp(np.outer(lam, t - self.t0)) * (lam[:, None] ** order) * self.a[:, None]
        return (self.mode.V @ Eh).real + self._xp(t, order)

    def g(self, t, order=0, j=None):
        """Switching functions (J, len(t)) (or row j) at absolute times t."""
        m, mdl = self.mode, self.mdl
        t = np.atleast_1d(np.asarray(t, float))
        sl = slice(None) if j is None else slice(j, j + 1)
        lam = m.lam
        Eh = np.exp(np.outer(lam, t - self.t0)) * (lam[:, None] ** order) * self.a[:, None]
        out = (m.CV[sl] @ Eh).real
        if mdl.hs.size:
            iw = 1j * mdl.hs * mdl.Om
            out += (m.CXh[sl] @ (np.exp(np.outer(iw, t)) * iw[:, None] ** order)).real
        if order == 0:
            out += self.gconst[sl, None]
        return out


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class TimeResult:
    """Time history of `simulate`.

    t (N,), q and qdot (N, n), w (N, E) slider positions, state (N, E) element states
    (0 separation, 1 stick, 2 positive slip, 3 negative slip; `STATE_NAMES`).
    events: structured array (t, element, old, new); event_q, event_qdot (Ne, n) and
    event_w (Ne, E) the state at each event, w BEFORE the switch.
    success/status/message: status 0 reached t_end, 1 event cap (chattering),
    -1 unsupported linear piece (singular/defective).  `evaluate(t)` gives the exact
    closed-form state at any t in [t[0], t_final].
    """

    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    w: np.ndarray
    state: np.ndarray
    events: np.ndarray
    event_q: np.ndarray
    event_qdot: np.ndarray
    event_w: np.ndarray
    t_final: float
    q_final: np.ndarray
    qdot_final: np.ndarray
    w_final: np.ndarray
    state_final: np.ndarray
    success: bool
    status: int
    message: str
    n_events: int
    n_pieces: int
    Omega: float
    _pieces: tuple = field(default=(), repr=False)
    _model: object = field(default=None, repr=False)

    def evaluate(self, t, order=0):
        """Exact (q^(order), q^(order+1), w, state) at times t (arrays over t first)."""
        t = np.atleast_1d(np.asarray(t, float))
        starts = np.array([p.t0 for p in self._pieces])
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
        mdl = self._model
        X = np.empty((t.size, 2 * mdl.n))
        W = np.empty((t.size, mdl.E))
        S = np.empty((t.size, mdl.E), int)
        for k in np.unique(idx):
            sel = idx == k
            p = self._pieces[k]
            X[sel] = p.x(t[sel], order).T
            st = np.asarray(p.mode.states)
            S[sel] = st
            if order == 0:
                W[sel] = mdl.derived_w(X[sel].T, p.w, st).T
        return X[:, : mdl.n], X[:, mdl.n:], W, S


def _integrate(mdl: _Model, t0, x0, w0, st0, t_end, record, t_eval=None,
               max_events_per_period=2000, max_zero_length=50):
    """Event loop from (t0, x0, w0, st0) to t_end; returns a dict."""
    T = mdl.T
    x, w, st, t = np.array(x0, float), np.array(w0, float), np.array(st0, int), float(t0)
    pieces, events, evq, evqd, evw = [], [], [], [], []
    n_events, zero_len, status, msg = 0, 0, 0, "reached t_end"
    period_events, period_id = 0, np.floor((t - t0) / T)
    while t < t_end - 1e-15 * max(1.0, abs(t_end)):
        mode = mdl.mode(st)
        if not mode.ok:
            status, msg = -1, f"unsupported linear piece: {mode.why}"
            break
        piece = _Piece(mdl, mode, t, x, w)
        if record:
            pieces.append(piece)
        t_stop = min(t_end, t + T)
        tau_ev, trig = _next_event(mdl, piece, t, t_stop, x)
        if tau_ev is None:
            x = piece.x(np.array([t_stop]))[:, 0]
            t = t_stop
            zero_len = 0
            continue
        t_ev = t + tau_ev
        x = piece.x(np.array([t_ev]))[:, 0]
        zero_len = zero_len + 1 if tau_ev <= 1e-13 * T else 0
        pid = np.floor((t_ev - t0) / T)
        if pid != period_id:
            period_id, period_events = pid, 0
        wd = mdl.derived_w(x, w, st)
        for j in trig:
            e = int(mode.elem[j])
            old = st[e]
            new, w_e = _switch(mdl, e, int(mode.kind[j]), x, old)
            if new == old:
                continue
            if record:
                events.append((t_ev, e, old, new))
                evq.append(x[: mdl.n].copy()), evqd.append(x[mdl.n:].copy()), evw.append(wd.copy())
            st[e], w[e] = new, w_e
            n_events += 1
            period_events += 1
        w = np.where(st == STICK, w, mdl.derived_w(x, w, st))
        t = t_ev
        if period_events > max_events_per_period:
            status, msg = 1, (f"more than {max_events_per_period} events in one period at "
                              f"t = {t:.6g}: chattering (Zeno-like) motion, stopped")
            break
        if zero_len > max_zero_length:
            status, msg = 1, f"{zero_len} consecutive zero-length states at t = {t:.6g}: stopped"
            break
    return dict(t=t, x=x, w=w, st=st, pieces=pieces, events=events, evq=evq, evqd=evqd,
                evw=evw, n_events=n_events, status=status, message=msg)


def _switch(mdl: _Model, e, kind, x, old):
    """New state and slider position of element e when switching function `kind` fires."""
    u, v, ud, vd = (a[e] for a in mdl.uv(x))
    kt, mu = mdl.kt[e], mdl.mu[e]
    n = mdl.n0[e] + mdl.kv[e] * v
    if kind == _LO:
        return SEP, u
    if kind == _TD:
        if kt == 0:
            return STICK, u
        f1, f2 = ud, mdl.r[e] * vd          # Sec. 4.1
        return (PS if f1 > f2 else NS if f1 < -f2 else STICK), u
    if kind == _TPS:
        return PS, u - mu * n / kt
    if kind == _TNS:
        return NS, u + mu * n / kt
    # slip -> stick: freeze the slider where it is
    return STICK, u - (1.0 if old == PS else -1.0) * mu * n / kt


def _next_event(mdl: _Model, piece: _Piece, t0, t1, x0):
    """Earliest time (tau from t0) in (0, t1 - t0] where a switching function becomes > 0.

    Returns (tau, [rows triggered]) or (None, []).
    """
    m = piece.mode
    J = m.Csw.shape[0]
    if J == 0:
        return None, []
    T = mdl.T
    span = t1 - t0
    fmax = max(np.abs(m.lam).max(), mdl.hmax_freq, 1e-300)
    dt = min(T / 64, (np.pi / 6) / fmax)
    N = max(4, int(np.ceil(span / dt)))
    ts = t0 + np.linspace(0.0, span, N + 1)
    G = piece.g(ts)
    Gp = piece.g(ts, 1)
    # magnitude of each function over the window (its start alone can be ~0, e.g. n0 = 0)
    scale = np.maximum(m.cabs @ np.abs(x0) + np.abs(piece.gconst),
                       np.abs(G).max(axis=1) + np.abs(Gp).max(axis=1) * (span / N)) + 1e-300
    # a just-switched function starts at 0 with a slope that is 0 up to rounding
    tol, tol_d = 1e-10 * scale, 1e-9 * scale * fmax
    best, trig = np.inf, []
    for j in range(J):
        g, gp = G[j], Gp[j]
        if g[0] > tol[j] or (g[0] > -tol[j] and (gp[0] > tol_d[j] or (
                abs(gp[0]) <= tol_d[j] and piece.g(t0, 2, j)[0, 0] > 0))):
            tj = t0                                  # inconsistent start: fire now
        else:
            tj = _first_crossing(piece, j, ts, g, gp, scale[j])
        if tj is None:
            continue
        tj = tj - t0
        if tj < best - 1e-14 * T:
            best, trig = tj, [j]
        elif abs(tj - best) <= 1e-14 * T:
            trig.append(j)
    if not np.isfinite(best):
        return None, []
    # simultaneous switches (several elements at one instant)
    gs, gps = piece.g(t0 + best)[:, 0], piece.g(t0 + best, 1)[:, 0]
    for j in range(J):
        if j not in trig and gs[j] > -1e-9 * scale[j] and gps[j] >= 0:
            trig.append(j)
    return best, trig


def _first_crossing(piece: _Piece, j, ts, g, gp, scale):
    """Absolute time of the first upward zero crossing of g_j after ts[0], or None."""
    def f(t):
        return piece.g(t, 0, j)[0, 0]

    pos = np.nonzero(g[1:] > 0)[0]
    k_pos = pos[0] + 1 if pos.size else len(g)
    # grazing: a local maximum between two non-positive samples may poke above zero
    k_max = len(g)
    cand = np.nonzero((gp[:-1] > 0) & (gp[1:] < 0))[0]
    for k in cand:
        if k + 1 >= k_pos:
            break
        h = ts[k + 1] - ts[k]
        # cubic Hermite bound of the peak; only polish peaks that may reach zero
        peak = max(g[k], g[k + 1]) + 0.25 * h * max(gp[k], -gp[k + 1])
        if peak < -1e-8 * scale:
            continue
        try:
            tm = brentq(lambda t: piece.g(t, 1, j)[0, 0], ts[k], ts[k + 1], xtol=1e-15 * h)
        except ValueError:
            continue
        if f(tm) > 1e-10 * scale:          # rounding-level bumps are not crossings
            k_max, t_hi = k, tm
            break
    if k_pos == len(g) and k_max == len(g):
        return None
    if k_max < k_pos:
        lo, hi = ts[k_max], t_hi
    else:
        lo, hi = ts[k_pos - 1], ts[k_pos]
    if f(lo) >= 0:                      # only at the start of a piece that just switched
        for s in 10.0 ** -np.arange(1, 12):
            tl = ts[0] + s * (hi - ts[0])
            if f(tl) < 0:
                lo = tl
                break
        else:
            return ts[0]
    return brentq(f, lo, hi, xtol=1e-15 * max(1.0, abs(hi)), rtol=4 * np.finfo(float).eps)


def _check(system, Omega):
    if not isinstance(system, System):
        raise ValueError(f"system must be a pipeline.model.system.System, got {type(system).__name__}")
    if system.cyclic is not None:
        raise ValueError("system is a cyclic sector (System.cyclic): integrate its N-sector "
                         "assembly, pipeline.model.cyclic.full_assembly, instead")
    if not (np.isfinite(Omega) and Omega > 0):
        raise ValueError(f"Omega must be a positive finite frequency [rad/s], got {Omega!r}")


def _initial(mdl, q0, qd0, w0, states0=None):
    n = mdl.n
    q0 = np.zeros(n) if q0 is None else np.asarray(q0, float).reshape(n)
    qd0 = np.zeros(n) if qd0 is None else np.asarray(qd0, float).reshape(n)
    x0 = np.concatenate([q0, qd0])
    st, w = mdl.classify(x0, None if w0 is None else np.asarray(w0, float).reshape(mdl.E))
    return x0, w, st


def simulate(system: System, Omega: float, t_end: float, q0=None, qd0=None, w0=None,
             t0: float = 0.0, samples_per_period: int = 128, t_eval=None,
             max_events_per_period: int = 2000) -> TimeResult:
    """Integrate from t0 to t_end, event by event, in closed form.

    q0, qd0: initial displacement / velocity (default 0); w0: initial slider
    positions [m] (default unstrained, w = u0); inconsistent w0 are clamped to the
    friction limit.  t_eval: output times (default `samples_per_period` per period).
    """
    _check(system, Omega)
    if not t_end > t0:
        raise ValueError(f"t_end must be > t0 = {t0}, got {t_end!r}")
    mdl = _Model(system, Omega)
    x0, w, st = _initial(mdl, q0, qd0, w0)
    return _run(mdl, t0, x0, w, st, t_end, samples_per_period, t_eval, max_events_per_period)


def _run(mdl, t0, x0, w, st, t_end, samples_per_period=128, t_eval=None,
         max_events_per_period=2000):
    out = _integrate(mdl, t0, x0, w, st, t_end, True,
                     max_events_per_period=max_events_per_period)
    tf = out["t"]
    if t_eval is None:
        N = max(2, int(np.ceil((tf - t0) / mdl.T * samples_per_period)) + 1)
        t_eval = np.linspace(t0, tf, N)
    t_eval = np.asarray(t_eval, float)
    t_eval = t_eval[(t_eval >= t0) & (t_eval <= tf)]
    ev = np.array(out["events"], dtype=_EVENT_DTYPE)
    n, E = mdl.n, mdl.E
    res = TimeResult(
        t=t_eval, q=np.empty((0, n)), qdot=np.empty((0, n)), w=np.empty((0, E)),
        state=np.empty((0, E), int), events=ev,
        event_q=np.array(out["evq"]).reshape(-1, n), event_qdot=np.array(out["evqd"]).reshape(-1, n),
        event_w=np.array(out["evw"]).reshape(-1, E),
        t_final=tf, q_final=out["x"][:n], qdot_final=out["x"][n:], w_final=out["w"],
        state_final=out["st"], success=out["status"] == 0, status=out["status"],
        message=out["message"], n_events=out["n_events"], n_pieces=len(out["pieces"]),
        Omega=mdl.Om, _pieces=tuple(out["pieces"]), _model=mdl)
    if out["pieces"]:
        q, qd, W, S = res.evaluate(t_eval)
        object.__setattr__(res, "q", q)
        object.__setattr__(res, "qdot", qd)
        object.__setattr__(res, "w", W)
        object.__setattr__(res, "state", S)
    return res


# --------------------------------------------------------------------------- steady state
@dataclass(frozen=True)
class SteadyResult:
    """One period of the periodic steady state (t in [0, 2 pi/Omega]).

    amplitude (n,): (max q - min q)/2 over the period (extrema polished exactly);
    Q (n, 2H+1): Fourier coefficients of q in the layout of harmonics.py (exact
    piecewise Gauss quadrature); residual: relative periodicity defect |z(T)-z(0)|/|z|
    of z = [q, q'/Omega, w] measured on the returned period; converged = residual < tol.
    multipliers: Floquet multipliers of the Poincare map from the shooting Jacobian
    (None for plain integration); stable = max |multiplier| <= 1 + 1e-6.
    periods: periods integrated in total (Jacobian columns included); n_events: events
    in the returned period; events: their (t, element, old, new).
    """

    Omega: float
    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    w: np.ndarray
    state: np.ndarray
    amplitude: np.ndarray
    Q: np.ndarray
    H: int
    q0: np.ndarray
    qd0: np.ndarray
    w0: np.ndarray
    residual: float
    converged: bool
    multipliers: np.ndarray | None
    stable: bool
    periods: int
    n_events: int
    n_events_total: int
    events: np.ndarray
    wall_time: float
    success: bool
    status: int
    message: str
    period: TimeResult = field(repr=False)


def _zvec(mdl, x, w, st):
    return np.concatenate([x[: mdl.n], x[mdl.n:] / mdl.Om, np.where(st == STICK, w, 0.0)])


def _period_map(mdl, x, w, st, t0=0.0):
    out = _integrate(mdl, t0, x, w, st, t0 + mdl.T, False)
    return out["x"], out["w"], out["st"], out["n_events"], out["status"], out["message"]


def _rel(dz, z):
    return float(np.linalg.norm(dz) / max(np.linalg.norm(z), 1e-300))


def steady_state(system: System, Omega: float, H: int | None = None, periods_max: int = 400,
                 tol: float = 1e-11, q0=None, qd0=None, w0=None, method: str = "shooting",
                 transient_periods: int = 2, newton_max: int = 8, n_samples: int = 512,
                 max_events_per_period: int = 2000, slider_rest: bool = True,
                 accept_unstable: bool = False) -> SteadyResult:
    """Periodic steady state at excitation frequency Omega [rad/s].

    method='shooting': a few transient periods, then Newton on the Poincare map
    P(z) - z = 0, z = [q, q'/Omega, w_stuck], with a finite-difference monodromy
    (least squares, so the neutral slider direction of a fully stuck cycle is
    harmless), backtracking, and fallback to plain periods when Newton stalls; an
    unstable fixed point is left by plain integration (accept_unstable=True returns
    it instead, with stable False: the reference for unstable harmonic-balance
    points; start it at the point with transient_periods=0).  method='integrate': plain
    periods until the Poincare map changes by less than tol.  H: harmonics of Q
    (default max(7, forcing harmonics)).
    """
    _check(system, Omega)
    if method not in ("shooting", "integrate"):
        raise ValueError(f"method must be 'shooting' or 'integrate', got {method!r}")
    if not tol > 0:
        raise ValueError(f"tol must be > 0, got {tol!r}")
    tic = time.perf_counter()
    mdl = _Model(system, Omega)
    H = max(7, int(mdl.hs.max()) if mdl.hs.size else 0) if H is None else int(H)
    x, w, st = _initial(mdl, q0, qd0, w0)
    periods, n_ev_total, status, msg = 0, 0, 0, ""
    mult = None

    def P(x, w, st):
        nonlocal periods, n_ev_total
        periods += 1
        xe, we, se, ne, stt, mm = _period_map(mdl, x, w, st)
        n_ev_total += ne
        return xe, we, se, stt, mm

    def plain(x, w, st, k):
        r = np.inf
        for _ in range(k):
            xe, we, se, stt, mm = P(x, w, st)
            if stt != 0:
                return x, w, st, r, stt, mm
            r = _rel(_zvec(mdl, xe, we, se) - _zvec(mdl, x, w, st), _zvec(mdl, xe, we, se))
            x, w, st = xe, we, se
            if r < tol or periods >= periods_max:
                break
        return x, w, st, r, 0, ""

    r = np.inf
    if method == "integrate":
        x, w, st, r, status, msg = plain(x, w, st, periods_max)
    else:
        # Newton phases from the physical trajectory; when a phase stalls (no orbit
        # nearby: past a fold, long transient) or lands on an unstable orbit, go on
        # integrating from the physical state for twice as long as before.
        x, w, st, r, status, msg = plain(x, w, st, transient_periods)
        n_plain = 8
        while status == 0 and r >= tol and periods < periods_max:
            xn, wn, sn, rn, mult_n = x, w, st, r, None
            for it in range(newton_max):
                ok, xn, wn, sn, rn, mult_n, status, msg = _newton_step(mdl, P, xn, wn, sn, rn, tol)
                log.debug("Omega=%g Newton %d: ok=%s residual=%.3e periods=%d", Omega, it, ok,
                          rn, periods)
                if not ok or status or rn < tol or periods >= periods_max:
                    break
            if status:
                break
            if rn < tol and (accept_unstable or mult_n is None
                             or np.abs(mult_n).max() <= 1 + 1e-6):
                x, w, st, r, mult = xn, wn, sn, rn, mult_n
                break
            if rn < tol:
                log.info("Omega=%g: shooting found an unstable orbit (|mult| = %.4g)",
                         Omega, np.abs(mult_n).max())
            x, w, st, r, status, msg = plain(x, w, st, n_plain)
            n_plain *= 2
    # the returned period, recorded densely; its defect is the reported residual
    t_eval = np.linspace(0, mdl.T, n_samples + 1)
    per = _run(mdl, 0.0, x, w, st, mdl.T, t_eval=t_eval,
               max_events_per_period=max_events_per_period)
    periods += 1
    if slider_rest and status == 0 and per.success and per.n_events == 0:
        xr, wr = _rest_sliders(mdl, system.contact.slider_rest, x, w, st, per)
        per_r = _run(mdl, 0.0, xr, wr, st, mdl.T, t_eval=t_eval,
                     max_events_per_period=max_events_per_period)
        periods += 1
        if per_r.success and per_r.n_events == 0:      # else keep the unshifted cycle
            x, w, per = xr, wr, per_r
        else:
            log.info("Omega=%g: slider_rest position not admissible; slider kept", Omega)
    ze = _zvec(mdl, np.concatenate([per.q_final, per.qdot_final]), per.w_final, per.state_final)
    res = _rel(ze - _zvec(mdl, x, w, st), ze)
    converged = bool(per.success and status == 0 and res < tol)
    if status == 0 and per.status != 0:
        status, msg = per.status, per.message
    elif status == 0:
        status = 0 if converged else 2
        msg = ("converged" if converged else
               f"not converged: periodicity residual {res:.2e} >= tol {tol:.1e} after {periods} periods")
    stable = True if mult is None else bool(np.abs(mult).max() <= 1 + 1e-6)
    amp, Q = _amplitude(per, mdl), fourier_coefficients(per, H)
    return SteadyResult(
        Omega=mdl.Om, t=per.t, q=per.q, qdot=per.qdot, w=per.w, state=per.state, amplitude=amp,
        Q=Q, H=H, q0=x[: mdl.n].copy(), qd0=x[mdl.n:].copy(), w0=w.copy(), residual=res,
        converged=converged, multipliers=mult, stable=stable, periods=periods,
        n_events=per.n_events, n_events_total=n_ev_total + per.n_events, events=per.events,
        wall_time=time.perf_counter() - tic, success=converged, status=status, message=msg,
        period=per)


def _rest_sliders(mdl, rest, x, w, st, per):
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


def _newton_step(mdl, P, x, w, st, r0, tol):
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
    r = _rel(R, f0)
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
        zn_full = _zvec(mdl, xx, ww, sn)
        rn = _rel(_zvec(mdl, fx, fw, fs) - zn_full, zn_full)
        if rn < 0.5 * r:
            return True, xx, ww, sn, rn, mult, 0, ""
        lam *= 0.5
    return False, xe, we, se, r, mult, 0, ""


def _quadrature(res: TimeResult, t0, t1, nodes=12):
    """Gauss-Legendre nodes/weights on [t0, t1] that never straddle a piece boundary."""
    mdl = res._model
    bounds = [p.t0 for p in res._pieces if t0 < p.t0 < t1] + [t1]
    fmax = max(max(np.abs(p.mode.lam).max() for p in res._pieces), mdl.hmax_freq)
    hmax = min(mdl.T / 64, 2.0 / max(fmax, 1e-300))
    xg, wg = np.polynomial.legendre.leggauss(nodes)
    ts, ws, a = [], [], t0
    for b in bounds:
        m = max(1, int(np.ceil((b - a) / hmax)))
        edges = np.linspace(a, b, m + 1)
        mid, half = (edges[1:] + edges[:-1]) / 2, (edges[1:] - edges[:-1]) / 2
        ts.append((mid[:, None] + half[:, None] * xg).ravel())
        ws.append((half[:, None] * wg).ravel())
        a = b
    return np.concatenate(ts), np.concatenate(ws)


def fourier_coefficients(res: TimeResult, H: int, t0: float = 0.0) -> np.ndarray:
    """Real Fourier coefficients (n, 2H+1) of q over the period [t0, t0 + 2 pi/Omega]."""
    mdl = res._model
    ts, ws = _quadrature(res, t0, t0 + mdl.T)
    # samples inside a piece only (piece starts are exact boundaries)
    q = res.evaluate(ts)[0]
    tau = mdl.Om * ts
    Q = np.zeros((mdl.n, 2 * H + 1))
    Q[:, 0] = ws @ q / mdl.T
    for j in range(1, H + 1):
        Q[:, 2 * j - 1] = (ws * np.cos(j * tau)) @ q * 2 / mdl.T
        Q[:, 2 * j] = (ws * np.sin(j * tau)) @ q * 2 / mdl.T
    return Q


def _amplitude(res: TimeResult, mdl) -> np.ndarray:
    """(max - min)/2 per DOF over the recorded period, extrema polished on q' = 0.

    res.t spans one closed period [0, T] (first and last sample coincide), so the
    neighbours of an extremum at either end wrap around.
    """
    N = len(res.t) - 1
    amp = np.zeros(mdl.n)
    for i in range(mdl.n):
        def qd(t):
            return res.evaluate(t)[1][0, i]
        ext = []
        for sgn in (1.0, -1.0):
            k = int(np.argmax(sgn * res.q[:N, i]))
            best = sgn * res.q[k, i]
            left = (k - 1, k) if k > 0 else (N - 1, N)
            right = (k, k + 1)
            for lo, hi in (left, right):
                a, b = res.t[lo], res.t[hi]
                if qd(a) * qd(b) < 0:
                    tm = brentq(qd, a, b, xtol=1e-15 * mdl.T)
                    best = max(best, sgn * res.evaluate(tm)[0][0, i])
            ext.append(sgn * best)
        amp[i] = (ext[0] - ext[1]) / 2
    return amp


def work_per_period(res: TimeResult, t0: float = 0.0, t1: float | None = None) -> dict:
    """Energy balance over [t0, t1] (default one period) from the exact pieces [J].

    input = int F(t) . q' dt, viscous = int q'^T C q' dt,
    friction = sum_e int f_u w' dt (slip only: mu n |w'|), plus the change of stored
    energy (kinetic + elastic + contact springs) between t0 and t1; for a periodic
    cycle input = viscous + friction.
    """
    mdl = res._model
    t1 = t0 + mdl.T if t1 is None else t1
    ts, ws = _quadrature(res, t0, t1)
    q, qd, _, S = res.evaluate(ts)
    Ft = np.tile(mdl.F0, (ts.size, 1))
    if mdl.hs.size:
        Ft = Ft + (np.exp(1j * np.outer(ts, mdl.hs * mdl.Om)) @ mdl.Fh.T).real
    p_in = np.einsum("ki,ki->k", Ft, qd)
    p_visc = np.einsum("ki,ij,kj->k", qd, mdl.C, qd)
    v, ud, vd = q @ mdl.Bn.T, qd @ mdl.Bt.T, qd @ mdl.Bn.T
    nrm = mdl.n0 + mdl.kv * v
    p_fric = np.where(S == PS, mdl.mu * nrm * (ud - mdl.r * vd), 0.0)
    p_fric += np.where(S == NS, -mdl.mu * nrm * (ud + mdl.r * vd), 0.0)
    return dict(input=float(ws @ p_in), viscous=float(ws @ p_visc),
                friction=float(ws @ p_fric.sum(axis=1)))


# --------------------------------------------------------------------------- sweep
@dataclass(frozen=True)
class SweepResult:
    """Stepped-sine sweep: Omega in sweep order, amplitude (nOm, n), Q (nOm, n, 2H+1).

    jumps: indices k where |A_k - A_{k-1}| > jump_ratio * max(A_k, A_{k-1}) on the
    response DOF (a heuristic flag of a fold jump between Omega[k-1] and Omega[k]).
    """

    Omega: np.ndarray
    direction: str
    amplitude: np.ndarray
    Q: np.ndarray
    converged: np.ndarray
    stable: np.ndarray
    periods: np.ndarray
    wall_time: np.ndarray
    jumps: np.ndarray
    results: tuple = field(repr=False)
    success: bool = True
    message: str = ""


def sweep(system: System, Omegas, direction: str = "up", dof: int = 0, jump_ratio: float = 0.2,
          q0=None, qd0=None, w0=None, callback=None, **kwargs) -> SweepResult:
    """Stepped-sine sweep: each frequency starts from the previous steady state.

    direction 'up' sorts Omegas ascending, 'down' descending; `dof` is the response
    DOF used to flag jumps; kwargs go to `steady_state`; callback(k, SteadyResult).
    """
    if direction not in ("up", "down"):
        raise ValueError(f"direction must be 'up' or 'down', got {direction!r}")
    Om = np.sort(np.asarray(Omegas, float).ravel())
    if direction == "down":
        Om = Om[::-1]
    out = []
    for k, om in enumerate(Om):
        r = steady_state(system, om, q0=q0, qd0=qd0, w0=w0, **kwargs)
        out.append(r)
        q0, qd0, w0 = r.q0, r.qd0, r.w0
        log.info("sweep %s: Omega=%.6g amp=%.6g converged=%s periods=%d", direction, om,
                 r.amplitude[dof], r.converged, r.periods)
        if callback is not None:
            callback(k, r)
    A = np.array([r.amplitude for r in out])
    a = A[:, dof]
    jumps = np.nonzero(np.abs(np.diff(a)) > jump_ratio * np.maximum(a[1:], a[:-1]))[0] + 1
    conv = np.array([r.converged for r in out])
    return SweepResult(
        Omega=Om, direction=direction, amplitude=A, Q=np.array([r.Q for r in out]),
        converged=conv, stable=np.array([r.stable for r in out]),
        periods=np.array([r.periods for r in out]),
        wall_time=np.array([r.wall_time for r in out]), jumps=jumps, results=tuple(out),
        success=bool(conv.all()),
        message="all converged" if conv.all() else f"{(~conv).sum()} frequencies not converged")
