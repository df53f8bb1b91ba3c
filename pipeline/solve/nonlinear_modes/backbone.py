"""A nonlinear mode continued in the modal amplitude: the backbone omega(a), the modal
damping ratio zeta(a) and the shape, from the small-amplitude linear mode through
microslip, macroslip and separation (`epmc` gives the equations).

The first point is Newton's method on the EPMC equations from the linear mode
(analytic Jacobian, backtracking on the residual norm); the rest is the pipeline's
pseudo-arclength continuation (`continuation.continue_branch`) in the unknowns and
s = log10 a, so a fold in the amplitude is passed.  Every point is accepted only if
its recomputed residual meets the tolerance in newtons (`epmc.check`).  Where the
continuation stops early (a branch point, a normalisation that degenerates) the
backbone ends there and says so in `message`.  Where a higher harmonic takes over the
motion (an internal resonance: h omega meets another mode) the branch turns into that
mode's; the backbone stops before it, says so, and resumes the family beyond it when
Newton finds it there (`internal_resonance`, `family_beyond`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from ...model.system import dense
from ..continuation.pseudo_arclength import continue_branch
from .epmc import ModeProblem, check_values, evaluate, linear_guess, pack, residual, unpack

TONGUE = 0.5    # a harmonic h >= 2 carrying more of the motion where the amplitude turns
FAMILY = 0.9    # the first harmonic's share of a point on the family itself
MAX_SKIPS = 3   # internal resonances skipped along one backbone


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


def continue_mode(mp: ModeProblem, s_from: float, s_to: float, tol_rel: float = 1e-8,
                  max_points: int = 2000, ds: float = 0.01, ds_max: float = 0.02,
                  progress=None) -> Backbone:
    """Backbone of `mp` from s_from to s_to (s = log10 a, a [kg^0.5 m]), starting from
    the linear mode at s_from (Newton), then by the pseudo-arclength continuation of
    `continuation.continue_branch` in (y, s): it follows the mode through a fold in
    the amplitude as through any other point.  Every point is recomputed and held to
    the tolerance in newtons (`epmc.check`); the backbone keeps the points up to the
    first that fails it.  `progress(s)` is called after every accepted point.

    Where a harmonic h >= 2 takes over the motion (`internal_resonance`: its h-th
    harmonic has met another mode) the branch is no longer the family's: the backbone
    keeps the points before it, says so in `message`, seeks the family beyond it
    (`family_beyond`) and, when found, continues it towards s_to (the backbone then
    holds both stretches with a gap between, named in `message`)."""
    if not (np.isfinite(s_from) and np.isfinite(s_to)) or s_to <= s_from:
        raise ValueError(f"need s_from < s_to (log10 of the modal amplitude), got "
                         f"{s_from}, {s_to}")
    y0, _, ok = newton(mp, linear_guess(mp), s_from, tol_rel)
    if y0 is None:
        return _backbone(mp, [], f"no converged point at the start log10 a = {s_from:.3g}")
    kw = dict(tol_rel=tol_rel, max_points=max_points, ds=ds, ds_max=ds_max,
              progress=progress)
    pts, message = stretch(mp, y0, s_from, s_to, **kw)
    notes, start = [], 0
    for _ in range(MAX_SKIPS):
        tongue = internal_resonance(mp, pts, start)
        if tongue is None:
            break
        c, b, note = tongue
        s_c = pts[c][0]
        pts, message = pts[:c], f"stopped at {note}"
        found = None if b is None else family_beyond(mp, pts[b], s_c, s_to, tol_rel)
        if found is None:
            break
        s_j, y_j = found
        notes.append(f"{note}; the family skips it from log10 a = {pts[-1][0]:.4g} to "
                     f"{s_j:.4g} (no point between)")
        more, message = stretch(mp, y_j, s_j, s_to, **kw)
        start, pts = len(pts), pts + more
    message = "; ".join(notes + ([message] if message else []))
    return _backbone(mp, pts, message)


def stretch(mp: ModeProblem, y0, s_from: float, s_to: float, *, tol_rel, max_points, ds,
            ds_max, progress):
    """(points [(s, y, iterations, ModeCheck)], message) of one continuation run from
    the converged y0 at s_from towards s_to."""
    nh = 2 * mp.H + 1
    nk = mp.kept.size
    groups = np.concatenate([np.repeat(np.arange(nk), nh), [nk, nk + 1]])
    r_ref = float(np.linalg.norm(residual(mp, y0, s_from, jacobian=False)[0][:-2]) +
                  np.linalg.norm(dense(mp.hbm.system.K) @ unpack(mp, y0, s_from)[0]))

    def callback(y, s):
        if progress is not None:
            progress(s)
        return False

    br = continue_branch(lambda y, s: residual(mp, y, s), y0, s_from, s_to,
                         tol=1e-12 * r_ref, tol_rel=tol_rel, r_ref=r_ref, ds=ds,
                         ds_max=ds_max, max_points=max_points, groups=groups,
                         callback=callback)
    pts, message = [], ""
    for y, s, it in zip(br.x, br.lam, br.nit):
        R, _, _, F, G, Q = evaluate(mp, y, s, jacobian=False)
        ok = check_values(mp, R, F, G, Q, tol_rel)
        if not ok.converged:    # the continuation's norm is not the check's: polish at s
            y, it, ok = newton(mp, y, s, tol_rel)
        if ok is None or not ok.converged:
            message = (f"stopped at log10 a = {s:.4g}: no point there meets the residual "
                       "tolerance in newtons")
            break
        pts.append((s, y, int(it), ok))
    if not message and not br.success:
        message = (f"stopped at log10 a = {br.lam[-1]:.4g}: {br.message} (a branch point, "
                   "or a degenerate normalisation)")
    elif not message and br.lam[-1] < s_to:
        message = f"stopped at log10 a = {br.lam[-1]:.4g}: the amplitude turned back"
    return pts, message


def harmonic_shares(mp: ModeProblem, Z) -> np.ndarray:
    """The share of each harmonic h = 1 ... H in the shape's mass norm
    sum_h Psi_h^T M Psi_h of Z (n, 2H+1) (cosine and sine parts together)."""
    e = np.array([np.sum(Z[:, 2 * h - 1:2 * h + 1] * (mp.M @ Z[:, 2 * h - 1:2 * h + 1]))
                  for h in range(1, mp.H + 1)])
    return e / e.sum()


def internal_resonance(mp: ModeProblem, pts, start: int = 0):
    """The first point c >= start where a harmonic h >= 2 carries more than TONGUE of
    the shape's mass norm: its h-th harmonic has met another mode near h omega, an
    internal h:1 resonance, and the branch from there is that mode's (on the shrouded
    disk's ND 12 at 3 N: harmonic 2 takes over near 760 Hz, carries 99.9 % at the
    turn of the amplitude and the branch returns to the linear mode, its sign flipped;
    on a two-DOF model with omega_2 / omega_1 between the stuck and the separated
    ratios, omega locks at omega_2 / 2 and the amplitude grows on the second mode).
    (c, index b of the last point before c whose first harmonic carries at least
    FAMILY or None, the note for `message`), or None."""
    for c in range(start, len(pts)):
        s, y = pts[c][0], pts[c][1]
        shares = harmonic_shares(mp, unpack(mp, y, s)[0])
        h = 1 + int(np.argmax(shares))
        if h > 1 and shares[h - 1] > TONGUE:
            break
    else:
        return None
    fam = [i for i in range(start, c)
           if harmonic_shares(mp, unpack(mp, pts[i][1], pts[i][0])[0])[0] >= FAMILY]
    f_c = unpack(mp, y, s)[1] / (2 * np.pi)
    return c, (fam[-1] if fam else None), (
        f"an internal {h}:1 resonance at log10 a = {s:.4g} ({f_c:.5g} Hz): harmonic {h} "
        f"carries {100 * shares[h - 1]:.1f} % of the motion there (another mode near "
        f"{h * f_c:.5g} Hz)")


def family_beyond(mp: ModeProblem, point, s_c: float, s_to: float, tol_rel: float):
    """The family beyond an internal resonance found at s_c (`internal_resonance`):
    from the family's last point (s_b, y_b, ...) before it, its higher harmonics
    dropped, Newton at s_c + k (s_c - s_b), k = 1, 2, 4, 8, until a point whose first
    harmonic carries at least FAMILY converges.  (s_j, y_j), or None (none below s_to)."""
    s_b = point[0]
    Z, om, ze, _ = unpack(mp, point[1], s_b)
    Z = Z.copy()
    Z[:, 3:] = 0.0
    Z[:, 1:3] /= np.sqrt(np.sum(Z[:, 1:3] * (mp.M @ Z[:, 1:3])))
    guess = pack(mp, Z, om, ze)
    for k in (1, 2, 4, 8):
        s_j = s_c + k * max(s_c - s_b, 0.01)
        if s_j >= s_to:
            return None
        y, _, ok = newton(mp, guess, s_j, tol_rel)
        if y is not None and harmonic_shares(mp, unpack(mp, y, s_j)[0])[0] >= FAMILY:
            return s_j, y
    return None


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


def segment_of(bb: Backbone, s: float) -> int:
    """The first i with s between bb.s[i] and bb.s[i + 1] (a backbone that folds in
    the amplitude holds several); ValueError when none does."""
    lo, hi = np.minimum(bb.s[:-1], bb.s[1:]), np.maximum(bb.s[:-1], bb.s[1:])
    inside = np.nonzero((lo <= s) & (s <= hi))[0]
    if inside.size == 0:
        raise ValueError(f"log10 a = {s} is outside the backbone ({bb.s.min()}, {bb.s.max()})")
    return int(inside[0])


def point_at(mp: ModeProblem, bb: Backbone, s: float, tol_rel: float = 1e-8,
             segment: int | None = None):
    """(omega [rad/s], zeta [-], Q (n, 2H+1) [m]) of the mode at s = log10 a between the
    backbone points `segment` and `segment` + 1 (default `segment_of`): Newton from
    them interpolated linearly in s.  ValueError when it does not converge."""
    i = segment_of(bb, s) if segment is None else int(segment)
    s0, s1 = bb.s[i], bb.s[i + 1]
    t = 0.0 if s1 == s0 else (s - s0) / (s1 - s0)
    scale = np.full(bb.Q.shape[2], 10.0 ** s)
    scale[0] = 1.0
    Z = (1 - t) * bb.Q[i] + t * bb.Q[i + 1]
    Z[:, 1:] /= 10.0 ** s
    guess = pack(mp, Z, (1 - t) * bb.omega[i] + t * bb.omega[i + 1],
                 (1 - t) * bb.zeta[i] + t * bb.zeta[i + 1])
    y, _, ok = newton(mp, guess, s, tol_rel)
    if y is None:
        raise ValueError(f"no converged point of the mode at log10 a = {s:.6g}")
    Zs, om, ze, _ = unpack(mp, y, s)
    return om, ze, Zs * scale


def damping_peak(mp: ModeProblem, bb: Backbone, tol_rel: float = 1e-10):
    """(s, zeta, omega) of the largest modal damping ratio along the backbone, located
    between the points either side of the largest sampled one by Brent's method on the
    mode recomputed at s (`point_at`), so no larger value hides between two points of a
    smooth stretch.  (NaN, NaN, NaN) for fewer than three points."""
    if bb.s.size < 3:
        return np.nan, np.nan, np.nan
    i = int(np.argmax(bb.zeta))
    best = (bb.s[i], bb.zeta[i], bb.omega[i])
    for seg in (i - 1, i):
        if not 0 <= seg < bb.s.size - 1 or bb.s[seg] == bb.s[seg + 1]:
            continue
        lo, hi = sorted((bb.s[seg], bb.s[seg + 1]))
        try:
            r = minimize_scalar(lambda s: -point_at(mp, bb, s, tol_rel, seg)[1], bounds=(lo, hi),
                                method="bounded", options={"xatol": 1e-9})
        except ValueError:    # a point there does not converge: keep the samples
            continue
        if -r.fun > best[1]:
            om, ze, _ = point_at(mp, bb, r.x, tol_rel, seg)
            best = (float(r.x), ze, om)
    return best
