"""Response studies (`[study] kind = "response"`, the default): a lumped or disk scene
(`lumped_scene`) or an FE blade scene (`blade_scene`), swept over a grid of cases, each one
frequency continuation `pipeline.solve.response.response.frequency_response(system, H,
omega_start, omega_stop, **solver.kwargs())`, or one direct solve per frequency for
a linear scene (`pipeline.solve.response.linear_response`).  Its registry entry `KIND`:
read, described for `check` with the cost estimate of `cost`, and run
(`run_response_study`: cases -> dataset -> figures, resumable from checkpoints).
"""
from __future__ import annotations

import logging
import shutil
import time
from pathlib import Path

from ... import __version__
from ..scenes import blade_scene
from ..scenes import lumped_scene
from .cases import default_solver, execute_cases
from .checkpoint import checkpoint_dir, remove_stale
from .cost import WHEEL_RESIDUAL, WHEEL_SOLVE
from .cost import estimate as cost_estimate, further_reductions, model_line, seconds, time_range
from .cost import wheel_memory
from .mistuned import tuned_references
from .python_study import check_python_study
from .optimum_search import grid_job, optimum_figure_of, planned_grid, study_optimum, variable_of
from ..figures.peak_shapes import write_peak_shapes
from ..figures.response_figures import sector_output_dofs, write_figures
from ..files.study_types import SWEEP_AXES, Study, StudyKind, StudyResult, always, is_linear_scene

log = logging.getLogger("pipeline.study.execution.run")


def parse(data: dict, *, file: str = "<study>", name: str = "study", text: str = "",
          quick: bool = False) -> Study:
    """A response study document: an FE blade scene or a lumped or disk scene."""
    read = (blade_scene.response_from_mapping if blade_scene.is_blade_document(data)
            else lumped_scene.study_from_mapping)
    return read(data, file=file, name=name, text=text, quick=quick)


