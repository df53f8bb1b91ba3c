"""Floquet multipliers of the exact flow linearised along a harmonic-balance orbit.

`floquet.from_hbm` converges the exact periodic orbit by shooting and composes its
monodromy (tens of ms a point).  Here the orbit is the harmonic-balance solution
itself: the exact contact kernel already knows, for each element, its state
sequence over the period and the exact transition times (`exact.periodic_segments`,
paper Sec. 4), so the monodromy of the piecewise-linear flow of `piecewise` is
composed directly on those pieces, without integrating anything:

    Phi_ext = expm(A_m tau_m) S_m ... S_1 expm(A_0 tau_0),

A_s the flow matrix of the discrete state s (`floquet.flow_matrix`), tau_k the
durations between consecutive transitions of any element, S_k the saltation
matrices of the switches (`floquet.switch_saltation`) at the orbit's state
y = [q, q', w] there, q and q' from the Fourier series, w from the kernel's stick
segments (or slaved).  The reduction to the Poincare vector and the verdict are
those of `floquet.monodromy`.  The cost is a few small matrix exponentials and one
eigenproblem of size 2n + (kept sliders) per point, against 2n(2H+1) for Hill.

The multipliers differ from the exact orbit's by the harmonic truncation of the
orbit (the perturbations are not truncated: unlike Hill's method, there are no
spurious exponents to select from).  Not covered (None is returned, the caller
falls back): frictionless elements (mu = 0 or ku = 0), a state sequence that does
not close over the period.
"""
from __future__ import annotations

import time

import numpy as np
from scipy.linalg import expm

from ...contact.exact import periodic_segments
from ...contact.laws import require_all
from ...model.system import System, dense
from .floquet import FloquetResult, cached_flow, classify, reduction, switch_saltation
from ..time_integration.piecewise import SEP, STICK, PiecewiseModel

TWO_PI = 2 * np.pi
_SAME_TIME = 1e-12   # transitions of several elements closer than this (rad) are one event


def element_sequences(seg, E: int) -> list:
    """Per element, its states over one period as a list of (tau in [0, 2 pi), state,
    w) in increasing tau, consecutive equal states merged (w: the stick segment's
    slider position, else NaN); a single entry when the state never changes."""
    out = []
    for e in range(E):
        if seg["regime"][e] in (0, 1):       # separated / stuck the whole period
            st = SEP if seg["regime"][e] == 0 else STICK
            out.append([(0.0, st, float(seg["w"][e, 0]) if st == STICK else np.nan)])
            continue
        used = (seg["state"][e] >= 0) & (seg["b"][e] > seg["a"][e])
        ta, st, w = seg["a"][e][used], seg["state"][e][used], seg["w"][e][used]
        keep = st != np.roll(st, 1)
        if not keep.any():
            keep[0] = True
        rows = [(float(np.mod(ta[i], TWO_PI)), int(st[i]),
                 float(w[i]) if st[i] == STICK else np.nan) for i in np.flatnonzero(keep)]
        out.append(sorted(rows))
    return out


def _state_at_start(rows):
    """Index of the row in force at tau = 0 (the last one, cyclically, if none starts at 0)."""
    return 0 if rows[0][0] == 0.0 else len(rows) - 1


def _orbit_state(Q, Om, tau):
    """[q, q'] (2n,) of the Fourier coefficients Q (n, 2H+1) at tau = Om t."""
    H = (Q.shape[1] - 1) // 2
    h = np.arange(1, H + 1)
    c, s = np.cos(h * tau), np.sin(h * tau)
    q = Q[:, 0] + Q[:, 1::2] @ c + Q[:, 2::2] @ s
    qd = Om * ((Q[:, 2::2] * h) @ c - (Q[:, 1::2] * h) @ s)
    return np.concatenate([q, qd])


