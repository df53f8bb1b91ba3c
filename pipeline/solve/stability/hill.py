"""Hill's method: Floquet exponents of a harmonic-balance solution.

The HBM unknowns Q (n, 2H+1) are flattened row-major (index dof*(2H+1) + c) in the
real layout of `harmonics.py`; the residual is

    R(Q) = (K x I + Om C x D + Om^2 M x D^2) Q + F_nl(Q) - P,   D = derivative_matrix(H)

and J = dR/dQ.  A perturbation y(t) = exp(lam t) p(tau), tau = Om t, of the periodic
solution gives the quadratic eigenproblem (Hill)

    [J + lam Delta1 + lam^2 Delta2] P = 0,
    Delta1 = C x I + 2 Om M x D,   Delta2 = M x I,

linearised here as  [[0, I], [-J, -Delta1]] z = lam [[I, 0], [0, Delta2]] z,
z = [P; lam P]  (size 2N, N = n(2H+1)).

Selection.  Each Floquet exponent appears 2H+1 times, shifted by i k Om, with the
eigenvector shifted by k harmonics.  We keep the exponents whose eigenvectors are
centred on harmonic 0 (`select="centroid"`, default; Lazarus & Thomas 2010): the
weight of complex harmonic k in P is |P_k|^2 (P_{+-j} = (Pc_j -+ i Ps_j)/2), its
centroid  m = sum k |P_k|^2 / sum |P_k|^2, and the count with the smallest |m| is
kept (count = 2n for a regular M; finite eigenvalues / (2H+1) for a singular M).
The copy centred on harmonic 0 is the best resolved one; it is also right when an
eigenfrequency exceeds Om/2, where `select="imag"` (smallest |Im lam|, the
classical rule) returns a shifted, truncated copy.  Both rules are ambiguous when
two families cross (lam1 - lam2 ~ i k Om, e.g. an undamped system at 2 omega = k Om);
where the crossing families share their real parts (copies of one linear system) the
stability verdict is unaffected, otherwise it may be (below).

Time-invariant Jacobians.  Where every contact is stuck or open over the whole
period, the rows of the harmonics h >= 1 of J commute with the time shift, as those
of K'' x I + Om C x D + Om^2 M x D^2 do; the static rows (K' on harmonic 0) may
couple to the others.  The Hill matrix is then block triangular: the eigenvectors
of its harmonic-0 block, the state matrix [[0, I], [-M^-1 K', -M^-1 C]], lie on
harmonic 0 alone (centroid 0), those of each harmonic k >= 1 are centred off 0.
The selected exponents are the 2n eigenvalues of that state matrix, which the dense
solver computes (2n x 2n) instead of the Hill matrix's (2N x 2N) (`time_invariant`).
Where a copy of another family crosses them (undamped: lam_k + i k Om = lam_0) the whole
matrix mixes their eigenvectors, its centroids are ambiguous and its selection may
drop an exponent of harmonic 0; the state matrix's are exact there too.

Solvers:
    "dense"   M regular: standard eigenproblem with Delta2^-1 (numpy.linalg.eig),
              O((2N)^3), fine up to N ~ 1500 (2N = 3000: ~30 s).
    "qz"      M singular (massless DOFs): generalized QZ (scipy.linalg.eig(A, B));
              infinite eigenvalues are dropped.  Same cost, about 3x slower.
    "auto"    "dense" if cond(M) < 1e10, else "qz".
    "sparse"  large problems: k eigenvalues nearest `sigma` (default 0) by
              shift-invert Arnoldi on (A - sigma B)^-1 B with one sparse LU; J may be
              scipy.sparse; M may be singular.  Only the exponents among those k with
              |centroid| < 0.5 are returned, so the verdict is reliable only if k
              covers every eigenvalue within |lam - sigma| <= |Re lam_crit| + Om/2;
              heavily damped or high-frequency modes are not computed (they do not
              decide stability of a damped forced response).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ...fourier.harmonics import derivative_matrix
from ...structure.reduction import start_vector

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class HillResult:
    """Selected Floquet exponents and everything they were selected from.

    exponents (m,)          selected, sorted by decreasing real part
    eigenvalues (K,)        all finite Hill eigenvalues computed
    centroid (K,)           harmonic centroid of each eigenvector
    selected (m,)           indices of `exponents` in `eigenvalues`
    vectors (N, K)          P-part of the eigenvectors (only with return_vectors)
    """

    exponents: np.ndarray
    eigenvalues: np.ndarray
    centroid: np.ndarray
    selected: np.ndarray
    solver: str
    vectors: np.ndarray | None = field(default=None, repr=False)


def hill_matrices(M, C, Omega, H):
    """(Delta1, Delta2) of the Hill quadratic eigenproblem, dense (N, N)."""
    I = np.eye(2 * H + 1)
    D = derivative_matrix(H)
    return np.kron(C, I) + 2 * Omega * np.kron(M, D), np.kron(M, I)


def companion(J, M, C, Omega, H):
    """[[0, I], [-Delta2^-1 J, -Delta2^-1 Delta1]] (2N, 2N) for a regular M, built
    without Kronecker products: Delta2^-1 = M^-1 (x) I acts on the DOF index only, and
    Delta2^-1 Delta1 = (M^-1 C) (x) I + 2 Om I_n (x) D."""
    n, nh = M.shape[0], 2 * H + 1
    N = n * nh
    Minv, top, low0, low1 = _companion_parts(M, C, H)
    A = np.empty((2 * N, 2 * N))
    A[:N] = top
    A[N:, :N] = -(Minv @ J.reshape(n, nh * N)).reshape(N, N)
    np.multiply(Omega, low1, out=A[N:, N:])
    A[N:, N:] += low0
    return A


_PARTS = {}   # `_companion_parts` by (M, C, H), the last few kept
KEEP_BYTES = 2**21   # [B] parts of one companion kept at most (N <= 256; larger: eig dominates)


def _companion_parts(M, C, H):
    """(M^-1, [0, I], -(M^-1 C) (x) I, -2 I_n (x) D) of `companion`: what does not
    change along a branch (M, C and H fixed), computed once for each (M, C, H) where
    they take at most KEEP_BYTES (8 kept: at most 16 MB); larger ones each time."""
    M, C = np.ascontiguousarray(M, dtype=float), np.ascontiguousarray(C, dtype=float)
    n, nh = M.shape[0], 2 * H + 1
    N = n * nh
    keep = 32 * N * N <= KEEP_BYTES
    key = (M.shape, M.tobytes(), C.tobytes(), H) if keep else None
    parts = _PARTS.get(key) if keep else None
    if parts is not None:
        return parts
    try:
        Minv = np.linalg.inv(M)
    except np.linalg.LinAlgError:
        raise ValueError("M is singular: use solver='qz' or 'sparse'") from None
    top = np.zeros((N, 2 * N))
    top[:, N:] = np.eye(N)
    low0, low1 = np.zeros((n, nh, n, nh)), np.zeros((n, nh, n, nh))
    k, i = np.arange(nh), np.arange(n)
    low0[:, k, :, k] = -(Minv @ C)          # -(M^-1 C) (x) I: diagonal in the harmonic
    low1[i, :, i, :] = -2.0 * derivative_matrix(H)   # -2 I_n (x) D, times Om
    parts = (Minv, top, low0.reshape(N, N), low1.reshape(N, N))
    for a in parts:
        a.flags.writeable = False
    if keep:
        for old in list(_PARTS)[:-7]:   # the oldest dropped (a list: safe beside other threads)
            _PARTS.pop(old, None)
        _PARTS[key] = parts
    return parts


def time_invariant(J, n, H, rtol=1e-13):
    """K' (n, n), the static block of J (n (2H+1) square), if the rows of the harmonics
    h >= 1 commute with the time shift (to rtol max|J|): no coupling to harmonic 0
    nor between harmonics, and within harmonic h the form [[A, B], [-B, A]] of one
    complex matrix (cos, sin rows and columns), as for K x I + Om C x D + Om^2 M x D^2;
    else None.  The static rows may couple to every harmonic (a stuck slider's rest
    position moves with the motion): the Hill matrix is block triangular, its
    harmonic-0 block's eigenvectors lie on harmonic 0 alone (module doc)."""
    nh = 2 * H + 1
    J4 = J.reshape(n, nh, n, nh)
    tol = rtol * np.max(np.abs(J), initial=0.0)
    if H == 0:
        return J4[:, 0, :, 0]
    if np.max(np.abs(J4[:, 1, :, 3:]), initial=0.0) > tol:   # harmonic 1 coupled to others
        return None
    B = J4[:, 1:, :, 1:].reshape(n, H, 2, n, H, 2)     # (dof, h, cos/sin, dof, h', cos/sin)
    h = np.arange(H)
    d = B[:, h, :, :, h]                               # (h, dof, 2, dof, 2): same harmonic
    off = B.copy()
    off[:, h, :, :, h] = 0.0
    dev = max(np.max(np.abs(J4[:, 1:, :, 0])), np.max(np.abs(off)),
              np.max(np.abs(d[..., 0, :, 0] - d[..., 1, :, 1])),
              np.max(np.abs(d[..., 0, :, 1] + d[..., 1, :, 0])))
    return J4[:, 0, :, 0] if dev <= tol else None


