"""Which stability flag to trust along a branch: Hill's method, the Floquet multipliers
of the exact flow, or Hill checked by them where it is in doubt.

Modes (`solver.stability` of a study, `stability=` of `response.frequency_response`):

    "hill"        Hill's method (`stability.is_stable`) at every point.
    "floquet"     the multipliers of the exact event-driven flow (`floquet.from_hbm`:
                  the orbit converged by shooting from the HBM point, monodromy by
                  the saltation product) at every converged point; Hill where they
                  cannot be had (the shooting or the integration failed).
    "hill+check"  Hill at every point; the Floquet multipliers, which then decide, at
                  the converged points where Hill is in doubt:
                    - its margin is small, |max Re lam| T < CHECK_MARGIN (Hill's
                      equivalent multiplier rho_H = exp(max Re lam T) in [e^-m, e^m]);
                    - the decided flag changes between two neighbours (both checked,
                      repeated until every change has Floquet on both sides);
                    - the peak of each DOF.
    "monodromy"   the multipliers of the exact flow linearised along the harmonic-
                  balance orbit (`orbit_floquet.along_orbit`: the kernel's transition
                  times, closed-form pieces and saltations, no integration, one
                  eigenproblem of size 2n + kept sliders) at every point; Hill where it
                  does not apply (frictionless elements).
    "monodromy+check"  the same, checked by the exact Floquet multipliers (which then
                  decide) where |log max |mu|| < MONODROMY_MARGIN and some element
                  switches in the period (without a switch the flow along the orbit is
                  linear and its monodromy exp(A T) exact), at both neighbours of every
                  change of the decided flag and at the peak of each DOF.
    "stretch"     "monodromy" (up to MAX_MONODROMY_DOF DOFs of the exact flow, else Hill)
                  at a few points of each stretch between two folds (its ends and
                  middle point, the peak of the response's norm over the DOFs, the
                  points beside each fold), the flag
                  propagated over the stretch (`stretches`: stability changes only at
                  folds and bifurcations; a secondary bifurcation inside a stretch is
                  found by bisection where its decided points disagree).  For reduced
                  FE models, where Hill at every point costs too much.
    None / False  not computed.

CHECK_MARGIN = 0.5 (rho_H in [0.61, 1.65]).  Measured: on a 3-DOF shrouded blade with
one Yang-Menq contact (tests/test_floquet.py) Hill calls unstable, with margins up to
0.28, orbits whose multipliers are 0.83-0.93; at stiff impact it calls stable, with
margin 0.39, an orbit whose largest multiplier is 1.05; in a seeded corpus of 40 random
2-4-DOF contact systems (tests/test_stability_check.py) the largest Hill margin at a
wrong Hill flag is 0.18.  A lightly damped structure (max Re lam T ~ -2 pi zeta) lies
inside the margin: there every point is checked.  A Floquet check costs one shooting + one monodromy (0.1-0.2 s
on a few DOFs), about a tenth of a continuation point at H = 10.

MONODROMY_MARGIN = 0.1 (max |mu| in [0.90, 1.11]).  Measured against the exact
multipliers (`floquet.from_hbm`) on the 3-DOF blade at H = 10 (89 points) and the 40
corpus systems at H = 5 (1149 points): the orbit monodromy's verdict is never wrong
(Hill's is at 51), its largest |mu| differs by at most 0.032 (the blade, where the
orbit itself is least converged in H), so the margin is three times that.

Cyclic sectors (`System.cyclic`): the exact flow of one sector is not the wheel's, so
their Floquet multipliers are those of the whole tuned wheel (`cyclic.wheel_system`,
the sector solution expanded to every sector, `cyclic.expand`): every wave number is
free, as in Hill's problem per wave number (`wave_jacobians`).

Beyond the shooting - more than MAX_WHEEL_DOF DOFs, or a flow so stiff that the event
search would sample a period more than MAX_SHOOTING_SAMPLES times at a uniform step
(a Craig-Bampton blade: 1e7-1e8, `shooting_samples`) - the orbit monodromy takes the
Floquet check's place up to MAX_MONODROMY_DOF DOFs (`effective_mode`); above that
every mode keeps Hill.

Where Hill and Floquet disagree, Floquet decides.  A "marginal" Floquet verdict
(|mu| within 1e-6 of 1) counts as stable, as Hill's relative margin does.

Per point: `method` (-1 not computed, 0 Hill, 1 Floquet, 2 monodromy, 3 propagated:
the flag of a decided point of the same stretch, "stretch" mode), `hill_multiplier`
rho_H (NaN where Hill was not run), `floquet_multiplier` max |mu| (NaN where not
run).  Bifurcations: wherever the decided flag changes between two converged
neighbours, the kind of the multiplier leaving the unit circle on the unstable side
- fold (a detected fold lies between them, or a real multiplier through +1),
period doubling (real, through -1), Neimark-Sacker (complex pair) - at the
parameter where the decided multiplier crosses 1 (interpolated in log |mu|).
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np

from ..model.cyclic import expand, wheel_system
from ..model.system import dense
from . import floquet
from .full_operators import wave_jacobians
from .orbit_floquet import along_orbit
from .stability import is_stable
from .stretches import propagate, stretches

log = logging.getLogger(__name__)

MODES = ("hill", "floquet", "hill+check", "monodromy", "monodromy+check", "stretch")
NOT_COMPUTED, HILL, FLOQUET, MONODROMY, PROPAGATED = -1, 0, 1, 2, 3
FOLD, PERIOD_DOUBLING, NEIMARK_SACKER = 1, 2, 3
KINDS = {FOLD: "fold", PERIOD_DOUBLING: "period doubling", NEIMARK_SACKER: "Neimark-Sacker"}
KIND_CODES = {v: k for k, v in KINDS.items()}
CHECK_MARGIN = 0.5
MONODROMY_MARGIN = 0.1    # |log max |mu|| of the orbit monodromy below which Floquet checks it
MAX_WHEEL_DOF = 200    # the shooting (Floquet) runs on exact flows of up to this many DOFs
MAX_MONODROMY_DOF = 400   # ... the orbit monodromy on up to this many (an FE blade's 352)
MAX_SHOOTING_SAMPLES = 1e5  # ... and whose event search samples a period at most this often


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


@dataclass(frozen=True)
class BranchStability:
    """Decided stability of the P points of a branch (module docstring)."""

    stable: np.ndarray              # (P,) bool; True where not computed
    method: np.ndarray              # (P,) int8: -1 not computed, 0 Hill, 1 Floquet, 2 monodromy
    hill_multiplier: np.ndarray     # (P,) exp(max Re lam T), NaN where Hill not run
    floquet_multiplier: np.ndarray  # (P,) max |mu|, NaN where Floquet not run
    bifurcation_parameter: np.ndarray  # (B,)
    bifurcation_kind: np.ndarray    # (B,) int8: 1 fold, 2 period doubling, 3 Neimark-Sacker
    note: str                       # how it was decided, in words
    floquet_time: float = 0.0       # [s]
    hill_time: float = 0.0          # [s]
    monodromy_multiplier: np.ndarray | None = None  # (P,) max |mu| along the HBM orbit
    monodromy_time: float = 0.0     # [s]

    @property
    def max_multiplier(self) -> np.ndarray:
        """The deciding method's largest |mu|: Floquet's, else the orbit monodromy's,
        else Hill's rho_H."""
        orb = (self.monodromy_multiplier if self.monodromy_multiplier is not None
               else np.full(self.hill_multiplier.shape, np.nan))
        return np.where(np.isfinite(self.floquet_multiplier), self.floquet_multiplier,
                        np.where(np.isfinite(orb), orb, self.hill_multiplier))


