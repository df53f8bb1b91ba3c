"""Tuned cyclic structures (bladed disks) with engine-order excitation.

N identical sectors j = 0..N-1, each with the linear M, C, K of one sector (n DOFs)
and Yang-Menq elements (paper Eq. 1, 9, 10) between sector j and the next one,
j+1 (mod N):

    u_j = Bt q_j + Bt_next q_{j+1},   v_j = Bn q_j + Bn_next q_{j+1}

(a shroud pair: Bt = -t . (right face of j), Bt_next = +t . (left face of j+1), so
the relative motion is d = U^L_{j+1} - U^R_j, as in the technical notes).  Rows with
zero `_next` parts are elements inside one sector (e.g. a damper to ground).

Engine-order excitation EO: sector j is loaded by the sector load shifted in time,
F_j(tau) = F_0(tau + j phi), phi = 2 pi EO / N, i.e. F_{j,h} = exp(i h j phi) F_{0,h}
(a first-harmonic load has the phase j phi).  The tuned steady state is then the
travelling wave (Petrov, J. Turbomach. 126, 2004; exact for the nonlinear problem)

    Q_{j,h} = exp(i h j phi) Q_{0,h}      for every harmonic h,

which closes the harmonic balance on ONE sector: `sector_system` returns that
sector as a `System` with `System.cyclic` set, which `hbm` solves with the
shifted contact maps (see `hbm` docstring).  `full_assembly` builds all N sectors
with the N x E elements as ordinary elements: the independent reference.
EO = 0 (all sectors in phase) and EO = N/2 (N even; neighbours in antiphase in the
odd harmonics) are standing waves; any other EO is a travelling wave.
Mistuning, localisation and excitations that are not engine orders need the full
assembly: `full_assembly(..., stiffness_factors)` with per-sector stiffness factors
(`mistuning_factors`) is the model of a mistuned disk.  The disk is rigid, so the
assembly is block diagonal up to the elements: stored sparse (O(N) nonzeros) above
DENSE_MAX_DOF DOFs, where `hbm` condenses it with one sparse LU per harmonic.  Stability: the sector's own Hill problem only sees perturbations with
the symmetry of the solution (wave number 0 relative to it); a travelling wave can
lose stability to other wave numbers r = 1..N/2 (measured: N = 4, EO = 1 with
separation, stable by the sector's Hill problem, unstable by the assembly's).
`full_operators.wave_jacobians` gives the Hill problem of every wave number from the sector
alone (together exactly the assembly's eigenvalues).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from math import gcd

import numpy as np
import scipy.sparse as sp

from ..contact.laws import ContactElements, LawElements
from ..fourier.harmonics import shift
from .system import CyclicCoupling, System

# N n above which `full_assembly` stores its matrices sparse by default.  Measured on
# the lumped mistuned disk (n = 2, H = 3, one thread): per continuation point the
# dense harmonic balance is 3.4x faster at N n = 48, 2.4x at 96, 1.15x slower at 192
# (dense matrices there: 0.3 MB each; sparse: 0.02 MB for all five)
DENSE_MAX_DOF = 160


@dataclass(frozen=True)
class Sector:
    """One tuned sector: linear part, interblade/intra-sector contacts, sector-0 load."""

    M: np.ndarray            # (n, n) [kg]
    C: np.ndarray            # (n, n) [N s/m]
    K: np.ndarray            # (n, n) [N/m]
    Bt: np.ndarray           # (E, n) tangential map on this sector's DOFs [-]
    Bn: np.ndarray           # (E, n) normal map on this sector's DOFs [-]
    Bt_next: np.ndarray      # (E, n) tangential map on the next sector's DOFs [-]
    Bn_next: np.ndarray      # (E, n) normal map on the next sector's DOFs [-]
    contact: ContactElements  # E elements (one set per sector)
    forcing: np.ndarray      # (n, Hf+1) complex load of sector 0, F_{0,h} [N]
    sectors: int             # N >= 2
    dof_names: tuple = field(default=())
    K_spring: np.ndarray | None = None   # (n, n) inter-sector springs on own DOFs [N/m]
    K_next: np.ndarray | None = None     # (n, n) inter-sector springs to the next [N/m]
    laws: tuple = ()         # further `contact.laws.LawElements` (own and next-sector maps)
    M_next: np.ndarray | None = None     # (n, n) mass coupling to the next sector [kg]
    C_next: np.ndarray | None = None     # (n, n) damping coupling to the next [N s/m]

    def __post_init__(self):
        n = np.shape(self.M)[0]
        if isinstance(self.sectors, bool) or int(self.sectors) != self.sectors or self.sectors < 2:
            raise ValueError(f"sectors must be an integer >= 2, got {self.sectors!r}")
        E = np.shape(self.Bt)[0]
        for name in ("Bn", "Bt_next", "Bn_next"):
            if np.shape(getattr(self, name)) != (E, n):
                raise ValueError(f"{name} must have shape ({E}, {n}) like Bt, "
                                 f"got {np.shape(getattr(self, name))}")
        if self.contact.size != E and E:
            raise ValueError(f"contact has {self.contact.size} elements, the maps have {E} rows")

    @property
    def n_dof(self) -> int:
        return np.shape(self.M)[0]

    @property
    def K_own(self):
        """The sector's stiffness with the inter-sector springs' own part [N/m]."""
        return self.K if self.K_spring is None else np.asarray(self.K, float) + self.K_spring


def spring_stiffness(rows, k, n: int) -> tuple:
    """(K_spring, K_next) of linear springs between neighbouring sectors [N/m]: spring s
    stretches by d_s = a_s . q_j + b_s . q_{j+1} (rows (S, 2n): a then b), so its
    energy 1/2 k_s d_s^2 gives sector j the stiffness a^T k a + b^T k b on its own DOFs
    (from the springs to j+1 and from j-1) and a^T k b towards q_{j+1} (b^T k a, its
    transpose, towards q_{j-1})."""
    R = np.asarray(rows, dtype=float).reshape(-1, 2 * n)
    a, b, k = R[:, :n], R[:, n:], np.asarray(k, dtype=float)
    return a.T @ (k[:, None] * a) + b.T @ (k[:, None] * b), a.T @ (k[:, None] * b)


def phase(sectors: int, engine_order: int) -> float:
    """Inter-sector phase angle phi = 2 pi EO / N [rad]."""
    return 2.0 * np.pi * engine_order / sectors


def check_engine_order(sectors: int, engine_order) -> int:
    """EO as an int in [0, N-1] (ValueError naming the argument otherwise).
    EO and N - EO are the same wave travelling the other way."""
    if isinstance(engine_order, bool) or int(engine_order) != engine_order:
        raise ValueError(f"engine_order must be an integer, got {engine_order!r}")
    eo = int(engine_order)
    if not 0 <= eo < sectors:
        raise ValueError(f"engine_order must be in [0, {sectors - 1}] for {sectors} sectors, "
                         f"got {eo}")
    return eo


def sector_system(sector: Sector, engine_order: int) -> System:
    """The cyclic reduction: one sector whose elements see the next sector as this
    one shifted by phi (Q_{j+1,h} = exp(i h phi) Q_{j,h}; Petrov 2004).  The
    result is an ordinary `System` (n DOFs) with `cyclic` set: `hbm`, `response`,
    `stability` solve it as they solve any other."""
    eo = check_engine_order(sector.sectors, engine_order)
    cy = CyclicCoupling(Bt_next=np.asarray(sector.Bt_next, float),
                        Bn_next=np.asarray(sector.Bn_next, float),
                        sectors=int(sector.sectors), engine_order=eo, K_next=sector.K_next,
                        M_next=sector.M_next, C_next=sector.C_next)
    return System(M=sector.M, C=sector.C, K=sector.K_own, Bt=np.asarray(sector.Bt, float),
                  Bn=np.asarray(sector.Bn, float), contact=sector.contact,
                  forcing=np.asarray(sector.forcing, complex), dof_names=tuple(sector.dof_names),
                  cyclic=cy, laws=tuple(sector.laws))


def isolated_system(sector: Sector) -> System:
    """The sector alone, its interblade elements removed (rows of Bt, Bn with a
    `_next` part dropped): the linear limit of EO = 0 for pure pair contacts
    (inter-sector springs in their EO = 0 state, K + K_next + K_next^T)."""
    keep = ~(np.any(sector.Bt_next != 0, 1) | np.any(sector.Bn_next != 0, 1))
    sub = sector.contact.take(keep)
    K, M, C = (X if Xn is None else X + Xn + np.asarray(Xn).T for X, Xn in (
        (sector.K_own, sector.K_next), (sector.M, sector.M_next), (sector.C, sector.C_next)))
    return System(M=M, C=C, K=K, Bt=np.asarray(sector.Bt)[keep],
                  Bn=np.asarray(sector.Bn)[keep], contact=sub,
                  forcing=np.asarray(sector.forcing, complex), dof_names=tuple(sector.dof_names))


def sector_forcing(sector: Sector, engine_order: int, j: int) -> np.ndarray:
    """Load of sector j: F_{j,h} = exp(i h j phi) F_{0,h} (n, Hf+1) [N]."""
    F = np.asarray(sector.forcing, complex)
    h = np.arange(F.shape[1])
    return F * np.exp(1j * h * j * phase(sector.sectors, engine_order))


def mistuning_factors(sectors: int, stiffness_std: float, seed: int) -> np.ndarray:
    """Stiffness factors 1 + delta_j of the N sectors (K_j = (1 + delta_j) K):
    delta_j ~ N(0, stiffness_std^2) from `numpy.random.default_rng(seed)`, drawn in
    sector order, truncated at 3 standard deviations and at -0.9 so every K_j stays
    positive definite.  The same (N, std, seed) gives the same disk on any machine."""
    if isinstance(sectors, bool) or int(sectors) != sectors or sectors < 2:
        raise ValueError(f"sectors must be an integer >= 2, got {sectors!r}")
    if not 0.0 <= stiffness_std < 0.5:
        raise ValueError(f"stiffness_std must be in [0, 0.5), got {stiffness_std!r}")
    if isinstance(seed, bool) or int(seed) != seed or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    delta = np.random.default_rng(int(seed)).normal(0.0, stiffness_std, int(sectors))
    return 1.0 + np.clip(delta, max(-3.0 * stiffness_std, -0.9), 3.0 * stiffness_std)


def full_assembly(sector: Sector, engine_order: int, stiffness_factors=None,
                  sparse: bool | None = None) -> System:
    """All N sectors in one `System` (N n DOFs, sector-major: DOF i of sector j is
    j n + i), the N E elements as ordinary rows of Bt, Bn, travelling-wave load.
    No symmetry is used: the reference for `sector_system`, and the model of a
    mistuned disk, sector j with the stiffness `stiffness_factors[j]` K (N positive
    factors, `mistuning_factors`; None: tuned, all 1).  M and the damping C are NOT
    scaled (C stays the tuned sector's, so modal damping ratios change by 1/sqrt(f_j)).

    For a Craig-Bampton-reduced FE blade, f K_r is exactly the reduction of the blade
    with Young's modulus f E: K(f E) = f K(E), so the constraint modes -K_ii^-1 K_ib
    are unchanged and the fixed-interface modes keep their shapes (frequencies times
    sqrt(f)); the basis is the same, the reduced stiffness f K_r, M_r unchanged
    (tests/structure/test_reduction_mistuning.py; the directly reduced blade's modal damping
    would be sqrt(f) C_r).

    With a rigid disk the sectors interact only through the elements (and the
    springs between sectors, `Sector.K_spring` / `K_next`, which add the block-cyclic
    K_next at (j, j+1) and K_next^T at (j+1, j)); otherwise M, C, K are
    block diagonal, blockdiag(M), blockdiag(C), blockdiag(f_j K), and Bt, Bn
    block-bidiagonal (own sector, next sector, the last row block closing the ring):
    O(N) nonzeros.  sparse=True returns them as scipy.sparse CSR matrices, False as
    ndarrays ((N n)^2 x 8 bytes per matrix), None (default) sparse exactly when
    N n > DENSE_MAX_DOF (below it the batched dense harmonic balance is faster).
    Both hold the same numbers."""
    eo = check_engine_order(sector.sectors, engine_order)
    N = sector.sectors
    kf = np.ones(N) if stiffness_factors is None else np.asarray(stiffness_factors, float)
    if kf.shape != (N,) or not np.all(np.isfinite(kf)) or np.any(kf <= 0):
        raise ValueError(f"stiffness_factors must be {N} positive numbers, got {kf!r}")
    one = sp.identity(N, format="csr")
    ring = sp.csr_matrix((np.ones(N), (np.arange(N), (np.arange(N) + 1) % N)), shape=(N, N))
    blk = lambda P, A: sp.kron(P, sp.csr_matrix(A, dtype=float), format="csr")  # noqa: E731
    mats = {"M": blk(one, sector.M), "C": blk(one, sector.C), "K": blk(sp.diags(kf), sector.K),
            "Bt": blk(one, sector.Bt) + blk(ring, sector.Bt_next),
            "Bn": blk(one, sector.Bn) + blk(ring, sector.Bn_next)}
    if sector.K_spring is not None:   # springs between sectors (the disk), never mistuned
        mats["K"] = (mats["K"] + blk(one, sector.K_spring)).tocsr()
    for name, Xn in (("K", sector.K_next), ("M", sector.M_next), ("C", sector.C_next)):
        if Xn is not None:           # the disk's coupling across the cut, never mistuned
            mats[name] = (mats[name] + blk(ring, Xn) + blk(ring.T, np.asarray(Xn).T)).tocsr()
    if not (N * sector.n_dof > DENSE_MAX_DOF if sparse is None else sparse):
        mats = {k: A.toarray() for k, A in mats.items()}
    contact = sector.contact.tile(N)
    F = np.concatenate([sector_forcing(sector, eo, j) for j in range(N)])
    names = tuple(f"s{j}.{d}" for j in range(N) for d in sector.dof_names)
    dense = isinstance(mats["M"], np.ndarray)
    laws = tuple(LawElements(le.law.tile(N), tuple(
        (A.toarray() if dense else A) for A in (
            blk(one, B) + (blk(ring, Bx) if le.maps_next else 0)
            for B, Bx in zip(le.maps, le.maps_next or le.maps)))) for le in sector.laws)
    return System(**mats, contact=contact, forcing=F, dof_names=names, laws=laws)


def expand(Q0, sectors: int, engine_order: int):
    """The N-sector response (N n, 2H+1) of a sector solution Q0 (n, 2H+1):
    Q_j = T(j phi) Q0 (`harmonics.shift`), stacked sector-major as in `full_assembly`."""
    phi = phase(sectors, engine_order)
    return np.concatenate([shift(Q0, j * phi) for j in range(sectors)])


def wheel_system(system: System) -> System:
    """The N-sector assembly (`full_assembly`, dense) of a tuned cyclic sector `System`
    (`sector_system`): what the sector's travelling wave is a solution of, with every
    wave number free (its time integration, its Floquet multipliers).  The further
    laws' elements (`System.laws`, own and next-sector maps) are assembled with it."""
    cy = system.cyclic
    sec = Sector(M=system.M, C=system.C, K=system.K, Bt=system.Bt, Bn=system.Bn,
                 Bt_next=cy.Bt_next, Bn_next=cy.Bn_next, contact=system.contact,
                 forcing=system.forcing, sectors=cy.sectors,
                 dof_names=tuple(system.dof_names), K_next=cy.K_next, laws=system.laws,
                 M_next=cy.M_next, C_next=cy.C_next)
    return full_assembly(sec, cy.engine_order, sparse=False)


def aft_samples_ok(sectors: int, engine_order: int, n_samples: int) -> bool:
    """True if AFT on the sector equals AFT on the full assembly: the sample grid
    must be invariant under the shift phi, i.e. n_samples a multiple of
    N / gcd(N, EO) (technical notes, Cyclic symmetry with HBM)."""
    return n_samples % (sectors // gcd(sectors, engine_order)) == 0

