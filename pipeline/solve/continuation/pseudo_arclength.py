"""Pseudo-arclength continuation of R(x, lam) = 0 (Keller; NLvib `solve_and_continue`).

Solves the n equations R(x, lam) = 0 for a branch of points (x, lam), x in R^n, by
predictor-corrector steps in the scaled unknowns y = [x; lam] / s:

    predictor   [dR/dx S_x, dR/dlam s_lam; t_prev^T] t = e_{n+1},  t <- t / |t|
                y_pred = y_k + ds t
    corrector   Newton on  R(x, lam) = 0,  t^T (y - y_pred) = 0, started where that
                hyperplane meets the cubic through the last two points and their
                tangents (on a smooth stretch; else at y_pred)

Continuation knows nothing about mechanics: `fun(x, lam) -> (R, dR_dx, dR_dlam)`
with R (n,), dR_dx (n, n) dense or scipy.sparse, dR_dlam (n,).

Convergence rule: a point is accepted only if its recomputed residual, in the
caller's units, satisfies ||R||_2 <= tol + tol_rel * r_ref.  Nothing else (Newton
step size, iteration count) ever accepts a point.

Options of `continue_branch` (defaults):
    tol        absolute residual tolerance in the units of R (required)
    tol_rel    0.0; tolerance relative to `r_ref` (a caller-given reference norm,
               e.g. the norm of the excitation)
    ds         0.05   initial step in the scaled metric (~ fraction of the magnitudes)
    ds_min     1e-6   smallest step; below it the run stops with a failure
    ds_max     0.5    largest step
    max_points 500    points including the first one
    max_newton 10     corrector iterations per attempt
    target_newton 4   iterations aimed at by the step control
    max_turn   pi/4   largest angle between successive tangents (scaled metric);
               larger turns are rejected (guards against branch jumping)
    scale      None   automatic: s_lam = |lam_end - lam0|, s_x = running maximum of
               |x| per component, floored at 1e-2 * its largest entry; or an array
               (n+1,) of positive fixed scales [x scales..., lam scale]
    max_deviation 0.3 largest distance of the corrected point from the predictor, in
                      step lengths (scaled metric); farther steps are rejected: the
                      secant left the tangent, i.e. the step crossed a feature
    kink_ds    0.01   below this step, a turn or deviation that persists when the step
                      is halved is accepted as a kink of the branch
    groups     None   (n,) group label per unknown: the automatic x scale is shared
                      within a group (e.g. all Fourier coefficients of one DOF)
    callback   None   callback(x, lam) after each accepted point; return True to stop
    refine_folds True  locate each fold by a few extra correctors (regula falsi on the
               lam-component of the tangent); False: cubic Hermite estimate only
    direction  +1     +1 starts towards lam_end, -1 reverses the initial tangent
               (useful at a fold, where the lam-component of the tangent vanishes,
               or with `lam_back`; otherwise the first step leaves the interval)
    lam_back   None   how far the run may go back beyond lam0 (on the side away from
               lam_end); default lam0.  With it, a branch that turns back past lam0
               (a start between two folds) is followed through its next fold.
    segment_check None  segment_check(x0, lam0, x1, lam1) -> None if a step from the
               current point to the corrected one may be taken, else the largest
               admissible |lam1 - lam0| (e.g. a resonance lies inside the step:
               `resonance.step_guard`); the step is shortened to fit.  A refused
               step that cannot shrink below ds_min is taken and counted in
               `n_unresolved`.
    tangent    None   a tangent (n+1,) of the branch at (x0, lam0) in physical units,
               if the caller knows it (e.g. from a corrector on a hyperplane there):
               the first tangent is then not computed (a dense QR); it is oriented
               like a computed one

The run stops when lam leaves the interval between lam_back and lam_end (the last
point is then re-solved exactly on the boundary), at max_points, on a callback
request, or when ds < ds_min.

Limits: branch points (bifurcations) are neither detected nor switched (the
bordered system is singular there; the run usually steps over them).  The step
control reads Newton counts, so with an inexact Jacobian (linear convergence) set
target_newton to the count the solver needs, or steps keep shrinking.  The first
tangent is the null vector of [J, J_lam] by a dense QR (O(n^3), robust at a fold);
with a sparse J it is a bordered solve that needs dR/dx regular at lam0.

Pieces: `arclength.continuation_options` checks the options once into a frozen
`arclength.ContinuationOptions`; `arclength.Metric` holds the scale s
(`automatic_scale`); `arclength.ScaledEquations` evaluates R and solves the
bordered systems in y (Newton by `newton.newton_core`), counting the costs; a
`tracer.Tracer` runs the steps (first point, predict, correct, assess, accept or
reject, pass corner, commit) and returns the `branch.Branch`, whose folds
`branch.refine_fold` locates.  `continue_branch` builds the options and runs a Tracer.
"""
from __future__ import annotations

import math

from .arclength import checked_start, continuation_options
from .branch import Branch
from .tracer import Tracer


def continue_branch(fun, x0, lam0, lam_end, *, tol=None, tol_rel=0.0, r_ref=None,
                    ds=0.05, ds_min=1e-6, ds_max=0.5, max_points=500, max_newton=10,
                    target_newton=4, max_turn=math.pi / 4, scale=None, callback=None,
                    direction=+1, refine_folds=True, groups=None,
                    max_deviation=0.3, kink_ds=0.01, lam_back=None,
                    segment_check=None, tangent=None) -> Branch:
    """Trace the solution branch of R(x, lam) = 0 from (x0, lam0) towards lam_end.

    See the module docstring for the equations and the options.  Numerical failure
    is returned as a Branch with success False; bad arguments raise ValueError.
    """
    if not callable(fun):
        raise ValueError("fun must be callable: fun(x, lam) -> (R, dR_dx, dR_dlam)")
    x0 = checked_start(x0)
    opts = continuation_options(
        x0.size, lam0, lam_end, tol=tol, tol_rel=tol_rel, r_ref=r_ref, ds=ds, ds_min=ds_min,
        ds_max=ds_max, max_points=max_points, max_newton=max_newton,
        target_newton=target_newton, max_turn=max_turn, scale=scale, callback=callback,
        direction=direction, refine_folds=refine_folds, groups=groups,
        max_deviation=max_deviation, kink_ds=kink_ds, lam_back=lam_back,
        segment_check=segment_check, tangent=tangent)
    return Tracer(fun, opts).run(x0)
