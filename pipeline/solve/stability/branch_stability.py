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
    "folds"       the fold rule (`fold_rule`): a verdict at the branch's ends where
                  it is cheap (no contact switches: a linear damped flow, stable; else
                  the orbit monodromy within a work budget), flipped at every fold.
                  The default of FE scenes, where every other mode costs minutes.
    None / False  not computed.

CHECK_MARGIN = 0.5 (rho_H in [0.61, 1.65]).  Measured: on a 3-DOF shrouded blade with
one Yang-Menq contact (tests/solve/stability/test_floquet.py) Hill calls unstable, with margins up to
0.28, orbits whose multipliers are 0.83-0.93; at stiff impact it calls stable, with
margin 0.39, an orbit whose largest multiplier is 1.05; in a seeded corpus of 40 random
2-4-DOF contact systems (tests/solve/stability/test_stability_check.py) the largest Hill margin at a
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
the flag of a decided point of the same stretch, "stretch" mode; 4 fold rule),
`hill_multiplier`
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

from ...contact.exact import periodic_segments
from ...model.cyclic import expand, wheel_system
from ...model.system import dense
from . import floquet
from .fold_rule import MAX_WORK, fold_rule
from ..harmonic_balance.full_operators import wave_jacobians
from ..harmonic_balance.hbm import contact_motion
from .orbit_floquet import along_orbit
from .hill import is_stable
from .methods import (CHECK_MARGIN, FLOQUET, FOLD, FOLD_RULE, HILL, KIND_CODES,
                              MAX_MONODROMY_DOF, MAX_SHOOTING_SAMPLES, MAX_WHEEL_DOF,
                              MONODROMY, MONODROMY_MARGIN, NEIMARK_SACKER,
                              NOT_COMPUTED, PERIOD_DOUBLING, PROPAGATED, describe,
                              effective_mode, flow_dof, require_mode, shooting_samples,
                              stability_mode)
from .stretches import propagate, stretches

log = logging.getLogger(__name__)


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

    def run_monodromy(self, i, max_work=None):
        """The monodromy of the flow linearised along the HBM orbit (`orbit_floquet`);
        left NaN where that method does not apply (or costs more than `max_work`)."""
        if self.orb_tried[i]:
            return
        self.orb_tried[i] = True
        t0 = time.perf_counter()
        s, Q = self.orbit(i)
        try:
            r = along_orbit(s, self.omega[i], Q, max_work=max_work)
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

    def linear_at(self, i) -> bool:
        """No contact switches over the period of point i (every element stuck or
        open throughout: the flow along the orbit is linear)."""
        prob = self.prob
        if prob.idx.shape[0] == 0:
            return True
        U, V = contact_motion(prob, self.Q[i][prob.c])
        regime = periodic_segments(U, V, self.elem_at(self.lam[i]))["regime"]
        return bool(np.all((regime == 0) | (regime == 1)))

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
    require_mode(prob.system.laws, mode)
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
    if mode == "folds":
        return _folds_result(pts, conv, fold_lam, size <= MAX_MONODROMY_DOF)
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


def _near_one(multiplier, margin) -> bool:
    return abs(np.log(max(multiplier, 1e-300))) < margin


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


def _folds_result(pts, conv, fold_lam, orbit) -> BranchStability:
    """"folds" mode (`fold_rule`): the ends decided by linearity or, if `orbit`, by
    the orbit monodromy within MAX_WORK; method FOLD_RULE elsewhere."""
    sym = all(np.allclose(a, a.T) for a in (dense(getattr(pts.prob.system, k))
                                           for k in ("M", "K", "C")))

    def verdict(i):
        if sym and pts.linear_at(i):
            return True
        if orbit:
            pts.run_monodromy(i, MAX_WORK)
            if np.isfinite(pts.orb[i]):
                return bool(pts.orb_stable[i])
        return None

    stable, _, note = fold_rule(pts.lam, np.isin(np.arange(pts.lam.size), conv), verdict)
    if stable is None:
        return _result(pts, np.full(pts.lam.size, NOT_COMPUTED, np.int8), fold_lam, conv, note)
    method = np.where(np.isfinite(pts.orb), MONODROMY, FOLD_RULE).astype(np.int8)
    ruled = method == FOLD_RULE
    pts.hill_stable[ruled] = pts.orb_stable[ruled] = stable[ruled]
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
        if not (np.isfinite(mult[a]) and np.isfinite(mult[b])):   # a propagated flag
            par.append(float(0.5 * (la + lb)))
            kind.append(int(kinds[u]) or FOLD)
            continue
        ga, gb = np.log(max(mult[a], 1e-300)), np.log(max(mult[b], 1e-300))
        s = np.clip(-ga / (gb - ga), 0.0, 1.0) if gb != ga else 0.5
        par.append(float(la + s * (lb - la)))
        kind.append(int(kinds[u]) or FOLD)
    return np.array(par, float), np.array(kind, np.int8)
