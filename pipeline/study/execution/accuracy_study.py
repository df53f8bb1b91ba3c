"""Accuracy against cost (`[study] kind = "accuracy_cost"`, `studies/accuracy_cost.toml`).

Each case (a lumped scene `[lumped]`, an FE blade scene `[blade]`) is traced once
with its REFERENCE settings (the most accurate ones), once with its BASELINE
settings and once per value of each accuracy knob, the other settings held at the
baseline.  Every run is a frequency continuation (`response.frequency_response`,
without stability) whose peak is located exactly; it gives

    wall time      best of `repeats` runs [s] (plus, for a blade, the FE assembly
                   and the Craig-Bampton reduction of its mesh and mode count)
    e_A = |A - A_ref| / A_ref               peak amplitude of the case's DOF
    e_W = |W - W_ref| / W_ref               peak frequency
    e_F = max_f |W_f - W_f,ref| / W_f,ref   fold frequencies (inf if the number of
                                            folds differs; NaN if neither has any)
    error = max(e_A, e_W, e_F)

Knobs: `harmonics` H, `samples` N (AFT forces on N samples instead of the exact
ones), `tolerance` (Newton residual tolerance of every point, relative to the
force scale, `hbm.tolerances`), `max_step` (largest continuation step in the
scaled arclength: it sets how densely the branch is sampled, while peaks and folds
are refined to the tolerance whatever the step), `craig_bampton_modes` and
`mesh = [n_chord, n_thick, n_span]` (blades).

The lumped reference is also checked against event-driven time integration
(`timesim.steady_state`, no harmonic truncation) at its peak: the amplitude there,
and the peak frequency found by maximising the integrated amplitude (bounded Brent).

The recommended value of each knob is the cheapest measured one (baseline
included) whose three errors are all below `[recommendation] target`; the
combination of the recommended values is then run once more and reported as is
(errors of several knobs add, so it may miss the target; the run says so).

Output: `DIR/<name>.nc` (one `run` dimension, the response variables of
the dataset contract per run, the settings, times and errors), `DIR/<name>/pareto.png`
(error against wall time, log-log, one series per knob) and
`DIR/<name>/table.md`.

This module reads a study document (`study_from_mapping`, the scenes through
lumped_scene.py and blade_scene.py), describes it for `check` and runs it
(`run_accuracy_study`): its registry entry `KIND` (`kinds`); the estimate is
`kind_costs.accuracy_estimate`, the systems of its runs
`accuracy_measure.case_systems`.  The plain data is in files/accuracy_types.py, the
runs, errors and recommendation in accuracy_measure.py, the Dataset and the table in
`datasets.accuracy_dataset`, the figure in `figures.pareto_figure`.
"""
from __future__ import annotations

import logging
import time
from dataclasses import replace
from pathlib import Path

from ...structure.fe_model import BladeParams
from ...structure.reduction import DEFAULT_MODES
from ..datasets.accuracy_dataset import recommendation_lines, results_table, to_dataset
from .accuracy_measure import case_systems, run_case
from ..files.accuracy_types import (MESH_FIELDS, AccuracyStudy, Case, Settings, beyond_reference,
                            check_settings, mesh_value)
from ..scenes.blade_scene import OUT_DOF_PATTERN, base_dir_of, parse_blade_params, parse_blade_scene
from ..files.validation import Checker
from ..files.header import overlay, parse_header, quick_tables
from ..figures.pareto_figure import pareto_figure
from ..files.rules import check_scene_rules, contact_rules
from ..files.sections import parse_sweep
from ..scenes.lumped_scene import parse_scene
from .kind_costs import accuracy_estimate, estimate_lines
from ..files.study_types import (MAX_HARMONICS, FrequencyRange, StudyKind, always, never,
                                 solver_rule_violations)

log = logging.getLogger(__name__)

