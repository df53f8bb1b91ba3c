"""Stability by the fold rule: one cheap verdict, flipped at every fold of the branch.

Along a branch of forced periodic responses, a Floquet multiplier crosses the unit
circle at +1 at every fold (the branch turns back in frequency), and the flag flips
there.  Without secondary bifurcations (period doubling, Neimark-Sacker) nothing
else changes it, so one decided point fixes the branch (`stretches.fold_parity`):

    stable[i] = stable[a] XOR (parity[i] - parity[a] odd),   a: a decided point.

The decided points are the two ends of the branch, where a verdict is cheap:

    linear      no contact switches over the period (every element stuck or open
                throughout): the flow along the orbit is that of a linear structure,
                q'' M + q' C + q (K + K_c) = 0 with M > 0 and C, K + K_c symmetric
                positive semi-definite, whose energy never grows: stable (marginally
                where C leaves a mode undamped).  No computation.
    monodromy   otherwise the orbit monodromy (`orbit_floquet.along_orbit`) where its
                matrix exponentials stay within MAX_WORK (events x (2n + E)^3; a
                Craig-Bampton blade with 216 events and 470 unknowns took 15 s).

Where neither end can be decided, the first point is taken stable (the start of a
sweep below the resonance), and the note says so.  Where both ends are decided and
disagree with the fold count between them, a secondary bifurcation lies on the
branch: the rule does not hold, every point is left not computed and the note says
to ask for a full method (`stability = true`).  Cost: one or two verdicts a branch,
against one monodromy per point.
"""
from __future__ import annotations

import numpy as np

from .stretches import fold_parity

MAX_WORK = 5e9   # events x dim^3 of an orbit monodromy the rule will pay for at an end


def fold_rule(lam, converged, verdict) -> tuple:
    """(stable (P,) bool, decided {index: bool}, note) of the branch lam (P,) with
    converged flags (P,) by the fold rule (module docstring); `verdict(i)` -> True,
    False or None (too dear) at an end.  stable is None where the rule is
    contradicted (a secondary bifurcation between the decided ends)."""
    conv = np.flatnonzero(np.asarray(converged, bool))
    P = np.asarray(lam).size
    if not conv.size:
        return np.ones(P, bool), {}, "fold rule: no converged point"
    parity = fold_parity(lam, converged)
    decided = {}
    for i in dict.fromkeys((int(conv[0]), int(conv[-1]))):
        v = verdict(i)
        if v is not None:
            decided[i] = bool(v)
    note = ("fold rule: the flag flips at each fold (assumes no period doubling or "
            "Neimark-Sacker bifurcation), from the verdict at ")
    if not decided:
        decided_flag, a = True, int(conv[0])
        note += "the first point, taken stable (a check there costs more than the rule allows)"
    else:
        a = min(decided)
        decided_flag = decided[a]
        note += "the branch's ends (linear flow or orbit monodromy)"
        base = {i: v ^ bool(parity[i] % 2) for i, v in decided.items()}
        if len(set(base.values())) > 1:
            return None, decided, (
                "fold rule contradicted: the verdicts at the branch's ends disagree with "
                "its fold count, so a secondary bifurcation lies on it; not computed (ask "
                "for `stability = true`)")
    flip = (parity - parity[a]) % 2 == 1
    stable = np.where(flip, not decided_flag, decided_flag)
    return stable.astype(bool), decided, note
