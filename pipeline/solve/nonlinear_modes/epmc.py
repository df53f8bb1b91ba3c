"""Nonlinear modes by the extended periodic motion concept (EPMC; Krack 2015).

The autonomous structure with its contacts, M q'' + C q' + K q + g(q) = 0, has no
periodic motion where friction dissipates.  The EPMC adds a negative mass-proportional
damping that compensates the dissipation,

    M q'' + (C - 2 zeta omega M) q' + K q + g(q) = 0,

and defines the nonlinear mode at the modal amplitude a as its periodic motion: the
frequency omega(a), the modal damping ratio zeta(a) and the shape.  In harmonic
balance (real layout of `fourier.harmonics`, Q (n, 2H+1)) the motion is

    Q = [Q_0, a Psi_1c, a Psi_1s, ..., a Psi_Hc, a Psi_Hs],

the static part Q_0 [m] kept physical (a preload's static deflection does not scale
with the vibration) and the harmonics h >= 1 written as a times the shape Psi.  The
unknowns are y = [Q_0, Psi (n 2H), omega, zeta] at a given s = log10 a; the equations

    R_0 = (L(omega, zeta) Q + G(Q))_0                            [N]
    R_h = (L(omega, zeta) Q + G(Q))_h / a,  h >= 1               [N per unit a]
    sum_{h>=1} Psi_hc^T M Psi_hc + Psi_hs^T M Psi_hs = 1         (amplitude)
    sum_{h>=1} h Psi_hs[ref] = 0                                 (phase)

with L the linear operator of `dynamic_stiffness` plus the EPMC term
Term(-2 zeta M, 1, True, 1) (i h omega (-2 zeta omega) M on harmonic h) and G the
contact forces of `hbm.contact_terms` (exact or AFT, with their Jacobian).  By default
the unknowns are the contact DOFs' rows of Z only, the others recovered per harmonic
as the forced response recovers them (`condensed`); `mode_problem(condense=False)`
keeps every DOF's rows as unknowns (below).

Amplitude: the shape is mass-normalised over all harmonics of the vibration
(h >= 1; NLvib normalises over all harmonics including h = 0, which a preload's static
deflection would dominate at small amplitude).  The phase condition makes the velocity
of DOF `ref` vanish at t = 0 (as NLvib).  A cyclic sector's mode is the travelling wave
of nodal diameter ND = its engine order, normalised with the sector's mass.

The Jacobian is analytic in every unknown and in s:
d(L Q)/d omega and d(L Q)/d zeta from the kernel (`dynamic_stiffness.apply_full` with
rate=True, `apply_terms` of the term at zeta = 1), dQ/ds = ln 10 Q_h.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sla

from ...fourier.harmonics import derivative_matrix
from ...model.static_load import StaticState, static_state
from ...model.system import (System, contact_set, dense, inertia_coupled, linear_stiffness,
                             with_preload)
from ..harmonic_balance.dynamic_stiffness import Term, apply_full, apply_terms
from ..harmonic_balance.full_operators import full_linear_operator
from ..harmonic_balance.hbm import HBMProblem, contact_terms, setup
from .condensed import Condensation, condensation, recover
from .condensed import evaluate as evaluate_condensed

LN10 = np.log(10.0)


@dataclass(frozen=True, eq=False)
class ModeProblem:
    """A system prepared for the EPMC with H harmonics: the harmonic-balance model
    (contacts, maps), the DOF `ref` of the phase condition, dense M, C, and the linear
    mode it starts from (`omega0` [rad/s], `zeta0` [-], `shape` (n,) complex,
    mass-normalised, `shape[ref]` real)."""

    hbm: HBMProblem
    ref: int
    M: np.ndarray
    C: np.ndarray
    omega0: float
    zeta0: float
    shape: np.ndarray
    static: StaticState | None = None   # the unilateral static state it starts from
    condensed: Condensation | None = None  # the unknowns on the contact DOFs only

    @property
    def n(self) -> int:
        return self.M.shape[0]

    @property
    def kept(self) -> np.ndarray:
        """The DOFs whose coefficients are unknowns: the contact DOFs when condensed."""
        return np.arange(self.n) if self.condensed is None else self.condensed.c

    @property
    def H(self) -> int:
        return self.hbm.H

    @property
    def size(self) -> int:
        """Unknowns (and equations) at one amplitude: n (2H+1) + 2 (n_c when condensed)."""
        return self.kept.size * (2 * self.H + 1) + 2


def static_start(system: System) -> StaticState:
    """The unilateral static contact state the mode starts from (`static_load.
    static_state`) with the forcing ignored, as the EPMC ignores it: an element that
    would pull is open, the others closed and stuck at their static normal load."""
    return static_state(replace(system, forcing=np.zeros_like(system.forcing)))


def linear_mode(system: System, mode: int = 0, closed=None):
    """(omega [rad/s], shape (n,) complex, M-normalised) of the linear mode `mode`
    (0: the lowest) of the small-amplitude limit: the `closed` elements of the
    `contact_set` stuck in both directions, the others open (default: the closed ones
    of the unilateral static state, `static_start`; a cyclic sector's engine-order
    family)."""
    if closed is None:
        closed = static_start(system).closed
    signed = with_preload(system, np.where(closed, 1.0, -1.0)) if np.size(closed) else system
    K = linear_stiffness(signed, "small")     # reads only the sign of n0
    M = dense(system.M)
    w2, V = sla.eigh(K, M)
    if not 0 <= mode < w2.size:
        raise ValueError(f"mode must be in 0..{w2.size - 1}, got {mode}")
    phi = V[:, mode].astype(complex)
    return float(np.sqrt(abs(w2[mode]))), phi / np.sqrt(np.real(phi.conj() @ M @ phi))


def mode_problem(system: System, H: int, mode: int = 0, method: str = "exact",
                 n_samples: int = 256, ref: int | None = None, start=None,
                 condense: bool = True) -> ModeProblem:
    """Prepare the EPMC of the linear mode `mode` of `system` (its forcing is ignored).
    `ref` (default: the DOF with the largest kinetic-energy share of the linear mode,
    |phi_i (M phi)_i|) carries the phase condition.  `start` = (omega [rad/s], shape
    (n,) complex) replaces the linear mode the continuation starts from (e.g. a cyclic
    sector's travelling wave expanded to the whole wheel, where the linear modes of a
    nodal diameter come in degenerate pairs); it is M-normalised here.  `condense`
    (default) keeps the contact DOFs' coefficients as the unknowns and recovers the
    others (`condensed`); False solves for all DOFs."""
    if inertia_coupled(system):
        raise ValueError("nonlinear modes of a sector whose mass couples it to its neighbours "
                         "(a flexible disk) are not available: solve the forced response")
    prob = setup(system, H, method, n_samples)
    M, C = dense(system.M), dense(system.C)
    st = static_start(system)
    if start is None:
        omega0, phi = linear_mode(system, mode, st.closed)
    else:
        omega0, phi = float(start[0]), np.asarray(start[1], complex)
        phi = phi / np.sqrt(np.real(phi.conj() @ M @ phi))
    if ref is None:
        ref = int(np.argmax(np.abs(phi.conj() * (M @ phi))))
    if not 0 <= ref < system.n_dof:
        raise ValueError(f"ref must be a DOF index in 0..{system.n_dof - 1}, got {ref}")
    phi = phi * np.exp(-1j * np.angle(phi[ref]))
    zeta0 = float(np.real(phi.conj() @ C @ phi)) / (2.0 * omega0)
    cd = condensation(system, H, prob.c, M) if condense else None
    return ModeProblem(prob, int(ref), M, C, omega0, zeta0, phi, st, cd)


def onset_amplitude(mp) -> float:
    """The smallest modal amplitude [kg^0.5 m] at which a closed element of the linear
    mode slips (mu s / (ku |u|)) or lifts off (s / (kv |v|)), s its static normal load
    in the unilateral static state the mode starts from (`ModeProblem.static`; n0
    without one), u, v per unit amplitude; open elements do not count."""
    sysm = mp.hbm.system
    Bt, Bn = dense(sysm.Bt).astype(complex), dense(sysm.Bn).astype(complex)
    cy = sysm.cyclic
    if cy is not None:
        z = np.exp(1j * cy.phase)
        Bt, Bn = Bt + z * dense(cy.Bt_next), Bn + z * dense(cy.Bn_next)
    u, v = np.abs(Bt @ mp.shape), np.abs(Bn @ mp.shape)
    el = sysm.contact
    s = el.n0
    if mp.static is not None and contact_set(sysm).law is None:
        s = mp.static.load
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.concatenate([np.where((s > 0) & (el.ku * u > 0), el.mu * s / (el.ku * u),
                                     np.inf),
                            np.where((s > 0) & (el.kv * v > 0), s / (el.kv * v), np.inf)])
    return float(np.min(a)) if a.size else np.inf


def linear_guess(mp: ModeProblem) -> np.ndarray:
    """y of the linear mode: Q_0 the static state's displacement (0 without one),
    Psi_1 = (Re phi, -Im phi), omega0, zeta0."""
    Z = np.zeros((mp.n, 2 * mp.H + 1))
    if mp.static is not None and mp.static.q0.size == mp.n:
        Z[:, 0] = mp.static.q0
    Z[:, 1], Z[:, 2] = mp.shape.real, -mp.shape.imag
    return pack(mp, Z, mp.omega0, mp.zeta0)


def pack(mp: ModeProblem, Z, omega: float, zeta: float) -> np.ndarray:
    """y of a motion Z (n, 2H+1) (Z_0 = Q_0, Z_h = Psi_h): its kept DOFs' rows, omega,
    zeta."""
    return np.concatenate([np.asarray(Z)[mp.kept].ravel(), [omega, zeta]])


def unpack(mp: ModeProblem, y, s: float):
    """(Z (n, 2H+1) with Z_0 = Q_0 and Z_h = Psi_h of all DOFs (recovered when
    condensed), omega, zeta, column scale [1, a, a, ...], Q = Z * scale)."""
    nh = 2 * mp.H + 1
    Z = np.asarray(y[:-2], float).reshape(mp.kept.size, nh)
    om, ze = float(y[-2]), float(y[-1])
    if mp.condensed is not None:
        Z = recover(mp.condensed, Z, om, ze)
    scale = np.full(nh, 10.0 ** s)
    scale[0] = 1.0
    return Z, om, ze, scale


def epmc_term(mp: ModeProblem, zeta: float) -> Term:
    """The EPMC damping -2 zeta omega M q' as a linear term of the dynamic stiffness:
    i h omega omega (-2 zeta M) on harmonic h (its derivative in zeta: zeta = 1)."""
    return Term(-2.0 * zeta * mp.M, 1, True, 1)


def mode_operator(mp: ModeProblem, omega: float, zeta: float) -> np.ndarray:
    """L(omega, zeta) (n nh, n nh): the linear operator with the EPMC damping term."""
    return full_linear_operator(mp.hbm.system, omega, mp.H, extra=(epmc_term(mp, zeta),))


def forces(mp: ModeProblem, Q, omega: float, zeta: float, jacobian: bool = True):
    """(F = L Q + G(Q) (n, nh) [N], dF/dQ (n nh, n nh) or None, G (n, nh) [N])."""
    prob, n, nh = mp.hbm, mp.n, 2 * mp.H + 1
    G = np.zeros((n, nh))
    Gc, Jc, _ = contact_terms(prob, Q[prob.c], jacobian=jacobian)
    G[prob.c] = Gc
    L = mode_operator(mp, omega, zeta)
    F = (L @ Q.ravel()).reshape(n, nh) + G
    if not jacobian:
        return F, None, G
    J = L.reshape(n, nh, n, nh)
    nc, k = prob.c.size, np.arange(nh)
    J[np.ix_(prob.c, k, prob.c, k)] += Jc.reshape(nc, nh, nc, nh)
    return F, J.reshape(n * nh, n * nh), G


def residual(mp: ModeProblem, y, s: float, jacobian: bool = True):
    """(R (size,), dR/dy (size, size), dR/ds (size,)) of the EPMC at s = log10 a."""
    return evaluate(mp, y, s, jacobian)[:3]


def evaluate(mp: ModeProblem, y, s: float, jacobian: bool = True):
    """`residual`'s three outputs, then F = L Q + G [N], G [N] and Q [m] (n, 2H+1)."""
    if mp.condensed is not None:
        nh = 2 * mp.H + 1
        Zc = np.asarray(y[:-2], float).reshape(mp.kept.size, nh)
        scale = np.full(nh, 10.0 ** s)
        scale[0] = 1.0

        def contact(Qc, jac):
            G, J, _ = contact_terms(mp.hbm, Qc, jacobian=jac)
            return G, J
        return evaluate_condensed(mp.condensed, Zc, float(y[-2]), float(y[-1]), scale, mp.M,
                                  mp.ref, contact, jacobian)
    Z, om, zeta, scale = unpack(mp, y, s)
    n, nh = Z.shape
    Q = Z * scale
    F, J, G = forces(mp, Q, om, zeta, jacobian)
    harm = Z[:, 1:]
    h = np.arange(1, mp.H + 1)
    R = np.concatenate([(F / scale).ravel(),
                        [np.sum(harm * (mp.M @ harm)) - 1.0, h @ Z[mp.ref, 2::2]]])
    if not jacobian:
        return R, None, None, F, G, Q
    sv = np.tile(scale, n)
    dF_dom = apply_full(None, mp.C, mp.M, Q, om, derivative_matrix(mp.H),
                        (epmc_term(mp, zeta),), rate=True)
    dF_dzeta = apply_terms(Q, om, (epmc_term(mp, 1.0),))
    Jy = np.zeros((R.size, R.size))
    m = n * nh
    Jy[:m, :m] = J * (sv[None, :] / sv[:, None])
    Jy[:m, m] = (dF_dom / scale).ravel()
    Jy[:m, m + 1] = (dF_dzeta / scale).ravel()
    dN = np.zeros((n, nh))
    dN[:, 1:] = 2.0 * (mp.M @ harm)
    Jy[m, :m] = dN.ravel()
    Jy[m + 1, mp.ref * nh + 2 * h] = h
    Qh = Q.copy()
    Qh[:, 0] = 0.0
    dR_ds = np.zeros(R.size)
    dR_ds[:m] = LN10 * (J @ Qh.ravel()) / sv
    dR_ds[:m] -= LN10 * np.where(np.arange(m) % nh == 0, 0.0, R[:m])
    return R, Jy, dR_ds, F, G, Q


