"""How cost grows with the shroud interface: `python -m pipeline bench interface`.

The full-size curved blade of `studies/full_size_blade.toml` (36 sectors, EO 3, 10 N a
face, H = 3) with n_chord = 1, 2, 5, 10, 21 elements across the chord: (2 n_chord + 1)
x 3 = 9, 15, 33, 63, 129 node pairs per shroud face, the airfoil's other counts fixed.
For each, with the 1D law (exact forces) and the 2D law (AFT, 64 samples): the
unknowns of the condensed harmonic balance, one residual with its Jacobian and one
Newton solve of it (`cost.time_system_point`, medians of three; the solve a float32
LU from 500 rows, as the solver does), and the curve from 0.985 to 1.003 of the
model's stuck ND 3 frequency, through its peak (located for the study's output DOF,
as the study does), without dense output (its
continuation points, time per point, and that time over one residual + one solve: the
floor a Newton step cannot go under; `whole`: the window covered).  The growth
exponent of the time per point with the pair count is the slope of a least-squares
line in log-log.  `--quick`: 9, 15 and 33 pairs.
"""
from __future__ import annotations

import math
import os
import time
from pathlib import Path

import numpy as np

from ..model.system import natural_frequencies
from ..solve.response.response import frequency_response
from ..study.execution.cost import time_system_point
from ..study.files.documents import parse_study

COUNTS = (1, 2, 5, 10, 21)     # n_chord: 9, 15, 33, 63, 129 pairs per face
WINDOW = (0.985, 1.003)        # x the model's stuck ND 3 frequency: through its peak


def blade_study(n_chord: int, law: str):
    """The full-size study with n_chord elements across the chord and the 1D or 2D law."""
    text = (Path(__file__).resolve().parents[2] / "studies" / "full_size_blade.toml").read_text()
    text = text[:text.index("[quick")]
    text = text.replace("n_chord = 8                      # 51 node pairs per shroud face",
                        f"n_chord = {n_chord}")
    if law == "1d":
        text = (text.replace('"friction", "friction_2d",', '"friction",')
                .replace('friction = "2d"\n', "")
                .replace('force_evaluation = "aft"', 'force_evaluation = "exact"'))
    return parse_study(text, file="full_size_blade.toml", name="interface")


def row(n_chord: int, law: str):
    study = blade_study(n_chord, law)
    sv = study.solver
    system = study.system({"preload": 10.0})
    pairs = (2 * n_chord + 1) * 3
    w0, w1 = (x * natural_frequencies(system, "stuck")[0] for x in WINDOW)
    t_r, t_s, unknowns, _ = time_system_point(system, sv.harmonics, sv.force_evaluation,
                                              sv.samples, math.sqrt(w0 * w1), 3)
    t0 = time.perf_counter()
    dofs = [study.scene.dof_index(d) for d in study.output.dofs]   # the study's peaks
    c = frequency_response(system, sv.harmonics, w0, w1, stability=False, peak_dofs=dofs,
                           tol_rel=sv.tolerance, method=sv.force_evaluation,
                           n_samples=sv.samples, dense_output=False)
    t = time.perf_counter() - t0
    per = t / max(c.omega.size, 1)
    print(f"{law:>3} {pairs:>6} {unknowns:>9} {t_r * 1e3:>9.1f} {t_s * 1e3:>9.1f} "
          f"{c.omega.size:>7} {per * 1e3:>9.1f} {per / (t_r + t_s):>7.2f} "
          f"{'yes' if c.success else 'no':>6}", flush=True)
    return pairs, per


def run(quick=False):
    counts = COUNTS[:3] if quick else COUNTS
    print(f"Cost against the shroud interface: the full-size curved blade, 10 N, H = 3, "
          f"{WINDOW[0]:g}-{WINDOW[1]:g} x the stuck ND 3 frequency (load average "
          f"{os.getloadavg()[0]:.1f}, {os.cpu_count()} cores)")
    print(f"{'law':>3} {'pairs':>6} {'unknowns':>9} {'R+J ms':>9} {'solve ms':>9} "
          f"{'points':>7} {'ms/point':>9} {'/(R+S)':>7} {'whole':>6}")
    for law in ("1d", "2d"):
        got = [row(n, law) for n in counts]
        p, t = np.log([g[0] for g in got]), np.log([g[1] for g in got])
        print(f"{law}: time per point grows as pairs^{np.polyfit(p, t, 1)[0]:.2f}")
    return 0
