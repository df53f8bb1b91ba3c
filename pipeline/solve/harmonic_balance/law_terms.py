"""The nonlinear force of the harmonic balance, law by law (`contact.laws`).

Every law's elements reach the condensed unknowns Qc (nc, 2H+1) through slots: slot a
of element e is the contact DOF idx[e, a] with the weight b_d[e, a] in direction d,
so that (cyclic sectors rotate Q_a by T(theta_a) first, `hbm`)

    X[e, d] = sum_a b_d[e, a] Q_{idx[e, a]},     G_{idx[e, a]} += sum_d b_d[e, a] F[e, d],
    dG_a/dQ_b = sum_p w_p[e, a, b] J_p[e],   w_p = b_d[e, a] b_d'[e, b], (d, d') = pairs[p],

the back-projection being the transpose of the motion map (action = reaction) and
the Jacobian exact.  The Yang-Menq contact of a `System` (Bt, Bn) is the first set;
`System.laws` adds further `LawElements`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ...fourier.harmonics import shift_tables


@dataclass(frozen=True)
class LawSlots:
    """One law's elements on the condensed unknowns: idx (E, m) positions in c,
    b (D arrays (E, m)) direction weights, weights (E, m m, P) slot-pair weights;
    rot: (cos, sin) tables (2, E, m, 2H+1) of each slot's time shift on a cyclic sector
    (the next sector's slots shifted by its phase), or None."""

    law: object
    idx: np.ndarray
    b: tuple
    weights: np.ndarray
    rot: object = None
    stacked: np.ndarray | None = field(default=None, repr=False, compare=False)
    next_sector: np.ndarray | None = field(default=None, repr=False, compare=False)  # (E, m) bool

    @property
    def directions(self) -> np.ndarray:
        """(E, D, m) weights b_d[e, a] (`stacked` if given): X[e] = directions[e] @ Q[idx[e]]."""
        return self.stacked if self.stacked is not None else stacked_weights(self.b)


def stacked_weights(b) -> np.ndarray:
    """(E, D, m) the direction weights b (D arrays (E, m)) as one array (read-only: it is
    kept with the problem)."""
    out = np.ascontiguousarray(np.stack(b, axis=1), dtype=float)
    out.setflags(write=False)
    return out


def pair_weights(b, pairs) -> np.ndarray:
    """(E, m m, P) weights b_d[e, a] b_d'[e, b] of the slot pairs (a, b) for each
    direction pair (d, d') of `pairs`."""
    E, m = b[0].shape
    return np.stack([b[d][:, :, None] * b[k][:, None, :] for d, k in pairs],
                    axis=-1).reshape(E, m * m, len(pairs))


def direction_rows(maps) -> list:
    """Per element: (DOF columns where any direction's map is nonzero, ascending;
    (D, k) values of each map there)."""
    P = sp.csr_matrix(sum(abs(sp.csr_matrix(B, dtype=float)) for B in maps))
    P.eliminate_zeros()
    P.sort_indices()
    rows = np.repeat(np.arange(P.shape[0]), np.diff(P.indptr))
    vals = np.stack([np.asarray(sp.csr_matrix(B, dtype=float)[rows, P.indices]).ravel()
                     for B in maps])
    return [(P.indices[a:b], vals[:, a:b]) for a, b in zip(P.indptr[:-1], P.indptr[1:])]


def law_columns(elements) -> np.ndarray:
    """DOFs touched by the elements of one `LawElements` (own and next sector's)."""
    rows = [r for maps in (elements.maps, elements.maps_next) if maps
            for r, _ in direction_rows(maps)]
    return np.concatenate(rows) if rows else np.zeros(0, int)


def law_slots(elements, c, phase: float | None = None, H: int | None = None) -> LawSlots:
    """`LawSlots` of one `LawElements` on the contact DOFs c (ascending); on a cyclic
    sector (`phase` [rad], H) its next-sector maps add slots shifted by the phase."""
    parts = [(direction_rows(elements.maps), 0.0)]
    if elements.maps_next:
        parts.append((direction_rows(elements.maps_next), float(phase)))
    D, E = len(elements.maps), len(parts[0][0])
    m = max([sum(rows[e][0].size for rows, _ in parts) for e in range(E)] + [1])
    idx = np.zeros((E, m), int)
    b = np.zeros((D, E, m))
    shift, nxt = np.zeros((E, m)), np.zeros((E, m), bool)
    for e in range(E):
        k = 0
        for p, (rows, th) in enumerate(parts):
            r, v = rows[e]
            idx[e, k:k + r.size] = np.searchsorted(c, r)
            b[:, e, k:k + r.size] = v
            shift[e, k:k + r.size], nxt[e, k:k + r.size] = th, p == 1
            k += r.size
    b = tuple(np.ascontiguousarray(x) for x in b)
    rot = np.stack(shift_tables(shift, H)) if elements.maps_next else None
    return LawSlots(elements.law, idx, b, pair_weights(b, elements.law.pairs), rot,
                    stacked_weights(b), nxt)


def slot_index(slots, attr: str = "idx") -> np.ndarray:
    """(E_all, m_all) positions in c of the element slots of all laws, padded with
    slot 0 (zero weight): the layout of the Jacobian blocks of `combine`; with
    attr="next_sector", whether each slot is a DOF of the next sector (padded False)."""
    m = max(s.idx.shape[1] for s in slots)
    return np.concatenate([np.pad(getattr(s, attr), ((0, 0), (0, m - s.idx.shape[1])))
                           for s in slots])


def motion(slots: LawSlots, Qc, rot=None, turn=None) -> np.ndarray:
    """X (E, D, 2H+1) of the law's elements from Qc (nc, 2H+1); `rot` (cos, sin) of
    each slot's time shift applied by `turn` first (cyclic sectors)."""
    Qe = Qc[slots.idx]
    if rot is not None:
        Qe = turn(Qe, rot[0], rot[1])
    return slots.directions @ Qe


def projected(slots: LawSlots, F) -> np.ndarray:
    """(E, m, 2H+1): sum_d b_d[e, a] F[e, d], each slot's share of the force."""
    return np.swapaxes(slots.directions, 1, 2) @ F


def element_jacobian(slots: LawSlots, J) -> np.ndarray:
    """(E, m, m, nh, nh) slot-pair blocks from the law's J (E, P, nh, nh): one batched
    product of the pair weights with the derivative blocks."""
    E, P, nh = J.shape[0], J.shape[1], J.shape[-1]
    m = slots.idx.shape[1]
    return (slots.weights @ J.reshape(E, P, nh * nh)).reshape(E, m, m, nh, nh)


def combine(blocks) -> np.ndarray:
    """Slot-pair blocks of several laws (E_k, m_k, m_k, nh, nh) in the layout of
    `slot_index` (zero padded)."""
    m = max(J.shape[1] for J in blocks)
    pad = [((0, 0), (0, m - J.shape[1]), (0, m - J.shape[1]), (0, 0), (0, 0)) for J in blocks]
    return np.concatenate([np.pad(J, p) for J, p in zip(blocks, pad)])


def assemble(prob, Je, out=None, idx=None):
    """Contact Jacobian (nc nh, nc nh) from per-element slot-pair blocks Je (E, m, m, nh, nh)
    at the slots `idx` (default: the problem's, `HBMProblem.slot_index`); added into
    `out` (nc nh, nc nh, C-contiguous) if given."""
    nc, nh = prob.c.size, prob.nh
    J = (np.zeros((nc, nh, nc, nh), dtype=Je.dtype) if out is None
         else out.reshape(nc, nh, nc, nh))
    ia, ib = prob.slot_pairs if idx is None else slot_pairs(idx)
    np.add.at(J, (ia, slice(None), ib), Je)
    return J.reshape(nc * nh, nc * nh)


def slot_pairs(idx) -> tuple:
    """(ia, ib) (E, m, m): the positions idx[e, a], idx[e, b] of every slot pair (a, b)
    of the slots idx (E, m), where `assemble` adds the blocks."""
    E, m = idx.shape
    return (np.broadcast_to(idx[:, :, None], (E, m, m)),
            np.broadcast_to(idx[:, None, :], (E, m, m)))
