"""A frequency branch followed out of its window and back in.

A branch that covers the window [lo, hi] may still miss its largest resonance: a
hardening (or softening) resonance bends over the window's edge, so that the branch
through the window's end leaves it, passes a fold outside and comes back in on
another sheet with a larger amplitude (a Duffing oscillator whose lower fold lies
below lo: from lo the branch runs on the lower sheet to hi, while the resonant sheet
and its fold, the peak, lie inside the window).  Its sign: the largest amplitude
inside the window lies where the branch meets its edge, still rising there; more
generally, the branch rises out of the window (a smaller resonance inside it may hide
the larger one behind the edge).

`follow_out` therefore continues the branch beyond each of its two ends at which the
amplitude of a DOF of `dofs` rises out of the window (at least RISE_SHARE of its
largest in-window amplitude), with the resonance guard and the caller's callback,
until

- it has left the window, moves away from it and the amplitude of every DOF that
  rose out of the window falls (a local maximum outside the window is enclosed: the
  branch does not come back within that rise), or
- it leaves [max(lo - FAR (hi - lo), lo / 2), hi + FAR (hi - lo)], or
  the continuation stops (max_points, a step below ds_min, the callback);

where it comes back into the window it is followed through it like any branch.  The
excursion up to its last point inside the window is joined to the branch (in order
along it; the tail that left for good is not kept: it may climb an undamped resonance
outside, whose points the residual's round-off floor decides).  Every crossing of a
window edge between two points gets a point exactly on the edge (`edge_points`).
Peaks are read inside the window only (`ResponseCurve.peak`,
`insert_peaks(window=...)`), and a largest amplitude traced outside the window, above
the window's, is said in the curve's message.

Not found: a resonance on a sheet that the branch does not reach within that reach
(an isola), or one behind a branch that leaves the window falling.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..continuation.amplitudes import amplitudes_at
from ..continuation.newton import linear_solve, newton
from ..continuation.pseudo_arclength import continue_branch
from ..continuation.restarts import join, piece

FAR = 1.0          # how far beyond the window (of its width) an excursion may go
OUTSIDE = "lies outside the range: not its peak"   # the message's words for that
RISE_SHARE = 0.05  # a rising end below this share of the window's largest: not followed


def rising_ends(lam, A, converged, window) -> dict:
    """{end: DOF mask} of the branch's ends ("first", "last") at which some column of
    A (P, D) rises out of the window: its value at the in-window point next to that
    end is above its in-window neighbour's and at least RISE_SHARE of its largest
    converged in-window value (a smaller one could not hold the window's peak any
    more than `insert_peaks` reads such a local maximum); the mask (D,) marks those
    columns."""
    lo, hi = window
    inside = np.flatnonzero(converged & (lam >= lo) & (lam <= hi))
    if inside.size < 2:
        return {}
    top = A[inside].max(axis=0)
    out = {}
    for end, (k, nb) in (("first", inside[:2]), ("last", inside[::-1][:2])):
        rising = (top > 0) & (A[k] >= RISE_SHARE * top) & (A[k] > A[nb])
        if rising.any():
            out[end] = rising
    return out


def follow_out(fp, br, window, dofs, callback=None, **kw):
    """The Branch `br` (covering `window` [rad/s]) with its excursions beyond the ends
    where the amplitude of a DOF of `dofs` rises out of the window (module
    docstring), and the notes [text] of what each excursion found.  `kw`: the
    continuation options (ds, ds_max, max_points, segment_check).  Also returns the
    amplitudes (P, D) of `dofs` at the returned branch's points."""
    lo, hi = window
    notes = []
    A = amplitudes_at(fp.prob, br.x, br.lam, dofs)
    for end in ("first", "last"):   # each end decided on the branch as it is by then
        rising = rising_ends(br.lam, A, br.converged, window).get(end)
        if rising is None:
            continue
        last = end == "last"
        x0, lam0 = (br.x[-1], br.lam[-1]) if last else (br.x[0], br.lam[0])
        t_out = br.tangent[-1] if last else -br.tangent[0]
        width = hi - lo
        side = 1.0 if lam0 >= 0.5 * (lo + hi) else -1.0
        far = hi + FAR * width if side > 0 else max(lo - FAR * width, 0.5 * lo)
        back = max(lo - FAR * width, 0.5 * lo) if side > 0 else hi + FAR * width
        direction = int(np.sign(t_out[-1] * (far - lam0)))
        if direction == 0:
            continue
        stop = ExcursionStop(fp.prob, [d for d, r in zip(dofs, rising) if r], window, callback)
        ext = continue_branch(fp.fun, x0, lam0, far, tol=1.0, groups=fp.groups,
                              lam_back=back, tangent=t_out, direction=direction,
                              callback=stop, **kw)
        if len(ext) < 2:
            continue
        notes.append(stop.note(lam0, ext))
        ext = until_back(ext, window)   # the tail that left for good: not drawn
        if len(ext) > 1:
            parts = ([br, piece(ext, drop_first=True)] if last
                     else [piece(ext, reverse=True), piece(br, drop_first=True)])
            br = join(parts, br.message, br.success, br.status)
            A = amplitudes_at(fp.prob, br.x, br.lam, dofs)
        top = A[(br.lam >= lo) & (br.lam <= hi)][:, rising].max(axis=0)
        if np.any(stop.outside[0] > top):
            k = int(np.argmax(stop.outside[0] - top))
            notes.append(f"the largest amplitude traced of model DOF {stop.dofs[k]}, "
                         f"{stop.outside[0][k]:.6g} m at lam = {stop.outside[1][k]:.6g}, "
                         f"{OUTSIDE}")
    return br, notes, A


