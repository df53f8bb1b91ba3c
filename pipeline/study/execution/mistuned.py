"""The tuned reference of a mistuned disk and the amplification of its response.

A mistuned disk (`Cyclic.mistuning`) is solved as the full N-sector assembly; what
the mistuning does is read against the same disk without it: `tuned_reference`
solves the tuned disk with the study's harmonics, forces, tolerances and frequency
range on ONE sector by the cyclic reduction (a small continuation per combination
of the sweep axes other than `mistuning_seed`, about a second each).  A tuned
disk's sectors all move alike, so its peak is one number per sector DOF, and the
amplification factor of one mistuned case is

    A = max over sectors of the sector's peak / the tuned peak   [-]

(Whitehead's bound for weak coupling: A <= (1 + sqrt(N)) / 2).  `tuned_references`
gives the tuned curve of every combination of the other axes, keyed by their values.
"""
from __future__ import annotations

import itertools
import logging
import time
from dataclasses import dataclass, replace

import numpy as np

from ...model.build import build_system
from .cases import default_solver, run_case

log = logging.getLogger("pipeline.study.execution.mistuned")
SEED_AXIS = "mistuning_seed"


@dataclass
class TunedCurve:
    """The tuned disk's response at one combination of the non-seed sweep axes."""

    frequency: np.ndarray    # (P,) in the study's frequency unit
    amplitude: dict          # sector DOF -> (P,) [m]
    stable: np.ndarray       # (P,) float: 1 stable, 0 unstable, NaN not computed
    converged: np.ndarray    # (P,) bool
    peak: dict               # sector DOF -> peak amplitude [m] (NaN if nothing converged)
    error: str | None = None


def tuned_reference(study, case: dict, dofs, solver=None) -> TunedCurve:
    """The disk of `study` without mistuning, one sector by the cyclic reduction,
    with the study's harmonics, forces, tolerances and frequency range; `case`
    holds the sweep values other than `mistuning_seed`."""

    scene = replace(study.scene, assembly=replace(study.scene.assembly, mistuning=None))
    fr, kw = study.sweep.frequency, study.solver.kwargs(study.output.yscale, study.output.curves)
    idx = [scene.sector_dofs.index(d) for d in dofs]
    kw["peak_dofs"] = idx
    case = {a: v for a, v in case.items() if a != SEED_AXIS}
    t0 = time.perf_counter()
    curve, err = run_case(solver or default_solver(study), build_system(scene, case),
                          study.solver.harmonics, fr.omega_start, fr.omega_stop, kw)
    if curve is None:
        nan = {d: np.nan for d in dofs}
        return TunedCurve(np.empty(0), {d: np.empty(0) for d in dofs}, np.empty(0),
                          np.empty(0, bool), nan, err or "failed")
    om = np.asarray(curve.omega, float) / fr.to_rad_s
    amp = np.asarray(curve.amplitude, float)
    conv = np.asarray(curve.converged, bool) & np.isfinite(om)
    stable = (np.asarray(curve.stable, bool).astype(float) if study.solver.stability
              else np.full(om.shape, np.nan))
    amps, peaks = {}, {}
    for d, i in zip(dofs, idx):
        a = amp[:, i]
        ok = conv & np.isfinite(a)
        amps[d] = a
        peaks[d] = float(a[ok].max()) if ok.any() else np.nan
    log.info("%s: tuned reference%s: peak %s in %.1f s", study.name,
             f" ({case})" if case else "",
             ", ".join(f"{d} {p:.4g} m" for d, p in peaks.items()), time.perf_counter() - t0)
    return TunedCurve(om, amps, stable, conv, peaks)


def tuned_references(study, dofs, solver=None) -> dict:
    """{values of the non-seed sweep axes (tuple, axis order): TunedCurve} for every
    combination of the sweep axes other than `mistuning_seed`."""
    axes = dict(study.sweep.axes)
    other = [a for a in axes if a != SEED_AXIS]
    out = {}
    for combo in itertools.product(*(axes[a] for a in other)):
        out[tuple(combo)] = tuned_reference(study, dict(zip(other, combo)), dofs, solver)
    return out
