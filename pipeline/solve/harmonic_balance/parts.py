"""Structures made of independent parts, such as a full wheel on a rigid disk: the
condensation and the harmonic balance Jacobian that keep their block structure.

With the disk rigid, a blade's interior DOFs couple only to its own contact DOFs:
S_oo is block-diagonal and the condensation (paper Eq. 7, condensed as in `hbm`)

    S~ = S_cc - sum_k S_{c,o_k} S_{o_k o_k}^-1 S_{o_k,c}

is a sum of small dense terms, one per part k (`part_blocks`, the connected
components of the structure's pattern over the interior DOFs, gathered once per
problem; `dynamic_stiffness.condense_parts`, all parts in one batched solve per
harmonic): O(N) work
for N blades instead of the O(N^3) of one dense S_co S_oo^-1 S_oc.  The contacts couple
neighbouring parts, so the condensed Jacobian is block-cyclic and mostly zero:
`jacobian_pattern` decides once per problem whether to build it sparse and fixes its
CSR structure; `pattern_matrix` fills it per evaluation.
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
    contact DOFs (nc, nc), dense; then the same blocks of added terms' matrices A_t."""

    o: np.ndarray    # (P, m) interior DOFs of each part
    ck: np.ndarray   # (P, k) its contact DOFs, positions in c
    oo: tuple        # (Koo, Moo, Coo, *A_t_oo)
    oc: tuple
    co: tuple
    cc: tuple
    disjoint: bool = False   # no contact DOF belongs to two parts (ck without repeats)
    cc_nz: tuple = ()        # (rows, cols) where any cc matrix is nonzero
    ccv: tuple = ()          # the cc matrices' entries there (K, M, C, *A_t)
    symmetric: bool = False  # every matrix symmetric: S_oc = S_co^T, S_co S_oo^-1 = X^T


def part_blocks(system, c, o, extra=()) -> PartBlocks | None:
    """The `PartBlocks` of a structure whose interior DOFs o fall into several
    connected components (the pattern of |K| + |M| + |C| (+ |A_t|), the added terms'
    matrices `extra` gathered after C) of equal size, each coupled to the same number
    of contact DOFs; None otherwise (one component, unequal parts, dense matrices)."""
    if not sp.issparse(system.K) or o.size == 0:
        return None
    mats = [sp.csr_matrix(A, dtype=float) for A in (system.K, system.M, system.C, *extra)]
    A = (abs(mats[0]) + abs(mats[1]) + abs(mats[2])).tocsr()
    for B in mats[3:]:
        A = (A + abs(B)).tocsr()
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

    cc = tuple(B[c][:, c].toarray() for B in mats)
    nz = np.nonzero(sum(np.abs(B) for B in cc))
    blocks = {k: tuple(gather(B, r, q) for B in mats)
              for k, r, q in (("oo", oo, oo), ("oc", oo, cg), ("co", cg, oo))}
    sym = all(abs(B - B.T).max() <= 1e-13 * abs(B).max() for B in mats)
    return PartBlocks(o=oo, ck=ck, **blocks, cc=cc,
                      disjoint=bool(np.unique(ck).size == ck.size), cc_nz=nz,
                      ccv=tuple(B[nz] for B in cc), symmetric=sym)


SPARSE_JACOBIAN_MIN = 500    # condensed unknowns from which a sparse Jacobian pays (measured)
SPARSE_JACOBIAN_FILL = 0.25    # ... when at most this fraction of S~_h is nonzero


