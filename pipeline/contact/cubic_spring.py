"""Polynomial (cubic) spring: a contact law with one direction (`contact.laws`).

Element e stretches by u = B[e] q (a signed DOF pair, or one DOF against ground)
and pulls back with

    f(u) = k1 u + k3 u^3,        df/du = k1 + 3 k3 u^2.

Harmonic balance.  u(tau) = sum_j U_j s_j(tau) has H harmonics, so f and
(df/du) s_j are trigonometric polynomials of degree 3H.  Sampled at N equispaced
instants, the discrete projection onto harmonic k <= H aliases harmonic k' onto
|k' -+ N|, which stays above H for every k' <= 3H as soon as N >= 4H + 1; with
N = 3 (2H + 1) = 6H + 3 samples the coefficients F_k = W f and the Jacobian
dF_k/dU_j = W diag(df/du) S are therefore those of the exact harmonic
convolution (up to round-off), for either evaluation method.

Lumped study file (`study.scenes.law_scene`):

    [scene]
    effects = ["cubic_stiffness"]
    [[scene.spring]]
    dofs = ["x1", "-x2"]     # stretch u = x1 - x2 (one DOF: against ground)
    k3 = 1.0e9               # [N/m^3]
    k1 = 0.0                 # [N/m], optional

Solvers: the harmonic balance and Hill's method (any law with a Jacobian).  The
event-driven time integration, shooting and the orbit monodromy are built on the
Yang-Menq element's events and do not evaluate this law.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..fourier.harmonics import harmonics_of, time_grid
from .laws import LawForces


def alias_free_samples(H: int) -> int:
    """N = 3 (2H + 1) samples a period (>= 4H + 1: the cubic's projection is exact)."""
    return 3 * (2 * H + 1)


@dataclass(frozen=True)
class CubicSpring:
    """E springs f = k1 u + k3 u^3: k3 [N/m^3], k1 [N/m] (arrays of length E, or
    scalars for one spring)."""

    k3: np.ndarray
    k1: np.ndarray = field(default_factory=lambda: np.zeros(1))

    name = "cubic_spring"
    directions = ("elongation",)
    pairs = ((0, 0),)
    supports = frozenset({"hbm", "hill"})
    # lumped study file: [[scene.spring]] dofs = ["x1", "-x2"], k3, k1
    effect = "cubic_stiffness"
    study_table = "spring"
    study_rows = ("dofs",)
    study_keys = {"k3": ("N/m^3", None), "k1": ("N/m", 0.0)}
    study_help = {"k3": "cubic stiffness: f = k1 u + k3 u^3", "k1": "linear stiffness"}

    def __post_init__(self):
        k3 = np.atleast_1d(np.asarray(self.k3, dtype=float))
        k1 = np.atleast_1d(np.asarray(self.k1, dtype=float))
        if k3.ndim != 1 or k1.ndim != 1 or k1.size not in (1, k3.size):
            raise ValueError(f"k3 and k1 must be 1-D with one common length (or k1 a "
                             f"scalar), got {k3.shape} and {k1.shape}")
        if not (np.all(np.isfinite(k3)) and np.all(np.isfinite(k1))):
            raise ValueError("k3 and k1 must be finite")
        object.__setattr__(self, "k3", k3)
        object.__setattr__(self, "k1", np.broadcast_to(k1, k3.shape).copy())

    @classmethod
    def from_study(cls, values: dict) -> "CubicSpring":
        """One spring from the study-file values {"k3": .., "k1": ..}."""
        return cls(k3=[values["k3"]], k1=[values["k1"]])

    @property
    def size(self) -> int:
        return self.k3.size

    def linear_limit(self, contacts: str) -> np.ndarray:
        """(E, 1) springs [N/m] of every linear limit (`model.system.linear_stiffness`):
        k1, the spring's tangent at rest, whatever the contacts do."""
        return self.k1[:, None].copy()

    def evaluate(self, X, method: str = "exact", n_samples: int = 0,
                 jacobian: bool = True):
        """Fourier coefficients F (E, 1, 2H+1) of f(u) and J (E, 1, 2H+1, 2H+1) =
        dF/dU for X (E, 1, 2H+1), alias-free (module docstring); `method` and
        `n_samples` are not needed: the result is exact either way."""
        X = np.asarray(X, dtype=float)
        if X.ndim != 3 or X.shape[:2] != (self.size, 1) or X.shape[2] % 2 == 0:
            raise ValueError(f"X must have shape (E={self.size}, 1, 2H+1), got {X.shape}")
        H = harmonics_of(X.shape[2])
        _, S, W = time_grid(H, alias_free_samples(H))
        u = X[:, 0] @ S.T                                        # (E, N)
        k1, k3 = self.k1[:, None], self.k3[:, None]
        F = ((k1 + k3 * u * u) * u) @ W.T
        J = None
        if jacobian:
            g = k1 + 3.0 * k3 * u * u                            # df/du at the samples
            J = np.einsum("kn,en,nj->ekj", W, g, S)[:, None]
        return LawForces(F[:, None, :], J, {"evaluated": self.size})
