"""Nonlinear modes of a scene with friction contacts: `[study] kind = "nonlinear_modes"`.

For each case (preload, contact parameters; on a disk each nodal diameter) the
nonlinear mode of one family is continued in its modal amplitude by the extended
periodic motion concept (`solve.nonlinear_modes`): frequency and modal damping ratio
from the stuck linear mode through microslip, macroslip and separation towards the
open one.  From each backbone the forced response to the scene's excitation is
synthesised for every force scale asked (milliseconds each), and with `compare` the
full harmonic balance of the same case is run over the `[sweep] frequency` range, so
the dataset shows what the single-mode synthesis gains and what it misses.

    [study] kind = "nonlinear_modes"
    [modes] mode = 0                  the family: 0 is the lowest linear mode (per ND)
            amplitude = [0.01, 1000]  modal amplitudes, in multiples of the slip onset
            nodal_diameters = [...]   disk scenes: one mode per ND (EO = ND excites it)
            force_scales = [1.0]      synthesis: factors on the scene's excitation
            compare = true            also the full harmonic balance (force scale 1);
                                      on a disk also a list of nodal diameters
            reference_dof = "x1"      its velocity vanishes at t = 0 (the phase
                                      condition; default: the DOF with the largest
                                      share of the linear mode's kinetic energy)

The rest is a response study's file (`[scene]`, `[sweep]` with its frequency range
and grid axes but `eo`, `[solver]`, `[output]`).  Each backbone starts from the
unilateral static state (`epmc.static_start`: an element that would pull is open, the
others closed and stuck); the slip onset is the smallest modal amplitude at which a
closed element of the linear mode would slip (mu s / (ku |u|)) or lift off
(s / (kv |v|)), s its static normal load, u, v its relative motions per unit modal
amplitude.
"""
from __future__ import annotations

import logging
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...solve.nonlinear_modes.backbone import continue_mode, damping_peak
from ...solve.nonlinear_modes.epmc import mode_problem, onset_amplitude
from ...solve.nonlinear_modes.epmc import linear_guess, residual
from ...solve.nonlinear_modes.synthesis import refiner, synthesise
from ...errors import interrupt_in_chain
from . import response_study
from .cases import default_solver
from .cases import compile_kernels, map_jobs
from .checkpoint import remove_stale
from .kind_costs import RangeEstimate, estimate_lines
from ..files.header import overlay
from ..files.study_types import StudyHeader, StudyKind, Study, StudyResult, always, never
from ..files.validation import Checker
from .disk_modes_study import is_disk_document

log = logging.getLogger(__name__)
KEYS = ("mode", "amplitude", "nodal_diameters", "force_scales", "compare", "reference_dof")
DEFAULT_AMPLITUDE = (0.01, 1000.0)
MAX_MODE = 1000


@dataclass(frozen=True)
class NonlinearModesStudy(StudyHeader):
    """A response study's scene, sweep, solver and output, and the modes asked."""

    response: Study
    mode: int = 0
    amplitude: tuple = DEFAULT_AMPLITUDE
    nodal_diameters: tuple = ()     # () for a scene that is not a disk
    reference_dof: str | None = None   # phase condition's DOF (None: largest kinetic share)
    force_scales: tuple = (1.0,)
    compare: bool | tuple = True    # or the nodal diameters to compare
    quick: bool = False
    kind: str = "nonlinear_modes"

    @property
    def scene(self):
        return self.response.scene

    def cases(self) -> list:
        """[(index tuple, case dict)] of the sweep's grid; on a disk its `eo` axis holds
        the nodal diameters (EO = ND excites the travelling wave of ND)."""
        return self.response.sweep.cases()