def until_back(br, window):
    """The Branch `br` up to its last point with lam inside `window` (its first point
    at least): the part of an excursion that came back, without the tail that left
    for good (folds kept where both their points are)."""
    lo, hi = window
    inside = np.flatnonzero((br.lam >= lo) & (br.lam <= hi))
    m = int(inside[-1]) + 1 if inside.size else 1
    if m == len(br):
        return br
    folds = br.fold_index < m - 1
    cut = {a: getattr(br, a)[:m] for a in ("x", "lam", "tangent", "converged", "nit",
                                             "point_nfev", "residual_norm")}
    return replace(br, **cut, fold_index=br.fold_index[folds], fold_lam=br.fold_lam[folds],
                   fold_x=br.fold_x[folds])


class ExcursionStop:
    """The callback of an excursion: True once the branch is outside the window,
    moving away from it, with every watched DOF's amplitude below the largest it
    reached on the excursion; or when the caller's callback asks, or raises at a
    point outside the window (its check, e.g. an undeclared separation, is the
    range's: the excursion stops there, and its tail is not kept)."""

    def __init__(self, prob, dofs, window, callback=None):
        self.prob, self.dofs, self.window, self.callback = prob, list(dofs), window, callback
        self.top = np.full(len(self.dofs), -np.inf)
        self.prev, self.returned, self.fell, self.refused = None, False, False, None
        # per DOF: the largest amplitude at a point outside the window, its lam
        self.outside = (np.full(len(self.dofs), -np.inf), np.full(len(self.dofs), np.nan))

    def __call__(self, x, lam):
        lo, hi = self.window
        try:
            if self.callback is not None and self.callback(x, lam):
                return True
        except Exception as exc:   # e.g. a separation not declared: the range's concern
            if lo <= lam <= hi:
                raise
            self.refused = str(exc)
            return True
        a = amplitudes_at(self.prob, x[None], np.array([lam]), self.dofs)[0]
        falling = bool(np.all(a < self.top))
        self.top = np.maximum(self.top, a)
        if not lo <= lam <= hi:
            more = a > self.outside[0]
            self.outside[0][more], self.outside[1][more] = a[more], lam
        away = (self.prev is not None and not lo <= lam <= hi
                and abs(lam - 0.5 * (lo + hi)) > abs(self.prev - 0.5 * (lo + hi)))
        self.returned |= self.prev is not None and lo < lam < hi
        self.prev = lam
        self.fell = away and falling
        return self.fell

    def note(self, lam0, ext) -> str:
        """What the excursion from lam0 found, for the curve's message."""
        how = ("came back into the range" if self.returned else "did not come back into "
               "the range")
        end = ("then fell away from it" if self.fell else
               f"stopped at lam = {ext.lam[-1]:.6g} ({self.refused or ext.message})")
        return (f"the branch rising out of the range at lam = {lam0:.6g} was followed: it "
                f"{how}, {end}")


