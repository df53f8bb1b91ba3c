"""Restarted continuations joined into one branch that covers a parameter range.

Like `continuation`, this module knows nothing about mechanics: `fun(x, lam) ->
(R, dR_dx, dR_dlam)` as for `continuation.continue_branch`, and the caller's
`first_point(lam, guess) -> (NewtonResult, nfev spent)` at a fixed parameter.

    cover_range             the branch across [lam0, lam_end]: from a first point at
                            lam0, else from one at lam_end traced backwards
    trace_range             the branch through a first point, followed back past lam0
                            (through a fold there) and, if it ends on that side,
                            traced both ways from the first point
    continue_past_corners   `continue_branch`, restarted at a fixed parameter a little
                            further where its step collapses at a corner
    piece, join             a Branch reversed and/or without its first point; Branches
                            joined into one

A joined branch is a `Branch` like any other: its points in order along the joined
curve (tangents oriented along it, normalised in the joined scale, the largest of
the parts' scales), its folds re-indexed to the joined points, and its costs
(nfev, njev, n_rejected) those of every attempt, discarded ones included.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .branch import Branch
from .pseudo_arclength import continue_branch
from .newton import newton

_BACK = 0.2  # how far (fraction of the range) a branch may be followed back past its start


def _read_only(a, dtype=float):
    a = np.asarray(a, dtype=dtype)
    a.setflags(write=False)
    return a


def piece(br: Branch, reverse=False, drop_first=False) -> Branch:
    """The branch without its first point (drop_first), then in reverse order.

    Reversed, the tangents point the other way.  Folds keep their places between
    points: a fold between the dropped first point and the next one is given the
    index -1 (or, reversed, the last index), i.e. it lies between this piece and
    the one it is joined to.
    """
    k = 1 if drop_first else 0
    order = slice(None, None, -1) if reverse else slice(None)
    m = len(br) - k if len(br) else 0
    fold_index = br.fold_index - k
    if reverse:
        fold_index = m - 2 - fold_index[::-1]
    cut = {a: _read_only(getattr(br, a)[k:][order], getattr(br, a).dtype)
           for a in ("x", "lam", "converged", "nit", "point_nfev", "residual_norm")}
    tangent = br.tangent[k:][order]
    return replace(br, tangent=_read_only(-tangent if reverse else tangent),
                   fold_index=_read_only(fold_index, int),
                   fold_lam=_read_only(br.fold_lam[order]),
                   fold_x=_read_only(br.fold_x[order]), **cut)


def join(parts, message, success, status, discarded=()) -> Branch:
    """One Branch of the parts' points in order.  nfev, njev and n_rejected count the
    `discarded` attempts too; n_unresolved and min_step are the parts'."""
    every = list(parts) + list(discarded)
    offsets = np.cumsum([0] + [len(p) for p in parts[:-1]])
    scale = np.max([p.scale for p in parts], axis=0)
    tangent = np.concatenate([p.tangent for p in parts])
    tangent = tangent / np.linalg.norm(tangent / scale, axis=1, keepdims=True)

    def cat(name, dtype=float):
        return _read_only(np.concatenate([getattr(p, name) for p in parts]), dtype)

    return Branch(
        x=cat("x"), lam=cat("lam"), tangent=_read_only(tangent),
        converged=cat("converged", bool), nit=cat("nit", int),
        point_nfev=cat("point_nfev", int), residual_norm=cat("residual_norm"),
        fold_index=_read_only(np.concatenate(
            [p.fold_index + o for p, o in zip(parts, offsets)]), int),
        fold_lam=cat("fold_lam"), fold_x=cat("fold_x"),
        nfev=sum(p.nfev for p in every), njev=sum(p.njev for p in every),
        n_rejected=sum(p.n_rejected for p in every),
        min_step=min(p.min_step for p in parts), scale=_read_only(scale),
        success=success, status=status, message=message,
        n_unresolved=sum(p.n_unresolved for p in parts))