def _hill_kind(lam, Om) -> int:
    """Kind of the multiplier exp(lam T) of a critical Hill exponent lam."""
    f = abs(lam.imag) / Om          # frequency of the multiplier's phase, in Om
    if f < 1e-4:
        return FOLD
    return PERIOD_DOUBLING if abs(f - 0.5) < 1e-4 else NEIMARK_SACKER


class _Points:
    """Hill and Floquet at single points of a branch, each computed at most once."""

    def __init__(self, prob, Q, omega, lam, elem_at):
        P = omega.size
        self.prob, self.Q, self.omega, self.lam, self.elem_at = prob, Q, omega, lam, elem_at
        self.hill = np.full(P, np.nan)
        self.hill_stable = np.ones(P, bool)
        self.hill_kind = np.zeros(P, np.int8)
        self.fq = np.full(P, np.nan)
        self.fq_stable = np.ones(P, bool)
        self.fq_kind = np.zeros(P, np.int8)
        self.fq_tried = np.zeros(P, bool)
        self.orb = np.full(P, np.nan)
        self.orb_stable = np.ones(P, bool)
        self.orb_kind = np.zeros(P, np.int8)
        self.orb_events = np.zeros(P, int)   # switches in the period (0: a linear flow)
        self.orb_tried = np.zeros(P, bool)
        self.times = [0.0, 0.0, 0.0]

    def run_hill(self, i):
        if np.isfinite(self.hill[i]):
            return
        t0, Om, H = time.perf_counter(), self.omega[i], self.prob.H
        worst, ok = None, True
        for _, J, Mr, Cr in wave_jacobians(self.prob, self.Q[i], Om, self.elem_at(self.lam[i])):
            st, _, ex = is_stable(J, Mr, Cr, Om, H)
            ok &= st
            if ex.size and (worst is None or ex[0].real > worst.real):
                worst = ex[np.argmax(ex.real)]
        T = 2 * np.pi / Om
        self.hill_stable[i] = ok
        self.hill[i] = np.exp(worst.real * T) if worst is not None else 0.0
        self.hill_kind[i] = _hill_kind(worst, Om) if worst is not None else FOLD
        self.times[0] += time.perf_counter() - t0

    def orbit(self, i):
        """(system, Q) of point i as an orbit of the exact flow: a cyclic sector's
        travelling wave as an orbit of the whole wheel."""
        s = replace(self.prob.system, contact=self.elem_at(self.lam[i]))
        Q = self.Q[i]
        if s.cyclic is not None:
            Q = expand(Q, s.cyclic.sectors, s.cyclic.engine_order)
            s = wheel_system(s)
        return s, Q

    def run_monodromy(self, i):
        """The monodromy of the flow linearised along the HBM orbit (`orbit_floquet`);
        left NaN where that method does not apply."""
        if self.orb_tried[i]:
            return
        self.orb_tried[i] = True
        t0 = time.perf_counter()
        s, Q = self.orbit(i)
        try:
            r = along_orbit(s, self.omega[i], Q)
        except (ValueError, np.linalg.LinAlgError) as exc:
            log.debug("orbit monodromy at %.6g rad/s failed: %s", self.omega[i], exc)
            r = None
        self.times[2] += time.perf_counter() - t0
        if r is None or not np.isfinite(r.max_modulus):
            return
        self.orb[i] = r.max_modulus
        self.orb_events[i] = r.n_events
        self.orb_stable[i] = r.verdict != "unstable"
        kind = r.leaving[0] if r.leaving else r.critical
        self.orb_kind[i] = KIND_CODES.get(kind, FOLD)

    def run_floquet(self, i):
        if self.fq_tried[i]:
            return
        self.fq_tried[i] = True
        t0 = time.perf_counter()
        s, Q = self.orbit(i)
        try:
            r = floquet.from_hbm(s, self.omega[i], Q)
        except (ValueError, np.linalg.LinAlgError) as exc:
            log.debug("Floquet at %.6g rad/s failed: %s", self.omega[i], exc)
            r = None
        self.times[1] += time.perf_counter() - t0
        if r is None or not (r.success and r.orbit_converged) or not np.isfinite(r.max_modulus):
            return
        self.fq[i] = r.max_modulus
        self.fq_stable[i] = r.verdict != "unstable"
        kind = r.leaving[0] if r.leaving else r.critical
        self.fq_kind[i] = KIND_CODES.get(kind, FOLD)


