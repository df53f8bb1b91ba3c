"""Multi-harmonic balance residual (paper Eq. 4, 7, 8), condensed onto contact DOFs.

Unknowns are the real Fourier coefficients Q (n, 2H+1) of `harmonics.py`.  Per
harmonic h the linear part is the dynamic stiffness S_h = K - (h Om)^2 M + i h Om C
(complex amplitude Q_h = Qc_h - i Qs_h), so that Eq. 7 reads

    R_h = S_h Q_h + Bt^T Fu_h(Bt Q, Bn Q) + Bn^T Fv_h(Bt Q, Bn Q) - P_h.

Condensation: the DOFs touched by a contact (c) keep their unknowns, all others (o)
carry no nonlinear force and are eliminated per harmonic,

    S~_h = S_cc - S_co S_oo^-1 S_oc,   P~_h = P_c - S_co S_oo^-1 P_o,

so Newton works on nc (2H+1) unknowns only; `recover` gives Q_o = S_oo^-1 (P_o -
S_oc Q_c) afterwards.  The condensed residual is the full residual restricted to
the c rows (the o rows vanish exactly), so its norm is in newtons [N], the units
of the equations: no scaling is applied to decide convergence.

Cyclic sectors (`System.cyclic`; Petrov, J. Turbomach. 126, 2004).  An element
that also acts on the next sector sees that sector's motion shifted in time,
q_{j+1}(tau) = q_j(tau + phi), phi = 2 pi EO / N.  In the real layout a shift by
theta is the orthogonal, harmonic-wise rotation

    T(theta) = blockdiag(1, R(theta), R(2 theta), ..., R(H theta)),
    R(a) = [[cos a, sin a], [-sin a, cos a]]    (acting on [Xc_h, Xs_h]),

i.e. the complex amplitude times exp(i h theta).  So every element DOF slot a
carries a weight b_a and a shift theta_a (0 on the own sector, phi on the next):

    U = sum_a bt_a T(theta_a) Q_a,   G_a += T(theta_a)^T (bt_a Fu + bn_a Fv),
    dG_a/dQ_b = T(theta_a)^T (bt_a bt_b dFu/dU + bt_a bn_b dFu/dV + bn_a bn_b dFv/dV) T(theta_b),

the back-projection being the transpose of the motion map (the force of the
previous sector's element reaches this sector shifted by -phi), so the Jacobian
stays exact.  The linear part, the condensation and the recovery are unchanged.
Without `System.cyclic` no shift is stored and nothing is rotated.  A linear
inter-sector coupling (`CyclicCoupling.K_next`) enters the linear part per harmonic,
K + e^{i h phi} K_next + e^{-i h phi} K_next^T (`stiffness_stack`).  The operators of
all DOFs (no condensation, for Hill's method) are in `full_operators`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..contact import YangMenq
from ..contact.laws import YangMenqLaw
from ..fourier.harmonics import (complex_harmonics, derivative_matrix, real_blocks, real_vector,
                                 shift_tables, turn)
from ..fourier.harmonics import shift as time_shift
from ..model.system import System, coupled_stiffness, dense, element_rows
from .interior import condense_blocks, interior_blocks, recover_blocks
from .law_terms import (LawSlots, assemble, combine, element_jacobian, law_columns, law_slots,
                        motion, pair_weights, projected, slot_index)
from .parts import (condense_parts, jacobian_pattern, linear_values, part_blocks,
                    pattern_matrix)


@dataclass(frozen=True)
class HBMProblem:
    """A System prepared for harmonic balance with H harmonics."""

    system: System
    H: int
    method: str            # "exact" or "aft"
    n_samples: int         # AFT samples per period
    c: np.ndarray          # contact DOF indices (nc,)
    o: np.ndarray          # eliminated DOF indices
    idx: np.ndarray        # (E, m) positions in c of each element's DOFs
    bt: np.ndarray         # (E, m) tangential weights
    bn: np.ndarray         # (E, m) normal weights
    P: np.ndarray          # (n, 2H+1) forcing coefficients [N]
    shift: np.ndarray | None = None   # (E, m) time shift theta of each slot [rad] (cyclic)
    rot: np.ndarray | None = None     # (2, E, m, 2H+1) cos, sin of h theta in the layout
    nxt: np.ndarray | None = None     # (E, m) bool: the slot is a DOF of the next sector
    parts: object = None              # parts.PartBlocks of independent parts (a full wheel)
    pattern: object = None            # parts.JacobianPattern: the Jacobian is built sparse
    interior: object = None           # interior.InteriorBlocks: dense blocks gathered once
    stiffness: np.ndarray | None = None  # (H+1, n, n) `stiffness_stack` of a dense system
    loads: np.ndarray | None = None      # (H+1, n) complex load per harmonic (`complex_loads`)
    weights: np.ndarray | None = None    # (E, m m, 3) slot-pair weights bt bt, bt bn, bn bn
    laws: tuple = ()                     # law_terms.LawSlots of `System.laws`
    slots: np.ndarray | None = None      # slot index of all laws (`law_terms.slot_index`)

    @property
    def nh(self):
        return 2 * self.H + 1

    @property
    def size(self):
        return self.c.size * self.nh

    @property
    def slot_index(self) -> np.ndarray:
        """(E, m) positions in c of the slots of the Jacobian blocks `contact_terms`
        returns: the Yang-Menq elements', then those of `System.laws` (padded)."""
        return self.idx if self.slots is None else self.slots


