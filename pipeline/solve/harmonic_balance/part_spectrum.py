"""Natural frequencies of a structure of independent parts (a full wheel on a rigid
disk) near a frequency, without a dense eigen-solve of the whole structure.

`resonance` needs, at a branch point and for an excited harmonic h, the number of
natural frequencies of the linearised structure below h Omega and the few natural
frequencies (with their damping) nearest h Omega.  With the structure split as in
`parts` (interior DOFs o of independent parts k, contact DOFs c), A = K + Herm(Z_h)
(Z_h on the contact DOFs only) and D(s) = A - s M, the inertia is additive over
the Schur complement (Haynsworth), which is Wittrick & Williams' (1971) count:

    #{eigenvalues of (A, M) below s} = sum_k #{eigenvalues of (K_oo,k, M_oo,k) below s}
                                       + #{negative eigenvalues of S(s)},
    S(s) = D_cc - sum_k D_c,o_k D_o_k o_k^-1 D_o_k,c           (Hermitian, nc x nc)

The parts' clamped spectra are solved once per structure (small dense blocks); S
costs one batched solve over the parts and one Hermitian eigen-solve on the contact
DOFs.  The frequencies nearest h Omega come from a sparse shift-invert Lanczos
solve of (A, M) about (h Omega)^2; the count at h Omega numbers them.  Their damping
ratio is the first-order modal value zeta_k = phi_k^H C phi_k / (2 w_k) of the
undamped mode phi_k (phi_k^H M phi_k = 1): the structure's own damping; friction
and impact add to it.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .parts import PartBlocks
from .ring import negative_eigenvalues as ring_negatives


@dataclass(frozen=True, eq=False)
class PartSpectra:
    """What the count and the windows need of a structure of parts, built once."""

    pb: PartBlocks
    clamped: np.ndarray   # sorted eigenvalues s = w^2 of every part's interior [rad^2/s^2]
    K: object             # (n, n) scipy.sparse CSC stiffness [N/m]
    M: object             # (n, n) mass [kg]
    C: object             # (n, n) damping [N s/m]
    c: np.ndarray         # contact DOFs (positions of the contact stiffness Z)


def part_spectra(system, pb: PartBlocks, c) -> PartSpectra:
    """The parts' clamped spectra (one dense generalized eigen-solve per part)."""
    Koo, Moo = pb.oo[0], pb.oo[1]
    clamped = np.sort(np.concatenate([sla.eigh(K, M, eigvals_only=True)
                                      for K, M in zip(Koo, Moo)]))
    K, M, C = (sp.csc_matrix(A, dtype=float) for A in (system.K, system.M, system.C))
    return PartSpectra(pb, clamped, K, M, C, np.asarray(c))


def count_below(ps: PartSpectra, Zh, s: float) -> int:
    """Number of eigenvalues of (K + Herm Zh, M) below s [rad^2/s^2] (module doc).
    With Zh sparse (a wheel), S is assembled sparse and its inertia taken over its
    ring of blades (`ring.negative_eigenvalues`) where it has one."""
    pb = ps.pb
    Doo, Doc, Dco = (K - s * M for K, M, *_ in (pb.oo, pb.oc, pb.co))
    X = np.linalg.solve(Doo, Doc)                                   # (P, m, k)
    rows = np.broadcast_to(pb.ck[:, :, None], X.shape[:1] + (pb.ck.shape[1],) * 2)
    cols = np.broadcast_to(pb.ck[:, None, :], rows.shape)
    if sp.issparse(Zh) and pb.cc_nz:
        nc = Zh.shape[0]
        S = sp.csr_matrix((np.concatenate([pb.ccv[0] - s * pb.ccv[1], -(Dco @ X).ravel()]),
                           (np.concatenate([pb.cc_nz[0], rows.ravel()]),
                            np.concatenate([pb.cc_nz[1], cols.ravel()]))), shape=(nc, nc))
        S = S.astype(complex) + 0.5 * (Zh + Zh.conj().T)
        S = (0.5 * (S + S.conj().T)).tocsr()
        below = ring_negatives(S, negative_eigenvalues)
        return int(np.searchsorted(ps.clamped, s)) + (
            negative_eigenvalues(S.toarray()) if below is None else below)
    S = (pb.cc[0] - s * pb.cc[1]).astype(complex) + 0.5 * (Zh + Zh.conj().T)
    np.add.at(S, (rows, cols), -(Dco @ X))
    S = 0.5 * (S + S.conj().T)
    return int(np.searchsorted(ps.clamped, s)) + negative_eigenvalues(S)


@lru_cache(maxsize=64)
def factorisation(hermitian: bool, n: int) -> tuple:
    """(LAPACK ?hetrf or ?sytrf, its optimal workspace for n rows): blocked, 3x faster
    at 600 rows."""
    name = "hetrf" if hermitian else "sytrf"
    trf, query = sla.get_lapack_funcs((name, name + "_lwork"),
                                      dtype=np.complex128 if hermitian else np.float64)
    return trf, max(1, int(np.real(query(n, lower=1)[0])))


