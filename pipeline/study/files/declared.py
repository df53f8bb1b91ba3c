"""The physics a scene declares is the physics solved: separation.

The Yang-Menq element separates wherever its normal load n(t) = n0 + kv v(t)
reaches zero (`contact.exact`), whatever the scene declares.  The loader refuses
the scenes where separation is certain from the data (a negative preload, or a
varying normal load with a preload <= 0: `scene.check_scene_rules`).  A scene
with a varying normal load, every preload > 0 and no "separation" in its effects
declares a contact that stays closed; whether it does depends on the motion, so
the run checks it: every solution point of such a scene is tested, and the first
one whose normal load reaches zero stops the case with `UndeclaredSeparation`
(the case fails, nothing of it is written as a solution).

The test is the exact element's own: over one period the normal load of an
element with a varying normal load changes sign (a root of the trigonometric
polynomial n(tau), `trigroots.sign_changes`) or is <= 0 throughout.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...fourier.harmonics import basis
from ...solve.harmonic_balance.hbm import set_motion, setup
from ...model.system import contact_set
from ...fourier.trigroots import sign_changes


class UndeclaredSeparation(RuntimeError):
    """A solution separates although the scene does not declare "separation"."""


def needs_guard(scene) -> bool:
    """The scene's normal load may vary but separation is not declared."""
    eff = set(getattr(scene, "effects", ()) or ())
    return "normal_load_variation" in eff and "separation" not in eff


def separating(prob, Qc, elem) -> np.ndarray:
    """(E,) bool: elements whose varying normal load reaches zero over the period,
    for the contact-DOF coefficients Qc (nc, 2H+1) of `prob` (`hbm.setup`); `elem`
    the system's `contact_set` elements (Yang-Menq or the 2D law's)."""

    V = set_motion(prob, np.asarray(Qc, dtype=float))[:, -1]
    N = elem.kv[:, None] * V
    N[:, 0] += elem.n0
    out = np.zeros(N.shape[0], bool)
    vary = np.flatnonzero(np.any(N[:, 1:] != 0.0, axis=1))
    if vary.size == 0:
        return out
    roots, _ = sign_changes(N[vary])
    crosses = ~np.isnan(roots).all(axis=1) if roots.shape[1] else np.zeros(vary.size, bool)
    tau = 2.0 * np.pi * np.arange(64) / 64
    never_positive = (N[vary] @ basis(tau, prob.H).T).max(axis=1) <= 0.0
    out[vary] = crosses | never_positive
    return out


@dataclass(frozen=True)
class SeparationGuard:
    """Stops a case whose solution separates (see the module docstring).

    unit: the study's frequency unit for the message ("rad/s" or "Hz");
    names: contact names, used when there is one per element."""

    unit: str = "rad/s"
    names: tuple = ()

    def _message(self, system, e, omega) -> str:
        to_unit = 2.0 * np.pi if self.unit == "Hz" else 1.0
        el = contact_set(system).elements
        name = (f"contact {self.names[e]!r}" if len(self.names) == el.size
                else f"contact element {e}")
        n0 = float(el.n0[e])
        return (f"{name} separates at {omega / to_unit:.6g} {self.unit} (its normal load "
                f"n = n0 + kv v, n0 = {n0:g} N, reaches 0 N) but scene.effects does not "
                "declare \"separation\": add it to solve with separation")

    def callback(self, system, H):
        """callback(x, Omega) for the continuation: x are the contact-DOF
        coefficients of `hbm.setup(system, H)`; raises at the first point that
        separates."""
        prob = setup(system, H)
        elem = contact_set(system).elements

        def check(x, lam):
            sep = separating(prob, np.reshape(x, (prob.c.size, prob.nh)), elem)
            if sep.any():
                raise UndeclaredSeparation(self._message(system, int(np.argmax(sep)), lam))
            return False
        return check

    def check_curve(self, system, curve):
        """Every converged point of a `ResponseCurve` (inserted peaks included)."""
        prob = setup(system, curve.H)
        for i in np.flatnonzero(np.asarray(curve.converged)):
            sep = separating(prob, curve.Q[i][prob.c], contact_set(system).elements)
            if sep.any():
                raise UndeclaredSeparation(self._message(system, int(np.argmax(sep)),
                                                         float(curve.omega[i])))