def harmonic_centroid(P, n, H):
    """Centroid sum k|P_k|^2 / sum |P_k|^2 of the complex harmonics of columns of P (N, K)."""
    P = np.asarray(P).reshape(n, 2 * H + 1, -1)
    # |P_+j|^2 - |P_-j|^2 = -Im(Pc_j conj(Ps_j)),  |P_+j|^2 + |P_-j|^2 = (|Pc_j|^2 + |Ps_j|^2) / 2
    a2 = np.abs(P) ** 2
    c, s = P[:, 1::2], P[:, 2::2]
    moment = -np.arange(1, H + 1) @ (c * s.conj()).imag.sum(axis=0)
    total = a2[:, 0].sum(axis=0) + 0.5 * a2[:, 1:].sum(axis=(0, 1))
    return moment / np.where(total > 0, total, 1.0)


def _validate(J, M, C, Omega, H):
    if isinstance(H, bool) or int(H) != H or H < 0:
        raise ValueError(f"H must be a non-negative integer, got {H!r}")
    H = int(H)
    if not (np.isfinite(Omega) and Omega > 0):
        raise ValueError(f"Omega must be a positive finite number, got {Omega!r}")
    M = np.atleast_2d(np.asarray(M, dtype=float))
    C = np.atleast_2d(np.asarray(C, dtype=float))
    n = M.shape[0]
    if M.shape != (n, n):
        raise ValueError(f"M must be square, got shape {M.shape}")
    if C.shape != (n, n):
        raise ValueError(f"C must have the shape of M {M.shape}, got {C.shape}")
    N = n * (2 * H + 1)
    if getattr(J, "shape", None) != (N, N):
        raise ValueError(f"J must have shape (n_dof*(2H+1),)*2 = ({N}, {N}), "
                         f"got {getattr(J, 'shape', None)}")
    return M, C, float(Omega), H, n, N


