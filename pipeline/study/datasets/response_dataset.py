"""Response curves of a study -> one labelled `xarray.Dataset` (`to_dataset`; written
to netCDF by `dataset.write_netcdf`, checked against the contract by `dataset_check`).
Layout (dims in this order):

    sweep axes... (e.g. preload [N]),  [sector,]  point,  dof,  harmonic (0..H)

`frequency` is a non-index coordinate on (sweep axes..., point): branches are
multivalued in frequency, and `ds.amplitude.sel(preload=10, dof="u").plot(x="frequency")`
draws one branch.  `sector` (the sector numbers) exists only for a mistuned disk,
whose response DOFs are reported per sector: `dof` then holds the sector's DOF
names ("x1"), never "x1@3".

Continuation branches have different lengths: every per-point variable is padded
along `point` with NaN (floats), False (flags) or -1 (counts).  Padded points and
points whose numbers are not finite are never `converged`, so every converged
point carries finite values.  `stable` is 1 (stable) or 0 (unstable) where stability
was decided (Hill, Floquet or the orbit monodromy: `stability_method`,
`stability_dataset`) and NaN elsewhere (not converged, or stability off): a flag that
cannot say "not computed" would read True there.  Amplitudes are half peak-to-peak
(max x - min x)/2; harmonic amplitudes sqrt(a_h^2 + b_h^2) of
x = a_0 + sum a_h cos(h W t) + b_h sin(h W t), |a_0| at h = 0.  Frequencies are in
the study's unit (rad/s or Hz).

Each case's flags (`CASE_FLAGS`): `peak_complete` (the branch covers the frequency
interval) and the count of points accepted on the residual's round-off floor
(`solve.harmonic_balance.roundoff`); a continuation message in the study's words and
unit (`readable_message`); `case_system_or_none` the system of a case that may have
failed because its model cannot be built.
"""
from __future__ import annotations

import itertools
import re
from dataclasses import dataclass

import numpy as np
import xarray as xr

from ...errors import interrupt_in_chain
from ...model.scene import AT
from ...model.build import stiffness_factors
from ...model.static_load import stuck_limit_system
from ...model.system import contact_set, lowest_frequencies
from .describe import points_attrs, provenance, scene_attrs, solution_method
from .meanings import annotate_natural_frequencies, sweep_long_name
from .optimum_dataset import add_optimum
from ..files.study_types import INTEGER_SWEEP_AXES, SWEEP_AXES, Study
from . import stability_dataset as sd
from .contact_dataset import add_contact_variables, set_motions

PEAK_NAME = ("largest amplitude over the converged points inside the frequency interval "
             "(a branch followed beyond it: not its points outside; the peak of the interval "
             "only where peak_complete = 1)")
# (dims after the sweep axes, units, long_name) of the per-case flags (`to_dataset`)
CASE_FLAGS = {
    "peak_complete": ((), "1", "1: the branch covers the frequency interval, so "
                      "peak_amplitude is its peak; 0: the branch stopped short of it "
                      "(see message), the peak may lie beyond its last point"),
    "roundoff_points": ((), "1", "points accepted on the round-off floor of their residual, "
                        "above residual_tolerance (-1: case failed)"),
}


_LAM = re.compile(r"\b(lam_end|lam0|lam) = ([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?)")
_WORDS = (("max_points reached before lam_end", "solver.max_points reached before the end of "
           "the range"), ("step size below ds_min", "arc-length step below its smallest, ds_min"))


def readable_message(message: str, to_unit: float, unit: str) -> str:
    """A continuation message in the study's words and unit: the continuation
    parameter lam [rad/s] is the excitation frequency ("reached lam_end = 439.82..."
    -> "reached the end of the range = 70 Hz")."""
    names = {"lam_end": "the end of the range", "lam0": "the start of the range",
             "lam": "the frequency"}
    for old, new in _WORDS:
        message = message.replace(old, new)
    return _LAM.sub(lambda m: f"{names[m.group(1)]} = {float(m.group(2)) / to_unit:.6g} {unit}",
                    message)


def case_system_or_none(study, case, curve):
    """The case's system; None for a failed case (`curve` None) whose model cannot be
    built (its variables stay padding: the other cases are written)."""
    try:
        return study.system(case)
    except Exception as exc:
        if curve is not None or interrupt_in_chain(exc):
            raise
        return None