def setup(system: System, H: int, method: str = "exact", n_samples: int = 256) -> HBMProblem:
    """Find the contact DOFs and the element -> DOF maps (rows of Bt, Bn; dense or
    scipy.sparse, never densified)."""
    if H < 1:
        raise ValueError(f"H must be >= 1, got {H}")
    if method not in ("exact", "aft"):
        raise ValueError(f"method must be 'exact' or 'aft', got {method!r}")
    n, E = system.n_dof, system.Bt.shape[0]
    maps = [(element_rows(system.Bt, system.Bn), 0.0, False)]
    cy = system.cyclic
    if cy is not None:  # slots on the next sector's DOFs, shifted by phi
        maps.append((element_rows(cy.Bt_next, cy.Bn_next), cy.phase, True))
    cols = [r for rows, *_ in maps for r, *_ in rows] + [law_columns(le) for le in system.laws]
    if system.laws and cy is not None:
        raise ValueError("contact laws other than Yang-Menq act on one structure, "
                         "not on a cyclic sector")
    c = np.unique(np.concatenate(cols)).astype(int) if cols else np.zeros(0, int)
    o = np.setdiff1d(np.arange(n), c)
    m = max([sum(rows[e][0].size for rows, *_ in maps) for e in range(E)] + [1])
    idx = np.zeros((E, m), int)
    bt, bn, shift = np.zeros((E, m)), np.zeros((E, m)), np.zeros((E, m))
    nxt = np.zeros((E, m), bool)
    for e in range(E):
        k = 0
        for rows, th, is_next in maps:
            r, vt, vn = rows[e]
            sl = slice(k, k + r.size)
            idx[e, sl] = np.searchsorted(c, r)
            bt[e, sl], bn[e, sl], shift[e, sl], nxt[e, sl] = vt, vn, th, is_next
            k += r.size
    interior = (None if sp.issparse(system.K) or (cy is not None and cy.K_next is not None)
                else interior_blocks(*(dense(A) for A in (system.K, system.M, system.C)), c, o))
    stack = None if sp.issparse(system.K) else stiffness_stack(system, H)
    P = system.forcing_coefficients(H)
    if cy is None:
        laws = tuple(law_slots(le, c) for le in system.laws)
        own = LawSlots(None, idx, (bt, bn), np.zeros(0))
        slots = slot_index((own,) + laws) if laws else None
        parts = part_blocks(system, c, o)
        pattern = (None if parts is None else
                   jacobian_pattern(parts, idx if slots is None else slots, c.size, 2 * H + 1))
        prob = HBMProblem(system, int(H), method, int(n_samples), c, o, idx, bt, bn,
                          P, parts=parts, pattern=pattern, interior=interior,
                          stiffness=stack, loads=complex_loads(P), weights=slot_weights(bt, bn))
        return replace(prob, laws=laws, slots=slots) if laws else prob
    return HBMProblem(system, int(H), method, int(n_samples), c, o, idx, bt, bn,
                      P, shift, np.stack(shift_tables(shift, H)), nxt, interior=interior,
                      stiffness=stack, loads=complex_loads(P), weights=slot_weights(bt, bn))


