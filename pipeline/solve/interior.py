"""Condensation onto the contact DOFs of a dense structure from blocks gathered once
(paper Eq. 7).

The harmonic balance keeps only the contact DOFs c; the interior DOFs o are
eliminated per harmonic h at w = h Omega (`hbm.linear_part`):

    S~ = S_cc - S_co X,   X = S_oo^-1 S_oc,   P~ = P_c - S_co S_oo^-1 P_o,
    S = K - w^2 M + i w C,
    dS~/dOmega = dS_cc - dS_co X - Y dS_oc + Y dS_oo X,   Y = S_co S_oo^-1.

The blocks of K, M and C over (c, c), (c, o), (o, c), (o, o) are gathered once per
problem (`interior_blocks`), so an evaluation forms only the small S blocks of each
harmonic and factorises S_oo (no x no) in one batched solve, instead of building and
indexing S over all DOFs.  For symmetric K, M, C (every structure here but a
cyclic sector's wave-number coupling) Y = X^T and Y dS_oc = (dS_co X)^T, which
saves a solve and a product.  The solve is LU (backward stable): the condensed
system and the recovered interior satisfy the full equations to rounding, however
stiff the interface (a diagonalisation of S_oo by the interior's modes would not:
its error grows with their frequency spread, 1e6 in a Craig-Bampton blade).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class InteriorBlocks:
    """Dense K, M, C blocks of a structure split into contact DOFs c and interior o."""

    cc: tuple             # (K_cc, M_cc, C_cc) (nc, nc)
    co: tuple             # (nc, no)
    oc: tuple             # (no, nc)
    oo: tuple             # (no, no)
    symmetric: bool       # K, M, C symmetric: Y = X^T


def interior_blocks(K, M, C, c, o) -> InteriorBlocks | None:
    """The blocks of dense K, M, C (n, n); None without interior DOFs."""
    if o.size == 0:
        return None
    sym = all(np.allclose(A, A.T, rtol=1e-13, atol=0) for A in (K, M, C))

    def blocks(r, q):
        idx = np.ix_(r, q)
        return tuple(np.ascontiguousarray(A[idx], dtype=float) for A in (K, M, C))

    return InteriorBlocks(blocks(c, c), blocks(c, o), blocks(o, c), blocks(o, o), sym)


def dynamic(blocks: tuple, h: int, Om: float):
    """S = K - w^2 M + i w C of one block at w = h Omega, and dS/dOmega."""
    K, M, C = blocks
    w = h * Om
    return K - w * w * M + 1j * w * C, h * (-2 * w * M + 1j * C)


def condense_blocks(ib: InteriorBlocks, H: int, Om: float, P, c, o, derivatives: bool,
                    motion=None):
    """(St, dSt, Pt, dPt) of `hbm.linear_part` for h = 0..H: St, dSt (H+1, nc, nc)
    complex, Pt, dPt (H+1, nc); P (H+1, n) the complex load per harmonic [N].

    With `motion` (H+1, nc) complex, dSt is returned applied to it, dSt[h] @ motion[h]
    (H+1, nc), by matrix-vector products: the residual needs only dR/dOmega, and the
    two (nc, no) x (no, nc) products of the matrix dSt would double the cost."""
    if derivatives and motion is not None:
        return _condense_applied(ib, H, Om, P, c, o, np.asarray(motion, complex))
    S = [[dynamic(b, h, Om) for b in (ib.cc, ib.co, ib.oc, ib.oo)] for h in range(H + 1)]
    Soo = np.array([s[3][0] for s in S])
    Soc = np.array([s[2][0] for s in S])
    sol = np.linalg.solve(Soo, np.concatenate([Soc, P[:, o, None]], axis=2))
    X, z = np.ascontiguousarray(sol[..., :-1]), sol[..., -1]
    Sco = np.array([s[1][0] for s in S])
    St = np.array([s[0][0] for s in S]) - Sco @ X
    Pt = P[:, c] - (Sco @ z[..., None])[..., 0]
    if not derivatives:
        return St, None, Pt, None
    dScc, dSco, dSoc, dSoo = (np.array([s[k][1] for s in S]) for k in range(4))
    if ib.symmetric:
        Y = np.swapaxes(X, 1, 2)
        B = dSco @ X
        YdSoc = np.swapaxes(B, 1, 2)
    else:
        Y = np.ascontiguousarray(np.swapaxes(np.linalg.solve(
            np.swapaxes(Soo, 1, 2), np.swapaxes(Sco, 1, 2)), 1, 2))
        B, YdSoc = dSco @ X, Y @ dSoc
    dSt = dScc - B - YdSoc + Y @ (dSoo @ X)
    dPt = (-(dSco @ z[..., None]) + Y @ (dSoo @ z[..., None]))[..., 0]
    return St, dSt, Pt, dPt


def _condense_applied(ib: InteriorBlocks, H: int, Om: float, P, c, o, q):
    S = [[dynamic(b, h, Om) for b in (ib.cc, ib.co, ib.oc, ib.oo)] for h in range(H + 1)]
    Soo = np.array([s[3][0] for s in S])
    Soc = np.array([s[2][0] for s in S])
    sol = np.linalg.solve(Soo, np.concatenate([Soc, P[:, o, None]], axis=2))
    X, z = np.ascontiguousarray(sol[..., :-1]), sol[..., -1]
    Sco = np.array([s[1][0] for s in S])
    St = np.array([s[0][0] for s in S]) - Sco @ X
    Pt = P[:, c] - (Sco @ z[..., None])[..., 0]
    dScc, dSco, dSoc, dSoo = (np.array([s[k][1] for s in S]) for k in range(4))
    # dSt q = dScc q - dSco X q - Y (dSoc q - dSoo X q);  dPt = -dSco z + Y dSoo z
    Xq = (X @ q[..., None])[..., 0]
    u = np.concatenate([(dSoc @ q[..., None] - dSoo @ Xq[..., None]),
                        dSoo @ z[..., None]], axis=2)                    # (H+1, no, 2)
    if ib.symmetric:   # Y = X^T
        Yu = np.swapaxes(X, 1, 2) @ u
    else:              # Y = Sco Soo^-1: Y u = Sco (Soo^-1 u)
        Yu = Sco @ np.linalg.solve(Soo, u)
    dStq = (dScc @ q[..., None] - dSco @ Xq[..., None])[..., 0] - Yu[..., 0]
    dPt = -(dSco @ z[..., None])[..., 0] + Yu[..., 1]
    return St, dStq, Pt, dPt


def recover_blocks(ib: InteriorBlocks, H: int, Om: float, Qh, P_o):
    """Interior coefficients Q_o (H+1, no) complex from the contact DOFs' Qh
    (H+1, nc) complex and the interior load P_o (H+1, no): S_oo Q_o = P_o - S_oc Qh."""
    Soo = np.array([dynamic(ib.oo, h, Om)[0] for h in range(H + 1)])
    Soc = np.array([dynamic(ib.oc, h, Om)[0] for h in range(H + 1)])
    rhs = P_o - (Soc @ Qh[..., None])[..., 0]
    return np.linalg.solve(Soo, rhs[..., None])[..., 0]