def _condition(M) -> float:
    """cond(M); a diagonal M's from its diagonal (no SVD); computed once for each M of
    at most KEEP_BYTES (8 kept)."""
    key = (M.shape, M.tobytes()) if M.nbytes <= KEEP_BYTES else None
    value = _CONDITION.get(key) if key is not None else None
    if value is None:
        d = np.diag(M)
        if np.count_nonzero(M - np.diag(d)) == 0:
            a = np.abs(d)
            value = float(a.max() / a.min()) if a.min() > 0 else np.inf
        else:
            value = float(np.linalg.cond(M))
        if key is not None:
            for old in list(_CONDITION)[:-7]:   # the oldest dropped (a list: safe beside threads)
                _CONDITION.pop(old, None)
            _CONDITION[key] = value
    return value


_CONDITION = {}   # `_condition` by M, the last few kept


def _select(lam, cen, count, select):
    if select == "centroid":
        key = np.lexsort((np.abs(lam.imag), np.round(np.abs(cen), 8)))
    else:
        key = np.lexsort((np.abs(cen), np.round(np.abs(lam.imag), 12)))
    return key[:count]


def hill_eigenvalues(J, M, C, Omega, H, *, select="centroid", solver="auto", k=None,
                     sigma=0.0, full_output=False, return_vectors=False):
    """Floquet exponents of an HBM solution by Hill's method (see module docstring).

    Returns the selected exponents (sorted by decreasing real part), or a HillResult
    if `full_output`.
    """
    M, C, Omega, H, n, N = _validate(J, M, C, Omega, H)
    if select not in ("centroid", "imag"):
        raise ValueError(f"select must be 'centroid' or 'imag', got {select!r}")
    if solver not in ("auto", "dense", "qz", "sparse"):
        raise ValueError(f"solver must be 'auto', 'dense', 'qz' or 'sparse', got {solver!r}")
    nh = 2 * H + 1
    if solver == "auto":
        solver = "dense" if _condition(M) < 1e10 else "qz"

    if solver == "sparse":
        lam, P = _sparse_eigs(J, M, C, Omega, H, n, N, k, sigma)
        cen = harmonic_centroid(P, n, H)
        sel = np.nonzero(np.abs(cen) < 0.5)[0] if select == "centroid" else \
            np.nonzero(np.abs(lam.imag) <= Omega / 2 * (1 + 1e-12))[0]
    else:
        Jd = J.toarray() if sp.issparse(J) else np.asarray(J, dtype=float)
        K0 = (time_invariant(Jd, n, H) if solver == "dense" and select == "centroid"
              and not (full_output or return_vectors) else None)
        if K0 is not None:   # the 2n exponents of the state matrix (module doc; H = 0 there)
            lam = np.linalg.eigvals(companion(K0, M, C, Omega, 0))
            return lam[np.argsort(-lam.real, kind="stable")]
        if solver == "dense":
            lam, Z = np.linalg.eig(companion(Jd, M, C, Omega, H))
        else:
            D1, D2 = hill_matrices(M, C, Omega, H)
            A = np.block([[np.zeros((N, N)), np.eye(N)], [-Jd, -D1]])
            B = sla.block_diag(np.eye(N), D2)
            a, b = np.linalg.norm(A, 1), np.linalg.norm(B, 1)
            (alpha, beta), Z = sla.eig(A / a, B / b, homogeneous_eigvals=True)
            # infinite eigenvalues (massless DOFs): beta ~ rounding of the normalised pencil
            ok = np.abs(beta) > 1e-10 * np.hypot(np.abs(alpha), np.abs(beta))
            lam, Z = (alpha[ok] / beta[ok]) * (a / b), Z[:, ok]
        P = Z[:N]
        cen = harmonic_centroid(P, n, H)
        count = 2 * n if solver == "dense" else int(round(lam.size / nh))
        sel = _select(lam, cen, count, select)
    order = np.argsort(-lam[sel].real, kind="stable")
    sel = sel[order]
    if not full_output:
        return lam[sel]
    return HillResult(exponents=lam[sel], eigenvalues=lam, centroid=cen, selected=sel,
                      solver=solver, vectors=P if return_vectors else None)


