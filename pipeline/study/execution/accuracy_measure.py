"""Measuring the runs of an accuracy-cost case and recommending settings.

`run_case` traces the case once per distinct setting (`measure`), times it again
`repeats - 1` times (`retime`), computes the relative errors against the reference
and the baseline (`relative_errors`), recommends a value per knob (`recommend`) and
runs the recommended combination; for the lumped case it checks the reference
against event-driven time integration (`time_integration_check`).  The study, its
errors and the recommendation rule are described in accuracy_study.py.

The systems come from the caller: `system_for(settings)` returns (System, index of the
case's DOF, model time [s], DOFs of the unreduced model), `case_systems`.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import minimize_scalar

from ...solve.time_integration import timesim
from ...solve.harmonic_balance.hbm_state import state_at_zero
from ...solve.response.response import frequency_response
from ...solve.nonlinear_modes.synthesis import synthesised_curve
from ...model.scene import CraigBampton
from ...model.build import build_system
from ...model.blade_cache import reduced_model, timed_blade_model
from ..files.accuracy_types import MESH_FIELDS, Case, Settings
from ...errors import interrupt_in_chain
from ..files.study_types import solver_rule_violations

log = logging.getLogger(__name__)

METRICS = ("peak_amplitude", "peak_frequency", "fold_frequency")


# ---------------------------------------------------------------------------
# Measurements
# ---------------------------------------------------------------------------

@dataclass
class Measurement:
    """What one run gives: its cost, its peak and folds, and its curve."""

    success: bool
    message: str
    crashed: bool = False               # raised an exception (a bug or a bad model)
    wall_time: float = math.nan         # [s] continuation (best of repeats) + model time
    cpu_time: float = math.nan          # [s] process time of that best continuation
    model_time: float = 0.0             # [s] blades: FE assembly + Craig-Bampton reduction
    peak_amplitude: float = math.nan    # [m]
    peak_frequency: float = math.nan    # [rad/s]
    folds: np.ndarray = field(default_factory=lambda: np.zeros(0))   # [rad/s], ascending
    repeats: int = 1                    # timing runs (the shortest counts)
    n_points: int = 0
    nfev: int = 0
    n_dof: int = 0                      # DOFs of the model solved (reduced for blades)
    n_dof_full: int = 0                 # DOFs of the unreduced model
    omega: np.ndarray = field(default_factory=lambda: np.zeros(0))          # (P,) [rad/s]
    amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0))      # (P,) [m]
    harmonic_amplitude: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    converged: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    peak_state: tuple | None = None     # (system, Q (n, 2H+1), omega) at the peak


def measure(case: Case, s: Settings, system_for, solver=None) -> Measurement:
    """Trace the case once with settings s: the result and its cost (`retime` adds
    timing runs).  `system_for(s)`: (System, DOF index, model time [s], n_dof_full)."""
    if s.forced_response == "nonlinear_mode":
        return measure_mode(case, s, system_for)
    solver = solver or frequency_response
    try:
        system, dof, t_model, n_full = system_for(s)
        t0, c0 = time.perf_counter(), time.process_time()
        curve = solver(system, s.harmonics, case.frequency.omega_start, case.frequency.omega_stop,
                       peak_dofs=[dof], **s.solver_kwargs())
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    except Exception as exc:  # a failing setting is a finding, not the end of the study
        log.exception("%s: %s failed", case.name, s.describe())
        return Measurement(success=False, message=f"{type(exc).__name__}: {exc}", crashed=True)
    conv = np.asarray(curve.converged, bool)
    m = Measurement(success=bool(curve.success and conv.any()), message=str(curve.message),
                    wall_time=wall + t_model, cpu_time=cpu, model_time=t_model,
                    n_points=int(curve.n_points), nfev=int(curve.nfev), n_dof=int(system.n_dof),
                    n_dof_full=int(n_full))
    if not conv.any():
        m.message = "no converged point: " + m.message
        return m
    amp, om, i = curve.peak(dof)
    m.peak_amplitude, m.peak_frequency = amp, om
    if i in (0, curve.n_points - 1):
        m.success = False
        m.message = "peak at the edge of the frequency window; " + m.message
    m.folds = np.sort(np.asarray(curve.fold_parameter, float))
    m.omega = np.asarray(curve.omega, float)
    m.amplitude = np.asarray(curve.amplitude, float)[:, dof]
    Q = np.asarray(curve.Q, float)[:, dof, :]
    m.harmonic_amplitude = np.column_stack([np.abs(Q[:, 0]), np.hypot(Q[:, 1::2], Q[:, 2::2])])
    m.converged = conv
    m.peak_state = (system, np.asarray(curve.Q[i], float), om)
    return m


def measure_mode(case: Case, s: Settings, system_for) -> Measurement:
    """The forced response synthesised from the first nonlinear mode (its backbone from
    0.01 to 1000 slip onsets, `solve.nonlinear_modes`) with the settings s: its cost
    (backbone and synthesis), peak and folds (where a flank turns) and its curve."""
    try:
        system, dof, t_model, n_full = system_for(s)
        t0, c0 = time.perf_counter(), time.process_time()
        c = synthesised_curve(system, s.harmonics, dof, s.force_evaluation, s.samples,
                              s.tolerance)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    except Exception as exc:  # a failing setting is a finding, not the end of the study
        log.exception("%s: %s failed", case.name, s.describe())
        return Measurement(success=False, message=f"{type(exc).__name__}: {exc}", crashed=True)
    lo, hi = case.frequency.omega_start, case.frequency.omega_stop
    inside = lo <= c["peak_omega"] <= hi
    folds = c["folds"][(c["folds"] >= lo) & (c["folds"] <= hi)]     # the window's, as traced
    return Measurement(success=bool(np.isfinite(c["peak_amplitude"]) and inside),
                       message=c["message"] or ("" if inside else "peak outside the window"),
                       wall_time=wall + t_model, cpu_time=cpu, model_time=t_model,
                       peak_amplitude=c["peak_amplitude"], peak_frequency=c["peak_omega"],
                       folds=folds, n_points=int(c["omega"].size), n_dof=int(system.n_dof),
                       n_dof_full=int(n_full), omega=c["omega"], amplitude=c["amplitude"],
                       harmonic_amplitude=c["harmonic_amplitude"],
                       converged=np.isfinite(c["omega"]))


def retime(case: Case, s: Settings, m: Measurement, system_for, solver=None) -> None:
    """Run the continuation of `m` again and keep the shorter time (wall and CPU
    of the same run)."""
    if m.crashed:
        return
    if s.forced_response == "nonlinear_mode":
        again = measure_mode(case, s, system_for)
        if again.wall_time < m.wall_time:
            m.wall_time, m.cpu_time = again.wall_time, again.cpu_time
        m.repeats += 1
        return
    solver = solver or frequency_response
    system, dof, t_model, _ = system_for(s)
    t0, c0 = time.perf_counter(), time.process_time()
    solver(system, s.harmonics, case.frequency.omega_start, case.frequency.omega_stop,
           peak_dofs=[dof], **s.solver_kwargs())
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if wall + t_model < m.wall_time:
        m.wall_time, m.cpu_time = wall + t_model, cpu
    m.repeats += 1


def relative_errors(m: Measurement, ref: Measurement) -> dict:
    """e_A, e_W, e_F and error = max of them (NaN parts ignored) against `ref`."""
    if not ref.success or not np.isfinite(m.peak_amplitude):
        return {k: math.nan for k in METRICS + ("error",)}
    e = {"peak_amplitude": abs(m.peak_amplitude / ref.peak_amplitude - 1.0),
         "peak_frequency": abs(m.peak_frequency / ref.peak_frequency - 1.0)}
    if m.folds.size != ref.folds.size:
        e["fold_frequency"] = math.inf
    elif ref.folds.size == 0:
        e["fold_frequency"] = math.nan
    else:
        e["fold_frequency"] = float(np.max(np.abs(m.folds / ref.folds - 1.0)))
    vals = [v for v in e.values() if not math.isnan(v)]
    e["error"] = max(vals) if vals and m.success else math.nan
    return e


def time_integration_check(ref: Measurement, dof: int, lo: float, rel_window: float = 1e-3) -> dict:
    """Event-driven time integration (`timesim.steady_state`, shooting from the HBM
    state) at the reference peak, and the peak frequency of the integrated response
    (bounded Brent on the amplitude in Omega_ref (1 -+ rel_window), kept above `lo`,
    the fold that ends the branch the peak sits on)."""
    system, Q, Om = ref.peak_state
    q0, qd0, w0 = state_at_zero(system, Q, Om)
    t0 = time.perf_counter()
    at_peak = timesim.steady_state(system, Om, q0=q0, qd0=qd0, w0=w0)
    periods = [at_peak.periods]

    def neg_amp(W):
        r = timesim.steady_state(system, W, q0=q0, qd0=qd0, w0=w0)
        periods.append(r.periods)
        return -r.amplitude[dof] if r.converged else math.inf

    bounds = (max(Om * (1 - rel_window), lo), Om * (1 + rel_window))
    res = minimize_scalar(neg_amp, bounds=bounds, method="bounded", options={"xatol": 1e-10 * Om})
    return {"amplitude_at_peak": float(at_peak.amplitude[dof]), "converged": bool(at_peak.converged),
            "peak_amplitude": float(-res.fun), "peak_frequency": float(res.x),
            "amplitude_error": abs(ref.peak_amplitude / at_peak.amplitude[dof] - 1.0),
            "peak_amplitude_error": abs(ref.peak_amplitude / -res.fun - 1.0),
            "peak_frequency_error": abs(ref.peak_frequency / res.x - 1.0),
            "wall_time": time.perf_counter() - t0, "periods": int(sum(periods)),
            "evaluations": len(periods)}


# ---------------------------------------------------------------------------
# Recommendation
# ---------------------------------------------------------------------------

TIE = 0.1   # wall times within 10 % of the cheapest count as equal (timing noise)


def recommend(rows: list, knobs, target: float) -> dict:
    """Per knob, the cheapest run (its series or the baseline) whose errors all meet
    the target: {knob: (value, row, met)}.  Runs within `TIE` of the cheapest time
    count as equally cheap, and the most accurate of them is taken.  If no run
    meets the target, the most accurate one (met False)."""
    base = next(r for r in rows if r["knob"] == "baseline")
    out = {}
    for k, _ in knobs:
        cand = [base] + [r for r in rows if r["knob"] == k]
        ok = [r for r in cand if meets_target(r, target)]
        if ok:
            t_min = min(r["m"].wall_time for r in ok)
            near = [r for r in ok if r["m"].wall_time <= (1 + TIE) * t_min]
            best = min(near, key=lambda r: r["errors"]["error"])
        else:
            best = min(cand, key=lambda r: (r["errors"]["error"] if np.isfinite(r["errors"]["error"])
                                           else math.inf))
        out[k] = (best["settings"].value_of(k), best, bool(ok))
    return out


def meets_target(row, target) -> bool:
    """Whether a run (a row of `run_case`) meets the target: it succeeded, none of its
    three errors exceeds `target` (a NaN one, no folds in either, passes) and its
    largest error is finite."""
    e = row["errors"]
    return bool(row["m"].success and all(not (e[k] > target) for k in METRICS)
                and np.isfinite(e["error"]))


def recommended_settings(baseline: Settings, rec: dict) -> Settings:
    """The baseline with the recommended value of every knob (`recommend`); exact
    forces if the recommended N falls below 2H+1 at the recommended H."""
    s = baseline
    for k, (value, _, _) in rec.items():
        s = replace(s, force_evaluation="exact") if (k == "samples" and value == "exact") \
            else s.with_knob(k, value)
    if "samples" in dict(solver_rule_violations(s)):
        s = replace(s, force_evaluation="exact")  # that N was measured at a lower H only
    return s


# ---------------------------------------------------------------------------
# Running one case
# ---------------------------------------------------------------------------

def run_case(case: Case, target: float, system_for, solver=None) -> dict:
    """All runs of one case: rows [{case, knob, value, settings, m, errors,
    errors_baseline}], the recommendation, and the time-integration check
    (`system_for`: see `measure`)."""
    cache = {}

    def get(settings):
        """Measure every new setting once, then time them again `repeats - 1` times,
        round-robin, so that a burst of load on a shared machine does not hit all
        the timings of one setting."""
        new = [s for s in dict.fromkeys(settings) if s not in cache]
        for s in new:
            cache[s] = m = measure(case, s, system_for, solver)
            log.info("%s: %s: %s, %.3g s%s", case.name, s.describe(),
                     f"peak {m.peak_amplitude:.8g} at {m.peak_frequency:.8g} rad/s, "
                     f"folds {np.round(m.folds, 6).tolist()}" if m.success else "FAILED",
                     m.wall_time, "" if m.success else f" ({m.message})")
        for _ in range(case.repeats - 1):
            for s in new:
                retime(case, s, cache[s], system_for, solver)
        return [cache[s] for s in settings]

    get([s for _, _, s in case.runs()])
    rows = []
    for knob, value, s in case.runs():
        rows.append({"case": case.name, "knob": knob, "value": value, "settings": s,
                     "m": cache[s]})
    ref = rows[0]["m"]
    base = rows[1]["m"]
    for r in rows:
        r["errors"] = relative_errors(r["m"], ref)
        r["errors_baseline"] = relative_errors(r["m"], base)
    rec = recommend(rows, case.knobs, target)
    s_rec = recommended_settings(case.baseline, rec)
    m_rec = get([s_rec])[0]
    row = {"case": case.name, "knob": "recommended", "value": None, "settings": s_rec, "m": m_rec,
           "errors": relative_errors(m_rec, ref), "errors_baseline": relative_errors(m_rec, base)}
    rows.append(row)
    ti, ti_error = (checked_time_integration(case, ref) if case.time_integration and ref.success
                    else (None, None))
    return {"case": case, "rows": rows, "recommendation": rec, "recommended": row, "ti": ti,
            "ti_error": ti_error}


def checked_time_integration(case: Case, ref: Measurement) -> tuple:
    """(`time_integration_check` of the reference, None), or (None, why) where it
    raises: the check is lost, not the case's runs."""
    lo = float(ref.folds[ref.folds < ref.peak_frequency].max()) if np.any(
        ref.folds < ref.peak_frequency) else 0.0
    try:
        ti = time_integration_check(ref, case.scene.dof_index(case.dof), lo * (1 + 1e-9))
    except Exception as exc:  # a failing check must not lose the measured runs
        if interrupt_in_chain(exc):
            raise
        log.exception("%s: the event-driven time-integration check failed", case.name)
        return None, f"{type(exc).__name__}: {exc}"
    log.info("%s: reference vs event-driven time integration: amplitude at the peak %.3g, "
             "peak amplitude %.3g, peak frequency %.3g (relative; %.2f s)", case.name,
             ti["amplitude_error"], ti["peak_amplitude_error"], ti["peak_frequency_error"],
             ti["wall_time"])
    return ti, None


