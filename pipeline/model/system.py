"""Plain data for a linear structure with Yang-Menq contacts (paper Eq. 4-6).

    M q'' + C q' + K q + Bt^T f_u(u, v) + Bn^T f_v(u, v) = F(t),
    u = Bt q,  v = Bn q   (relative tangential / normal displacement per element)

`Bt`, `Bn` (E, n) map the structure's DOFs to each element's relative motion: a row
[.., +1 (dof a), .., -1 (dof b), ..] is a pair of DOFs, a single +1 is a DOF against
ground, and rows of direction cosines give tilted contact frames.  The transposes
distribute the contact forces back, so action = reaction holds by construction.

The excitation is F(t) = Re sum_h F_h exp(i h Omega t) with `forcing[:, h] = F_h`
(column 0 is a real static load), so any DOF and any harmonic can be excited.

A System may be ONE SECTOR of a tuned cyclic structure (`cyclic`, see
`CyclicCoupling` and `pipeline.model.cyclic`): its elements then also act on the next
sector's DOFs, u = Bt q_j + Bt_next q_{j+1}, and the travelling wave
q_{j+1}(tau) = q_j(tau + phi), phi = 2 pi EO / N, closes the equations on one
sector (Petrov 2004).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..contact.laws import ContactElements


def dense(A) -> np.ndarray:
    """A as a float ndarray (a scipy.sparse matrix densified: (rows x columns) x 8 bytes).
    For the consumers that need a whole matrix (full eigen-solves, Hill's method, the
    event-driven integrator); the harmonic balance itself keeps sparse input sparse."""
    if sp.issparse(A):
        return A.toarray()
    A = np.asarray(A)
    return A if np.iscomplexobj(A) else A.astype(float, copy=False)


@dataclass(frozen=True)
class CyclicCoupling:
    """Contacts of a cyclic sector with the NEXT sector (tuned disk, N sectors).

    Element e of sector j has the relative motion

        u = Bt[e] q_j + Bt_next[e] q_{j+1},   v = Bn[e] q_j + Bn_next[e] q_{j+1},

    and the engine-order travelling wave is q_{j+1}(tau) = q_j(tau + phi),
    phi = 2 pi EO / N, i.e. Q_{j+1,h} = exp(i h phi) Q_{j,h} for every harmonic h
    (Petrov, J. Turbomach. 126, 2004).  `pipeline.model.cyclic` builds such sectors and
    their full N-sector assemblies.

    `K_next` is a LINEAR coupling to the neighbours (disk flexibility, e.g. springs
    between neighbouring disk masses): the elastic force on sector j is
    K q_j + K_next q_{j+1} + K_next^T q_{j-1}, so harmonic h of the travelling
    wave sees the Hermitian stiffness `coupled_stiffness(system, h phi)`.  A sector
    cut out of a flexible disk (`structure.cyclic_cut`) also shares mass and damping
    with its neighbours across the cut faces: `M_next`, `C_next` couple the same way
    (inertia M q_j'' + M_next q_{j+1}'' + M_next^T q_{j-1}'', `coupled_matrix`).
    """

    Bt_next: np.ndarray      # (E, n) tangential map on the next sector's DOFs [-]
    Bn_next: np.ndarray      # (E, n) normal map on the next sector's DOFs [-]
    sectors: int             # N
    engine_order: int        # EO
    K_next: np.ndarray | None = None   # (n, n) linear coupling to the next sector [N/m]
    M_next: np.ndarray | None = None   # (n, n) mass coupling to the next sector [kg]
    C_next: np.ndarray | None = None   # (n, n) damping coupling to the next sector [N s/m]

    @property
    def phase(self) -> float:
        """Inter-sector phase angle phi = 2 pi EO / N [rad]."""
        return 2.0 * np.pi * self.engine_order / self.sectors


@dataclass(frozen=True)
class System:
    """Linear structure + Yang-Menq elements + harmonic excitation (SI units).

    `laws`: elements of further contact laws (`contact.laws.LawElements`, each with its
    own map from the DOFs); their forces add B^T f to the equations of motion.
    """

    M: np.ndarray            # (n, n) mass [kg]
    C: np.ndarray            # (n, n) viscous damping [N s/m]
    K: np.ndarray            # (n, n) stiffness [N/m]
    Bt: np.ndarray           # (E, n) tangential relative displacement map [-]
    Bn: np.ndarray           # (E, n) normal relative displacement map [-]
    # M, C, K, Bt, Bn: ndarrays or scipy.sparse matrices (an unreduced FE blade, a
    # large N-sector assembly); `dense` gives an ndarray where one is needed
    contact: ContactElements  # E element parameter sets
    forcing: np.ndarray      # (n, Hf+1) complex harmonic load amplitudes [N]
    dof_names: tuple = field(default=())
    cyclic: CyclicCoupling | None = None   # None: an ordinary (non-cyclic) structure
    laws: tuple = ()         # further `contact.laws.LawElements` (other contact laws)

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    @property
    def n_elements(self) -> int:
        return self.Bt.shape[0]

    def forcing_coefficients(self, H: int) -> np.ndarray:
        """F in the real layout of harmonics.py, shape (n, 2H+1) [N]."""
        F = np.zeros((self.n_dof, 2 * H + 1))
        Fh = np.asarray(self.forcing)
        F[:, 0] = Fh[:, 0].real
        for h in range(1, min(H, Fh.shape[1] - 1) + 1):
            F[:, 2 * h - 1] = Fh[:, h].real
            F[:, 2 * h] = -Fh[:, h].imag
        return F


@dataclass(frozen=True)
class ContactSet:
    """The elements of a system's declared contacts and their maps: the Yang-Menq
    set (`System.contact`, maps (Bt, Bn), next (Bt_next, Bn_next) on a cyclic
    sector) or, when that is empty, the first further law with a normal direction and
    a preload (an FE blade's 2D friction contacts: maps (t1, t2, n)).  The normal map
    is the last; `elements` has ku, kv, mu, n0 (E,); `law` the 2D law's `LawElements`
    index in `System.laws` (None for Yang-Menq)."""

    elements: object
    maps: tuple
    maps_next: tuple
    law: int | None = None

    @property
    def size(self) -> int:
        return self.elements.size


def normal_load_laws(laws) -> tuple:
    """Indices of the `LawElements` of `laws` whose elements carry a normal load
    n = n0 + kv v (a normal direction and a preload: the 2D friction law), which
    can separate."""
    return tuple(k for k, le in enumerate(laws)
                 if "normal" in le.law.directions and hasattr(le.law, "n0"))


def contact_set(system: System) -> ContactSet:
    """The `ContactSet` of a system (see there)."""
    cy = system.cyclic
    if system.contact.size == 0:
        for k in normal_load_laws(system.laws)[:1]:
            le = system.laws[k]
            return ContactSet(le.law, tuple(le.maps), tuple(le.maps_next), k)
    nxt = (cy.Bt_next, cy.Bn_next) if cy is not None else ()
    return ContactSet(system.contact, (system.Bt, system.Bn), nxt)


def with_preload(system: System, n0) -> System:
    """The system with the preload n0 (E,) [N] of its `contact_set`'s elements."""
    cs = contact_set(system)
    if cs.law is None:
        return replace(system, contact=replace(system.contact, n0=np.asarray(n0, float)))
    laws = list(system.laws)
    laws[cs.law] = replace(laws[cs.law], law=replace(cs.elements, n0=np.asarray(n0, float)))
    return replace(system, laws=tuple(laws))


def coupled_matrix(system: System, name: str, angle: float):
    """X + exp(i angle) X_next + exp(-i angle) X_next^T of the system's matrix `name`
    ("K" [N/m], "M" [kg] or "C" [N s/m]): what a wave with the inter-sector phase
    `angle` [rad] sees (harmonic h of the engine-order wave: angle = h phi; Hill's
    perturbation of wave number r adds 2 pi r / N).  X itself (real, dense or sparse
    as given) when the system has no such inter-sector coupling."""
    X = getattr(system, name)
    Xn = coupling(system, name)
    if Xn is None:
        return X
    X = X.toarray() if hasattr(X, "toarray") else np.asarray(X, float)
    z = np.exp(1j * angle)
    out = X + z * Xn + np.conj(z) * Xn.T
    return out.real if abs(z.imag) < 1e-15 else out


def coupling(system: System, name: str):
    """The dense inter-sector coupling X_next (n, n) of the matrix `name` ("K", "M",
    "C") of a cyclic sector, or None."""
    cy = system.cyclic
    Xn = None if cy is None else getattr(cy, f"{name}_next")
    return None if Xn is None else np.asarray(Xn.toarray() if hasattr(Xn, "toarray") else Xn,
                                              dtype=float)


def inertia_coupled(system: System) -> bool:
    """True for a cyclic sector whose mass or damping couples it to its neighbours (a
    sector cut out of a flexible disk): each harmonic then has its own M and C."""
    return coupling(system, "M") is not None or coupling(system, "C") is not None


def coupled_stiffness(system: System, angle: float):
    """K + exp(i angle) K_next + exp(-i angle) K_next^T [N/m] (`coupled_matrix`)."""
    return coupled_matrix(system, "K", angle)


def natural_frequencies(system: System, contacts: str = "open") -> np.ndarray:
    """Undamped natural frequencies [rad/s] with the contacts open or stuck.

    "stuck" (or "tied") adds ku along Bt and kv along Bn of every element, whatever its
    preload (every contact closed and stuck: with a gap too, where sticking needs the
    contact closed): with "open" the linear limits the nonlinear response tends to.  For a cyclic
    sector the maps of the first harmonic, B = Bt + exp(i phi) Bt_next, give the
    Hermitian stiffness K + B^H ku B + ... (with a linear inter-sector coupling,
    `coupled_stiffness(system, phi)` in place of K, and with a mass coupling
    `wave_mass`): the frequencies of the engine-order family (nodal diameter EO).
    """
    # every frequency: one dense eigen-solve of the whole structure (N n DOFs for an
    # N-sector assembly), whether the matrices are stored sparse or not
    K = linear_stiffness(system, contacts)
    return from_squares(sla.eigh(K, wave_mass(system), eigvals_only=True), square_scale(system))


def wave_mass(system: System) -> np.ndarray:
    """The dense mass [kg] of `linear_stiffness`' problem: M, or for a cyclic sector
    with a mass coupling that of its engine-order family (`coupled_matrix`)."""
    cy = system.cyclic
    return dense(coupled_matrix(system, "M", cy.phase if cy is not None else 0.0))


def natural_modes(system: System, contacts: str = "open") -> tuple:
    """(frequencies [rad/s] (n,), mode shapes (n, n)) of `natural_frequencies`' problem:
    column j solves (K_contacts - w_j^2 M) x_j = 0, complex for a cyclic sector's
    travelling waves, each scaled to max |x| = 1 with that entry real and positive."""
    K = linear_stiffness(system, contacts)
    w2, X = sla.eigh(K, wave_mass(system))
    j = np.argmax(np.abs(X), axis=0)
    peak = X[j, np.arange(X.shape[1])]
    return from_squares(w2, square_scale(system)), X / peak[None, :]


NEGATIVE_REL = 1e-12  # an omega^2 below -NEGATIVE_REL of the scale: a negative stiffness
#                       (eigh's round-off: about eps times the largest omega^2)


def from_squares(w2, scale: float = 0.0) -> np.ndarray:
    """Frequencies [rad/s] from the eigenvalues omega^2 [rad^2/s^2] of K - omega^2 M:
    sqrt, 0 for a round-off negative (a free body), NaN for an omega^2 below
    -NEGATIVE_REL max(|omega^2|, scale) (the structure diverges statically there: no
    frequency, `negative_stiffness`); `scale` [rad^2/s^2] for a subset of the
    eigenvalues (`square_scale`)."""
    w2 = np.asarray(w2, float)
    if w2.size == 0:
        return w2
    floor = -NEGATIVE_REL * max(float(np.max(np.abs(w2))), scale)
    return np.where(w2 < floor, np.nan, np.sqrt(np.maximum(w2, 0.0)))


def square_scale(system: System) -> float:
    """max |K_ii| / max M_ii [rad^2/s^2]: the scale of the structure's omega^2, for
    telling a negative stiffness from round-off when only the lowest are known."""
    dK = np.abs(system.K.diagonal() if hasattr(system.K, "diagonal") else np.diag(system.K))
    dM = np.abs(system.M.diagonal() if hasattr(system.M, "diagonal") else np.diag(system.M))
    return float(np.max(dK) / np.max(dM)) if dK.size and np.max(dM) > 0 else 0.0


def negative_stiffness(system: System) -> float | None:
    """The lowest omega^2 [rad^2/s^2] of the structure at rest (the "small" limit:
    preloaded contacts stuck, the others open, the further laws' springs) where it is
    a negative stiffness (below -NEGATIVE_REL of its scale, `from_squares`), else None:
    such a structure is statically unstable about rest (spin softening beyond the
    speed of divergence).  None with a nonlinear elastic law (a cubic spring): a
    negative linear stiffness with a stiffening k3 (a double well) has stable
    equilibria away from rest."""
    if any(getattr(le.law, "k3", None) is not None for le in system.laws):
        return None
    try:
        w2 = lowest_squares(system, "small", 6)
    except (RuntimeError, np.linalg.LinAlgError):   # shift-invert about 0 of a singular K:
        return None                                 # a free body, no negative stiffness found
    if w2.size == 0 or not np.isnan(from_squares(w2, square_scale(system))[0]):
        return None
    return float(w2[0])


def linear_stiffness(system: System, contacts: str = "open", laws: bool = True) -> np.ndarray:
    """The dense stiffness [N/m] of a linear limit (`natural_frequencies`' meaning of
    `contacts`): K plus the stuck contacts' springs and (`laws`) the further laws'
    linear limits; for a cyclic sector the Hermitian stiffness of the engine-order
    family (complex unless phi = 0 or pi).  "small": the limit of vanishing
    vibration, the preloaded elements (n0 > 0) stuck in both directions and the others
    (a gap) open."""
    cy = system.cyclic
    K = dense(coupled_stiffness(system, cy.phase if cy is not None else 0.0))
    if contacts in ("stuck", "tied", "small"):
        el = system.contact
        closed = np.ones(el.size, bool) if contacts in ("stuck", "tied") else el.n0 > 0
        Bt, Bn = system.Bt, system.Bn
        if cy is not None:
            z = np.exp(1j * cy.phase)
            Bt = dense(Bt) + z * dense(cy.Bt_next)
            Bn = dense(Bn) + z * dense(cy.Bn_next)
        ku = el.ku * closed if contacts == "small" else el.ku
        K = K + (stiffness_along(Bt, ku) + stiffness_along(Bn, el.kv * closed))
    elif contacts != "open":
        raise ValueError("contacts must be 'open', 'stuck', 'tied' or 'small', "
                         f"got {contacts!r}")
    for le in system.laws if laws else ():   # 2D friction's limits; a spring's k1
        limit = getattr(le.law, "linear_limit", None)
        if limit is None:
            continue
        k = limit(contacts)       # (E, D) springs along the law's directions [N/m]
        for d, B in enumerate(le.maps):
            if cy is not None and le.maps_next:
                B = dense(B) + np.exp(1j * cy.phase) * dense(le.maps_next[d])
            K = K + stiffness_along(B, k[:, d])
    return K


def stiffness_along(B, k) -> np.ndarray:
    """B^H diag(k) B (n, n) [N/m], dense: springs k [N/m] along the rows of B (E, n)
    (an ndarray, complex for a cyclic sector's wave maps, or scipy.sparse)."""
    if sp.issparse(B):
        return (B.T @ sp.diags(np.asarray(k, float)) @ B).toarray()
    return B.conj().T @ (np.asarray(k)[:, None] * B)


def element_rows(T, N_) -> list:
    """Per row e of the maps T, N_ (E, n), ndarrays or scipy.sparse: (columns where
    either is nonzero, ascending; T's values there [-]; N_'s values there [-]),
    read from the sparse structure without densifying."""
    P = sp.csr_matrix(abs(sp.csr_matrix(T, dtype=float)) + abs(sp.csr_matrix(N_, dtype=float)))
    if P.shape[0] == 0:      # no elements (an FE wheel whose contacts are another law's)
        return []
    P.eliminate_zeros()
    P.sort_indices()
    rows = np.repeat(np.arange(P.shape[0]), np.diff(P.indptr))
    if sp.issparse(T) or sp.issparse(N_):
        vt = np.asarray(sp.csr_matrix(T)[rows, P.indices], float).ravel()
        vn = np.asarray(sp.csr_matrix(N_)[rows, P.indices], float).ravel()
    else:
        vt, vn = np.asarray(T, float)[rows, P.indices], np.asarray(N_, float)[rows, P.indices]
    return [(P.indices[a:b], vt[a:b], vn[a:b]) for a, b in zip(P.indptr[:-1], P.indptr[1:])]


DENSE_EIGEN_MAX = 2000   # DOFs: above, the lowest frequencies by sparse shift-invert


def lowest_frequencies(system: System, contacts: str, k: int) -> np.ndarray:
    """The k lowest undamped natural frequencies [rad/s] (`natural_frequencies`'
    meaning of `contacts`; NaN for a negative stiffness, `from_squares`), without a
    dense whole-structure matrix above DENSE_EIGEN_MAX DOFs (`lowest_squares`)."""
    return from_squares(lowest_squares(system, contacts, k), square_scale(system))


def lowest_squares(system: System, contacts: str, k: int, laws: bool = True) -> np.ndarray:
    """The k lowest eigenvalues omega^2 [rad^2/s^2] of a linear limit (`laws` as
    `linear_stiffness`), ascending; above DENSE_EIGEN_MAX DOFs K (+ the stuck
    contacts' ku, kv) and M stay sparse and ARPACK's shift-invert Lanczos about 0
    finds the k nearest 0 (the lowest where K has no large negative eigenvalue; a
    full wheel)."""
    n = system.n_dof
    k = min(int(k), n)
    if n <= DENSE_EIGEN_MAX or system.cyclic is not None or not sp.issparse(system.K):
        K = linear_stiffness(system, contacts, laws)
        return sla.eigh(K, wave_mass(system), eigvals_only=True)[:k]

    K = sp.csr_matrix(system.K, dtype=float)
    if contacts in ("stuck", "tied", "small"):
        el = system.contact
        closed = np.ones(el.size, bool) if contacts in ("stuck", "tied") else el.n0 > 0
        ku = el.ku * closed if contacts == "small" else el.ku
        Bt, Bn = sp.csr_matrix(system.Bt), sp.csr_matrix(system.Bn)
        K = K + Bt.T @ sp.diags(ku) @ Bt + Bn.T @ sp.diags(el.kv * closed) @ Bn
    elif contacts != "open":
        raise ValueError(f"contacts must be 'open', 'stuck', 'tied' or 'small', got "
                         f"{contacts!r}")
    for le in system.laws if laws else ():   # 2D friction's limits; a spring's k1
        if getattr(le.law, "linear_limit", None) is not None:
            k = le.law.linear_limit(contacts)
            for d, B in enumerate(le.maps):
                B = sp.csr_matrix(B)
                K = K + B.T @ sp.diags(k[:, d]) @ B
    w2 = spla.eigsh(K.tocsc(), k=k, M=sp.csc_matrix(system.M), sigma=0.0,
                    return_eigenvectors=False, v0=np.ones(n))
    return np.sort(w2)

