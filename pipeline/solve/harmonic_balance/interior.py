"""Blocks of a dense structure split into contact DOFs c and interior DOFs o, gathered
once per problem for the condensation onto c (paper Eq. 7; `dynamic_stiffness`,
strategy "blocks"):

    S~ = S_cc - S_co X,   X = S_oo^-1 S_oc,   P~ = P_c - S_co S_oo^-1 P_o,
    dS~/dOmega = dS_cc - dS_co X - Y dS_oc + Y dS_oo X,   Y = S_co S_oo^-1.

The blocks of K, M, C (and of added terms) over (c, c), (c, o), (o, c), (o, o) are
gathered once (`interior_blocks`), so an evaluation forms only the small S blocks of
each harmonic (`dynamic_stiffness.dynamic`, passed in: S is formed there only) and
factorises S_oo (no x no) in one batched solve, instead of building and indexing S
over all DOFs.  The static harmonic (S = K at every Omega) is condensed
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
    """Dense K, M, C blocks (then those of the added terms' matrices A_t) of a structure
    split into contact DOFs c and interior o."""

    cc: tuple             # (K_cc, M_cc, C_cc, *A_t_cc) (nc, nc)
    co: tuple             # (nc, no)
    oc: tuple             # (no, nc)
    oo: tuple             # (no, no)
    symmetric: bool       # K, M, C symmetric: Y = X^T
    static: tuple | None = None  # h = 0 (S = K at any Omega): (LU of K_oo, X_0, S~_0)


def interior_blocks(K, M, C, c, o, extra=()) -> InteriorBlocks | None:
    """The blocks of dense K, M, C (n, n) and of the added terms' matrices `extra`;
    None without interior DOFs."""
    if o.size == 0:
        return None
    mats = (K, M, C) + tuple(extra)
    sym = all(np.allclose(A, A.T, rtol=1e-13, atol=0) for A in mats)

    def blocks(r, q):
        idx = np.ix_(r, q)
        return tuple(np.ascontiguousarray(A[idx], dtype=float) for A in mats)

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


def _condensed(ib: InteriorBlocks, P, c, o, S):
    """(X, z, Sco, Soo, St, Pt): X = S_oo^-1 S_oc, z = S_oo^-1 P_o, and the condensed
    stiffness and load, per harmonic (one batched solve; h = 0 from `static`)."""
    Sco, Soo = S(ib.co), S(ib.oo)
    Soc = np.swapaxes(Sco, 1, 2) if ib.symmetric else S(ib.oc)
    first = 0 if ib.static is None else 1  # the harmonics solved here
    sol = np.linalg.solve(Soo[first:], np.concatenate([Soc[first:], P[first:, o, None]], axis=2))
    X = np.empty(Soc.shape, complex)
    z = np.empty((P.shape[0], Soc.shape[1], 1), complex)
    X[first:], z[first:] = sol[..., :-1], sol[..., -1:]
    St = S(ib.cc)
    St[first:] -= Sco[first:] @ X[first:]
    if first:
        lu, X[0], St[0] = ib.static
        z[0, :, 0] = (sla.lu_solve(lu, P[0, o].real, check_finite=False)
                      + 1j * sla.lu_solve(lu, P[0, o].imag, check_finite=False))
    Pt = P[:, c] - (Sco @ z)[..., 0]
    return X, z, Sco, Soo, St, Pt


def condense_blocks(ib: InteriorBlocks, P, c, o, derivatives: bool, motion, S, dS):
    """(St, dSt, Pt, dPt) of `dynamic_stiffness.condense` for h = 0..H: St, dSt
    (H+1, nc, nc) complex, Pt, dPt (H+1, nc); P (H+1, n) the complex load per harmonic
    [N]; S(blocks) and dS(blocks, V=None) the dynamic stiffness of a block tuple per
    harmonic and its Omega-derivative (times V), as `dynamic_stiffness` forms them.

    With `motion` (H+1, nc) complex, dSt is returned applied to it, dSt[h] @ motion[h]
    (H+1, nc), by matrix-vector products: the residual needs only dR/dOmega, and the
    two (nc, no) x (no, nc) products of the matrix dSt would double the cost."""
    X, z, Sco, Soo, St, Pt = _condensed(ib, P, c, o, S)
    if not derivatives:
        return St, None, Pt, None
    if motion is not None:
        dStq, dPt = _applied(ib, X, z, Sco, Soo, np.asarray(motion, complex), dS)
        return St, dStq, Pt, dPt
    dScc, dSco, dSoc, dSoo = (dS(b) for b in (ib.cc, ib.co, ib.oc, ib.oo))
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


def _applied(ib: InteriorBlocks, X, z, Sco, Soo, q, dS):
    """(dSt q, dPt) by products with vectors only (dS with V):
    dSt q = dScc q - dSco X q - Y (dSoc q - dSoo X q),  dPt = -dSco z + Y dSoo z,
    Y = S_co S_oo^-1 (X^T for symmetric blocks)."""
    q = q[..., None]
    Xq = X @ q
    oo = dS(ib.oo, np.concatenate([Xq, z], axis=2))
    u = np.concatenate([dS(ib.oc, q) - oo[..., :1], oo[..., 1:]], axis=2)
    Yu = np.swapaxes(X, 1, 2) @ u if ib.symmetric else Sco @ np.linalg.solve(Soo, u)
    co = dS(ib.co, np.concatenate([Xq, z], axis=2))
    dStq = dS(ib.cc, q)[..., 0] - co[..., 0] - Yu[..., 0]
    return dStq, -co[..., 1] + Yu[..., 1]