def branch_stability(prob, Q, omega, lam, elem_at, converged, mode, fold_lam=(),
                     amplitude=None, margin: float = CHECK_MARGIN) -> BranchStability:
    """Decided stability of the branch points (Q (P, n, 2H+1), omega (P,), parameter
    lam (P,), contact elements elem_at(lam)) in `mode` (`stability_mode`); `fold_lam`
    the detected folds, `amplitude` (P, n) for the peaks (module docstring)."""
    mode = stability_mode(mode)
    P = omega.size
    pts = _Points(prob, Q, omega, np.asarray(lam, float), elem_at)
    conv = np.flatnonzero(np.asarray(converged, bool))
    size = flow_dof(prob.system)
    stiff = (stability_mode(mode) not in (None, "hill") and size <= MAX_WHEEL_DOF
             and P > 0 and shooting_samples(prob.system, omega) > MAX_SHOOTING_SAMPLES)
    note = describe(mode, size, margin, stiff)
    mode, check = effective_mode(mode, size, stiff)
    if mode is None:
        return _result(pts, np.full(P, NOT_COMPUTED, np.int8), fold_lam, conv, note)
    if mode == "stretch":
        return _stretch_result(pts, conv, amplitude, fold_lam, note,
                               size <= MAX_MONODROMY_DOF)
    if mode in ("hill", "hill+check"):
        for i in range(P):
            pts.run_hill(i)
    if mode in ("monodromy", "monodromy+check"):
        for i in range(P):
            pts.run_monodromy(i)
            if not np.isfinite(pts.orb[i]):
                pts.run_hill(i)
    if mode == "floquet":
        for i in conv:
            pts.run_floquet(i)
        for i in range(P):
            if not np.isfinite(pts.fq[i]):
                pts.run_hill(i)
    elif mode == "hill+check":
        _check_doubtful(pts, conv, lambda i: _near_one(pts.hill[i], margin), amplitude, check)
    elif mode == "monodromy+check":   # no switch in the period: the linear flow, exact
        _check_doubtful(pts, conv, lambda i: (pts.orb_events[i] > 0
                                              and _near_one(pts.orb[i], MONODROMY_MARGIN))
                        if np.isfinite(pts.orb[i]) else _near_one(pts.hill[i], margin),
                        amplitude, check)
    method = np.where(np.isfinite(pts.fq), FLOQUET,
                      np.where(np.isfinite(pts.orb), MONODROMY, HILL)).astype(np.int8)
    return _result(pts, method, fold_lam, conv, note)


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
    if mode in (None, "hill", "stretch") or (size <= MAX_WHEEL_DOF and not stiff):
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


