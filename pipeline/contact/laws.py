"""Contact laws: the one interface through which the harmonic balance evaluates
nonlinear element forces.

A law acts on E elements; element e has D local directions (Yang-Menq: the
tangential u and the normal v).  Its motion is linear in the structure's DOFs,

    X[e, d] = sum_j B[e, d, j] q_j          (B: (E, D, n), `LawElements`),

and its forces f[e, d](X[e]) act back through the transpose, B^T f, so action =
reaction holds by construction.  In the harmonic balance X and F are real Fourier
coefficients in the layout of `harmonics.py`, [X0, Xc1, Xs1, ..., XcH, XsH], shaped
(E, D, 2H+1).  A law declares:

    name           its registry name (`contact.registry.LAWS`)
    directions     names of the D local directions
    pairs          the direction pairs (d, d') whose Jacobian block dF_d/dX_d' may be
                   nonzero, in a fixed order (all others vanish identically)
    supports       the solvers that can evaluate it (`SOLVERS`): every law with a
                   Jacobian serves the harmonic balance and Hill's method; the event-driven
                   time integration, shooting and the orbit monodromy need the law's own
                   event structure
    size           E
    evaluate(X, method, n_samples, jacobian) -> `LawForces`

and keeps its parameters as plain frozen data.  `YangMenqLaw` is the friction
element of the paper (Eq. 9-11) evaluated exactly or by AFT (`contact.forces`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.sparse as sp

from .aft import aft_forces
from .element import YangMenq, check_coefficients
from .exact import exact_forces, stacked_forces, unstacked

# solvers a law may support: harmonic balance, Hill's method (both need only the
# Fourier coefficients of the forces and their Jacobian), the event-driven time
# integration and shooting, and the monodromy of the event-driven orbit (Floquet)
SOLVERS = ("hbm", "hill", "timesim", "shooting", "orbit_floquet")


class ContactElements(Protocol):
    """The parameter set of E elements acting along a structure's tangential and
    normal maps (`model.System.contact`, maps Bt, Bn); `registry.law_of` gives the
    law that evaluates them.  Today the Yang-Menq element (`contact.element`)."""

    n0: np.ndarray           # (E,) preload [N] (negative: a gap)

    @property
    def size(self) -> int: ...

    def take(self, index) -> "ContactElements": ...

    def tile(self, reps: int) -> "ContactElements": ...


@dataclass(frozen=True)
class LawForces:
    """Fourier coefficients F (E, D, 2H+1) [N] of a law's forces and their Jacobian
    J (E, P, 2H+1, 2H+1) [N/m], block p = dF_d/dX_d' for (d, d') = law.pairs[p]
    (None without Jacobian); `regimes` counts the law's evaluation regimes and
    `detail` is the law's own result (for Yang-Menq the `ContactForces`)."""

    F: np.ndarray
    J: np.ndarray | None
    regimes: dict
    detail: object = None


@dataclass(frozen=True)
class YangMenqLaw:
    """The Yang-Menq element as a contact law: directions (tangential u, normal v),
    forces (f_u, f_v) of Eq. 9-11; dF_v/dU = 0 identically, so the Jacobian pairs
    are (u, u), (u, v), (v, v).  method "exact" (transition times and closed-form
    integrals) or "aft" (n_samples samples a period)."""

    element: YangMenq

    name = "yang_menq"
    directions = ("tangential", "normal")
    pairs = ((0, 0), (0, 1), (1, 1))
    supports = frozenset(SOLVERS)

    @property
    def size(self) -> int:
        return self.element.size

    def evaluate(self, X, method: str = "exact", n_samples: int = 1024,
                 jacobian: bool = True) -> LawForces:
        elem = self.element
        U, V = np.ascontiguousarray(X[:, 0]), np.ascontiguousarray(X[:, 1])
        if method == "exact" and elem.size == U.shape[0]:   # shapes known: no re-check
            F, J, regimes = stacked_forces(U, V, elem, jacobian)   # already in this layout
            return LawForces(F, J, regimes, unstacked(F, J, regimes))
        f = yang_menq_forces(U, V, elem, method, n_samples, jacobian)
        J = (np.stack([f.dFu_dU, f.dFu_dV, f.dFv_dV], axis=1) if jacobian else None)
        return LawForces(np.stack([f.Fu, f.Fv], axis=1), J, f.regimes, f)


def yang_menq_forces(U, V, elem: YangMenq, method: str = "exact", n_samples: int = 1024,
                     jacobian: bool = True):
    """Fourier coefficients of f_u, f_v (Eq. 9-11) for motions U, V (E, 2H+1), checked
    (`contact.forces`)."""
    E = elem.size
    U = check_coefficients("U", U, E)
    V = check_coefficients("V", V, E)
    if U.shape != V.shape:
        raise ValueError(f"U and V must have the same shape, got {U.shape} and {V.shape}")
    if method == "exact":
        return exact_forces(U, V, elem, jacobian)
    if method == "aft":
        return aft_forces(U, V, elem, int(n_samples), jacobian)
    raise ValueError(f"method must be 'exact' or 'aft', got {method!r}")


@dataclass(frozen=True, eq=False)
class LawElements:
    """E elements of one law and their map from the structure's n DOFs: `maps` holds
    one (E, n) matrix per direction (ndarrays or scipy.sparse), row e of map d giving
    X[e, d] = maps[d][e] . q.  On a cyclic sector, `maps_next` (one per direction, or
    empty) adds the next sector's DOFs: X[e, d] = maps[d][e] . q_j +
    maps_next[d][e] . q_{j+1}, the next sector's motion being this one's shifted by the
    engine order's phase (`model.system.CyclicCoupling`)."""

    law: object
    maps: tuple
    maps_next: tuple = ()

    def __post_init__(self):
        D = len(self.law.directions)
        if len(self.maps) != D or len(self.maps_next) not in (0, D):
            raise ValueError(f"law {self.law.name!r} has {D} directions, got {len(self.maps)} "
                             f"maps and {len(self.maps_next)} next-sector maps")
        for d, B in enumerate(self.maps + self.maps_next):
            if B.ndim != 2 or B.shape[0] != self.law.size:
                raise ValueError(f"law {self.law.name!r}: map {d % D} must be (E={self.law.size},"
                                 f" n), got {B.shape}")

    @property
    def B(self) -> np.ndarray:
        """(E, D, n) dense map from the DOFs to the element directions [-]."""
        return np.stack([B.toarray() if sp.issparse(B) else np.asarray(B, float)
                         for B in self.maps], axis=1)


def require(law, solver: str) -> None:
    """ValueError naming the law when it cannot be evaluated by `solver`."""
    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r} (known: {', '.join(SOLVERS)})")
    if solver not in law.supports:
        raise ValueError(f"the contact law {law.name!r} is not supported by {solver} "
                         f"(it supports {', '.join(s for s in SOLVERS if s in law.supports)})")


def require_all(laws, solver: str) -> None:
    """`require` for the law of every `LawElements` in `laws` (a `System.laws`)."""
    for le in laws:
        require(le.law, solver)