def case_flags(curve) -> tuple:
    """(peak_complete, roundoff_points) of a finished curve: whether it covers its
    interval (`success`), and its points accepted on the round-off floor."""
    return bool(curve.success), int(curve.info.get("roundoff_points", 0))


MAX_MODES = 50    # natural frequencies per case in a dataset (the lowest)


def response_layout(study):
    """(dof labels, sector numbers or None, rows) of the reported response DOFs.

    rows[s, d] is the row in a case's `System` of DOF `dofs[d]` of sector
    `sectors[s]`.  A mistuned disk reports its DOFs per sector (output labels
    "<dof>@<sector>" become the grid sectors x dofs); every other scene has one
    row of rows and `sectors` None (no sector dimension)."""
    scene, labels = study.scene, study.output.dofs
    if scene.mistuning is None:
        return tuple(labels), None, np.array([[scene.dof_index(d) for d in labels]])
    pairs = [scene.split_dof(d) for d in labels]
    dofs = tuple(dict.fromkeys(d for d, _ in pairs))
    sectors = tuple(sorted({j for _, j in pairs}))
    rows = np.array([[scene.dof_index(f"{d}{AT}{j}") for d in dofs] for j in sectors])
    return dofs, sectors, rows


def dof_selection(study, label: str) -> dict:
    """`Dataset.sel` arguments of an output DOF label: {"dof": "x1", "sector": 3}
    for "x1@3" of a mistuned disk, else {"dof": label}."""
    if study.scene.mistuning is None:
        return {"dof": label}
    d, j = study.scene.split_dof(label)
    return {"dof": d, "sector": j}


def _case_arrays(curve, rows, to_unit):
    """Plain per-point arrays of one curve (converged points finite); rows (S, D)
    of the reported DOFs give amplitudes shaped (S, P, D), (S, P, D, H+1)."""
    om = np.asarray(curve.omega, dtype=float)
    amp = np.moveaxis(np.asarray(curve.amplitude, dtype=float)[:, rows], 0, 1)
    Q = np.moveaxis(np.asarray(curve.Q, dtype=float)[:, rows, :], 0, 1)
    H = (Q.shape[-1] - 1) // 2
    hamp = np.empty(Q.shape[:-1] + (H + 1,))
    hamp[..., 0] = np.abs(Q[..., 0])
    hamp[..., 1:] = np.hypot(Q[..., 1::2], Q[..., 2::2])
    finite = (np.isfinite(om) & np.all(np.isfinite(amp), axis=(0, 2))
              & np.all(np.isfinite(hamp), axis=(0, 2, 3)))
    conv = np.asarray(curve.converged, dtype=bool) & finite
    return dict(frequency=om / to_unit, amplitude=amp, harmonic_amplitude=hamp, converged=conv,
                stable=np.where(conv, np.asarray(curve.stable, dtype=float), np.nan),
                residual=np.asarray(curve.residual, dtype=float),
                newton_iterations=np.asarray(curve.newton_iterations).astype(np.int32))


def _peak(freq, amp, mask):
    """(peak amplitude, its frequency), each (S, D), of amp (S, P, D) over the
    points in `mask` (P,)."""
    S, P, D = amp.shape
    if P == 0 or not mask.any():
        return np.full((S, D), np.nan), np.full((S, D), np.nan)
    a = np.where(mask[None, :, None], amp, -np.inf)
    i = np.argmax(a, axis=1)
    return np.take_along_axis(a, i[:, None, :], axis=1)[:, 0, :], freq[i]


@dataclass(frozen=True)
class Layout:
    """Sizes of a response dataset: grid `shape`, reported DOFs and sectors (`rows`,
    `response_layout`), harmonics H, points P, folds F, peak windows W, modes n."""

    shape: tuple
    dofs: tuple
    sectors: tuple | None
    rows: np.ndarray
    H: int
    P: int
    F: int
    W: int
    n: int
    unit: str
    to_unit: float
    computed: bool            # stability computed (solver.stability)
    B: int = 1                # bifurcations
    mode: object = None       # solver.stability
    notes: tuple = ()         # each case's description of how stability was decided


