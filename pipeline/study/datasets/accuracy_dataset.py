"""The accuracy-cost study's results (`accuracy_measure.run_case`, one per case) as an
xarray Dataset and as a Markdown table.

The Dataset has one `run` per measured setting (references, baselines, knob values,
the recommended combinations).  Its variables are listed in `VARIABLES` (name, dims,
units, long_name and, for one value per run, its dtype and how a row of results gives
it); the lumped reference's time-integration check adds the scalars of
`TIME_INTEGRATION`; the settings of the reference, baseline and recommendation are
global attributes.
"""
from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np

from ..execution.accuracy_measure import meets_target
from ..files.accuracy_types import AccuracyStudy
from .describe import provenance


class Variable(NamedTuple):
    """One variable of the Dataset.  `units` None: no units attribute (text and
    booleans); `dtype` and `value` (a row of results -> its value) for a variable with
    one value per run, None for the arrays `to_dataset` computes from the branches."""

    name: str
    dims: tuple
    units: str | None
    long_name: str
    dtype: object = None
    value: Callable | None = None


RUN = ("run",)
BRANCH = ("run", "point")


def _m(attr):
    """Row -> the `attr` of its Measurement."""
    return lambda r: getattr(r["m"], attr)


def _setting(attr):
    """Row -> the `attr` of its Settings."""
    return lambda r: getattr(r["settings"], attr)


def _aft_samples(r):
    s = r["settings"]
    return s.samples if s.force_evaluation == "aft" else -1


def _modes(r):
    s = r["settings"]
    return -1 if s.craig_bampton_modes is None else s.craig_bampton_modes


def _mesh(r):
    s = r["settings"]
    return "" if s.mesh is None else "x".join(map(str, s.mesh))


def _value_text(row) -> str:
    k, s = row["knob"], row["settings"]
    if k in ("reference", "baseline", "recommended"):
        return s.describe()
    v = s.value_of(k)
    if k == "mesh":
        return "x".join(map(str, v)) + f" ({row['m'].n_dof_full:,} DOFs)"
    if k == "samples":
        return f"AFT N = {v}"
    return f"{v:g}" if isinstance(v, float) else str(v)


def _run_label(row) -> str:
    k = row["knob"]
    if k in ("reference", "baseline", "recommended"):
        return f"{row['case']}/{k}"
    v = row["settings"].value_of(k)
    v = "x".join(map(str, v)) if k == "mesh" else (f"{v:g}" if isinstance(v, float) else v)
    return f"{row['case']}/{k}={v}"


def _error_variables() -> tuple:
    """The relative errors of every run against its case's reference and baseline."""
    out = []
    for key, what in (("errors", "the case's reference"), ("errors_baseline", "its baseline")):
        sfx = "" if key == "errors" else "_vs_baseline"
        for k, text in (("peak_amplitude", "peak amplitude"), ("peak_frequency", "peak frequency"),
                        ("fold_frequency", "fold frequencies (largest; inf: other fold count)"),
                        ("error", "largest of the three")):
            out.append(Variable(f"{k}_error{sfx}" if k != "error" else f"error{sfx}", RUN, "1",
                                f"relative error of the {text} against {what}", float,
                                lambda r, key=key, k=k: r[key][k]))
    return tuple(out)