def _near_one(multiplier, margin) -> bool:
    return abs(np.log(max(multiplier, 1e-300))) < margin


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


def _stretch_result(pts, conv, amplitude, fold_lam, note, orbit) -> BranchStability:
    """"stretch" mode: at the points `stretches.propagate` asks for, the orbit
    monodromy if `orbit` (Hill where it does not apply), else Hill; the flag
    propagated to the others (method PROPAGATED, multipliers NaN)."""
    # the peak of the response as a whole (the norm over the DOFs), not of each DOF:
    # on a reduced FE model every DOF's own peak would be a decision
    peaks = ([conv[int(np.argmax(np.linalg.norm(amplitude[conv], axis=1)))]]
             if amplitude is not None and conv.size else [])

    def decide(i):
        if orbit:
            pts.run_monodromy(i)
            if np.isfinite(pts.orb[i]):
                return pts.orb_stable[i]
        pts.run_hill(i)
        return pts.hill_stable[i]

    stable, done = propagate(stretches(pts.lam, np.isin(np.arange(pts.lam.size), conv)),
                             decide, peaks)
    method = np.full(pts.lam.size, PROPAGATED, np.int8)
    method[done] = np.where(np.isfinite(pts.orb[done]), MONODROMY, HILL)
    prop = np.setdiff1d(np.arange(stable.size), done)
    pts.hill_stable[prop] = pts.orb_stable[prop] = stable[prop]
    return _result(pts, method, fold_lam, conv, note)