def _sparse_eigs(J, M, C, Omega, H, n, N, k, sigma):
    nh = 2 * H + 1
    I = sp.identity(nh, format="csr")
    D = sp.csr_matrix(derivative_matrix(H))
    D1 = sp.kron(sp.csr_matrix(C), I) + 2 * Omega * sp.kron(sp.csr_matrix(M), D)
    D2 = sp.kron(sp.csr_matrix(M), I)
    IN = sp.identity(N, format="csr")
    A = sp.bmat([[None, IN], [-sp.csr_matrix(J), -D1]], format="csc")
    B = sp.bmat([[IN, None], [None, D2]], format="csc")
    k = min(int(k) if k is not None else 4 * 2 * n + 8, 2 * N - 2)
    if k < 1:
        raise ValueError(f"k must be >= 1 and < 2N - 1 = {2 * N - 1}, got {k}")
    lu = spla.splu((A - sigma * B).astype(complex if np.iscomplex(sigma) else float).tocsc())
    op = spla.LinearOperator((2 * N, 2 * N), matvec=lambda v: lu.solve(B @ v),
                             dtype=complex if np.iscomplex(sigma) else float)
    v0 = start_vector(2 * N).astype(op.dtype)  # repeatable, as the reduction's modes
    mu, Z = spla.eigs(op, k=k, which="LM", v0=v0)
    # infinite eigenvalues (singular M) map to mu = 0: drop them at rounding level
    ok = np.abs(mu) > 1e-11 * np.abs(mu).max()
    return sigma + 1.0 / mu[ok], Z[:N, ok]


def is_stable(J, M, C, Omega, H, *, rtol=1e-9, **hill_kwargs):
    """(stable, max_real, exponents): asymptotically stable iff max Re lam <= rtol * max|lam|.

    The small relative margin keeps undamped or marginal cases from flipping on
    rounding; pass rtol=0 for a strict test.  Keyword arguments go to
    `hill_eigenvalues`.
    """
    if not (np.isfinite(rtol) and rtol >= 0):
        raise ValueError(f"rtol must be a non-negative finite number, got {rtol!r}")
    hill_kwargs.pop("full_output", None)
    lam = hill_eigenvalues(J, M, C, Omega, H, **hill_kwargs)
    if lam.size == 0:
        return True, -np.inf, lam
    max_real = float(lam.real.max())
    return bool(max_real <= rtol * np.abs(lam).max()), max_real, lam
