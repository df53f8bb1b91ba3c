"""One case of the mistuned wheels' Monte Carlo (`python -m pipeline bench montecarlo`).

The case studies/shrouded_disk_monte_carlo.toml runs (24 beam blades, 3 % stiffness
mistuning, seed 1, 1 N per face, H = 3; --quick: its quick variant, seed 1 at 3 N, H = 1):
each blade's largest peak only (`frequency_response(keep="peaks")`, what the study
keeps) against the full curves (dense output, every local maximum located: what
studies/shrouded_disk_mistuned.toml keeps), in one run.  CPU is this process's time
(OPENBLAS_NUM_THREADS=1 makes it the work done); the peaks of the 24 blade tips must
agree (largest relative difference printed)."""
from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from ..solve.response.response import frequency_response
from ..study.files.documents import load_study

STUDY = Path(__file__).resolve().parents[2] / "studies" / "shrouded_disk_monte_carlo.toml"


def case_rows(quick: bool = False) -> tuple:
    """(case text, [(mode, wall s, CPU s, points kept, branch points, evaluations,
    peaks (D,), frequencies (D,))]) of the full curves and the largest peaks."""
    st = load_study(STUDY, quick=quick)
    case = {"preload": st.sweep.axes["preload"][0], "mistuning_seed": 1}
    system = st.system(case)
    dofs = [st.scene.dof_index(d) for d in st.output.dofs]
    fr, H = st.sweep.frequency, st.solver.harmonics
    rows = []
    for mode, curves in (("full curves", True), ("largest peaks", False)):
        kw = st.solver.kwargs(st.output.yscale, curves)
        t, c0 = time.perf_counter(), time.process_time()
        c = frequency_response(system, H, fr.omega_start, fr.omega_stop, peak_dofs=dofs, **kw)
        wall, cpu = time.perf_counter() - t, time.process_time() - c0
        peaks = np.array([c.peak(d)[:2] for d in dofs])
        rows.append((mode, wall, cpu, c.n_points, c.info["branch_points"], c.nfev,
                     peaks[:, 0], peaks[:, 1]))
    text = (f"{len(dofs)} blades, seed 1, {case['preload']:g} N per face, H = {H}, "
            f"{fr.start:g}-{fr.stop:g} {fr.unit}")
    return text, rows


def run(quick: bool = False) -> int:
    text, rows = case_rows(quick)
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"Mistuned wheel Monte-Carlo case ({text}); OPENBLAS_NUM_THREADS="
          f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}; load average {load}")
    print(f"{'kept':<14} {'wall s':>7} {'CPU s':>7} {'points':>6} {'branch':>6} "
          f"{'R evals':>7} {'largest peak m':>14} {'peaks vs full':>13} {'freq vs full':>12}")
    ref = rows[0]
    for mode, wall, cpu, n, branch, nfev, peaks, om in rows:
        da = np.max(np.abs(peaks / ref[6] - 1))
        df = np.max(np.abs(om / ref[7] - 1))
        print(f"{mode:<14} {wall:7.1f} {cpu:7.1f} {n:6d} {branch:6d} {nfev:7d} "
              f"{peaks.max():14.6g} {da:13.1e} {df:12.1e}")
    print(f"ratio (full / largest peaks): wall {rows[0][1] / rows[1][1]:.2f}, CPU "
          f"{rows[0][2] / rows[1][2]:.2f}")
    return 0
