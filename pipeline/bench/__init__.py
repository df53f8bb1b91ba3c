"""Benchmarks that print tables (`python -m pipeline bench WHAT`).

Timings are wall-clock medians of repeated calls on this machine; every table
also reports the accuracy reached, because speed without accuracy means nothing.
"""
from __future__ import annotations

import logging
import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..solve.time_integration import timesim
from ..contact import YangMenq, exact_reference, forces
from ..fourier.harmonics import basis
from ..paper_systems import example1, example3
from ..solve.response.response import frequency_response
from ..study.execution.run import run_study
from ..study.files.documents import load_study
from .blade import run as run_blade
from .disk import run as run_disk
from .estimate import run as run_estimate
from .evaluations import run as run_evaluations
from .friction2d import friction2d_rows, print_friction2d
from .interface import run as run_interface
from .modes import run as run_modes
from .montecarlo import run as run_montecarlo
from .peers import run as run_peers
from .stability import run as run_stability


def _median_time(fn, repeat):
    fn()  # warm caches (index tables, imports)
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def shroud_like_motions(E, H, seed=0):
    """Contact motions typical of a shroud interface: a dominant first harmonic,
    higher harmonics decaying by 0.3 per order, preloads spanning separation,
    stick-slip and full stick."""
    rng = np.random.default_rng(seed)
    dec = np.repeat(0.3 ** np.arange(H), 2)
    U = np.zeros((E, 2 * H + 1))
    V = np.zeros((E, 2 * H + 1))
    U[:, 1:] = rng.normal(size=(E, 2 * H)) * dec
    V[:, 1:] = rng.normal(size=(E, 2 * H)) * dec * 0.5
    elem = YangMenq(ku=1.0, kv=1.0, mu=0.4, n0=rng.uniform(-0.5, 2.0, E))
    return U, V, elem