# in the order of the file: the branches and peaks (computed by `to_dataset`), then one
# value per run: costs, outcome, settings, errors
VARIABLES = (
    Variable("amplitude", ("run", "point", "dof"), "m",
             "half peak-to-peak amplitude of the case's response DOF"),
    Variable("harmonic_amplitude", ("run", "point", "dof", "harmonic"), "m",
             "sqrt(a_h^2 + b_h^2) of the response DOF (|a_0| at h = 0)"),
    Variable("converged", BRANCH, "1", "full residual within its tolerance"),
    Variable("stable", BRANCH, "1", "stability NOT computed (accuracy study): NaN everywhere"),
    Variable("peak_amplitude", ("run", "dof"), "m", "largest amplitude on the branch (exact peak)"),
    Variable("peak_frequency", ("run", "dof"), "rad/s", "frequency of that peak"),
    Variable("fold_frequency", ("run", "fold"), "rad/s",
             "frequencies of the folds, ascending (NaN: fewer folds)"),
    Variable("n_folds", RUN, "1", "folds detected on the branch", np.int32,
             lambda r: r["m"].folds.size),
    Variable("wall_time", RUN, "s", "wall time: shortest continuation of the repeats + model time",
             float, _m("wall_time")),
    Variable("cpu_time", RUN, "s", "process (CPU) time of that continuation", float,
             _m("cpu_time")),
    Variable("repeats", RUN, "1", "timing runs of the setting (interleaved; the shortest counts)",
             np.int32, _m("repeats")),
    Variable("model_time", RUN, "s", "FE assembly + Craig-Bampton reduction (blades; 0 for lumped)",
             float, _m("model_time")),
    Variable("n_points", RUN, "1", "points on the branch", np.int32, _m("n_points")),
    Variable("residual_evaluations", RUN, "1", "residual evaluations of the continuation",
             np.int32, _m("nfev")),
    Variable("n_dof", RUN, "1", "DOFs of the model solved (reduced for blades)", np.int32,
             _m("n_dof")),
    Variable("n_dof_full", RUN, "1", "DOFs of the unreduced model", np.int32, _m("n_dof_full")),
    Variable("success", RUN, "1",
             "the branch reached the end of the window and its peak is interior", bool,
             _m("success")),
    Variable("message", RUN, None, "continuation message", str, _m("message")),
    Variable("case", RUN, None, "case", str, lambda r: r["case"]),
    Variable("knob", RUN, None, "knob varied (or reference / baseline / recommended)", str,
             lambda r: r["knob"]),
    Variable("value", RUN, None,
             "value of the knob (settings of reference / baseline / recommended)", str,
             _value_text),
    Variable("harmonics", RUN, "1", "harmonics H", np.int32, _setting("harmonics")),
    Variable("force_evaluation", RUN, None, "contact forces: exact or aft", str,
             _setting("force_evaluation")),
    Variable("samples", RUN, "1", "AFT samples per period (-1: exact forces)", np.int32,
             _aft_samples),
    Variable("tolerance", RUN, "1", "Newton residual tolerance, relative to the force scale",
             float, _setting("tolerance")),
    Variable("max_step", RUN, "1", "largest continuation step (scaled arclength)", float,
             _setting("max_step")),
    Variable("craig_bampton_modes", RUN, "1", "Craig-Bampton fixed-interface modes (-1: lumped)",
             np.int32, _modes),
    Variable("mesh", RUN, None, "blade mesh n_chord x n_thick x n_span ('' : lumped)", str, _mesh),
    Variable("forced_response", RUN, None, "forced response: harmonic_balance (traced) or "
             "nonlinear_mode (synthesised from the first nonlinear mode)", str,
             _setting("forced_response")),
) + _error_variables() + (
    Variable("response_dof", RUN, None, "the case's response DOF (dof = 'response')"),
)

# the lumped reference against event-driven time integration (`<case>_time_integration_<key>`,
# scalars): key, units, what
TIME_INTEGRATION = (
    ("amplitude_at_peak", "m", "amplitude at the reference peak frequency"),
    ("peak_amplitude", "m", "largest amplitude near the reference peak"),
    ("peak_frequency", "rad/s", "frequency of that largest amplitude"),
    ("amplitude_error", "1", "|A_ref / A_ti(W_ref) - 1| at the reference peak"),
    ("peak_amplitude_error", "1", "|A_ref / A_ti,peak - 1|"),
    ("peak_frequency_error", "1", "|W_ref / W_ti,peak - 1|"),
    ("wall_time", "s", "wall time of the time integration check"),
)


