"""Condensation onto the contact DOFs through the interior's modes (paper Eq. 7).

The harmonic balance keeps only the contact DOFs c; the interior DOFs o are
eliminated per harmonic h at w = h Omega (`hbm.linear_part`):

    S~ = S_cc - S_co S_oo^-1 S_oc,   P~ = P_c - S_co S_oo^-1 P_o,
    S = K - w^2 M + i w C.

When the interior's damping is diagonal in the interior's undamped modes (Rayleigh
damping C = alpha M + beta K, as FE blades and their Craig-Bampton reduction carry,
or no damping), one generalized eigen-solve K_oo Phi = M_oo Phi diag(lam),
Phi^T M_oo Phi = I, Phi^T C_oo Phi = diag(gam), done once per problem, diagonalises
S_oo at every frequency:

    S_oo^-1 = Phi D Phi^T,   D = diag(1 / (lam - w^2 + i w gam)),
    S_co Phi = A(w) = K_co Phi - w^2 M_co Phi + i w C_co Phi,
    S~ = S_cc - A D A^T,     P~ = P_c - A D Phi^T P_o,

so an evaluation costs products of (nc x m) matrices instead of solves and block
copies of the whole structure.  Derivatives in Omega (dw/dOmega = h):
    dS~ = dS_cc - dA D A^T - A D dA^T + A diag(dd / d^2) A^T,   dd = h (-2 w + i gam).
Symmetric K, M, C only (S_oc = S_co^T); `modal_interior` returns None otherwise, or
when the damping is not diagonal in the modes, and the direct solve is used.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

DIAGONAL_TOL = 1e-9   # off-diagonal Phi^T C Phi, relative to its largest diagonal entry


@dataclass(frozen=True, eq=False)
class ModalInterior:
    """The interior's modes and the couplings projected on them, built once."""

    lam: np.ndarray       # (m,) eigenvalues of (K_oo, M_oo) [rad^2/s^2]
    gam: np.ndarray       # (m,) diagonal of Phi^T C_oo Phi [1/s]
    Phi: np.ndarray       # (no, m) M_oo-orthonormal modes
    A: tuple              # (K_co Phi, M_co Phi, C_co Phi), each (nc, m)
    cc: tuple             # (K_cc, M_cc, C_cc), each (nc, nc)


def modal_interior(K, M, C, c, o) -> ModalInterior | None:
    """The `ModalInterior` of dense symmetric K, M, C (n, n) split into contact DOFs c
    and interior DOFs o; None when it does not apply (module doc)."""
    if o.size == 0 or any(not np.allclose(A, A.T, rtol=1e-12, atol=0) for A in (K, M, C)):
        return None
    oo, co, cc = np.ix_(o, o), np.ix_(c, o), np.ix_(c, c)
    try:
        lam, Phi = sla.eigh(K[oo], M[oo])
    except np.linalg.LinAlgError:    # M_oo not positive definite (massless interior DOFs)
        return None
    G = Phi.T @ C[oo] @ Phi
    gam = np.diag(G).copy()
    off = np.abs(G - np.diag(gam)).max() if G.size else 0.0
    if off > DIAGONAL_TOL * max(np.abs(gam).max(), np.finfo(float).tiny):
        return None
    return ModalInterior(lam, gam, Phi, tuple(A[co] @ Phi for A in (K, M, C)),
                         tuple(np.array(A[cc]) for A in (K, M, C)))


def condense_modal(mi: ModalInterior, H: int, Om: float, P, c, o, derivatives: bool):
    """(St, dSt, Pt, dPt) of `hbm.linear_part` for h = 0..H: St, dSt (H+1, nc, nc)
    complex, Pt, dPt (H+1, nc); P (H+1, n) the complex load per harmonic [N]."""
    Kc, Mc, Cc = mi.cc
    AK, AM, AC = mi.A
    St, dSt, Pt, dPt = [], [], [], []
    for h in range(H + 1):
        w = h * Om
        A = AK - w * w * AM + 1j * w * AC
        d = mi.lam - w * w + 1j * w * mi.gam
        AD = A / d
        p = mi.Phi.T @ P[h, o]
        St.append(Kc - w * w * Mc + 1j * w * Cc - AD @ A.T)
        Pt.append(P[h, c] - AD @ p)
        if not derivatives:
            continue
        dA = h * (-2 * w * AM + 1j * AC)
        dd = h * (-2 * w + 1j * mi.gam)
        B = dA @ AD.T
        dSt.append(h * (-2 * w * Mc + 1j * Cc) - B - B.T + (AD * dd) @ AD.T)
        dPt.append(-(dA / d) @ p + (AD * (dd / d)) @ p)
    return (np.array(St), np.array(dSt) if derivatives else None, np.array(Pt),
            np.array(dPt) if derivatives else None)


def recover_modal(mi: ModalInterior, h: int, Om: float, Qh, P_o):
    """Interior coefficients Q_o (no,) complex of harmonic h from the contact DOFs'
    Qh (nc,) complex: Q_o = Phi D (Phi^T P_o - A^T Qh)."""
    w = h * Om
    A = mi.A[0] - w * w * mi.A[1] + 1j * w * mi.A[2]
    d = mi.lam - w * w + 1j * w * mi.gam
    return mi.Phi @ ((mi.Phi.T @ P_o - A.T @ Qh) / d)
