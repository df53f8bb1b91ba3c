"""Resonances between two branch points: a Sturm (Wittrick-Williams) count.

A continuation step that is long compared with a resonance's width can jump over
it: both ends of the step are far from the peak, Newton converges at once (a
linear branch converges in one iteration), and nothing in the corrector notices.
This module tells whether a resonance lies inside a step, without sampling it.

At a branch point (Q, Omega) the contact elements have a tangent stiffness per
harmonic h (the h-block of dG/dQ, paper Eq. 9-11 differentiated): written as a
complex matrix Z_h = P_h + i Q_h on the contact DOFs (the real 2x2 block
[[p, q], [-q, p]] of the cos/sin layout is p + i q), its Hermitian part is the
effective stiffness the contact adds at that harmonic (ku, kv where stuck, less
where it slips or separates, 0 where open) and its anti-Hermitian part the
dissipation.  The number of natural frequencies of the locally linearised
structure below h Omega is the number of negative eigenvalues of

    D_h(Omega) = K + Herm(Z_h) - (h Omega)^2 M        (Sylvester's law of inertia)

(Wittrick & Williams 1971 count natural frequencies of a structure the same way).
Between two points whose counts differ, h Omega crossed a natural frequency w_k of
the linearised structure: a resonance (of the stuck or open linear limit on a
linear branch, of the backbone of a nonlinear one) lies inside the step.  Such a
step is admissible only if it resolves that resonance: the detuning
g = w_k - h Omega changes over the step by at most the half-power width
2 zeta_k h Omega, so both ends lie inside the half-power band (for a linear branch
in frequency: a step of at most 2 zeta_k Omega).  zeta_k is the smaller damping
ratio of mode k of the bounding linear systems (contacts open, contacts closed);
friction and impact only add dissipation, so a real resonance is at least that
wide.  The rule holds for any continuation parameter (frequency or preload).
Only the excited harmonics are counted: they carry the primary resonances, the
only ones a linear branch has.

Contact laws (`contact.laws`): the count reads every law's tangent stiffness from
`hbm.contact_terms`, so it holds for any law with a Jacobian.  The bounding linear
systems are those of the Yang-Menq elements; a further law (`System.laws`, e.g. a
hardening spring, whose tangent stiffness has no upper limit) also takes zeta_k no
larger than the damping ratio of the structure linearised at each end of the step.

A structure of independent parts (a full wheel on a rigid disk, `parts`) is
counted part by part and its few frequencies near h Omega found by a sparse
shift-invert solve (`part_spectrum`), with no dense matrix of the whole; its
damping ratios are the modal ones of the linearised structure at both ends.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.linalg as sla

from ...model.system import (coupled_matrix, coupled_stiffness, dense, inertia_coupled,
                             stiffness_along)
from ..harmonic_balance import hbm
from ..harmonic_balance.part_spectrum import PartSpectrum, negative_eigenvalues, part_spectra

MAX_DENSE_DOF = 3000   # above this the count (a dense eigen-solve per point) is skipped
WIDTH_FLOOR = 1e-6     # smallest width resolved, relative to Omega (zeta = 0 structures)


@dataclass(frozen=True)
class ResonanceCount:
    """What the count needs of a problem, prepared once (plain arrays)."""

    K: np.ndarray | None    # (n, n) structural stiffness [N/m] (None: counted by parts)
    M: np.ndarray | None    # (n, n) mass [kg]
    harmonics: tuple        # excited harmonics h >= 1
    zeta: np.ndarray | None  # (n,) smallest modal damping ratio of mode i, open or closed [-]
    parts: object = None    # part_spectrum.PartSpectra of a structure of independent parts
    masses: dict | None = None  # h -> (n, n) mass of harmonic h [kg] (a mass-coupled sector)


class DenseSpectrum:
    """The natural frequencies of one linearised structure, stiffness K (Hermitian,
    dense) and mass M [kg], with the damping ratios zeta [-] of its modes, computed
    on demand and kept (a memo of one point): `count(w)`, the number below w
    [rad/s], by the inertia of K - w|w| M (`negative_eigenvalues`, a fifth of the
    cost of the eigenvalues; most steps cross no resonance and need only the
    counts), and `mode(k)`, (w_k [rad/s], zeta_k [-]) of the k-th (from 0), from
    all eigenvalues, solved at the first call."""

    def __init__(self, K, M, zeta):
        self.K, self.M, self.zeta = K, M, zeta
        self.counts, self.w = {}, None

    def count(self, w: float) -> int:
        w = float(w)
        if w not in self.counts:
            self.counts[w] = (int(np.sum(self.w < w)) if self.w is not None
                              else negative_eigenvalues(self.K - (w * abs(w)) * self.M))
        return self.counts[w]

    def mode(self, k: int) -> tuple:
        if self.w is None:
            lam = sla.eigh(self.K, self.M, eigvals_only=True, check_finite=False)
            self.w = np.sign(lam) * np.sqrt(np.abs(lam))
        return float(self.w[k]), float(self.zeta[k]) if k < self.zeta.size else 0.0


def modal_damping(M, C, K) -> np.ndarray:
    """Damping ratios zeta_i of the modes of M q'' + C q' + K q = 0, in the order of
    their natural frequencies |lambda_i| (state-space eigenvalues, any damping)."""
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = sla.eigvals(A)
    lam = lam[lam.imag >= 0]  # one of each conjugate pair (overdamped pairs: both real)
    lam = lam[np.argsort(np.abs(lam))][:n]
    mag = np.abs(lam)
    zeta = np.where(mag > 0, -lam.real / np.where(mag > 0, mag, 1.0), 1.0)
    out = np.ones(n)
    out[:zeta.size] = zeta
    return out


def closed_stiffness(system) -> np.ndarray:
    """K plus every contact element closed and stuck (ku along Bt, kv along Bn,
    whatever the preload): the stiffest linear limit of the structure [N/m]."""
    el = system.contact
    return dense(system.K) + stiffness_along(system.Bt, el.ku) + stiffness_along(system.Bn, el.kv)


def prepare(prob: hbm.HBMProblem) -> ResonanceCount | None:
    """The count's data for a problem; None when it does not apply (no excited
    harmonic, or more than MAX_DENSE_DOF DOFs that do not fall into parts)."""
    sys = prob.system
    F = np.asarray(sys.forcing)
    harmonics = tuple(h for h in range(1, min(prob.H, F.shape[1] - 1) + 1) if np.any(F[:, h]))
    if harmonics and prob.parts is not None and sys.cyclic is None:
        return ResonanceCount(None, None, harmonics, None, part_spectra(sys, prob.parts, prob.c))
    if not harmonics or sys.n_dof > MAX_DENSE_DOF:
        return None
    # the count needs every natural frequency and damping ratio of the whole structure
    # (dense eigen-solves, n^2 x 8 bytes per matrix, sparse storage or not): capped
    # by MAX_DENSE_DOF
    K, M, C = dense(sys.K), dense(sys.M), dense(sys.C)
    # with a linear inter-sector coupling: its first harmonic's real part for the
    # damping estimate (the count below uses each harmonic's Hermitian stiffness)
    coupled = sys.cyclic is not None and sys.cyclic.K_next is not None
    K1 = np.real(coupled_stiffness(sys, sys.cyclic.phase)) if coupled else K
    masses = None
    if inertia_coupled(sys):   # a flexible disk's sector: M and C of each harmonic too
        phi = sys.cyclic.phase
        masses = {h: dense(coupled_matrix(sys, "M", h * phi)) for h in harmonics}
        M, C = (np.real(dense(coupled_matrix(sys, name, phi))) for name in "MC")
    zeta = np.minimum(modal_damping(M, C, K1), modal_damping(M, C, closed_stiffness(sys) + K1 - K))
    return ResonanceCount(K, M, harmonics, np.maximum(zeta, 0.0), masses=masses)


def contact_stiffness(prob: hbm.HBMProblem, Qc, contact, h: int, sparse: bool = False):
    """Complex tangent stiffness Z_h (nc, nc) of the contacts at harmonic h [N/m]
    (sparse: scipy.sparse CSR, for a wheel of parts)."""
    nc = prob.c.size
    if prob.slot_index.shape[0] == 0:
        return sp.csr_matrix((nc, nc), dtype=complex) if sparse else np.zeros((nc, nc), complex)
    _, Je, _ = hbm.contact_terms(prob, Qc, contact, jacobian=True, blocks=True)
    a, b = 2 * h - 1, 2 * h
    z = 0.5 * (Je[..., a, a] + Je[..., b, b]) + 0.5j * (Je[..., a, b] - Je[..., b, a])
    idx = prob.slot_index
    E, m = idx.shape
    ia = np.broadcast_to(idx[:, :, None], (E, m, m))
    ib = np.broadcast_to(idx[:, None, :], (E, m, m))
    if sparse:   # duplicates summed
        return sp.csr_matrix((z.ravel(), (ia.ravel(), ib.ravel())), shape=(nc, nc))
    Z = np.zeros((nc, nc), complex)
    np.add.at(Z, (ia, ib), z)
    return Z


def natural_frequencies(rc: ResonanceCount, prob: hbm.HBMProblem, x, contact,
                        Om: float | None = None) -> tuple:
    """Natural frequencies of the structure linearised at x, per excited harmonic h
    (the contacts' tangent stiffness depends on h): a tuple, in the order of
    rc.harmonics, of spectra with `count(w)` and `mode(k)` (`DenseSpectrum`, or for
    parts a `PartSpectrum` near h Om)."""
    Qc = np.asarray(x, float).reshape(prob.c.size, prob.nh)
    if rc.parts is not None:
        return tuple(PartSpectrum(rc.parts, contact_stiffness(prob, Qc, contact, h, True),
                                  h * Om)
                     for h in rc.harmonics)
    cc = np.ix_(prob.c, prob.c)
    out = []
    cy = prob.system.cyclic
    for h in rc.harmonics:
        Z = contact_stiffness(prob, Qc, contact, h)
        K = (rc.K if cy is None or cy.K_next is None
             else coupled_stiffness(prob.system, h * cy.phase)).astype(complex)
        K[cc] += 0.5 * (Z + Z.conj().T)
        zeta = rc.zeta
        if prob.laws:   # no open/stuck limits bound these laws: also this point's damping
            zeta = np.minimum(zeta, modal_damping(rc.M, dense(prob.system.C), K.real))
        M = rc.M if rc.masses is None else rc.masses[h]
        out.append(DenseSpectrum(K if np.any(K.imag) else K.real,
                                 M if np.any(np.imag(M)) else np.real(M), zeta))
    return tuple(out)


def counts(rc: ResonanceCount, prob: hbm.HBMProblem, x, Om, contact) -> tuple:
    """Number of natural frequencies of the linearised structure below h Omega, for
    each excited harmonic h (tuple of ints, in the order of rc.harmonics)."""
    return tuple(w.count(h * Om) for h, w
                 in zip(rc.harmonics, natural_frequencies(rc, prob, x, contact, Om)))


def crossed(rc: ResonanceCount, w_a, Om_a, w_b, Om_b) -> list:
    """(h, mode index) of every natural frequency w_k / h that Omega passes between
    two points (spectra w_a, w_b per harmonic as `natural_frequencies`)."""
    out = []
    for h, wa, wb in zip(rc.harmonics, w_a, w_b):
        ka, kb = wa.count(h * Om_a), wb.count(h * Om_b)
        out += [(h, k) for k in range(min(ka, kb), max(ka, kb))]
    return out


def detuning_ratio(rc: ResonanceCount, modes, w_a, Om_a, w_b, Om_b) -> float:
    """Largest change of the detuning g = w_k - h Omega between two points, over the
    half-power width 2 zeta_k h Omega of the resonance, among `modes` [(h, k)]:
    <= 1 when the step resolves every one of those resonances."""
    idx = {h: i for i, h in enumerate(rc.harmonics)}
    ratio = 0.0
    for h, k in modes:
        i = idx[h]
        (wa, za), (wb, zb) = w_a[i].mode(k), w_b[i].mode(k)
        change = abs((wb - h * Om_b) - (wa - h * Om_a))
        zeta = max(min(za, zb), 0.5 * WIDTH_FLOOR)
        ratio = max(ratio, change / (2.0 * zeta * h * 0.5 * (Om_a + Om_b)))
    return ratio


def step_guard(prob: hbm.HBMProblem, contact_of, omega_of=lambda lam: lam):
    """segment_check(x0, lam0, x1, lam1) for `continuation.continue_branch`; lam is the
    frequency, or any parameter with Omega = omega_of(lam) and contact elements
    contact_of(lam) (e.g. the preload).

    None when no resonance is crossed or the step resolves each one crossed (the
    detuning w_k - h Omega changes by at most the half-power width over the step:
    both ends lie inside the resonance's half-power band), else the admissible
    |lam1 - lam0| estimated by linear interpolation of the detuning.  The step
    after a crossing is held to the same rule for the modes just crossed, so a
    resonance has points inside its band on both sides.  None (no guard) if the
    count does not apply (`prepare`)."""
    rc = prepare(prob)
    if rc is None:
        return None
    memo = {}
    near = {"at": None, "modes": []}

    def freqs(x, lam):
        key = (float(lam), np.asarray(x, float).tobytes())
        if key not in memo:
            if len(memo) > 64:
                memo.clear()
            memo[key] = natural_frequencies(rc, prob, x, contact_of(lam), omega_of(lam))
        return memo[key]

    def check(x0, lam0, x1, lam1):
        Om0, Om1 = omega_of(lam0), omega_of(lam1)
        w0, w1 = freqs(x0, lam0), freqs(x1, lam1)
        modes = crossed(rc, w0, Om0, w1, Om1)
        held = modes + (near["modes"] if near["at"] == float(lam0) else [])
        ratio = detuning_ratio(rc, held, w0, Om0, w1, Om1)
        if ratio <= 1.0:
            near.update(at=float(lam1) if modes else None, modes=modes)
            return None
        return abs(lam1 - lam0) / ratio

    check.frequencies = freqs
    return check
