"""Floquet multipliers of a periodic orbit of the exact (event-driven) flow.

The reference for the stability of harmonic-balance points: the monodromy matrix
of the piecewise-linear Filippov flow of `piecewise` / `events`, composed from the
closed-form pieces and the saltation matrices of the switching events.

State of the flow.  The extended vector y = [q; q'; w] (size 2n + E, one slider
position per element) with, in the discrete state s (one of separation / stick /
PS / NS per element; `piecewise` for the equations),

    q'' = M^-1 (F(t) + p0_s + Wm_s w - K_s q - C q')      (Wm_s: the stuck springs)
    w_e' = 0                       stick (w is a memory state)
    w_e' = (bt_e -+ r_e bn_e) q'    PS / NS: w = u -+ mu n/ku, r = mu kv/ku (slaved)
    w_e' = bt_e q'                 separation: the slider follows, w = u

so y' = A_s y + b(t) is linear and the state-transition matrix of a piece of
duration tau is expm(A_s tau) (scipy.linalg.expm; the forcing b(t) does not enter).
At an event where g(y) = 0 (g affine, its gradient `event_gradient`) the element
switches s- -> s+ and the state jumps, y+ = R y- + c (`jump_map`): the new w_e
is u -+ mu n/ku for slip, u for separation and for touchdown (the memory is
erased; a stick entered from slip keeps the slaved value, so it is continuous).
The saltation matrix of a jump map is

    S = R + (f+ - R f-) grad g^T / (grad g^T f-),   f-+ = A_s-+ y-+ + b(t_e),

(for R = I the familiar S = I + (f+ - f-) grad g^T / (grad g^T f-)), and the
extended monodromy is  Phi_ext = expm(A_m tau_m) S_m ... S_1 expm(A_0 tau_0).

Trivial multipliers.  A slider that is slaved at t = 0 (slip, separation) is not
an independent state, and the slider of an element stuck through the whole
period is a neutral direction (every w in the stuck interval gives a periodic
cycle: multiplier exactly 1).  Both are removed by restricting the map to the
Poincare vector z = [q, q', w_S], S = the elements stuck at t = 0 that switch
during the period:  Phi = P Phi_ext E with E the embedding z -> y (slaved rows of
the states at t = 0, the always-stuck sliders held fixed) and P the projection
y -> z.  The eigenvalues of Phi are the Floquet multipliers; Phi_ext has the same
ones plus 1 per always-stuck slider and 0 per slaved one (`FloquetResult`).  A kept
slider is overwritten by its own slip (its value afterwards is a function of q), so
Phi has rank <= 2n: one multiplier 0 per kept slider, harmless to the verdict.

`finite_difference_monodromy` differentiates the period map itself (central
differences of `events.integrate`, the discrete states re-determined from every
perturbed start): the independent check of the saltation product.
`from_hbm` starts the integrator on a harmonic-balance solution, converges the
periodic orbit by shooting (`timesim.steady_state`) and returns its multipliers;
`from_steady_state` takes a converged steady state as it is.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.linalg import expm

from ...contact.laws import require_all
from ...model.system import System
from ..time_integration.events import integrate
from ..time_integration.piecewise import NS, PS, SEP, STICK, PiecewiseModel
from ..time_integration.timesim import steady_state

MULTIPLIER_KINDS = ("fold", "period doubling", "Neimark-Sacker")


@dataclass(frozen=True)
class FloquetResult:
    """Floquet multipliers of one periodic orbit (or of one period from a start).

    multipliers (m,) eigenvalues of the reduced monodromy `monodromy` (m, m), sorted
    by decreasing modulus; moduli their |mu|; max_modulus the largest.
    verdict: "stable" (max |mu| < 1 - tol), "unstable" (> 1 + tol) or "marginal".
    critical: the kind of the largest multiplier, leaving: the kinds of those
    outside the unit circle (+1 side "fold", -1 side "period doubling", complex
    pair "Neimark-Sacker"); crossing = |Im mu| > 1e-9 |mu| for a complex pair.
    stuck_sliders: elements whose w is in the state (stuck at t = 0, switching
    later); neutral_sliders: elements stuck all period (w held, multiplier 1
    dropped).  extended (2n+E, 2n+E): Phi_ext of the flow in y = [q, q', w].
    n_events: switches in the period; min_transversality: min over events of
    |grad g . f-| / (|grad g| |f-|) (near 0: a grazing event, the saltation is
    ill-conditioned).  orbit_converged / orbit_residual: of the shooting when the
    orbit was converged here (`from_hbm`), else None.
    success/status/message: status 0 ok, -1 the integrator failed in the period.
    """

    Omega: float
    multipliers: np.ndarray
    moduli: np.ndarray
    max_modulus: float
    verdict: str
    critical: str
    leaving: tuple
    monodromy: np.ndarray = field(repr=False)
    extended: np.ndarray = field(repr=False)
    stuck_sliders: tuple
    neutral_sliders: tuple
    n_events: int
    min_transversality: float
    x0: np.ndarray = field(repr=False)
    w0: np.ndarray = field(repr=False)
    states0: np.ndarray = field(repr=False)
    wall_time: float
    success: bool
    status: int
    message: str
    orbit_converged: bool | None = None
    orbit_residual: float | None = None

    @property
    def stable(self) -> bool:
        return self.verdict == "stable"


# --------------------------------------------------------------------------- the flow
def slaved_map(mdl: PiecewiseModel, e: int, state: int):
    """(row (n,), constant) of the slaved slider w_e = row . q + constant in `state`
    (PS: u - mu n/ku, NS: u + mu n/ku, separation: u); stick has no slaved form."""
    bt, bn = mdl.Bt[e], mdl.Bn[e]
    if state == SEP or mdl.kt[e] == 0:
        return bt.copy(), 0.0
    if state not in (PS, NS):
        raise ValueError(f"state must be separation, PS or NS, got {state!r}")
    sg = 1.0 if state == PS else -1.0
    return bt - sg * mdl.r[e] * bn, -sg * mdl.mu[e] * mdl.n0[e] / mdl.kt[e]


def flow_matrix(mdl: PiecewiseModel, states) -> np.ndarray:
    """A_s (2n+E, 2n+E) of y' = A_s y + b(t), y = [q, q', w], in the discrete state."""
    n, E = mdl.n, mdl.E
    K, Wm, _ = mdl.matrices(states)
    A = np.zeros((2 * n + E, 2 * n + E))
    A[:n, n:2 * n] = np.eye(n)
    A[n:2 * n, :n] = -mdl.Minv @ K
    A[n:2 * n, n:2 * n] = -mdl.Minv @ mdl.C
    A[n:2 * n, 2 * n:] = mdl.Minv @ Wm
    for e, s in enumerate(states):
        if s != STICK:
            A[2 * n + e, n:2 * n] = slaved_map(mdl, e, s)[0]
    return A


def vector_field(mdl: PiecewiseModel, states, t: float, y, A=None) -> np.ndarray:
    """f = A_s y + b(t): the right-hand side of the extended flow at time t."""
    n = mdl.n
    A = flow_matrix(mdl, states) if A is None else A
    F = mdl.matrices(states)[2].copy()
    if mdl.hs.size:
        F += (mdl.Fh @ np.exp(1j * mdl.hs * mdl.Om * t)).real
    f = A @ y
    f[n:2 * n] += mdl.Minv @ F
    return f


def event_gradient(mdl: PiecewiseModel, e: int, old: int, new: int) -> np.ndarray:
    """grad g (2n+E) of the switching function of element e for old -> new (`piecewise`)."""
    n = mdl.n
    g = np.zeros(2 * n + mdl.E)
    bt, bn, kv = mdl.Bt[e], mdl.Bn[e], mdl.kv[e]
    if old == SEP:                               # touchdown: n = n0 + kv v reaches 0
        g[:n] = kv * bn
    elif new == SEP:                             # lift-off
        g[:n] = -kv * bn
    elif old == STICK:                           # +-ku (u - w) reaches mu n
        sg = 1.0 if new == PS else -1.0
        g[:n] = sg * mdl.kt[e] * bt - mdl.mu[e] * kv * bn
        g[2 * n + e] = -sg * mdl.kt[e]
    else:                                        # slider velocity u' -+ r v' reaches 0
        sg = 1.0 if old == PS else -1.0
        g[n:2 * n] = -sg * (bt - sg * mdl.r[e] * bn)
    return g


def jump_map(mdl: PiecewiseModel, e: int, old: int, new: int):
    """(R, c): y+ = R y- + c when element e switches old -> new (only w_e moves)."""
    n = mdl.n
    R = np.eye(2 * n + mdl.E)
    c = np.zeros(2 * n + mdl.E)
    row, const = slaved_map(mdl, e, old if new == STICK else new)
    R[2 * n + e] = 0.0
    R[2 * n + e, :n] = row
    c[2 * n + e] = const
    return R, c


def saltation(R, grad, f_minus, f_plus, scale=None):
    """S = R + (f+ - R f-) grad^T / (grad^T f-) and the transversality of the crossing,
    |grad . f-| / (|grad / scale| |scale f-|) (scale: the state's units, e.g. 1/Omega
    on q', so that the cosine does not mix m and m/s)."""
    den = float(grad @ f_minus)
    d = np.ones(grad.size) if scale is None else scale
    trans = abs(den) / max(np.linalg.norm(grad / d) * np.linalg.norm(d * f_minus), 1e-300)
    return R + np.outer(f_plus - R @ f_minus, grad) / den, trans


def switch_saltation(mdl, t, y, sa, sb, flows):
    """Saltation product and state after the switches sa -> sb at time t, one element
    at a time through the intermediate states; (S, y+, min transversality)."""
    S = np.eye(y.size)
    cur, trans = tuple(sa), np.inf
    for e in [k for k in range(mdl.E) if sa[k] != sb[k]]:
        nxt = cur[:e] + (sb[e],) + cur[e + 1:]
        R, c = jump_map(mdl, e, cur[e], sb[e])
        yp = R @ y + c
        fm = vector_field(mdl, cur, t, y, cached_flow(mdl, cur, flows))
        fp = vector_field(mdl, nxt, t, yp, cached_flow(mdl, nxt, flows))
        d = np.ones(y.size)
        d[mdl.n:2 * mdl.n] = 1.0 / mdl.Om
        Se, tr = saltation(R, event_gradient(mdl, e, cur[e], sb[e]), fm, fp, d)
        S, y, cur, trans = Se @ S, yp, nxt, min(trans, tr)
    return S, y, trans


def cached_flow(mdl, states, flows):
    """flow_matrix of `states`, memoised in the dict `flows`."""
    key = tuple(int(s) for s in states)
    if key not in flows:
        flows[key] = flow_matrix(mdl, key)
    return flows[key]


def extended_monodromy(mdl: PiecewiseModel, x0, w0, states0, t0: float = 0.0):
    """Phi_ext over [t0, t0 + T] from (x0, w0, states0) by the saltation product.

    Returns (Phi_ext, info) with info: n_events, switched (set of elements that
    switched), min_transversality, status and message of the integration."""
    out = integrate(mdl, t0, np.asarray(x0, float), np.asarray(w0, float),
                    np.asarray(states0, int), t0 + mdl.T, True)
    pieces, dim = out["pieces"], 2 * mdl.n + mdl.E
    info = dict(n_events=out["n_events"], status=out["status"], message=out["message"],
                switched={int(ev[1]) for ev in out["events"]}, min_transversality=np.inf)
    Phi, flows = np.eye(dim), {}
    for k, p in enumerate(pieces):
        last = k + 1 == len(pieces)
        t1 = out["t"] if last else pieces[k + 1].t0
        if t1 > p.t0:
            Phi = expm(cached_flow(mdl, p.mode.states, flows) * (t1 - p.t0)) @ Phi
        if last or pieces[k + 1].mode.states == p.mode.states:
            continue
        x = p.x(t1)[:, 0]
        y = np.concatenate([x, mdl.derived_w(x, p.w, np.asarray(p.mode.states))])
        S, _, tr = switch_saltation(mdl, t1, y, p.mode.states, pieces[k + 1].mode.states, flows)
        Phi = S @ Phi
        info["min_transversality"] = min(info["min_transversality"], tr)
    return Phi, info


def reduction(mdl: PiecewiseModel, states0, switched):
    """(E, P, kept): embedding z -> y (2n+E, m), projection y -> z and the sliders kept
    in z = [q, q', w_kept] (stuck at t = 0 and switching in the period)."""
    n, Et = mdl.n, mdl.E
    kept = [e for e in range(Et) if states0[e] == STICK and mdl.kt[e] > 0 and e in switched]
    m = 2 * n + len(kept)
    Em, P = np.zeros((2 * n + Et, m)), np.zeros((m, 2 * n + Et))
    Em[:2 * n, :2 * n] = P[:2 * n, :2 * n] = np.eye(2 * n)
    for i, e in enumerate(kept):
        Em[2 * n + e, 2 * n + i] = P[2 * n + i, 2 * n + e] = 1.0
    for e in range(Et):
        if states0[e] != STICK:
            Em[2 * n + e, :n] = slaved_map(mdl, e, states0[e])[0]
    return Em, P, kept


# --------------------------------------------------------------------------- verdict
def classify(multipliers, tol: float = 1e-6):
    """(verdict, critical kind, kinds of the leaving multipliers) of multipliers."""
    mu = np.asarray(multipliers, complex)
    if mu.size == 0:
        return "stable", "", ()

    def kind(z):
        if abs(z.imag) > 1e-9 * abs(z):
            return "Neimark-Sacker"
        return "fold" if z.real > 0 else "period doubling"

    mod = np.abs(mu)
    top = float(mod.max())
    verdict = "unstable" if top > 1 + tol else ("stable" if top < 1 - tol else "marginal")
    out = mu[mod > 1 + tol]
    leaving = tuple(dict.fromkeys(kind(z) for z in out[np.argsort(-np.abs(out))]))
    return verdict, kind(mu[int(np.argmax(mod))]), leaving


def _check(system, Omega, x0, w0, states0):
    if not isinstance(system, System):
        raise ValueError(f"system must be a pipeline.model.system.System, got {type(system).__name__}")
    require_all(system.laws, "shooting")
    if system.cyclic is not None:
        raise ValueError("system is a cyclic sector (System.cyclic): use its N-sector assembly")
    if not (np.isfinite(Omega) and Omega > 0):
        raise ValueError(f"Omega must be a positive finite frequency [rad/s], got {Omega!r}")
    n, E = system.n_dof, system.n_elements
    x0, w0, st = (np.asarray(a, dt).ravel() for a, dt in ((x0, float), (w0, float), (states0, int)))
    for name, a, k in (("x0", x0, 2 * n), ("w0", w0, E), ("states0", st, E)):
        if a.size != k:
            raise ValueError(f"{name} must have {k} entries, got {a.size}")
    if np.any((st < SEP) | (st > NS)):
        raise ValueError(f"states0 must hold element states 0..3, got {st}")
    return x0, w0, st


# --------------------------------------------------------------------------- entry points
def monodromy(system: System, Omega: float, x0, w0, states0, tol: float = 1e-6) -> FloquetResult:
    """Floquet multipliers of the period from x0 = [q, q'] (2n), slider positions w0 (E)
    and element states states0 (E) at t = 0, by the saltation product (module
    docstring).  On a periodic orbit they are its multipliers; `tol` is the margin
    of the verdict around |mu| = 1."""
    x0, w0, st = _check(system, Omega, x0, w0, states0)
    tic = time.perf_counter()
    mdl = PiecewiseModel(system, Omega)
    Phi_ext, info = extended_monodromy(mdl, x0, w0, st)
    Em, P, kept = reduction(mdl, st, info["switched"])
    Phi = P @ Phi_ext @ Em
    ok = info["status"] == 0
    mu = np.linalg.eigvals(Phi) if ok else np.full(Phi.shape[0], np.nan + 0j)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    verdict, critical, leaving = classify(mu, tol) if ok else ("failed", "", ())
    neutral = tuple(e for e in range(mdl.E) if st[e] == STICK and mdl.kt[e] > 0
                    and e not in info["switched"])
    return FloquetResult(
        Omega=float(Omega), multipliers=mu, moduli=np.abs(mu),
        max_modulus=float(np.abs(mu).max()) if mu.size else 0.0, verdict=verdict,
        critical=critical, leaving=leaving, monodromy=Phi, extended=Phi_ext,
        stuck_sliders=tuple(kept), neutral_sliders=neutral, n_events=info["n_events"],
        min_transversality=float(info["min_transversality"]), x0=x0, w0=w0, states0=st,
        wall_time=time.perf_counter() - tic, success=ok, status=0 if ok else -1,
        message="ok" if ok else info["message"])


def period_map(mdl: PiecewiseModel, z, w0, states0, kept):
    """z one period later: z = [q, q', w_kept]; the other sliders slaved (or held at
    w0 when stuck), the discrete states re-determined from the perturbed start
    (`PiecewiseModel.classify`).  None if the integration fails."""
    n = mdl.n
    x = z[:2 * n]
    w = np.array(w0, float)
    w[kept] = z[2 * n:]
    w = mdl.derived_w(x, w, np.asarray(states0))
    st, w = mdl.classify(x, w)
    out = integrate(mdl, 0.0, x, w, st, mdl.T, False)
    if out["status"] != 0:
        return None
    wT = mdl.derived_w(out["x"], out["w"], out["st"])
    return np.concatenate([out["x"], wT[kept]])


def finite_difference_monodromy(system: System, Omega: float, x0, w0, states0, kept=None,
                                rel_step: float = 1e-6) -> np.ndarray:
    """Central differences of the period map in z = [q, q', w_kept] (`period_map`);
    kept defaults to the sliders `monodromy` keeps.  The step of each entry is
    rel_step times the largest |entry| of its block (q, q' or w).  NaN columns
    where a perturbed period fails."""
    x0, w0, st = _check(system, Omega, x0, w0, states0)
    mdl = PiecewiseModel(system, Omega)
    if kept is None:
        _, info = extended_monodromy(mdl, x0, w0, st)
        kept = reduction(mdl, st, info["switched"])[2]
    kept = list(kept)
    n = mdl.n
    z0 = np.concatenate([x0, w0[kept]])
    blocks = [slice(0, n), slice(n, 2 * n), slice(2 * n, z0.size)]
    h = np.empty(z0.size)
    for b in blocks:
        h[b] = rel_step * max(np.abs(z0[b]).max(initial=0.0), 1e-12)
    J = np.full((z0.size, z0.size), np.nan)
    for k in range(z0.size):
        dz = np.zeros(z0.size)
        dz[k] = h[k]
        fp, fm = period_map(mdl, z0 + dz, w0, st, kept), period_map(mdl, z0 - dz, w0, st, kept)
        if fp is not None and fm is not None:
            J[:, k] = (fp - fm) / (2 * h[k])
    return J


def hbm_initial_state(system: System, Omega: float, Q, samples: int = 1024):
    """(q0, q0', w0) at t = 0 of the harmonic-balance solution Q (n, 2H+1), real
    layout of `harmonics.py`.  w0 from the slider history over two periods of the
    HBM motion (stick: w kept inside u -+ mu n/ku; separation: w = u)."""
    Q = np.asarray(Q, float)
    if Q.ndim != 2 or Q.shape[0] != system.n_dof or Q.shape[1] % 2 != 1:
        raise ValueError(f"Q must have shape ({system.n_dof}, 2H+1), got {Q.shape}")
    H = (Q.shape[1] - 1) // 2
    h = np.arange(1, H + 1)
    q0 = Q[:, 0] + Q[:, 1::2].sum(axis=1)
    qd0 = Omega * (Q[:, 2::2] * h).sum(axis=1)
    mdl = PiecewiseModel(system, Omega)
    tau = np.linspace(0.0, 4 * np.pi, 2 * samples + 1)
    q = Q[:, :1] + Q[:, 1::2] @ np.cos(np.outer(h, tau)) + Q[:, 2::2] @ np.sin(np.outer(h, tau))
    u, nrm = mdl.Bt @ q, mdl.n0[:, None] + mdl.kv[:, None] * (mdl.Bn @ q)
    half = np.where(mdl.kt > 0, mdl.mu / np.where(mdl.kt > 0, mdl.kt, 1.0), 0.0)[:, None] * nrm
    w = u[:, 0].copy()
    for k in range(tau.size):
        w = np.where(nrm[:, k] <= 0, u[:, k], np.clip(w, u[:, k] - half[:, k], u[:, k] + half[:, k]))
    return q0, qd0, w


def from_steady_state(system: System, steady, tol: float = 1e-6) -> FloquetResult:
    """Multipliers of a `timesim.steady_state` result (its start q0, qd0, w0 and the
    element states at t = 0)."""
    res = monodromy(system, steady.Omega, np.concatenate([steady.q0, steady.qd0]), steady.w0,
                    steady.state[0], tol)
    return replace(res, orbit_converged=bool(steady.converged),
                   orbit_residual=float(steady.residual))


def from_hbm(system: System, Omega: float, Q, tol: float = 1e-6, shooting_tol: float = 1e-11,
             periods_max: int = 200, newton_max: int = 12) -> FloquetResult:
    """Multipliers of the periodic orbit nearest the HBM solution Q (n, 2H+1) at Omega.

    The integrator starts on Q's state at t = 0 (`hbm_initial_state`); shooting
    (`timesim.steady_state`, Newton first, unstable orbits accepted) converges the
    orbit, whose multipliers are returned.  If it does not converge, the multipliers
    of the HBM-started period are returned, with orbit_converged False."""
    require_all(system.laws, "shooting")
    q0, qd0, w0 = hbm_initial_state(system, Omega, Q)
    ss = steady_state(system, Omega, q0=q0, qd0=qd0, w0=w0, tol=shooting_tol,
                      transient_periods=0, newton_max=newton_max, periods_max=periods_max,
                      accept_unstable=True)
    if ss.converged:
        x0, w, st = np.concatenate([ss.q0, ss.qd0]), ss.w0, ss.state[0]
    else:
        mdl = PiecewiseModel(system, Omega)
        x0 = np.concatenate([q0, qd0])
        st, w = mdl.classify(x0, w0)
    res = monodromy(system, Omega, x0, w, st, tol)
    return replace(res, orbit_converged=bool(ss.converged), orbit_residual=float(ss.residual))