def _decided(pts):
    return np.where(np.isfinite(pts.fq), pts.fq_stable,
                    np.where(np.isfinite(pts.orb), pts.orb_stable, pts.hill_stable))


def _check_doubtful(pts, conv, doubtful, amplitude, check="floquet"):
    """The `check` ("floquet", or "monodromy" on flows beyond the shooting) where the
    first method is in doubt (`doubtful(i)`), at the peaks, then at both neighbours
    of every change of the decided flag until each change has it on both sides."""
    run, tried = ((pts.run_floquet, pts.fq_tried) if check == "floquet"
                  else (pts.run_monodromy, pts.orb_tried))
    for i in conv:
        if doubtful(i):
            run(i)
    if amplitude is not None and conv.size:
        for d in range(amplitude.shape[1]):
            run(conv[int(np.argmax(amplitude[conv, d]))])
    while True:
        st = _decided(pts)
        todo = [k for a, b in zip(conv[:-1], conv[1:]) if st[a] != st[b]
                for k in (a, b) if not tried[k]]
        if not todo:
            return
        for k in todo:
            run(k)


def _result(pts, method, fold_lam, conv, note) -> BranchStability:
    computed = method != NOT_COMPUTED
    stable = np.where(computed, _decided(pts), True)
    par, kind = _bifurcations(pts, stable, conv, np.asarray(fold_lam, float)) \
        if computed.any() else (np.zeros(0), np.zeros(0, np.int8))
    return BranchStability(
        stable=stable.astype(bool), method=method, hill_multiplier=pts.hill,
        floquet_multiplier=pts.fq, bifurcation_parameter=par, bifurcation_kind=kind,
        note=note, hill_time=pts.times[0], floquet_time=pts.times[1],
        monodromy_multiplier=pts.orb, monodromy_time=pts.times[2])


def _bifurcations(pts, stable, conv, fold_lam):
    """(parameter (B,), kind (B,)) where the decided flag changes between neighbours."""
    mult = np.where(np.isfinite(pts.fq), pts.fq, np.where(np.isfinite(pts.orb), pts.orb, pts.hill))
    kinds = np.where(np.isfinite(pts.fq), pts.fq_kind,
                     np.where(np.isfinite(pts.orb), pts.orb_kind, pts.hill_kind))
    par, kind = [], []
    for a, b in zip(conv[:-1], conv[1:]):
        if stable[a] == stable[b]:
            continue
        la, lb = pts.lam[a], pts.lam[b]
        lo, hi = min(la, lb), max(la, lb)
        folds = fold_lam[(fold_lam >= lo) & (fold_lam <= hi)]
        if folds.size:
            par.append(float(folds[0]))
            kind.append(FOLD)
            continue
        u = b if stable[a] else a
        ga, gb = np.log(max(mult[a], 1e-300)), np.log(max(mult[b], 1e-300))
        s = np.clip(-ga / (gb - ga), 0.0, 1.0) if gb != ga else 0.5
        par.append(float(la + s * (lb - la)))
        kind.append(int(kinds[u]) or FOLD)
    return np.array(par, float), np.array(kind, np.int8)