@dataclass(frozen=True, eq=False)
class JacobianPattern:
    """The CSR structure of the condensed HBM Jacobian of a structure of parts, fixed
    per problem: S~_h's nonzero pattern (pi, pj) (the contact DOFs' own couplings
    and one dense block per part, the same for every h) expanded to the real
    cos/sin layout of `hbm.real_blocks`, and the contact elements' blocks
    (E, m, m, nh, nh) of `hbm.contact_terms`.  `lin` and `nl` give the position in
    the CSR data of every linear and every contact entry (duplicates are summed),
    so a Jacobian is one np.bincount, no sort."""

    pi: np.ndarray        # (p,) rows of S~_h's pattern (positions in c)
    pj: np.ndarray        # (p,) its columns
    indptr: np.ndarray
    indices: np.ndarray
    lin: np.ndarray       # (p (2 nh - 1),) data positions of the linear entries
    nl: np.ndarray        # (E m m nh nh,) data positions of the contact entries
    size: int             # nc nh
    pairs: object = None  # (u, E m m) sparse: sums the elements' blocks per DOF pair
    pair_pos: np.ndarray | None = None   # (u nh nh,) data positions of those sums
    cc_pos: np.ndarray | None = None     # (q,) positions in (pi, pj) of PartBlocks.cc_nz
    part_pos: np.ndarray | None = None   # (P, k, k) positions of each part's ck x ck block