CASES = ("lumped", "blade")
_LUMPED_KNOBS = ("harmonics", "samples", "tolerance", "max_step", "forced_response")
RESPONSES = ("harmonic_balance", "nonlinear_mode")
KNOBS = {"lumped": _LUMPED_KNOBS, "blade": _LUMPED_KNOBS + ("craig_bampton_modes", "mesh")}
_SETTINGS = {"lumped": ("harmonics", "force_evaluation", "samples", "tolerance", "max_step",
                        "initial_step"),
             "blade": ("harmonics", "force_evaluation", "samples", "tolerance", "max_step",
                       "initial_step", "craig_bampton_modes", "mesh")}
_CASE_KEYS = ("dof", "preload", "frequency", "repeats", "time_integration", "scene", "reference",
              "baseline", "knobs")
_QUICK_KEYS = ("dof", "preload", "frequency", "repeats", "time_integration", "reference",
               "baseline", "knobs")


# ---------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------

class _Prefixed(Checker):
    """Reports every field under a prefix (a scene nested in a case table)."""

    def __init__(self, file, prefix):
        super().__init__(file)
        self.prefix = prefix

    def fail(self, field_, what):
        super().fail(f"{self.prefix}.{field_}" if field_ else self.prefix, what)


class _At(Checker):
    """Reports every failure at one field (a value checked by code that names others)."""

    def __init__(self, file, at):
        super().__init__(file)
        self.at = at

    def fail(self, field_, what):
        super().fail(self.at, what)


def study_from_mapping(data: dict, *, file: str = "<study>", name: str = "study", text: str = "",
                       quick: bool = False) -> AccuracyStudy:
    """Validate an accuracy-cost study document (both the full and the quick variant)."""
    ck = Checker(file)
    ck.table(data, "(document)")
    ck.keys(data, "", ("study", "recommendation", "quick") + CASES, required=("study",))
    header = parse_header(ck, data)
    rec = ck.table(data.get("recommendation"), "recommendation", required=False)
    ck.keys(rec, "recommendation", ("target",))
    target = ck.number(rec.get("target", 1e-3), "recommendation.target", gt=0.0, lt=1.0)
    present = [c for c in CASES if c in data]
    if not present:
        ck.fail("(document)", "no case: give a [lumped] and/or a [blade] table")
    qt = quick_tables(ck, data, quick, present)   # read only for --quick
    base_dir = base_dir_of(file)
    full, short = [], []
    for c in present:
        tab = ck.table(data[c], c)
        ck.keys(tab, c, _CASE_KEYS, required=("scene", "reference", "frequency"))
        q = qt.get(c, {})
        ck.keys(q, f"quick.{c}", _QUICK_KEYS)
        merged, w_quick = overlay(ck, tab, q, c, deep=("reference", "baseline"))
        w_full = lambda p, c=c: f"{c}.{p}"  # noqa: E731
        # the FE blade is built (validated) once, on the chosen variant's reference mesh
        scene, h_excited = _case_scene(ck, c, merged if quick else tab, base_dir,
                                       w_quick if quick else w_full)
        full.append(_case(ck, c, tab, scene, h_excited, w_full))
        short.append(_case(ck, c, merged, scene, h_excited, w_quick))
    return AccuracyStudy(file=file, name=name, **header, text=text,
                         cases=tuple(short if quick else full),
                         target=float(target), quick=bool(quick))