# --------------------------------------------------------------------------
# linear part, condensed
# --------------------------------------------------------------------------

def _phase(sys) -> float:
    """Inter-sector phase phi [rad] of a cyclic sector (0 otherwise)."""
    return sys.cyclic.phase if sys.cyclic is not None else 0.0


def stiffness_stack(sys, H: int) -> np.ndarray:
    """(H+1, n, n) stiffness of each harmonic h: K, or for a cyclic sector with a
    linear inter-sector coupling K + e^{i h phi} K_next + e^{-i h phi} K_next^T."""
    phi = _phase(sys)
    Ks = [coupled_stiffness(sys, h * phi) for h in range(H + 1)]
    return np.stack([dense(K) for K in Ks])


def _S(sys, h, Om):
    K, M, C = coupled_stiffness(sys, h * _phase(sys)), sys.M, sys.C
    if sp.issparse(K):
        return (K - (h * Om) ** 2 * M + 1j * h * Om * C).tocsc()
    return np.asarray(K) - (h * Om) ** 2 * np.asarray(M) + 1j * h * Om * np.asarray(C)


def _dS(sys, h, Om):
    K, M, C = sys.K, sys.M, sys.C
    if sp.issparse(K):
        return (-2 * h * h * Om * M + 1j * h * C).tocsc()
    return -2 * h * h * Om * np.asarray(M) + 1j * h * np.asarray(C)


def _complex_forcing(P, h):
    return P[:, 0].astype(complex) if h == 0 else P[:, 2 * h - 1] - 1j * P[:, 2 * h]