def response_sizes(study: Study, curves) -> Layout:
    dofs, sectors, rows = response_layout(study)
    fr, done = study.sweep.frequency, [c for c in curves if c is not None]
    return Layout(shape=study.sweep.shape, dofs=dofs, sectors=sectors, rows=rows,
                  H=max([study.solver.harmonics] + [(c.Q.shape[-1] - 1) // 2 for c in done]),
                  P=max([1] + [c.n_points for c in done]),
                  F=max([1] + [np.size(c.fold_parameter) for c in done]),
                  W=len(study.output.peak_windows), n=min(len(study.scene.dofs), MAX_MODES),
                  unit=fr.unit,
                  to_unit=fr.to_rad_s, computed=bool(study.solver.stability),
                  B=sd.bifurcation_count(done), mode=study.solver.stability,
                  notes=tuple(c.info.get("stability", "") for c in done))


def empty_arrays(lay: Layout) -> dict:
    """Every per-case array of a response dataset, all padding."""
    S, D = lay.rows.shape
    P, H, F, W, n = lay.P, lay.H, lay.F, lay.W, lay.n

    def full(tail, fill, dtype=float):
        return np.full(lay.shape + tail, fill, dtype=dtype)

    return dict(frequency=full((P,), np.nan), amplitude=full((S, P, D), np.nan),
                harmonic_amplitude=full((S, P, D, H + 1), np.nan),
                converged=full((P,), False, bool), stable=full((P,), np.nan),
                residual=full((P,), np.nan), newton_iterations=full((P,), -1, np.int32),
                peak_amplitude=full((S, D), np.nan), peak_frequency=full((S, D), np.nan),
                fold_frequency=full((F,), np.nan), fold_amplitude=full((S, F, D), np.nan),
                n_points=full((), 0, np.int32),
                wall_time=full((), np.nan), residual_evaluations=full((), -1, np.int32),
                success=full((), False, bool), status=full((), -1, np.int32),
                peaks_resolved=full((), False, bool), peak_complete=full((), False, bool),
                residual_tolerance=full((), np.nan), roundoff_points=full((), -1, np.int32),
                natural_frequency_stuck=full((n,), np.nan),
                natural_frequency_free=full((n,), np.nan),
                window_peak_amplitude=full((S, W, D), np.nan),
                window_peak_frequency=full((S, W, D), np.nan),
                window_peak_complete=full((W,), False, bool),
                **sd.stability_arrays(lay.shape, P, lay.B))


def fill_case(v: dict, idx, c, lay: Layout, windows) -> str:
    """Write one finished curve `c` into the arrays `v` at grid index `idx`; returns
    its message in the study's words."""
    a = _case_arrays(c, lay.rows, lay.to_unit)
    p, h1 = c.n_points, a["harmonic_amplitude"].shape[-1]
    for k in ("frequency", "converged", "residual", "newton_iterations"):
        v[k][idx][:p] = a[k]
    if lay.computed:
        v["stable"][idx][:p] = a["stable"]
    v["amplitude"][idx][:, :p] = a["amplitude"]
    v["harmonic_amplitude"][idx][:, :p, :, :h1] = a["harmonic_amplitude"]
    v["harmonic_amplitude"][idx][:, :p, :, h1:] = 0.0
    lo, hi = np.asarray(c.info.get("window", (-np.inf, np.inf))) / lay.to_unit  # the range's
    v["peak_amplitude"][idx], v["peak_frequency"][idx] = _peak(  # peak: inside it only
        a["frequency"], a["amplitude"], a["converged"] & (a["frequency"] >= lo)
        & (a["frequency"] <= hi))
    for w, (lo, hi) in enumerate(windows):
        inside = a["converged"] & (a["frequency"] >= lo) & (a["frequency"] <= hi)
        v["window_peak_amplitude"][idx][:, w], v["window_peak_frequency"][idx][:, w] = _peak(
            a["frequency"], a["amplitude"], inside)
        f = a["frequency"][a["converged"]]
        tol = 1e-9 * max(abs(lo), abs(hi))    # the window's edges in the stored unit
        v["window_peak_complete"][idx][w] = bool(f.size and f.min() <= lo + tol
                                                 and f.max() >= hi - tol)
    folds = np.asarray(c.fold_parameter, dtype=float).ravel() / lay.to_unit
    v["fold_frequency"][idx][:folds.size] = folds
    if c.fold_amplitude is not None and folds.size:
        v["fold_amplitude"][idx][:, :folds.size] = np.moveaxis(c.fold_amplitude[:, lay.rows], 0, 1)
    sd.fill_stability(v, idx, c, a["converged"], lay.computed, lay.to_unit)
    v["n_points"][idx] = p
    v["wall_time"][idx] = c.wall_time
    v["residual_evaluations"][idx] = c.nfev
    v["success"][idx] = c.success
    v["peaks_resolved"][idx] = (bool(c.info.get("resonance_guard", False))
                                and c.info.get("unresolved_resonance_steps", 1) == 0)
    v["status"][idx] = c.status
    v["residual_tolerance"][idx] = c.tolerance
    v["peak_complete"][idx], v["roundoff_points"][idx] = case_flags(c)
    return readable_message(str(c.message), lay.to_unit, lay.unit)


def response_meta(unit: str, computed: bool) -> dict:
    """name -> (dims after the sweep axes, units, long_name) of every per-case variable."""
    stable_name = ("asymptotically stable (method: stability_method): 1 stable, 0 unstable, "
                   "NaN not computed"
                   if computed else
                   "stability NOT computed (solver.stability = false): NaN everywhere")
    return {
        "amplitude": (("sector", "point", "dof"), "m",
                      "response amplitude, half peak-to-peak (max x - min x)/2"),
        "harmonic_amplitude": (("sector", "point", "dof", "harmonic"), "m",
                               "harmonic amplitude sqrt(a_h^2 + b_h^2)"),
        "converged": (("point",), "1", "Newton converged at this point"),
        "stable": (("point",), "1", stable_name),
        "residual": (("point",), "N", "recomputed harmonic balance residual norm"),
        "newton_iterations": (("point",), "1", "Newton iterations at this point (-1: padding)"),
        "peak_amplitude": (("sector", "dof"), "m", PEAK_NAME),
        "peak_frequency": (("sector", "dof"), unit, "frequency of the largest amplitude"),
        "fold_frequency": (("fold",), unit, "frequency of a fold (turning point) of the branch"),
        "fold_amplitude": (("sector", "fold", "dof"), "m",
                           "response amplitude at a fold, half peak-to-peak (NaN: the fold's "
                           "state is not within the residual tolerance)"),
        "n_points": ((), "1", "points on the branch"),
        "wall_time": ((), "s", "wall-clock time of the case"),
        "residual_evaluations": ((), "1", "residual evaluations of the case (-1: case failed)"),
        "success": ((), "1", "continuation reached the end of the frequency interval"),
        "status": ((), "1", "continuation status code (-1: case failed)"),
        "peaks_resolved": ((), "1",
                           "1: every resonance the branch crosses has points inside its "
                           "half-power band (no peak can hide between two points); "
                           "0: not excluded (see the case's message)"),
        "residual_tolerance": ((), "N", "residual norm accepted as converged"), **CASE_FLAGS,
        "natural_frequency_free": (("mode",), unit, "undamped natural frequency without contacts "
                                                   f"(further laws' linear springs kept; the "
                                                   f"lowest, at most {MAX_MODES}; NaN: a "
                                                   "negative stiffness, omega^2 < 0)"),
        "natural_frequency_stuck": (("mode",), unit,
                                    "undamped natural frequency with the contacts of the "
                                    "static state stuck (ku and kv of every element the "
                                    "unilateral static solution does not open; an element that "
                                    "would pull, a gap, stays open; the lowest, at most "
                                    f"{MAX_MODES}; NaN: a negative stiffness, omega^2 < 0)"),
        "window_peak_amplitude": (("sector", "peak_window", "dof"), "m",
                                  "largest amplitude over converged points inside the peak window"),
        "window_peak_frequency": (("sector", "peak_window", "dof"), unit,
                                  "frequency of the largest amplitude inside the peak window"),
        "window_peak_complete": (("peak_window",), "1",
                                 "1: the converged points span the whole peak window (its "
                                 "largest amplitude is a resonant peak unless it lies on a "
                                 "flank at the window's edge: run warns); 0: the branch does "
                                 "not reach across it"),
        **sd.stability_meta(unit),
    }


def response_variables(study: Study, v: dict, message, lay: Layout) -> dict:
    """The data variables of a response dataset from the filled arrays `v`."""
    sw = tuple(study.sweep.axes)
    data_vars = {}
    for k, (dims, units, long_name) in response_meta(lay.unit, lay.computed).items():
        if "peak_window" in dims and not lay.W:
            continue
        data = v[k]
        if "sector" in dims and lay.sectors is None:  # one row of DOFs: no sector dimension
            data, dims = data.take(0, axis=len(sw)), dims[1:]
        data_vars[k] = (sw + dims, data, {"units": units, "long_name": long_name})
    data_vars["stable"][2].update(
        flag_values=np.array([0.0, 1.0]), flag_meanings="unstable stable",
        comment="NaN where stability was not computed: points that did not converge"
                + ("" if lay.computed else ", and every point since solver.stability = false"),
        stability_computed=int(lay.computed))
    sd.stability_attrs(data_vars)
    annotate_natural_frequencies(data_vars, study.scene)   # a disk: at ND = EO
    data_vars["message"] = (sw, message.astype(str), {"long_name": "continuation message"})
    return data_vars


def index_coord(name, values, long_name, units="1"):
    return (name, np.asarray(values, dtype=np.int32), {"units": units, "long_name": long_name})


def response_coords(study: Study, frequency, lay: Layout) -> dict:
    """The coordinates of a response dataset, `frequency` (grid..., point) included."""
    sw = tuple(study.sweep.axes)
    coords = {a: (a, np.asarray(vals, dtype=np.int32 if a in INTEGER_SWEEP_AXES else float),
                  {"units": SWEEP_AXES[a][0], "long_name": sweep_long_name(a, study.scene)})
              for a, vals in study.sweep.axes.items()}
    coords["frequency"] = (sw + ("point",), frequency,
                           {"units": lay.unit, "long_name": "excitation frequency"})
    coords["dof"] = ("dof", np.asarray(lay.dofs, dtype=str),
                     {"long_name": "response degree of freedom"})
    if lay.sectors is not None:
        coords["sector"] = index_coord("sector", lay.sectors, "sector number j (0 ... sectors - 1)")
    coords["harmonic"] = index_coord("harmonic", np.arange(lay.H + 1),
                                     "harmonic index h (0: static part)")
    coords["point"] = index_coord("point", np.arange(lay.P), "index along the continuation branch")
    coords["fold"] = index_coord("fold", np.arange(lay.F),
                                 "index of a fold (turning point) on the branch")
    coords["bifurcation"] = index_coord("bifurcation", np.arange(lay.B),
                                        "index of a change of the decided stability flag")
    coords["mode"] = index_coord("mode", np.arange(1, lay.n + 1), "mode number")
    if lay.W:
        lo, hi = np.array(study.output.peak_windows, dtype=float).T
        coords["peak_window"] = index_coord("peak_window", np.arange(lay.W), "peak window index")
        coords["peak_window_low"] = ("peak_window", lo, {
            "units": lay.unit, "long_name": "lower bound of the peak window"})
        coords["peak_window_high"] = ("peak_window", hi, {
            "units": lay.unit, "long_name": "upper bound of the peak window"})
    return coords


def response_attrs(study: Study, lay: Layout) -> dict:
    """Global attributes of a response dataset: the study, its method, provenance, the
    scene's model, stability."""
    scene, sv = study.scene, study.solver
    attrs = {"title": study.title, "study": study.text, "study_name": study.name,
             "description": study.description, "reference": study.reference,
             "model": scene.model, "effects": ", ".join(scene.effects) or "none (linear)",
             "solution_method": solution_method(study), "harmonics": int(lay.H),
             "force_evaluation": sv.force_evaluation, "aft_samples": int(sv.samples),
             "tolerance": float(sv.tolerance), "frequency_unit": lay.unit,
             "quick": int(study.quick), **points_attrs(study.output),
             "frequency_range": np.sort([study.sweep.frequency.start, study.sweep.frequency.stop]),
             **provenance("pipeline (harmonic balance with Yang-Menq contact, continuation, "
                          "Hill / Floquet stability)")}
    attrs.update(scene_attrs(scene))  # FE blade and disk scenes describe their model
    attrs["stability"] = (sd.stability_note(lay.mode, lay.notes) if lay.computed else
                          "not computed (solver.stability = false): stable is NaN everywhere")
    return attrs


def to_dataset(study: Study, curves, errors=None, optimum=None, tuned=None) -> xr.Dataset:
    """Build the study dataset from one ResponseCurve per grid case.

    curves: sequence aligned with `study.sweep.cases()`; None for a case that
    raised (then all its points are padding and `message` holds `errors[k]`).
    `stable` is NaN wherever stability was not computed: at every point when the
    study's `solver.stability` is off (the solver then reports True everywhere),
    and at points that did not converge.  `tuned` (a mistuned disk: the tuned
    references of `mistuned.tuned_references`) adds `tuned_peak_amplitude` and
    `amplification_factor`.
    """
    cases = study.sweep.cases()
    curves = list(curves)
    if len(curves) != len(cases):
        raise ValueError(f"curves has {len(curves)} entries, the study has {len(cases)} cases")
    errors = list(errors) if errors is not None else [None] * len(cases)
    lay = response_sizes(study, curves)
    v, message = empty_arrays(lay), np.full(lay.shape, "", dtype=object)
    systems = []
    for (idx, case), c, err in zip(cases, curves, errors):
        sysc = case_system_or_none(study, case, c)   # per case: mistuning changes them
        systems.append(sysc)
        if sysc is not None:   # else a failed case whose model cannot be built
            v["natural_frequency_stuck"][idx] = lowest_frequencies(
                stuck_limit_system(sysc), "small", lay.n) / lay.to_unit
            v["natural_frequency_free"][idx] = lowest_frequencies(sysc, "open",
                                                                  lay.n) / lay.to_unit
        message[idx] = (fill_case(v, idx, c, lay, study.output.peak_windows) if c is not None
                        else f"failed: {err}" if err else "failed")
    data_vars = response_variables(study, v, message, lay)
    coords = response_coords(study, v["frequency"], lay)
    if lay.sectors is not None:
        _add_mistuning_factors(data_vars, study, lay.sectors)
    if tuned is not None and "sector" in data_vars["peak_amplitude"][0]:
        _add_amplification(data_vars, study, tuned, lay)
    if "hysteresis" in study.output.figures and lay.sectors is None:
        _add_hysteresis(data_vars, study, cases, curves, systems, lay)
        coords["coefficient"] = index_coord("coefficient", np.arange(2 * study.solver.harmonics
                                                                     + 1),
                                            "Fourier coefficient [a0, a1, b1, a2, b2, ...]")
    if optimum is not None:
        add_optimum(data_vars, coords, optimum, study, lay.to_unit, lay.unit)
    attrs = response_attrs(study, lay)
    add_contact_variables(data_vars, coords, attrs, study, cases, curves, systems, lay)
    return xr.Dataset(data_vars=data_vars, coords=coords, attrs=attrs)


def _add_mistuning_factors(data_vars, study, sectors):
    """`mistuning_factor` (mistuning_seed?, sector): the stiffness factor 1 + delta_j
    of each reported sector; it depends on the seed only."""
    scene, axes = study.scene, study.sweep.axes
    seeds = axes.get("mistuning_seed")
    cases = [{}] if seeds is None else [{"mistuning_seed": s} for s in seeds]
    f = np.array([np.asarray(stiffness_factors(scene, c), dtype=float)[list(sectors)]
                  for c in cases])
    dims = ("sector",) if seeds is None else ("mistuning_seed", "sector")
    data_vars["mistuning_factor"] = (dims, f[0] if seeds is None else f, {
        "units": "1", "long_name": "stiffness factor 1 + delta_j of the sector "
                                   "(mistuned stiffness (1 + delta_j) K)"})


def _add_amplification(data_vars, study, tuned: dict, lay: Layout):
    """`tuned_peak_amplitude` (other axes..., dof) [m] and `amplification_factor`
    (grid axes..., dof) [-] = max over the sectors of the peak / the tuned peak."""
    axes = study.sweep.axes
    other = [a for a in axes if a != "mistuning_seed"]
    dims, peak, attrs = data_vars["peak_amplitude"]
    dofs = list(lay.dofs)
    ref = np.array([[tuned[combo].peak.get(d, np.nan) for d in dofs]
                    for combo in itertools.product(*(axes[a] for a in other))])
    ref = ref.reshape(tuple(len(axes[a]) for a in other) + (len(dofs),))
    data_vars["tuned_peak_amplitude"] = (tuple(other) + ("dof",), ref, {
        "units": "m", "long_name": "peak amplitude of the tuned disk (no mistuning; one "
                                   "sector by the cyclic reduction)"})
    top = np.nanmax(peak, axis=dims.index("sector")) if np.isfinite(peak).any() else peak.max(
        axis=dims.index("sector"))
    rest = [d for d in dims if d != "sector"]
    ref_b = np.expand_dims(ref, axis=rest.index("mistuning_seed")) if "mistuning_seed" in rest \
        else ref
    data_vars["amplification_factor"] = (tuple(rest), top / ref_b, {
        "units": "1", "long_name": "amplification factor: largest sector peak / tuned peak"})


def _add_hysteresis(data_vars, study, cases, curves, systems, lay: Layout):
    """The contact motion at each case's peak (first output DOF) of the element that
    slides most there: `hysteresis_u`, `hysteresis_v` (grid..., coefficient) [m] in
    the layout of `harmonics.py`, its parameters and index; enough to redraw its
    force-displacement loop exactly (`contact.exact.history`)."""
    H, axes = study.solver.harmonics, tuple(study.sweep.axes)
    shape = lay.shape
    plane = False        # the system's contact set is the 2D law's (3 directions)
    U, V = np.full(shape + (2 * H + 1,), np.nan), np.full(shape + (2 * H + 1,), np.nan)
    U2 = np.full(shape + (2 * H + 1,), np.nan)
    par = {k: np.full(shape, np.nan) for k in ("ku", "kv", "mu", "n0", "ku2", "frequency")}
    element = np.full(shape, -1, dtype=np.int32)
    for (idx, _), c, system in zip(cases, curves, systems):
        ok = None if c is None else np.asarray(c.converged, bool)
        if ok is None or not ok.any():
            continue
        a = np.where(ok, np.asarray(c.amplitude, float)[:, lay.rows[0, 0]], -np.inf)
        i = int(np.argmax(a))
        X = set_motions(system, np.asarray(c.Q, float)[i:i + 1])[0]    # (E, D, 2H+1)
        plane = plane or X.shape[1] == 3
        e = int(np.argmax(np.linalg.norm(X[:, :-1, 1:], axis=(1, 2))))
        U[idx], V[idx], U2[idx], element[idx] = X[e, 0], X[e, -1], X[e, 1], e
        el = contact_set(system).elements
        for k in ("ku", "kv", "mu", "n0", "ku2"):     # ku2: the 2D law's second tangent
            par[k][idx] = float(np.asarray(getattr(el, k, el.ku))[e])
        par["frequency"][idx] = float(c.omega[i]) / lay.to_unit
    coeff = axes + ("coefficient",)
    data_vars["hysteresis_u"] = (coeff, U, {"units": "m", "long_name": "tangential relative "
                                           "displacement at the peak, Fourier coefficients"})
    data_vars["hysteresis_v"] = (coeff, V, {"units": "m", "long_name": "normal relative "
                                           "displacement at the peak, Fourier coefficients"})
    if plane:   # 2D friction: u along the first tangent, u2 along n x t1
        data_vars["hysteresis_u2"] = (coeff, U2, {"units": "m", "long_name": "relative "
                                      "displacement along the second tangent at the peak, "
                                      "Fourier coefficients"})
    data_vars["hysteresis_element"] = (axes, element, {"units": "1", "long_name":
                                       "contact element sliding most at the peak"})
    for k, (u, name) in {"ku": ("N/m", "tangential stiffness"), "kv": ("N/m", "normal "
                         "stiffness"), "mu": ("1", "friction coefficient"), "n0": ("N", "normal "
                         "preload"), "ku2": ("N/m", "tangential stiffness along the second "
                         "tangent"), "frequency": (lay.unit, "frequency of the peak")}.items():
        if k == "ku2" and not plane:
            continue
        data_vars[f"hysteresis_{k}"] = (axes, par[k], {"units": u, "long_name": f"{name} of "
                                                       "that element" if k != "frequency"
                                                       else name})

