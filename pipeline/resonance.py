"""Resonances between two branch points: a Sturm (Wittrick-Williams) count.

A continuation step that is long compared with a resonance's width can jump over
it: both ends of the step are far from the peak, Newton converges at once (a
linear branch converges in one iteration), and nothing in the corrector notices.
This module tells whether a resonance lies inside a step, without sampling it.

At a branch point (Q, Omega) the contact elements have a tangent stiffness per
harmonic h (the h-block of dG/dQ, paper Eq. 9-11 differentiated): written as a
complex matrix Z_h = P_h + i Q_h on the contact DOFs (the real 2x2 block
[[p, q], [-q, p]] of the cos/sin layout is p + i q), its Hermitian part is the
effective stiffness the contact adds at that harmonic (ku, kv where stuck, less
where it slips or separates, 0 where open) and its anti-Hermitian part the
dissipation.  The number of natural frequencies of the locally linearised
structure below h Omega is the number of negative eigenvalues of

    D_h(Omega) = K + Herm(Z_h) - (h Omega)^2 M        (Sylvester's law of inertia)

(Wittrick & Williams 1971 count natural frequencies of a structure the same way).
Between two points whose counts differ, h Omega crossed a natural frequency of the
linearised structure: a resonance (of the stuck or open linear limit on a linear
branch, of the backbone of a nonlinear one) lies inside the step.  Such a step is
admissible only if it is short enough to resolve that resonance: at most the
half-power width 2 zeta Omega of the slowest-decaying (least damped) mode among
those crossed, from the viscous damping of the bounding linear systems (contacts
open, contacts closed); friction and impact only add dissipation, so a real
resonance is at least that wide.  Only the excited harmonics are counted: they
carry the primary resonances, the only ones a linear branch has.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from . import hbm

MAX_DENSE_DOF = 3000   # above this the count (a dense eigen-solve per point) is skipped
WIDTH_FLOOR = 1e-6     # smallest width resolved, relative to Omega (zeta = 0 structures)


@dataclass(frozen=True)
class ResonanceCount:
    """What the count needs of a problem, prepared once (plain arrays)."""

    K: np.ndarray           # (n, n) structural stiffness [N/m]
    M: np.ndarray           # (n, n) mass [kg]
    harmonics: tuple        # excited harmonics h >= 1
    zeta: np.ndarray        # (n,) smallest modal damping ratio of mode i, open or closed [-]


def _dense(A):
    return np.asarray(A.toarray() if hasattr(A, "toarray") else A, dtype=float)


def modal_damping(M, C, K) -> np.ndarray:
    """Damping ratios zeta_i of the modes of M q'' + C q' + K q = 0, in the order of
    their natural frequencies |lambda_i| (state-space eigenvalues, any damping)."""
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = sla.eigvals(A)
    lam = lam[lam.imag >= 0]  # one of each conjugate pair (overdamped pairs: both real)
    lam = lam[np.argsort(np.abs(lam))][:n]
    mag = np.abs(lam)
    zeta = np.where(mag > 0, -lam.real / np.where(mag > 0, mag, 1.0), 1.0)
    out = np.ones(n)
    out[:zeta.size] = zeta
    return out


def closed_stiffness(system) -> np.ndarray:
    """K plus every contact element closed and stuck (ku along Bt, kv along Bn,
    whatever the preload): the stiffest linear limit of the structure [N/m]."""
    el = system.contact
    Bt, Bn = _dense(system.Bt), _dense(system.Bn)
    return _dense(system.K) + Bt.T @ (el.ku[:, None] * Bt) + Bn.T @ (el.kv[:, None] * Bn)


def prepare(prob: hbm.HBMProblem) -> ResonanceCount | None:
    """The count's data for a problem; None when it does not apply (no excited
    harmonic, or more than MAX_DENSE_DOF DOFs)."""
    sys = prob.system
    F = np.asarray(sys.forcing)
    harmonics = tuple(h for h in range(1, min(prob.H, F.shape[1] - 1) + 1) if np.any(F[:, h]))
    if not harmonics or sys.n_dof > MAX_DENSE_DOF:
        return None
    K, M, C = _dense(sys.K), _dense(sys.M), _dense(sys.C)
    zeta = np.minimum(modal_damping(M, C, K), modal_damping(M, C, closed_stiffness(sys)))
    return ResonanceCount(K, M, harmonics, np.maximum(zeta, 0.0))


def contact_stiffness(prob: hbm.HBMProblem, Qc, contact, h: int) -> np.ndarray:
    """Complex tangent stiffness Z_h (nc, nc) of the contacts at harmonic h [N/m]."""
    nc = prob.c.size
    Z = np.zeros((nc, nc), complex)
    if prob.idx.shape[0] == 0:
        return Z
    _, Je, _ = hbm.contact_terms(prob, Qc, contact, jacobian=True, blocks=True)
    a, b = 2 * h - 1, 2 * h
    z = 0.5 * (Je[..., a, a] + Je[..., b, b]) + 0.5j * (Je[..., a, b] - Je[..., b, a])
    E, m = prob.idx.shape
    ia = np.broadcast_to(prob.idx[:, :, None], (E, m, m))
    ib = np.broadcast_to(prob.idx[:, None, :], (E, m, m))
    np.add.at(Z, (ia, ib), z)
    return Z


def counts(rc: ResonanceCount, prob: hbm.HBMProblem, x, Om, contact) -> tuple:
    """Number of natural frequencies of the linearised structure below h Omega, for
    each excited harmonic h (tuple of ints, in the order of rc.harmonics)."""
    Qc = np.asarray(x, float).reshape(prob.c.size, prob.nh)
    out = []
    cc = np.ix_(prob.c, prob.c)
    for h in rc.harmonics:
        Z = contact_stiffness(prob, Qc, contact, h)
        D = rc.K.astype(complex) - (h * Om) ** 2 * rc.M
        D[cc] += 0.5 * (Z + Z.conj().T)
        out.append(int(np.sum(np.linalg.eigvalsh(D) < 0.0)))
    return tuple(out)


def width(rc: ResonanceCount, counts_a, counts_b, Om) -> float:
    """Half-power width [rad/s of Omega] of the least damped resonance crossed between
    two points with these counts; inf if none is crossed."""
    w = np.inf
    for h, ka, kb in zip(rc.harmonics, counts_a, counts_b):
        if ka != kb:
            lo, hi = sorted((ka, kb))
            zeta = float(rc.zeta[lo:hi].min()) if hi <= rc.zeta.size else 0.0
            w = min(w, max(2.0 * zeta, WIDTH_FLOOR) * Om)
    return w


def step_guard(prob: hbm.HBMProblem, contact, omega_of=lambda lam: lam):
    """segment_check(x0, lam0, x1, lam1) for `continuation.continue_branch`: None when
    no resonance is crossed or the step resolves it, else the largest admissible
    |lam1 - lam0|.  A step next to a resolved crossing is held to the same width,
    so the resonance has points on both sides.  None if the count does not apply."""
    rc = prepare(prob)
    if rc is None:
        return None
    memo = {}
    near = {"width": np.inf, "at": None}

    def count_at(x, lam):
        key = (float(lam), np.asarray(x, float).tobytes())
        if key not in memo:
            if len(memo) > 64:
                memo.clear()
            memo[key] = counts(rc, prob, x, omega_of(lam), contact)
        return memo[key]

    def check(x0, lam0, x1, lam1):
        step = abs(lam1 - lam0)
        Om = 0.5 * (omega_of(lam0) + omega_of(lam1))
        w_cross = width(rc, count_at(x0, lam0), count_at(x1, lam1), Om)
        w = min(w_cross, near["width"]) if near["at"] == float(lam0) else w_cross
        if step <= w:
            crossed = bool(np.isfinite(w_cross))
            near.update(width=w_cross if crossed else np.inf, at=float(lam1) if crossed else None)
            return None
        return w

    check.counts = count_at
    return check