def cover_range(fun, first_point, lam0, lam_end, tol, groups, guess=None, **kw):
    """The branch across [lam0, lam_end]: from the first point at lam0 (`trace_range`);
    if that does not reach lam_end (an isolated arc, or no first point at lam0), from
    a first point at lam_end backwards, returned in the order lam0 -> lam_end.  A
    branch that still does not reach the other end is no success.
    Returns (Branch, nfev spent on first points)."""
    nr, spent = first_point(lam0, guess)
    br = trace_range(fun, nr.x, lam0, lam_end, tol, groups, **kw)
    if br.status in (1, -2):
        nr_end, spent_end = first_point(lam_end)
        spent += spent_end
        rb = trace_range(fun, nr_end.x, lam_end, lam0, tol, groups, **kw)
        if rb.status == 0:
            br = join([piece(rb, reverse=True)], f"reached {lam_end} (traced backwards from "
                      f"there; from {lam0}: {br.message})", True, 0, discarded=[br])
        else:
            br = join([br], br.message, False, br.status, discarded=[rb])
    if br.status == 1:  # the range is not covered: an incomplete curve is no success
        br = join([br], f"{lam_end} not reached: {br.message}", False, 1)
    return br, spent


def trace_range(fun, x0, lam0, lam_end, tol, groups, **kw):
    """The branch through (x0, lam0) across [lam0, lam_end] (`continue_past_corners`).

    A start between two folds (e.g. on the unstable middle branch of an S-curve)
    sends the branch back past lam0; it is followed there, up to _BACK of the range
    beyond lam0 (staying positive), through its next fold.  If it still ends on the
    lam0 side, the other side of the branch through the first point is traced too
    (initial tangent reversed); when that reaches lam_end, the curve is both pieces
    joined at the first point (with points beyond lam0).
    """
    span = lam_end - lam0
    back = lam0 - _BACK * span
    if span > 0 and lam0 > 0:
        back = max(back, 0.5 * lam0)
    br = continue_past_corners(fun, x0, lam0, lam_end, tol, groups, lam_back=back, **kw)
    if br.status != 1 or br.lam.size < 2:
        return br
    other = continue_past_corners(fun, x0, lam0, lam_end, tol, groups, lam_back=back,
                                  direction=-1, **kw)
    if other.status != 0:
        return join([br], br.message, br.success, br.status, discarded=[other])
    return join([piece(br, reverse=True), piece(other, drop_first=True)],
                other.message + " (the branch through the first point traced both ways)",
                True, 0)


def continue_past_corners(fun, x0, lam0, lam_end, tol, groups, max_restarts=4,
                          lam_back=None, **kw):
    """`continue_branch`, restarted where it stalls at a corner of the branch.

    At a corner the one-sided tangents can alternate between accepted points so that
    the step shrinks to its minimum without crossing.  Then the point just beyond is
    solved at a fixed parameter a little further (damped Newton from the last point)
    and the continuation resumes from it, but only if that point is continuous with
    the last one (relative change below 5 %, so no jump to another branch) and the
    parameter keeps its direction of travel.
    """
    parts = []
    x, lam = x0, lam0
    back = lam0 if lam_back is None else lam_back
    for _ in range(max_restarts + 1):
        br = continue_branch(fun, x, lam, lam_end, tol=tol, groups=groups,
                             lam_back=back if back != lam else None, **kw)
        parts.append(br)
        if br.success or br.status != -1 or br.lam.size < 2:
            break
        jumped = _step_past_corner(fun, br, lam0, lam_end, back, tol)
        if jumped is None:
            break
        x, lam, direction = jumped
        # keep the direction of travel (towards or away from lam_end)
        kw["direction"] = 1 if direction * (lam_end - lam) > 0 else -1
    last = parts[-1]
    if len(parts) == 1:
        return last
    return join(parts, last.message + f" (after {len(parts) - 1} restart(s) past corners)",
                bool(last.success), int(last.status))


def _step_past_corner(fun, br, lam0, lam_end, back, tol):
    """(x, lam, direction of travel) of a point a little beyond the last one of `br`
    at a fixed parameter, continuous with it; None if there is none in [back, lam_end]."""
    xl, ll = br.x[-1], br.lam[-1]
    direction = np.sign(br.lam[-1] - br.lam[-2]) or np.sign(lam_end - lam0)
    span = abs(lam_end - lam0)
    for frac in (1e-4, 1e-3, 1e-2):
        lt = ll + direction * frac * span
        if (lt - back) * (lt - lam_end) > 0:
            return None
        r = newton(lambda y: fun(y, lt)[:2], xl, tol, max_iter=30)
        if r.success and np.linalg.norm(r.x - xl) <= 0.05 * max(np.linalg.norm(xl), 1e-300):
            return r.x, lt, direction
    return None
