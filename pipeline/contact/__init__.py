"""Yang-Menq contact forces (paper Sec. 2, 4, 5; Eq. 1, 9, 10, 11): `forces` and the
element (`contact.element` describes the element, its states and the layout).

Layered one way: `contact.element` (the element as data, its states, the result type)
<- `contact.exact`, `contact.aft` (the two force evaluations) <- this module, which
dispatches between them (`contact.laws.yang_menq_forces`, the Yang-Menq law of the
contact-law interface) and re-exports the element, so `from pipeline.contact import
YangMenq, forces` is the one import a caller needs.
"""
from __future__ import annotations

from .element import (NSLIP, PSLIP, SEP, STATE_NAMES, STICK, ContactForces, YangMenq,
                      check_coefficients)
from .laws import yang_menq_forces

__all__ = ["NSLIP", "PSLIP", "SEP", "STATE_NAMES", "STICK", "ContactForces", "YangMenq",
           "check_coefficients", "forces"]


def forces(U, V, elem: YangMenq, method: str = "exact", n_samples: int = 1024,
           jacobian: bool = True) -> ContactForces:
    """Fourier coefficients of f_u, f_v (Eq. 9-11) for motions U, V (E, 2H+1).

    method "exact": transition times as roots of trigonometric polynomials and
    closed-form Fourier integrals of each state's force piece (`exact.exact_forces`);
    "aft": alternating frequency-time with `n_samples` samples (`aft.aft_forces`).
    """
    return yang_menq_forces(U, V, elem, method, n_samples, jacobian)
