"""Run a study: grid of sweep cases -> response curves -> dataset -> figures.

    python -m pipeline run STUDY.toml [--out DIR] [--workers N] [--scheduler ADDRESS] [--quick]

Each grid case (one combination of the `[sweep]` axes) is one frequency
continuation `pipeline.response.frequency_response(system, H, omega_start,
omega_stop, **solver.kwargs())`.  Cases run in this process (`--workers 1`), a
process pool (`--workers N`) or on a Dask cluster (`--scheduler ADDRESS`).  The
dataset `DIR/<name>.nc` is written atomically after all cases finished, then the
figures under `DIR/<name>/`.  A case that raises is logged and kept as an empty
branch; the run then exits 1 (the dataset of the other cases is still written).
"""
from __future__ import annotations

import logging
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import UsageError
from .scene import Study, load_study

log = logging.getLogger("pipeline.study")


def default_solver():
    """`pipeline.response.frequency_response` (looked up at call time)."""
    from . import response

    fn = getattr(response, "frequency_response", None)
    if fn is None:
        raise RuntimeError("pipeline.response.frequency_response is not available yet")
    return fn


def run_case(solver, system, H, omega_start, omega_stop, kwargs):
    """One continuation; returns (ResponseCurve or None, error text or None)."""
    try:
        return solver(system, H, omega_start, omega_stop, **kwargs), None
    except Exception as exc:  # numerical failures of one case must not lose the others
        logging.getLogger(__name__).exception("case failed")
        return None, f"{type(exc).__name__}: {exc}"


@dataclass
class StudyResult:
    study: Study
    dataset: object                 # xarray.Dataset
    path: Path | None               # the netCDF file (None if nothing converged)
    figures: list = field(default_factory=list)
    failures: int = 0               # cases that raised
    wall_time: float = 0.0          # [s]

    @property
    def ok(self) -> bool:
        return self.path is not None and self.failures == 0


class _Progress:
    """tqdm when it is installed, otherwise one log line per finished case."""

    def __init__(self, total, desc):
        self.total, self.desc, self.done = total, desc, 0
        try:
            from tqdm.auto import tqdm
            self.bar = tqdm(total=total, desc=desc, unit="case", disable=None, file=sys.stderr)
        except ImportError:
            self.bar = None

    def update(self, case, curve, err):
        self.done += 1
        what = (f"failed ({err})" if curve is None else
                f"{curve.n_points} points, {int(np.sum(curve.converged))} converged, "
                f"{curve.wall_time:.2f} s")
        if self.bar is not None and not self.bar.disable:
            self.bar.update(1)
            log.debug("case %s: %s", case, what)
        else:
            log.info("%s: case %d/%d %s: %s", self.desc, self.done, self.total, case, what)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _execute(study, solver, workers, scheduler, progress):
    cases = study.sweep.cases()
    H, fr, kw = study.solver.harmonics, study.sweep.frequency, study.solver.kwargs()
    if study.scene.model != "lumped":  # FE scenes: exact peaks of the reported DOFs only
        kw["peak_dofs"] = [study.scene.dof_index(d) for d in study.output.dofs]
    jobs = [(solver, study.system(case), H, fr.omega_start, fr.omega_stop, kw) for _, case in cases]
    results = [None] * len(jobs)
    bar = _Progress(len(jobs), study.name) if progress else None

    def done(k, res):
        results[k] = res
        if bar is not None:
            bar.update(cases[k][1], *res)

    try:
        if scheduler:
            from dask.distributed import Client, as_completed

            with Client(scheduler) as client:
                futs = [client.submit(run_case, *job, pure=False) for job in jobs]
                index = {f.key: k for k, f in enumerate(futs)}
                for fut in as_completed(futs):
                    done(index[fut.key], fut.result())
        elif workers > 1 and len(jobs) > 1:
            from concurrent.futures import ProcessPoolExecutor, as_completed

            with ProcessPoolExecutor(max_workers=min(workers, len(jobs))) as pool:
                futs = {pool.submit(run_case, *job): k for k, job in enumerate(jobs)}
                for fut in as_completed(futs):
                    done(futs[fut], fut.result())
        else:
            for k, job in enumerate(jobs):
                done(k, run_case(*job))
    finally:
        if bar is not None:
            bar.close()
    return results