def to_dataset(study: AccuracyStudy, results: list):
    """One `run` per measured setting (references, baselines, knob values, the
    recommended combinations); per run the contract's response variables (studies/README.md,
    Dataset) of the case's DOF (frequency in rad/s), the settings, times, peaks,
    folds and errors."""
    # xarray is imported when a dataset is built: reading or checking a study does not
    # pay for its import
    import xarray as xr

    rows = [r for res in results for r in res["rows"]]
    P = max([1] + [r["m"].omega.size for r in rows])
    Hmax = max(r["settings"].harmonics for r in rows)
    F = max([1] + [r["m"].folds.size for r in rows])
    arrays, freq = _branch_arrays(rows, P, Hmax, F)
    dofs = {res["case"].name: res["case"].dof for res in results}
    arrays["response_dof"] = np.array([dofs[r["case"]] for r in rows], dtype=str)
    extra = {"stable": dict(flag_values=np.array([0.0, 1.0]), flag_meanings="unstable stable",
                            comment="NaN: stability not computed (the runs measure accuracy "
                                    "and time)", stability_computed=0)}
    data_vars = {}
    for v in VARIABLES:
        data = (arrays[v.name] if v.value is None
                else np.array([v.value(r) for r in rows], dtype=v.dtype))
        data_vars[v.name] = _variable(v.dims, data, v.units, v.long_name, **extra.get(v.name, {}))
    for res in results:
        ti = res["ti"]
        if ti is not None:
            c = res["case"].name
            for k, units, text in TIME_INTEGRATION:
                data_vars[f"{c}_time_integration_{k}"] = _variable(
                    (), float(ti[k]), units, f"{c}: event-driven time integration: {text}")
    data_vars["response_dof"] = data_vars.pop("response_dof")   # the last variable
    return xr.Dataset(data_vars=data_vars, coords=_coordinates(rows, P, Hmax, F, freq),
                      attrs=_attributes(study, results, Hmax))


def _variable(dims, data, units, long_name, **extra):
    attrs = {"long_name": long_name, **extra}
    if units is not None:
        attrs["units"] = units
    return (dims, data, attrs)


def _pad(rows, get, shape, fill=np.nan, dtype=float):
    """(runs,) + shape array of get(row) per row, padded with `fill`."""
    a = np.full((len(rows),) + shape, fill, dtype=dtype)
    for i, r in enumerate(rows):
        v = np.asarray(get(r))
        a[(i,) + tuple(slice(0, n) for n in v.shape)] = v
    return a


def _branch_arrays(rows, P, Hmax, F):
    """({name: array} of the branch and peak variables, frequency (run, point));
    NaN at the points that did not converge."""
    conv = _pad(rows, lambda r: r["m"].converged, (P,), False, bool)
    freq = _pad(rows, lambda r: r["m"].omega, (P,))
    amp = _pad(rows, lambda r: r["m"].amplitude, (P,))
    freq[~conv], amp[~conv] = np.nan, np.nan
    hamp = _pad(rows, lambda r: r["m"].harmonic_amplitude, (P, Hmax + 1))
    for i, r in enumerate(rows):  # harmonics above a run's H are not in its ansatz: zero
        hamp[i, :, np.shape(r["m"].harmonic_amplitude)[-1]:] = 0.0
    hamp[~conv] = np.nan
    num = lambda f: np.array([f(r) for r in rows], dtype=float)        # noqa: E731
    arrays = {"amplitude": amp[..., None], "harmonic_amplitude": hamp[:, :, None, :],
              "converged": conv, "stable": np.full(conv.shape, np.nan),
              "peak_amplitude": num(lambda r: r["m"].peak_amplitude)[:, None],
              "peak_frequency": num(lambda r: r["m"].peak_frequency)[:, None],
              "fold_frequency": _pad(rows, lambda r: r["m"].folds, (F,))}
    return arrays, freq


def _coordinates(rows, P, Hmax, F, freq) -> dict:
    labels = np.array([_run_label(r) for r in rows], dtype=str)
    return {"run": ("run", labels, {"long_name": "run: case/knob=value"}),
            "dof": ("dof", np.array(["response"], dtype=str),
                    {"long_name": "the case's response DOF (see response_dof)"}),
            "harmonic": ("harmonic", np.arange(Hmax + 1, dtype=np.int32),
                         {"units": "1", "long_name": "harmonic index h"}),
            "point": ("point", np.arange(P, dtype=np.int32),
                      {"units": "1", "long_name": "index along the branch"}),
            "fold": ("fold", np.arange(F, dtype=np.int32),
                     {"units": "1", "long_name": "index of a fold, in ascending frequency"}),
            "frequency": (("run", "point"), freq, {"units": "rad/s",
                                                   "long_name": "excitation frequency"})}


