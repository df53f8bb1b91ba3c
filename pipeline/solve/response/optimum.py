"""The global minimum of the resonant peak over the preload: grid, brackets, Brent.

The peak-versus-preload curve p(n0) of a friction damper need not be unimodal: a
shrouded disk's curve (studies/shrouded_disk.toml) has a local minimum (2.658e-5 m at
1.437 N) beside the global one (2.017e-5 m at 6.144 N), and a bounded Brent search over the whole bounds lands in
whichever basin its first golden-section points fall in.  `global_minimum` therefore

1. samples p on a grid of nodes t_0 < ... < t_N over the bounds, t = ln n0
   (log spacing: bounds span decades) or t = x (linear: a variable that crosses zero,
   a shroud interference [m]): `grid_nodes` gives N + 1 = max(MIN_NODES,
   ceil(PER_DECADE log10(hi / lo)) + 1) evenly spaced nodes (linear: `min_nodes`),
   plus the `extra_nodes` inside the bounds (the study's own cases, whose peaks are
   known: free nodes), each of which replaces a regular node closer than SNAP of the
   spacing (a case at 3 N stands for the node at 3.16 N: one continuation fewer, the
   largest gap (1 + SNAP) spacings);
2. brackets every local minimum of the sampled curve: a node i with
   p_i < p_(i-1) and p_i <= p_(i+1) (an end node against its one neighbour), unless
   it is flat (both sides within FLAT_REL relative: a stuck or open plateau, not a
   basin);
3. refines each bracket [t_(i-1), t_(i+1)] by Brent's method (golden section and
   parabolic steps, started from the known node t_i) to xatol = rtol / REFINE in t
   (rtol (hi - lo) / REFINE on a linear grid): Brent stops with the minimiser anywhere in a final
   bracket about 4/3 xatol wide, and the peak is flat at its minimum (Example 1: 1e-6
   over 1 % of preload), so a tenth of rtol keeps the optimum within rtol with margin;
   — best basin first; a later bracket whose parabola through its three nodes stays
   more than SKIP_REL above the best peak found is not refined (its minimum would
   have to dip that far below the parabola within one node spacing, which the
   assumption below excludes): the shrouded disk's basin at 1.44 N (parabola 2.66e-5 m
   against 2.017e-5 m found at 6.14 N) costs no continuation;
4. returns the best of all evaluations.

A peak that does not depend on the preload (every grid node's value the same to
round-off: relative spread (max - min) / max below FLAT_SPREAD, e.g. a contact whose
closure an `interference` fixes) has no optimum: the search stops after the grid
and returns preload NaN, `independent` True and the `spread` (the peak and its
frequency those of the first node, the value at every preload).  Nor has a smallest
peak shared by a stretch of the bounds (two grid nodes or more within `plateau_rel`
of the best value, PLATEAU_REL or the peaks' round-off: a shroud gap that stays open over the cycle, the peak the free blades'
whatever the gap): preload NaN and `plateau` (low, high), the evaluations there.

Assumption (when a minimum can still be missed): the global minimum's basin must hold
a grid node whose value is below the nodes on either side, i.e. the interval around
the minimiser over which p is lower than both neighbouring nodes must be wider than
the largest node gap ((1 + SNAP) / PER_DECADE decades with log spacing).  A dip narrower than the
spacing can fall between two nodes whose values both exceed those of another basin;
the grid then never brackets it and the search returns the best minimum it did
bracket.  Friction-damper peaks vary smoothly with log n0 over a fraction of a decade
or more (the slip onset moves with n0 / mu ku), so PER_DECADE = 4 (factor 1.78
between nodes) resolves the two basins of the shrouded disk (1.44 N and 6.14 N, a
factor 4.3 apart): nodes 1.78 N and 5.62 N fall in them, the case at 3 N between.

The function is evaluated through a memo keyed by the exact preload: `known` values
(the study's case curves) are never recomputed.  An interrupted search's evaluations
(`replay`) are never recomputed either, but each enters the memo only when the search
asks for its preload: the decisions read the memo (the best value so far, a bracket's
nodes, the evaluated preload nearest a trial, a trial already valued over the band),
so a search that knew a later evaluation too early would decide otherwise than the
run that made it.  Taken in turn, the trial points depend only on the values, and a
resumed search visits exactly the same preloads as an uninterrupted one.
"""
from __future__ import annotations

