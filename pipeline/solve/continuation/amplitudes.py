"""The DOF amplitudes the branch refinement reads: the condensed unknowns recovered on
all DOFs (`hbm.recover`), half peak-to-peak over the period
(`amplitude_half_peak_to_peak`)."""
from __future__ import annotations

import numpy as np

from ..harmonic_balance import hbm
from ...fourier.harmonics import amplitude_half_peak_to_peak


def amplitudes_at(prob, X, L, dofs, omega_of=lambda l: l):
    """(P, D) amplitudes of the DOFs `dofs` at the points X, L (one recovery of all
    DOFs per point)."""
    if L.size == 0:
        return np.zeros((0, len(dofs)))
    Q = [hbm.recover(prob, X[i].reshape(prob.c.size, prob.nh), omega_of(L[i]))[dofs]
         for i in range(L.size)]
    return amplitude_half_peak_to_peak(np.stack(Q))


class AmplitudeCache:
    """amplitude(z, dof) of a DOF of `dofs` at the branch point z = [x, lam]
    (physical), each point recovered once for all of `dofs`: the peak searches of
    several DOFs between the same branch points (a wheel's blades peaking together)
    read the same trials and slopes.  Values as `amplitudes_at`'s, bit for bit."""

    def __init__(self, prob, dofs, omega_of=lambda l: l):
        self.prob, self.dofs, self.omega_of = prob, list(dofs), omega_of
        self.index = {d: k for k, d in enumerate(self.dofs)}
        self.seen = {}

    def __call__(self, z, dof) -> float:
        key = z.tobytes()
        a = self.seen.get(key)
        if a is None:
            a = self.seen[key] = amplitudes_at(self.prob, z[None, :-1], z[-1:], self.dofs,
                                               self.omega_of)[0]
        return float(a[self.index[dof]])
