"""Linear scenes (no friction, no separation): solved directly, per frequency.

Without contact forces the harmonic balance (paper Eq. 7 with f = 0) decouples
into one complex linear system per excited harmonic h:

    [K - (h Omega)^2 M + i h Omega C] X_h = F_h,     x(t) = Re sum_h X_h e^{i h Omega t}

so there is no Newton iteration and no continuation: the frequency grid is chosen
up front (uniform, plus points clustered at the natural frequencies), the peak of
every reported DOF is located by a bounded scalar search, and each point's
residual is recomputed in N and held to the same tolerances as the nonlinear path
(`hbm.tolerances`).  Stability does not depend on Omega: the state matrix's
eigenvalues are computed once.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla
from scipy.optimize import minimize_scalar

from ...fourier.harmonics import amplitude_half_peak_to_peak
from ..harmonic_balance import roundoff
from .response import ResponseCurve
from ...model.system import System, coupled_matrix, dense, inertia_coupled, natural_frequencies
from ..harmonic_balance.dynamic_stiffness import at_frequency, harmonic_matrices, stiffness_stack

BASE_POINTS = 201                     # uniform part of the grid
CLUSTER = np.array([-3e-2, -1e-2, -3e-3, -1e-3, 0.0, 1e-3, 3e-3, 1e-2, 3e-2])  # relative offsets


def is_linear(system: System) -> bool:
    """True when the system has no contact element: nothing nonlinear to solve."""
    return system.n_elements == 0


def _solve(Ms, Cs, Ks, F, H, omega):
    """Q (n, 2H+1) in the real layout and the residual parts (static, harmonic) [N];
    Ks[h], Ms[h], Cs[h] the stiffness, mass and damping of harmonic h
    (`dynamic_stiffness.stiffness_stack`, `harmonic_matrices`); the dynamic stiffness of
    harmonic h from `dynamic_stiffness.at_frequency`."""
    n = Ks[0].shape[0]
    K = Ks[0]
    Q = np.zeros((n, 2 * H + 1))
    r_static = r_dyn = 0.0
    if np.any(F[:, 0]):
        x0 = np.linalg.solve(K, F[:, 0].real)
        Q[:, 0] = x0
        r_static = float(np.linalg.norm(K @ x0 - F[:, 0].real))
    for h in range(1, min(H, F.shape[1] - 1) + 1):
        if not np.any(F[:, h]):
            continue
        D = at_frequency(Ks[h], Ms[h], Cs[h], h * omega)
        X = np.linalg.solve(D, F[:, h])
        Q[:, 2 * h - 1], Q[:, 2 * h] = X.real, -X.imag
        r_dyn += float(np.linalg.norm(D @ X - F[:, h]) ** 2)
    return Q, r_static, float(np.sqrt(r_dyn))


def wave_matrices(system: System) -> list:
    """(M, C, K) of every wave number r = 0..N/2 of perturbation of a cyclic sector
    (angle 2 pi r / N, `coupled_matrix`; just the system's otherwise): the linear
    structure is stable iff each is."""
    cy = system.cyclic
    angles = [0.0] if cy is None else [2 * np.pi * r / cy.sectors
                                       for r in range(cy.sectors // 2 + 1)]
    return [tuple(dense(coupled_matrix(system, name, a)) for name in "MCK") for a in angles]



def _asymptotically_stable(M, C, K) -> bool:
    """All eigenvalues of [[0, I], [-M^-1 K, -M^-1 C]] in the open left half plane."""
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = sla.eigvals(A)
    return bool(np.max(lam.real) < -1e-12 * max(1.0, float(np.max(np.abs(lam)))))


def frequency_grid(system: System, omega_start, omega_end, n_base=BASE_POINTS):
    """Uniform points plus a cluster at each natural frequency inside the range [rad/s]."""
    lo, hi = sorted((float(omega_start), float(omega_end)))
    grid = [np.linspace(lo, hi, n_base)]
    wn = natural_frequencies(system, "open")
    for w in wn[(wn > lo) & (wn < hi)]:
        grid.append(w * (1.0 + CLUSTER))
    g = np.unique(np.clip(np.concatenate(grid), lo, hi))
    return g if omega_end >= omega_start else g[::-1]


def frequency_response(system: System, H, omega_start, omega_end, *, tol_rel=1e-10,
                       stability=True, peak_dofs=None, **_continuation_settings) -> ResponseCurve:
    """The response of a linear system over [omega_start, omega_end] [rad/s], with the
    same result type as `response.frequency_response` (no Newton: iterations 0).

    Continuation settings (step sizes, force evaluation) have nothing to act on
    and are accepted and ignored, so a study's [solver] table applies unchanged.
    """
    if not is_linear(system):
        raise ValueError(f"the system has {system.n_elements} contact element(s): "
                         "use response.frequency_response")
    t0 = time.perf_counter()
    # dense even for sparse input: the grid needs every natural frequency and the
    # stability every eigenvalue of the state matrix (dense eigen-solves anyway)
    Ks = stiffness_stack(system, H)
    Ms, Cs = ((harmonic_matrices(system, name, H) for name in "MC") if inertia_coupled(system)
              else ([dense(system.M)] * (H + 1), [dense(system.C)] * (H + 1)))
    F = np.zeros((system.n_dof, H + 1), complex)
    Fh = np.asarray(system.forcing, complex)
    F[:, :min(H + 1, Fh.shape[1])] = Fh[:, :H + 1]
    d = float(np.linalg.norm(F[:, 1:]))
    s = float(np.linalg.norm(F[:, 0])) + d or 1.0
    tols = (tol_rel * s, tol_rel * (d or s))

    def amp(om, dof):
        return amplitude_half_peak_to_peak(_solve(Ms, Cs, Ks, F, H, om)[0][None])[0, dof]

    grid = list(frequency_grid(system, omega_start, omega_end))
    dofs = range(system.n_dof) if peak_dofs is None else peak_dofs
    n_search = 0
    for dof in dofs:  # exact peaks: bounded search around each local maximum on the grid
        a = np.array([amp(om, dof) for om in grid])
        for i in range(1, len(grid) - 1):
            if a[i] >= a[i - 1] and a[i] >= a[i + 1] and a[i] > 0:
                lo, hi = sorted((grid[i - 1], grid[i + 1]))
                r = minimize_scalar(lambda om: -amp(om, dof), bounds=(lo, hi), method="bounded",
                                    options={"xatol": 1e-12 * hi})
                n_search += int(r.nfev)
                grid.append(float(r.x))
    om = np.unique(grid)
    if omega_end < omega_start:
        om = om[::-1]
    P, n = om.size, system.n_dof
    Q = np.zeros((P, n, 2 * H + 1))
    residual = np.zeros(P)
    ok = np.zeros(P, bool)
    n_floor = 0
    for i, w in enumerate(om):
        Q[i], rs, rd = _solve(Ms, Cs, Ks, F, H, w)
        residual[i] = np.hypot(rs, rd)
        ok[i] = rs <= tols[0] and rd <= tols[1]
        if not ok[i] and np.isfinite(Q[i]).all():   # a tolerance below round-off
            fs, fd = roundoff.linear_floor(system, Q[i], w, system.forcing_coefficients(H))
            ok[i] = rs <= max(tols[0], fs) and rd <= max(tols[1], fd)
            n_floor += int(ok[i])
    ok &= np.isfinite(Q).all(axis=(1, 2))
    stable = np.full(P, all(_asymptotically_stable(*MCK) for MCK in wave_matrices(system))
                     if stability else True)
    n_bad = int(P - ok.sum())
    return ResponseCurve(
        parameter=om.copy(), omega=om, Q=Q, converged=ok, residual=residual, stable=stable,
        amplitude=amplitude_half_peak_to_peak(Q), fold_parameter=np.zeros(0),
        newton_iterations=np.zeros(P, int), nfev=0, wall_time=time.perf_counter() - t0,
        success=n_bad == 0, status=0 if n_bad == 0 else -3,
        message=("linear scene: direct solve per frequency (no Newton, no continuation)"
                 if n_bad == 0 else f"linear scene: {n_bad} point(s) above the residual tolerance"),
        H=int(H), tolerance=float(np.hypot(*tols)),
        info={"solver": "linear_direct", "peak_search_solves": n_search,
              "resonance_guard": True, "unresolved_resonance_steps": 0,  # grid at every w_n
              "tol_static": tols[0], "tol_dynamic": tols[1], "roundoff_points": n_floor})
