"""The sections every response study file shares, read and validated: `[solver]`
(`parse_solver`), `[sweep]` (`parse_sweep`, a Monte-Carlo sample of mistuning seeds
`seed_range`), the `[quick]` overrides of both (`quick_response_tables`) and the
`[output]` keys common to every scene (`output_common`, peak windows inside the swept
range `check_windows`, the optimum preload or interference search `parse_optimum`).
Lumped, disk and FE blade scenes (`study.scenes`) and the accuracy-cost study read
them; every failure is `UsageError("<file>: <field>: <what>")` through the `Checker`.
"""
from __future__ import annotations

from dataclasses import replace

from ...solve.response.optimum import LINEAR_NODES
from .study_types import (DEFAULT_FIGURES, FIGURES, FREQUENCY_UNITS, INTEGER_SWEEP_AXES,
                          MAX_HARMONICS, STABILITY_MODES, STABILITY_WHEN_TRUE, SWEEP_AXES,
                          FrequencyRange, SolverSettings, solver_rule_violations)
from .validation import join_field, kind_of


def solver_sweep_tables(ck, data):
    """[solver] and [sweep] of any response study."""
    solver_tab = ck.table(data.get("solver"), "solver", required=False)
    sweep_tab = ck.table(data["sweep"], "sweep")
    return solver_tab, sweep_tab


def quick_response_tables(ck, quick: dict, sweep_tab):
    """([quick.solver], [quick.sweep]) of a response study from its quick tables
    (`header.quick_tables`, read only for `--quick`, after the main tables); quick
    mode may only override axes that [sweep] has."""
    q_sweep, q_solver = quick.get("sweep", {}), quick.get("solver", {})
    for k in q_sweep:
        if k not in sweep_tab:
            ck.fail(join_field("quick.sweep", k), "quick mode may only override axes of [sweep] "
                                             f"(which has: {', '.join(sweep_tab) or 'none'})")
    return q_solver, q_sweep


_SOLVER_KEYS = ("harmonics", "force_evaluation", "samples", "tolerance", "stability",
                "initial_step", "max_step", "max_points", "dense_output")


def parse_solver(ck, tab, path, base=None, model="lumped") -> SolverSettings:
    """`SolverSettings` from the table `tab` at field `path` (keys not given keep the values
    of `base`, or the defaults; `stability = true`: `study_types.STABILITY_WHEN_TRUE[model]`)."""
    ck.keys(tab, path, _SOLVER_KEYS)
    kw = {}
    if "harmonics" in tab:
        kw["harmonics"] = ck.integer(tab["harmonics"], f"{path}.harmonics", 1, MAX_HARMONICS)
    if "force_evaluation" in tab:
        kw["force_evaluation"] = ck.string(tab["force_evaluation"], f"{path}.force_evaluation",
                                           ("exact", "aft"))
    if "samples" in tab:
        kw["samples"] = ck.integer(tab["samples"], f"{path}.samples", 3, 1 << 16)
    if "tolerance" in tab:
        kw["tolerance"] = ck.number(tab["tolerance"], f"{path}.tolerance", gt=0.0, lt=1.0)
    if "stability" in tab:
        kw["stability"] = ck.switch(tab["stability"], f"{path}.stability", STABILITY_MODES,
                                    STABILITY_WHEN_TRUE.get(str(model), "monodromy+check"))
    if "dense_output" in tab:
        kw["dense_output"] = ck.boolean(tab["dense_output"], f"{path}.dense_output")
    for key in ("initial_step", "max_step"):
        if key in tab:
            kw[key] = ck.number(tab[key], f"{path}.{key}", gt=0.0, le=10.0)
    if "max_points" in tab:
        kw["max_points"] = ck.integer(tab["max_points"], f"{path}.max_points", 2, 1_000_000)
    s = replace(base, **kw) if base is not None else SolverSettings(**kw)
    # blame a key of this table that takes part in the broken rule
    partner = {"initial_step": "max_step", "samples": "harmonics"}
    for key, what in solver_rule_violations(s):
        if key not in tab and partner[key] in tab:
            key = partner[key]
        ck.fail(f"{path}.{key}", what)
    return s


