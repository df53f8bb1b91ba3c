"""Structures made of independent parts, such as a full wheel on a rigid disk: the
condensation and the harmonic balance Jacobian that keep their block structure.

With the disk rigid, a blade's interior DOFs couple only to its own contact DOFs:
S_oo is block-diagonal and the condensation (paper Eq. 7, condensed as in `hbm`)

    S~ = S_cc - sum_k S_{c,o_k} S_{o_k o_k}^-1 S_{o_k,c}

is a sum of small dense terms, one per part k (`part_blocks`, the connected
components of the structure's pattern over the interior DOFs, gathered once per
problem; `condense_parts`, all parts in one batched solve per harmonic): O(N) work
for N blades instead of the O(N^3) of one dense S_co S_oo^-1 S_oc.  The contacts couple
neighbouring parts, so the condensed Jacobian is block-cyclic and mostly zero:
`sparse_jacobian` decides when to build it sparse (`real_blocks_sparse`,
`assemble_sparse`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components


@dataclass(frozen=True, eq=False)
class PartBlocks:
    """The dense blocks of P equal-sized independent parts (module doc), gathered once:
    interior DOFs o (P, m) and their contact DOFs (positions in c) ck (P, k); K, M, C
    over (o, o) (P, m, m), (o, c) (P, m, k), (c, o) (P, k, m); and K, M, C over the
    contact DOFs (nc, nc), dense."""

    o: np.ndarray    # (P, m) interior DOFs of each part
    ck: np.ndarray   # (P, k) its contact DOFs, positions in c
    oo: tuple        # (Koo, Moo, Coo)
    oc: tuple
    co: tuple
    cc: tuple


def part_blocks(system, c, o) -> PartBlocks | None:
    """The `PartBlocks` of a structure whose interior DOFs o fall into several
    connected components (the pattern of |K| + |M| + |C|) of equal size, each coupled
    to the same number of contact DOFs; None otherwise (one component, unequal parts,
    dense matrices)."""
    if not sp.issparse(system.K) or o.size == 0:
        return None
    mats = [sp.csr_matrix(A, dtype=float) for A in (system.K, system.M, system.C)]
    A = (abs(mats[0]) + abs(mats[1]) + abs(mats[2])).tocsr()
    n_parts, label = connected_components(A[o][:, o], directed=False)
    if n_parts < 2:
        return None
    Aco = A[c][:, o].tocsc()
    ok = [np.flatnonzero(label == k) for k in range(n_parts)]
    ck = [np.unique(Aco[:, i].tocoo().row) for i in ok]
    if len({i.size for i in ok}) > 1 or len({i.size for i in ck}) > 1:
        return None
    oo, ck = o[np.array(ok)], np.array(ck)
    cg = c[ck]

    def gather(B, rows, cols):
        return np.stack([B[r][:, q].toarray() for r, q in zip(rows, cols)])

    return PartBlocks(o=oo, ck=ck, oo=tuple(gather(B, oo, oo) for B in mats),
                      oc=tuple(gather(B, oo, cg) for B in mats),
                      co=tuple(gather(B, cg, oo) for B in mats),
                      cc=tuple(B[c][:, c].toarray() for B in mats))


def condense_parts(pb: PartBlocks, h: int, Om: float, P, c, derivatives: bool):
    """(S~, dS~, P~, dP~) of harmonic h part by part, all parts in batched dense
    solves: S = K - (h Om)^2 M + i h Om C per block, P (n,) the load [N]."""
    w = h * Om

    def S(K, M, C):
        return K - w * w * M + 1j * w * C

    def dS(K, M, C):
        return -2 * h * w * M + 1j * h * C

    Soo, Soc, Sco = S(*pb.oo), S(*pb.oc), S(*pb.co)
    Po = P[pb.o]                                              # (parts, m)
    sol = np.linalg.solve(Soo, np.concatenate([Soc, Po[..., None]], axis=2))
    X, z = sol[..., :-1], sol[..., -1]
    St = S(*pb.cc).astype(complex)
    Pt = P[c].astype(complex)
    rows = np.broadcast_to(pb.ck[:, :, None], X.shape[:1] + (pb.ck.shape[1],) * 2)
    cols = np.broadcast_to(pb.ck[:, None, :], rows.shape)
    np.add.at(St, (rows, cols), -(Sco @ X))
    np.add.at(Pt, pb.ck, -(Sco @ z[..., None])[..., 0])
    if not derivatives:
        return St, None, Pt, None
    dSoo, dSoc, dSco = dS(*pb.oo), dS(*pb.oc), dS(*pb.co)
    Y = np.linalg.solve(np.swapaxes(Soo, 1, 2), np.swapaxes(Sco, 1, 2)).swapaxes(1, 2)
    dSt = dS(*pb.cc).astype(complex)
    np.add.at(dSt, (rows, cols), -(dSco @ X + Y @ dSoc - Y @ (dSoo @ X)))
    dPt = np.zeros(c.size, complex)
    np.add.at(dPt, pb.ck, (-(dSco @ z[..., None]) + Y @ (dSoo @ z[..., None]))[..., 0])
    return St, dSt, Pt, dPt


SPARSE_JACOBIAN_MIN = 500    # condensed unknowns from which a sparse Jacobian pays (measured)
SPARSE_JACOBIAN_FILL = 0.25    # ... when at most this fraction of S~_h is nonzero


def sparse_jacobian(prob, St) -> bool:
    """True for a large problem whose condensed dynamic stiffness is mostly zero: a
    full wheel (each blade's contact DOFs condense onto their own blade only, so the
    Jacobian is block-cyclic), then built and factorised sparse."""
    nc = prob.c.size
    return (sp.issparse(prob.system.K) and prob.size >= SPARSE_JACOBIAN_MIN
            and np.count_nonzero(St[-1]) <= SPARSE_JACOBIAN_FILL * nc * nc)


def real_blocks_sparse(St, nh):
    """`real_blocks` as a scipy.sparse CSR matrix, from the nonzeros of St[h]."""
    nc = St[0].shape[0]
    rows, cols, vals = [], [], []
    for h, S in enumerate(St):
        i, j = np.nonzero(S)
        A, B = S.real[i, j], S.imag[i, j]
        if h == 0:
            rows.append(i * nh), cols.append(j * nh), vals.append(A)
            continue
        ci, si = 2 * h - 1, 2 * h
        for r, c, v in ((ci, ci, A), (ci, si, B), (si, ci, -B), (si, si, A)):
            rows.append(i * nh + r), cols.append(j * nh + c), vals.append(v)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(nc * nh, nc * nh))


def assemble_sparse(prob, Je):
    """`assemble` as a scipy.sparse CSR matrix (duplicate entries summed)."""
    nc, nh = prob.c.size, prob.nh
    k = np.arange(nh)
    rows = prob.idx[:, :, None, None, None] * nh + k[:, None]
    cols = prob.idx[:, None, :, None, None] * nh + k
    rows, cols = np.broadcast_arrays(rows, cols, Je)[:2]
    return sp.csr_matrix((Je.ravel(), (rows.ravel(), cols.ravel())), shape=(nc * nh, nc * nh))
