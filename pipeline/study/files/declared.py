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
polynomial n(tau), `trigroots.sign_changes`) or is <= 0 throughout.  It reads every
element with a normal load, under every law (`normal_sets`): the Yang-Menq
contacts and the elements of each further law with a normal direction and a
preload (2D friction: `[[scene.friction_2d]]`, FE pairs with friction = "2d").
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...fourier.harmonics import basis
from ...solve.harmonic_balance.hbm import contact_motion, law_motion, set_motion, setup
from ...fourier.trigroots import sign_changes
from ...model.system import normal_load_laws


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
    return _reaches_zero(elem, set_motion(prob, np.asarray(Qc, dtype=float))[:, -1], prob.H)


def normal_sets(system) -> tuple:
    """((k, elements), ...): every element set of `system` with a normal load
    n = n0 + kv v, under every law: the Yang-Menq elements (k None), then those of
    each further law with a normal direction and a preload (k its `System.laws`
    index)."""
    own = ((None, system.contact),) if system.contact.size else ()
    return own + tuple((k, system.laws[k].law) for k in normal_load_laws(system.laws))


def first_separation(prob, Qc):
    """(k, e) of the first element, over `normal_sets`, whose normal load reaches zero
    over the period for the contact-DOF coefficients Qc (nc, 2H+1); None if none."""
    Qc = np.asarray(Qc, dtype=float)
    for k, elem in normal_sets(prob.system):
        if k is None:
            V = contact_motion(prob, Qc)[1]
        else:
            V = law_motion(prob, Qc, k)[:, elem.directions.index("normal")]
        sep = _reaches_zero(elem, V, prob.H)
        if sep.any():
            return k, int(np.argmax(sep))
    return None


def _reaches_zero(elem, V, H) -> np.ndarray:
    """(E,) bool: n = n0 + kv v (V the normal motion's coefficients, (E, 2H+1))
    changes sign over the period or is <= 0 throughout, where it varies."""
    N = elem.kv[:, None] * V
    N[:, 0] += elem.n0
    out = np.zeros(N.shape[0], bool)
    vary = np.flatnonzero(np.any(N[:, 1:] != 0.0, axis=1))
    if vary.size == 0:
        return out
    roots, _ = sign_changes(N[vary])
    crosses = ~np.isnan(roots).all(axis=1) if roots.shape[1] else np.zeros(vary.size, bool)
    tau = 2.0 * np.pi * np.arange(64) / 64
    never_positive = (N[vary] @ basis(tau, H).T).max(axis=1) <= 0.0
    out[vary] = crosses | never_positive
    return out


@dataclass(frozen=True)
class SeparationGuard:
    """Stops a case whose solution separates (see the module docstring).

    unit: the study's frequency unit for the message ("rad/s" or "Hz");
    names: contact names, used when there is one per element."""

    unit: str = "rad/s"
    names: tuple = ()

    def _message(self, system, where, omega) -> str:
        to_unit = 2.0 * np.pi if self.unit == "Hz" else 1.0
        k, e = where
        if k is None:
            el = system.contact
            name = (f"contact {self.names[e]!r}" if len(self.names) == el.size
                    else f"contact element {e}")
        else:   # counted over the elements of that law, as its study-file table
            el = system.laws[k].law
            j = e + sum(le.law.size for le in system.laws[:k] if le.law.name == el.name)
            name = f"{el.name} element {j}"
        n0 = float(el.n0[e])
        return (f"{name} separates at {omega / to_unit:.6g} {self.unit} (its normal load "
                f"n = n0 + kv v, n0 = {n0:g} N, reaches 0 N) but scene.effects does not "
                "declare \"separation\": add it to solve with separation")

    def callback(self, system, H):
        """callback(x, Omega) for the continuation: x are the contact-DOF
        coefficients of `hbm.setup(system, H)`; raises at the first point that
        separates."""
        prob = setup(system, H)

        def check(x, lam):
            where = first_separation(prob, np.reshape(x, (prob.c.size, prob.nh)))
            if where is not None:
                raise UndeclaredSeparation(self._message(system, where, lam))
            return False
        return check

    def check_curve(self, system, curve):
        """Every converged point of a `ResponseCurve` (inserted peaks included)."""
        prob = setup(system, curve.H)
        for i in np.flatnonzero(np.asarray(curve.converged)):
            where = first_separation(prob, curve.Q[i][prob.c])
            if where is not None:
                raise UndeclaredSeparation(self._message(system, where, float(curve.omega[i])))
