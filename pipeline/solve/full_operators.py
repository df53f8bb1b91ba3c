"""The harmonic balance operators of ALL DOFs (no condensation), for Hill's method.

`full_linear_operator` is the linear part K (x) I + Om C (x) D + Om^2 M (x) D^2 of
paper Eq. 7 on Q (n, 2H+1) row-major; `full_jacobian` adds the contact Jacobian of
`hbm.contact_terms` (exact, paper Eq. 10-12 differentiated).  A cyclic sector's own
Jacobian only sees perturbations with the solution's symmetry: `wave_jacobians`
gives the Hill problem of every wave number r = 0..N/2 from the sector alone,
with a linear inter-sector coupling (`coupling_operators`) treated like the
contacts' slots on the next sector.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..contact import YangMenq
from ..fourier.harmonics import derivative_matrix
from ..fourier.harmonics import shift as time_shift
from ..model.system import System, dense
from .hbm import HBMProblem, assemble, contact_terms


def full_linear_operator(sys: System, Om: float, H: int, coupling: bool = True):
    """K (x) I + Om C (x) D + Om^2 M (x) D^2 acting on Q (n, 2H+1) row-major (dense),
    plus (coupling=True) a cyclic sector's linear inter-sector coupling
    (`coupling_operators`, wave number 0)."""
    if sp.issparse(sys.K):  # only the (n nh)^2 result is dense, no (n, n) copies
        D, I = derivative_matrix(H), np.eye(2 * H + 1)
        L = (sp.kron(sys.K, I) + Om * sp.kron(sys.C, D) + Om**2 * sp.kron(sys.M, D @ D)
             ).toarray()
    else:   # filled per harmonic (D^2 = diag(-h^2)); the same as the Kronecker sum
        K, C, M = dense(sys.K), dense(sys.C), dense(sys.M)
        n, nh = K.shape[0], 2 * H + 1
        L4 = np.zeros((n, nh, n, nh))
        h2 = np.concatenate([[0.0], np.repeat(np.arange(1.0, H + 1) ** 2, 2)])
        k = np.arange(nh)
        L4[:, k, :, k] = K - (Om**2 * h2)[:, None, None] * M
        ci, si = np.arange(1, nh, 2), np.arange(2, nh, 2)
        hD = Om * np.arange(1.0, H + 1)[:, None, None] * C     # Om C (x) D, D[c, s] = h
        L4[:, ci, :, si] = hD
        L4[:, si, :, ci] = -hD
        L = L4.reshape(n * nh, n * nh)
    parts = coupling_operators(sys, H) if coupling else None
    return L if parts is None else L + parts[0] + parts[1]


def coupling_operators(sys: System, H: int):
    """(L_sn, L_ns) of a cyclic sector with a linear inter-sector coupling, in the
    layout of `full_linear_operator`: K_next acting on the next sector's motion,
    shift(Q, phi), and K_next^T on the previous one's, shift(Q, -phi); None when
    there is no such coupling."""
    cy = sys.cyclic
    if cy is None or cy.K_next is None:
        return None
    T = time_shift(np.eye(2 * H + 1), cy.phase)       # shift(Q, phi) = Q @ T
    Kn = np.asarray(cy.K_next, dtype=float)
    return np.kron(Kn, T.T), np.kron(Kn.T, T)


def full_jacobian(prob: HBMProblem, Q, Om, contact: YangMenq | None = None):
    """dR/dQ of the full (uncondensed) system, dense (n nh)^2: for Hill's method."""
    nh, n = prob.nh, prob.system.n_dof
    J = full_linear_operator(prob.system, Om, prob.H).reshape(n, nh, n, nh)
    _, Jnl, _ = contact_terms(prob, Q[prob.c], contact, jacobian=True)
    nc = prob.c.size
    J[np.ix_(prob.c, np.arange(nh), prob.c, np.arange(nh))] += Jnl.reshape(nc, nh, nc, nh)
    return J.reshape(n * nh, n * nh)


def wave_jacobians(prob: HBMProblem, Q, Om, contact: YangMenq | None = None):
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
        D = J_sn - J_ns, c + i s = z,   with M, C doubled.

    The union of their exponents is the Hill spectrum of the full assembly."""
    sysm, nh, n = prob.system, prob.nh, prob.system.n_dof
    M, C = dense(sysm.M), dense(sysm.C)
    if prob.nxt is None:
        return [(0, full_jacobian(prob, Q, Om, contact), M, C)]
    N = sysm.cyclic.sectors
    L = full_linear_operator(sysm, Om, prob.H, coupling=False)
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
    lin = coupling_operators(sysm, prob.H)
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