import logging
import math

import numpy as np

logger = logging.getLogger(__name__)

PER_DECADE = 4          # grid nodes per decade of preload (log spacing)
MIN_NODES = 7           # at least this many grid nodes however narrow the bounds
LINEAR_NODES = 9        # grid nodes of a linear search (an interference) unless asked
REFINE = 10             # Brent's xatol = rtol / REFINE (module docstring)
SNAP = 1.0 / 3.0        # an extra node replaces a regular one this close (of the spacing)
FLAT_REL = 1e-7         # a local minimum shallower than this (relative) is a plateau
PLATEAU_REL = FLAT_REL  # grid nodes this close to the best (relative): a flat minimum; a
PLATEAU_PER_TOL = 100   # search on traced peaks widens it to this many Newton tolerances, above
#                         their round-off (8e-8 on the shrouded disk at tolerance 1e-8)
SKIP_REL = 0.1          # a bracket whose parabola stays this far above the best: not refined
FLAT_SPREAD = 1e-9      # grid values within this relative spread: the peak ignores n0
VERIFY_REL = 1e-6       # a bracket's local result and its band value agree to this (relative)
GOLDEN = 0.5 * (3.0 - math.sqrt(5.0))
SQRT_EPS = math.sqrt(np.finfo(float).eps)
MAX_BRENT_STEPS = 100


def grid_nodes(lo: float, hi: float, *, log: bool = True, per_decade: float = PER_DECADE,
               min_nodes: int = MIN_NODES, extra=()) -> np.ndarray:
    """Sorted preloads [N] of the search grid: N + 1 = max(min_nodes, ceil(per_decade
    log10(hi / lo)) + 1) nodes evenly spaced in ln n0 (`log`) or in n0 from lo to hi,
    plus the `extra` preloads inside [lo, hi], each replacing the regular nodes (not
    the bounds) closer than SNAP of the spacing; duplicates (relative 1e-12) once."""
    lo, hi = float(lo), float(hi)
    if not lo < hi or (log and lo <= 0):
        raise ValueError(f"bounds must satisfy {'0 < ' if log else ''}low < high, got "
                         f"({lo:g}, {hi:g})")
    decades = math.log10(hi / lo) if log else 0.0   # linear: min_nodes nodes
    n = max(int(min_nodes), int(math.ceil(per_decade * decades - 1e-9)) + 1)
    base = np.exp(np.linspace(math.log(lo), math.log(hi), n)) if log else np.linspace(lo, hi, n)
    base[0], base[-1] = lo, hi      # exactly the bounds (exp(ln x) may round)
    more = [float(x) for x in extra if lo <= float(x) <= hi]
    if more and n > 2:
        t = np.log(base) if log else base
        tm = np.log(more) if log else np.asarray(more)
        gap = SNAP * (t[-1] - t[0]) / (n - 1)
        near = np.abs(t[:, None] - tm[None, :]).min(axis=1) < gap
        near[[0, -1]] = False
        base = base[~near]
    nodes = np.sort(np.concatenate([base, np.asarray(more, dtype=float)]))
    keep = np.concatenate([[True], np.diff(nodes) > 1e-12 * np.abs(nodes[1:])])
    # a node within 1e-12 of an extra one: keep the extra one (its value is known)
    out = []
    for x, k in zip(nodes, keep):
        if k:
            out.append(x)
        elif x in more:
            out[-1] = x
    return np.asarray(out)


def local_minima(values) -> list[int]:
    """Indices i of the local minima of a sampled curve: v_i < v_(i-1) and
    v_i <= v_(i+1) (an end node against its one neighbour), finite, and not flat
    (some side deeper than FLAT_REL |v_i|)."""
    v = np.asarray(values, dtype=float)
    out = []
    for i in range(v.size):
        if not np.isfinite(v[i]):
            continue
        left = v[i - 1] if i > 0 else np.inf
        right = v[i + 1] if i + 1 < v.size else np.inf
        if not (v[i] < left and v[i] <= right):
            continue
        sides = [d for d in (left, right) if np.isfinite(d)]
        if sides and max(sides) - v[i] <= FLAT_REL * abs(v[i]):
            continue          # a plateau (both neighbours equal to noise), not a basin
        out.append(i)
    return out


