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
indexing S over all DOFs.  The static harmonic (S = K at every Omega) is condensed
once, with the blocks.  For symmetric K, M, C (every structure here but a
cyclic sector's wave-number coupling) Y = X^T and Y dS_oc = (dS_co X)^T, which
saves a solve and a product.  The solve is LU (backward stable): the condensed
system and the recovered interior satisfy the full equations to rounding, however
stiff the interface (a diagonalisation of S_oo by the interior's modes would not:
its error grows with their frequency spread, 1e6 in a Craig-Bampton blade).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla


@dataclass(frozen=True, eq=False)
class InteriorBlocks:
    """Dense K, M, C blocks of a structure split into contact DOFs c and interior o."""

    cc: tuple             # (K_cc, M_cc, C_cc) (nc, nc)
    co: tuple             # (nc, no)
    oc: tuple             # (no, nc)
    oo: tuple             # (no, no)
    symmetric: bool       # K, M, C symmetric: Y = X^T
    static: tuple | None = None  # h = 0 (S = K at any Omega): (LU of K_oo, X_0, S~_0)


def interior_blocks(K, M, C, c, o) -> InteriorBlocks | None:
    """The blocks of dense K, M, C (n, n); None without interior DOFs."""
    if o.size == 0:
        return None
    sym = all(np.allclose(A, A.T, rtol=1e-13, atol=0) for A in (K, M, C))

    def blocks(r, q):
        idx = np.ix_(r, q)
        return tuple(np.ascontiguousarray(A[idx], dtype=float) for A in (K, M, C))

    cc, co, oc, oo = blocks(c, c), blocks(c, o), blocks(o, c), blocks(o, o)
    return InteriorBlocks(cc, co, oc, oo, sym, _static_part(cc[0], co[0], oc[0], oo[0]))


def _static_part(Kcc, Kco, Koc, Koo):
    """The harmonic h = 0 of the condensation, the same at every Omega (S = K):
    (LU of K_oo, X_0 = K_oo^-1 K_oc, S~_0 = K_cc - K_co X_0), or None if K_oo is
    singular (an interior free to move statically: every evaluation then fails
    at h = 0, as without this)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        lu = sla.lu_factor(Koo, check_finite=False)
    if not np.all(np.diagonal(lu[0])):
        return None
    X0 = sla.lu_solve(lu, Koc, check_finite=False)
    return lu, X0, Kcc - Kco @ X0


def dynamic(blocks: tuple, H: int, Om: float):
    """S = K - w^2 M + i w C of one block at w = h Omega for h = 0..H, (H+1, r, q)."""
    K, M, C = blocks
    w = np.arange(H + 1)[:, None, None] * Om
    S = np.empty((H + 1,) + K.shape, complex)
    np.subtract(K, w * w * M, out=S.real)
    np.multiply(w, C, out=S.imag)
    return S


def dynamic_derivative(blocks: tuple, H: int, Om: float, V=None):
    """dS/dOmega = h (-2 w M + i C) of one block for h = 0..H, (H+1, r, q); with V
    (H+1, q, k) its product with V, from M V and C V (no dS matrix formed)."""
    _, M, C = blocks
    h = np.arange(H + 1)[:, None, None]
    if V is None:
        return h * (-2 * h * Om * M + 1j * C)
    return h * (-2 * h * Om * (M @ V) + 1j * (C @ V))


def _condensed(ib: InteriorBlocks, H: int, Om: float, P, c, o):
    """(X, z, Sco, Soo, St, Pt): X = S_oo^-1 S_oc, z = S_oo^-1 P_o, and the condensed
    stiffness and load, per harmonic (one batched solve; h = 0 from `static`)."""
    Sco, Soo = dynamic(ib.co, H, Om), dynamic(ib.oo, H, Om)
    Soc = np.swapaxes(Sco, 1, 2) if ib.symmetric else dynamic(ib.oc, H, Om)
    first = 0 if ib.static is None else 1  # the harmonics solved here
    sol = np.linalg.solve(Soo[first:], np.concatenate([Soc[first:], P[first:, o, None]], axis=2))
    X = np.empty(Soc.shape, complex)
    z = np.empty((H + 1, Soc.shape[1], 1), complex)
    X[first:], z[first:] = sol[..., :-1], sol[..., -1:]
    St = dynamic(ib.cc, H, Om)
    St[first:] -= Sco[first:] @ X[first:]
    if first:
        lu, X[0], St[0] = ib.static
        z[0, :, 0] = (sla.lu_solve(lu, P[0, o].real, check_finite=False)
                      + 1j * sla.lu_solve(lu, P[0, o].imag, check_finite=False))
    Pt = P[:, c] - (Sco @ z)[..., 0]
    return X, z, Sco, Soo, St, Pt


def condense_blocks(ib: InteriorBlocks, H: int, Om: float, P, c, o, derivatives: bool,
                    motion=None):
    """(St, dSt, Pt, dPt) of `hbm.linear_part` for h = 0..H: St, dSt (H+1, nc, nc)
    complex, Pt, dPt (H+1, nc); P (H+1, n) the complex load per harmonic [N].

    With `motion` (H+1, nc) complex, dSt is returned applied to it, dSt[h] @ motion[h]
    (H+1, nc), by matrix-vector products: the residual needs only dR/dOmega, and the
    two (nc, no) x (no, nc) products of the matrix dSt would double the cost."""
    X, z, Sco, Soo, St, Pt = _condensed(ib, H, Om, P, c, o)
    if not derivatives:
        return St, None, Pt, None
    if motion is not None:
        dStq, dPt = _applied(ib, H, Om, X, z, Sco, Soo, np.asarray(motion, complex))
        return St, dStq, Pt, dPt
    dScc, dSco, dSoc, dSoo = (dynamic_derivative(b, H, Om) for b in (ib.cc, ib.co, ib.oc, ib.oo))
    if ib.symmetric:
        Y = np.swapaxes(X, 1, 2)
        B = dSco @ X
        YdSoc = np.swapaxes(B, 1, 2)
    else:
        Y = np.ascontiguousarray(np.swapaxes(np.linalg.solve(
            np.swapaxes(Soo, 1, 2), np.swapaxes(Sco, 1, 2)), 1, 2))
        B, YdSoc = dSco @ X, Y @ dSoc
    dSt = dScc - B - YdSoc + Y @ (dSoo @ X)
    dPt = (-(dSco @ z) + Y @ (dSoo @ z))[..., 0]
    return St, dSt, Pt, dPt


def _applied(ib: InteriorBlocks, H: int, Om: float, X, z, Sco, Soo, q):
    """(dSt q, dPt) by products with vectors only (`dynamic_derivative` with V):
    dSt q = dScc q - dSco X q - Y (dSoc q - dSoo X q),  dPt = -dSco z + Y dSoo z,
    Y = S_co S_oo^-1 (X^T for symmetric blocks)."""
    q = q[..., None]
    Xq = X @ q
    oo = dynamic_derivative(ib.oo, H, Om, np.concatenate([Xq, z], axis=2))
    u = np.concatenate([dynamic_derivative(ib.oc, H, Om, q) - oo[..., :1], oo[..., 1:]], axis=2)
    Yu = np.swapaxes(X, 1, 2) @ u if ib.symmetric else Sco @ np.linalg.solve(Soo, u)
    co = dynamic_derivative(ib.co, H, Om, np.concatenate([Xq, z], axis=2))
    dStq = dynamic_derivative(ib.cc, H, Om, q)[..., 0] - co[..., 0] - Yu[..., 0]
    return dStq, -co[..., 1] + Yu[..., 1]


def recover_blocks(ib: InteriorBlocks, H: int, Om: float, Qh, P_o):
    """Interior coefficients Q_o (H+1, no) complex from the contact DOFs' Qh
    (H+1, nc) complex and the interior load P_o (H+1, no): S_oo Q_o = P_o - S_oc Qh."""
    Soo, Soc = dynamic(ib.oo, H, Om), dynamic(ib.oc, H, Om)
    rhs = P_o - (Soc @ Qh[..., None])[..., 0]
    return np.linalg.solve(Soo, rhs[..., None])[..., 0]
