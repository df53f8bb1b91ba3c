"""The linear pieces of the event-driven time integration (paper Sec. 2, 4, 5).

    M q'' + C q' + K q + Bt^T f_u + Bn^T f_v = F(t),  F(t) = Re sum_h F_h exp(i h Omega t)
    u = Bt q, v = Bn q, n = n0 + kv v                          (Eq. 1, 5-6)
    separation (n <= 0):  f_u = f_v = 0, slider follows (w = u)
    contact:              f_v = n                              (Eq. 10)
      stick               f_u = ku (u - w), w constant, |f_u| < mu n
      positive slip (PS)  f_u = +mu n,  w = u - mu n/ku,  w' > 0  (Eq. 9)
      negative slip (NS)  f_u = -mu n,  w = u + mu n/ku,  w' < 0

In every discrete state (one of separation / stick / PS / NS per element) the
equation is LINEAR with harmonic forcing, so each piece is solved in closed form:

    x = [q; q'],  x' = A_s x + c_s(w) + b(t)
    x(t) = Re V exp(Lambda (t - t0)) a + x_p(t),   x_p = [q_s; 0] + Re sum_h X_h e^{ih Om t}

(eigen-decomposition A_s = V Lambda V^-1, static part K_s q_s = F_0 - g_s(w), harmonic
part (K_s - (h Om)^2 M + i h Om C) Q_h = F_h).  The switching functions of a state
are affine in x; when one becomes > 0, `transition` gives the element's new state:

    stick -> PS/NS   when ku (u - w) reaches +-mu n                (Sec. 4.4)
    PS/NS -> stick   when the slider velocity u' -+ mu kv v'/ku changes sign (4.2, 4.3)
    contact -> sep.  when n crosses 0 downwards
    sep. -> contact  when n crosses 0 upwards; the spring restarts unstrained (w = u)
                     and f1 = u', f2 = mu kv/ku v' select PS (f1 > f2), NS (f1 < -f2)
                     or stick (Sec. 4.1)

kv = 0 is a constant normal load n0 (Jenkins element); mu = 0 or ku = 0 gives no
tangential force (the element is labelled stick with a zero spring).

`PiecewiseModel` holds the system for one Omega and caches the closed-form data of
each state it meets; a `Piece` is the solution from one state's start (t0, x0).
Like all of the time integration, this module evaluates no force through
`pipeline.contact`, it only reads the parameters.
"""
from __future__ import annotations

import numpy as np

from ...contact.laws import require_all
from ...model.system import System, dense
from ..harmonic_balance.dynamic_stiffness import at_harmonic

SEP, STICK, PS, NS = 0, 1, 2, 3
STATE_NAMES = ("separation", "stick", "positive slip", "negative slip")
# switching-function kinds: which transition fires when the function becomes > 0
_TD, _LO, _TPS, _TNS, _TST = 0, 1, 2, 3, 4


# --------------------------------------------------------------------------- model
def state_matrices(mdl: "PiecewiseModel", states) -> tuple:
    """(K_s, Wm_s, p0_s): stiffness with the contacts of the discrete state, the stuck
    springs' action on the sliders w, and the constant force (preloads) [N]."""
    n, E = mdl.n, mdl.E
    K = mdl.K.copy()
    g0 = np.zeros(n)                      # constant contact force (w-free part)
    Wm = np.zeros((n, E))                 # RHS += Wm @ w (stuck springs)
    for e, st in enumerate(states):
        if st == SEP:
            continue
        bt, bn = mdl.Bt[e], mdl.Bn[e]
        K += mdl.kv[e] * np.outer(bn, bn)
        g0 += mdl.n0[e] * bn
        if st == STICK:
            K += mdl.kt[e] * np.outer(bt, bt)
            Wm[:, e] = mdl.kt[e] * bt
        else:
            sg = 1.0 if st == PS else -1.0
            K += sg * mdl.mu[e] * mdl.kv[e] * np.outer(bt, bn)
            g0 += sg * mdl.mu[e] * mdl.n0[e] * bt
    return K, Wm, mdl.F0 - g0


