"""The cyclic condition on a sector's cut faces, and the reduction of the cut faces.

A sector of N (blade and disk sector, `disk_sector`) has two cut faces: `cyclic_low`
and `cyclic_high`, the high face the low face turned by the pitch alpha = 2 pi / N
about the disk axis, node for node (`cut_pairing`).  In the wheel the high face of
sector j is the low face of sector j + 1, so in sector j's own frame

    u_high,j = R(alpha) u_low,j+1                  (R(alpha): `DiskPlacement.rotation`)

and the sector's DOFs without its high face, q_j, give all of its DOFs as

    u_j = A q_j + B q_j+1                         (`cut_maps`: A keeps, B turns)

The wheel's energy sum_j 1/2 u_j^T K u_j then gives each sector the stiffness
K_0 = A^T K A + B^T K B on its own DOFs and K_1 = A^T K B towards the next
(`cyclic_parts`; the same for M and C): the elastic force on sector j is
K_0 q_j + K_1 q_j+1 + K_1^T q_j-1, and a wave of inter-sector phase phi (nodal
diameter k: phi = 2 pi k / N) sees K_0 + e^{i phi} K_1 + e^{-i phi} K_1^T (Hermitian;
`wave_matrix`), the complex constraint u_high = e^{i phi} R u_low of cyclic symmetry
(e.g. Thomas, Int. J. Numer. Meth. Eng. 14, 1979).

Cut-face reduction (`interface_modes`): the low face's DOFs q_c are replaced by c
characteristic constraint modes (Castanier, Tan & Pierre, AIAA J. 39, 2001): the lowest
eigenvectors of the face's own block of (K_0, M_0), q_c = Phi_c eta.  With all of them
the model is the unreduced one; the error of fewer is shown converging in the tests.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from scipy.spatial import cKDTree

CUT_TOLERANCE = 1e-6   # pairing tolerance relative to the cut face's size [-]


def cut_pairing(points_low, points_high, placement, tol: float | None = None) -> np.ndarray:
    """high[k]: the index in `points_high` (m, 3) [m] of the point that is
    `points_low[k]` turned by the pitch about the disk axis (`placement`:
    `fe_model.DiskPlacement`).  ValueError in one line naming the farthest unmatched
    cut-face point and its distance when the faces do not map onto each other."""
    lo = np.asarray(points_low, float).reshape(-1, 3)
    hi = np.asarray(points_high, float).reshape(-1, 3)
    if not len(lo) or len(lo) != len(hi):
        raise ValueError(f"cut faces do not pair: cyclic_low has {len(lo)} free points, "
                         f"cyclic_high {len(hi)}")
    size = float(np.ptp(np.vstack([lo, hi]), axis=0).max())
    tol = CUT_TOLERANCE * size if tol is None else float(tol)
    image = placement.rotate(lo, placement.pitch_angle)
    dist, high = cKDTree(hi).query(image)
    k = int(np.argmax(dist))
    if dist[k] > tol or np.unique(high).size != high.size:
        raise ValueError(
            f"cut faces do not pair: cyclic_low point {k} at ({lo[k, 0]:.6g}, {lo[k, 1]:.6g}, "
            f"{lo[k, 2]:.6g}) m turned by 2 pi / {placement.sectors} is {dist[k]:.3g} m from "
            f"the nearest cyclic_high point (tolerance {tol:.3g} m)")
    return high


def cut_maps(n: int, low, high, rotation) -> tuple:
    """(A, B, keep): sparse (n, n') maps u = A q_j + B q_j+1 (module doc) over n DOFs,
    `low`, `high` (k, 3) the DOF indices of paired cut-face points (row k of each;
    `cut_pairing`), `rotation` R(alpha) (3, 3); keep (n',): the DOFs q_j keeps (all
    but the high face's), ascending."""
    low, high = np.asarray(low, np.int64), np.asarray(high, np.int64)
    keep = np.setdiff1d(np.arange(n), high.ravel())
    pos = -np.ones(n, dtype=np.int64)
    pos[keep] = np.arange(keep.size)
    A = sp.csr_matrix((np.ones(keep.size), (keep, np.arange(keep.size))), shape=(n, keep.size))
    rows = np.repeat(high, 3, axis=1).ravel()            # (k, c, d) -> u_high[k, c]
    cols = pos[np.tile(low, (1, 3))].ravel()             # u_low[k, d]
    vals = np.tile(np.asarray(rotation, float).ravel(), len(low))
    B = sp.csr_matrix((vals, (rows, cols)), shape=(n, keep.size))
    B.eliminate_zeros()
    return A, B, keep


def cyclic_parts(X, A, B) -> tuple:
    """(X_0, X_1) = (A^T X A + B^T X B, A^T X B) of a sector matrix X (K, M or C, dense
    or sparse), as X is (module doc)."""
    if sp.issparse(X):
        X = sp.csr_matrix(X)
        return (A.T @ X @ A + B.T @ X @ B).tocsr(), (A.T @ X @ B).tocsr()
    At, Bt = A.T.toarray(), B.T.toarray()
    X = np.asarray(X)
    XA, XB = X @ A.toarray(), X @ B.toarray()
    return At @ XA + Bt @ XB, At @ XB


def wave_matrix(X0, X1, angle: float):
    """X_0 + e^{i angle} X_1 + e^{-i angle} X_1^T: the matrix a wave of inter-sector
    phase `angle` [rad] sees (real at 0 and pi)."""
    z = np.exp(1j * angle)
    out = X0 + z * X1 + np.conj(z) * X1.T
    if abs(z.imag) < 1e-15:
        return out.real
    return out


INTERFACE_ANGLES = (0.0, np.pi / 2, np.pi)   # the phases whose cut-face modes span the basis


def interface_basis(K0, K1, M0, M1, face, physical, count: int,
                    angles=INTERFACE_ANGLES) -> np.ndarray:
    """Phi (m, r) [-]: an orthonormal basis of the cut face's m DOFs `face` (positions in
    q_j), r <= 4 `count`: at each inter-sector phase of `angles` the sector's wave
    matrices (`wave_matrix`) statically condensed onto the face from the DOFs
    `physical` (Guyan; the modal coordinates stay out), and of that condensed problem
    the `count` lowest eigenvectors, their real and imaginary parts (characteristic
    constraint modes, Castanier, Tan & Pierre, AIAA J. 39, 2001, taken per phase: the
    face of a low nodal diameter bends with the disk, that of a high one does not),
    orthonormalised (SVD, directions below 1e-10 of the largest dropped)."""
    face = np.asarray(face, np.int64).ravel()
    if not 0 < count <= face.size:
        raise ValueError(f"cut_face_modes must be in [1, {face.size}] (the cut face's DOFs), "
                         f"got {count!r}")
    other = np.setdiff1d(np.asarray(physical, np.int64), face)
    vectors = []
    for angle in angles:
        K, M = wave_matrix(K0, K1, angle), wave_matrix(M0, M1, angle)
        G = np.zeros((K.shape[0], face.size), dtype=K.dtype)
        G[face, np.arange(face.size)] = 1.0
        if other.size:
            G[other] = -la.solve(K[np.ix_(other, other)], K[np.ix_(other, face)], assume_a="her")
        _, X = la.eigh(G.conj().T @ K @ G, G.conj().T @ M @ G, subset_by_index=[0, count - 1])
        vectors += [X.real] + ([X.imag] if np.iscomplexobj(X) else [])
    U, s, _ = la.svd(np.hstack(vectors), full_matrices=False)
    return U[:, s > 1e-10 * s[0]]


def interface_transform(n: int, face, Phi) -> np.ndarray:
    """T (n, n - m + r): q_j = T q'_j keeps every DOF but the face's m DOFs `face`, in
    their order, and puts the face's r amplitudes on the basis Phi (m, r) last."""
    face = np.asarray(face, np.int64).ravel()
    rest = np.setdiff1d(np.arange(n), face)
    T = np.zeros((n, rest.size + Phi.shape[1]))
    T[rest, np.arange(rest.size)] = 1.0
    T[face, rest.size:] = Phi
    return T


@dataclass(frozen=True, eq=False)
class CutSector:
    """A reduced sector with its cut faces joined to its neighbours' (module doc):
    the sector's reduced coordinates r_j = T_own q_j + T_next q_j+1; (K, M, C)_0 on its
    own coordinates q_j and (K, M, C)_1 towards the next (dense) [N/m], [kg], [N s/m];
    `names` one per coordinate of q_j; `interface` the cut face's basis size (None: its
    DOFs kept)."""

    K0: np.ndarray
    K1: np.ndarray
    M0: np.ndarray
    M1: np.ndarray
    C0: np.ndarray
    C1: np.ndarray
    T_own: np.ndarray
    T_next: np.ndarray
    names: tuple
    interface: int | None = None

    def coordinates(self, q, angle: float = 0.0):
        """The sector's reduced coordinates r (n_r, ...) of q (n', ...) on a wave of
        inter-sector phase `angle` [rad] (the next sector's q is e^{i angle} q)."""
        q = np.asarray(q)
        z = np.exp(1j * angle) if angle else 1.0     # real coordinates stay real at 0
        return self.T_own @ q + z * (self.T_next @ q)


def cut_sector(K, M, C, low, high, n_physical: int, rotation, names, count=None) -> CutSector:
    """The `CutSector` of reduced matrices K, M, C (n_r, n_r) whose coordinates hold the
    cut faces' DOFs `low`, `high` (k, 3) (paired row by row, `cut_pairing`), the first
    `n_physical` coordinates physical (a Craig-Bampton model's boundary); `rotation`
    R(alpha) (3, 3); `names` (n_r,); `count`: cut-face modes per phase
    (`interface_basis`), None to keep the face's DOFs."""
    n = K.shape[0]
    A, B, keep = cut_maps(n, low, high, rotation)
    (K0, K1), (M0, M1), (C0, C1) = (cyclic_parts(X, A, B) for X in (K, M, C))
    kept = tuple(names[i] for i in keep)
    T = np.eye(keep.size)
    if count is not None:
        face = np.searchsorted(keep, np.asarray(low).ravel())
        Phi = interface_basis(K0, K1, M0, M1, face, np.nonzero(keep < n_physical)[0], count)
        T = interface_transform(keep.size, face, Phi)
        rest = np.setdiff1d(np.arange(keep.size), face)
        kept = tuple(kept[i] for i in rest) + tuple(f"cut.{k}" for k in range(Phi.shape[1]))
    own = [(T.T @ X @ T + (T.T @ X @ T).T) / 2 for X in (K0, M0, C0)]
    nxt = [T.T @ X @ T for X in (K1, M1, C1)]
    return CutSector(own[0], nxt[0], own[1], nxt[1], own[2], nxt[2], A @ T, B @ T, kept,
                     None if count is None else T.shape[1] - (keep.size - np.asarray(low).size))
