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
    None / False  not computed.

CHECK_MARGIN = 0.5 (rho_H in [0.61, 1.65]).  Measured: on a 3-DOF shrouded blade with
one Yang-Menq contact (tests/test_floquet.py) Hill calls unstable, with margins up to
0.28, orbits whose multipliers are 0.83-0.93; at stiff impact it calls stable, with
margin 0.39, an orbit whose largest multiplier is 1.05; in a seeded corpus of 40 random
2-4-DOF contact systems (tests/test_stability_check.py) the largest Hill margin at a
wrong Hill flag is 0.18.  A lightly damped structure (max Re lam T ~ -2 pi zeta) lies
inside the margin: there every point is checked.  A Floquet check costs one shooting + one monodromy (0.1-0.2 s
on a few DOFs), about a tenth of a continuation point at H = 10.

Cyclic sectors (`System.cyclic`): the exact flow of one sector is not the wheel's, so
their Floquet multipliers are those of the whole tuned wheel (`cyclic.wheel_system`,
the sector solution expanded to every sector, `cyclic.expand`): every wave number is
free, as in Hill's problem per wave number (`wave_jacobians`).  Above MAX_WHEEL_DOF
DOFs in the wheel every mode keeps Hill.

Where Hill and Floquet disagree, Floquet decides.  A "marginal" Floquet verdict
(|mu| within 1e-6 of 1) counts as stable, as Hill's relative margin does.

Per point: `method` (-1 not computed, 0 Hill, 1 Floquet), `hill_multiplier`
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
from . import floquet
from .full_operators import wave_jacobians
from .stability import is_stable

log = logging.getLogger(__name__)

MODES = ("hill", "floquet", "hill+check")
NOT_COMPUTED, HILL, FLOQUET = -1, 0, 1
FOLD, PERIOD_DOUBLING, NEIMARK_SACKER = 1, 2, 3
KINDS = {FOLD: "fold", PERIOD_DOUBLING: "period doubling", NEIMARK_SACKER: "Neimark-Sacker"}
KIND_CODES = {v: k for k, v in KINDS.items()}
CHECK_MARGIN = 0.5
MAX_WHEEL_DOF = 200    # a cyclic sector's Floquet check integrates the whole wheel up to this


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
    method: np.ndarray              # (P,) int8: -1 not computed, 0 Hill, 1 Floquet
    hill_multiplier: np.ndarray     # (P,) exp(max Re lam T), NaN where Hill not run
    floquet_multiplier: np.ndarray  # (P,) max |mu|, NaN where Floquet not run
    bifurcation_parameter: np.ndarray  # (B,)
    bifurcation_kind: np.ndarray    # (B,) int8: 1 fold, 2 period doubling, 3 Neimark-Sacker
    note: str                       # how it was decided, in words
    floquet_time: float = 0.0       # [s]
    hill_time: float = 0.0          # [s]

    @property
    def max_multiplier(self) -> np.ndarray:
        """Floquet's largest |mu| where it was computed, Hill's rho_H elsewhere."""
        return np.where(np.isfinite(self.floquet_multiplier), self.floquet_multiplier,
                        self.hill_multiplier)


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
        self.times = [0.0, 0.0]

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

    def run_floquet(self, i):
        if self.fq_tried[i]:
            return
        self.fq_tried[i] = True
        t0 = time.perf_counter()
        s = replace(self.prob.system, contact=self.elem_at(self.lam[i]))
        Q = self.Q[i]
        if s.cyclic is not None:   # the travelling wave as an orbit of the whole wheel
            Q = expand(Q, s.cyclic.sectors, s.cyclic.engine_order)
            s = wheel_system(s)
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
    cy = getattr(prob.system, "cyclic", None)
    too_big = cy is not None and cy.sectors * prob.system.n_dof > MAX_WHEEL_DOF
    note = describe(mode, too_big, margin)
    if too_big and mode in ("floquet", "hill+check"):
        mode = "hill"
    if mode is None:
        return _result(pts, np.full(P, NOT_COMPUTED, np.int8), fold_lam, conv, note)
    if mode in ("hill", "hill+check"):
        for i in range(P):
            pts.run_hill(i)
    if mode == "floquet":
        for i in conv:
            pts.run_floquet(i)
        for i in range(P):
            if not np.isfinite(pts.fq[i]):
                pts.run_hill(i)
    elif mode == "hill+check":
        _check_doubtful(pts, conv, margin, amplitude)
    method = np.where(np.isfinite(pts.fq), FLOQUET, HILL).astype(np.int8)
    return _result(pts, method, fold_lam, conv, note)


def describe(mode, wheel_too_big: bool = False, margin: float = CHECK_MARGIN) -> str:
    """How `branch_stability` decides in `mode` (`stability_mode`), in words;
    wheel_too_big: a cyclic sector whose wheel has more than MAX_WHEEL_DOF DOFs."""
    mode = stability_mode(mode)
    if wheel_too_big and mode in ("floquet", "hill+check"):
        return ("Hill's method at every point, every wave number: the Floquet check of a "
                f"cyclic sector integrates the whole wheel, above {MAX_WHEEL_DOF} DOFs "
                f"{mode!r} keeps Hill")
    return {None: "not computed", "hill": "Hill's method at every point",
            "floquet": "Floquet multipliers of the exact flow at every converged point (Hill "
                       "where the periodic orbit was not found)",
            "hill+check": "Hill's method, checked by the Floquet multipliers of the exact flow "
                          f"where |max Re lambda| T < {margin:g}, at both neighbours of every "
                          "change of the flag and at the peaks; where they disagree, Floquet "
                          "decides"}[mode]


def _decided(pts):
    return np.where(np.isfinite(pts.fq), pts.fq_stable, pts.hill_stable)


def _check_doubtful(pts, conv, margin, amplitude):
    """Floquet where Hill's margin is small, at the peaks, then at both neighbours of
    every change of the decided flag until each change has Floquet on both sides."""
    for i in conv:
        if abs(np.log(max(pts.hill[i], 1e-300))) < margin:
            pts.run_floquet(i)
    if amplitude is not None and conv.size:
        for d in range(amplitude.shape[1]):
            pts.run_floquet(conv[int(np.argmax(amplitude[conv, d]))])
    while True:
        st = _decided(pts)
        todo = [k for a, b in zip(conv[:-1], conv[1:]) if st[a] != st[b]
                for k in (a, b) if not pts.fq_tried[k]]
        if not todo:
            return
        for k in todo:
            pts.run_floquet(k)


def _result(pts, method, fold_lam, conv, note) -> BranchStability:
    computed = method != NOT_COMPUTED
    stable = np.where(computed, _decided(pts), True)
    par, kind = _bifurcations(pts, stable, conv, np.asarray(fold_lam, float)) \
        if computed.any() else (np.zeros(0), np.zeros(0, np.int8))
    return BranchStability(
        stable=stable.astype(bool), method=method, hill_multiplier=pts.hill,
        floquet_multiplier=pts.fq, bifurcation_parameter=par, bifurcation_kind=kind,
        note=note, hill_time=pts.times[0], floquet_time=pts.times[1])


def _bifurcations(pts, stable, conv, fold_lam):
    """(parameter (B,), kind (B,)) where the decided flag changes between neighbours."""
    mult = np.where(np.isfinite(pts.fq), pts.fq, pts.hill)
    kinds = np.where(np.isfinite(pts.fq), pts.fq_kind, pts.hill_kind)
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
