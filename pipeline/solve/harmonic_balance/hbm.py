"""Multi-harmonic balance residual (paper Eq. 4, 7, 8), condensed onto contact DOFs.

Unknowns are the real Fourier coefficients Q (n, 2H+1) of `harmonics.py`.  Per
harmonic h the linear part is the dynamic stiffness S_h = K - (h Om)^2 M + i h Om C
(complex amplitude Q_h = Qc_h - i Qs_h; formed, condensed and recovered in
`dynamic_stiffness` only, with any added linear terms), so that Eq. 7 reads

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
K + e^{i h phi} K_next + e^{-i h phi} K_next^T (`dynamic_stiffness.stiffness_stack`).
The operators of all DOFs (no condensation, for Hill's method) are in `full_operators`.
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ...contact.laws import ContactElements
from ...contact.registry import law_of
from ...fourier.harmonics import (complex_harmonics, derivative_matrix, real_blocks, real_vector,
                                 shift_tables, turn)
from ...model.system import System, contact_set, element_rows
from . import dynamic_stiffness as dyn
from .law_terms import (LawSlots, assemble, combine, element_jacobian, law_columns, law_slots,
                        motion, pair_weights, projected, slot_index, slot_pairs,
                        stacked_weights)
from .parts import jacobian_pattern, linear_values, pattern_matrix, with_contacts


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
    linear: dyn.DynamicStiffness      # S_h(Om), its condensation and recovery (`dynamic_stiffness`)
    weights: np.ndarray    # (E, m m, 3) slot-pair weights bt bt, bt bn, bn bn
    shift: np.ndarray | None = None   # (E, m) time shift theta of each slot [rad] (cyclic)
    rot: np.ndarray | None = None     # (2, E, m, 2H+1) cos, sin of h theta in the layout
    nxt: np.ndarray | None = None     # (E, m) bool of `slot_index`: a DOF of the next sector
    pattern: object = None            # parts.JacobianPattern: the Jacobian is built sparse
    laws: tuple = ()                  # law_terms.LawSlots of `System.laws`
    slots: np.ndarray | None = None   # slot index of all laws (`law_terms.slot_index`)

    @property
    def parts(self):
        """parts.PartBlocks of independent parts (a full wheel), or None."""
        return self.linear.parts

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

    @cached_property
    def slot_pairs(self) -> tuple:
        """`law_terms.slot_pairs` of `slot_index`: where the Jacobian blocks go."""
        return slot_pairs(self.slot_index)

    @cached_property
    def directions(self) -> np.ndarray:
        """(E, 2, m) the weights bt, bn stacked (`law_terms.LawSlots.directions`)."""
        return stacked_weights((self.bt, self.bn))

    @cached_property
    def evaluated(self) -> "ContactMemo":
        """The contact terms already evaluated at given coefficients (`ContactMemo`)."""
        return ContactMemo()


MEMO_BYTES = 16 * 2**20   # [B] contact terms a problem keeps (`ContactMemo`)


class ContactMemo:
    """The contact terms of `contact_terms` by their exact input (the elements, the
    bytes of Qc), the least recently used dropped beyond MEMO_BYTES.  A converged
    point's full-residual check, Hill's Jacobian and the resonance guard's contact
    stiffness are taken at the coefficients of the point's last Newton evaluation:
    the same input, hence bit for bit the same terms, without a second evaluation.
    The kept arrays are read-only."""

    def __init__(self, max_bytes: int = MEMO_BYTES):
        self.entries, self.bytes, self.max_bytes = OrderedDict(), 0, max_bytes

    def __reduce__(self):   # a problem sent to another process takes no kept terms along
        return ContactMemo, (self.max_bytes,)

    def get(self, contact, Qc, jacobian):
        """(G, Je blocks or None, detail) kept for these elements at Qc, or None (also
        where the Jacobian is asked for and was not kept)."""
        key = (id(contact), Qc.shape, Qc.tobytes())
        e = self.entries.get(key)
        if e is None or e[0] is not contact or (jacobian and e[1][1] is None):
            return None
        self.entries.move_to_end(key)
        return e[1]

    def put(self, contact, Qc, terms):
        G, Je, _ = terms
        for a in (G, Je):
            if a is not None:
                a.flags.writeable = False
        size = G.nbytes + (0 if Je is None else Je.nbytes) + Qc.nbytes
        if size > self.max_bytes:
            return
        key = (id(contact), Qc.shape, Qc.tobytes())
        old = self.entries.pop(key, None)
        self.bytes += size - (0 if old is None else old[2])
        self.entries[key] = (contact, terms, size)   # the elements kept alive: ids stay unique
        while self.bytes > self.max_bytes:
            self.bytes -= self.entries.popitem(last=False)[1][2]


def setup(system: System, H: int, method: str = "exact", n_samples: int = 256,
          extra=()) -> HBMProblem:
    """Find the contact DOFs and the element -> DOF maps (rows of Bt, Bn; dense or
    scipy.sparse, never densified); prepare the linear part (`dynamic_stiffness`),
    with the added linear terms `extra` (`dynamic_stiffness.Term`)."""
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
    if cy is None and any(le.maps_next for le in system.laws):
        raise ValueError("a contact law with next-sector maps needs a cyclic sector")
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
    P = system.forcing_coefficients(H)
    linear = dyn.prepare(system, H, c, o, P, extra)
    parts = linear.parts
    pattern = None if parts is None else jacobian_pattern(parts, idx, c.size, 2 * H + 1)
    common = (system, int(H), method, int(n_samples), c, o, idx, bt, bn, P, linear,
              slot_weights(bt, bn, law_of(system.contact).pairs))
    if cy is None:
        laws = tuple(law_slots(le, c) for le in system.laws)
        own = LawSlots(None, idx, (bt, bn), np.zeros(0))
        slots = slot_index((own,) + laws) if laws else None
        if slots is not None and parts is not None:
            pattern = jacobian_pattern(parts, slots, c.size, 2 * H + 1)
        prob = HBMProblem(*common, pattern=pattern)
        return replace(prob, laws=laws, slots=slots) if laws else prob
    prob = HBMProblem(*common, shift, np.stack(shift_tables(shift, H)), nxt, pattern)
    if not system.laws:
        return prob
    laws = tuple(law_slots(le, c, cy.phase, H) for le in system.laws)
    own = LawSlots(None, idx, (bt, bn), np.zeros(0), next_sector=nxt)
    return replace(prob, laws=laws, slots=slot_index((own,) + laws),
                   nxt=slot_index((own,) + laws, "next_sector"))


# --------------------------------------------------------------------------
# linear part, condensed
# --------------------------------------------------------------------------

def linear_part(prob: HBMProblem, Om: float, derivatives: bool = True, motion=None,
                pattern=None):
    """Condensed dynamic stiffness per harmonic and condensed forcing
    (`dynamic_stiffness.condense`, the strategy fixed by `setup`).

    Returns (St, dSt, Pt, dPt): St[h], dSt[h] complex (nc, nc) for h = 0..H
    (dSt = d/dOm), Pt, dPt complex (H+1, nc).  With `motion` (H+1, nc) complex (the
    contact DOFs' harmonics, `complex_harmonics`), dSt is returned applied to it,
    dSt[h] @ motion[h] (H+1, nc): all the residual needs for dR/dOm.  With the
    problem's `pattern` (and `motion`), St is its values there (H+1, p).
    """
    return dyn.condense(prob.linear, Om, derivatives, motion, pattern)


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


def set_motion(prob: HBMProblem, Qc):
    """X (E, D, 2H+1) along the directions of the system's `contact_set`: (U, V) of
    `contact_motion` for Yang-Menq, (U1, U2, V) for an FE blade's 2D friction law."""
    k = contact_set(prob.system).law
    if k is None:
        return np.stack(contact_motion(prob, Qc), axis=1)
    return law_motion(prob, Qc, k)


def law_motion(prob: HBMProblem, Qc, k: int):
    """X (E, D, 2H+1) of the elements of `System.laws[k]` along the law's directions."""
    slots = prob.laws[k]
    return motion(slots, Qc, slots.rot, turn)


def contact_slots(prob: HBMProblem, contact: ContactElements | None = None) -> tuple:
    """((`law_terms.LawSlots`, rotation or None), ...) of every law of the problem:
    the elements `contact` (default the system's, `System.contact`) on Bt, Bn, then
    `System.laws`."""
    law = law_of(contact if contact is not None else prob.system.contact)
    W = prob.weights if prob.weights is not None else slot_weights(prob.bt, prob.bn, law.pairs)
    own = LawSlots(law, prob.idx, (prob.bt, prob.bn), W, stacked=prob.directions)
    return ((own, prob.rot),) + tuple((s, s.rot) for s in prob.laws)


def contact_terms(prob: HBMProblem, Qc, contact: ContactElements | None = None, jacobian=True,
                  blocks=False):
    """Generalised contact force B^T F of every law, Bt^T Fu + Bn^T Fv for Yang-Menq,
    (nc, nh), and its Jacobian (nc nh, nc nh); with blocks=True the Jacobian is
    returned per element and slot pair instead, (E, m, m, nh, nh), at
    `HBMProblem.slot_index`, for `assemble` (see `wave_jacobians`).  The third
    output is the `LawForces.detail` of the system's own elements (for Yang-Menq the
    `ContactForces`; None without such elements)."""
    nc, nh = prob.c.size, prob.nh
    if prob.idx.shape[0] == 0 and not prob.laws:
        return np.zeros((nc, nh)), (np.zeros((nc * nh, nc * nh)) if jacobian else None), None
    Qc = np.asarray(Qc, dtype=float)
    contact = prob.system.contact if contact is None else contact
    kept = prob.evaluated.get(contact, Qc, jacobian)
    if kept is None:
        kept = _contact_blocks(prob, Qc, contact, jacobian)
        prob.evaluated.put(contact, Qc, kept)
    G, Je, f = kept
    if not jacobian:
        return G, None, f
    return G, (Je if blocks else assemble(prob, Je)), f


def _contact_blocks(prob: HBMProblem, Qc, contact, jacobian):
    """(G (nc, nh), Jacobian blocks (E, m, m, nh, nh) at `slot_index` or None, detail)
    of `contact_terms`, evaluated."""
    G, Jes, f = np.zeros((prob.c.size, prob.nh)), [], None
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
    return G, (combine(Jes) if prob.laws else Jes[0]), f   # laws: padded as `slot_index`


def slot_weights(bt, bn, pairs) -> np.ndarray:
    """(E, m m, P) weights of the slot pairs (a, b) of each element for the law's
    direction pairs, e.g. bt_a bt_b, bt_a bn_b, bn_a bn_b (`contact_terms`)."""
    return pair_weights((bt, bn), pairs)


# --------------------------------------------------------------------------
# residual, recovery, full-system check
# --------------------------------------------------------------------------

def residual(prob: HBMProblem, x, Om, contact: ContactElements | None = None, jacobian=True):
    """Condensed residual R(x, Om) [N] with x = Qc.ravel(); (R, dR/dx, dR/dOm).
    dR/dx is scipy.sparse for a full wheel (`HBMProblem.pattern`), else dense."""
    nh = prob.nh
    Qc = x.reshape(prob.c.size, nh)
    pat = prob.pattern
    St, dSt, Pt, dPt = linear_part(prob, Om, derivatives=jacobian,   # dSt applied to Qc
                                   motion=complex_harmonics(Qc) if jacobian else None,
                                   pattern=pat)
    L = pattern_matrix(pat, linear_values(St)) if pat is not None else real_blocks(St, nh)
    G, Jnl, _ = contact_terms(prob, Qc, contact, jacobian, blocks=jacobian)
    R = L @ x + G.ravel() - real_vector(Pt, nh).ravel()
    if not jacobian:
        return R, None, None
    dR_dOm = real_vector(dSt - dPt, nh).ravel()
    blocks = Jnl if Jnl.ndim == 5 else None     # 2-D zeros without elements
    if pat is not None:
        return R, (L if blocks is None else with_contacts(pat, L, blocks)), dR_dOm
    return R, (L if blocks is None else assemble(prob, blocks, out=L)), dR_dOm


def recover(prob: HBMProblem, Qc, Om):
    """All DOFs' coefficients Q (n, nh) from the contact DOFs' Qc (nc, nh)."""
    return dyn.recover(prob.linear, Qc, Om)


def full_residual(prob: HBMProblem, Q, Om, contact: ContactElements | None = None):
    """Residual of all n (2H+1) equations [N] (no condensation): every point's convergence check."""
    sys = prob.system
    D = derivative_matrix(prob.H)
    lin = dyn.apply_full(sys.K, sys.C, sys.M, Q, Om, D, prob.linear.extra)
    lin = lin + dyn.apply_coupling(sys, Q, Om, D)
    G, _, _ = contact_terms(prob, Q[prob.c], contact, jacobian=False)
    R = np.asarray(lin) - prob.P
    R[prob.c] += G
    return R


def force_scale(prob: HBMProblem, contact: ContactElements | None = None) -> float:
    """Reference force [N] for tolerances: |P| + sum |n0_e| |Bn_e| (never 0), the
    elements of further laws with a normal direction included.

    A preload counts only where it loads the structure (through Bn); the Jenkins
    normal load of a kv = 0 element with Bn = 0 merely limits friction.
    """
    elem = contact if contact is not None else prob.system.contact
    bn = np.linalg.norm(prob.bn, axis=1) if prob.bn.size else np.zeros(0)
    s = float(np.linalg.norm(prob.P)) + float(np.sum(np.abs(elem.n0) * bn)) + law_preloads(prob)
    return s if s > 0 else 1.0


def law_preloads(prob: HBMProblem) -> float:
    """sum |n0_e| |B_normal,e| [N] of the further laws with a normal direction and a
    preload (the 2D friction law's): their share of the static force scale."""
    s = 0.0
    for slots in prob.laws:
        if "normal" in slots.law.directions and hasattr(slots.law, "n0"):
            b = slots.b[slots.law.directions.index("normal")]
            s += float(np.sum(np.abs(slots.law.n0) * np.linalg.norm(b, axis=1)))
    return s


def tolerances(prob: HBMProblem, tol_rel: float, contact: ContactElements | None = None):
    """Residual tolerances [N] of the static (h = 0) and the harmonic (h >= 1) equations.

    static:  tol_rel * (|P_0| + sum |n0_e| |Bn_e| + |P_h>=1|)   (all laws' elements)
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
    s = (float(np.linalg.norm(prob.P[:, 0])) + float(np.sum(np.abs(elem.n0) * bn)) + d
         + law_preloads(prob))
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
