"""Exact (event-based) Yang-Menq forces: paper Sec. 4 transitions, Eq. 9-11 integrals.

The element as a play operator.  With the band
    lo(tau) = u - (mu/ku) n,   hi(tau) = u + (mu/ku) n,   n = n0 + kv v   (Eq. 1)
the slider position w (f_u = ku (u - w), Eq. 9) obeys, in contact (n > 0),
w = clamp(w, lo, hi): stick while lo < w < hi, positive slip w = lo, negative slip
w = hi; in separation (n <= 0) f_u = f_v = 0 and the spring restarts unstrained at
touchdown, w = u(tau_td) (Sec. 4.1).  The paper's switching equations are the same
events: PS -> stick where lo' = u' - mu kv/ku v' = 0 (lo maximal, Sec. 4.2), NS ->
stick where hi' = 0 (Sec. 4.3), stick -> PS/NS where lo = w / hi = w, i.e.
ku u -+ mu kv v + (f0 -+ mu n0 - ku u0) = 0 with w = u0 - f0/ku (Sec. 4.4).

Transition times: the sign changes of n, lo' and hi' (trigonometric polynomials
of degree H) are found by `trigkernel.sign_changes_one` (the certified search of
`trigroots.sign_changes`), which provably misses none.
Between consecutive such breakpoints n keeps its sign and lo, hi are monotone, so
at most one stick -> slip event occurs in each (slips end only at breakpoints);
it is the single root of the monotone lo - w (or hi - w) on that interval.

The periodic (steady-state) history is found directly, not by marching to
convergence:
  * n changes sign: a touchdown erases all memory; start there.
  * n > 0 throughout and max lo <= min hi: every w in [max lo, min hi] is a
    periodic full-stick state; `YangMenq.slider_rest` picks one.
  * n > 0 throughout and max lo > min hi: any trajectory that passes argmax lo and
    then argmin hi leaves argmin hi with w = min hi (w can only decrease by being
    clamped to hi, and hi >= min hi), so the periodic state starts there in
    negative slip with w = hi(tau_b).
Fourier integrals (Eq. 11) of each piece (a trigonometric polynomial times the
basis) are closed form.  Forces are continuous at every transition, so the exact
Jacobian is the integral of the piecewise derivative plus the derivative of each
stick phase's w with respect to the coefficients, taken where it was set (lo, hi
stationary there; at touchdown dtau/dV = -s(tau)/v').

Evaluation: compiled (Numba), one element at a time in a loop over the elements
(`contact.exact_kernel`: state sequence; `contact.exact_integrals`: forces and
Jacobian).  The numpy evaluation of the same mathematics, `contact.exact_reference`,
is kept as the independent reference of the tests.  The compiled code is cached
once per machine and kernel version (`pipeline.kernel_cache_dir`).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .element import ContactForces, YangMenq, check_coefficients, history_from_segments
from .exact_integrals import capacities, forces_all, segments_all
from ..fourier.harmonics import basis, harmonics_of
from ..fourier.trigkernel import TWO_PI, root_tables


@lru_cache(maxsize=None)
def kernel_tables(H: int):
    """(root-search grids of `trigkernel.root_tables`, basis at 16 points of the
    period (the sign of a normal load that does not cross zero))."""
    B16 = basis(TWO_PI * np.arange(16) / 16, H)
    B16.setflags(write=False)
    return root_tables(H), B16


def element_arrays(elem: YangMenq):
    """ku, kv, mu, n0, slider rest (zeros if None) and whether it is set."""
    has_rest = elem.slider_rest is not None
    rest = elem.slider_rest if has_rest else np.zeros(elem.size)
    return elem.ku, elem.kv, elem.mu, elem.n0, rest, has_rest


def kernel_input(X):
    """X as a C-contiguous, writeable float array: the one array type the kernels are
    compiled for (a read-only or strided array would compile another variant)."""
    if (type(X) is np.ndarray and X.dtype == np.float64 and X.flags.c_contiguous
            and X.flags.writeable):
        return X
    return np.require(X, dtype=float, requirements=("C", "W"))


def stacked_forces(U, V, elem: YangMenq, jacobian: bool = True):
    """(F, J, regimes): exact Fourier coefficients F (E, 2, 2H+1) of (f_u, f_v)
    (Eq. 9-11) and their Jacobian J (E, 3, 2H+1, 2H+1) = (dFu/dU, dFu/dV, dFv/dV)
    (None without `jacobian`), in the layout of `contact.laws.LawForces`; regimes
    as `ContactForces.regimes`."""
    U, V = kernel_input(U), kernel_input(V)
    E, nc = U.shape
    H = harmonics_of(nc)
    F = np.zeros((E, 2, nc))
    J = np.zeros((E if jacobian else 1, 3, nc, nc))
    regime, varying = np.empty(E, np.int64), np.empty(E, np.bool_)
    T, B16 = kernel_tables(H)
    forces_all(U, V, *element_arrays(elem), T, B16, bool(jacobian), F, J, regime, varying)
    k = np.bincount(regime, minlength=4)
    regimes = {"separated": int(k[0]), "stuck": int(k[1]), "transitions": int(k[2]),
               "frictionless": int(k[3]), "normal_load_searched": int(np.count_nonzero(varying))}
    return F, (J if jacobian else None), regimes


def unstacked(F, J, regimes) -> ContactForces:
    """The `ContactForces` of `stacked_forces`' output, each force and derivative a
    view of its stack."""
    if J is None:
        return ContactForces(F[:, 0], F[:, 1], None, None, None, regimes)
    return ContactForces(F[:, 0], F[:, 1], J[:, 0], J[:, 1], J[:, 2], regimes)


def exact_forces(U, V, elem: YangMenq, jacobian: bool = True) -> ContactForces:
    """Exact Fourier coefficients of f_u, f_v (Eq. 9-11) and their Jacobian."""
    return unstacked(*stacked_forces(U, V, elem, jacobian))


def periodic_segments(U, V, elem: YangMenq) -> dict:
    """Steady-state state sequence of every element over one period: arrays (E, S)
    `a`, `b` (segment limits, tau in [t0, t0 + 2 pi)), `state` (SEP/STICK/PSLIP/NSLIP,
    -1 = unused), `w` (slider position of stick segments); per element `regime`
    (0 separated, 1 stuck, 2 transitions, 3 frictionless) and `Nc` (E, 2H+1), the
    normal load's coefficients."""
    U, V = kernel_input(U), kernel_input(V)
    E, nc = U.shape
    H = harmonics_of(nc)
    S = capacities(H)[1]
    a, b, w = np.zeros((E, S)), np.zeros((E, S)), np.zeros((E, S))
    state, regime = np.full((E, S), -1, np.int64), np.empty(E, np.int64)
    T, B16 = kernel_tables(H)
    segments_all(U, V, *element_arrays(elem), T, B16, a, b, state, w, regime)
    Nc = elem.kv[:, None] * V
    Nc[:, 0] += elem.n0
    return dict(a=a, b=b, state=state, w=w, regime=regime, Nc=Nc)


def history(U, V, elem: YangMenq, tau) -> dict:
    """Periodic time history of every element at the instants `tau` (K,), from this
    module's `periodic_segments` (`element.history_from_segments`)."""
    E = elem.size
    U = check_coefficients("U", U, E)
    V = check_coefficients("V", V, E)
    return history_from_segments(U, V, elem, tau, periodic_segments(U, V, elem))