def parse(data: dict, *, file: str = "<study>", name: str = "study", text: str = "",
          quick: bool = False) -> NonlinearModesStudy:
    """Validate a nonlinear modes document: its response part by the response parser,
    `[modes]` (and `[quick.modes]`) here; every mistake `<file>: <field>: <what>`."""
    ck = Checker(file)
    modes_tbl = ck.table(data.get("modes", {}), "modes", required=False)
    q = ck.table(data.get("quick", {}), "quick", required=False)
    quick_modes = ck.table(q.get("modes", {}), "quick.modes", required=False) if quick else {}
    modes, where = overlay(ck, modes_tbl, quick_modes, "modes")
    ck.keys(modes, "modes", KEYS)
    effects = (data.get("scene") or {}).get("effects", []) if isinstance(data.get("scene"),
                                                                        dict) else []
    if not (isinstance(effects, list) and {"friction", "separation"} & set(map(str, effects))):
        ck.fail("scene.effects", "a nonlinear modes study needs contacts that slip or "
                                 "separate: declare \"friction\" (or \"separation\") and give a "
                                 "[[scene.contact]]")
    sweep = ck.table(data.get("sweep", {}), "sweep", required=False)
    for axis in ("eo", "excitation_scale", "mistuning_seed"):
        if axis in sweep or axis in ck.table(q.get("sweep", {}), "quick.sweep", required=False):
            ck.fail(f"sweep.{axis}", "not an axis of a nonlinear modes study (nodal diameters: "
                                     "[modes] nodal_diameters; force levels: [modes] force_scales)")
    nds, disk = (), is_disk_document(data)
    if disk and "nodal_diameters" not in modes:
        ck.fail("modes.nodal_diameters", "missing: a disk scene needs the nodal diameters "
                                         "of its modes, e.g. nodal_diameters = [0, 3]")
    if not disk and "nodal_diameters" in modes:
        ck.fail(where("nodal_diameters"), "only a disk scene has nodal diameters")
    if disk:   # the response part sweeps them as its engine orders
        nds = tuple(ck.integer(v, where(f"nodal_diameters[{i}]"), 0, MAX_MODE) for i, v in
                    enumerate(ck.array(modes["nodal_diameters"], where("nodal_diameters"))))
        if len(set(nds)) != len(nds):
            ck.fail(where("nodal_diameters"), "a nodal diameter is listed twice")
        N = (data["scene"].get("disk") or {}).get("sectors")
        if isinstance(N, int) and max(nds) > N // 2:
            ck.fail(where("nodal_diameters"), f"a nodal diameter of {N} sectors is 0 ... "
                                              f"{N // 2}, got {max(nds)}")
        sweep = {**sweep, "eo": list(nds)}
    rest = {**data, "sweep": sweep}      # the response part: without [modes]
    rest.pop("modes", None)
    if "quick" in rest:
        rest["quick"] = dict(q)
        rest["quick"].pop("modes", None)
        if nds and "sweep" in rest["quick"]:
            rest["quick"]["sweep"] = {**rest["quick"]["sweep"], "eo": list(nds)}
    resp = response_study.parse(rest, file=file, name=name, text=text, quick=quick)
    sc = resp.scene
    if getattr(sc, "mistuning", None) is not None:
        ck.fail("scene.disk.mistuning", "nonlinear modes per nodal diameter need a tuned disk")
    amp = tuple(ck.number(v, where(f"amplitude[{i}]"), gt=0.0)
                for i, v in enumerate(ck.array(modes.get("amplitude", list(DEFAULT_AMPLITUDE)),
                                               where("amplitude"))))
    if len(amp) != 2 or not amp[0] < amp[1]:
        ck.fail(where("amplitude"), "give [lowest, highest] with lowest < highest (multiples "
                                    "of the slip-onset modal amplitude)")
    scales = tuple(ck.number(v, where(f"force_scales[{i}]"), gt=0.0)
                   for i, v in enumerate(ck.array(modes.get("force_scales", [1.0]),
                                                  where("force_scales"))))
    compare = modes.get("compare", True)
    if isinstance(compare, list) and nds:     # only these nodal diameters
        compare = tuple(ck.integer(v, where(f"compare[{i}]"), 0, MAX_MODE)
                        for i, v in enumerate(compare))
        if not set(compare) <= set(nds):
            ck.fail(where("compare"), "compare only nodal diameters the study computes "
                                      f"({', '.join(map(str, nds))})")
    elif not isinstance(compare, bool):
        ck.fail(where("compare"), "must be true, false or (disk scenes) a list of nodal "
                                  f"diameters, got {compare!r}")
    mode = ck.integer(modes.get("mode", 0), where("mode"), 0, MAX_MODE)
    ref = modes.get("reference_dof")
    if ref is not None and ref not in sc.dofs:
        ck.fail(where("reference_dof"), f"{ref!r} is not a DOF of the scene (its DOFs: "
                                        f"{', '.join(sc.dofs[:8])}{', ...' if len(sc.dofs) > 8 else ''})")
    return NonlinearModesStudy(file=file, name=name, title=resp.title,
                               description=resp.description, reference=resp.reference,
                               text=text, response=resp, mode=mode, amplitude=amp,
                               nodal_diameters=nds, force_scales=scales, compare=compare,
                               reference_dof=ref,
                               quick=bool(quick))


