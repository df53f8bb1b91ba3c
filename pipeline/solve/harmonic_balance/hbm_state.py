"""From a harmonic-balance solution to the time integration: the state at t = 0.

`state_at_zero` gives q(0), q'(0) and the slider positions w(0) of an HBM solution,
the initial state from which `timesim` integrates on (to check an HBM point against
the event-driven reference, or to leave an unstable one).
"""
from __future__ import annotations

import numpy as np

from ...contact.exact import history
from ...model.system import System


def state_at_zero(system: System, Q, Om):
    """q(0), q'(0) and the slider positions w(0) of an HBM solution Q (n, 2H+1) at
    Om [rad/s]: the state from which `timesim` integrates on from an HBM point."""
    H = (Q.shape[1] - 1) // 2
    j = np.arange(1, H + 1)
    q0 = Q[:, 0] + Q[:, 1::2].sum(1)
    qd0 = Om * (Q[:, 2::2] * j).sum(1)
    h = history(system.Bt @ Q, system.Bn @ Q, system.contact, np.array([0.0]))
    w0 = np.where(h["state"][:, 0] == 0, h["u"][:, 0], h["u"][:, 0] - h["fu"][:, 0] / system.contact.ku)
    return q0, qd0, w0