def _case_scene(ck, c, tab, base_dir, where):
    """(scene, highest excited harmonic) of a case: a lumped `Scene` or a `BladeScene`
    (built on the reference mesh with the reference mode count of `tab`)."""
    pk = _Prefixed(ck.file, c)
    raw = ck.table(tab["scene"], f"{c}.scene")
    model = raw.get("model")
    if c == "lumped":
        if model != "lumped":
            ck.fail(f"{c}.scene.model", f"the [lumped] case needs model = \"lumped\", got {model!r}")
        scene = parse_scene(pk, raw)
        return scene, scene.loads[0].amplitudes.shape[1] - 1
    if model != "solid_blade":
        ck.fail(f"{c}.scene.model", f"the [blade] case needs model = \"solid_blade\", got {model!r}")
    for k in ("craig_bampton_modes",):
        if k in raw:
            ck.fail(f"{c}.scene.{k}", "an accuracy setting: give it in reference, baseline or knobs")
    blade_tab = ck.table(raw.get("blade", {}), f"{c}.scene.blade")
    for k in MESH_FIELDS:
        if k in blade_tab:
            ck.fail(f"{c}.scene.blade.{k}", "an accuracy setting: give mesh = [n_chord, n_thick, "
                                            "n_span] in reference, baseline or knobs")
    ref = ck.table(tab["reference"], where("reference"))
    at = dict(raw)
    if "mesh" in ref:  # build (and so validate) the scene on the reference mesh
        counts = mesh_value(ck, ref["mesh"], where("reference.mesh"))
        at["blade"] = {**blade_tab, **dict(zip(MESH_FIELDS, counts))}
    if "craig_bampton_modes" in ref:
        at["craig_bampton_modes"] = ck.integer(ref["craig_bampton_modes"],
                                               where("reference.craig_bampton_modes"), 0, 10_000)
    scene = parse_blade_scene(pk, at, base_dir)
    if not scene.contacts:
        ck.fail(f"{c}.scene.contact", "a blade case needs at least one [[blade.scene.contact]]")
    return scene, max(ld.harmonic for ld in scene.loads)


def _setting(ck, key, value, field_, h_excited):
    """One validated setting value."""
    if key == "harmonics":
        H = ck.integer(value, field_, 1, MAX_HARMONICS)
        if H < h_excited:
            ck.fail(field_, f"H = {H} is below the excited harmonic {h_excited}")
        return H
    if key == "force_evaluation":
        return ck.string(value, field_, ("exact", "aft"))
    if key == "samples":
        return ck.integer(value, field_, 3, 1 << 16)
    if key == "tolerance":
        return ck.number(value, field_, gt=0.0, lt=1.0)
    if key in ("max_step", "initial_step"):
        return ck.number(value, field_, gt=0.0, le=10.0)
    if key == "craig_bampton_modes":
        return ck.integer(value, field_, 0, 10_000)
    if key == "mesh":
        return mesh_value(ck, value, field_)
    if key == "forced_response":
        return ck.string(value, field_, RESPONSES)
    raise AssertionError(key)


def _settings(ck, c, t, path, where, h_excited, base=None) -> Settings:
    """Settings from table `t` on top of `base` (default: the built-in defaults)."""
    allowed = _SETTINGS[c]
    for k in t:
        if k not in allowed:
            ck.keys({k: None}, where(f"{path}.{k}").rsplit(".", 1)[0], allowed)
    kw = {k: _setting(ck, k, v, f"{where(f'{path}.{k}')}", h_excited) for k, v in t.items()}
    s = replace(base, **kw) if base is not None else Settings(**kw)
    if c == "blade" and base is None:
        if s.craig_bampton_modes is None:
            s = replace(s, craig_bampton_modes=DEFAULT_MODES)
        if s.mesh is None:
            # fe_model imports scikit-fem (slow to import): only a blade case needs it
            p = BladeParams()
            s = replace(s, mesh=(p.n_chord, p.n_thick, p.n_span))
    check_settings(ck, s, lambda k: where(f"{path}.{k}") if k in t else where(path))
    return s


