"""Forced responses synthesised from one nonlinear mode (single-nonlinear-mode theory,
Krack 2015, with the mode's dissipation split into its viscous and its friction part).

Near a resonance of a well separated mode the forced motion is taken as the nonlinear
mode at the amplitude a it reaches, q(t) = a Psi(a) at the excitation's frequency
Omega.  Projecting the first harmonic of the equation of motion onto the mode's first
harmonic Psi_1 = Psi_1c - i Psi_1s (complex, `epmc`), and subtracting the EPMC
equation the mode satisfies at its own frequency omega, gives the modal equation

    [(omega^2 - Omega^2) m_1 + i ((Omega - omega) c_1 + 2 zeta omega^2 m_1)] a
        = Psi_1^H F_1 e^{-i theta},
    m_1 = Psi_1^H M Psi_1,  c_1 = Re Psi_1^H C Psi_1,

F_1 the complex first-harmonic load [N] (a cyclic sector's engine-order load, the
mode the travelling wave of that nodal diameter).  The viscous part c_1 scales with
the frequency, the friction forces' part 2 zeta omega^2 m_1 - c_1 omega does not (they
are rate independent): for one DOF and one harmonic this is exact; Krack's viscous
form 2 zeta omega Omega m_1 is the same where Omega = omega.  With r = |Psi_1^H F_1| / a
the frequencies at which the amplitude a is reached are the positive roots Omega of

    ((omega^2 - Omega^2) m_1)^2 + ((Omega - omega) c_1 + 2 zeta omega^2 m_1)^2 = r^2,

and the peak is the largest a with a root.  Any force level, for any load and preload
already on a backbone: no further harmonic balance.  What it neglects (the other
modes' contributions, higher harmonics of the load) is what the comparison with the
full harmonic balance on the same scene shows.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from ...fourier.harmonics import amplitude_half_peak_to_peak
from .backbone import Backbone, continue_mode, point_at
from .epmc import ModeProblem, mode_problem, onset_amplitude


@dataclass(frozen=True)
class Synthesis:
    """The synthesised forced response along the backbone's points (P,): `below` and
    `above` the frequencies [rad/s] at which each amplitude is reached (NaN where it is
    not), `modal_force` |Psi_1^H F_1| [N kg^-0.5], and the peak: the modal amplitude
    `peak_amplitude` [kg^0.5 m] and frequency `peak_omega` [rad/s] (NaN when the
    backbone does not reach it)."""

    below: np.ndarray
    above: np.ndarray
    modal_force: np.ndarray
    peak_s: float
    peak_omega: float
    peak_index: int = -1     # the peak lies between backbone points peak_index and + 1

    @property
    def peak_amplitude(self) -> float:
        return 10.0 ** self.peak_s


def first_harmonic(bb: Backbone) -> np.ndarray:
    """(P, n) complex first harmonic of the shape, Psi_1 = (Q_1c - i Q_1s) / a."""
    return (bb.Q[:, :, 1] - 1j * bb.Q[:, :, 2]) / bb.amplitude[:, None]


def modal_quantities(bb: Backbone, M, C, F1):
    """(|Psi_1^H F_1| [N kg^-0.5], m_1 [-], c_1 [s^-1]) per backbone point; F1 (n,)
    complex [N]."""
    psi = first_harmonic(bb)
    m1 = np.einsum("pi,ij,pj->p", psi.conj(), np.asarray(M, float), psi).real
    c1 = np.einsum("pi,ij,pj->p", psi.conj(), np.asarray(C, float), psi).real
    return np.abs(psi.conj() @ np.asarray(F1, complex)), m1, c1


def _quartic(omega, zeta, m1, c1):
    """Coefficients (P, 5) (Omega^4 .. Omega^0) of the left side of the modal equation."""
    omega, zeta, m1, c1 = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float))
                                                for v in (omega, zeta, m1, c1)))
    d = 2.0 * zeta * omega**2 * m1 - c1 * omega
    return np.stack([m1**2, np.zeros_like(m1), c1**2 - 2.0 * omega**2 * m1**2,
                     2.0 * c1 * d, omega**4 * m1**2 + d**2], axis=-1)


def _roots(co):
    """(P, d) roots of the P polynomials co (P, d + 1), highest power first: the
    eigenvalues of their companion matrices, in one batched call."""
    P, d = co.shape[0], co.shape[1] - 1
    comp = np.zeros((P, d, d))
    comp[:, 0, :] = -co[:, 1:] / co[:, :1]
    comp[:, np.arange(1, d), np.arange(d - 1)] = 1.0
    return np.linalg.eigvals(comp)


def _positive_real(roots):
    """The roots that are real (to 1e-9 relative) and positive; NaN elsewhere."""
    real = (np.abs(roots.imag) <= 1e-9 * np.abs(roots)) & (roots.real > 0)
    return np.where(real, roots.real, np.nan)


def frequencies(omega, zeta, m1, c1, r):
    """(below, above) [rad/s]: the smallest and largest root Omega > 0 of the modal
    equation at amplitude-scaled force r, NaN where there is none (above the peak).
    `below` is NaN too where the amplitude is under the quasi-static one (the left
    side at Omega = 0 does not exceed r^2): the response never falls to it below the
    resonance, and the one root left lies above it."""
    co = _quartic(omega, zeta, m1, c1)
    co[:, -1] -= np.atleast_1d(np.asarray(r, float)) ** 2
    below, above = _ends(_positive_real(_roots(co)))
    return np.where(co[:, -1] > 0, below, np.nan), above


def _ends(x):
    """(smallest, largest) of each row of x, NaN where a row has no number."""
    none = np.all(np.isnan(x), axis=1)
    lo = np.where(none, np.nan, np.min(np.where(np.isnan(x), np.inf, x), axis=1))
    hi = np.where(none, np.nan, np.max(np.where(np.isnan(x), -np.inf, x), axis=1))
    return lo, hi


def peak_gap(omega, zeta, m1, c1, r):
    """(r^2 - min over Omega > 0 of the left side, the minimising Omega [rad/s]) per
    point: positive below the peak amplitude, zero at it."""
    co = _quartic(omega, zeta, m1, c1)
    crit = _positive_real(_roots(co[:, :-1] * np.arange(4, 0, -1)))
    vals = np.where(np.isnan(crit), np.inf, sum(co[:, [k]] * np.nan_to_num(crit) ** (4 - k)
                                                for k in range(5)))
    i = np.argmin(vals, axis=1)
    rows = np.arange(co.shape[0])
    return np.atleast_1d(np.asarray(r, float)) ** 2 - vals[rows, i], crit[rows, i]


def synthesise(bb: Backbone, M, C, F1, refine=None) -> Synthesis:
    """The forced response to the first-harmonic load F1 (n,) [N] synthesised from the
    backbone `bb` of a system with mass M and damping C.  The peak lies between the
    last backbone point below it and the next (the first such pair along a backbone
    that folds); `refine(s, i)` (a one-point `Backbone`, the mode recomputed at s
    between points i and i + 1, `refiner`) locates it by Brent's method to 1e-12 in s, else it
    is interpolated linearly in s."""
    f, m1, c1 = modal_quantities(bb, M, C, F1)
    r = f / bb.amplitude
    below, above = frequencies(bb.omega, bb.zeta, m1, c1, r)
    g, at = peak_gap(bb.omega, bb.zeta, m1, c1, r)
    cross = np.nonzero((g[:-1] > 0) & (g[1:] <= 0))[0]
    if cross.size == 0:
        return Synthesis(below, above, f, np.nan, np.nan)
    i = int(cross[0])
    if refine is None:
        t = g[i] / (g[i] - g[i + 1])
        return Synthesis(below, above, f, float(bb.s[i] + t * (bb.s[i + 1] - bb.s[i])),
                         float(at[i] + t * (at[i + 1] - at[i])), i)

    def gap(s):
        one = refine(s, i)
        fs, ms, cs = modal_quantities(one, M, C, F1)
        return peak_gap(one.omega, one.zeta, ms, cs, fs / one.amplitude)

    s = brentq(lambda s: gap(s)[0][0], *sorted((bb.s[i], bb.s[i + 1])), xtol=1e-12,
               rtol=1e-14)
    return Synthesis(below, above, f, float(s), float(gap(s)[1][0]), i)


def refiner(mp: ModeProblem, bb: Backbone, tol_rel: float = 1e-10):
    """`synthesise`'s `refine`: the mode recomputed at s between the points i and i + 1
    (`backbone.point_at`) as a one-point `Backbone`."""
    def refine(s, i):
        om, ze, Q = point_at(mp, bb, s, tol_rel, segment=i)
        return Backbone(np.array([s]), np.array([om]), np.array([ze]), Q[None],
                        np.zeros(1), np.zeros(1), np.zeros(1, int))
    return refine


def synthesised_curve(system, H: int, dof: int, method: str = "exact", n_samples: int = 256,
                      tol_rel: float = 1e-9, span=(0.01, 1000.0)) -> dict:
    """The forced response of `system` to its own first-harmonic load synthesised from
    its first nonlinear mode (backbone over `span` slip onsets): `omega` [rad/s] and
    `amplitude` [m] of DOF `dof` along the curve (the lower flank with the amplitude
    rising, the peak of the modal amplitude located exactly, then the upper flank
    back), `harmonic_amplitude` (P, H+1) [m], the largest amplitude of the DOF on it
    (`peak_amplitude` [m], `peak_omega` [rad/s]), `folds` [rad/s] (where a flank turns,
    at the backbone's points) and `message`."""
    mp = mode_problem(system, H, 0, method, n_samples)
    a = onset_amplitude(mp)
    a = a if np.isfinite(a) else 1.0
    bb = continue_mode(mp, np.log10(span[0] * a), np.log10(span[1] * a), tol_rel=tol_rel)
    F1 = np.asarray(system.forcing, complex)[:, 1]
    syn = synthesise(bb, mp.M, mp.C, F1, refine=refiner(mp, bb, tol_rel))
    amp = np.array([amplitude_half_peak_to_peak(Q)[dof] for Q in bb.Q])
    Qd = bb.Q[:, dof, :]
    harm = np.column_stack([np.abs(Qd[:, 0]), np.hypot(Qd[:, 1::2], Qd[:, 2::2])])
    folds = []
    for flank in (syn.below, syn.above):
        ok = np.isfinite(flank)
        d = np.diff(flank[ok])
        turns = np.nonzero(d[:-1] * d[1:] < 0)[0] + 1
        folds += list(flank[ok][turns])
    order = np.r_[np.arange(bb.s.size), np.arange(bb.s.size)[::-1]]
    omega, amp, harm = np.r_[syn.below, syn.above[::-1]], amp[order], harm[order]
    if np.isfinite(syn.peak_s):   # the peak of the modal amplitude joins the two flanks
        _, _, Q = point_at(mp, bb, syn.peak_s, tol_rel, segment=syn.peak_index)
        k = bb.s.size
        Qp = Q[dof]
        omega = np.r_[omega[:k], syn.peak_omega, omega[k:]]
        amp = np.r_[amp[:k], amplitude_half_peak_to_peak(Q)[dof], amp[k:]]
        harm = np.vstack([harm[:k], np.r_[abs(Qp[0]), np.hypot(Qp[1::2], Qp[2::2])], harm[k:]])
    drawn = np.isfinite(omega)
    i = int(np.argmax(np.where(drawn, amp, -np.inf))) if drawn.any() else None
    return {"omega": omega, "amplitude": amp, "harmonic_amplitude": harm,
            "peak_amplitude": np.nan if i is None else float(amp[i]),
            "peak_omega": np.nan if i is None else float(omega[i]),
            "folds": np.sort(np.asarray(folds, float)), "message": bb.message}
