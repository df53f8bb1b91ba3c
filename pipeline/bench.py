"""Benchmarks that print tables (`python -m pipeline bench WHAT`).

Timings are wall-clock medians of repeated calls on this machine; every table
also reports the accuracy reached, because speed without accuracy means nothing.
"""
from __future__ import annotations

import time

import numpy as np


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
    from .contact import YangMenq

    rng = np.random.default_rng(seed)
    dec = np.repeat(0.3 ** np.arange(H), 2)
    U = np.zeros((E, 2 * H + 1))
    V = np.zeros((E, 2 * H + 1))
    U[:, 1:] = rng.normal(size=(E, 2 * H)) * dec
    V[:, 1:] = rng.normal(size=(E, 2 * H)) * dec * 0.5
    elem = YangMenq(ku=1.0, kv=1.0, mu=0.4, n0=rng.uniform(-0.5, 2.0, E))
    return U, V, elem


def contact(quick=False):
    """Exact vs AFT evaluations of the Yang-Menq element, with Jacobian."""
    from .contact import forces
    from .harmonics import basis

    rows = []
    for H in (1, 7, 21):
        for E in (100, 1000):
            U, V, elem = shroud_like_motions(E, H)
            tau = np.linspace(0, 2 * np.pi, 2001)
            nmax = np.maximum((elem.n0[:, None] + elem.kv[:, None] * (V @ basis(tau, H).T)).max(1), 1e-9)
            scale = elem.mu * nmax
            ref = forces(U, V, elem, "exact")
            rep = 3 if quick else 7
            t_ex = _median_time(lambda: forces(U, V, elem, "exact"), rep)
            row = {"H": H, "E": E, "regimes": ref.regimes, "exact_ms": 1e3 * t_ex}
            for N in (128, 1024):
                if N < 2 * H + 1:
                    continue
                t_a = _median_time(lambda: forces(U, V, elem, "aft", n_samples=N), max(1, rep // 2))
                fa = forces(U, V, elem, "aft", n_samples=N, jacobian=False)
                err = np.max(np.max(np.abs(fa.Fu - ref.Fu), 1) / scale)
                row[f"aft{N}_ms"], row[f"aft{N}_err"] = 1e3 * t_a, err
            rows.append(row)
    print("Yang-Menq element, forces + Jacobian, one core (numpy); error = max |F - F_exact| / (mu max n)")
    print(f"{'H':>3} {'E':>5} | {'exact ms':>9} {'evals/s':>9} | {'AFT128 ms':>9} {'err':>8} | "
          f"{'AFT1024 ms':>10} {'err':>8} | regimes (sep/stuck/switching)")
    for r in rows:
        reg = r["regimes"]
        print(f"{r['H']:>3} {r['E']:>5} | {r['exact_ms']:9.2f} {r['E'] / r['exact_ms'] * 1e3:9.0f} | "
              f"{r.get('aft128_ms', float('nan')):9.2f} {r.get('aft128_err', float('nan')):8.1e} | "
              f"{r.get('aft1024_ms', float('nan')):10.2f} {r.get('aft1024_err', float('nan')):8.1e} | "
              f"{reg['separated']}/{reg['stuck']}/{reg['transitions']}")
    return 0


BENCHES = {"contact": contact}


def run(what, quick=False):
    if what not in BENCHES:
        raise ValueError(f"unknown benchmark {what!r}; choose from {sorted(BENCHES)}")
    return BENCHES[what](quick=quick)
