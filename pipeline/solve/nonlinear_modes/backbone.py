"""A nonlinear mode continued in the modal amplitude: the backbone omega(a), the modal
damping ratio zeta(a) and the shape, from the small-amplitude linear mode through
microslip, macroslip and separation (`epmc` gives the equations).

Continuation in s = log10 a with a secant predictor and Newton's method on the
EPMC equations (analytic Jacobian, backtracking on the residual norm); the step in s
grows after easy points and halves after a failed one.  Every point is accepted only if
its recomputed residual meets the tolerance in newtons (`epmc.check`).  Where the step
falls below `min_step` decades (the amplitude turns back: an internal resonance, or a
normalisation that degenerates) the backbone ends there and says so in `message`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .epmc import ModeProblem, check_values, evaluate, linear_guess, unpack


@dataclass(frozen=True)
class Backbone:
    """Points along one nonlinear mode: s = log10 a (a the modal amplitude
    [kg^0.5 m]), omega [rad/s], zeta [-], Q (P, n, 2H+1) [m] (the physical motion,
    static part included), the recomputed residuals [N] and `message` ("" when the
    requested amplitude range was covered, else why the continuation stopped)."""

    s: np.ndarray
    omega: np.ndarray
    zeta: np.ndarray
    Q: np.ndarray
    residual_static: np.ndarray
    residual_harmonic: np.ndarray
    newton_iterations: np.ndarray
    message: str = ""

    @property
    def amplitude(self) -> np.ndarray:
        """Modal amplitude a [kg^0.5 m]."""
        return 10.0 ** self.s


def newton(mp: ModeProblem, y, s: float, tol_rel: float, max_iter: int = 30):
    """(y, iterations, ModeCheck) of Newton's method at fixed s from y; backtracking
    halves a step that does not reduce |R| (up to 10 times).  Every iterate's residual
    is evaluated afresh and held to the tolerance in newtons (`epmc.check_values`);
    y None when it fails."""
    R, J, _, F, G, Q = evaluate(mp, y, s)
    ok = check_values(mp, R, F, G, Q, tol_rel)
    if ok.converged:
        return y, 0, ok
    r = np.linalg.norm(R)
    for it in range(1, max_iter + 1):
        try:
            dy = np.linalg.solve(J, -R)
        except np.linalg.LinAlgError:
            return None, it, None
        t = 1.0
        for _ in range(11):
            out = evaluate(mp, y + t * dy, s)
            r_try = np.linalg.norm(out[0])
            if np.isfinite(r_try) and r_try < max(r, 1e-300) * (1 - 1e-4 * t) or r_try == 0:
                break
            t *= 0.5
        else:   # no decrease: at round-off, the full step is as good as any
            t = 1.0
            out = evaluate(mp, y + dy, s)
        y = y + t * dy
        R, J, _, F, G, Q = out
        r = np.linalg.norm(R)
        ok = check_values(mp, R, F, G, Q, tol_rel)
        if ok.converged:
            return y, it, ok
    return None, max_iter, None


def continue_mode(mp: ModeProblem, s_from: float, s_to: float, step: float = 0.1,
                  min_step: float = 1e-4, max_step: float = 0.25, tol_rel: float = 1e-8,
                  max_points: int = 2000, progress=None, resolution=(0.005, 0.05)) -> Backbone:
    """Backbone of `mp` from s_from to s_to (s = log10 a, a [kg^0.5 m]), starting from
    the linear mode at s_from.  A step that changes omega by more than twice
    resolution[0] (relative) or zeta by more than twice resolution[1] (relative to the
    larger) is halved and retried, so the curves are resolved where they turn.
    `progress(s)` is called after every accepted point."""
    if not (np.isfinite(s_from) and np.isfinite(s_to)) or s_to <= s_from:
        raise ValueError(f"need s_from < s_to (log10 of the modal amplitude), got "
                         f"{s_from}, {s_to}")
    pts, message = [], ""
    y, it, ok = newton(mp, linear_guess(mp), s_from, tol_rel)
    if y is None:
        return _backbone(mp, [], f"no converged point at the start log10 a = {s_from:.3g}")
    pts.append((s_from, y, it, ok))
    ds = step
    while pts[-1][0] < s_to and len(pts) < max_points:
        s0, y0 = pts[-1][0], pts[-1][1]
        s1 = min(s0 + ds, s_to)
        if len(pts) > 1:   # secant predictor in s
            sp, yp = pts[-2][0], pts[-2][1]
            guess = y0 + (y0 - yp) * (s1 - s0) / (s0 - sp)
        else:
            guess = y0
        y1, it, ok = newton(mp, guess, s1, tol_rel)
        if y1 is None:
            ds *= 0.5
            if ds < min_step:
                message = (f"stopped at log10 a = {s0:.4g}: no converged point within "
                           f"{min_step:g} decades (the amplitude turns back: an internal "
                           "resonance, or a degenerate normalisation)")
                break
            continue
        change = max(abs(y1[-2] - y0[-2]) / abs(y0[-2]) / resolution[0],
                     abs(y1[-1] - y0[-1]) / max(abs(y0[-1]), abs(y1[-1]), 1e-4) / resolution[1])
        if change > 2.0 and ds > 4 * min_step:   # too coarse to draw: a shorter step
            ds *= 0.5
            continue
        pts.append((s1, y1, it, ok))
        if progress is not None:
            progress(s1)
        ds = min(ds * (1.5 if it <= 4 and change < 0.5 else 1.0), max_step)
    if not message and pts[-1][0] < s_to:
        message = f"stopped at log10 a = {pts[-1][0]:.4g}: {max_points} points reached"
    return _backbone(mp, pts, message)


def _backbone(mp: ModeProblem, pts, message: str) -> Backbone:
    n, nh = mp.n, 2 * mp.H + 1
    if not pts:
        e = np.zeros(0)
        return Backbone(e, e, e, np.zeros((0, n, nh)), e, e, np.zeros(0, int), message)
    Qs, om, ze = [], [], []
    for s, y, _, _ in pts:
        Z, w, z, scale = unpack(mp, y, s)
        Qs.append(Z * scale)
        om.append(w)
        ze.append(z)
    return Backbone(np.array([p[0] for p in pts]), np.array(om), np.array(ze), np.array(Qs),
                    np.array([p[3].static for p in pts]),
                    np.array([p[3].harmonic for p in pts]),
                    np.array([p[2] for p in pts]), message)


def point_at(mp: ModeProblem, bb: Backbone, s: float, tol_rel: float = 1e-8):
    """(omega [rad/s], zeta [-], Q (n, 2H+1) [m]) of the mode at s = log10 a inside the
    backbone's range: Newton from the points interpolated linearly in s.  ValueError
    when it does not converge."""
    if not bb.s[0] <= s <= bb.s[-1]:
        raise ValueError(f"log10 a = {s} is outside the backbone ({bb.s[0]}, {bb.s[-1]})")
    scale = np.full(bb.Q.shape[2], 10.0 ** s)
    scale[0] = 1.0
    Z = np.stack([np.interp(s, bb.s, q) for q in bb.Q.reshape(bb.s.size, -1).T], axis=-1)
    Z = Z.reshape(bb.Q.shape[1:])
    Z[:, 1:] /= 10.0 ** np.interp(s, bb.s, bb.s)
    guess = np.concatenate([Z.ravel(), [np.interp(s, bb.s, bb.omega),
                                        np.interp(s, bb.s, bb.zeta)]])
    y, _, ok = newton(mp, guess, s, tol_rel)
    if y is None:
        raise ValueError(f"no converged point of the mode at log10 a = {s:.6g}")
    Zs, om, ze, _ = unpack(mp, y, s)
    return om, ze, Zs * scale