def _case(ck, c, tab, scene, h_excited, where) -> Case:
    """Validate one case table (full or quick variant); `where(path)` gives the
    dotted field of a path inside the case."""
    dof = _case_dof(ck, c, tab, scene.dofs, where)
    preload = ck.number(tab["preload"], where("preload")) if "preload" in tab else None
    freq = _case_frequency(ck, tab, where)
    repeats = ck.integer(tab.get("repeats", 1), where("repeats"), 1, 100)
    ti = ck.boolean(tab.get("time_integration", False), where("time_integration"))
    if ti and c != "lumped":
        ck.fail(where("time_integration"), "event-driven time integration is offered for the "
                                           "lumped case only")
    ref_t = ck.table(tab["reference"], where("reference"))
    reference = _settings(ck, c, ref_t, "reference", where, h_excited)
    base_t = ck.table(tab.get("baseline", {}), where("baseline"))
    baseline = _settings(ck, c, base_t, "baseline", where, h_excited, base=reference)
    for k in base_t:
        why = beyond_reference(k, baseline.value_of(k), reference) if k in KNOBS[c] else None
        if why:
            ck.fail(where(f"baseline.{k}"), why + ": the reference must be the most accurate")
    knobs_t = ck.table(tab.get("knobs", {}), where("knobs"))
    knobs = _knobs(ck, c, knobs_t, scene, reference, baseline, h_excited, where)
    if c == "blade":
        for k, s in (("reference", reference), ("baseline", baseline)):
            _check_mesh(ck, scene, s.mesh, where(f"{k}.mesh"))
        if scene.structure.mesh is not None and ("mesh" in knobs_t or "mesh" in base_t):
            ck.fail(where("knobs.mesh" if "mesh" in knobs_t else "baseline.mesh"),
                    "the scene reads a mesh file: it cannot be refined")
    if preload is not None and not scene.contacts:
        ck.fail(where("preload"), "the scene has no contact to apply it to")
    axes = {"preload": (preload,)} if preload is not None else {}
    check_scene_rules(_Prefixed(ck.file, c), scene.effects, contact_rules(scene), h_excited,
                      reference.harmonics, axes, "reference", "")
    return Case(name=c, scene=scene, dof=dof, preload=preload,
                frequency=FrequencyRange(freq.start, freq.stop, freq.unit), repeats=repeats,
                time_integration=ti, reference=reference, baseline=baseline, knobs=tuple(knobs))


def _case_dof(ck, c, tab, dofs, where) -> str:
    """The case's response DOF: a DOF of the lumped scene, '<set>.<component>' of a blade."""
    if "dof" not in tab:
        ck.fail(where("dof"), "missing (required): the response DOF whose peak is measured")
    dof = ck.string(tab["dof"], where("dof"))
    if c == "blade":
        if not OUT_DOF_PATTERN.match(dof):
            ck.fail(where("dof"), f"{dof!r} is not '<set>.<component>' with set excitation or "
                                  "response and component x, y or z")
    elif dof not in dofs:
        ck.fail(where("dof"), f"unknown DOF {dof!r} (DOFs: {', '.join(dofs)})")
    return dof


def _case_frequency(ck, tab, where):
    """The case's frequency window {start, stop, unit} (a continuation sweep's)."""
    fr = tab["frequency"]
    if not isinstance(fr, dict):
        ck.fail(where("frequency"), "must be a table {start, stop, unit}")
    _, freq = parse_sweep(_Prefixed(ck.file, where("frequency").rsplit(".", 1)[0]),
                     {"frequency": fr}, "", partial=True)
    if freq.start > freq.stop:
        ck.fail(where("frequency"), "start must be below stop")
    return freq


def _knobs(ck, c, knobs_t, scene, reference, baseline, h_excited, where) -> list:
    """[(knob, (value, ...))] of the `knobs` table: known knobs, values valid, distinct,
    no more accurate than the reference, and AFT samples >= 2H+1 at the baseline's H."""
    if not knobs_t:
        ck.fail(where("knobs"), f"no knob to vary (knobs: {', '.join(KNOBS[c])})")
    knobs = []
    for k, values in knobs_t.items():
        path = where(f"knobs.{k}")
        if k not in KNOBS[c]:
            ck.keys({k: None}, where("knobs"), KNOBS[c])
        vals = ck.array(values, path)
        out = []
        for i, v in enumerate(vals):
            f = f"{path}[{i}]"
            x = _setting(ck, k, v, f, h_excited)
            if x in out:
                ck.fail(f, f"duplicate value {v}")
            why = beyond_reference(k, x, reference)
            if why:
                ck.fail(f, why + ": the reference must be the most accurate setting")
            s = baseline.with_knob(k, x)
            if "samples" in dict(solver_rule_violations(s)):
                ck.fail(f, f"must be >= 2H+1 = {2 * s.harmonics + 1} for the baseline's H = "
                           f"{s.harmonics}, got {s.samples}")
            if k == "mesh":
                _check_mesh(ck, scene, x, f)
            out.append(x)
        knobs.append((k, tuple(out)))
    return knobs


