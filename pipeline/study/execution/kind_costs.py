"""What a modes, disk-modes or accuracy-cost study will cost (`shroud check`), from the
model it builds: the response studies' estimate is `cost`, these use its timings.

    modes        the full FE model's eigen-solve dominates: t = MODES_RATE N^1.57 + MODES_FIXED
                 (N free DOFs of the mesh, `structure.mesh_size`; MODES_FIXED the dataset,
                 figure and mode shapes' VTU), calibrated on the shipped blade study: 0.31 s at N = 1458,
                 8.3 s at N = 11934 on an idle core;
    disk_modes   the sector model built and one eigen-solve timed now, times the 2 x (nodal
                 diameters) solves (contacts open and stuck), + FIXED;
    campbell     a disk modes study with speeds (`study.execution.campbell_study`): a reduction
                 (Craig-Bampton at that speed) and the eigen-solves of every nodal
                 diameter and contact state at each speed, and Brent's evaluations of
                 each engine-order crossing (a reduction and one eigen-solve each):

                     t = t_blade + (S + BRENT c) t_red + (S D Z + BRENT c) t_eig
                         + S t_static + FIXED,

                 S speeds, D nodal diameters, Z contact states (open, stuck, and static
                 with an interference), c crossings; t_blade, t_red (the sector at the
                 largest speed), t_eig (mean of the solves of the excited nodal diameters)
                 and t_static (the static contact solution, with an interference) timed
                 now; c counted now as the engine-order lines whose sign against a
                 family changes between the first and the last speed (the run brackets
                 on the whole grid: a family crossed twice is counted once, as the run
                 finds it);
    accuracy     each distinct run (settings) timed now on its own model as `cost`
                 times a response point, times its points (`cost.points_per_case`, more
                 below a continuation step of 0.1: (0.1 / max_step)^(1/3)), times the
                 case's timing repeats, + its model's build.

Each is a range of SPREAD about its middle, scaled like `cost` by the machine's
slowdown now.  `python -m pipeline bench estimate` measures them against the run.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ...model.cyclic import sector_system
from ...model.static_load import static_contact
from ...model.system import natural_frequencies
from ...structure.mesh_size import mesh_size
from .accuracy_measure import case_systems
from ..figures.nd_figure import excited_nodal_diameter
from .campbell_study import STATIC, frequencies_at, speed_sector, states
from .cost import (CALIBRATION_SLOWDOWN, OVERHEAD, modes_in_range, points_per_case, seconds,
                   slowdown, time_range, time_system_point, work_per_point)

MODES_RATE = 3.3e-6        # [s per N^1.57] the full eigen-solve of a blade's FE model
MODES_EXPONENT = 1.57
SPREAD = 2.0               # the range is middle / SPREAD ... middle x SPREAD
FIXED = 0.3                # [s] dataset and figure of a disk modal study (modules imported)
MODES_FIXED = 0.8          # [s] ... of a blade modal study, its mode shapes' VTU included
STEP_REF = 0.1             # continuation step whose curves `cost.POINTS` counts
BRENT = 4.5                # trial speeds of one crossing's Brent search, the grid's ends
#                            known: the Campbell study 42 for 11 crossings quick (3.8 each),
#                            51 for 12 in full (4.3)


@dataclass(frozen=True)
class RangeEstimate:
    """The cost of a study [s]: a range (lo, hi) and what it was made of, in words."""

    lo: float
    hi: float
    detail: str

    @property
    def mid(self) -> float:
        return math.sqrt(self.lo * self.hi)


def _spread(mid: float, detail: str) -> RangeEstimate:
    return RangeEstimate(mid / SPREAD, mid * SPREAD, detail)


def modes_estimate(study) -> RangeEstimate:
    """A blade modes study (module docstring)."""
    sc = study.scene
    n = mesh_size(sc.structure.params, sc.structure.disk).free_dofs
    f = slowdown()
    t = f * (MODES_RATE * n ** MODES_EXPONENT + MODES_FIXED)
    return _spread(t, f"the full model's eigen-solve on {n:,} DOFs (from the mesh "
                      f"parameters) and {len(study.mode_counts)} reductions")


def disk_modes_estimate(study) -> RangeEstimate:
    """A disk modes study (module docstring): the sector built and solved once now;
    with speeds, `campbell_estimate`."""
    if getattr(study, "speeds", ()):
        return campbell_estimate(study)
    # deferred: `check` of a lumped study builds no sector
    from ...model.build import sector

    sc = study.scene
    t0 = time.perf_counter()
    preset = all(getattr(c, "n0", None) is not None for c in sc.contacts)
    sec = sector(sc, None if preset else {"preload": 0.0})
    t1 = time.perf_counter()
    build = t1 - t0
    if getattr(sc.structure, "params", None) is not None:   # FE: as first built
        # deferred: FE blades only (scikit-fem, meshio)
        from ...model.blade_cache import reduced_model, timed_blade_model
        build += (timed_blade_model(sc.structure)[1]
                  + reduced_model(sc.structure, sc.reduction)[1])
    natural_frequencies(sector_system(sec, study.nodal_diameters[0]), "open")
    t_solve = time.perf_counter() - t1
    solves = 2 * len(study.nodal_diameters)
    t = build + solves * t_solve + slowdown() * FIXED
    return _spread(t, f"sector model {build:.2g} s, {solves} sector eigen-solves of "
                      f"{t_solve * 1e3:.3g} ms (timed now)")


def campbell_estimate(study) -> RangeEstimate:
    """A Campbell diagram (module docstring): its parts timed now, `campbell_cost`."""
    sc, speeds = study.scene, study.speeds
    N, nf = sc.assembly.sectors, study.n_frequencies
    t_blade = 0.0
    if getattr(sc.structure, "params", None) is not None:   # FE: as first built
        # deferred: FE blades only (scikit-fem, meshio)
        from ...model.blade_cache import timed_blade_model
        t_blade = timed_blade_model(sc.structure)[1]
    ends = (speeds[0], speeds[-1])
    secs = [speed_sector(sc, ends[0])]   # the blade built (t_blade), then reduced
    t1 = time.perf_counter()
    secs.append(speed_sector(sc, ends[1]))
    t_red = time.perf_counter() - t1
    nds = [nd for nd in dict.fromkeys(excited_nodal_diameter(eo, N) for eo in
                                      study.engine_orders) if nd in study.nodal_diameters]
    nds = nds or [study.nodal_diameters[0]]
    names = states(sc)
    t_static = 0.0
    if STATIC in names:
        t2 = time.perf_counter()
        static_contact(sector_system(secs[1], 0))
        t_static = time.perf_counter() - t2
    f, t_eig, solves = {}, 0.0, 0
    for i, (v, sec) in enumerate(zip(ends, secs)):
        for state in names:
            t2 = time.perf_counter()
            f[i, state] = frequencies_at(sc, v, nds, nf, state, sec)
            t_eig += time.perf_counter() - t2 - (t_static if state == STATIC else 0.0)
            solves += len(nds)
    crossings = 0
    for eo in study.engine_orders:
        nd = excited_nodal_diameter(eo, N)
        if nd in nds:
            j = nds.index(nd)
            for state in names:
                g = [f[i, state][j] - eo * v / 60.0 for i, v in enumerate(ends)]
                crossings += int(np.sum(np.sign(g[0]) * np.sign(g[1]) <= 0))
    t_eig = max(t_eig, 0.0) / solves
    t = campbell_cost(t_blade, t_red, t_eig, t_static, len(speeds),
                      len(study.nodal_diameters), len(names), crossings) + slowdown() * FIXED
    return _spread(t, f"{len(speeds)} speeds x (a reduction of {t_red:.2g} s + "
                      f"{len(study.nodal_diameters)} nodal diameters x {len(names)} contact "
                      f"states, eigen-solves of {t_eig * 1e3:.3g} ms"
                      + (f", the static contact solution {t_static * 1e3:.3g} ms" if t_static
                         else "") + f"), {crossings} engine-order crossing(s) x {BRENT:g} "
                      "trial speeds (timed now)")


def campbell_cost(t_blade: float, t_red: float, t_eig: float, t_static: float, speeds: int,
                  nodal_diameters: int, states: int, crossings: int) -> float:
    """t [s] of a Campbell diagram without FIXED (module docstring): the blade built
    once, each speed reduced and solved, each crossing's trial speeds."""
    trials = BRENT * crossings
    return (t_blade + (speeds + trials) * t_red + speeds * t_static
            + (speeds * nodal_diameters * states + trials) * t_eig)


