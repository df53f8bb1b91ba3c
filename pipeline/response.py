"""Response curves: harmonic balance + continuation + Hill stability, as plain arrays.

`frequency_response` traces the periodic response of a `System` over an excitation
frequency range (pseudo-arclength continuation in Omega, folds passed);
`preload_response` traces it over a scale factor of the preloads n0 at a fixed
frequency.  Both return a `ResponseCurve` of plain numpy arrays, which the
dataset layer turns into xarray.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class ResponseCurve:
    """One continuation branch (P points) of a system with n DOFs and H harmonics."""

    parameter: np.ndarray      # (P,) continuation parameter (Omega [rad/s] or preload scale [-])
    omega: np.ndarray          # (P,) excitation frequency [rad/s]
    Q: np.ndarray              # (P, n, 2H+1) Fourier coefficients of every DOF [m]
    converged: np.ndarray      # (P,) bool: recomputed full residual <= tolerance
    residual: np.ndarray       # (P,) recomputed full residual norm [N]
    stable: np.ndarray         # (P,) bool (Hill); all True where stability was not asked
    amplitude: np.ndarray      # (P, n) half peak-to-peak amplitude [m]
    fold_parameter: np.ndarray  # (F,) parameter values of the detected folds
    newton_iterations: np.ndarray  # (P,)
    nfev: int                  # residual evaluations in total
    wall_time: float           # [s]
    success: bool
    status: int
    message: str
    H: int
    tolerance: float           # [N]
    info: dict = field(default_factory=dict)

    @property
    def n_points(self) -> int:
        return self.parameter.size

    def peak(self, dof: int):
        """(amplitude, omega, index) of the largest converged amplitude of a DOF."""
        a = np.where(self.converged, self.amplitude[:, dof], -np.inf)
        i = int(np.argmax(a))
        return float(a[i]), float(self.omega[i]), i
