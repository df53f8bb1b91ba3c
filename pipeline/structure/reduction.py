"""Craig-Bampton reduction that keeps the boundary (shroud contact) DOFs physical.

Partition the free DOFs u = [u_b; u_i] (b: contact faces + excitation + response,
i: interior, root already clamped).  With

    Psi = -K_ii^{-1} K_ib                      (static constraint modes)
    K_ii Phi = M_ii Phi Lambda,  Phi^T M_ii Phi = I   (fixed-interface normal modes)
    u = T q,  T = [[I, 0], [Psi, Phi]],  q = [u_b; eta]

the reduced matrices are

    K_r = blkdiag(K_bb + K_bi Psi, Lambda)
    M_r = T^T M T:  M_bb^r = M_bb + M_bi Psi + Psi^T M_ib + Psi^T M_ii Psi,
                    M_bm^r = (M_bi + Psi^T M_ii) Phi,   M_mm^r = I.

K_ii is factorised ONCE (SuperLU, symmetric ordering, diagonal pivots: P K_ii P^T =
L D L^T) and the factor is reused as OPinv = K_ii^{-1} of the shift-invert Lanczos
(`eigsh`, sigma = 0) and, split into dense supernode blocks of L (`supernodal`),
for the constraint modes, hundreds of right-hand sides per pass.  Everything on the
full model stays sparse; only the n_i x n_b block Psi and the n_i x m block Phi are
dense; Psi^T M_ii Psi is formed by column chunks, upper block triangle only.

Damping: modal ratios zeta_k on the reduced modes (K_r X = M_r X W^2,
X^T M_r X = I):  C_r = M_r X diag(2 zeta_k w_k) X^T M_r;  or Rayleigh
C_r = alpha M_r + beta K_r, the exact projection of alpha M + beta K.
Reduced eigenfrequencies are Rayleigh-Ritz upper bounds of the full ones.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from .fe_model import boundary_dofs
from .supernodal import solve_into, supernodes

log = logging.getLogger(__name__)

DEFAULT_MODES = 40


@dataclass(frozen=True, eq=False)
class ReducedModel:
    """Craig-Bampton model, q = [u_b (n_b physical DOFs); eta (n_m modal coordinates)].

    M, K, C: dense (n_r, n_r) [kg], [N/m], [N s/m].  boundary (n_b,) and interior
    (n_i,) index the full free-DOF vector; Psi (n_i, n_b), Phi (n_i, n_m) are the
    interior rows of T (`T` assembles the full matrix on request).  labels: one per
    reduced coordinate.  frequencies: eigenfrequencies of (K, M) [Hz];
    fixed_frequencies: those of the fixed-interface modes [Hz].  sets: named
    boundary sets as positions in q (e.g. "shroud_left" -> (k, 3)).  info: timings
    [s] and sizes.
    """

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    Psi: np.ndarray
    Phi: np.ndarray
    boundary: np.ndarray
    interior: np.ndarray
    labels: tuple
    frequencies: np.ndarray
    fixed_frequencies: np.ndarray
    sets: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    @property
    def n_boundary(self) -> int:
        return self.boundary.size

    @property
    def n_modes(self) -> int:
        return self.Phi.shape[1]

    @property
    def n_full(self) -> int:
        return self.boundary.size + self.interior.size

    @property
    def T(self) -> np.ndarray:
        """Dense (n_full, n_r) transformation u = T q (rows in the full DOF order)."""
        T = np.zeros((self.n_full, self.M.shape[0]))
        T[self.boundary, np.arange(self.n_boundary)] = 1.0
        T[self.interior, :self.n_boundary] = self.Psi
        T[self.interior, self.n_boundary:] = self.Phi
        return T


def _check_square(name, A, n=None):
    if A.ndim != 2 or A.shape[0] != A.shape[1] or (n is not None and A.shape[0] != n):
        raise ValueError(f"{name} must be square ({n or 'n'} x {n or 'n'}), got {A.shape}")


def factorize(A):
    """SuperLU of a symmetric positive definite sparse matrix (symmetric ordering,
    diagonal pivots: no fill from pivoting)."""
    return sla.splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                    options={"SymmetricMode": True})


def start_vector(n: int) -> np.ndarray:
    """The fixed ARPACK start vector of length n (seeded normal draws): repeatable
    eigen solutions, and generic enough to have a part along every eigenvector."""
    return np.random.default_rng(0).standard_normal(n)


def eigenmodes(K, M, k: int, lu=None):
    """Lowest k eigenpairs of K x = w^2 M x (shift-invert about 0, OPinv = K^-1 from
    `lu`, factorised here if None): (omega^2 ascending, X with X^T M X = I)."""
    n = K.shape[0]
    if k >= n - 1:  # ARPACK needs k < n - 1: dense fallback for tiny problems
        w, X = la.eigh(K.toarray() if sp.issparse(K) else K, M.toarray() if sp.issparse(M) else M)
        return w[:k], X[:, :k]
    lu = lu or factorize(K)
    op = sla.LinearOperator((n, n), matvec=lu.solve, dtype=float)
    # a fixed start vector: the same model gives the same modes (signs included) on
    # every run; ARPACK would otherwise draw a random one
    w, X = sla.eigsh(K, k, M, sigma=0.0, which="LM", OPinv=op, v0=start_vector(n))
    order = np.argsort(w)
    w, X = w[order], X[:, order]
    X /= np.sqrt(np.einsum("ij,ij->j", X, M @ X))
    return w, X


def _damping(Kr, Mr, damping_ratios, rayleigh):
    w2, X = la.eigh(Kr, Mr)
    w = np.sqrt(np.maximum(w2, 0.0))
    if rayleigh is not None:
        alpha, beta = rayleigh
        return alpha * Mr + beta * Kr, w
    z = np.asarray(damping_ratios, dtype=float)
    zeta = np.concatenate([z, np.full(max(0, w.size - z.size), z[-1])])[:w.size]
    MX = Mr @ X
    return (MX * (2 * zeta * w)) @ MX.T, w


def _constraint_modes(lu, Kib, block):
    """Static constraint modes Psi = -K_ii^{-1} K_ib (dense n_i x n_b) from the factor
    `lu` of K_ii, by supernode blocks of its L (`supernodal`), about `block`
    right-hand sides per pass (equal column chunks)."""
    F = supernodes(lu)
    nb = Kib.shape[1]
    Psi = np.empty((Kib.shape[0], nb))
    for j in np.array_split(np.arange(nb), -(-nb // block)):
        j = slice(j[0], j[-1] + 1)
        solve_into(F, -Kib[:, j], Psi[:, j])
    return Psi


def _psi_m_psi(Mii, Psi, block):
    """Psi^T M_ii Psi (n_b x n_b) without an n_i x n_b temporary: M_ii Psi about
    `block` columns at a time, each chunk multiplied only into the upper block
    triangle, the lower one mirrored."""
    nb = Psi.shape[1]
    G = np.zeros((nb, nb))
    for j in np.array_split(np.arange(nb), -(-nb // block)):
        j0, j1 = j[0], j[-1] + 1
        G[:j1, j0:j1] = Psi[:, :j1].T @ (Mii @ Psi[:, j0:j1])
    return np.triu(G) + np.triu(G, 1).T


def _project(Kbb, Mbb, Kib, Mib, Mii, Psi, Phi, w2, block):
    """Dense reduced (K_r, M_r) = T^T (K, M) T of u = T q, T = [[I, 0], [Psi, Phi]]
    (module doc), from the partitioned blocks, the fixed-interface eigenvalues w2
    and modes Phi (M_ii-normalised); boundary blocks symmetrised."""
    nb = Psi.shape[1]
    Kr_bb = Kbb + Kib.T @ Psi
    MibPsi = Mib.T @ Psi
    Mr_bb = Mbb + MibPsi + MibPsi.T + _psi_m_psi(Mii, Psi, block)
    Mr_bm = (Mib.T @ Phi) + Psi.T @ (Mii @ Phi)
    nr = nb + Phi.shape[1]
    Kr, Mr = np.zeros((nr, nr)), np.zeros((nr, nr))
    Kr[:nb, :nb] = (Kr_bb + Kr_bb.T) / 2
    Kr[nb:, nb:] = np.diag(w2)
    Mr[:nb, :nb] = (Mr_bb + Mr_bb.T) / 2
    Mr[:nb, nb:] = Mr_bm
    Mr[nb:, :nb] = Mr_bm.T
    Mr[nb:, nb:] = np.eye(Phi.shape[1])
    return Kr, Mr


def reduce(K, M, boundary, n_modes: int = DEFAULT_MODES, *, damping_ratios=(0.0,),
           rayleigh=None, labels=None, block: int = 512) -> ReducedModel:
    """Craig-Bampton reduction of (K, M) keeping the DOFs `boundary` (module doc).

    K, M: sparse symmetric (n, n), positive definite K (clamped structure).
    boundary: indices of the kept physical DOFs (order kept, no duplicates).
    n_modes: fixed-interface normal modes (0 = Guyan).  damping_ratios: modal
    ratios (last repeats), or rayleigh = (alpha, beta).  block: constraint modes
    are solved, and multiplied by M_ii, about `block` columns at a time (memory).
    """
    K, M = sp.csr_matrix(K), sp.csr_matrix(M)
    _check_square("K", K)
    n = K.shape[0]
    _check_square("M", M, n)
    b = np.asarray(boundary, dtype=np.int64).ravel()
    if b.size == 0 or b.min() < 0 or b.max() >= n:
        raise ValueError(f"boundary must be non-empty indices in [0, {n}), got {b.size} "
                         f"indices in [{b.min() if b.size else '-'}, "
                         f"{b.max() if b.size else '-'}]")
    if np.unique(b).size != b.size:
        raise ValueError("boundary has duplicate indices")
    if int(n_modes) != n_modes or n_modes < 0 or n_modes > n - b.size:
        raise ValueError(f"n_modes must be an integer in [0, {n - b.size}], got {n_modes!r}")
    if labels is not None and len(labels) != b.size:
        raise ValueError(f"labels has {len(labels)} entries, expected {b.size} (boundary)")
    if rayleigh is not None and len(rayleigh) != 2:
        raise ValueError(f"rayleigh must be (alpha, beta), got {rayleigh!r}")
    mask = np.ones(n, dtype=bool)
    mask[b] = False
    i = np.nonzero(mask)[0]
    nb = b.size
    times = {}

    t0 = time.perf_counter()
    Kii = K[i][:, i]
    Mii = M[i][:, i]
    Kib, Mib = K[i][:, b].tocsc(), M[i][:, b].tocsc()
    Kbb, Mbb = K[b][:, b].toarray(), M[b][:, b].toarray()
    times["partition"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    lu = factorize(Kii)
    times["factorize"] = time.perf_counter() - t0
    log.debug("K_ii: n=%d, nnz(L+U)=%d", i.size, lu.L.nnz + lu.U.nnz)

    t0 = time.perf_counter()
    w2, Phi = eigenmodes(Kii, Mii, int(n_modes), lu) if n_modes else (np.zeros(0), np.zeros((i.size, 0)))
    times["normal_modes"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    Psi = _constraint_modes(lu, Kib, block)
    times["constraint_modes"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    Kr, Mr = _project(Kbb, Mbb, Kib, Mib, Mii, Psi, Phi, w2, block)
    times["projection"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    Cr, w = _damping(Kr, Mr, damping_ratios, rayleigh)
    times["damping"] = time.perf_counter() - t0
    labels = tuple(labels) if labels is not None else tuple(f"dof:{d}" for d in b)
    labels += tuple(f"mode:{k + 1}" for k in range(Phi.shape[1]))
    info = {"n_full": n, "n_boundary": nb, "n_modes": Phi.shape[1],
            "nnz_LU": int(lu.L.nnz + lu.U.nnz), "times": times}
    log.info("Craig-Bampton: %d DOFs -> %d boundary + %d modes (%.2f s)", n, nb,
             Phi.shape[1], sum(times.values()))
    return ReducedModel(Mr, Kr, Cr, Psi, Phi, b, i, labels, w / (2 * np.pi),
                        np.sqrt(np.maximum(w2, 0)) / (2 * np.pi), {}, info)


def reduce_blade(blade, n_modes: int = DEFAULT_MODES, names=None, **kw) -> ReducedModel:
    """Reduce a `fe_model.BladeModel`, keeping its contact faces, excitation and
    response DOFs (or the sets `names`); modal damping from its parameters.
    `sets` of the result give each set's positions in q, shaped like the blade's."""
    b, labels = boundary_dofs(blade, names)
    kw.setdefault("damping_ratios", blade.params.damping_ratios)
    red = reduce(blade.K, blade.M, b, n_modes, labels=labels, **kw)
    pos = -np.ones(blade.n_dof, dtype=np.int64)
    pos[b] = np.arange(b.size)
    sets = {k: pos[v] for k, v in blade.dof_sets.items() if np.all(pos[v] >= 0)}
    return replace(red, sets=sets)


def reconstruct(model: ReducedModel, q: np.ndarray) -> np.ndarray:
    """Full free-DOF field u = T q for q (n_r,) or (n_r, k), real or complex."""
    q = np.asarray(q)
    nr = model.M.shape[0]
    if q.shape[0] != nr:
        raise ValueError(f"q must have {nr} rows (reduced coordinates), got {q.shape}")
    nb = model.n_boundary
    u = np.zeros((model.n_full,) + q.shape[1:], dtype=np.result_type(q, float))
    u[model.boundary] = q[:nb]
    u[model.interior] = model.Psi @ q[:nb] + model.Phi @ q[nb:]
    return u


def reduce_map(model: ReducedModel, B) -> np.ndarray:
    """B T for a map B (E, n_full) that touches only boundary DOFs (e.g. the Bt, Bn of
    contact faces): the same rows over the reduced coordinates, dense (E, n_r)."""
    B = sp.csr_matrix(B)
    if B.shape[1] != model.n_full:
        raise ValueError(f"B must have {model.n_full} columns, got {B.shape}")
    if abs(B[:, model.interior]).sum() > 0:
        raise ValueError("B touches interior DOFs: keep them in the boundary set")
    out = np.zeros((B.shape[0], model.M.shape[0]))
    out[:, :model.n_boundary] = B[:, model.boundary].toarray()
    return out


def reduced_modes(model: ReducedModel, k: int):
    """Lowest k modes of the reduced model: (frequencies [Hz], full-field shapes (n, k))."""
    w2, X = la.eigh(model.K, model.M, subset_by_index=[0, k - 1])
    return np.sqrt(np.maximum(w2, 0)) / (2 * np.pi), reconstruct(model, X)


def frf(K, M, C, inputs, outputs, omegas) -> np.ndarray:
    """Receptance H[w, o, j] = [(K - w^2 M + i w C)^{-1}]_{outputs[o], inputs[j]} [m/N]
    for sparse or dense matrices (C may be None)."""
    inputs, outputs = np.atleast_1d(inputs), np.atleast_1d(outputs)
    n = K.shape[0]
    out = np.empty((len(omegas), outputs.size, inputs.size), dtype=complex)
    F = np.zeros((n, inputs.size))
    F[inputs, np.arange(inputs.size)] = 1.0
    for k, w in enumerate(omegas):
        D = K - w**2 * M + (1j * w * C if C is not None else 0)
        if sp.issparse(D):
            x = sla.splu(sp.csc_matrix(D)).solve(F.astype(complex))
        else:
            x = la.solve(D, F, assume_a="sym")
        out[k] = x[outputs]
    return out


def modal_convergence(blade_params, mode_counts, n_freqs: int = 10) -> dict:
    """Full vs Craig-Bampton eigenfrequencies of a blade for several mode counts.

    Returns plain numpy arrays: mode_counts (m,), full_hz (n_freqs,), reduced_hz
    (m, n_freqs), rel_error (m, n_freqs) = reduced/full - 1, time_full_s (scalar
    array), time_reduce_s (m,), n_dof, n_boundary.
    """
    from .blades import build_blade  # deferred: scikit-fem and meshio (slow imports)

    counts = np.asarray(mode_counts, dtype=int)
    if counts.ndim != 1 or counts.size == 0 or np.any(counts < 0):
        raise ValueError(f"mode_counts must be a non-empty list of integers >= 0, got "
                         f"{mode_counts!r}")
    blade = build_blade(blade_params)
    t0 = time.perf_counter()
    w2, _ = eigenmodes(blade.K, blade.M, n_freqs)
    t_full = time.perf_counter() - t0
    full = np.sqrt(w2) / (2 * np.pi)
    b, _ = boundary_dofs(blade)
    red, times = [], []
    for m in counts:
        t0 = time.perf_counter()
        r = reduce(blade.K, blade.M, b, int(m))
        times.append(time.perf_counter() - t0)
        red.append(r.frequencies[:n_freqs])
    red = np.array(red)
    return {"mode_counts": counts, "full_hz": full, "reduced_hz": red,
            "rel_error": red / full - 1, "time_full_s": np.asarray(t_full),
            "time_reduce_s": np.array(times), "n_dof": np.asarray(blade.n_dof),
            "n_boundary": np.asarray(b.size)}