def run_case(study: NonlinearModesStudy, case: dict) -> dict:
    """`case_result`, or for a case that raises {"case", "error"}: a failing case is
    recorded as failed (`datasets.nonlinear_modes_dataset.case_status`), never the end of the
    others."""
    try:
        return case_result(study, case)
    except Exception as exc:  # numerical failures of one case must not lose the others
        if interrupt_in_chain(exc):
            raise
        log.exception("case %s failed", case)
        return {"case": case, "error": f"{type(exc).__name__}: {exc}"}


def case_problem(study: NonlinearModesStudy, system):
    """(mode problem, slip-onset modal amplitude) of a case's system."""
    sv = study.response.solver
    ref = (None if study.reference_dof is None
           else list(system.dof_names).index(study.reference_dof))
    mp = mode_problem(system, sv.harmonics, study.mode, sv.force_evaluation, sv.samples, ref)
    a_on, st = onset_amplitude(mp), mp.static
    log.info("the mode starts from the unilateral static state: %d of %d element(s) closed and "
             "stuck, %d open; linear frequency %.6g Hz, slip onset %.4g kg^0.5 m",
             int(st.closed.sum()), st.closed.size, int((~st.closed).sum()),
             mp.omega0 / (2 * np.pi), a_on)
    return mp, a_on


def case_result(study: NonlinearModesStudy, case: dict) -> dict:
    """Backbone, synthesis per force scale and (compare) the full response of one case."""
    sv, resp = study.response.solver, study.response
    system = resp.system(case)
    t0 = time.perf_counter()
    mp, a_on = case_problem(study, system)
    # a mode that moves no preloaded contact (ND 0 of shrouds whose neighbours move
    # alike) is linear: its backbone is drawn over the range of a unit modal amplitude
    lo, hi = (np.log10((a_on if np.isfinite(a_on) else 1.0) * f) for f in study.amplitude)
    bb = continue_mode(mp, lo, hi, tol_rel=sv.tolerance)
    peak = damping_peak(mp, bb, sv.tolerance)
    out = {"case": case, "backbone": bb, "onset": a_on, "problem": mp,
           "time": time.perf_counter() - t0, "damping_peak": peak}
    add_synthesis(study, system, out)
    out["curve"] = None
    if study.compare is True or (study.compare and case.get("eo") in study.compare):
        fr = resp.sweep.frequency
        t1 = time.perf_counter()
        kw = sv.kwargs()
        kw["stability"] = False
        kw["peak_dofs"] = [list(system.dof_names).index(d) for d in resp.output.dofs]
        try:   # the backbone is kept whatever the comparison does
            out["curve"] = default_solver(resp)(
                system, sv.harmonics, fr.omega_start, fr.omega_stop, **kw)
        except Exception as exc:  # noqa: BLE001 -- recorded in the case's message
            if interrupt_in_chain(exc):
                raise
            log.exception("case %s: the full harmonic balance failed", case)
            out["compare_error"] = f"{type(exc).__name__}: {exc}"
        out["curve_time"] = time.perf_counter() - t1
    return out