def peak_points(prob, pts, dofs, window=(-np.inf, np.inf)) -> dict:
    """The branch points `pts` reduced to those where a DOF of `dofs` has its
    largest converged amplitude inside the `window` of lam, and outside it where
    the branch went there (each kept once, in branch order)."""
    L = pts["lam"]
    if L.size == 0:
        return pts
    dofs = list(dofs)
    A = pts.get("amplitude")  # from `insert_peaks`, if it drew these DOFs at these points
    if A is None or pts.get("amplitude_dofs") != dofs or len(A) != L.size:
        A = amplitudes_at(prob, pts["x"], L, dofs)
    A = np.where(pts["converged"][:, None], A, -np.inf)
    inside = ((L >= window[0]) & (L <= window[1]))[:, None]
    keep = [np.argmax(np.where(part, A, -np.inf), axis=0)[np.any(part & np.isfinite(A), 0)]
            for part in (inside, ~inside)]
    keep = np.unique(np.concatenate(keep))
    out = dict(pts)
    for k in ("x", "lam", "nit", "converged"):
        out[k] = np.asarray(pts[k])[keep]
    if "tangent" in pts:
        out["tangent"] = [pts["tangent"][k] for k in keep]
    out.pop("amplitude", None)
    return out


def windowed(curve, window, dofs, notes):
    """The ResponseCurve with info["window"] (its peaks read inside it) and, in its
    message, the excursions' `notes` and, where a DOF of `dofs` has its largest
    converged amplitude outside the window, where that is (not the range's peak)."""
    lo, hi = window
    inside = (curve.omega >= lo) & (curve.omega <= hi)
    out = []
    for d in dofs:
        a = np.where(curve.converged, curve.amplitude[:, d], -np.inf)
        k = int(np.argmax(a)) if a.size else 0
        if a.size and np.isfinite(a[k]) and not inside[k] and a[k] > np.max(
                np.where(inside, a, -np.inf)):
            out.append(f"the largest amplitude traced of model DOF {d}, {a[k]:.6g} m at lam = "
                       f"{curve.omega[k]:.6g}, {OUTSIDE}")
    said = any(OUTSIDE in n for n in notes)
    message = "; ".join([curve.message] + notes + ([] if said else out[:1]))
    return replace(curve, message=message, info={**curve.info, "window": (lo, hi),
                                                  "outside_peak": said or bool(out)})


def edge_points(fp, pts, window) -> dict:
    """The branch points `pts` (`response.branch_points`) with a point exactly on each
    edge of `window` that the branch crosses between two of them (one inside, one
    outside): Newton at lam = edge from the chord's crossing, its tangent the null
    vector of [dR/dx, dR/dlam] oriented along the branch.  The largest amplitude of a
    branch that rises out of the window is then its value at the edge, not at the last
    point before it.  A crossing whose Newton fails is left as it was."""
    L, X = pts["lam"], pts["x"]
    add = []
    for i in range(L.size - 1):
        for edge in window:
            if (L[i] - edge) * (L[i + 1] - edge) >= 0:
                continue   # no crossing, or a point already on the edge
            u = (edge - L[i]) / (L[i + 1] - L[i])
            nr = newton(lambda y: fp.fun(y, edge)[:2], X[i] + u * (X[i + 1] - X[i]), 1.0,
                        max_iter=20)
            if nr.success:
                add.append((i + u, nr, edge))
    if not add:
        return pts
    keys = ("x", "lam", "nit", "converged", "tangent")
    out = {**pts, **{k: list(pts[k]) for k in keys}}
    out.pop("amplitude", None)   # drawn at the points before
    for pos, nr, edge in sorted(add, key=lambda a: -a[0]):   # from the end: indices hold
        k = int(pos) + 1
        _, Jx, Jl = fp.fun(nr.x, edge)
        try:
            t = np.append(-linear_solve(Jx, Jl), 1.0)
        except (np.linalg.LinAlgError, RuntimeError):   # a fold on the edge: left out
            continue
        ref = np.asarray(pts["tangent"][k - 1])
        t = t * np.sign(t @ ref) * np.linalg.norm(ref / pts["scale"]) / np.linalg.norm(
            t / pts["scale"])
        for key, v in (("x", nr.x), ("lam", edge), ("nit", nr.nit), ("converged", True),
                       ("tangent", t)):
            out[key].insert(k, v)
    for key, dtype in (("x", float), ("lam", float), ("nit", int), ("converged", bool)):
        out[key] = np.array(out[key], dtype)
    out["extra_nfev"] = pts["extra_nfev"] + sum(nr.nfev + 1 for _, nr, _ in add)
    return out