class _Mode:
    """Closed-form solution data of one discrete state (tuple of element states)."""

    def __init__(self, mdl: "PiecewiseModel", states: tuple):
        n = mdl.n
        s = np.asarray(states)
        self.states = tuple(int(v) for v in s)
        self.K, self.Wm, self.p0 = mdl.matrices(self.states)
        K = self.K
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
            S = at_harmonic(K, mdl.M, mdl.C, h, Om)
            Q = np.linalg.solve(S, mdl.Fh[:, k])
            Xh[:n, k] = Q
            Xh[n:, k] = 1j * h * Om * Q
        self.Xh = Xh
        self._switching_functions(mdl, s)

    def _switching_functions(self, mdl: "PiecewiseModel", s):
        """The switching functions g_j(x, w) = c_j . x + d0_j + dw_j w_e of the state s
        (element states); the event of g_j when it becomes > 0, its `kind`."""
        n, E = mdl.n, mdl.E
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
        self.CV = self.Csw @ self.V
        self.CXh = self.Csw @ self.Xh
        self.cabs = np.abs(self.Csw)


class PiecewiseModel:
    """System matrices, element parameters and a cache of `_Mode`s for one Omega."""

    def __init__(self, system: System, Om: float):
        require_all(system.laws, "timesim")   # the flow has the Yang-Menq element's events only
        # dense: the closed-form pieces need eigenvectors of the whole state matrix
        self.M, self.C, self.K = dense(system.M), dense(system.C), dense(system.K)
        self.Bt = np.atleast_2d(dense(system.Bt))
        self.Bn = np.atleast_2d(dense(system.Bn))
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
        self._matrices: dict = {}
        self.hmax_freq = (self.hs.max() if self.hs.size else 0) * self.Om

    def matrices(self, states) -> tuple:
        """(K_s, Wm_s, p0_s) of the discrete state: q'' = M^-1 (F(t) + p0_s + Wm_s w -
        K_s q - C q') (module docstring), cached; no closed-form data (`mode`)."""
        key = tuple(int(v) for v in states)
        out = self._matrices.get(key)
        if out is None:
            out = self._matrices[key] = state_matrices(self, key)
        return out

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
_DECAYED = 1e-17   # a mode's share of a quantity below this (relative): gone


def graded_steps(lam, share, span, T, floor_freq, per_rad):
    """[(start, end, step)] covering [0, span] of a piece: on each interval the step
    is per_rad / max|lambda| over the modes still present there (at most T/64),
    mode k being present until its share (its term's size relative to the quantity
    sampled) has decayed below _DECAYED: share_k e^(Re lambda_k t) < _DECAYED.  A stiff
    mode that has decayed no longer sets the step: on a Craig-Bampton blade the
    boundary DOFs' modes (|lambda| ~ 1e9) vanish within nanoseconds, and a uniform
    step for them would take millions of samples per period; the terms left out
    are below _DECAYED of what is sampled."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        life = np.where(lam.real < 0, np.log(np.maximum(share / _DECAYED, 1.0)) / -lam.real,
                        np.inf)
    out, start = [], 0.0
    for end in np.unique(np.concatenate([life[life < span], [span]])):
        alive = life >= end                  # the modes still present on (start, end]
        f = max(np.abs(lam[alive]).max() if alive.any() else 0.0, floor_freq, 1e-300)
        if end > start:
            out.append((start, end, min(T / 64, per_rad / f)))
        start = end
    return out


class Piece:
    """Closed-form solution from (t0, x0) in one mode with slider positions w."""

    __slots__ = ("mode", "mdl", "t0", "w", "qs", "a", "gconst", "t1")

    def __init__(self, mdl: PiecewiseModel, mode: _Mode, t0, x0, w):
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


def transition(mdl: PiecewiseModel, e, kind, x, old):
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