def find_optimum(study: Study) -> dict:
    """The preload that minimises the resonant peak (`response.optimum_preload`):
    bounded Brent on log(n0) over the exact peak of each frequency response; the
    other sweep axes keep the scene's own values."""
    from .response import optimum_preload

    o, sv = study.output.optimum, study.solver
    window = o["window"] or study.sweep.frequency
    dof = study.scene.dofs.index(o["dof"])
    kw = {k: v for k, v in sv.kwargs().items() if k not in ("stability",)}
    t0 = time.perf_counter()
    res = optimum_preload(lambda n0: study.system({"preload": n0}), sv.harmonics,
                          window.omega_start, window.omega_stop, dof, o["bounds"],
                          rtol=o["rtol"], **kw)
    res["wall_time"] = time.perf_counter() - t0
    log.info("%s: optimum preload %.4g N (peak %.4g m at %.4g rad/s), %d evaluations, %.1f s",
             study.name, res["preload"], res["peak"], res["peak_omega"],
             len(res["evaluations"]), res["wall_time"])
    return res


def run_study(study: Study, out_dir="results", *, workers: int = 1, scheduler: str | None = None,
              solver=None, figures: bool = True, progress: bool = True) -> StudyResult:
    """Run every case of `study`, write `out_dir/<name>.nc` and the figures."""
    from .dataset import to_dataset, write_netcdf

    if getattr(study, "kind", "response") == "modes":  # blade modal study (blade_scene.py)
        from .blade_scene import run_modes_study
        return run_modes_study(study, out_dir, figures=figures)
    if getattr(study, "kind", "response") == "accuracy_cost":  # pipeline/accuracy_cost.py
        from .accuracy_cost import run_accuracy_study
        return run_accuracy_study(study, out_dir, figures=figures, progress=progress)
    t0 = time.perf_counter()
    solver = solver or default_solver()
    out_dir = Path(out_dir)
    log.info("%s: %d case(s) %s, H = %d, %s forces%s", study.name, len(study.sweep.cases()),
             dict(zip(study.sweep.axes, study.sweep.shape)), study.solver.harmonics,
             study.solver.force_evaluation, " (quick)" if study.quick else "")
    results = _execute(study, solver, workers, scheduler, progress)
    curves = [c for c, _ in results]
    errors = [e for _, e in results]
    failures = sum(c is None for c in curves)
    optimum = find_optimum(study) if study.output.optimum is not None else None
    ds = to_dataset(study, curves, errors, optimum=optimum)
    res = StudyResult(study=study, dataset=ds, path=None, failures=failures)
    if int(ds["converged"].sum()) == 0:
        log.error("%s: no converged point in any case; nothing written", study.name)
        res.wall_time = time.perf_counter() - t0
        return res
    res.path = write_netcdf(ds, out_dir / f"{study.name}.nc")
    log.info("wrote %s", res.path)
    if figures:
        res.figures = write_figures(study, ds, out_dir / study.name)
        for p in res.figures:
            log.info("wrote %s", p)
    res.wall_time = time.perf_counter() - t0
    return res


