"""Stability decided at a few points of each stretch of a branch and propagated.

The stability of a periodic solution changes only where a Floquet multiplier
crosses the unit circle: at a fold (a real multiplier through +1, where the branch
turns back in frequency) or at a secondary bifurcation (period doubling,
Neimark-Sacker).  Between two such points every solution has the same verdict, so
one point of a stretch decides it:

    stretches   the converged points of a branch, cut at every gap (a point that
                did not converge) and at every turning point k of the parameter
                lam (lam[k] - lam[k-1] and lam[k+1] - lam[k] of opposite sign),
                which forms a stretch of its own: the fold lies within one step
                of k on one side or the other, so k is decided by itself;
    decided at  the first, middle and last points of each stretch and each DOF's peak
                (the point of largest amplitude) inside it;
    propagated  a stretch whose decided points agree takes their verdict at every
                point; where two decided points of a stretch disagree, a secondary
                bifurcation lies between them: bisection (decide the middle point
                between them) until the change lies between neighbours;
    checked     at both neighbours of every change of the flag along the branch
                (the two points beside each fold), repeated until each change has a
                decided point on both sides; a decided neighbour that contradicts
                its stretch's verdict starts the bisection there.

What remains an assumption: a pair of secondary bifurcations inside one stretch
that no decided point separates (the branch loses and regains stability between
two decided points of the same verdict).  The cost is a handful of decisions per
stretch instead of one per point: on P points with F folds about 1 + 3F + (DOFs)
decisions, plus log2 of the stretch length for each secondary bifurcation.

The fold rule (`fold_parity`) is the cheapest form of the same fact: without
secondary bifurcations the flag flips at every fold and nowhere else, so one decided
point fixes the whole branch.  The turning point k keeps the flag of the points
before it; the fold is counted between k and k + 1.  A gap (points that did not
converge) across which the parameter reverses counts as a fold too.
"""
from __future__ import annotations

import numpy as np


def stretches(lam, converged) -> list:
    """Index arrays of the stretches of a branch with parameter lam (P,) and
    converged flags (P,) (module docstring): cut at gaps and at turning points,
    each turning point a stretch of its own."""
    conv = np.flatnonzero(np.asarray(converged, bool))
    lam = np.asarray(lam, float)
    parts, cur = [], []
    for j, i in enumerate(conv):
        if cur and i != cur[-1] + 1:
            parts.append(cur)
            cur = []
        turn = (0 < j < conv.size - 1 and conv[j - 1] == i - 1 and conv[j + 1] == i + 1
                and (lam[i] - lam[i - 1]) * (lam[i + 1] - lam[i]) < 0)
        if turn:
            if cur:
                parts.append(cur)
            parts.append([i])
            cur = []
        else:
            cur.append(i)
    if cur:
        parts.append(cur)
    return [np.array(p, int) for p in parts]


def fold_parity(lam, converged) -> np.ndarray:
    """(P,) int: the number of folds of the parameter lam (P,) passed along the
    converged points (`converged` (P,) bool) before each of them, -1 at the others
    (module docstring: the flag of point i is that of point j flipped
    parity[i] - parity[j] times)."""
    conv = np.flatnonzero(np.asarray(converged, bool))
    lam = np.asarray(lam, float)
    out = np.full(lam.size, -1, int)
    count, last = 0, 0.0
    for j, i in enumerate(conv):
        if j:
            step = lam[i] - lam[conv[j - 1]]
            if step != 0.0:
                if last != 0.0 and np.sign(step) != np.sign(last):
                    count += 1
                last = step
        out[i] = count
    return out


def propagate(parts, decide, peaks=()) -> tuple:
    """(stable (P,) bool over the indices of `parts`, decided (sorted int array)):
    each stretch of `parts` (`stretches`) decided at its ends, middle point and the
    `peaks` inside it, `decide(i) -> bool` called at most once per point, bisected
    where its decided points disagree, and checked at both neighbours of every
    change of the flag (module docstring).  Points outside every stretch stay True."""
    known: dict = {}

    def at(i):
        i = int(i)
        if i not in known:
            known[i] = bool(decide(i))
        return known[i]

    peaks = {int(p) for p in peaks}
    for p in parts:
        for i in (p[0], p[p.size // 2], p[-1]):
            at(i)
        for i in peaks.intersection(p.tolist()):
            at(i)
    size = max((int(p[-1]) + 1 for p in parts), default=0)
    while True:
        stable = np.ones(size, bool)
        for p in parts:
            _bisect(p, at, known)
            _fill(p, known, stable)
        order = np.concatenate(parts) if parts else np.zeros(0, int)
        todo = [int(k) for a, b in zip(order[:-1], order[1:]) if stable[a] != stable[b]
                for k in (a, b) if int(k) not in known]
        if not todo:
            return stable, np.array(sorted(known), int)
        for k in todo:
            at(k)


def _bisect(p, at, known):
    """Decide the middle points between disagreeing decided points of stretch `p`
    until every change of the flag lies between neighbours."""
    while True:
        pos = [j for j, i in enumerate(p) if int(i) in known]
        gaps = [(a, b) for a, b in zip(pos[:-1], pos[1:])
                if b > a + 1 and known[int(p[a])] != known[int(p[b])]]
        if not gaps:
            return
        for a, b in gaps:
            at(p[(a + b) // 2])


def _fill(p, known, stable):
    """Each point of stretch `p` takes the verdict of the nearest decided point at
    or before it (the first decided point's before that)."""
    pos = [j for j, i in enumerate(p) if int(i) in known]
    flag = known[int(p[pos[0]])]
    for i in p:
        flag = known.get(int(i), flag)
        stable[i] = flag