def linear_keys(pi, pj, nh):
    """Row and column of each real entry of S~_h's pattern, in `linear_values` order:
    h = 0 (cos 0), then per h >= 1 the blocks [[A, B], [-B, A]] of A + iB."""
    rows, cols = [pi * nh], [pj * nh]
    for h in range(1, (nh - 1) // 2 + 1):
        ci, si = 2 * h - 1, 2 * h
        for r, c in ((ci, ci), (ci, si), (si, ci), (si, si)):
            rows.append(pi * nh + r), cols.append(pj * nh + c)
    return np.concatenate(rows), np.concatenate(cols)


def jacobian_pattern(pb: PartBlocks, idx, nc: int, nh: int) -> JacobianPattern | None:
    """The pattern of a problem whose Jacobian pays to be sparse: at least
    SPARSE_JACOBIAN_MIN unknowns and at most SPARSE_JACOBIAN_FILL of S~_h nonzero;
    None otherwise (the dense path)."""
    mask = (np.abs(pb.cc[0]) + np.abs(pb.cc[1]) + np.abs(pb.cc[2])) != 0
    for B in pb.cc[3:]:
        mask |= B != 0
    mask[pb.ck[:, :, None], pb.ck[:, None, :]] = True
    size = nc * nh
    if size < SPARSE_JACOBIAN_MIN or mask.sum() > SPARSE_JACOBIAN_FILL * nc * nc:
        return None
    pi, pj = np.nonzero(mask)
    lr, lc = linear_keys(pi, pj, nh)
    k = np.arange(nh)
    nr = np.broadcast_to(idx[:, :, None, None, None] * nh + k[:, None], idx.shape
                         + (idx.shape[1], nh, nh))
    nr_c = np.broadcast_to(idx[:, None, :, None, None] * nh + k, nr.shape)
    keys = np.concatenate([lr * size + lc, (nr * size + nr_c).ravel()])
    uniq, inverse = np.unique(keys, return_inverse=True)
    # scipy keeps int32 indices where they fit, and checks wider ones on every matrix
    itype = np.int32 if uniq.size < 2 ** 31 else np.int64
    indptr = np.searchsorted(uniq // size, np.arange(size + 1)).astype(itype)
    # the elements' (a, b) DOF pairs, each summed once over the elements sharing it
    pk = (idx[:, :, None] * nc + idx[:, None, :]).ravel()
    up, inv = np.unique(pk, return_inverse=True)
    pairs = sp.csr_matrix((np.ones(pk.size), (inv, np.arange(pk.size))), shape=(up.size, pk.size))
    pr = (up // nc)[:, None, None] * nh + k[:, None]
    pc = (up % nc)[:, None, None] * nh + k
    pos = np.searchsorted(uniq, (pr * size + pc).ravel())
    at = pi * nc + pj    # (pi, pj) is in row-major order: sorted keys
    cc_pos = np.searchsorted(at, pb.cc_nz[0] * nc + pb.cc_nz[1])
    part_pos = np.searchsorted(at, pb.ck[:, :, None] * nc + pb.ck[:, None, :])
    return JacobianPattern(pi, pj, indptr, (uniq % size).astype(itype),
                           inverse[:lr.size], inverse[lr.size:], size, pairs, pos,
                           cc_pos, part_pos)


def linear_values(V):
    """The real entries of S~_h on the pattern, in `linear_keys` order, from its complex
    values V (H+1, p) there (`dynamic_stiffness.condense` with the pattern)."""
    out = [V[0].real]
    for v in V[1:]:
        out += [v.real, v.imag, -v.imag, v.real]
    return np.concatenate(out)


def pattern_matrix(pat: JacobianPattern, lin_values, Je=None):
    """CSR matrix (nc nh, nc nh) of the linear entries plus, with Je, the contact
    blocks (E, m, m, nh, nh) (duplicates summed)."""
    nnz = pat.indices.size
    data = np.bincount(pat.lin, weights=lin_values, minlength=nnz)
    if Je is not None:
        data += np.bincount(pat.nl, weights=np.ascontiguousarray(Je).ravel(), minlength=nnz)
    return _on_structure(pat, data)


def with_contacts(pat: JacobianPattern, L, Je):
    """The `pattern_matrix` L of the linear entries plus the contact blocks Je
    (E, m, m, nh, nh): L's data summed once, not again."""
    data = L.data.copy()
    nh = Je.shape[-1]
    data[pat.pair_pos] += (pat.pairs @ Je.reshape(-1, nh * nh)).ravel()
    return _on_structure(pat, data)


def _on_structure(pat: JacobianPattern, data):
    """The CSR matrix of `data` on the pattern's structure, flagged canonical (sorted,
    no repeats: built from np.unique), which scipy would otherwise scan for."""
    M = sp.csr_matrix((data, pat.indices, pat.indptr), shape=(pat.size, pat.size))
    M.has_canonical_format = True
    return M


def on_contact_dofs(pb: PartBlocks, cc_values, part_values):
    """(H+1, nc, nc) complex: the cc matrices' values at their nonzeros (H+1, q) plus
    each part's block (H+1, P, k, k) at its contact DOFs."""
    out = np.zeros((cc_values.shape[0],) + pb.cc[0].shape, complex)
    out[:, pb.cc_nz[0], pb.cc_nz[1]] = cc_values
    rows = np.broadcast_to(pb.ck[:, :, None], pb.ck.shape + pb.ck.shape[1:])
    (scatter_add if pb.disjoint else np.add.at)(out, (slice(None), rows, rows.swapaxes(1, 2)),
                                                part_values)
    return out


def on_parts(pb: PartBlocks, out, part_values):
    """out (H+1, nc) plus each part's vector (H+1, P, k) at its contact DOFs."""
    (scatter_add if pb.disjoint else np.add.at)(out, (slice(None), pb.ck), part_values)
    return out


def scatter_add(a, index, values):
    """np.add.at(a, index, values) for an index without repeated entries (parts that
    share no contact DOF): one gather and one scatter."""
    a[index] += values


def on_pattern(pb: PartBlocks, pat: JacobianPattern, cc_values, part_values):
    """(H+1, p) complex: S~_h on the pattern (pi, pj) from the cc matrices' values at
    their nonzeros (H+1, q) plus the parts' blocks (H+1, P, k, k), no dense S~_h."""
    out = np.zeros(cc_values.shape[:1] + pat.pi.shape, complex)
    out[:, pat.cc_pos] = cc_values
    (scatter_add if pb.disjoint else np.add.at)(out, (slice(None), pat.part_pos), part_values)
    return out


def applied(pb: PartBlocks, cc_values, part_values, motion):
    """(H+1, nc) complex: (dS~_h) motion[h] for dS~_h given as `on_pattern` takes it
    (cc values at their nonzeros, the parts' blocks), no dense matrix."""
    rows, cols = pb.cc_nz
    terms = cc_values * motion[:, cols]
    nc = motion.shape[1]
    out = np.array([np.bincount(rows, t.real, nc) + 1j * np.bincount(rows, t.imag, nc)
                    for t in terms])
    return on_parts(pb, out, (part_values @ motion[:, pb.ck][..., None])[..., 0])
