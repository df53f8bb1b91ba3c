"""`bench peers`: paper Example 1's frequency response (H = 7, 150-250 rad/s) at
n = 1, 2, 5 N by this pipeline, NLvib (Octave) and pyHarm, side by side.

The tools run interleaved in one process tree (ours, NLvib, pyHarm for n = 1, then
n = 2, ...), so that all of them see the same machine load.  The peers are external
programs, never imported: NLvib through `octave` and `peer_scripts/nlvib_example1.m`
(its folder from `--nlvib` or $NLVIB_PATH), pyHarm through an interpreter that has it
(`--pyharm-python` or $PYHARM_PYTHON) running `peer_scripts/pyharm_example1.py`.  Each
prints one line `RESULT n points seconds peak omega ...`, its time measured inside
the tool (start-up excluded), the median of as many curves as ours; the subprocess's
whole wall time is reported too.
A third row, "minimal numpy loop" (`peer_scripts/minimal_example1.py`, run by this
interpreter), is the floor of a Python design: the same exact forces and Hill at every
point in a bare pseudo-arclength loop, without this pipeline's checks (resonance
guard, recomputed residual, round-off floor, dense output, exact peak, folds).
The peak of a peer is its largest point (half peak-to-peak amplitude, as ours); ours
is located exactly between points (`response.insert_peaks`).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..paper_systems import example1
from ..solve.response.response import frequency_response

SCRIPTS = Path(__file__).resolve().parent / "peer_scripts"
LOADS = (1.0, 2.0, 5.0)       # normal loads n [N]
H, OMEGA = 7, (150.0, 250.0)
NLVIB_DS = 3.0                # NLvib step with its examples' scaling (peer_scripts/nlvib_example1.m)
NLVIB_TOL = 1e-9              # fsolve's TolFun = TolX, as NLvib's examples set them
# pyHarm's default step (1 rad/s here) misses the sharp peak at n = 1 N by a third; a
# second row with the step that brings it within 0.2 % (ds0 = ds_max)
PYHARM_FINE_DS = {1.0: 0.06}
PYHARM_SAMPLES = 128          # pyHarm's AFT samples a period: ours with AFT at as many
TIMEOUT = 900.0               # [s] per external curve
END_GAP = 1e-3               # a curve ending below OMEGA[1] (1 - END_GAP) stopped short
MINIMAL = "minimal numpy loop"  # peer_scripts/minimal_example1.py: the floor of a Python loop


@dataclass(frozen=True)
class Row:
    """One curve by one tool; `status` is "ok" or says why there are no numbers."""

    n: float
    tool: str
    status: str = "ok"
    points: int = 0
    seconds: float = float("nan")     # the curve, measured inside the tool
    total: float = float("nan")       # the whole subprocess (start-up included)
    cpu: float = float("nan")         # the curve's CPU time, measured inside the tool
    peak: float = float("nan")        # half peak-to-peak amplitude [m]
    peak_omega: float = float("nan")  # [rad/s]


def parse_result(n, tool, stdout, total):
    """The Row of a peer's `RESULT n points seconds peak omega ... final cpu=CPU` line;
    a curve whose last frequency (`final`, the last field before the CPU time) stops
    short of the band's end is a failed row, never timed as a whole curve."""
    for line in stdout.splitlines():
        if line.startswith("RESULT "):
            f = line.split()
            cpu = [float(x[4:]) for x in f if x.startswith("cpu=")]
            rest = [x for x in f if not x.startswith("cpu=")]
            if len(rest) > 6 and float(rest[-1]) < OMEGA[1] * (1 - END_GAP):
                return Row(n, tool, status=f"failed: stopped at {float(rest[-1]):.2f} rad/s, "
                           f"short of {OMEGA[1]:g}")
            return Row(n, tool, points=int(f[2]), seconds=float(f[3]), total=total,
                       peak=float(f[4]), peak_omega=float(f[5]),
                       cpu=cpu[0] if cpu else float("nan"))
    return Row(n, tool, status="failed: no RESULT line")


