"""The harmonic balance operators of ALL DOFs (no condensation), for Hill's method.

`full_linear_operator` is the linear part K (x) I + Om C (x) D + Om^2 M (x) D^2 of
paper Eq. 7 on Q (n, 2H+1) row-major (formed in `dynamic_stiffness`, with the
problem's added linear terms); `full_jacobian` adds the contact Jacobian of
`hbm.contact_terms` (exact, paper Eq. 10-12 differentiated).  A cyclic sector's own
Jacobian only sees perturbations with the solution's symmetry: `wave_jacobians`
gives the Hill problem of every wave number r = 0..N/2 from the sector alone,
with a linear inter-sector coupling (`coupling_operators`) treated like the
contacts' slots on the next sector.
"""
from __future__ import annotations

import numpy as np

from ...contact.laws import ContactElements
from ...fourier.harmonics import shift as time_shift
from ...fourier.harmonics import derivative_matrix
from ...model.system import System, coupling, dense, inertia_coupled
from .dynamic_stiffness import full_operator, motion_matrices
from .hbm import HBMProblem, assemble, contact_terms


def full_linear_operator(sys: System, Om: float, H: int, coupling: bool = True, extra=()):
    """K (x) I + Om C (x) D + Om^2 M (x) D^2 (+ added terms, `dynamic_stiffness.Term`)
    acting on Q (n, 2H+1) row-major (dense; `dynamic_stiffness.full_operator`), plus
    (coupling=True) a cyclic sector's linear inter-sector coupling
    (`coupling_operators`, wave number 0)."""
    L = full_operator(sys, Om, H, extra)
    parts = coupling_operators(sys, H, Om) if coupling else None
    return L if parts is None else L + parts[0] + parts[1]


def coupling_operators(sys: System, H: int, Om: float = 0.0):
    """(L_sn, L_ns) of a cyclic sector with a linear inter-sector coupling, in the
    layout of `full_linear_operator`: K_next + Om C_next D + Om^2 M_next D^2 acting on
    the next sector's motion, shift(Q, phi), and the transposes on the previous one's,
    shift(Q, -phi) (`dynamic_stiffness.apply_coupling`); None when there is no such
    coupling."""
    cy = sys.cyclic
    K, C, M = (coupling(sys, name) for name in "KCM")
    if cy is None or (K is None and C is None and M is None):
        return None
    D = derivative_matrix(H)
    T = time_shift(np.eye(2 * H + 1), cy.phase)       # shift(Q, phi) = Q @ T

    def layout(X, Y):    # X Q Y on Q row-major
        return 0.0 if X is None else np.kron(X, Y.T)

    def part(tr, T):     # K Q T + Om C Q T D^T + Om^2 M Q T (D D)^T
        Kx, Cx, Mx = (None if X is None else (X.T if tr else X) for X in (K, C, M))
        return (layout(Kx, T) + Om * layout(Cx, T @ D.T) + Om ** 2 * layout(Mx, T @ (D @ D).T)
                + np.zeros((sys.n_dof * (2 * H + 1),) * 2))
    return part(False, T), part(True, T.T)


def full_jacobian(prob: HBMProblem, Q, Om, contact: ContactElements | None = None):
    """dR/dQ of the full (uncondensed) system, dense (n nh)^2: for Hill's method."""
    nh, n = prob.nh, prob.system.n_dof
    J = full_linear_operator(prob.system, Om, prob.H, extra=prob.linear.extra)
    J = J.reshape(n, nh, n, nh)
    _, Jnl, _ = contact_terms(prob, Q[prob.c], contact, jacobian=True)
    nc = prob.c.size
    if nc == n:   # every DOF a contact DOF (c ascending: c = 0..n-1)
        return J.reshape(n * nh, n * nh) + Jnl
    J[np.ix_(prob.c, np.arange(nh), prob.c, np.arange(nh))] += Jnl.reshape(nc, nh, nc, nh)
    return J.reshape(n * nh, n * nh)


def wave_jacobians(prob: HBMProblem, Q, Om, contact: ContactElements | None = None):
    """Hill's problems [(r, J, M, C), ...] of a solution Q (n, nh) for every family of
    perturbations, so that the travelling wave is stable iff each one is.

    Non-cyclic: the one problem (0, full_jacobian, M, C).  A cyclic sector's own
    Jacobian only sees perturbations with the symmetry of the solution; the
    N-sector assembly also has perturbations with a wave number r: dQ_j =
    z^j T(j phi) dQ_0, z = exp(2 pi i r / N).  With that ansatz the contact
    Jacobian becomes (from the equivariance of the contact law under time shifts)

        J_r = L + J_ss + J_nn + z J_sn + conj(z) J_ns

    (s: slots on this sector, n: on the next; J_sn = rows s, columns n).  For
    r = 0 and r = N/2 z is real; the pairs r, N - r are conjugate and are solved
    together as the real problem of twice the size

        [[L + A + c S, -s D], [s D, L + A + c S]],  A = J_ss + J_nn, S = J_sn + J_ns,
        D = J_sn - J_ns, c + i s = z,   with M, C doubled (M, C with the added
    linear terms that are a velocity or an acceleration term, `motion_matrices`).

    The union of their exponents is the Hill spectrum of the full assembly."""
    sysm, nh, n = prob.system, prob.nh, prob.system.n_dof
    if inertia_coupled(sysm):
        raise ValueError("Hill's method on a sector whose mass couples it to its neighbours "
                         "(a flexible disk) is not available: use the wheel's orbit "
                         "(stability = \"monodromy\") or stability = false")
    M, C = motion_matrices(dense(sysm.M), dense(sysm.C), Om, prob.linear.extra)
    if prob.nxt is None:
        return [(0, full_jacobian(prob, Q, Om, contact), M, C)]
    N = sysm.cyclic.sectors
    L = full_linear_operator(sysm, Om, prob.H, coupling=False, extra=prob.linear.extra)
    _, Je, _ = contact_terms(prob, Q[prob.c], contact, jacobian=True, blocks=True)
    nxt = prob.nxt

    def part(rows, cols):
        mask = (nxt[:, :, None] == rows) & (nxt[:, None, :] == cols)
        out = np.zeros((n, nh, n, nh))
        nc = prob.c.size
        out[np.ix_(prob.c, np.arange(nh), prob.c, np.arange(nh))] = assemble(
            prob, Je * mask[..., None, None]).reshape(nc, nh, nc, nh)
        return out.reshape(n * nh, n * nh)

    A = L + part(False, False) + part(True, True)
    Jsn, Jns = part(False, True), part(True, False)
    lin = coupling_operators(sysm, prob.H, Om)
    if lin is not None:   # linear inter-sector coupling: also z on the next sector
        Jsn, Jns = Jsn + lin[0], Jns + lin[1]
    out = []
    for r in range(N // 2 + 1):
        a = 2 * np.pi * r / N
        if r == 0 or 2 * r == N:
            out.append((r, A + np.cos(a) * (Jsn + Jns), M, C))
            continue
        c, s = np.cos(a), np.sin(a)
        B, D = A + c * (Jsn + Jns), s * (Jsn - Jns)
        J2 = np.block([[B, -D], [D, B]])
        # real and imaginary parts of the perturbation as two blocks of DOFs
        out.append((r, J2, np.kron(np.eye(2), M), np.kron(np.eye(2), C)))
    return out

