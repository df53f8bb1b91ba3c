"""Loads of a scene: harmonic amplitudes over named DOFs (`Forcing`) or a force at
the node of an FE node set (`PointLoad`), F(t) = Re sum_h F_h exp(i h Omega t)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Forcing:
    """F(t) = Re sum_h F_h exp(i h Omega t) over the structure's DOFs."""

    amplitudes: np.ndarray  # (n, Hf+1) complex [N]; column 0 a static load


@dataclass(frozen=True)
class PointLoad:
    """F(t) = amplitude * direction * cos(h Omega t + phase) at the node of an FE set."""

    set: str
    direction: tuple        # unit vector, global axes (blade DOF frame for beams)
    amplitude: float        # [N]
    harmonic: int
    phase: float            # [rad]


def point_forcing(blade, loads) -> np.ndarray:
    """(n_full, Hf+1) complex load amplitudes [N] of `PointLoad`s on an FE blade.
    ValueError when a load component falls on a clamped DOF (it would load nothing)."""
    hf = max([ld.harmonic for ld in loads] + [1])
    F = np.zeros((blade.n_dof, hf + 1), dtype=complex)
    for ld in loads:
        local = blade.point_rotation.T @ np.asarray(ld.direction)
        a = ld.amplitude * complex(math.cos(ld.phase), math.sin(ld.phase))
        for c, d in enumerate(blade.dof_sets[ld.set][0]):
            if d >= 0:
                F[d, ld.harmonic] += a * local[c]
            elif abs(local[c]) > 1e-12 and ld.amplitude != 0:
                raise ValueError(f"the load at node set {ld.set!r} acts on a clamped DOF "
                                 f"(component {'xyz'[c]}): it would load nothing; refine the "
                                 "span so the set lies off the root")
    return F