def write_figures(study: Study, ds, fig_dir) -> list:
    """Amplitude-frequency figures (one per response DOF and per combination of
    the non-curve sweep axes); one curve per value of `preload` (or the first axis)."""
    from .plots import response_curves_figure

    if "amplitude" not in study.output.figures:
        return []
    axes = list(study.sweep.axes)
    curve_axis = "preload" if "preload" in axes else (axes[0] if axes else None)
    other = [a for a in axes if a != curve_axis]
    unit = ds["frequency"].attrs["units"]
    paths = []
    import itertools

    for combo in itertools.product(*(range(len(study.sweep.axes[a])) for a in other)):
        sel = dict(zip(other, combo))
        sub = ds.isel(sel)
        suffix = "".join(f"_{a}={study.sweep.axes[a][i]:g}" for a, i in sel.items())
        for dof in study.output.dofs:
            d = sub.sel(dof=dof)
            branches = []
            for j in range(ds.sizes[curve_axis] if curve_axis else 1):
                b = d.isel({curve_axis: j}) if curve_axis else d
                label = (f"{curve_axis} = {float(b[curve_axis]):g} {ds[curve_axis].attrs['units']}"
                         if curve_axis else study.name)
                branches.append((label, b["frequency"].values, b["amplitude"].values,
                                 b["stable"].values, b["converged"].values))
            title = study.title + "".join(f", {a} = {study.sweep.axes[a][i]:g}" for a, i in sel.items())
            paths.append(response_curves_figure(
                Path(fig_dir) / f"amplitude_{dof}{suffix}.png", branches,
                xlabel=f"excitation frequency [{unit}]", ylabel=f"amplitude of {dof} [m]",
                title=title, yscale=study.output.yscale))
    return paths


# ---------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------

def add_run_parser(subparsers):
    """Register `run` on the CLI's subparsers (`pipeline/__main__.py`)."""
    r = subparsers.add_parser("run", help="run a study file: dataset (netCDF) and figures")
    configure_run_parser(r)
    return r


def configure_run_parser(r):
    r.add_argument("study", metavar="STUDY.toml", help="study file (see README: Study files)")
    r.add_argument("--out", default="results", metavar="DIR",
                   help="output directory: DIR/<name>.nc and DIR/<name>/*.png (default: results)")
    r.add_argument("--workers", type=int, default=1, metavar="N",
                   help="local worker processes (default 1: run in this process)")
    r.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address, e.g. tcp://host:8786 (overrides --workers)")
    r.add_argument("--quick", action="store_true",
                   help="use the study's [quick] overrides (fewer cases, fewer harmonics)")
    r.add_argument("--no-figures", dest="figures", action="store_false", help="skip the figures")
    r.set_defaults(func=cmd_run)


def cmd_run(args) -> int:
    """`python -m pipeline run`: 0 ok, 1 a case failed or nothing converged, 2 bad input."""
    try:
        study = load_study(args.study, quick=getattr(args, "quick", False))
        workers = getattr(args, "workers", 1)
        if workers is None or workers < 1:
            raise UsageError(f"{args.study}: --workers: must be >= 1, got {workers}")
        out = Path(getattr(args, "out", "results"))
        if out.exists() and not out.is_dir():
            raise UsageError(f"{args.study}: --out: {out} exists and is not a directory")
        scheduler = getattr(args, "scheduler", None)
        if scheduler:
            try:
                import dask.distributed  # noqa: F401
            except ImportError:
                raise UsageError(f"{args.study}: --scheduler: dask.distributed is not installed "
                                 "(pip install 'dask[distributed]')") from None
    except UsageError as exc:
        # printed here too so the one-line contract holds however `run` is wired
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        solver = default_solver()
    except RuntimeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    try:
        res = run_study(study, out, workers=workers, scheduler=scheduler, solver=solver,
                        figures=getattr(args, "figures", True))
    except OSError as exc:
        print(f"error: {args.study}: --out: cannot write: {exc}", file=sys.stderr)
        return 1
    log.info("%s: done in %.1f s", study.name, res.wall_time)
    return 0 if res.ok else 1


def main(argv=None) -> int:
    """`python -m pipeline.study STUDY.toml ...` (same as `python -m pipeline run`)."""
    import argparse

    p = argparse.ArgumentParser(prog="python -m pipeline.study", description=__doc__.splitlines()[0])
    p.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    configure_run_parser(p)
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return cmd_run(args)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