def along_orbit(system: System, Omega: float, Q, tol: float = 1e-6,
                max_work: float | None = None) -> FloquetResult | None:
    """Multipliers of the flow linearised along the harmonic-balance orbit (module
    docstring); None where the method does not apply.

    system: the `System` the harmonic balance solved (e.g. `paper_systems.example3`);
    Omega [rad/s]; Q (n, 2H+1): the Fourier coefficients of all DOFs in the real layout
    [X0, Xc1, Xs1, ..., XcH, XsH] (a point of `response.frequency_response(...).Q`).
    tol: the band around |mu| = 1 of a "marginal" verdict.  Read `max_modulus`,
    `verdict` ("stable" / "unstable" / "marginal"), `multipliers` and `leaving` (the
    kinds of those outside the unit circle) of the `floquet.FloquetResult`;
    `n_events` = 0 means no contact switched: the flow is linear, exp(A T) exact.
    max_work: None is also returned where (events + 1) (2n + E)^3 exceeds it (the
    matrix exponentials' work, which dominates)."""
    tic = time.perf_counter()
    require_all(system.laws, "orbit_floquet")
    Q = np.asarray(Q, float)
    if Q.ndim != 2 or Q.shape[0] != system.n_dof or Q.shape[1] % 2 != 1:
        raise ValueError(f"Q must have shape ({system.n_dof}, 2H+1), got {Q.shape}")
    mdl = PiecewiseModel(system, Omega)
    if mdl.E == 0 or np.any(mdl.kt == 0):
        return None
    Bt, Bn = np.atleast_2d(dense(system.Bt)), np.atleast_2d(dense(system.Bn))
    seg = periodic_segments(Bt @ Q, Bn @ Q, system.contact)
    if np.any(seg["regime"] == 3):
        return None
    rows = element_sequences(seg, mdl.E)
    ptr = [_state_at_start(r) for r in rows]
    st0 = np.array([r[p][1] for r, p in zip(rows, ptr)])
    events = sorted((r[k][0], e, k) for e, r in enumerate(rows) if len(r) > 1
                    for k in range(len(r)))
    dim = 2 * mdl.n + mdl.E
    if max_work is not None and (len(events) + 1) * float(dim) ** 3 > max_work:
        return None
    Phi, flows, cur = np.eye(dim), {}, tuple(int(s) for s in st0)
    tau_prev, switched, trans, i = 0.0, set(), np.inf, 0
    while i < len(events):
        tau = events[i][0]
        group = [ev for ev in events[i:] if ev[0] - tau <= _SAME_TIME]
        i += len(group)
        if tau > tau_prev:
            Phi = expm(cached_flow(mdl, cur, flows) * ((tau - tau_prev) / Omega)) @ Phi
        w = np.array([rows[e][ptr[e]][2] for e in range(mdl.E)])
        x = _orbit_state(Q, Omega, tau)
        y = np.concatenate([x, mdl.derived_w(x, np.nan_to_num(w), np.array(cur))])
        nxt = list(cur)
        for _, e, k in group:
            ptr[e], nxt[e] = k, rows[e][k][1]
            switched.add(e)
        if tuple(nxt) != cur:
            S, _, tr = switch_saltation(mdl, tau / Omega, y, cur, tuple(nxt), flows)
            Phi, trans, cur = S @ Phi, min(trans, tr), tuple(nxt)
        tau_prev = tau
    Phi = expm(cached_flow(mdl, cur, flows) * ((TWO_PI - tau_prev) / Omega)) @ Phi
    if cur != tuple(int(s) for s in st0) or not np.all(np.isfinite(Phi)):
        return None
    Em, P, kept = reduction(mdl, st0, switched)
    mu = np.linalg.eigvals(P @ Phi @ Em)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    verdict, critical, leaving = classify(mu, tol)
    neutral = tuple(e for e in range(mdl.E) if st0[e] == STICK and e not in switched)
    x0 = _orbit_state(Q, Omega, 0.0)
    w0 = np.array([rows[e][_state_at_start(rows[e])][2] for e in range(mdl.E)])
    return FloquetResult(
        Omega=float(Omega), multipliers=mu, moduli=np.abs(mu),
        max_modulus=float(np.abs(mu).max()) if mu.size else 0.0, verdict=verdict,
        critical=critical, leaving=leaving, monodromy=P @ Phi @ Em, extended=Phi,
        stuck_sliders=tuple(kept), neutral_sliders=neutral, n_events=len(events),
        min_transversality=float(trans), x0=x0, w0=mdl.derived_w(x0, np.nan_to_num(w0), st0),
        states0=st0, wall_time=time.perf_counter() - tic, success=True, status=0,
        message="ok: linearised along the harmonic-balance orbit")