def accuracy_estimate(study) -> RangeEstimate:
    """An accuracy-cost study (module docstring): every distinct run timed now."""
    f = slowdown() / CALIBRATION_SLOWDOWN
    lo = hi = 0.0
    runs = 0
    for case in study.cases:
        system_for = case_systems(case)
        fr = case.frequency
        om = math.sqrt(fr.omega_start * fr.omega_stop)
        for s in dict.fromkeys(st for _, _, st in case.runs()):
            system, _, model_time, _ = system_for(s)
            t_r, t_s, unknowns, sparse = time_system_point(
                system, s.harmonics, s.force_evaluation, s.samples, om, repeats=3)
            pairs, lus = work_per_point(unknowns, sparse)
            point = [c * t_r + k * t_s + f * (s0 + s1 * system.n_dof)
                     for c, k, s0, s1 in zip(pairs, lus, *OVERHEAD)]
            scale = max(1.0, (STEP_REF / s.max_step) ** (1 / 3))
            points = points_per_case(modes_in_range(system, fr), 100_000, scale)
            lo += case.repeats * points[0] * point[0] + model_time
            hi += case.repeats * points[1] * point[1] + model_time
            runs += 1
    return RangeEstimate(lo, hi, f"{runs} distinct runs, each timed now on its own model "
                                 "(one point) and counted as `check` counts a response case")


def estimate_lines(e: RangeEstimate) -> list:
    """The cost line `check` prints for a modes, disk-modes or accuracy-cost study."""
    return [f"estimated cost: {time_range(e.lo, e.hi)} (middle {seconds(e.mid)}): {e.detail}; "
            "calibrated on the shipped studies (bench estimate)"]
