"""The round-off floor of the harmonic-balance residual: the smallest residual [N]
that double precision can resolve at a point, and acceptance against it.

The residual R = S(Om) Q + G(Q) - P is a sum of terms that cancel at a solution.
Near a resonance of a stiff model the terms K Q and Om^2 M Q are many orders of
magnitude larger than the load P, and the computed R of even the exact solution
(rounded to doubles) is not zero but of the size of the rounding of those terms.
In the backward-error manner of linear algebra (Higham, Accuracy and Stability of
Numerical Algorithms, 2nd ed., ch. 3 and 7) the floor of each equation block is

    floor = c eps || |K| |Q| + Om |C| |Q| |D|^T + Om^2 |M| |Q| |D^2|^T
                    + |X_next| terms of (|T(phi) Q|, ...) + |G| + |P| ||  (full residual)
    floor = c eps ( || |J| |x| || + || load scale || )                (condensed residual)

per block (static h = 0 column, harmonic h >= 1 columns), eps = 2.2e-16, |.| taken
entry by entry, D the derivative matrix of the Fourier layout (`harmonics`), J the
Jacobian of the condensed residual at the condensed unknowns x (its rows hold the
condensed dynamic stiffness and the contact stiffness, so |J||x| bounds the terms
that the condensed residual sums), the load scale that of `hbm.tolerances`.

The constant c = ROUNDOFF_FACTOR = 8: each entry of |A||q| is a sum of m terms
whose rounding errors add like a random walk, about sqrt(m) eps times the sum of the
absolute terms at worst; the computed residual of an exact linear solution measured
0.5 to 0.8 eps || |A||q| || on a Craig-Bampton blade sector (rows of 100 to 600 terms,
dynamic amplification 1e6) and on stiff lumped chains.  c = 8 lies an order of
magnitude above what was measured, so that Newton lands below it in one step, and
below the sqrt(m) eps of a single row of 64 terms or more.

A point is accepted if each block's residual is within max(tolerance, floor): a
tolerance above the floor (every study with a tolerance that double precision
resolves) keeps its meaning exactly, and a tolerance below it can no longer stop a
continuation that has reached the best residual the arithmetic allows.  The floor
is computed only for a residual that misses its tolerance, so it costs nothing
where it does not decide.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from . import hbm
from ...fourier.harmonics import derivative_matrix
from .dynamic_stiffness import apply_coupling, apply_full, term_layout

ROUNDOFF_FACTOR = 8.0
EPS = np.finfo(float).eps


def load_scales(prob, contact=None) -> tuple:
    """(static, harmonic) load scale [N] of the residual: |P_0| + sum |n0_e| |Bn_e|
    and |P_h>=1| (the terms of `hbm.tolerances`)."""
    elem = contact if contact is not None else prob.system.contact
    bn = np.linalg.norm(prob.bn, axis=1) if prob.bn.size else np.zeros(0)
    d = float(np.linalg.norm(prob.P[:, 1:]))
    s = float(np.linalg.norm(prob.P[:, 0])) + float(np.sum(np.abs(elem.n0) * bn))
    return s, d


def _blocks(A) -> tuple:
    """(static, harmonic) norms of the absolute terms A (rows, 2H+1) times c eps."""
    return (ROUNDOFF_FACTOR * EPS * float(np.linalg.norm(A[:, 0])),
            ROUNDOFF_FACTOR * EPS * float(np.linalg.norm(A[:, 1:])))


def condensed_floor(prob, x, J, loads) -> tuple:
    """(static, harmonic) floor [N] of the condensed residual at x (`hbm.residual`)
    from its Jacobian J (dense or scipy.sparse, unscaled) and the load scales."""
    ax = np.abs(x)
    A = (abs(J) @ ax) if sp.issparse(J) else np.abs(J) @ ax
    fs, fd = _blocks(np.asarray(A).reshape(prob.c.size, prob.nh))
    c = ROUNDOFF_FACTOR * EPS
    return fs + c * loads[0], fd + c * loads[1]


def linear_terms(system, Q, Om, P, extra=()) -> np.ndarray:
    """(n, 2H+1) absolute terms of the linear part of the full residual [N]:
    |K||Q| + Om |C||Q||D|^T + Om^2 |M||Q||D^2|^T (+ |A_t||Q||F_t|^T of added terms)
    (+ the inter-sector coupling) + |P| (`dynamic_stiffness.apply_full`)."""
    H = (Q.shape[1] - 1) // 2
    D = np.abs(derivative_matrix(H))
    aQ = np.abs(Q)
    K, M, C = (_absolute(A) for A in (system.K, system.M, system.C))
    A = np.asarray(apply_full(K, C, M, aQ, Om, D))
    for t in extra:
        A = A + np.asarray(_absolute(t.matrix) @ aQ) @ np.abs(term_layout(t, H, Om)).T
    A = A + apply_coupling(system, Q, Om, D, absolute=True)
    return A + np.abs(P)


def _absolute(A):
    return abs(A) if sp.issparse(A) else np.abs(np.asarray(A, dtype=float))


def linear_floor(system, Q, Om, P) -> tuple:
    """(static, harmonic) floor [N] of the residual of a linear system (no contact)."""
    return _blocks(linear_terms(system, Q, Om, P))


def full_floor(prob, Q, Om, contact=None) -> tuple:
    """(static, harmonic) floor [N] of the full residual (`hbm.full_residual`) at the
    coefficients Q (n, 2H+1) of all DOFs and Om [rad/s]."""
    A = linear_terms(prob.system, Q, Om, prob.P, prob.linear.extra)
    G, _, _ = hbm.contact_terms(prob, Q[prob.c], contact, jacobian=False)
    A[prob.c] += np.abs(G)
    return _blocks(A)


def check_point(prob, Q, Om, contact, tols) -> tuple:
    """(residual norm [N], accepted, accepted on the floor only) of a point: its full
    residual's static and harmonic parts each within max(tolerance, floor)."""
    rs, rd = hbm.residual_parts(hbm.full_residual(prob, Q, Om, contact))
    norm = float(np.hypot(rs, rd))
    if rs <= tols[0] and rd <= tols[1]:
        return norm, True, False
    fs, fd = full_floor(prob, Q, Om, contact)
    ok = bool(rs <= max(tols[0], fs) and rd <= max(tols[1], fd))
    return norm, ok, ok


class FlooredWeights:
    """Row weights 1 / max(tolerance, floor) of the condensed equations at a point:
    `hbm.row_weights` where the residual meets its tolerances, else each block's
    tolerance raised to the round-off floor where that is larger (`condensed_floor`)."""

    def __init__(self, prob, tols, loads):
        self.prob, self.tols, self.loads = prob, tuple(tols), tuple(loads)
        self.w = hbm.row_weights(prob, self.tols)
        self.static = np.zeros((prob.c.size, prob.nh), bool)
        self.static[:, 0] = True
        self.static = self.static.ravel()

    def __call__(self, x, R, J):
        """The weights at x with residual R and Jacobian J (unscaled)."""
        w = self.w
        if J is None or np.linalg.norm(w * R) <= 1.0:
            return w
        Rb = R.reshape(self.prob.c.size, self.prob.nh)
        rs, rd = np.linalg.norm(Rb[:, 0]), np.linalg.norm(Rb[:, 1:])
        if rs <= self.tols[0] and rd <= self.tols[1]:
            return w
        fs, fd = condensed_floor(self.prob, x, J, self.loads)
        if fs <= self.tols[0] and fd <= self.tols[1]:
            return w
        return np.where(self.static, 1.0 / max(self.tols[0], fs), 1.0 / max(self.tols[1], fd))
