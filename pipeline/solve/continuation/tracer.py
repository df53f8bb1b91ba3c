"""The steps of one continuation run: `Tracer` (predict, correct, assess, accept or
reject, pass a corner of the branch, commit), which returns the `Branch`.

The equations, tangents and the scaled metric are `arclength.ScaledEquations`; the
folds of the finished branch are located by `branch.refine_fold`.
"""
from __future__ import annotations

import logging
import math

import numpy as np

from .arclength import ContinuationOptions, ScaledEquations
from .branch import (Branch, fold_segments, frozen_array, hermite, hermite_on_plane,
                     refine_fold)
from .newton import NEWTON_MESSAGES

# the run's messages keep the logger of `continuation` (the command line quiets it)
log = logging.getLogger("pipeline.solve.continuation.pseudo_arclength")

_CORNER_TURN = math.radians(20.0)  # one-sided tangents differing by more: try a corner
_CURVED_COS = math.cos(math.radians(20.0))  # a larger turn between the last two tangents:
# a corner between them, no cubic through both
_ONE_ITER_ORDER = 6  # r1 ~ ds^6 from the cubic (start error ~ ds^3 or better, squared)
_NEAR_MISS = 10.0    # a first iterate within this factor of the tolerance: aim at one


class Tracer:
    """One run of `continue_branch`: the state its steps share, and the steps.

    State: the current point z = [x; lam] and its tangent t_phys (physical units),
    the step ds, the accepted points, the rejections; the equations `eq` hold the
    metric and count the costs.  `run` solves the
    first point, then repeats `step` (predict, correct, assess, then accept or
    reject, a rejection possibly passing a corner) until one returns the Branch.
    """

    def __init__(self, fun, opts: ContinuationOptions):
        self.opts, self.n = opts, opts.n
        self.eq = ScaledEquations(fun, opts)
        self.ds = self.planned = opts.ds  # planned: the step chosen at the last point
        self.z = self.t_phys = None
        self.points = []    # (z, t_phys, nit, nfev, ||R||) of each accepted point
        self.n_rejected = self.n_unresolved = 0
        self.min_step = math.inf
        self.spent = 0      # fun calls since the last accepted point
        self.rejected_before = 0  # n_rejected when the last point was accepted
        self.curved = False  # the last point's corrector started on the cubic
        self.history = []    # residual norms of the last corrector's iterates
        self.recent = {}    # turn / deviation of the rejections since the last acceptance

    @property
    def s(self):
        return self.eq.s

    def run(self, x0) -> Branch:
        done = self.first_point(x0)
        while done is None:
            done = self.step()
        return done

    # ---- the first point
    def first_point(self, x0):
        """Newton at fixed lam0 and the first tangent; the Branch if the run ends there."""
        o = self.opts
        x, st, nit, nfev, r, (R, Jx, Jl) = self.eq.solve_fixed_lam(x0, o.lam0)
        if st != 0:
            return self.result(-2, f"first point at lam0 = {o.lam0} did not converge: "
                                   f"{NEWTON_MESSAGES[st]} (||R|| = {r:.3e}, "
                                   f"tol = {o.thresh:.3e})")
        self.eq.metric.observe(x)  # from the solution, not from the caller's guess
        t = self.first_tangent(x, Jx, Jl)
        if t is None:
            return self.result(-2, "tangent at the first point failed: singular dR_dx at lam0")
        self.z, self.t_phys = np.append(x, o.lam0), t * self.s
        self.points.append((self.z, self.t_phys, nit, nfev, np.linalg.norm(R)))
        if o.callback is not None and o.callback(x.copy(), o.lam0):
            return self.result(3, "stopped by callback")
        if o.max_points == 1:
            return self.result(2, "max_points reached before lam_end")
        return None

    def first_tangent(self, x, Jx, Jl):
        """Unit scaled tangent at the first point, towards lam_end times `direction`
        (at a fold, where its lam-component vanishes: towards growing |x|)."""
        n, s, o = self.n, self.s, self.opts
        if o.tangent is not None:   # given by the caller: scaled and normalised
            t = o.tangent / s
            t /= np.linalg.norm(t)
        else:
            t = self.eq.null_vector(Jx, Jl)
        if t is None:
            return None
        sgn = np.sign(t[n] * (o.lam_end - o.lam0))
        if abs(t[n]) < 1e-12:
            sgn = np.sign(t[:n] @ (x / s[:n])) or 1.0
        t *= sgn * o.direction
        return t

    # ---- one step
    def step(self):
        """One predictor-corrector step; the Branch if the run ends with it, else None."""
        ts, y_pred = self.predict()
        start = self.curved_start(ts, y_pred)
        zn, st, nit, _, r, JJ = self.correct(y_pred, ts, start)
        reason, feature, tan, shrink = self.assess(zn, st, JJ, y_pred)
        if reason is not None:
            return self.reject(reason, feature, shrink, ts, zn, JJ)
        dev = np.linalg.norm(zn / self.s - y_pred) / self.ds
        return self.accept(zn, tan, nit, r, dev, curved=start is not None)

    def predict(self):
        """(unit scaled tangent ts, predictor y_k + ds ts) in the scaled unknowns."""
        ts = self.t_phys / self.s
        ts /= np.linalg.norm(ts)
        return ts, self.z / self.s + self.ds * ts

    def curved_start(self, ts, y_pred):
        """A start for the corrector on the predictor's hyperplane, nearer the branch
        than y_pred: where the hyperplane meets the Hermite curve through the last
        points and their tangents, extrapolated (`branch.hermite_on_plane`).  The
        corrected point is the one from y_pred (same hyperplane), only Newton starts
        closer to it: the tangent predictor's error is O(ds^2), the cubic's through
        two points O(ds^4), the quintic's through three O(ds^6) on a smooth arc.
        The quintic is used where it would have predicted the last point better
        than the cubic (`quintic_fits`): a change of the stick/slip pattern
        between the points breaks the smoothness it needs.  None (start at y_pred)
        after a corner, where the curve would span it; when a step from here was
        rejected: a retry starts where the line predictor does, so that it meets the
        corner tests as the line's corrector does; and after a point that the line
        reached in one iteration (the line suffices there)."""
        if (len(self.points) < 2 or self.n_rejected > self.rejected_before
                or (self.points[-1][2] < 2 and not self.curved)):
            return None  # (a last point found in one iteration from the line: it suffices)
        Y, T = self.smooth_tail(4)
        if len(Y) < 2 or (Y[-1] - Y[-2]) @ (T[-2] + T[-1]) <= 0:
            return None
        orders = (3, 2) if len(Y) == 4 and self.quintic_fits(Y, T) else (2,)
        for m in orders:
            start = hermite_on_plane(Y[-m:], T[-m:], ts, self.ds)
            if (start is not None
                    and np.linalg.norm(start - y_pred) <= self.opts.max_deviation * self.ds):
                return start
        return None  # the curve strays: a feature ahead, the line is the safer start

    def smooth_tail(self, k):
        """The last (at most k) accepted points, scaled, and their unit scaled
        tangents, back to the first turn of more than 20 degrees between two."""
        s = self.s
        Y, T = [self.z / s], [self.t_phys / s / np.linalg.norm(self.t_phys / s)]
        for z, t, *_ in self.points[-2:-k - 1:-1]:
            tu = t / s / np.linalg.norm(t / s)
            if tu @ T[0] < _CURVED_COS:
                break
            Y.insert(0, z / s)
            T.insert(0, tu)
        return np.array(Y), np.array(T)

    @staticmethod
    def quintic_fits(Y, T):
        """Whether the quintic through the first three of four points predicts the
        fourth (on its corrector's hyperplane) better than the cubic through the
        two before it: the branch is smooth enough there for the higher order."""
        d = T[2] @ (Y[3] - Y[2])
        quintic, cubic = (hermite_on_plane(Y[i:3], T[i:3], T[2], d) for i in (0, 1))
        return (quintic is not None and cubic is not None
                and np.linalg.norm(quintic - Y[3]) < np.linalg.norm(cubic - Y[3]))

    def correct(self, y_pred, normal, start=None):
        """Corrector on the hyperplane through y_pred normal to `normal` (scaled), from
        `start` on it (default y_pred): (z, status, nit, nfev, ||R||, (Jx, Jl)); status
        -1: the hyperplane condition is not met although ||R|| is.  The residual
        norms of its iterates are kept in `history`."""
        self.history = []
        zn, st, nit, nfev, _, r, JJ, F = self.eq.solve_on_plane(y_pred, normal, start,
                                                                self.history)
        self.spent += nfev
        if st == 0 and abs(F[self.n]) > 1e-6 * max(
                np.linalg.norm(y_pred - self.z / self.s), 1e-12):
            st = -1  # arclength condition not met
        return zn, st, nit, nfev, r, JJ

    def assess(self, zn, st, JJ, y_pred):
        """The tests a corrected point must pass, in order: convergence, deviation
        from the predictor, turn of the tangent, `segment_check`.  Returns (reason
        for rejection or None, rejected for a feature (possibly a corner)?, tangent
        triple of `tangent_from` or None, factor for the step if rejected)."""
        if st != 0:
            return ("arclength condition not met" if st == -1 else NEWTON_MESSAGES[st],
                    False, None, 0.5)
        reason = self.deviation_test(zn, y_pred)
        if reason is not None:
            return reason, True, None, 0.5
        tan = self.eq.tangent_from(JJ[0], JJ[1], self.t_phys)
        self.eq.njev += 1
        if tan is None:
            return "singular tangent system", False, None, 0.5
        reason = self.turn_test(tan[1])
        if reason is not None:
            return reason, True, tan, 0.5
        reason, shrink = self.segment_test(zn)
        return reason, False, tan, shrink

    def deviation_test(self, zn, y_pred):
        """The corrector must stay near the predictor: a large deviation of the secant
        from the tangent means the step jumped over a feature (e.g. a resonance of a
        branch Newton finds easy), even if the tangents agree."""
        o = self.opts
        dev = np.linalg.norm(zn / self.s - y_pred) / self.ds
        if dev > o.max_deviation and self.ds > o.ds_min:
            if not self.is_kink("deviation", dev):
                return f"corrector moved {dev:.2f} step lengths from the predictor"
            log.debug("kink passed: deviation %.2f persists as ds shrinks", dev)
        return None

    def turn_test(self, cos_angle):
        """The tangent may turn by at most max_turn in one step (no branch jumping)."""
        if cos_angle < self.opts.cos_turn and self.ds > self.opts.ds_min:
            angle = math.acos(min(1.0, cos_angle))
            if not self.is_kink("turn", angle):
                return f"tangent turned by {math.degrees(angle):.1f} deg"
            log.debug("kink passed: turn %.1f deg persists as ds shrinks", math.degrees(angle))
        return None

    def segment_test(self, zn):
        """(reason or None, step factor) from the caller's `segment_check`."""
        o, z, n = self.opts, self.z, self.n
        if o.segment_check is None:
            return None, 0.5
        width = o.segment_check(z[:n], z[n], zn[:n], zn[n])
        if width is not None and self.ds > o.ds_min:
            step = abs(zn[n] - z[n])
            return (f"a resonance inside the step (|dlam| = {step:.3g} > {width:.3g})",
                    min(0.5, max(0.9 * width / step, 1e-3)))
        if width is not None:
            self.n_unresolved += 1
            log.debug("step at ds_min taken although segment_check refused it")
        return None, 0.5

    def is_kink(self, what, value):
        """A smooth curve's turn and predictor deviation shrink in proportion to the
        step; once the step is small (< kink_ds, while crossing a resonance needs a
        step of order one in the scaled metric), a rejection that survives three
        halvings there is a corner of the branch (e.g. a change of the stick/slip
        pattern), not a jump: it is accepted."""
        prev = self.recent.get(what)
        self.recent[what] = value
        if self.ds >= self.opts.kink_ds:
            return False
        self.recent["small"] = self.recent.get("small", 0) + 1
        return self.recent["small"] > 3 or (prev is not None and value > 0.75 * prev)

    def accept(self, zn, tan, nit, r, dev=0.0, curved=False):
        """Take the corrected point and choose the next step (`next_step`)."""
        self.recent.clear()
        self.min_step = min(self.min_step, self.ds)
        done = self.commit(zn, tan[2], nit, r)
        self.curved = curved
        if done is not None:
            return done
        self.ds = self.planned = self.next_step(nit, math.acos(min(1.0, tan[1])), dev, curved)
        return None

    def next_step(self, nit, turn, dev, curved):
        """The step after an accepted one of nit iterations, turn and deviation dev
        (the corrector's distance from the line predictor, in step lengths).

        It aims at target_newton iterations, and at half the deviation and half the
        turn that would reject it (both grow in proportion to the step, while
        Newton, started near the branch by `curved_start`, no longer feels the
        curvature; one iteration from the cubic counts as two).  A step of one
        iteration costs 2 evaluations against 3 for two: when two were needed from
        the cubic but the first iterate's residual r1 came within _NEAR_MISS of the
        tolerance, the shorter step with r1 = thresh / 2 (r1 shrinks like
        ds^_ONE_ITER_ORDER) is taken if it is cheaper per length."""
        o = self.opts
        geometric = min(0.5 * o.max_deviation / max(dev, 1e-12),
                        0.5 * o.max_turn / max(turn, 1e-12))

        def bounded(factor):
            return min(max(self.ds * min(max(factor, 0.5), 2.0), o.ds_min), o.ds_max)

        n_two = max(nit, 2) if curved else nit
        ds = bounded(min(math.sqrt(o.target_newton / max(n_two, 1)), geometric))
        if curved and nit == 2 and self.history[1] < _NEAR_MISS * self.eq.thresh:
            one = (0.5 * self.eq.thresh / self.history[1]) ** (1.0 / _ONE_ITER_ORDER)
            ds_one = bounded(min(one, geometric))
            if 2.0 / ds_one < (n_two + 1.0) / ds:
                ds = min(ds, ds_one)
        return ds

    def reject(self, reason, feature, shrink, ts, zn, JJ):
        """Pass a corner if the rejection may be one, else shorten the step; the
        Branch (failure) once the step falls below ds_min."""
        o = self.opts
        self.n_rejected += 1
        corner = self.pass_corner(ts, zn, JJ) if feature else None
        if corner:
            log.debug("corner passed with %d point(s) (%s)", len(corner), reason)
            return self.commit_corner(corner)
        self.ds *= shrink
        log.debug("step rejected (%s); ds -> %.3e", reason, self.ds)
        if shrink < 0.5 and self.ds < o.ds_min:  # try the smallest step before giving up
            self.ds = o.ds_min
        if self.ds < o.ds_min:
            return self.result(-1, f"step size below ds_min = {o.ds_min:g} at lam = "
                                   f"{self.z[self.n]:.6g} (last failure: {reason})")
        return None

    # ---- corners
    def pass_corner(self, ts, zn, JJn, depth=0):
        """A corner of the branch between z and the rejected corrector point zn.

        The branch is piecewise smooth (stick/slip/separation patterns change at
        corners): where one-sided tangents differ, halving the step only creeps
        towards the corner.  Instead, the corner is located as the meeting point
        c = y + a t = y_n - b t_n of the line along the tangent t at z and the line
        back along the tangent t_n at zn (least squares, scaled metric), and two
        points are solved: y1 just before c (corrector normal to t at 0.98 a; its
        tangent must still be t) and y2 beyond it (predictor c + d t_n, corrector
        normal to t_n, d = min(ds, b)); y2 must lie near its predictor and its
        tangent near t_n.  A smooth turn fails these tests (its chords and middle
        tangents lie between t and t_n), so only genuine corners pass.  A y1 whose
        tangent has already turned to t_n lies past the corner (c estimated too far):
        the corner is then located once more between z and y1, the nearer point.
        Returns the accepted points [(z, t_scaled, nit, r)] (possibly only y1), or
        None.
        """
        found = self.locate_corner(ts, zn, JJn)
        if found is None:
            return None
        a, b, tn, turn = found
        out = []
        if a > 0.05 * self.ds:  # a point just before the corner
            before, past = self.point_before_corner(ts, tn, a,
                                                    max(0.2 * turn, math.radians(2.0)))
            if before is None:
                return None if past is None or depth else self.pass_corner(ts, *past, 1)
            out.append(before)
        beyond = self.point_beyond_corner(self.z / self.s + a * ts, tn, b)
        if beyond is not None:
            out.append(beyond)
        return out or None

    def locate_corner(self, ts, zn, JJn):
        """(a, b, t_n, turn) of the corner c = y + a t = y_n - b t_n, or None if the
        two tangents do not meet like a corner's."""
        y0, yn = self.z / self.s, zn / self.s
        tn = self.eq.oriented_tangent(JJn, yn - y0)
        if tn is None:
            return None
        (a, b), *_ = np.linalg.lstsq(np.column_stack([ts, tn]), yn - y0, rcond=None)
        if b < 0:
            tn, b = -tn, -b
        turn = math.acos(float(np.clip(ts @ tn, -1.0, 1.0)))
        gap = np.linalg.norm(y0 + a * ts + b * tn - yn)
        if not (turn > _CORNER_TURN and 0 < a <= self.ds and gap <= 0.25 * max(a, b)):
            return None
        return a, b, tn, turn

    def point_before_corner(self, ts, tn, a, tol_angle):
        """(the point at 0.98 a along the tangent ts if its tangent is still ts, else
        None; (z, Jacobians) of that point if it converged near its predictor with
        its tangent turned to the outgoing tn (past the corner, not inside a smooth
        turn), else None); both tangents within tol_angle."""
        y1p = self.z / self.s + 0.98 * a * ts
        z1, st1, nit1, _, r1, JJ1 = self.correct(y1p, ts)
        if st1 != 0:
            return None, None
        t1 = self.eq.oriented_tangent(JJ1, ts)
        if (t1 is None or np.linalg.norm(z1 / self.s - y1p)
                > self.opts.max_deviation * 0.98 * a):
            return None, None
        if math.acos(min(1.0, float(t1 @ ts))) > tol_angle:
            past = math.acos(min(1.0, abs(float(t1 @ tn)))) <= tol_angle
            return None, (z1, JJ1) if past else None
        return (z1, t1, nit1, r1), None

    def point_beyond_corner(self, c, tn, b):
        """The point at c + d tn, near its predictor with its tangent near tn
        (d = min(ds, b), once more at d / 4, and if b < ds / 4 at ds / 4: a rejected
        point just past the corner fixes tn, but the corner only roughly), or None."""
        o = self.opts
        d = min(self.ds, b)
        tries = [d, 0.25 * d] + ([0.25 * self.ds] if b < 0.25 * self.ds else [])
        for d in tries:
            y2p = c + d * tn
            z2, st2, nit2, _, r2, JJ2 = self.correct(y2p, tn)
            t2 = self.eq.oriented_tangent(JJ2, tn) if st2 == 0 else None
            if (t2 is not None and np.linalg.norm(z2 / self.s - y2p) <= o.max_deviation * d
                    and math.acos(min(1.0, float(t2 @ tn))) <= o.max_turn):
                return z2, t2, nit2, r2
        return None

    def commit_corner(self, corner):
        """Commit the points of a passed corner; the Branch if the run ends there.
        The next step is the one planned before the rejections that found the
        corner: they shortened it for the corner, which now lies behind."""
        self.recent.clear()
        self.curved = False
        self.min_step = min(self.min_step, self.ds)
        for zc, tc, nitc, rc in corner:
            done = self.commit(zc, tc * self.s, nitc, rc)
            if done is not None:
                return done
        self.ds = max(self.ds, self.planned)
        return None

    # ---- accepted points and the end of the run
    def commit(self, zn, t_new_phys, nit, r):
        """Append an accepted point; a Branch when the run ends there, else None."""
        o, n = self.opts, self.n
        lo, hi = o.bounds
        if not lo <= zn[n] <= hi:
            return self.finish_at_bound(zn, t_new_phys, nit, r)
        self.z, self.t_phys = zn, t_new_phys
        self.points.append((zn, t_new_phys, nit, self.spent, r))
        self.spent = 0
        self.rejected_before = self.n_rejected
        self.eq.metric.observe(zn[:n])
        if o.callback is not None and o.callback(zn[:n].copy(), zn[n]):
            return self.result(3, "stopped by callback")
        if len(self.points) >= o.max_points:
            return self.result(2, "max_points reached before lam_end")
        return None

    def finish_at_bound(self, zn, t_new_phys, nit, r):
        """The step left [lo, hi]: the last point is re-solved on the boundary it
        crossed (from the linear interpolation) and the Branch returned."""
        o, n = self.opts, self.n
        lo, hi = o.bounds
        bound = hi if zn[n] > hi else lo
        xg = self.crossing_guess(zn, t_new_phys, bound)
        if not (bound == o.lam0 and len(self.points) == 1):
            xb, stb, nitb, nfevb, rb, (R, Jx, Jl) = self.eq.solve_fixed_lam(xg, bound)
            self.spent += nfevb
            if stb == 0:
                tb = self.eq.tangent_from(Jx, Jl, self.t_phys)
                self.eq.njev += 1
                if tb is not None:
                    zn, nit, t_new_phys = np.append(xb, bound), nitb, tb[2]
                    r = np.linalg.norm(R)
            self.points.append((zn, t_new_phys, nit, self.spent, r))
        if bound == o.lam_end:
            return self.result(0, f"reached lam_end = {o.lam_end}")
        return self.result(1, f"left the interval at lam = {bound} (branch turned back)")

    def crossing_guess(self, zn, t_new_phys, bound):
        """x where the branch from z to zn crosses lam = bound: on the cubic Hermite
        curve through both points and their tangents (scaled), whose error is O(ds^4)
        against the chord's O(ds^2); on the chord if the cubic does not cross there
        once."""
        n, s, z = self.n, self.s, self.z
        frac = (bound - z[n]) / (zn[n] - z[n])
        y0, y1 = z / s, zn / s
        L = np.linalg.norm(y1 - y0)
        t0, t1 = (t / s / np.linalg.norm(t / s) for t in (self.t_phys, t_new_phys))
        if t1 @ (y1 - y0) < 0:
            t1 = -t1
        c0, c1, g0, g1 = y0[n], y1[n], L * t0[n], L * t1[n]
        # lam(u) of the cubic as a polynomial in u, minus the bound
        coef = [2 * c0 + g0 - 2 * c1 + g1, -3 * c0 - 2 * g0 + 3 * c1 - g1, g0, c0 - bound / s[n]]
        u = np.roots(coef)
        u = u[(np.abs(u.imag) < 1e-12) & (u.real >= 0) & (u.real <= 1)].real
        if u.size != 1:
            return z[:n] + frac * (zn[:n] - z[:n])
        p, _ = hermite(y0, y1, L * t0, L * t1, u[0])
        return p[:n] * s[:n]

    def result(self, status, message) -> Branch:
        """The Branch of the points so far, its folds located."""
        n, s, m = self.n, self.s, len(self.points)
        Z, T, NIT, PNFEV, RN = (list(c) for c in zip(*self.points)) if m else ([],) * 5
        Zs = np.array(Z, float).reshape(m, n + 1)
        Ts = np.array(T, float).reshape(m, n + 1)
        if m:
            Ts = Ts / np.linalg.norm(Ts / s, axis=1, keepdims=True)
        folds = [refine_fold(self.eq, *f, refine=self.opts.refine_folds)
                 for f in fold_segments(Zs, Ts, s)]
        fi = np.array([f[0] for f in folds], int)
        fl = np.array([f[1][n] for f in folds], float)
        fx = np.array([f[1][:n] for f in folds], float).reshape(len(folds), n)
        log.debug("continuation: %d points, %d folds, nfev=%d: %s", m, fi.size, self.eq.nfev,
                  message)
        return Branch(
            x=frozen_array(Zs[:, :n]), lam=frozen_array(Zs[:, n]), tangent=frozen_array(Ts),
            converged=frozen_array(np.ones(m, bool), bool), nit=frozen_array(NIT, int),
            point_nfev=frozen_array(PNFEV, int), residual_norm=frozen_array(RN),
            fold_index=frozen_array(fi, int), fold_lam=frozen_array(fl), fold_x=frozen_array(fx),
            nfev=self.eq.nfev, njev=self.eq.njev, n_rejected=self.n_rejected,
            min_step=self.min_step, scale=frozen_array(s), success=status >= 0 and status != 2,
            status=status, message=message, n_unresolved=self.n_unresolved)
