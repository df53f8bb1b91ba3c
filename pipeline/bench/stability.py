"""What a trustworthy stability flag costs: `python -m pipeline bench stability`.

One frequency-response curve (dense output on, exact forces) per stability mode
(`solve.stability_check`) on paper Examples 1 and 3 and the 3-DOF shrouded blade,
each timed as this process's CPU time (single-threaded BLAS), with the points the
exact Floquet multipliers decided, the unstable points and the bifurcations.
"""
from __future__ import annotations

import logging
import os
import time

import numpy as np

from ..paper_systems import blade3, example1, example3
from ..solve.response import frequency_response
from ..solve.stability_check import FLOQUET, KINDS, MONODROMY

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
    logging.getLogger("pipeline.solve.timesim").setLevel(logging.WARNING)
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
    return 0