def _num(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def describe(study: Study, workers: int = 1) -> list:
    """The lines `check` prints for a response study: scene, cases, frequency, solver,
    output, model size and cost estimate."""
    sc, sw, sv = study.scene, study.sweep, study.solver
    lines = []
    n_cases = len(sw.cases())
    contacts = getattr(sc, "contacts", ())
    ndof = len(getattr(sc, "dofs", ()) or ())
    laws = "".join(f", {le.B.shape[0]} {le.law.name} element(s)"
                   for le in getattr(sc, "laws", ()))
    lines.append(f"scene: {sc.model}, {ndof} DOF(s), {len(contacts)} contact(s){laws}; effects: "
                 f"{', '.join(sc.effects) or 'none (linear)'}")
    grid = " x ".join(f"{a} ({len(v)})" for a, v in sw.axes.items()) or "one case"
    lines.append(f"cases: {n_cases} = {grid}")
    for a, v in sw.axes.items():
        unit = SWEEP_AXES[a][0]
        lines.append(f"  {a}{'' if unit == '1' else f' [{unit}]'}: {', '.join(_num(x) for x in v)}")
    fr = sw.frequency
    lines.append(f"frequency: {fr.start:g} to {fr.stop:g} {fr.unit} (continuation)")
    linear = is_linear_scene(sc)
    if linear:
        lines.append("solver: direct linear solve per frequency (no contact: no Newton, "
                     "no continuation)")
    else:
        steps = ", ".join(f"{k.replace('_', ' ')} {getattr(sv, k):g}" for k in
                          ("initial_step", "max_step") if getattr(sv, k) is not None)
        lines.append(f"solver: H = {sv.harmonics}, {sv.force_evaluation} forces"
                     + (f" ({sv.samples} samples per period)" if sv.force_evaluation == "aft" else "")
                     + f", tolerance {sv.tolerance:g} (relative), stability "
                     f"{sv.stability or 'off'}, at most {sv.max_points} points per case"
                     + (f", {steps}" if steps else ""))
    o = study.output
    lines.append(f"output: dofs {', '.join(o.dofs)}; figures {', '.join(o.figures) or 'none'}"
                 + (f"; optimum-{variable_of(study)[0]} search on {o.optimum['dof']} in "
                    f"[{o.optimum['bounds'][0]:g}, {o.optimum['bounds'][1]:g}] "
                    f"{variable_of(study)[1]}" if o.optimum else ""))
    return lines + estimate_lines(study, n_cases, workers, linear)


def estimate_lines(study, n_cases: int, workers: int, linear: bool) -> list:
    """The model and cost lines (`pipeline.study.execution.cost`: what they assume)."""
    if linear:
        return [f"estimated cost: {n_cases} direct solve sweep(s), well under 1 s each"]

    lines = [model_line(study)]
    e = cost_estimate(study, workers)
    tm = e.timing
    search = (f", of which the optimum-{variable_of(study)[0]} search {time_range(*e.search)}"
              if e.search else "")
    lines.append(
        f"estimated cost: {time_range(e.lo, e.hi)} (middle {seconds(e.mid)}) for {n_cases} case(s) "
        f"on {e.workers} worker(s){search}")
    lines.append(
        f"  assumes {e.points[0]:.0f}-{e.points[1]:.0f} points per case ({e.modes} natural "
        f"frequenc{'y' if e.modes == 1 else 'ies'} in the range, contacts open and stuck counted "
        f"apart) at {e.per_point[0] * 1e3:.3g}-{e.per_point[1] * 1e3:.3g} "
        f"ms each (residual + Jacobian {tm.t_residual * 1e3:.3g} ms and Newton solve "
        f"{tm.t_solve * 1e3:.3g} ms of {tm.unknowns} unknowns, timed now on this model, "
        f"{e.pairs[0]:g}-{e.pairs[1]:g} times a point, plus bookkeeping and stability {study.solver.stability or 'off'}) = "
        f"{time_range(*e.case)} per case; model build and reduction {seconds(tm.setup)}"
        f"{model_words(study, tm)}; one "
        f"thread here {tm.slowdown:.2g}x as slow as on an idle core now; "
        "calibrated on the shipped studies (bench estimate); assumes the compiled kernels "
        "already cached (the first run after an install compiles them: up to 50 s more); a "
        "fresh process adds 2-5 s of start-up (imports, the first figure); a "
        "curve with many more folds costs more")
    if tm.sectors:
        need, have = wheel_memory(tm)
        lines.append(
            f"  the mistuned wheel is not built to estimate it: its tuned sector was timed "
            f"and scaled to {tm.sectors} blades (residual x {WHEEL_RESIDUAL:g} N, the solve over "
            f"its ring of blades x {WHEEL_SOLVE:g} N the sector's dense one); its natural "
            f"frequencies counted as the tuned wheel's; its Jacobian and factors need at "
            f"least about {need / 1e9:.2g} GB")
        if need > 0.8 * have:
            lines.append(f"warning: the wheel's Jacobian and factors (about {need / 1e9:.2g} GB) "
                         f"exceed this machine's memory ({have / 1e9:.2g} GB): the run would "
                         "be stopped for memory; fewer contact pairs, harmonics or blades")
    if e.modes == 0:
        fr = study.sweep.frequency
        lines.append(f"warning: no natural frequency (contacts open or stuck) lies in "
                     f"{fr.start:g}-{fr.stop:g} {fr.unit}: the curves may hold no resonant "
                     "peak (is the range's unit the one meant?)")
    return lines


def model_words(study, tm) -> str:
    """What `cost.model_work` adds, in words: the further reductions and the static
    contact solutions (empty without either)."""
    r = further_reductions(study)
    return ((f", + {r} further reduction(s) (speeds, the dataset's at rest), "
             f"{tm.reduction:.2g} s each" if r and tm.reduction else "")
            + (f", + the static contact solution of each case ({tm.static * 1e3:.3g} ms, "
               "interference)" if tm.static else ""))


def estimate(study: Study, workers: int = 1):
    """`cost.estimate` of a response study (what `check` prints)."""
    return cost_estimate(study, workers)


def n_cases(study: Study) -> int:
    return len(study.sweep.cases())


def keep_older_dataset(target: Path):
    """A dataset at `target` written by another pipeline version (or not readable as
    ours) is renamed, never overwritten: `<name>.v<version>.nc` / `<name>.unreadable.nc`."""
    if not target.exists():
        return None
    try:
        # deferred: xarray (slow import), only when a study runs
        import xarray as xr
        with xr.open_dataset(target, engine="netcdf4") as old:
            version = str(old.attrs.get("pipeline_version", "unknown"))
    except Exception:
        version = None
    if version == __version__:
        return None
    tag = f"v{version}" if version is not None else "unreadable"
    backup = target.with_name(f"{target.stem}.{tag}{target.suffix}")
    n = 1
    while backup.exists():
        n += 1
        backup = target.with_name(f"{target.stem}.{tag}.{n}{target.suffix}")
    target.rename(backup)
    log.warning("%s was written by %s; kept it as %s", target,
                f"pipeline {version}" if version else "something else (not readable as netCDF)",
                backup.name)
    return backup


def run_response_study(study: Study, out_dir="results", *, workers: int = 1,
                       scheduler: str | None = None, solver=None, figures: bool = True,
                       progress: bool = True, checkpoints: bool = True) -> StudyResult:
    """Run every case of `study`, write `out_dir/<name>.nc` and the figures.

    With `checkpoints`, each finished case is kept in `checkpoint_dir` as soon as
    it ends; a rerun after an interruption computes only the missing cases, and
    the directory is removed once the dataset is written."""
    # deferred: xarray (slow import), only when a study runs
    from ..datasets.response_dataset import to_dataset
    from ..datasets.dataset import write_netcdf

    check_python_study(study)   # a study built in Python meets its file's rules
    t0 = time.perf_counter()
    solver = solver or default_solver(study)
    out_dir = Path(out_dir)
    log.info("%s: %d case(s) %s, H = %d, %s forces%s", study.name, len(study.sweep.cases()),
             dict(zip(study.sweep.axes, study.sweep.shape)), study.solver.harmonics,
             study.solver.force_evaluation, " (quick)" if study.quick else "")
    fresh_out = not out_dir.exists()
    cdir = checkpoint_dir(study, out_dir, solver) if checkpoints else None
    if cdir is not None:
        remove_stale(out_dir, study.name, cdir)
    grid = {}   # the optimum search's grid, run beside the cases on the same workers
    if (workers > 1 or scheduler) and getattr(solver, "__module__", "") == \
            "pipeline.solve.response.response":
        grid = {("grid", n0): grid_job(study, n0) for n0 in planned_grid(study, cdir)}
    results, reused, early = execute_cases(study, solver, workers, scheduler, progress, cdir,
                                           grid)
    curves = [c for c, _ in results]
    errors = [e for _, e in results]
    failures = sum(c is None for c in curves)
    optimum, optimum_error = study_optimum(study, solver, curves, cdir, workers, scheduler,
                                           {k[1]: r for k, r in early.items()})
    tuned = None
    if getattr(study.scene, "mistuning", None) is not None and int(sum(
            c is not None for c in curves)):   # the tuned disk the mistuning is read against
        tuned = tuned_references(study, sector_output_dofs(study), solver)
    ds = to_dataset(study, curves, errors, optimum=optimum, tuned=tuned)
    res = StudyResult(study=study, dataset=ds, path=None, failures=failures,
                      reused=reused, computed=len(curves) - reused, optimum_error=optimum_error,
                      failed=[(case, err) for (_, case), c, err in zip(study.sweep.cases(), curves,
                                                                       errors) if c is None])
    if int(ds["converged"].sum()) == 0:
        log.error("%s: no converged point in any case; nothing written", study.name)
        if cdir is not None:  # nothing worth resuming
            shutil.rmtree(cdir, ignore_errors=True)
            if fresh_out and out_dir.is_dir() and not any(out_dir.iterdir()):
                out_dir.rmdir()
        res.wall_time = time.perf_counter() - t0
        return res
    target = out_dir / f"{study.name}.nc"
    keep_older_dataset(target)
    res.path = write_netcdf(ds, target)
    log.info("wrote %s", res.path)
    if cdir is not None and failures == 0:
        shutil.rmtree(cdir, ignore_errors=True)
    elif cdir is not None:
        log.info("%s: %d case(s) failed; the finished ones stay in %s, a rerun retries "
                 "only the failed ones", study.name, failures, cdir)
    if figures:
        res.figures = (write_figures(study, ds, out_dir / study.name, tuned)
                       + write_peak_shapes(study, ds, curves, out_dir / study.name))
        if optimum is not None:   # the peak-versus-preload curve the optimum was found on
            res.figures.append(optimum_figure_of(study, optimum, out_dir / study.name))
        for p in res.figures:
            log.info("wrote %s", p)
    res.wall_time = time.perf_counter() - t0
    return res


KIND = StudyKind(name="response", word="response", fits=always, by_default=always,
                 parse=parse, describe=describe, estimate=estimate, run=run_response_study,
                 cases=n_cases, optimum=True)