def negative_eigenvalues(D) -> int:
    """The number of negative eigenvalues of a Hermitian (or real symmetric) matrix D
    by Sylvester's law of inertia: those of the block-diagonal B of D = L B L^H
    (LAPACK ?hetrf / ?sytrf, Bunch-Kaufman pivoting, blocked with its optimal
    workspace: 0.46 ms against 2.0 ms for the eigenvalues of a complex 144 x 144,
    1.4-7x faster than scipy.linalg.ldl from 144 to 600 rows).  B has 1x1 blocks b and
    2x2 blocks [[a, e], [conj e, c]]: a 1x1 block counts if b < 0; a 2x2 block has one
    negative eigenvalue if its determinant ac - |e|^2 < 0, else two if a + c < 0, else
    none."""
    D = np.asarray(D)
    D = D.real if not np.iscomplexobj(D) or not D.imag.any() else D
    if D.shape == (1, 1):    # its own factor
        return int(D[0, 0].real < 0)
    dtype = np.complex128 if np.iscomplexobj(D) else np.float64
    trf, lwork = factorisation(dtype == np.complex128, D.shape[0])
    lu, piv, info = trf(np.array(D, dtype=dtype, order="F"), lower=1, lwork=lwork)
    if info < 0:
        raise ValueError(f"?hetrf/?sytrf: illegal argument {-info}")
    d = np.real(np.diagonal(lu))
    two = np.flatnonzero(piv < 0)      # the two rows of each 2x2 block, top to bottom
    k = two[0::2]
    if two.size % 2 or np.any(two[1::2] != k + 1):
        raise ValueError("?hetrf/?sytrf: unexpected pivot blocks")
    one = np.ones(d.size, bool)
    one[two] = False
    a, c, e = d[k], d[k + 1], np.abs(lu[k + 1, k])
    s = np.maximum(np.maximum(np.abs(a), np.abs(c)), e)   # scaled: no overflow, no underflow
    s = np.where(s > 0, s, 1.0)
    det, trace = (a / s) * (c / s) - (e / s) ** 2, a + c
    return (int(np.sum(d[one] < 0)) + int(np.sum(det < 0))
            + 2 * int(np.sum((det > 0) & (trace < 0)))
            + int(np.sum((det == 0) & (trace < 0))))   # a singular block: its other one


def linearised_stiffness(ps: PartSpectra, Zh):
    """K + Herm Zh as a sparse CSC matrix [N/m] (Zh (nc, nc) on the contact DOFs)."""
    Zs = sp.coo_matrix(0.5 * (Zh + Zh.conj().T))
    n = ps.K.shape[0]
    Zf = sp.coo_matrix((Zs.data, (ps.c[Zs.row], ps.c[Zs.col])), shape=(n, n))
    return (ps.K + Zf).tocsc()


def nearest(ps: PartSpectra, A, s: float, k: int) -> tuple:
    """The k eigenvalues of (A, M) nearest s, ascending, as natural frequencies
    sign(lam) sqrt|lam| [rad/s], and their first-order damping ratios [-]."""
    n = A.shape[0]
    if k >= n - 1:
        lam, phi = sla.eigh(A.toarray(), ps.M.toarray())
    else:
        lam, phi = spla.eigsh(A, k=k, M=ps.M, sigma=s, which="LM")
        order = np.argsort(lam)
        lam, phi = lam[order], phi[:, order]
    phi = phi / np.sqrt(np.real(np.einsum("ik,ik->k", phi.conj(), ps.M @ phi)))
    w = np.sign(lam) * np.sqrt(np.abs(lam))
    damp = np.real(np.einsum("ik,ik->k", phi.conj(), ps.C @ phi))
    zeta = np.where(w > 0, damp / (2.0 * np.where(w > 0, w, 1.0)), 1.0)
    return w, zeta


class PartSpectrum:
    """The natural frequencies of one linearised structure (one point, one harmonic)
    near a reference frequency w_ref [rad/s]: `count(w)`, the number below w, and
    `mode(k)`, (w_k [rad/s], zeta_k [-]) of the k-th (from 0), both computed on
    demand and kept (a memo of one point, not shared data)."""

    def __init__(self, ps: PartSpectra, Zh, w_ref: float):
        self.ps, self.Zh, self.w_ref = ps, Zh, float(w_ref)
        self.counts = {}
        self.window = (0, np.zeros(0), np.zeros(0))   # (offset, w, zeta)

    def count(self, w: float) -> int:
        w = float(w)
        if w not in self.counts:
            self.counts[w] = count_below(self.ps, self.Zh, w * abs(w))
        return self.counts[w]

    def mode(self, k: int) -> tuple:
        offset, w, zeta = self.window
        want = 8
        while not offset <= k < offset + w.size:
            want = max(want, 2 * abs(k - self.count(self.w_ref)) + 4)
            n = self.ps.K.shape[0]
            w, zeta = nearest(self.ps, linearised_stiffness(self.ps, self.Zh),
                              self.w_ref ** 2, min(want, n))
            below = int(np.sum(w < self.w_ref))
            offset = 0 if w.size == n else self.count(self.w_ref) - below
            self.window = (offset, w, zeta)
            if want >= n:
                break
            want *= 2
        return float(w[k - offset]), float(zeta[k - offset])
