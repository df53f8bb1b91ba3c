"""The EPMC condensed onto the contact DOFs, as the forced response is: the unknowns
are the contact DOFs' coefficients Z_c, omega and zeta; the other DOFs o follow from
them per harmonic,

    S_h(omega, zeta) = K_h - (h omega)^2 M + i h omega (C - 2 zeta omega M),
    V_o,h = -S_oo,h^-1 S_oc,h V_c,h                       (h = 0: S_0 = K_0),

V_h = Z_h,cos - i Z_h,sin the complex harmonic of the shape (h >= 1) or the static
part (h = 0).  The equations (`epmc` module doc) become

    R_c,h = (S~_h Q_c,h + G_c,h) / a,  S~_h = S_cc - S_co S_oo^-1 S_oc   [N per unit a]
    N = sum_{h>=1} Re(V_h^H M V_h) - 1 = 0,    sum_{h>=1} h Z_h,sin[ref] = 0,

the two conditions read on the recovered shape (all DOFs, as the uncondensed
problem's), so omega, zeta and the motion are those of `epmc` with all DOFs
unknown.  Derivatives, with V_o = -X V_c, X = S_oo^-1 S_oc:

    d(S~ Q_c)/dp = [dS/dp Q]_c - S_co S_oo^-1 [dS/dp Q]_o,       p = omega, zeta,
    a condition f(V) with gradient g_h = df/dRe V_h + i df/dIm V_h:
    df/dV_c = g_c - X^H g_o,   df/dp = -Re(u^H [dS/dp V]_o),  u = S_oo^-H g_o.

S_h and its rates come from the dynamic stiffness (`dynamic_stiffness.dense_stack`,
the EPMC damping a `Term` whose matrix is linear in zeta).  One dense solve with
S_oo per harmonic and evaluation; the Newton system is n_c (2H+1) + 2 instead of
n (2H+1) + 2.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...fourier.harmonics import complex_harmonics, real_blocks, real_vector
from ..harmonic_balance.dynamic_stiffness import (DynamicStiffness, Term, dense_stack,
                                                  dense_stack_derivative, prepare,
                                                  term_stiffness)

LN10 = np.log(10.0)


@dataclass(frozen=True, eq=False)
class Condensation:
    """The linear part of the EPMC split into kept DOFs c (the contact DOFs) and
    recovered DOFs o: `linear` the dynamic stiffness without the EPMC damping, `unit`
    the EPMC damping at zeta = 1, Term(-2 M, 1, True, 1)."""

    c: np.ndarray
    o: np.ndarray
    linear: DynamicStiffness
    unit: tuple


def condensation(system, H: int, c, M) -> Condensation | None:
    """The `Condensation` of a system onto the DOFs c, None when nothing is left to
    recover (every DOF a contact DOF) or nothing to keep (no contact)."""
    c = np.asarray(c, int)
    o = np.setdiff1d(np.arange(system.n_dof), c)
    if o.size == 0 or c.size == 0:
        return None
    P = np.zeros((system.n_dof, 2 * H + 1))
    return Condensation(c, o, prepare(system, H, c, o, P, strategy="dense"),
                        (Term(-2.0 * np.asarray(M, float), 1, True, 1),))


def operators(cd: Condensation, omega: float, zeta: float):
    """(S, dS/domega, dS/dzeta), each (H+1, n, n) complex."""
    H = cd.linear.H
    T = term_stiffness(cd.unit, H, omega)
    S = dense_stack(cd.linear, omega) + zeta * T
    dS = dense_stack_derivative(cd.linear, omega) + zeta * term_stiffness(cd.unit, H, omega, True)
    return S, dS, T


def split(cd: Condensation, S):
    """(S_cc, S_co, S_oc, S_oo) of a stack (H+1, n, n)."""
    c, o = cd.c, cd.o
    Sc, So = S[:, c], S[:, o]
    return Sc[:, :, c], np.ascontiguousarray(Sc[:, :, o]), So[:, :, c], So[:, :, o]


def recover(cd: Condensation, Zc, omega: float, zeta: float, S=None) -> np.ndarray:
    """Z (n, 2H+1) of all DOFs from the kept DOFs' Zc (nc, 2H+1): S_oo V_o = -S_oc V_c
    per harmonic (the static column with K_0)."""
    if S is None:
        S = operators(cd, omega, zeta)[0]
    _, _, Soc, Soo = split(cd, S)
    Vo = -np.linalg.solve(Soo, (Soc @ complex_harmonics(Zc)[..., None]))[..., 0]
    n = cd.c.size + cd.o.size
    Z = np.zeros((n, Zc.shape[1]))
    Z[cd.c] = Zc
    Z[cd.o] = real_vector(Vo, Zc.shape[1])
    return Z


def evaluate(cd: Condensation, Zc, omega: float, zeta: float, scale, M, ref: int,
             contact, jacobian: bool = True):
    """The condensed EPMC at one point: (R, dR/dy, dR/ds, F, G, Q) as `epmc.evaluate`,
    R and dR/dy over y = [Zc, omega, zeta], F = L Q + G, G and Q (n, 2H+1) over all
    DOFs (F recomputed on the recovered motion: its rows o vanish to round-off).
    `contact(Qc, jacobian)` gives the contact DOFs' forces (nc, 2H+1) [N] and their
    Jacobian (nc nh, nc nh)."""
    nc, nh = Zc.shape
    S, dSw, T = operators(cd, omega, zeta)
    Scc, Sco, Soc, Soo = split(cd, S)
    Z = recover(cd, Zc, omega, zeta, S)
    Q = Z * scale
    Gc, Jc = contact(Q[cd.c], jacobian)
    Qh = complex_harmonics(Q)                               # (H+1, n)
    F = real_vector(np.einsum("hij,hj->hi", S, Qh), nh).reshape(-1, nh)
    F[cd.c] += Gc
    G = np.zeros_like(F)
    G[cd.c] = Gc
    harm = Z[:, 1:]
    h = np.arange(1, (nh - 1) // 2 + 1)
    R = np.concatenate([(F[cd.c] / scale).ravel(),
                        [np.sum(harm * (M @ harm)) - 1.0, h @ Z[ref, 2::2]]])
    if not jacobian:
        return R, None, None, F, G, Q
    X = np.linalg.solve(Soo, Soc)
    m = nc * nh
    Jy = np.zeros((m + 2, m + 2))
    J = Jy[:m, :m]                                          # dF_c/dQ_c, then scaled
    J[...] = real_blocks(Scc - Sco @ X, nh)
    J += Jc
    sv = np.tile(scale, nc)
    Zk = Zc.copy()
    Zk[:, 0] = 0.0
    dR_ds = np.zeros(m + 2)
    J *= sv[None, :]
    dR_ds[:m] = LN10 * (J @ Zk.ravel())                     # (dF/dQ ln10 Q_h) / a
    J /= sv[:, None]
    dR_ds[:m] /= sv
    dR_ds[:m] -= LN10 * np.where(np.arange(m) % nh == 0, 0.0, R[:m])
    for col, dS in ((m, dSw), (m + 1, T)):                  # d/domega, d/dzeta
        dQ = np.einsum("hij,hj->hi", dS, Qh)
        t = np.linalg.solve(Soo, dQ[:, cd.o, None])[..., 0]
        dFc = dQ[:, cd.c] - np.einsum("hij,hj->hi", Sco, t)
        Jy[:m, col] = (real_vector(dFc, nh) / scale).ravel()
    V = complex_harmonics(Z)
    V[0] = 0.0                                              # the conditions read h >= 1
    gN = 2.0 * (M @ V.T).T.astype(complex)
    gP = np.zeros_like(V)
    gP[1:, ref] = -1j * h
    dSV = [np.einsum("hij,hj->hi", dS, V) for dS in (dSw, T)]
    for row, g in ((m, gN), (m + 1, gP)):
        u = np.linalg.solve(np.conj(np.swapaxes(Soo, -1, -2)), g[:, cd.o, None])[..., 0]
        total = g[:, cd.c] - np.einsum("hji,hj->hi", np.conj(Soc), u)
        grad = real_vector(total, nh)                       # d/dZ_cos = Re, d/dZ_sin = -Im
        grad[:, 0] = 0.0
        Jy[row, :m] = grad.ravel()
        Jy[row, m:] = [-np.sum((np.conj(u) * d[:, cd.o]).real) for d in dSV]
    return R, Jy, dR_ds, F, G, Q
