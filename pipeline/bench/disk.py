"""FE blades in a disk: `python -m pipeline bench disk [--quick]`.

Two tables, each with the machine load (os.getloadavg, 1/5/15 min):

1. Tuned sector: the engine-order travelling wave solved on one FE sector
   (`build_system`, `System.cyclic`), N = 12, 24, 48, 96.  The cost per
   continuation point must not depend on N: the nonlinear unknowns are the sector's
   contact DOFs whatever N.
2. Full wheel: all N blades (`full_system`, sparse M, C, K, Bt, Bn above
   `cyclic.DENSE_MAX_DOF` DOFs, no symmetry used), N = 6, 12, 24, 48, a fixed
   budget of continuation points from the same start in a fixed window; each N in a
   fresh (spawned) process so that its peak resident memory is its own.

Geometry: the hub radius R is set so that the wheel's derived shroud width
(`disk.wheel_shroud_width`) is SHROUD_WIDTH for every N,

    R = w_s cos(gamma) / (2 tan(pi / N)) - L - h_s / 2,

so every N has the same blade (same mesh, mass and stiffness; only the disk
curvature differs) and the tuned sector's response is the same travelling wave.
(R = N x 0.01 m would keep the hub pitch fixed instead, but the tip pitch, hence
the shroud width, would then shrink by 40 % from N = 12 to 96.)

Stability (Hill) is off in the timed curves: with hundreds of DOFs one Hill
evaluation costs seconds per point; its cost per point is reported separately.
"""
from __future__ import annotations

import cProfile
import io
import multiprocessing as mp
import os
import pstats
import resource
import time

import numpy as np
import scipy.sparse as sp

from ..model.cyclic import DENSE_MAX_DOF
from ..model.contacts import ShroudPair
from ..model.loads import PointLoad
from ..model.scene import Blade, CraigBampton, Cyclic, Scene
from ..model.build import build_system, full_system
from ..model.system import natural_frequencies
from ..solve.harmonic_balance import hbm
from ..solve.harmonic_balance.parts import SPARSE_JACOBIAN_MIN
from ..solve.harmonic_balance.full_operators import wave_jacobians
from ..solve.continuation.newton import newton
from ..solve.response.response import frequency_response, initial_guess
from ..solve.stability.hill import is_stable
from ..structure.fe_model import BladeParams, DiskPlacement

SHROUD_WIDTH = 0.15     # [m], the same for every N (module docstring)
EO = 2
PRELOAD = 30.0          # [N] over each shroud face: stick-slip at resonance
PAIR = ShroudPair("shroud", ku=1e5, kv=1e5, mu=0.3, n0=None)   # [N/m] per node pair
LOAD = PointLoad("excitation", (0.0, 1.0, 0.0), 1.0, 1, 0.0)   # 1 N in Y, first harmonic
# table 1: the coarse mesh of tests/study/scenes/test_disk_blades.py
SECTOR_BLADE = BladeParams(n_chord=2, n_thick=1, n_span=4)
SECTOR_MODES = 6
SECTOR_PHASE_DIVISOR = 6    # table 1: EO = N / 6, the interblade phase 2 pi / 6 for every N
# table 2: the beam blade with a rigid tip shroud (2 x 2 contact points per face)
WHEEL_BLADE = BladeParams(kind="beam", n_span=10)
WHEEL_MODES = 6
TOL_REL = 1e-6
# full wheel: skip an N whose dense condensed HBM Jacobian (nc nh)^2 x 8 bytes alone
# exceeds this (the machine is shared; several copies live at once)
MAX_JACOBIAN_BYTES = 1.0e9


def hub_radius(params: BladeParams, sectors: int, shroud_width: float = SHROUD_WIDTH) -> float:
    """Hub radius R [m] giving the wheel shroud width `shroud_width` [m] for N sectors."""
    r = shroud_width * np.cos(params.stagger_angle) / (2.0 * np.tan(np.pi / sectors))
    return float(r - params.length - params.shroud_height / 2)


def disk_scene(params: BladeParams, sectors: int, modes: int, eo: int = EO) -> Scene:
    """One shroud pair, the 1 N excitation, EO travelling wave, Craig-Bampton(modes)."""
    disk = DiskPlacement(hub_radius=hub_radius(params, sectors), sectors=sectors)
    return Scene(Blade(params, disk=disk), contacts=(PAIR,), loads=(LOAD,),
                 assembly=Cyclic(sectors, eo), reduction=CraigBampton(modes))