def external(n, tool, cmd, cwd):
    """Run one peer's curve; a failure or a time-out is a row, not an exception."""
    t = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT, cwd=cwd)
    except subprocess.TimeoutExpired:
        return Row(n, tool, status=f"failed: over {TIMEOUT:.0f} s")
    total = time.perf_counter() - t
    row = parse_result(n, tool, p.stdout, total)
    if row.status != "ok" or p.returncode != 0:
        err = (p.stderr.strip().splitlines() or ["exit code %d" % p.returncode])[-1]
        return Row(n, tool, status=f"failed: {err[:60]}")
    return row


def nlvib_command(nlvib_dir, n, repeat=1):
    q = lambda s: str(s).replace("'", "''")  # noqa: E731  Octave string quoting
    call = (f"addpath('{q(SCRIPTS)}'); nlvib_example1('{q(nlvib_dir)}', {n!r}, {NLVIB_DS!r}, "
            f"{NLVIB_TOL!r}, {int(repeat)})")
    return ["octave", "--no-gui", "--no-window-system", "--quiet", "--eval", call]


def available(nlvib_dir, pyharm_python):
    """{tool: None if it can run, else the reason it cannot}."""
    why = {}
    if shutil.which("octave") is None:
        why["NLvib"] = "not installed (no octave on PATH)"
    elif not nlvib_dir or not (Path(nlvib_dir) / "SRC" / "HB_residual.m").is_file():
        why["NLvib"] = "not installed (give --nlvib PATH or $NLVIB_PATH, the NLvib folder)"
    else:
        why["NLvib"] = None
    if not pyharm_python or shutil.which(str(pyharm_python)) is None:
        why["pyHarm"] = "not installed (give --pyharm-python PATH or $PYHARM_PYTHON)"
    else:
        why["pyHarm"] = None
    return why


def ours(n, stability, repeat, samples=None, dense=True):
    """Median wall time of `repeat` curves (the compiled kernels already loaded); exact
    forces, or AFT with `samples` samples (pyHarm's way, at its 128); dense=False: the
    continuation's points and the peak only, without the points added where the drawn
    curve bends (`dense_output`)."""
    times, cpus = [], []
    kw = {} if samples is None else {"method": "aft", "n_samples": samples}
    for _ in range(repeat):
        t, cpu = time.perf_counter(), time.process_time()
        c = frequency_response(example1(n), H, *OMEGA, stability=stability,
                               dense_output=dense, **kw)
        times.append(time.perf_counter() - t)
        cpus.append(time.process_time() - cpu)
    a, om, _ = c.peak(0)
    tool = "ours" if stability else "ours, no Hill"
    tool += "" if samples is None else f", AFT {samples}"
    tool += "" if dense else ", no dense output"
    status = "ok" if c.success else f"failed: {c.message[:60]}"
    return Row(n, tool, status, c.n_points, float(np.median(times)), peak=a, peak_omega=om,
               cpu=float(np.median(cpus)))


def table(nlvib_dir=None, pyharm_python=None, loads=LOADS, repeat=3):
    """All rows, the tools interleaved load by load."""
    why = available(nlvib_dir, pyharm_python)
    frequency_response(example1(2.0), H, *OMEGA)  # warm-up: compiled kernels, caches
    frequency_response(example1(2.0), H, *OMEGA, method="aft", n_samples=PYHARM_SAMPLES)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:  # the peers' working folder
        for n in loads:
            rows += [ours(n, True, repeat), ours(n, True, repeat, dense=False),
                     ours(n, False, repeat), ours(n, False, repeat, PYHARM_SAMPLES)]
            rows.append(external(n, MINIMAL, [sys.executable, str(SCRIPTS / "minimal_example1.py"),
                                              repr(n), "--repeat", str(repeat)], tmp))
            if why["NLvib"] is None:
                rows.append(external(n, "NLvib", nlvib_command(nlvib_dir, n, repeat), tmp))
            if why["pyHarm"] is None:
                cmd = [str(pyharm_python), str(SCRIPTS / "pyharm_example1.py"), repr(n),
                       "--repeat", str(repeat)]
                rows.append(external(n, "pyHarm", cmd, tmp))
                if n in PYHARM_FINE_DS:
                    ds = PYHARM_FINE_DS[n]
                    rows.append(external(n, f"pyHarm ds {ds:g}", cmd[:3] + [repr(ds)], tmp))
            rows += [Row(n, tool, status) for tool, status in why.items() if status]
    return rows