def add_synthesis(study: NonlinearModesStudy, system, out: dict):
    """The synthesised response of `out`'s backbone per force scale (and its times)."""
    bb, mp, tol = out["backbone"], out["problem"], study.response.solver.tolerance
    out["synthesis"], out["synthesis_time"] = [], []
    F1 = np.asarray(system.forcing, complex)[:, 1] if system.forcing.shape[1] > 1 else None
    for f in study.force_scales:
        t1 = time.perf_counter()
        syn = None if F1 is None or bb.s.size < 2 else synthesise(
            bb, mp.M, mp.C, f * F1, refine=refiner(mp, bb, tol))
        out["synthesis"].append(syn)
        out["synthesis_time"].append(time.perf_counter() - t1)


def resumed_case(study: NonlinearModesStudy, case: dict, kept, curve) -> dict:
    """The result of a case kept by an interrupted run (`nonlinear_modes_checkpoint`):
    its backbone, times, damping peak and compared curve as kept, its mode problem and
    synthesis from the same system and backbone."""
    system = study.response.system(case)
    mp, a_on = case_problem(study, system)
    out = {"case": case, "backbone": kept.backbone(), "onset": a_on, "problem": mp,
           "time": kept.time, "damping_peak": tuple(kept.damping_peak), "curve": curve,
           "curve_time": kept.curve_time}
    if kept.compare_error:
        out["compare_error"] = kept.compare_error
    add_synthesis(study, system, out)
    return out


def run(study: NonlinearModesStudy, out_dir="results", *, figures: bool = True,
        workers: int = 1, checkpoints: bool = True, **_) -> StudyResult:
    """`out_dir/<name>.nc` and the figures `out_dir/<name>/backbones.png`,
    `synthesis_<dof>.png`; the cases on `workers` processes.  With `checkpoints` each
    finished case is kept at once (`nonlinear_modes_checkpoint`), a rerun computes only
    the missing ones, and the folder is removed once the dataset is written with no
    failed case."""
    # deferred: xarray and matplotlib (slow imports), only when the study runs
    from ..datasets.dataset import write_netcdf
    from .nonlinear_modes_checkpoint import load_kept, modes_checkpoint_dir, save_kept
    from ..datasets.nonlinear_modes_dataset import case_status, modes_dataset
    from ..figures.backbone_figures import write_backbone_figures

    t0 = time.perf_counter()
    cases = [c for _, c in study.cases()]
    cdir = modes_checkpoint_dir(study, out_dir) if checkpoints else None
    if cdir is not None:
        remove_stale(Path(out_dir), study.name, cdir)
    kept = load_kept(cdir, cases) if cdir is not None else {}
    results = [resumed_case(study, cases[k], *kept[k]) if k in kept else None
               for k in range(len(cases))]
    if kept:
        log.info("%s: resuming: %d of %d case(s) finished earlier (kept in %s)", study.name,
                 len(kept), len(cases), cdir)

    def done(k, res):
        results[k] = res
        bb, n_done = res.get("backbone"), sum(r is not None for r in results)
        if bb is None or not bb.s.size:
            log.error("case %d/%d %s: %s", n_done, len(cases), cases[k], case_status(res)[1])
            return
        if cdir is not None:
            save_kept(cdir, k, cases[k], res)
        log.info("case %d/%d %s: %d points, %.4g to %.4g Hz, zeta up to %.3g, %.2f s%s",
                 n_done, len(cases), cases[k], bb.s.size, *(bb.omega[[0, -1]] / (2 * np.pi)),
                 np.max(bb.zeta), res["time"], f" ({bb.message})" if bb.message else "")

    todo = [k for k in range(len(cases)) if k not in kept]
    if workers > 1 and len(todo) > 1:
        compile_kernels(study.response, cases[todo[0]], study.response.solver.force_evaluation,
                        workers)
    map_jobs(run_case, todo, lambda k: (study, cases[k]), done, workers)
    states = [(r["case"], *case_status(r)) for r in results]
    failed = [(case, msg) for case, status, msg in states if status < 0]
    ds = modes_dataset(study, results)
    res = StudyResult(study=study, dataset=ds, path=None, failures=len(failed), failed=failed,
                      stopped=[(case, msg) for case, status, msg in states if status > 0],
                      reused=len(kept), computed=len(cases) - len(kept))
    if ds is None:
        log.error("%s: no converged backbone point in any case; nothing written", study.name)
    else:
        res.path = write_netcdf(ds, Path(out_dir) / f"{study.name}.nc")
        log.info("wrote %s", res.path)
        res.figures = write_backbone_figures(Path(out_dir) / study.name, ds) if figures else []
    if cdir is not None and (ds is None or all(case_status(r)[0] >= 0 for r in results)):
        shutil.rmtree(cdir, ignore_errors=True)
    elif cdir is not None:
        log.info("%s: %d case(s) failed; the finished ones stay in %s, a rerun retries only "
                 "the failed ones", study.name, len(failed), cdir)
    res.wall_time = time.perf_counter() - t0
    return res