def complex_loads(P) -> np.ndarray:
    """(H+1, n) complex load per harmonic of real coefficients P (n, 2H+1)."""
    return np.stack([_complex_forcing(P, h) for h in range((P.shape[1] - 1) // 2 + 1)])


def _block(S, c, o):
    if sp.issparse(S):
        S = S.tocsr()
        return (S[c][:, c].toarray(), S[c][:, o], S[o][:, c], S[o][:, o].tocsc())
    return S[np.ix_(c, c)], S[np.ix_(c, o)], S[np.ix_(o, c)], S[np.ix_(o, o)]


class _Solver:
    """Factorisation of S_oo (dense LU or sparse LU), reused for several solves."""

    def __init__(self, A):
        if sp.issparse(A):
            import scipy.sparse.linalg as spla
            self.lu = spla.splu(A.tocsc())
            self.solve = self.lu.solve
        else:
            self.lu = sla.lu_factor(A, check_finite=False)
            self.solve = lambda b: sla.lu_solve(self.lu, b, check_finite=False)


def linear_part(prob: HBMProblem, Om: float, derivatives: bool = True, motion=None):
    """Condensed dynamic stiffness per harmonic and condensed forcing.

    Returns (St, dSt, Pt, dPt): St[h], dSt[h] complex (nc, nc) for h = 0..H
    (dSt = d/dOm), Pt, dPt complex (H+1, nc).  With `motion` (H+1, nc) complex (the
    contact DOFs' harmonics, `complex_harmonics`), dSt is returned applied to it,
    dSt[h] @ motion[h] (H+1, nc): all the residual needs for dR/dOm.
    """
    sys, c, o, H = prob.system, prob.c, prob.o, prob.H
    if prob.interior is not None:   # dense blocks gathered once (interior.py)
        P = prob.loads if prob.loads is not None else complex_loads(prob.P)
        return condense_blocks(prob.interior, H, Om, P, c, o, derivatives, motion)
    out = _linear_part(prob, Om, derivatives)
    if not (derivatives and motion is not None):
        return out
    St, dSt, Pt, dPt = out
    return St, np.einsum("hij,hj->hi", np.asarray(dSt), motion), Pt, dPt


def _linear_part(prob: HBMProblem, Om: float, derivatives: bool):
    sys, c, o, H = prob.system, prob.c, prob.o, prob.H
    if not sp.issparse(sys.K):
        return _linear_part_dense(prob, Om, derivatives)
    if prob.parts is not None:   # a full wheel on a rigid disk: blade by blade (parts.py)
        out = [condense_parts(prob.parts, h, Om, _complex_forcing(prob.P, h), c, derivatives)
               for h in range(H + 1)]
        St, dSt, Pt, dPt = zip(*out)
        return (list(St), list(dSt) if derivatives else [], np.array(Pt),
                np.array(dPt) if derivatives else None)
    St, dSt, Pt, dPt = [], [], [], []
    for h in range(H + 1):
        S = _S(sys, h, Om)
        Ph = _complex_forcing(prob.P, h)
        if o.size == 0:
            St.append(np.asarray(S.toarray() if sp.issparse(S) else S)[np.ix_(c, c)])
            Pt.append(Ph[c])
            if derivatives:
                dS = _dS(sys, h, Om)
                dSt.append(np.asarray(dS.toarray() if sp.issparse(dS) else dS)[np.ix_(c, c)])
                dPt.append(np.zeros(c.size, complex))
            continue
        Scc, Sco, Soc, Soo = _block(S, c, o)
        lu = _Solver(Soo)
        rhs = np.column_stack([_dense_c(Soc), Ph[o][:, None]])
        sol = lu.solve(rhs)
        X, z = sol[:, :-1], sol[:, -1]           # X = Soo^-1 Soc, z = Soo^-1 P_o
        St.append(Scc - (Sco @ X))
        Pt.append(Ph[c] - (Sco @ z))
        if derivatives:
            dScc, dSco, dSoc, dSoo = _block(_dS(sys, h, Om), c, o)
            # Y = Sco Soo^-1 via the transposed solve: Y^T = Soo^-T Sco^T
            YT = _solve_T(lu, Soo, _dense_c(Sco).T)
            Y = YT.T
            dSt.append(dScc - (dSco @ X) - Y @ _dense_c(dSoc) + Y @ (dSoo @ X))
            dPt.append(-(dSco @ z) + Y @ (dSoo @ z))
    return St, dSt, np.array(Pt), np.array(dPt) if derivatives else None


def _linear_part_dense(prob: HBMProblem, Om: float, derivatives: bool):
    """`linear_part` for dense matrices: all harmonics in batched numpy calls."""
    sys, c, o, H = prob.system, prob.c, prob.o, prob.H
    M, C = (np.asarray(A, dtype=float) for A in (sys.M, sys.C))
    h = np.arange(H + 1)[:, None, None]
    Kh = prob.stiffness if prob.stiffness is not None else stiffness_stack(sys, H)
    S = Kh - (h * Om) ** 2 * M + 1j * h * Om * C   # (H+1, n, n)
    P = prob.loads if prob.loads is not None else complex_loads(prob.P)  # (H+1, n)
    dS = -2 * h * h * Om * M + 1j * h * C if derivatives else None
    if o.size == 0:   # every DOF is a contact DOF: c = 0..n-1
        return S, dS, P, np.zeros((H + 1, c.size), complex) if derivatives else None
    Scc, Sco, Soc, Soo = S[:, c][:, :, c], S[:, c][:, :, o], S[:, o][:, :, c], S[:, o][:, :, o]
    sol = np.linalg.solve(Soo, np.concatenate([Soc, P[:, o, None]], axis=2))
    # contiguous copies: batched matmul on strided complex views falls back to a slow
    # loop in numpy (15-40x slower on a 136-DOF blade)
    X, z = np.ascontiguousarray(sol[..., :-1]), sol[..., -1]   # Soo^-1 Soc, Soo^-1 P_o
    St = Scc - Sco @ X
    Pt = P[:, c] - (Sco @ z[..., None])[..., 0]
    if not derivatives:
        return St, None, Pt, None
    dScc, dSco, dSoc, dSoo = (dS[:, c][:, :, c], dS[:, c][:, :, o], dS[:, o][:, :, c],
                              dS[:, o][:, :, o])
    Y = np.ascontiguousarray(
        np.linalg.solve(Soo.transpose(0, 2, 1), Sco.transpose(0, 2, 1)).transpose(0, 2, 1))
    dSt = dScc - dSco @ X - Y @ dSoc + Y @ dSoo @ X
    dPt = (-(dSco @ z[..., None]) + Y @ (dSoo @ z[..., None]))[..., 0]
    return St, dSt, Pt, dPt


def _dense_c(A):
    return A.toarray() if sp.issparse(A) else A


def _solve_T(lu, A, B):
    if sp.issparse(A):
        return lu.lu.solve(B, trans="T")
    return sla.lu_solve(lu.lu, B, trans=1, check_finite=False)


# --------------------------------------------------------------------------
# nonlinear part
# --------------------------------------------------------------------------

def contact_motion(prob: HBMProblem, Qc):
    """Relative displacements U = Bt Q, V = Bn Q (E, 2H+1) from Qc (nc, 2H+1)
    (cyclic: each slot's coefficients shifted first, U = sum_a bt_a T(theta_a) Q_a)."""
    Qe = Qc[prob.idx]  # (E, m, nh)
    if prob.rot is not None:
        Qe = turn(Qe, prob.rot[0], prob.rot[1])
    return np.einsum("em,emk->ek", prob.bt, Qe), np.einsum("em,emk->ek", prob.bn, Qe)


def contact_slots(prob: HBMProblem, contact: YangMenq | None = None) -> tuple:
    """((`law_terms.LawSlots`, rotation or None), ...) of every law of the problem:
    the Yang-Menq elements `contact` (default the system's) on Bt, Bn, then
    `System.laws`."""
    elem = contact if contact is not None else prob.system.contact
    W = prob.weights if prob.weights is not None else slot_weights(prob.bt, prob.bn)
    own = LawSlots(YangMenqLaw(elem), prob.idx, (prob.bt, prob.bn), W)
    return ((own, prob.rot),) + tuple((s, None) for s in prob.laws)


def contact_terms(prob: HBMProblem, Qc, contact: YangMenq | None = None, jacobian=True,
                  blocks=False):
    """Generalised contact force B^T F of every law, Bt^T Fu + Bn^T Fv for Yang-Menq,
    (nc, nh), and its Jacobian (nc nh, nc nh); with blocks=True the Jacobian is
    returned per element and slot pair instead, (E, m, m, nh, nh), at
    `HBMProblem.slot_index`, for `assemble` (see `wave_jacobians`).  The third
    output is the Yang-Menq `ContactForces` (None without Yang-Menq elements)."""
    nc, nh = prob.c.size, prob.nh
    if prob.idx.shape[0] == 0 and not prob.laws:
        return np.zeros((nc, nh)), (np.zeros((nc * nh, nc * nh)) if jacobian else None), None
    G, Jes, f = np.zeros((nc, nh)), [], None
    for slots, rot in contact_slots(prob, contact):
        if slots.idx.shape[0] == 0:
            continue
        out = slots.law.evaluate(motion(slots, Qc, rot, turn), prob.method, prob.n_samples,
                                 jacobian)
        f = out.detail if slots.idx is prob.idx else f
        contrib = projected(slots, out.F)
        if rot is not None:  # back-projection T(theta_a)^T = T(-theta_a)
            contrib = turn(contrib, rot[0], -rot[1])
        np.add.at(G, slots.idx, contrib)
        if jacobian:
            Je = element_jacobian(slots, out.J)
            if rot is not None:  # T(theta_a)^T Je T(theta_b): rows by -theta_a, columns by -theta_b
                c, s = rot
                Je = turn(Je, c[:, :, None, :, None], -s[:, :, None, :, None], axis=-2)
                Je = turn(Je, c[:, None, :, None, :], -s[:, None, :, None, :], axis=-1)
            Jes.append(Je)
    if not jacobian:
        return G, None, f
    Je = combine(Jes) if prob.laws else Jes[0]   # laws: padded as `slot_index`
    return G, (Je if blocks else assemble(prob, Je)), f


def slot_weights(bt, bn) -> np.ndarray:
    """(E, m m, 3) weights of the slot pairs (a, b) of each element: bt_a bt_b,
    bt_a bn_b, bn_a bn_b (`contact_terms`)."""
    return pair_weights((bt, bn), YangMenqLaw.pairs)


# --------------------------------------------------------------------------
# residual, recovery, full-system check
# --------------------------------------------------------------------------

def residual(prob: HBMProblem, x, Om, contact: YangMenq | None = None, jacobian=True):
    """Condensed residual R(x, Om) [N] with x = Qc.ravel(); (R, dR/dx, dR/dOm).
    dR/dx is scipy.sparse for a full wheel (`HBMProblem.pattern`), else dense."""
    nh = prob.nh
    Qc = x.reshape(prob.c.size, nh)
    pat = prob.pattern
    applied = jacobian and pat is None
    St, dSt, Pt, dPt = linear_part(prob, Om, derivatives=jacobian,
                                   motion=complex_harmonics(Qc) if applied else None)
    lin = linear_values(pat, St) if pat is not None else None
    L = pattern_matrix(pat, lin) if pat is not None else real_blocks(St, nh)
    G, Jnl, _ = contact_terms(prob, Qc, contact, jacobian, blocks=jacobian)
    R = L @ x + G.ravel() - real_vector(Pt, nh).ravel()
    if not jacobian:
        return R, None, None
    if applied:   # dSt already applied to the motion (`linear_part`)
        dR_dOm = real_vector(dSt - dPt, nh).ravel()
    else:
        dR_dOm = (pattern_matrix(pat, linear_values(pat, dSt)) @ x
                  - real_vector(dPt, nh).ravel())
    blocks = Jnl if Jnl.ndim == 5 else None     # 2-D zeros without elements
    if pat is not None:
        return R, pattern_matrix(pat, lin, blocks), dR_dOm
    return R, (L if blocks is None else assemble(prob, blocks, out=L)), dR_dOm


def recover(prob: HBMProblem, Qc, Om):
    """All DOFs' coefficients Q (n, nh) from the contact DOFs' Qc (nc, nh)."""
    sys, c, o, H, nh = prob.system, prob.c, prob.o, prob.H, prob.nh
    Q = np.zeros((sys.n_dof, nh))
    Q[c] = Qc
    if o.size == 0:
        return Q
    if prob.interior is not None:
        Qh = complex_harmonics(Qc)
        P_o = (prob.loads if prob.loads is not None else complex_loads(prob.P))[:, o]
        Qo = recover_blocks(prob.interior, H, Om, Qh, P_o)              # (H+1, no)
        Q[o, 0] = Qo[0].real
        Q[o, 1::2], Q[o, 2::2] = Qo[1:].real.T, -Qo[1:].imag.T
        return Q
    if not sp.issparse(sys.K):
        M, C = (np.asarray(A, dtype=float) for A in (sys.M, sys.C))
        h = np.arange(H + 1)[:, None, None]
        Kh = prob.stiffness if prob.stiffness is not None else stiffness_stack(sys, H)
        S = (Kh - (h * Om) ** 2 * M + 1j * h * Om * C)[:, o]
        Qh = complex_harmonics(Qc)
        rhs = np.stack([_complex_forcing(prob.P, k)[o] for k in range(H + 1)])
        rhs = rhs - (S[:, :, c] @ Qh[..., None])[..., 0]
        Qo = np.linalg.solve(S[:, :, o], rhs[..., None])[..., 0]     # (H+1, no)
        Q[o, 0] = Qo[0].real
        Q[o, 1::2], Q[o, 2::2] = Qo[1:].real.T, -Qo[1:].imag.T
        return Q
    for h in range(H + 1):
        _, _, Soc, Soo = _block(_S(sys, h, Om), c, o)
        Qh = Qc[:, 0].astype(complex) if h == 0 else Qc[:, 2 * h - 1] - 1j * Qc[:, 2 * h]
        rhs = _complex_forcing(prob.P, h)[o] - (Soc @ Qh)
        Qo = _Solver(Soo).solve(rhs)
        if h == 0:
            Q[o, 0] = Qo.real
        else:
            Q[o, 2 * h - 1], Q[o, 2 * h] = Qo.real, -Qo.imag
    return Q


def full_residual(prob: HBMProblem, Q, Om, contact: YangMenq | None = None):
    """Residual of all n (2H+1) equations [N] (no condensation): every point's convergence check."""
    sys = prob.system
    K, C, M = sys.K, sys.C, sys.M
    D = derivative_matrix(prob.H)
    lin = K @ Q + Om * (C @ Q) @ D.T + Om**2 * (M @ Q) @ (D @ D).T
    cy = sys.cyclic
    if cy is not None and cy.K_next is not None:
        Kn = np.asarray(cy.K_next, dtype=float)
        lin = lin + Kn @ time_shift(Q, cy.phase) + Kn.T @ time_shift(Q, -cy.phase)
    G, _, _ = contact_terms(prob, Q[prob.c], contact, jacobian=False)
    R = np.asarray(lin) - prob.P
    R[prob.c] += G
    return R


def force_scale(prob: HBMProblem, contact: YangMenq | None = None) -> float:
    """Reference force [N] for tolerances: |P| + sum |n0_e| |Bn_e| (never 0).

    A preload counts only where it loads the structure (through Bn); the Jenkins
    normal load of a kv = 0 element with Bn = 0 merely limits friction.
    """
    elem = contact if contact is not None else prob.system.contact
    bn = np.linalg.norm(prob.bn, axis=1) if prob.bn.size else np.zeros(0)
    s = float(np.linalg.norm(prob.P)) + float(np.sum(np.abs(elem.n0) * bn))
    return s if s > 0 else 1.0


def tolerances(prob: HBMProblem, tol_rel: float, contact: YangMenq | None = None):
    """Residual tolerances [N] of the static (h = 0) and the harmonic (h >= 1) equations.

    static:  tol_rel * (|P_0| + sum |n0_e| |Bn_e| + |P_h>=1|)
    dynamic: tol_rel * |P_h>=1|
    The harmonic equations are held to the excitation's scale, so a large static
    preload cannot swamp them; the static equations also carry the rectified
    (mean) contact forces of the vibration, so their scale includes the dynamic
    load.  Zero excitation falls back to the static scale, then to tol_rel * 1 N.
    Below the residual's round-off the tolerance is raised per point (`roundoff`).
    """
    elem = contact if contact is not None else prob.system.contact
    bn = np.linalg.norm(prob.bn, axis=1) if prob.bn.size else np.zeros(0)
    d = float(np.linalg.norm(prob.P[:, 1:]))
    s = float(np.linalg.norm(prob.P[:, 0])) + float(np.sum(np.abs(elem.n0) * bn)) + d
    s = s or 1.0
    return tol_rel * s, tol_rel * (d or s)


def row_weights(prob: HBMProblem, tols) -> np.ndarray:
    """1/tolerance for each condensed equation (DOF-major rows): with them, one
    scaled residual norm <= 1 implies every block within its tolerance."""
    w = np.full((prob.c.size, prob.nh), 1.0 / tols[1])
    w[:, 0] = 1.0 / tols[0]
    return w.ravel()


def residual_parts(R_full) -> tuple:
    """(static, harmonic) norms [N] of a full residual (n, 2H+1)."""
    return float(np.linalg.norm(R_full[:, 0])), float(np.linalg.norm(R_full[:, 1:]))
