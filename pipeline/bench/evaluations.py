"""What a curve costs in residual evaluations: `python -m pipeline bench evaluations`.

Ten frequency-response curves of the paper's three examples (exact forces,
`frequency_response` defaults, stability off), each with the residual evaluations
(one call of R with its Jacobian: every Newton iterate is one) it needed in total
and per point, split into what they paid for:
- continuation: the first point, the steps (rejected ones, corners and the resonance
  guard's retries included) and the location of the folds;
- dense output: the points added where the drawn curves bend;
- peaks: the exact location of each resonance peak.

The aim is at most 3 evaluations per point of the returned curve.  With `quick`,
one curve of each example.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

from ..paper_systems import example1, example2, example3
from ..solve.response.response import frequency_response

AIM = 3.0  # residual evaluations per point of the returned curve

# (example, load [N], H, window [rad/s])
CURVES = ([(1, n, 7, (150.0, 250.0)) for n in (1.0, 2.0, 5.0, 10.0)]
          + [(2, n, 7, (2 * np.pi * 13, 2 * np.pi * 67)) for n in (100.0, 300.0, 1000.0)]
          + [(3, n, 14, (0.5, 1.6)) for n in (5.0, 10.0, 20.0)])
QUICK = (1, 5, 8)  # Example 1 at 2 N, Example 2 at 300 N, Example 3 at 10 N
SYSTEMS = {1: example1, 2: example2, 3: example3}


@dataclass(frozen=True)
class CurveCost:
    """The evaluations of one curve, and what it found."""

    example: int
    load: float          # [N]: n of Examples 1 and 2, n0 of Example 3
    H: int
    points: int          # of the returned curve
    branch_points: int   # continuation points (the rest: dense output and peaks)
    dense_points: int
    nfev: int            # residual evaluations in total
    continuation: int    # ... of which for the continuation and its folds
    dense: int           # ... for the dense output
    peaks: int           # ... for the exact peaks
    rejected: int        # rejected continuation steps
    seconds: float       # wall time of the curve
    peak: float          # largest amplitude of DOF 0 [m]
    peak_omega: float    # [rad/s]
    folds: tuple         # fold frequencies [rad/s]

    @property
    def per_point(self) -> float:
        return self.nfev / self.points


def curve_cost(example, load, H, window) -> CurveCost:
    """One curve of `CURVES`, traced once."""
    system = SYSTEMS[example](load)
    t = time.perf_counter()
    c = frequency_response(system, H, *window, stability=False)
    seconds = time.perf_counter() - t
    info = c.info
    peak, omega, _ = c.peak(0)
    dense, peaks = int(info.get("dense_nfev", 0)), int(info.get("peak_nfev", 0))
    return CurveCost(example, load, H, c.n_points, int(info["branch_points"]),
                     int(info.get("dense_points", 0)), c.nfev, c.nfev - dense - peaks, dense,
                     peaks, int(info["n_rejected"]), seconds, float(peak), float(omega),
                     tuple(float(f) for f in c.fold_parameter))


def format_row(r: CurveCost) -> str:
    folds = ", ".join(f"{f:.6g}" for f in r.folds) or "-"
    return (f"Example {r.example} {r.load:>6g} N {r.H:>3} {r.points:>6} {r.branch_points:>6} "
            f"{r.dense_points:>5} {r.nfev:>6} {r.per_point:>6.2f} {r.continuation:>6} "
            f"{r.dense:>6} {r.peaks:>5} {r.rejected:>4} {r.seconds:>6.2f} {r.peak:>11.5e} "
            f"{r.peak_omega:>10.6g}  {folds}")


def run(quick=False):
    print("Residual evaluations per curve (exact forces, frequency_response defaults, stability "
          f"off), one core, load average {os.getloadavg()[0]:.1f}")
    print(f"{'curve':<19} {'H':>3} {'points':>6} {'cont.':>6} {'dense':>5} {'evals':>6} "
          f"{'/point':>6} {'cont.':>6} {'dense':>6} {'peaks':>5} {'rej.':>4} {'time s':>6} "
          f"{'peak [m]':>11} {'at rad/s':>10}  folds [rad/s]")
    curves = [CURVES[i] for i in QUICK] if quick else CURVES
    frequency_response(example1(2.0), 7, 150.0, 250.0, stability=False)  # warm-up: kernels
    rows = [curve_cost(*curve) for curve in curves]
    for r in rows:
        print(format_row(r))
    total = sum(r.nfev for r in rows) / sum(r.points for r in rows)
    met = sum(r.per_point <= AIM for r in rows)
    print("points: of the returned curve, of which cont. from the continuation and dense from "
          "the dense output (the rest:\n  the inserted peaks); evals: in total, then per point "
          "and split as continuation (first point,\n  steps, rejected ones, corners, folds) / "
          "dense output / peaks; rej.: rejected steps")
    print(f"all curves: {total:.2f} evaluations per point; at most {AIM:g} on {met} of "
          f"{len(rows)} curves")
    return 0