def contact(quick=False):
    """Exact forces + Jacobian: the compiled kernel, its numpy reference and AFT."""
    rows = []
    forces(*shroud_like_motions(2, 1))  # compile, or load the compiled kernels
    for H in (1, 7, 21):
        for E in (100, 1000):
            U, V, elem = shroud_like_motions(E, H)
            tau = np.linspace(0, 2 * np.pi, 2001)
            nmax = np.maximum((elem.n0[:, None] + elem.kv[:, None] * (V @ basis(tau, H).T)).max(1), 1e-9)
            scale = elem.mu * nmax
            ref = forces(U, V, elem, "exact")
            rep = 3 if quick else 7
            t_ex = _median_time(lambda: forces(U, V, elem, "exact"), 3 * rep)
            t_np = _median_time(lambda: exact_reference.exact_forces(U, V, elem), max(1, rep // 2))
            numpy = exact_reference.exact_forces(U, V, elem)
            row = {"H": H, "E": E, "regimes": ref.regimes, "exact_ms": 1e3 * t_ex,
                   "numpy_ms": 1e3 * t_np,
                   "numpy_diff": max(np.max(np.abs(getattr(numpy, k) - getattr(ref, k)))
                                     for k in ("Fu", "dFu_dU", "dFu_dV"))}
            for N in (128, 1024):
                if N < 2 * H + 1:
                    continue
                t_a = _median_time(lambda: forces(U, V, elem, "aft", n_samples=N), max(1, rep // 2))
                fa = forces(U, V, elem, "aft", n_samples=N, jacobian=False)
                err = np.max(np.max(np.abs(fa.Fu - ref.Fu), 1) / scale)
                row[f"aft{N}_ms"], row[f"aft{N}_err"] = 1e3 * t_a, err
            rows.append(row)
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print("Yang-Menq element, forces + Jacobian, one thread; error = max |F - F_exact| / (mu max n);"
          f" load average {load}")
    print(f"{'H':>3} {'E':>5} | {'exact ms':>8} {'evals/s':>8} | {'numpy ms':>8} {'ratio':>5} "
          f"{'diff':>7} | {'AFT128 ms':>9} {'err':>7} | {'AFT1024 ms':>10} {'err':>7} {'ratio':>5} | "
          f"regimes (sep/stuck/switching)")
    for r in rows:
        reg, t = r["regimes"], r["exact_ms"]
        a1024 = r.get("aft1024_ms", float("nan"))
        print(f"{r['H']:>3} {r['E']:>5} | {t:8.2f} {r['E'] / t * 1e3:8.0f} | "
              f"{r['numpy_ms']:8.2f} {r['numpy_ms'] / t:5.1f} {r['numpy_diff']:7.0e} | "
              f"{r.get('aft128_ms', float('nan')):9.2f} {r.get('aft128_err', float('nan')):7.1e} | "
              f"{a1024:10.2f} {r.get('aft1024_err', float('nan')):7.1e} {a1024 / t:5.0f} | "
              f"{reg['separated']}/{reg['stuck']}/{reg['transitions']}")
    print("exact: the compiled kernel (contact.exact); numpy: the same mathematics in numpy "
          "(contact.exact_reference), diff = its largest difference in Fu and the Jacobian; "
          "ratio = time / exact time")
    print_friction2d(friction2d_rows(shroud_like_motions, _median_time, quick))
    return 0


def _paper_system(example, n):
    return example1(n) if example == 1 else example3(n)


def hbm(quick=False):
    """Frequency-response curves of paper Examples 1 and 3: HBM + continuation vs
    event-driven time integration of the same points (stepped, each started from
    the previous steady state)."""
    cases = [("Example 1, n = 2 N", 1, 2.0, 7, 150.0, 250.0),
             ("Example 1, n = 10 N", 1, 10.0, 7, 150.0, 250.0),
             ("Example 3, n0 = 10 N (folds)", 3, 10.0, 14, 0.5, 1.6)]
    logging.getLogger("pipeline.solve.time_integration.timesim").setLevel(logging.WARNING)  # its sweep's points
    print("Harmonic balance + continuation, exact forces, one core; stability by Hill "
          "(time), by the monodromy along the orbit (mono s); median of 3")
    print(f"{'case':<30} {'H':>3} {'time s':>7} {'mono s':>7} {'points':>6} {'Newton/pt':>9} "
          f"{'R evals/pt (total)':>18} {'peak':>10} {'at rad/s':>9} | {'time-int s':>10} "
          f"{'ratio':>6} {'peak err':>8}")
    for name, ex, n, H, w0, w1 in cases:
        system = _paper_system(ex, n)
        frequency_response(system, H, w0, w1)  # warm-up (caches, imports)
        t_hbm = _median_time(lambda: frequency_response(system, H, w0, w1), 1 if quick else 3)
        t_mono = _median_time(lambda: frequency_response(system, H, w0, w1, stability="monodromy"),
                              1 if quick else 3)
        c = frequency_response(system, H, w0, w1)
        a, om, i = c.peak(0)
        nit = float(np.mean(c.newton_iterations[c.newton_iterations > 0])) if c.n_points else 0
        # time integration of the same curve: every stable HBM frequency, in order
        sel = np.flatnonzero(c.stable & c.converged)
        if quick:
            sel = sel[:: max(1, sel.size // 10)]
        t = time.perf_counter()
        sw = timesim.sweep(system, c.omega[sel], direction="up", H=H)
        t_ti = time.perf_counter() - t
        if quick:
            t_ti *= len(np.flatnonzero(c.stable & c.converged)) / max(sel.size, 1)
        ti_peak = float(np.nanmax(np.where(sw.converged, sw.amplitude[:, 0], np.nan)))
        hb_peak = float(np.max(c.amplitude[sel, 0]))
        print(f"{name:<30} {H:>3} {t_hbm:7.2f} {t_mono:7.2f} {c.n_points:>6} {nit:9.2f} "
              f"{c.nfev / c.n_points:11.2f} ({c.nfev:>4}) {a:10.4g} {om:9.4g} | {t_ti:10.2f} "
              f"{t_ti / t_hbm:6.1f} {abs(ti_peak - hb_peak) / hb_peak:8.1e}")
    print("time-int: event-driven integration to steady state (shooting) at the same stable points"
          + (" (extrapolated from every 10th point)" if quick else ""))
    print("peak err: relative difference of the largest amplitude over those points; a stepped\n"
          "  up-sweep follows the lower branch past a softening peak (jump at the fold), so for\n"
          "  Example 3 it differs by design (tests compare at the peak, started from the HBM state)")
    aft_table(quick)
    return 0


def aft_table(quick=False):
    """Example 1 at 2 N, H = 7 with stability: the exact forces against AFT (the
    compiled march, `contact.aft`) at 128 and 1024 samples, in one run."""
    system = example1(2.0)
    print("\nExample 1, n = 2 N, H = 7, with stability: exact forces against AFT; median of "
          f"{1 if quick else 3}; load average {', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'forces':<10} {'time s':>7} {'ratio':>6} {'points':>6} {'R evals':>7} {'peak m':>11} "
          f"{'peak err':>8}")
    ref = None
    for name, kw in (("exact", {}), ("AFT-128", {"method": "aft", "n_samples": 128}),
                     ("AFT-1024", {"method": "aft", "n_samples": 1024})):
        frequency_response(system, 7, 150.0, 250.0, **kw)   # warm-up
        t = _median_time(lambda: frequency_response(system, 7, 150.0, 250.0, **kw),
                         1 if quick else 3)
        c = frequency_response(system, 7, 150.0, 250.0, **kw)
        a = c.peak(0)[0]
        ref = ref or (t, a)
        print(f"{name:<10} {t:7.3f} {t / ref[0]:6.2f} {c.n_points:>6} {c.nfev:>7} {a:11.5e} "
              f"{abs(a - ref[1]) / ref[1]:8.1e}")


def blade(quick=False):
    return run_blade(quick)


def disk_bench(quick=False):
    # not named `disk`: that is the submodule, which its import sets as this attribute
    return run_disk(quick)


def parallel(quick=False, studies=("paper_example1", "paper_example3", "paper_example1 x mu"),
             serial=True):
    """Wall time of whole studies: in this process, a 2-process pool and a Dask
    LocalCluster with 2 workers; the datasets must be identical (timing aside).
    "paper_example1 x mu": Example 1's preloads times mu = 0.3, 0.5, 0.7 (21 cases).
    Studies named on the command line (in studies/ or files) are run on the pool and
    the cluster only (serial=False): long studies, the two compared."""
    # deferred: the study layer imports xarray (slow), which the other benches never use
    import xarray as xr


    for name in ("pipeline", "distributed"):
        logging.getLogger(name).setLevel(logging.WARNING)
    root = Path(__file__).resolve().parents[2] / "studies"

    def same(a, b):
        a, b = (d.drop_vars(["wall_time", "optimum_search_wall_time"], errors="ignore") for d in (a, b))
        a.attrs.pop("created", None), b.attrs.pop("created", None)
        return a.identical(b)

    paths = [Path(name.split()[0]) for name in studies]
    paths = [p if p.suffix == ".toml" else root / f"{p}.toml" for p in paths]
    loaded = [load_study(p, quick=quick) for p in paths]   # a bad file: its error, no table
    print(f"{'study':<20} {'cases':>5} | {'serial s':>8} | {'pool-2 s':>8} {'speed-up':>8} | "
          f"{'dask-2 s':>8} {'speed-up':>8} | identical")
    for name, path, study in zip(studies, paths, loaded):
        if name.endswith("x mu"):
            study = replace(study, sweep=replace(study.sweep, axes={**study.sweep.axes,
                                                                    "mu": (0.3, 0.5, 0.7)}))
        # the cases only: the optimum-preload search after them is one serial search
        study = replace(study, output=replace(study.output, optimum=None))
        times, data = {}, {}
        with tempfile.TemporaryDirectory() as tmp:
            # serial last: warm caches, a conservative speed-up
            for how in ("pool", "dask", "serial") if serial else ("pool", "dask"):
                kw = dict(figures=False, progress=False, checkpoints=False)
                t = time.perf_counter()
                if how == "dask":
                    # deferred: Dask is optional (pip install -e ".[dask]")
                    from dask.distributed import LocalCluster
                    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None, silence_logs=logging.WARNING) as cluster:
                        t = time.perf_counter()  # cluster start-up not counted
                        res = run_study(study, Path(tmp) / how, scheduler=cluster.scheduler_address, **kw)
                        times[how] = time.perf_counter() - t
                else:
                    res = run_study(study, Path(tmp) / how, workers=1 if how == "serial" else 2, **kw)
                    times[how] = time.perf_counter() - t
                data[how] = res.dataset
        ref = data["serial"] if serial else data["pool"]
        ok = same(ref, data["pool"]) and same(ref, data["dask"])
        base = times["serial"] if serial else times["pool"]
        print(f"{path.stem:<20} {len(study.sweep.cases()):>5} | "
              f"{times['serial'] if serial else float('nan'):8.2f} | "
              f"{times['pool']:8.2f} {base / times['pool']:8.2f} | "
              f"{times['dask']:8.2f} {base / times['dask']:8.2f} | {'yes' if ok else 'NO'}",
              flush=True)
    print("pool: process start-up included; dask: cluster start-up excluded, client connection included"
          + ("" if serial else "; no serial run: the speed-ups are against the pool"))
    return 0


def evaluations_bench(quick=False):
    return run_evaluations(quick)


def stability_bench(quick=False):
    return run_stability(quick)


def peers_bench(quick=False, nlvib=None, pyharm_python=None):
    # not named `peers`: that is the submodule, which its import sets as this attribute
    return run_peers(quick, nlvib=nlvib, pyharm_python=pyharm_python)


def modes_bench(quick=False):
    return run_modes(quick)


def estimate_bench(quick=False, studies=()):
    return run_estimate(quick, studies)


def montecarlo_bench(quick=False):
    return run_montecarlo(quick)


BENCHES = {"contact": contact, "hbm": hbm, "evaluations": evaluations_bench, "blade": blade,
           "disk": disk_bench, "parallel": parallel, "peers": peers_bench,
           "stability": stability_bench, "estimate": estimate_bench, "modes": modes_bench,
           "montecarlo": montecarlo_bench, "interface": run_interface}


def run(what, quick=False, **options):
    """Run one bench; `options` go to it (`peers`: nlvib, pyharm_python; `estimate`:
    studies)."""
    if what not in BENCHES:
        raise ValueError(f"unknown benchmark {what!r}; choose from {sorted(BENCHES)}")
    return BENCHES[what](quick=quick, **options)