def _attributes(study: AccuracyStudy, results: list, Hmax: int) -> dict:
    """The global attributes: the study, then per case its reference, baseline and
    recommended settings and how the recommendation fares."""
    attrs = {"title": study.title, "study": study.text, "study_name": study.name,
             "description": study.description, "reference": study.reference,
             "kind": "accuracy_cost", "quick": int(study.quick),
             "harmonics": int(Hmax), "force_evaluation": "per run (variable force_evaluation)",
             "target": float(study.target),
             "frequency_note": "every frequency in rad/s (blade: Hz = rad/s / 2 pi)",
             **provenance("pipeline (accuracy-cost study: harmonic balance, continuation)")}
    for res in results:
        c = res["case"].name
        rr = res["recommended"]
        attrs[f"{c}_reference"] = res["case"].reference.describe()
        if res["case"].preload is not None:
            attrs[f"{c}_preload"] = float(res["case"].preload)
        attrs[f"{c}_baseline"] = res["case"].baseline.describe()
        attrs[f"{c}_recommended"] = rr["settings"].describe()
        attrs[f"{c}_recommended_error"] = float(rr["errors"]["error"])
        attrs[f"{c}_recommended_wall_time"] = float(rr["m"].wall_time)
        attrs[f"{c}_recommended_meets_target"] = int(meets_target(rr, study.target))
        for k, (v, _, met) in res["recommendation"].items():
            attrs[f"{c}_recommended_{k}"] = ("x".join(map(str, v)) if k == "mesh" else v
                                            if isinstance(v, str) else
                                            int(v) if isinstance(v, (int, np.integer)) else float(v))
            attrs[f"{c}_recommended_{k}_meets_target"] = int(met)
    return attrs


# ---------------------------------------------------------------------------
# The Markdown table
# ---------------------------------------------------------------------------

def _fmt(x) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if math.isinf(x):
        return "fold missed"
    return "0" if x == 0 else f"{x:.1e}"


def results_table(results: list, target: float) -> str:
    """Markdown table: case, knob, value, wall time, residual evaluations, the three
    errors against the reference, the largest against the baseline."""
    lines = ["| case | knob | value | wall time [s] | residual evaluations | peak amplitude "
             "| peak frequency | folds | largest vs baseline |",
             "|---|---|---|---|---|---|---|---|---|"]
    for res in results:
        for r in res["rows"]:
            e, m = r["errors"], r["m"]
            ok = "" if m.success else " (failed)"
            lines.append(f"| {r['case']} | {r['knob']} | {_value_text(r)}{ok} | "
                         f"{m.wall_time:.3g} | {m.nfev} | {_fmt(e['peak_amplitude'])} | "
                         f"{_fmt(e['peak_frequency'])} | {_fmt(e['fold_frequency'])} | "
                         f"{_fmt(r['errors_baseline']['error'])} |")
    return "\n".join(lines)


def recommendation_lines(results: list, target: float) -> list:
    """Per case, the recommended settings, their error against the target and their
    time; for the lumped case, the reference against time integration."""
    out = []
    for res in results:
        c, rr, ref = res["case"].name, res["recommended"], res["rows"][0]["m"]
        parts = []
        for k, (v, _, met) in res["recommendation"].items():
            txt = "x".join(map(str, v)) if k == "mesh" else (f"{v:g}" if isinstance(v, float) else v)
            parts.append(f"{k} = {txt}" + ("" if met else f" (none meets {target:g})"))
        verdict = "meets" if meets_target(rr, target) else "MISSES"
        out.append(f"{c}: recommended {', '.join(parts)} -> error {_fmt(rr['errors']['error'])} "
                   f"({verdict} the target {target:g}) in {rr['m'].wall_time:.3g} s; reference "
                   f"{ref.wall_time:.3g} s")
        ti = res["ti"]
        if ti is not None:
            out.append(f"{c}: reference vs event-driven time integration: amplitude at the peak "
                       f"{_fmt(ti['amplitude_error'])}, peak amplitude "
                       f"{_fmt(ti['peak_amplitude_error'])}, peak frequency "
                       f"{_fmt(ti['peak_frequency_error'])}")
    return out