# ---------------------------------------------------------------------------
# The systems of a case's runs (measured by `run_case`)
# ---------------------------------------------------------------------------

def _system(case: Case, s: Settings):
    """(System, index of the case's DOF, model time [s], n_dof_full) for settings s.
    FE blades and their reductions are cached on their specs (`model.blade_cache`); the
    model time is what building and reducing took when first done."""
    case_arg = {"preload": case.preload} if case.preload is not None else None
    if case.name == "lumped":
        system = build_system(case.scene, case_arg)
        return system, case.scene.dof_index(case.dof), 0.0, system.n_dof
    sc = case.scene
    st = sc.structure if s.mesh is None else replace(
        sc.structure, params=replace(sc.structure.params, **dict(zip(MESH_FIELDS, s.mesh))))
    v = replace(sc, structure=st, reduction=CraigBampton(s.craig_bampton_modes))
    blade, t_fe = timed_blade_model(st)        # build and reduction times as measured
    t_red = reduced_model(st, v.reduction)[1]  # when first made, cached or not
    return (build_system(v, case_arg), v.dof_index(case.dof), t_fe + t_red, blade.n_dof)


def case_systems(case: Case):
    """`system_for` of `run_case`: settings -> (System, index of the
    case's DOF, model time [s], n_dof_full), FE blades cached per mesh and their
    reductions per (mesh, modes) for the case's runs."""
    return lambda s: _system(case, s)
