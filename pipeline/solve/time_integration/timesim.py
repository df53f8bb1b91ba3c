"""Event-driven time integration of a `System` with Yang-Menq contacts (paper Sec. 2, 4, 5).

    M q'' + C q' + K q + Bt^T f_u + Bn^T f_v = F(t),  F(t) = Re sum_h F_h exp(i h Omega t)
    u = Bt q, v = Bn q, n = n0 + kv v                          (Eq. 1, 5-6)

The system is integrated as a Filippov system, event by event.  In every discrete
state (one of separation / stick / PS / NS per element) the equation is LINEAR with
harmonic forcing, so each piece is solved in closed form (`piecewise`, with the
contact law and the paper's transitions); the switching events are located to
machine precision and the pieces joined (`events`); the periodic steady state is
found by shooting on the Poincare map of one period (`shooting`).

This module (with those three) is the INDEPENDENT reference for the harmonic-balance
code: it evaluates no force through `pipeline.contact`, only reads the parameters.

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

from ...contact.laws import require_all
from ...model.system import System
from .events import EVENT_DTYPE, integrate
from .piecewise import NS, PS, PiecewiseModel, graded_steps
from .shooting import PoincareMap, poincare_vector, relative_defect, rest_sliders, shoot

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class TimeResult:
    """Time history of `simulate`.

    t (N,), q and qdot (N, n), w (N, E) slider positions, state (N, E) element states
    (0 separation, 1 stick, 2 positive slip, 3 negative slip; `piecewise.STATE_NAMES`).
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


def _check(system, Omega):
    if not isinstance(system, System):
        raise ValueError(f"system must be a pipeline.model.system.System, got {type(system).__name__}")
    require_all(system.laws, "timesim")
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
    mdl = PiecewiseModel(system, Omega)
    x0, w, st = _initial(mdl, q0, qd0, w0)
    return _run(mdl, t0, x0, w, st, t_end, samples_per_period, t_eval, max_events_per_period)


def _run(mdl, t0, x0, w, st, t_end, samples_per_period=128, t_eval=None,
         max_events_per_period=2000):
    out = integrate(mdl, t0, x0, w, st, t_end, True,
                    max_events_per_period=max_events_per_period)
    tf = out["t"]
    if t_eval is None:
        N = max(2, int(np.ceil((tf - t0) / mdl.T * samples_per_period)) + 1)
        t_eval = np.linspace(t0, tf, N)
    t_eval = np.asarray(t_eval, float)
    t_eval = t_eval[(t_eval >= t0) & (t_eval <= tf)]
    ev = np.array(out["events"], dtype=EVENT_DTYPE)
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

    amplitude (n,): (max q - min q)/2 over the period (extrema polished exactly; NaN,
    as Q, where the returned period could not be integrated to its end: see status);
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
    mdl = PiecewiseModel(system, Omega)
    H = max(7, int(mdl.hs.max()) if mdl.hs.size else 0) if H is None else int(H)
    x, w, st = _initial(mdl, q0, qd0, w0)
    P = PoincareMap(mdl, tol, periods_max)
    if method == "integrate":
        x, w, st, _, status, msg = P.plain(x, w, st, periods_max)
        mult = None
    else:
        x, w, st, mult, status, msg = shoot(P, x, w, st, transient_periods, newton_max,
                                            accept_unstable)
    # the returned period, recorded densely; its defect is the reported residual
    x, w, per = _recorded_period(mdl, x, w, st, P, n_samples, max_events_per_period,
                                 slider_rest and status == 0, system.contact.slider_rest)
    ze = poincare_vector(mdl, np.concatenate([per.q_final, per.qdot_final]), per.w_final,
                         per.state_final)
    res = relative_defect(ze - poincare_vector(mdl, x, w, st), ze)
    converged = bool(per.success and status == 0 and res < tol)
    if status == 0 and per.status != 0:
        status, msg = per.status, per.message
    elif status == 0:
        status = 0 if converged else 2
        msg = ("converged" if converged else
               f"not converged: periodicity residual {res:.2e} >= tol {tol:.1e} after {P.periods} periods")
    stable = True if mult is None else bool(np.abs(mult).max() <= 1 + 1e-6)
    if per.success:
        amp, Q = _amplitude(per, mdl), fourier_coefficients(per, H)
    else:                   # the period was not integrated to its end: nothing to measure
        amp, Q = np.full(mdl.n, np.nan), np.full((mdl.n, 2 * H + 1), np.nan)
    return SteadyResult(
        Omega=mdl.Om, t=per.t, q=per.q, qdot=per.qdot, w=per.w, state=per.state, amplitude=amp,
        Q=Q, H=H, q0=x[: mdl.n].copy(), qd0=x[mdl.n:].copy(), w0=w.copy(), residual=res,
        converged=converged, multipliers=mult, stable=stable, periods=P.periods,
        n_events=per.n_events, n_events_total=P.n_events + per.n_events, events=per.events,
        wall_time=time.perf_counter() - tic, success=converged, status=status, message=msg,
        period=per)


def _recorded_period(mdl, x, w, st, P, n_samples, max_events_per_period, shift, rest):
    """The period from (x, w, st), recorded at n_samples + 1 times; with `shift`, an
    event-free cycle gets its stuck sliders moved to the slider_rest convention
    `rest` (`shooting.rest_sliders`) if the shifted cycle stays event-free.  The
    periods integrated are counted in P.  Returns (x, w, TimeResult)."""
    t_eval = np.linspace(0, mdl.T, n_samples + 1)
    per = _run(mdl, 0.0, x, w, st, mdl.T, t_eval=t_eval,
               max_events_per_period=max_events_per_period)
    P.periods += 1
    if shift and per.success and per.n_events == 0:
        xr, wr = rest_sliders(mdl, rest, x, w, st, per)
        per_r = _run(mdl, 0.0, xr, wr, st, mdl.T, t_eval=t_eval,
                     max_events_per_period=max_events_per_period)
        P.periods += 1
        if per_r.success and per_r.n_events == 0:      # else keep the unshifted cycle
            x, w, per = xr, wr, per_r
        else:
            log.debug("Omega=%g: slider_rest position not admissible; slider kept", mdl.Om)
    return x, w, per


def _quadrature(res: TimeResult, t0, t1, nodes=12):
    """Gauss-Legendre nodes/weights on [t0, t1] that never straddle a piece boundary,
    on sub-intervals of at most 2/max|lambda| over the piece's modes still present
    (`piecewise.graded_steps`, each mode's share |V a_k| of the state's size)."""
    mdl = res._model
    starts = [p.t0 for p in res._pieces]
    bounds = [s for s in starts if t0 < s < t1] + [t1]
    xg, wg = np.polynomial.legendre.leggauss(nodes)
    ts, ws, a = [], [], t0
    for b in bounds:
        p = res._pieces[max(0, int(np.searchsorted(starts, a, side="right")) - 1)]
        amp = np.abs(p.mode.V) * np.abs(p.a)[None, :]
        share = (amp.max(axis=0) * np.exp(p.mode.lam.real * (a - p.t0))
                 / (np.abs(p.x(np.array([a]))).max() + amp.max() + 1e-300))
        for lo, hi, h in graded_steps(p.mode.lam, share, b - a, mdl.T, mdl.hmax_freq, 2.0):
            m = max(1, int(np.ceil((hi - lo) / h)))
            edges = a + np.linspace(lo, hi, m + 1)
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