def format_rows(rows):
    """The table's lines; peak difference and time ratios against ours (Hill on)."""
    ref = {r.n: r for r in rows if r.tool == "ours"}
    lines = [f"{'n N':>4} {'tool':<24} {'points':>6} {'time s':>7} {'total s':>7} "
             f"{'peak m':>10} {'at rad/s':>9} {'d peak':>8} {'d rad/s':>7} {'time/ours':>9} "
             f"{'cpu s':>6} {'cpu/ours':>8}"]
    for r in rows:
        head = f"{r.n:4g} {r.tool:<24}"
        if r.status != "ok":
            lines.append(f"{head} {r.status}")
            continue
        o = ref.get(r.n)
        dp = (r.peak - o.peak) / o.peak if o else float("nan")
        dw = r.peak_omega - o.peak_omega if o else float("nan")
        ratio = r.seconds / o.seconds if o else float("nan")
        cpu_ratio = r.cpu / o.cpu if o else float("nan")
        total = "" if np.isnan(r.total) else f"{r.total:7.2f}"
        lines.append(f"{head} {r.points:>6} {r.seconds:7.2f} {total:>7} {r.peak:10.4e} "
                     f"{r.peak_omega:9.3f} {dp:+8.1e} {dw:+7.3f} {ratio:9.2f} "
                     f"{r.cpu:6.2f} {cpu_ratio:8.2f}")
    return lines


def run(quick=False, nlvib=None, pyharm_python=None):
    nlvib = nlvib or os.environ.get("NLVIB_PATH")
    pyharm_python = pyharm_python or os.environ.get("PYHARM_PYTHON")
    load = lambda: ", ".join(f"{x:.2f}" for x in os.getloadavg())  # noqa: E731
    before = load()
    rows = table(nlvib, pyharm_python, repeat=1 if quick else 3)
    print(f"Example 1, H = {H}, {OMEGA[0]:g}-{OMEGA[1]:g} rad/s: this pipeline (exact forces; "
          f"AFT at pyHarm's {PYHARM_SAMPLES} samples), NLvib and pyHarm (AFT, "
          f"{PYHARM_SAMPLES} samples); load average {before} (start), "
          f"{load()} (end)")
    if quick:
        print("--quick: one curve per tool, so the ratios swing with the machine's load "
              "(without --quick: the median of 3)")
    print("\n".join(format_rows(rows)))
    print(f"time: the curve, measured inside each tool, the median of {1 if quick else 3} "
          "(pyHarm with the smaller step: one); "
          "total: the subprocess, start-up included\n"
          "d peak: relative difference of the peak amplitude from ours (Hill on), d rad/s: of "
          "its frequency; time/ours: time over ours (Hill on); cpu: the CPU time of the "
          "curve (its process's), cpu/ours: over ours (Hill on)\n"
          f"NLvib: solve_and_continue, ds = {NLVIB_DS:g}, harmonics scaled by the linear "
          f"response at the start and adapted (dynamicDscale), tolerance {NLVIB_TOL:g}; "
          "pyHarm: "
          "FRF analysis, default "
          "arc-length step (ds: a smaller one); neither computes stability\n"
          f"{MINIMAL}: this pipeline's exact forces and Hill at every point in a bare "
          "pseudo-arclength loop, none of its checks (the floor of a Python design)")
    return 0
