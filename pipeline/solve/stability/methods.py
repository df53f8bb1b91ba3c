"""Which stability mode runs where, and how it reads in words: the modes, their codes,
and the size and stiffness limits that send a mode to a cheaper one
(`stability_check` runs them; its docstring describes each mode).
"""
from __future__ import annotations

import numpy as np

from ...contact.laws import require_all
from ...model.system import dense

MODES = ("hill", "floquet", "hill+check", "monodromy", "monodromy+check", "stretch", "folds")
NOT_COMPUTED, HILL, FLOQUET, MONODROMY, PROPAGATED, FOLD_RULE = -1, 0, 1, 2, 3, 4
FOLD, PERIOD_DOUBLING, NEIMARK_SACKER = 1, 2, 3
KINDS = {FOLD: "fold", PERIOD_DOUBLING: "period doubling", NEIMARK_SACKER: "Neimark-Sacker"}
KIND_CODES = {v: k for k, v in KINDS.items()}
CHECK_MARGIN = 0.5
MONODROMY_MARGIN = 0.1    # |log max |mu|| of the orbit monodromy below which Floquet checks it
MAX_WHEEL_DOF = 200    # the shooting (Floquet) runs on exact flows of up to this many DOFs
MAX_MONODROMY_DOF = 400   # ... the orbit monodromy on up to this many (an FE blade's 352)
MAX_SHOOTING_SAMPLES = 1e5  # ... and whose event search samples a period at most this often


# the solvers (`contact.laws.SOLVERS`) each mode may run: a contact law must support
# all of them (the event-driven flow exists for the Yang-Menq element only)
MODE_SOLVERS = {"hill": ("hill",), "floquet": ("hill", "shooting", "timesim"),
                "hill+check": ("hill", "shooting", "timesim"),
                "monodromy": ("hill", "orbit_floquet"),
                "monodromy+check": ("hill", "orbit_floquet", "shooting", "timesim"),
                "stretch": ("hill", "orbit_floquet"), "folds": ("hill", "orbit_floquet")}


def require_mode(laws, mode) -> None:
    """ValueError naming the law when one of `laws` (`System.laws`) cannot be run
    by a solver the stability `mode` needs."""
    mode = stability_mode(mode)
    for solver in MODE_SOLVERS.get(mode, ()):
        try:
            require_all(laws, solver)
        except ValueError as exc:
            raise ValueError(f"stability {mode!r}: {exc}") from None


def stability_mode(value) -> str | None:
    """The mode of a `stability` argument: True -> "hill", False/None -> None, a
    string of MODES as it is; ValueError naming the argument otherwise."""
    if value is None or value is False:
        return None
    if value is True:
        return "hill"
    if isinstance(value, str) and value in MODES:
        return value
    raise ValueError(f"stability must be true, false or one of {', '.join(map(repr, MODES))}, "
                     f"got {value!r}")


def effective_mode(mode, size: int, stiff: bool = False) -> tuple:
    """(mode run, check "floquet" | "monodromy") for `mode` on an exact flow of `size`
    DOFs (`flow_dof`), `stiff` if its event search would take more than
    MAX_SHOOTING_SAMPLES samples a period (`shooting_samples`).  Up to MAX_WHEEL_DOF
    DOFs and not stiff, every mode runs as named, checked by Floquet.  Otherwise the
    shooting is out of reach (an FE blade's stiff reduced model, a large wheel): up
    to MAX_MONODROMY_DOF "hill+check" is checked by the orbit monodromy instead,
    and "floquet" and "monodromy+check" run as "monodromy"; above that, every mode
    runs as "hill"."""
    mode = stability_mode(mode)
    if mode in (None, "hill", "stretch", "folds") or (size <= MAX_WHEEL_DOF and not stiff):
        return mode, "floquet"
    if size > MAX_MONODROMY_DOF:
        return "hill", "floquet"
    return ("hill+check" if mode == "hill+check" else "monodromy"), "monodromy"


