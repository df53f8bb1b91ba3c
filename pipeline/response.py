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


def _initial_guess(prob, Om, contact):
    """Linear solutions with the contacts open and stuck; Newton picks the better."""
    from .hbm import real_vector, linear_part, residual
    nh, nc = prob.nh, prob.c.size
    St, _, Pt, _ = linear_part(prob, Om, derivatives=False)
    guesses = []
    for stuck in (False, True):
        xs = []
        for h in range(prob.H + 1):
            A = St[h].copy()
            if stuck:
                # linearised contact stiffness: ku along t, kv along n (assembled)
                bt, bn, idx = prob.bt, prob.bn, prob.idx
                Kc = np.zeros((nc, nc))
                for e in range(idx.shape[0]):
                    Kc[np.ix_(idx[e], idx[e])] += (contact.ku[e] * np.outer(bt[e], bt[e])
                                                   + contact.kv[e] * np.outer(bn[e], bn[e]))
                A = A + Kc
            try:
                xs.append(np.linalg.solve(A, Pt[h]))
            except np.linalg.LinAlgError:
                xs.append(np.linalg.lstsq(A, Pt[h], rcond=None)[0])
        guesses.append(real_vector(np.array(xs), nh).ravel())
    norms = [np.linalg.norm(residual(prob, g, Om, contact, jacobian=False)[0]) for g in guesses]
    return guesses[int(np.argmin(norms))]


def frequency_response(system, H, omega_start, omega_end, *, method="exact", n_samples=256,
                       stability=True, tol_rel=1e-9, ds=0.02, ds_max=0.1, max_points=1000,
                       contact=None, callback=None) -> ResponseCurve:
    """Trace the periodic response over Omega in [omega_start, omega_end] [rad/s].

    Pseudo-arclength continuation (`continuation.continue_branch`) of the condensed
    HBM residual (`hbm.residual`), all DOFs recovered, each point's full residual
    recomputed (converged iff <= tol_rel * force_scale [N]), Hill stability of the
    full system at every point (`stability.is_stable`).
    """
    import time

    from . import hbm
    from .continuation import continue_branch, newton

    t_start = time.perf_counter()
    prob = hbm.setup(system, H, method, n_samples)
    elem = contact if contact is not None else system.contact
    tol = tol_rel * hbm.force_scale(prob, elem)
    x0 = _initial_guess(prob, omega_start, elem)
    nr = newton(lambda x: hbm.residual(prob, x, omega_start, elem)[:2], x0, tol, max_iter=60)
    fun = lambda x, lam: hbm.residual(prob, x, lam, elem)  # noqa: E731
    br = continue_branch(fun, nr.x, omega_start, omega_end, tol=tol, ds=ds, ds_max=ds_max,
                         max_points=max_points, callback=callback)
    return _curve_from_branch(prob, br, elem, tol, stability, lambda lam: lam,
                              time.perf_counter() - t_start, nr.nfev)


def _curve_from_branch(prob, br, elem, tol, stability, omega_of, elapsed, extra_nfev):
    import time

    from . import hbm
    from .harmonics import amplitude_half_peak_to_peak
    from .stability import is_stable

    t0 = time.perf_counter()
    P = br.lam.size
    n, nh = prob.system.n_dof, prob.nh
    Q = np.zeros((P, n, nh))
    res = np.zeros(P)
    stable = np.ones(P, bool)
    omega = np.array([omega_of(l) for l in br.lam], dtype=float)
    for i in range(P):
        Qc = br.x[i].reshape(prob.c.size, nh)
        Q[i] = hbm.recover(prob, Qc, omega[i])
        res[i] = np.linalg.norm(hbm.full_residual(prob, Q[i], omega[i], elem))
        if stability:
            J = hbm.full_jacobian(prob, Q[i], omega[i], elem)
            stable[i] = is_stable(J, hbm._dense(prob.system.M), hbm._dense(prob.system.C),
                                  omega[i], prob.H)[0]
    converged = np.asarray(br.converged, bool) & (res <= tol) & np.isfinite(res)
    amp = amplitude_half_peak_to_peak(Q) if P else np.zeros((0, n))
    return ResponseCurve(
        parameter=np.asarray(br.lam, float), omega=omega, Q=Q, converged=converged,
        residual=res, stable=stable, amplitude=amp,
        fold_parameter=np.asarray(br.fold_lam, float),
        newton_iterations=np.asarray(br.nit), nfev=int(br.nfev + extra_nfev),
        wall_time=elapsed + time.perf_counter() - t0, success=bool(br.success),
        status=int(br.status), message=str(br.message), H=prob.H, tolerance=tol,
        info={"njev": int(br.njev), "n_rejected": int(br.n_rejected),
              "solve_time": elapsed, "postprocess_time": time.perf_counter() - t0})