def brent(f, a: float, b: float, xatol: float, x: float | None = None, fx: float | None = None):
    """Minimise f on [a, b] by Brent's method (golden section with parabolic steps;
    Brent 1973, ch. 5) to |x - x*| about xatol.  Started from the interior point x with
    the known value fx if given, else from the golden point a + 0.382 (b - a).
    Returns (x, f(x)) of the best point; f may return inf (a failed evaluation)."""
    if x is None:
        x = a + GOLDEN * (b - a)
        fx = f(x)
    v = w = x
    fv = fw = fx
    d = e = 0.0
    for _ in range(MAX_BRENT_STEPS):
        m = 0.5 * (a + b)
        tol = SQRT_EPS * abs(x) + xatol / 3.0
        if abs(x - m) <= 2.0 * tol - 0.5 * (b - a):
            break
        parabolic = False
        if abs(e) > tol and np.isfinite([fx, fw, fv]).all():
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            if q > 0:
                p = -p
            q = abs(q)
            if abs(p) < abs(0.5 * q * e) and q * (a - x) < p < q * (b - x):
                e, d = d, p / q
                parabolic = True
                if (x + d - a) < 2 * tol or (b - x - d) < 2 * tol:
                    d = tol if x < m else -tol
        if not parabolic:
            e = (b - x) if x < m else (a - x)
            d = GOLDEN * e
        u = x + (d if abs(d) >= tol else math.copysign(tol, d))
        fu = f(u)
        if fu <= fx:
            if u < x:
                b = x
            else:
                a = x
            v, fv, w, fw, x, fx = w, fw, x, fx, u, fu
        else:
            if u < x:
                a = u
            else:
                b = u
            if fu <= fw or w == x:
                v, fv, w, fw = w, fw, u, fu
            elif fu <= fv or v == x or v == w:
                v, fv = u, fu
    return x, fx