def shooting_samples(system, omega) -> float:
    """Samples per period (at the lowest of the frequencies `omega` [rad/s]) of the
    exact integrator's event search, which steps (pi/6)/max|lambda| of the flow
    (`events`), from the bound max|lambda| <= ||M^-1 C|| + sqrt(||M^-1 (K + K_c)||)
    (1-norms; K_c the contacts' springs ku, kv), without the grading to the modes
    still present (`piecewise.graded_steps`): a measure of stiffness.  Tens to
    hundreds on lumped systems, 1e7-1e8 on a Craig-Bampton blade, whose boundary DOFs
    are stiff: there every switch starts transients to resolve, and the shooting
    (many periods, each mode's eigenvectors) took over 10 minutes a point on a
    102-DOF blade, against 1-5 s for one period of the integration."""
    M, K, C, Bt, Bn = (np.abs(np.atleast_2d(dense(a)))
                       for a in (system.M, system.K, system.C, system.Bt, system.Bn))
    ct = system.contact
    if ct is not None and Bt.size and Bn.size:
        K = K + Bt.T @ (np.abs(ct.ku)[:, None] * Bt) + Bn.T @ (np.abs(ct.kv)[:, None] * Bn)
    try:
        Minv = np.abs(np.linalg.inv(M))
    except np.linalg.LinAlgError:   # a massless DOF: no closed-form pieces, no shooting
        return np.inf
    lam = (Minv @ C).sum(0).max() + np.sqrt((Minv @ K).sum(0).max())
    return float(2 * np.pi / np.min(omega) * lam * 6 / np.pi)


def flow_dof(system) -> int:
    """DOFs of the exact flow whose multipliers `floquet` and `monodromy` compute: the
    whole wheel for a cyclic sector."""
    cy = getattr(system, "cyclic", None)
    return system.n_dof * (cy.sectors if cy is not None else 1)


def describe(mode, size: int = 0, margin: float = CHECK_MARGIN, stiff: bool = False) -> str:
    """How `branch_stability` decides in `mode` (`stability_mode`) on an exact flow of
    `size` DOFs, `stiff` or not (`effective_mode`), in words."""
    mode = stability_mode(mode)
    run, check = effective_mode(mode, size, stiff)
    if run == "hill" and mode not in (None, "hill"):
        return ("Hill's method at every point (every wave number of a cyclic sector): the "
                f"exact flow has {size} > {MAX_MONODROMY_DOF} DOFs here (a cyclic sector's "
                f"is the whole wheel's), so {mode!r} keeps Hill")
    if check == "monodromy":
        why = (f"is too stiff for the event search (over {MAX_SHOOTING_SAMPLES:.0e} samples "
               "a period)" if stiff and size <= MAX_WHEEL_DOF else
               f"has {size} > {MAX_WHEEL_DOF} DOFs")
        beyond = f"the exact flow {why} here, beyond the shooting, so {mode!r} runs as "
        if run == "hill+check":
            return (beyond + "Hill's method, checked by the multipliers of the exact flow "
                    "linearised along the harmonic-balance orbit where |max Re lambda| T < "
                    f"{margin:g}, at both neighbours of every change of the flag and at the "
                    "peaks; where they disagree, the orbit monodromy decides")
        return (beyond + "the multipliers of the exact flow linearised along the "
                "harmonic-balance orbit at every point (Hill where that does not apply)")
    check = ("at both neighbours of every change of the flag and at the peaks; where they "
             "disagree, Floquet decides")
    return {None: "not computed", "hill": "Hill's method at every point",
            "stretch": "multipliers of the exact flow linearised along the harmonic-balance "
                       "orbit (Hill's method beyond that method's size or where it does not "
                       "apply) at the ends and middle point of each stretch between two "
                       "folds, at the peaks and beside each fold, the flag propagated over "
                       "the stretch (bisected where its decided points disagree)",
            "folds": "fold rule: a verdict at the branch's ends where it is cheap, "
                     "flipped at every fold",
            "floquet": "Floquet multipliers of the exact flow at every converged point (Hill "
                       "where the periodic orbit was not found)",
            "hill+check": "Hill's method, checked by the Floquet multipliers of the exact flow "
                          f"where |max Re lambda| T < {margin:g}, " + check,
            "monodromy": "multipliers of the exact flow linearised along the harmonic-balance "
                         "orbit at every point (Hill where that does not apply)",
            "monodromy+check": "multipliers of the exact flow linearised along the "
                               "harmonic-balance orbit, checked by those of the exact "
                               f"periodic orbit where |log max |mu|| < {MONODROMY_MARGIN:g} "
                               "and a contact switches in the period, " + check}[mode]