def _check_mesh(ck, scene, counts, field_):
    """A generated blade with these element counts must be valid and not too fine."""
    p = scene.structure.params
    t = {k: getattr(p, k) for k in ("length", "chord", "thickness", "shroud_chord",
                                    "shroud_width", "shroud_height", "shroud_angle",
                                    "stagger_angle", "E", "nu", "rho")}
    t.update(dict(zip(MESH_FIELDS, counts)))
    parse_blade_params(_At(ck.file, field_), t, scene.model)


# ---------------------------------------------------------------------------
# Running the study
# ---------------------------------------------------------------------------

def run_accuracy_study(study: AccuracyStudy, out_dir="results", *, figures: bool = True,
                       progress: bool = True, solver=None):
    """Run every case, write `out_dir/<name>.nc`, `out_dir/<name>/table.md` and
    `out_dir/<name>/pareto.png`; returns a `study_types.StudyResult`."""
    # dataset.py (xarray) and run.py are imported when a study runs: reading or checking
    # one needs neither
    from ..datasets.dataset import write_netcdf
    from ..files.study_types import StudyResult

    t0 = time.perf_counter()
    out_dir = Path(out_dir)
    results = []
    for case in study.cases:
        n = len({s for _, _, s in case.runs()})
        log.info("%s: case %s, %d distinct settings%s", study.name, case.name, n,
                 " (quick)" if study.quick else "")
        results.append(run_case(case, study.target, case_systems(case), solver))
    ds = to_dataset(study, results)
    res = StudyResult(study=study, dataset=ds, path=None)
    # a knob value whose continuation fails is a finding; a failed reference, a crash or a
    # failed time-integration check is not
    res.failures = sum(int(not r["rows"][0]["m"].success) for r in results) + sum(
        int(row["m"].crashed) for r in results for row in r["rows"]) + sum(
        int(r.get("ti_error") is not None) for r in results)
    res.path = write_netcdf(ds, out_dir / f"{study.name}.nc")
    log.info("wrote %s", res.path)
    table = results_table(results, study.target)
    for line in table.splitlines():
        log.info("%s", line)
    for line in recommendation_lines(results, study.target):
        log.info("%s", line)
    fig_dir = out_dir / study.name
    fig_dir.mkdir(parents=True, exist_ok=True)
    table_path = fig_dir / "table.md"
    tmp = table_path.with_name(f".{table_path.name}.tmp")
    tmp.write_text(table + "\n\n" + "\n".join(recommendation_lines(results, study.target)) + "\n")
    tmp.replace(table_path)
    res.figures.append(table_path)
    if figures:
        res.figures.append(pareto_figure(fig_dir / "pareto.png", ds))
    for p in res.figures:
        log.info("wrote %s", p)
    res.wall_time = time.perf_counter() - t0
    return res


def describe(study: AccuracyStudy, workers: int = 1) -> list:
    """The lines `check` prints for an accuracy-cost study, its cost estimate included."""
    lines = []
    for c in study.cases:
        runs = c.runs()
        lines.append(f"case {c.name}: {c.scene.model}, dof {c.dof}, {c.frequency.start:g} to "
                     f"{c.frequency.stop:g} {c.frequency.unit}; {len(runs)} runs "
                     f"(reference, baseline, {len(runs) - 2} knob values) x {c.repeats} "
                     "timing repeat(s)")
    return lines + estimate_lines(accuracy_estimate(study))


KIND = StudyKind(name="accuracy_cost", word="accuracy_cost", fits=always, by_default=never,
                 parse=study_from_mapping, describe=describe,
                 estimate=lambda study, workers=1: accuracy_estimate(study),
                 run=lambda study, out_dir, figures=True, progress=True, **_: run_accuracy_study(
                     study, out_dir, figures=figures, progress=progress),
                 cases=lambda study: len(study.cases))