def load_average() -> str:
    return "load average (1/5/15 min): " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def limits(sector_system) -> tuple:
    """First open and first stuck natural frequency [rad/s] of the EO family."""
    return (float(natural_frequencies(sector_system, "open")[0]),
            float(natural_frequencies(sector_system, "stuck")[0]))


# ---------------------------------------------------------------------------
# table 1: tuned sector
# ---------------------------------------------------------------------------

def sector_row(sectors: int, H: int, window=(0.8, 1.2), max_points: int = 1000,
               sweep_points: int | None = None) -> dict:
    """One traced curve of the tuned sector over [window[0] w_open, window[1] w_stuck],
    engine order N / 6: the same interblade phase (60 deg), so the same blade traces
    the same curve for every N and only the cost of the reduction could differ; and
    the fixed-frequency sweep of `sweep_points` (default SWEEP_POINTS) Newton solves."""
    scene = disk_scene(SECTOR_BLADE, sectors, SECTOR_MODES, eo=sectors // SECTOR_PHASE_DIVISOR)
    s = build_system(scene, {"preload": PRELOAD})
    w_open, w_stuck = limits(s)
    frequency_response(s, 1, w_open, 1.01 * w_open, stability=False,  # warm-up (caches)
                       dense_output=False, max_points=3)
    t, cpu = time.perf_counter(), time.process_time()
    c = frequency_response(s, H, window[0] * w_open, window[1] * w_stuck, tol_rel=TOL_REL,
                           stability=False, peak_dofs=[0], dense_output=False,
                           max_points=max_points)
    wall, cpu = time.perf_counter() - t, time.process_time() - cpu
    return {"N": sectors, "EO": sectors // SECTOR_PHASE_DIVISOR,
            "R": hub_radius(SECTOR_BLADE, sectors), "dofs": s.n_dof,
            "contact_dofs": int(hbm.setup(s, H).c.size), "pairs": s.contact.size,
            "w_open": w_open, "w_stuck": w_stuck, "points": c.n_points, "s_curve": wall,
            "ms_point": 1e3 * wall / max(c.n_points, 1),
            "cpu_point": 1e3 * cpu / max(c.n_points, 1),
            "newton_point": float(c.info["njev"]) / max(c.n_points, 1),
            "cpu_eval": 1e3 * cpu / max(c.nfev, 1),
            "cpu_newton": 1e3 * cpu / max(int(c.info["njev"]), 1),
            "converged": bool(np.all(c.converged)), "success": c.success, "curve": c,
            "system": s, **sector_sweep(s, H, (window[0] * w_open, window[1] * w_stuck),
                                        sweep_points or SWEEP_POINTS)}


SWEEP_POINTS = 60     # the fixed-frequency sweep of table 1


def sector_sweep(s, H: int, window, points: int = SWEEP_POINTS) -> dict:
    """The same work for every N: Newton at `points` fixed frequencies across the window,
    each started from the previous solution (a stepped sine), rows scaled by their
    tolerances (`hbm.row_weights`); CPU ms per point and Newton iterations per point."""
    prob = hbm.setup(s, H)
    w = hbm.row_weights(prob, hbm.tolerances(prob, TOL_REL))
    omegas = np.linspace(window[0], window[1], points)
    x = initial_guess(prob, omegas[0], s.contact)
    cpu, nit, ok = time.process_time(), 0, 0
    for Om in omegas:
        r = newton(lambda z: (lambda R, J, _: (w * R, w[:, None] * J))(  # noqa: E731
            *hbm.residual(prob, z, Om)), x, 1.0, max_iter=40)
        nit, ok = nit + r.nit, ok + bool(r.success)
        x = r.x if r.success else x
    cpu = time.process_time() - cpu
    return {"sweep_cpu_point": 1e3 * cpu / points, "sweep_newton_point": nit / points,
            "sweep_converged": ok}


def sector_table(sizes, H: int, **kw) -> list[dict]:
    rows = [sector_row(N, H, **kw) for N in sizes]
    for r in rows:
        r["ratio"] = r["cpu_point"] / rows[0]["cpu_point"]
        r["ratio_newton"] = r["cpu_newton"] / rows[0]["cpu_newton"]
        r["ratio_sweep"] = r["sweep_cpu_point"] / rows[0]["sweep_cpu_point"]
    return rows


def stability_cost(row: dict, sample: bool = False) -> tuple:
    """(seconds, wave numbers) of one Hill stability evaluation at the curve's largest
    amplitude point: every wave number r = 0..N/2 of the sector (`wave_jacobians`; the
    pairs r, N - r as one real problem of twice the size).  With `sample`, one problem
    of each size is solved and the time extrapolated to all of them."""
    c, s = row["curve"], row["system"]
    i = int(np.argmax(c.amplitude.max(axis=1)))
    prob = hbm.setup(s, c.H)
    t = time.perf_counter()
    problems = wave_jacobians(prob, c.Q[i], c.omega[i], s.contact)
    total = time.perf_counter() - t
    sizes = [J.shape[0] for _, J, _, _ in problems]
    timed = {}
    for size, (_, J, M, C) in zip(sizes, problems):
        if sample and size in timed:
            continue
        t = time.perf_counter()
        is_stable(J, M, C, c.omega[i], c.H)
        timed[size] = timed.get(size, 0.0) + time.perf_counter() - t
    if sample:
        return total + sum(timed[n] for n in sizes), len(problems)
    return total + sum(timed.values()), len(problems)


def print_sector_table(rows, H: int) -> None:
    print(f"Tuned FE sector (solid blade {SECTOR_BLADE.n_chord}x{SECTOR_BLADE.n_thick}x"
          f"{SECTOR_BLADE.n_span} Hex2, Craig-Bampton({SECTOR_MODES}), {rows[0]['pairs']} "
          f"contact pairs), EO = N/6 (interblade phase 60 deg), H = {H}, preload {PRELOAD} N, "
          "stability off; window [0.8 w_open, 1.2 w_stuck] of ND = EO")
    print(f"R: shroud width {SHROUD_WIDTH} m for every N; {load_average()}")
    print(f"{'N':>4} {'EO':>3} {'R [m]':>7} {'DOFs':>5} {'contact DOFs':>12} {'w_open':>8} "
          f"{'w_stuck':>8} {'points':>6} {'Newton/pt':>9} {'s/curve':>8} {'ms/point':>9} "
          f"{'CPU ms/pt':>9} {'CPU ms/eval':>11} {'CPU ms/Newton':>13} {'ratio/pt':>8} "
          f"{'ratio/Newton':>12} {'covered':>7} {'conv.':>5}")
    for r in rows:
        print(f"{r['N']:>4} {r['EO']:>3} {r['R']:7.3f} {r['dofs']:>5} {r['contact_dofs']:>12} "
              f"{r['w_open']:8.1f} {r['w_stuck']:8.1f} {r['points']:>6} {r['newton_point']:9.2f} "
              f"{r['s_curve']:8.2f} {r['ms_point']:9.1f} {r['cpu_point']:9.1f} "
              f"{r['cpu_eval']:11.1f} {r['cpu_newton']:13.1f} {r['ratio']:8.2f} "
              f"{r['ratio_newton']:12.2f} {'yes' if r['success'] else 'no':>7} "
              f"{'yes' if r['converged'] else 'NO':>5}")
    print(f"the same work for every N: a stepped sine of {SWEEP_POINTS} fixed frequencies "
          "across the window, Newton from the previous point")
    print(f"{'N':>4} {'Newton/pt':>9} {'CPU ms/pt':>9} {'ratio':>6} {'CPU ms/Newton':>13} "
          f"{'converged':>9}")
    for r in rows:
        per_it = r["sweep_cpu_point"] / max(r["sweep_newton_point"], 1e-12)
        print(f"{r['N']:>4} {r['sweep_newton_point']:9.2f} {r['sweep_cpu_point']:9.1f} "
              f"{r['ratio_sweep']:6.2f} {per_it:13.1f} {r['sweep_converged']:>5}/{SWEEP_POINTS}")
    nc = {r["contact_dofs"] for r in rows}
    print(f"nonlinear unknowns per harmonic: {sorted(nc)} "
          f"({'the same for every N' if len(nc) == 1 else 'NOT the same'}); "
          f"w in rad/s; ratio: ms/point over N = {rows[0]['N']}; covered: the curve reached "
          "the window's end; conv.: every point's full residual within tolerance")
    print("CPU: this process's CPU time (independent of what else the machine runs; "
          "OPENBLAS_NUM_THREADS=1 makes it the work done); CPU ms/eval per residual "
          "evaluation with its Jacobian; CPU ms/Newton per Newton iteration (the curve's "
          "CPU time over its Jacobian evaluations): the cost of a point at equal work, since "
          "the iterations a point takes follow the path, which the disk curvature changes "
          "slightly with N; ratios over N = " + str(rows[0]["N"]))


# ---------------------------------------------------------------------------
# table 2: full wheel
# ---------------------------------------------------------------------------

def matrix_bytes(A) -> int:
    """Stored bytes of a dense or CSR matrix (data + indices + indptr)."""
    if sp.issparse(A):
        A = A.tocsr()
        return int(A.data.nbytes + A.indices.nbytes + A.indptr.nbytes)
    return int(np.asarray(A).nbytes)


def current_rss() -> int:
    """Resident memory of this process now [bytes] (Linux /proc; else the peak so far)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError):
        return peak_rss()


def peak_rss() -> int:
    """Peak resident memory [bytes]: since `reset_peak_rss` where Linux allows it
    (/proc/self/status VmHWM), else since the process started."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024   # KiB on Linux


def reset_peak_rss() -> None:
    """Restart the peak resident memory from the current one (Linux: clear_refs 5);
    without it the peak includes what came before (the wheel's setup)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def wheel_setup(sectors: int, H: int) -> dict:
    """The full wheel's system, its frequency window and its sizes (no solve); engine
    order N / 6, the same interblade phase for every N (as table 1)."""
    scene = disk_scene(WHEEL_BLADE, sectors, WHEEL_MODES, eo=sectors // SECTOR_PHASE_DIVISOR)
    case = {"preload": PRELOAD}
    w_open, w_stuck = limits(build_system(scene, case))
    f = full_system(scene, case)
    n = f.n_dof // sectors
    if f.n_dof > DENSE_MAX_DOF:   # no (N n)^2 dense matrix in the assembly
        assert all(sp.issparse(A) for A in (f.M, f.C, f.K, f.Bt, f.Bn)), "dense full wheel"
    nc = int(hbm.setup(f, H).c.size)
    return {"N": sectors, "R": hub_radius(WHEEL_BLADE, sectors), "dofs": f.n_dof,
            "sector_dofs": n, "contact_dofs": nc, "pairs": f.contact.size // sectors,
            "sparse": sp.issparse(f.K),
            "matrix_bytes": sum(matrix_bytes(A) for A in (f.M, f.C, f.K, f.Bt, f.Bn)),
            # the condensed Jacobian is built sparse from SPARSE_JACOBIAN_MIN unknowns
            "jacobian_bytes": ((nc * (2 * H + 1)) ** 2 * 8
                               if nc * (2 * H + 1) < SPARSE_JACOBIAN_MIN else 0),
            "window": (0.9 * w_stuck, 1.1 * w_stuck),
            "system": f}


def wheel_row(sectors: int, H: int, points: int, max_jacobian_bytes=MAX_JACOBIAN_BYTES) -> dict:
    """One FRF of the full wheel with a budget of `points` continuation points from the
    window's start; skipped (row without timings) when the dense condensed Jacobian
    alone would exceed `max_jacobian_bytes`."""
    row = wheel_setup(sectors, H)
    f = row.pop("system")
    if row["jacobian_bytes"] > max_jacobian_bytes:
        return {**row, "skipped": True}
    reset_peak_rss()
    rss0 = current_rss()
    t, cpu = time.perf_counter(), time.process_time()
    c = frequency_response(f, H, *row["window"], tol_rel=TOL_REL, stability=False,
                           peak_dofs=[0], dense_output=False, max_points=points)
    wall, cpu = time.perf_counter() - t, time.process_time() - cpu
    return {**row, "skipped": False, "points": c.n_points, "s_frf": wall,
            "s_point": wall / max(c.n_points, 1), "cpu_point": cpu / max(c.n_points, 1),
            "newton_point": float(c.info["njev"]) / max(c.n_points, 1),
            "omega_end": float(c.omega[-1]) if c.n_points else float("nan"),
            "converged": bool(np.all(c.converged)), "rss_delta": max(peak_rss() - rss0, 0)}


def wheel_table(sizes, H: int, points: int, isolate: bool = True, **kw) -> list[dict]:
    """`wheel_row` per N, each in a fresh spawned process when `isolate` (its own peak
    memory, and a size that runs out of memory does not take the bench down)."""
    rows = []
    for N in sizes:
        if isolate:
            with mp.get_context("spawn").Pool(1) as pool:
                rows.append(pool.apply(wheel_row, (N, H, points), kw))
        else:
            rows.append(wheel_row(N, H, points, **kw))
    base = rows[0]
    for r in rows:
        r["growth"] = (r["cpu_point"] / base["cpu_point"] / (r["N"] / base["N"])
                       if not (r["skipped"] or base["skipped"]) else float("nan"))
    return rows


def print_wheel_table(rows, H: int, points: int) -> None:
    MB = 1e6
    print(f"Full wheel (all N blades, no symmetry; beam blades with a rigid tip shroud, "
          f"{WHEEL_BLADE.n_span} elements, Craig-Bampton({WHEEL_MODES}), "
          f"{rows[0]['pairs']} contact pairs per interface, {rows[0]['sector_dofs']} DOFs per "
          f"blade), EO = N/6, H = {H}, preload {PRELOAD} N, stability off")
    print(f"window [0.9, 1.1] w_stuck of ND = EO, budget {points} points from its start; "
          f"{load_average()}")
    print(f"{'N':>3} {'R [m]':>6} {'DOFs':>6} {'contact DOFs':>12} {'points':>6} "
          f"{'Newton/pt':>9} {'s/FRF':>8} {'s/point':>8} {'CPU s/pt':>8} {'growth':>7} {'w_end':>7} "
          f"{'RSS+ [MB]':>9} {'matrices [MB]':>13} {'sparse':>6} {'dense J [MB]':>12}")
    for r in rows:
        head = (f"{r['N']:>3} {r['R']:6.3f} {r['dofs']:>6} {r['contact_dofs']:>12} ")
        tail = (f"{r['matrix_bytes'] / MB:13.3f} {'yes' if r['sparse'] else 'no':>6} "
                + (f"{r['jacobian_bytes'] / MB:12.0f}" if r["jacobian_bytes"] else
                   f"{'sparse':>12}"))
        if r["skipped"]:
            print(head + f"{'skipped: dense J over ' + f'{MAX_JACOBIAN_BYTES / MB:.0f} MB':>67} "
                  + tail)
            continue
        print(head + f"{r['points']:>6} {r['newton_point']:9.2f} {r['s_frf']:8.1f} "
              f"{r['s_point']:8.2f} {r['cpu_point']:8.2f} {r['growth']:7.2f} {r['omega_end']:7.0f} "
              f"{r['rss_delta'] / MB:9.0f} " + tail)
    done = [r for r in rows if not r["skipped"]]
    print("a 200-point FRF at the measured cost per point: " + ", ".join(
        f"N = {r['N']}: {200 * r['s_point']:.0f} s ({200 * r['cpu_point']:.0f} s CPU)"
        for r in done))
    print("growth: (CPU s/point) / (CPU s/point at the first N) / (N / first N), 1 = linear "
          "in N (CPU: this process's CPU time, OPENBLAS_NUM_THREADS=1 advised); "
          "RSS+: peak resident memory of the FRF's fresh process above its resident memory "
          "before the FRF; matrices: stored bytes of M, C, K, Bt, Bn; dense J: one copy of "
          "the condensed HBM Jacobian (nc (2H+1))^2 x 8 bytes, or 'sparse' where it is built "
          "and factorised sparse (block-cyclic)")


def profile_wheel(sectors: int, H: int, points: int, top: int = 8) -> str:
    """cProfile of one full-wheel FRF: the `top` functions by cumulative and by own time."""
    f = wheel_setup(sectors, H)
    prof = cProfile.Profile()
    prof.enable()
    frequency_response(f["system"], H, *f["window"], tol_rel=TOL_REL, stability=False,
                       peak_dofs=[0], dense_output=False, max_points=points)
    prof.disable()
    out = io.StringIO()
    st = pstats.Stats(prof, stream=out).strip_dirs()
    st.sort_stats("cumulative").print_stats(top)
    st.sort_stats("tottime").print_stats(top)
    return out.getvalue()


def run(quick: bool) -> int:
    """Print both tables, the stability cost and the full wheel's profile; returns 0."""
    H1, H2 = 3, 5
    sizes1, sizes2 = ((12, 24), (6, 12)) if quick else ((12, 24, 48, 96), (6, 12, 24, 48))
    points = 20 if quick else 200
    rows = sector_table(sizes1, H1, **({"max_points": 25} if quick else {}))
    print_sector_table(rows, H1)
    t, waves = stability_cost(rows[0], sample=quick)
    print(f"Hill stability at one point (N = {rows[0]['N']}, H = {H1}): {t:.2f} s for "
          f"{waves} wave numbers r = 0..N/2 ({1e3 * t / waves:.0f} ms each; their count grows "
          f"as N/2 + 1){'; one problem of each size solved, extrapolated' if quick else ''}; "
          f"{load_average()}")
    print()
    print_wheel_table(wheel_table(sizes2, H2, points), H2, points)
    print(f"\nProfile of the full wheel, N = {sizes2[0]}, H = {H2}, {points} points "
          f"(cProfile; {load_average()}):")
    print(profile_wheel(sizes2[0], H2, points))
    return 0