def parse_sweep(ck, tab, path, partial=False):
    """(grid axes {name: values}, `FrequencyRange` or None) from the [sweep] table `tab`
    at field `path`; `partial` (a quick override) may omit the frequency."""
    axes, freq = {}, None
    for key, value in tab.items():
        field = join_field(path, key)
        if key == "frequency":
            if isinstance(value, list):
                ck.fail(field, "a frequency grid (continuation in preload) is not supported yet; "
                               "give the continuation interval {start, stop, unit}")
            t = ck.table(value, field)
            ck.keys(t, field, ("start", "stop", "unit"), required=("start", "stop"))
            if "unit" not in t:  # no default: a range meant in Hz must not run in rad/s
                ck.fail(f"{field}.unit", f"missing (required): one of {FREQUENCY_UNITS}")
            unit = ck.string(t["unit"], f"{field}.unit", FREQUENCY_UNITS)
            start = ck.number(t["start"], f"{field}.start", gt=0.0)
            stop = ck.number(t["stop"], f"{field}.stop", gt=0.0)
            if start == stop:
                ck.fail(field, f"start and stop are equal ({start:g} {unit}): empty interval")
            freq = FrequencyRange(start, stop, unit)
        elif key in INTEGER_SWEEP_AXES:  # engine orders (range checked against the
            # sectors) and mistuning seeds: integers >= 0
            vals = (seed_range(ck, value, field) if key == "mistuning_seed"
                    and isinstance(value, dict) else ck.array(value, field))
            for i, v in enumerate(vals):
                ck.integer(v, f"{field}[{i}]", 0, 1 << 30)
                if v in vals[:i]:
                    ck.fail(f"{field}[{i}]", f"duplicate value {v}")
            axes[key] = tuple(int(v) for v in vals)
        elif key in SWEEP_AXES:
            if isinstance(value, dict):
                ck.fail(field, f"continuation in {key} is not supported yet; give a list of values")
            bounds = {"preload": {}, "normal_load": {"gt": 0.0}, "mu": {"ge": 0.0}, "ku": {"gt": 0.0}, "kv": {"ge": 0.0},
                      "excitation_scale": {"gt": 0.0}, "speed": {"ge": 0.0},
                      "interference": {}}[key]
            vals = ck.numbers(value, field, **bounds)
            for i, v in enumerate(vals):
                if v in vals[:i]:
                    ck.fail(f"{field}[{i}]", f"duplicate value {v:g}")
            axes[key] = tuple(float(v) for v in vals)
        else:
            allowed = ("frequency",) + tuple(SWEEP_AXES)
            ck.keys({key: value}, path, allowed)
    if freq is None and not partial:
        ck.fail(f"{path}.frequency", "missing (required): the continuation interval "
                                     "{start, stop, unit}")
    return axes, freq


def check_windows(ck, windows, freq):
    """Every peak window must overlap the swept frequency range."""
    f0, f1 = sorted((freq.start, freq.stop))
    for lo, hi in windows:
        if hi <= f0 or lo >= f1:
            ck.fail("output.peak_windows", f"window [{lo:g}, {hi:g}] lies outside the frequency "
                                           f"range [{f0:g}, {f1:g}] {freq.unit}")


def output_common(ck, t):
    """`[output]` keys shared by every scene: figures, yscale, peak_windows."""
    figs = ck.names(t.get("figures", list(DEFAULT_FIGURES)), "output.figures", min_length=0)
    for i, fg in enumerate(figs):
        if fg not in FIGURES:
            ck.fail(f"output.figures[{i}]", f"unknown figure {fg!r} (known: {', '.join(FIGURES)})")
    yscale = ck.string(t.get("yscale", "linear"), "output.yscale", ("linear", "log"))
    windows = []
    for i, w in enumerate(ck.array(t.get("peak_windows", []), "output.peak_windows", min_length=0)):
        lo, hi = ck.numbers(w, f"output.peak_windows[{i}]", 2, ge=0.0)
        if not lo < hi:
            ck.fail(f"output.peak_windows[{i}]", f"must be [low, high] with low < high, got "
                                                 f"[{lo:g}, {hi:g}]")
        windows.append((float(lo), float(hi)))
    return tuple(figs), yscale, tuple(windows)


def parse_optimum(ck, t, scene, variable: str = "preload"):
    """`[output] optimum_preload = { dof, bounds = [lo, hi] (N), frequency?, rtol? }`
    (None when absent): the preload search of `peak_tracking.optimum_preload`;
    variable="interference": `optimum_interference`, bounds [m] of either sign on a
    linear grid of `nodes` (default LINEAR_NODES), rtol of the bounds' width."""
    key = f"optimum_{variable}"
    if key not in t:
        return None
    o, f, linear = t[key], f"output.{key}", variable == "interference"
    if not isinstance(o, dict):
        ck.fail(f, f"must be a table, got {kind_of(o)}")
    ck.keys(o, f, ("dof", "bounds", "frequency", "rtol") + (("nodes",) if linear else ()))
    if "dof" not in o or "bounds" not in o:
        ck.fail(f, f"needs dof and bounds = [low, high] ({'m' if linear else 'N'})")
    dof = ck.string(o["dof"], f + ".dof", tuple(scene.dofs))
    lo, hi = ck.numbers(o["bounds"], f + ".bounds", 2, **({} if linear else {"gt": 0.0}))
    if not lo < hi:
        ck.fail(f + ".bounds", f"must be [low, high] with {'' if linear else '0 < '}low < high, "
                               f"got [{lo:g}, {hi:g}]{' m' if linear else ''}")
    window = None
    if "frequency" in o:
        w = o["frequency"]
        if not isinstance(w, dict):
            ck.fail(f + ".frequency", f"must be a table {{start, stop, unit}}, got {kind_of(w)}")
        window = parse_sweep(ck, {"frequency": w}, f, partial=True)[1]
    rtol = ck.number(o.get("rtol", 1e-2), f + ".rtol", gt=0.0, lt=1.0)
    if not scene.contacts:
        ck.fail(f, "the scene has no contact: there is no preload to optimise")
    out = {"dof": dof, "bounds": (float(lo), float(hi)), "window": window, "rtol": float(rtol)}
    if linear:
        out.update(variable=variable, nodes=ck.integer(o.get("nodes", LINEAR_NODES),
                                                       f + ".nodes", 3, 200))
    return out



def seed_range(ck, value, field) -> list:
    """`mistuning_seed = { first = 1, count = 100 }`: the seeds first ... first + count - 1
    (a Monte-Carlo sample)."""
    ck.keys(value, field, ("first", "count"), required=("first", "count"))
    first = ck.integer(value["first"], f"{field}.first", 0, 1 << 30)
    count = ck.integer(value["count"], f"{field}.count", 1, 100_000)
    return list(range(first, first + count))