POINTS, ITERATIONS = 40, 4   # a backbone's points and Newton iterations a point (typical)


def estimate(study: NonlinearModesStudy, workers: int = 1) -> RangeEstimate:
    """One EPMC Jacobian timed now on the first case's model, times the points and
    iterations of a typical backbone, per case; plus the response estimate (compare)."""
    cases = study.cases()
    sv = study.response.solver
    mp = mode_problem(study.response.system(cases[0][1]), sv.harmonics, study.mode,
                      sv.force_evaluation, sv.samples)
    y = linear_guess(mp)
    residual(mp, y, 0.0)                       # the first call loads the compiled kernels
    t0 = time.perf_counter()
    R, J, _ = residual(mp, y, 0.0)
    np.linalg.solve(J, R)
    one = time.perf_counter() - t0
    mid = len(cases) * POINTS * ITERATIONS * one
    detail = f"{len(cases)} backbone(s), one EPMC step timed now ({one * 1e3:.1f} ms)"
    if study.compare:
        e = response_study.estimate(study.response, workers)
        share = (1.0 if study.compare is True
                 else len(study.compare) / max(1, len(study.nodal_diameters)))
        mid += e.mid * share
        detail += f"; the full harmonic balance of the cases compared {e.mid * share:.3g} s"
    return RangeEstimate(mid / 3.0, mid * 3.0, detail)


def describe(study: NonlinearModesStudy, workers: int = 1) -> list:
    sc = study.scene
    nd = (f"; nodal diameters {', '.join(map(str, study.nodal_diameters))}"
          if study.nodal_diameters else "")
    return ([f"scene: {sc.model}, {len(sc.contacts)} contact(s); nonlinear mode {study.mode}"
             f"{nd}; amplitude {study.amplitude[0]:g} to {study.amplitude[1]:g} x slip onset",
             f"cases: {len(study.cases())}; synthesis at force scales "
             f"{', '.join(f'{f:g}' for f in study.force_scales)}"
             + ("; full harmonic balance compared" + (
                "" if study.compare is True else f" at ND {', '.join(map(str, study.compare))}")
               if study.compare else "")]
            + estimate_lines(estimate(study, workers)))


KIND = StudyKind(name="nonlinear_modes", word="nonlinear_modes", fits=always, by_default=never,
                 parse=parse, describe=describe, estimate=estimate, run=run,
                 cases=lambda study: len(study.cases()))