def global_minimum(evaluate, bounds, *, rtol: float = 1e-3, log: bool = True,
                   per_decade: float = PER_DECADE, min_nodes: int = MIN_NODES, known=None,
                   extra_nodes=(), on_evaluation=None, local=None, verify_rel: float = VERIFY_REL,
                   evaluate_many=None, replay=None, plateau_rel=PLATEAU_REL) -> dict:
    """The preload in `bounds` [N] with the smallest value of evaluate(n0) -> (peak,
    omega), peak = inf for a failed evaluation (see the module docstring: grid,
    brackets of every local minimum, Brent in each to |d ln n0| <= rtol / REFINE
    (`log`) or |d n0| <= rtol (hi - lo) / REFINE; at least `min_nodes` grid nodes).

    known: {n0: (peak, omega)} known from the start (the cases); replay: those of an
    interrupted run, each taken for evaluate(n0) when asked; extra_nodes: added nodes;
    on_evaluation(n0, peak, omega) is called after each new evaluation (a checkpoint).
    evaluate_many(list of n0, record): the grid nodes not known yet evaluated together
    (e.g. in parallel), record(n0, peak, omega) called as each ends; else one by one.

    local(n0, near) -> (peak, omega): a cheaper lower bound of evaluate(n0) from the
    evaluated preload `near` (the peak continued in preload) for Brent's trials, its
    result checked by evaluate to verify_rel (`refine_bracket`).  Returns a dict:
    preload, peak, peak_omega, evaluations [(n0, peak, omega)] sorted by n0 (every
    preload looked at, reused ones included; peak and omega NaN where the evaluation
    failed), local (the preloads among them valued by `local` alone), verified [(n0,
    local, full)] (each bracket's check), grid (the nodes), brackets [(low, node, high)]
    [N], skipped (the brackets not refined: SKIP_REL), computed (new evaluations),
    reused, success (some evaluation finite), spread (the grid's `relative_spread`),
    independent (below FLAT_SPREAD: preload NaN, module docstring), plateau ((low, high)
    of a smallest peak shared, to plateau_rel, by a stretch: preload NaN; or None)."""
    lo, hi = float(bounds[0]), float(bounds[1])
    memo = {float(k): (float(p), float(o)) for k, (p, o) in dict(known or {}).items()}
    kept = {float(k): (float(p), float(o)) for k, (p, o) in dict(replay or {}).items()}
    lmemo, reused, verified, computed = {}, set(), [], [0]   # lmemo: n0 -> `local`'s bound

    def record(n0, p, om):
        p, om = float(p), float(om)
        if not np.isfinite(p):
            p, om = np.inf, np.nan
        memo[n0] = (p, om)
        computed[0] += 1
        if on_evaluation is not None:
            on_evaluation(n0, p, om)
        return p

    def peak_at(n0):
        n0 = float(n0)
        if n0 in memo or n0 in kept:
            reused.add(n0)
            memo.setdefault(n0, kept.get(n0))
            return memo[n0][0]
        return record(n0, *evaluate(n0))

    to_n0 = (lambda t: float(np.exp(t))) if log else float
    to_t = (lambda n0: math.log(n0)) if log else float
    nodes = grid_nodes(lo, hi, log=log, per_decade=per_decade, min_nodes=min_nodes,
                       extra=extra_nodes)
    todo = [float(n0) for n0 in nodes if float(n0) not in memo and float(n0) not in kept]
    if evaluate_many is not None and len(todo) > 1:
        evaluate_many(todo, record)
    values = [peak_at(n0) for n0 in nodes]
    reused.difference_update(todo)      # evaluated here, not known before
    spread = relative_spread(values)   # below FLAT_SPREAD: no basin, the peak ignores n0
    t = [to_t(n0) for n0 in nodes]
    xatol = (rtol if log else rtol * (hi - lo)) / REFINE
    brackets, skipped = [], []
    for i in sorted(local_minima(values) if spread >= FLAT_SPREAD else [], key=values.__getitem__):
        a, b = t[max(i - 1, 0)], t[min(i + 1, len(t) - 1)]
        brackets.append((to_n0(a), float(nodes[i]), to_n0(b)))
        best = min(p for p, _ in memo.values())
        if len(brackets) > 1 and parabola_floor(t, values, i) > (1 + SKIP_REL) * best:
            skipped.append(brackets[-1])
            continue
        inner = (t[i], values[i]) if 0 < i < len(t) - 1 else (None, None)
        if local is None:
            brent(lambda s: peak_at(to_n0(s)), a, b, xatol, *inner)
        else:
            verified.append(refine_bracket(peak_at, local, memo, lmemo, to_n0, to_t,
                                           (a, b), xatol, inner, verify_rel, (lo, hi)))
        logger.debug("optimum search: bracket [%.6g, %.6g] N refined", to_n0(a), to_n0(b))
    return _result(memo, lmemo, (lo, hi), grid=[float(x) for x in nodes], verified=verified,
                   brackets=brackets, skipped=skipped, computed=computed[0],
                   reused=len(reused), independent=spread < FLAT_SPREAD, spread=spread,
                   plateau_rel=plateau_rel)


def relative_spread(values) -> float:
    """(max - min) / max |v| of the sampled values; inf where fewer than two, or some
    not finite (a failed evaluation: the curve is not known there), or all zero."""
    v = np.asarray(values, dtype=float)
    top = np.max(np.abs(v)) if v.size else 0.0
    if v.size < 2 or not np.all(np.isfinite(v)) or top == 0:
        return np.inf
    return float((v.max() - v.min()) / top)


def _result(memo, lmemo, bounds, **more) -> dict:
    """`global_minimum`'s dict: the evaluations within `bounds` (full and local values
    merged, full ones first), the best full value (preload NaN where `more` says the
    peak is independent of it), and `more`."""
    lo, hi = bounds
    merged = {**{k: v for k, v in lmemo.items() if k not in memo}, **memo}
    evaluations = sorted((n0, (p if np.isfinite(p) else np.nan), om)
                         for n0, (p, om) in merged.items() if lo <= n0 <= hi)
    # candidates: full values only (a local value is a lower bound, checked where it won)
    finite = [e for e in evaluations if np.isfinite(e[1]) and e[0] in memo]
    best = min(finite, key=lambda e: e[1]) if finite else (np.nan, np.nan, np.nan)
    plateau, rel = None, more.pop("plateau_rel", PLATEAU_REL)
    if more.get("independent"):    # the value at every preload (the first node's): no optimum
        best = (np.nan, *memo[more["grid"][0]])
    elif finite:
        plateau = flat_minimum(finite, more["grid"], best[1], rel)
        best = best if plateau is None else (np.nan, *best[1:])
    return {"preload": best[0], "peak": best[1], "peak_omega": best[2],
            "evaluations": evaluations,
            "local": sorted(k for k in lmemo if k not in memo and lo <= k <= hi),
            "success": bool(finite), "plateau": plateau, **more}