@dataclass(frozen=True)
class ModeCheck:
    """The recomputed residual of one point in SI units: the largest static and
    harmonic force residuals [N] against their tolerances [N], and the normalisation's
    and phase condition's residuals [-]."""

    static: float
    static_tol: float
    harmonic: float
    harmonic_tol: float
    conditions: float

    @property
    def converged(self) -> bool:
        return (self.static <= self.static_tol and self.harmonic <= self.harmonic_tol
                and self.conditions <= 1e-9)


def check(mp: ModeProblem, y, s: float, tol_rel: float = 1e-8) -> ModeCheck:
    """Recompute F = L Q + G(Q) [N] at the point and hold it to tol_rel times the
    scale of its own terms per part: harmonic |K Q_h| + |G_h| (never below 1e-300 N;
    the inertia balances them), static |K Q_0| + |G_0| plus the harmonic scale (the static
    equations carry the rectified forces of the vibration, as `hbm.tolerances`)."""
    R, _, _, F, G, Q = evaluate(mp, y, s, jacobian=False)
    return check_values(mp, R, F, G, Q, tol_rel)


def check_values(mp: ModeProblem, R, F, G, Q, tol_rel: float) -> ModeCheck:
    """`check` of a point from its evaluation (`evaluate`'s R, F, G, Q)."""
    KQ = dense(mp.hbm.system.K) @ Q
    hs = max(float(np.linalg.norm(KQ[:, 1:]) + np.linalg.norm(G[:, 1:])), 1e-300)
    st = float(np.linalg.norm(KQ[:, 0]) + np.linalg.norm(G[:, 0])) + hs
    return ModeCheck(float(np.linalg.norm(F[:, 0])), tol_rel * st,
                     float(np.linalg.norm(F[:, 1:])), tol_rel * hs, float(np.max(np.abs(R[-2:]))))
