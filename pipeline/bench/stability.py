"""What a trustworthy stability flag costs: `python -m pipeline bench stability`.

One frequency-response curve (dense output on, exact forces) per stability mode
(`solve.stability.branch_stability`) on paper Examples 1 and 3 and the 3-DOF shrouded blade,
each timed as this process's CPU time (single-threaded BLAS), with the points the
exact Floquet multipliers decided, the unstable points and the bifurcations.

Then the FE blade of `studies/blade_shroud_contact.toml` (its quick mesh, 208 DOFs:
beyond the shooting, `stability.methods.effective_mode`): its curve without
stability, and Hill's and the orbit monodromy's CPU time and largest multiplier at
sampled points of it (a whole curve with either takes many minutes); the curve times
of the modes follow from the per-point costs.
"""
from __future__ import annotations

import logging
import os
import time
from pathlib import Path

import numpy as np

from ..paper_systems import blade3, example1, example3
from ..solve.harmonic_balance import hbm
from ..solve.response.response import frequency_response
from ..solve.stability.orbit_floquet import along_orbit
from ..solve.stability.branch_stability import branch_stability
from ..solve.stability.methods import FLOQUET, KINDS, MONODROMY
from ..study.files.documents import load_study

CURVES = [("Example 1, n = 2 N, H = 7, 150-250 rad/s", lambda: example1(2.0), 7, 150.0, 250.0),
          ("Example 3, n0 = 10 N, H = 14, 0.5-1.6 rad/s", lambda: example3(10.0), 14, 0.5, 1.6),
          ("3-DOF shrouded blade, H = 10, 112-121 rad/s", blade3, 10, 112.0, 121.0)]
MODES = ("hill", "monodromy", "monodromy+check", "hill+check", "floquet")


def run(quick=False):
    print("Stability modes: one curve each, CPU time of this process "
          f"(load average {os.getloadavg()[0]:.1f})")
    print(f"{'curve':<44} {'stability':<16} {'points':>6} {'CPU s':>6} {'stab. s':>7} "
          f"{'by Floquet':>10} {'by monodromy':>12} {'unstable':>8}  bifurcations [rad/s]")
    modes = MODES[:3] if quick else MODES
    # the shooting's notes on slider rests are not this table's business
    logging.getLogger("pipeline.solve.time_integration.timesim").setLevel(logging.WARNING)
    for name, make, H, lo, hi in CURVES:
        system = make()
        frequency_response(system, H, lo, hi, stability="monodromy")   # warm-up
        for mode in modes:
            t = time.process_time()
            c = frequency_response(system, H, lo, hi, stability=mode)
            cpu = time.process_time() - t
            stab = sum(c.info.get(k, 0.0) for k in ("hill_time", "floquet_time", "monodromy_time"))
            bif = ", ".join(f"{p:.4g} {KINDS[int(k)]}" for p, k in
                            zip(c.bifurcation_parameter, c.bifurcation_kind)) or "-"
            print(f"{name:<44} {mode:<16} {c.n_points:>6} {cpu:6.2f} {stab:7.2f} "
                  f"{int(np.sum(c.stability_method == FLOQUET)):>10} "
                  f"{int(np.sum(c.stability_method == MONODROMY)):>12} "
                  f"{int(np.sum(~c.stable & c.converged)):>8}  {bif}")
            name = ""
    print("stab. s: the stability part of the CPU time (Hill, the orbit monodromy, Floquet); "
          "by Floquet / by monodromy: points\ndecided by each (the rest by Hill); "
          "bifurcations in branch order")
    fe_blade(3 if quick else 8)
    return 0


def fe_blade(samples: int):
    """Hill and the orbit monodromy at `samples` points of the quick FE blade's curve."""
    study = load_study(Path(__file__).resolve().parents[2] / "studies"
                       / "blade_shroud_contact.toml", quick=True)
    case = study.sweep.cases()[0][1]
    system, H = study.system(case), study.solver.harmonics
    fr, kw = study.sweep.frequency, study.solver.kwargs()
    kw.update(stability=False, peak_dofs=[study.scene.dof_index(d) for d in study.output.dofs])
    t = time.process_time()
    c = frequency_response(system, H, fr.omega_start, fr.omega_stop, **kw)
    cpu = time.process_time() - t
    where = ", ".join(f"{k} = {v:g}" for k, v in case.items())
    print(f"\nFE blade, quick mesh ({system.n_dof} DOFs, {system.contact.ku.size} contact "
          f"elements), {where}, H = {H}: {c.n_points} points in {cpu:.1f} s CPU without "
          "stability")
    print(f"{'Omega rad/s':>11} {'switches':>8} {'Hill s':>7} {'rho_H':>7} "
          f"{'monodromy s':>11} {'max |mu|':>8}")
    prob = hbm.setup(system, H)
    picks = np.unique(np.linspace(0, c.n_points - 1, samples).round().astype(int))
    tot = np.zeros(2)
    for i in picks:
        t = time.process_time()
        h = branch_stability(prob, c.Q[i:i + 1], c.omega[i:i + 1], c.omega[i:i + 1],
                             lambda lam: system.contact, np.ones(1, bool), "hill")
        th = time.process_time() - t
        t = time.process_time()
        m = along_orbit(system, c.omega[i], c.Q[i])   # what the monodromy modes run
        tm = time.process_time() - t
        tot += th, tm
        print(f"{c.omega[i]:11.2f} {m.n_events:>8} {th:7.2f} {h.hill_multiplier[0]:7.4f} "
              f"{tm:11.2f} {m.max_modulus:8.4f}")
    per = tot / picks.size
    print(f"per point: Hill {per[0]:.1f} s, monodromy {per[1]:.1f} s; a curve of "
          f"{c.n_points} points: hill ~{cpu + c.n_points * per[0]:.0f} s, monodromy (also "
          f"floquet, monodromy+check) ~{cpu + c.n_points * per[1]:.0f} s, hill+check "
          f"(lightly damped: every point checked) ~{cpu + c.n_points * per.sum():.0f} s")