def flat_minimum(evaluations, grid, best: float, rel: float = PLATEAU_REL) -> tuple | None:
    """(low, high) of the `evaluations` [(x, peak, omega)] whose peak equals the `best`
    to `rel` where two `grid` nodes or more are among them (the smallest peak is the
    same over at least one node spacing: no single optimum), else None."""
    flat = [x for x, p, _ in evaluations if p - best <= rel * abs(best)]
    if np.isin(flat, grid).sum() < 2:
        return None
    return (float(min(flat)), float(max(flat)))


def refine_bracket(full, local, memo, lmemo, to_n0, to_t, ab, xatol, inner, verify_rel,
                   bounds):
    """Brent in the bracket `ab` (in t) on local values, the result evaluated in `full`
    (the memoised evaluation) and compared: returns (n0, local peak, full peak) of
    that check; where the two differ by more than verify_rel (relative), Brent runs
    again on full values (logged).

    local(n0, near) -> (peak, omega) is asked from the evaluated preload `near`
    nearest to n0 within `bounds`; it never exceeds full(n0) and equals it while the
    same maximum stays the largest (the peak continued in preload); inf where it finds
    none (then full(n0) is taken).  Since every local value is a lower bound, a
    verified result is the best of the preloads tried by their full values too."""
    def local_at(s):
        n0 = to_n0(s)
        if n0 in memo:
            return memo[n0][0]
        if n0 not in lmemo:
            done = {k: v for k, v in {**lmemo, **memo}.items()
                    if np.isfinite(v[0]) and bounds[0] <= k <= bounds[1]}
            near = min(done, key=lambda k: (abs(to_t(k) - s), k)) if done else None
            p, om = local(n0, near) if near is not None else (np.inf, np.nan)
            if not np.isfinite(p):
                return full(n0)
            lmemo[n0] = (float(p), float(om))
        return lmemo[n0][0]

    x, _ = brent(local_at, *ab, xatol, *inner)
    n0 = to_n0(x)
    guess = lmemo.get(n0, memo.get(n0, (np.inf,)))[0]
    p = full(n0)
    if abs(p - guess) <= verify_rel * abs(p):   # the same maximum (either way: a local
        return (n0, guess, p)                   # value above the band's is no lower bound)
    logger.warning("optimum search: the peak at %.6g N is %.6g m over the band, %.6g m "
                   "continued from a nearby preload: the bracket [%.6g, %.6g] N is refined "
                   "again on the whole band", n0, p, guess, to_n0(ab[0]), to_n0(ab[1]))
    brent(lambda s: full(to_n0(s)), *ab, xatol, *inner)
    return (n0, guess, p)


def parabola_floor(t, values, i) -> float:
    """The lowest value of the parabola through nodes i-1, i, i+1 (its vertex, inside
    the bracket); node i's value at an end of the grid or where a neighbour failed."""
    if not 0 < i < len(t) - 1 or not np.isfinite(values[i - 1:i + 2]).all():
        return float(values[i])
    (x0, x1, x2), (y0, y1, y2) = t[i - 1:i + 2], values[i - 1:i + 2]
    d1, d2 = (y1 - y0) / (x1 - x0), (y2 - y1) / (x2 - x1)
    c = (d2 - d1) / (x2 - x0)              # the parabola's curvature / 2
    if c <= 0:
        return float(min(y0, y1, y2))
    xv = 0.5 * (x0 + x1) - d1 / (2 * c)    # its vertex
    return float(y0 + d1 * (xv - x0) + c * (xv - x0) * (xv - x1))
