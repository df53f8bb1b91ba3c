"""The 2D friction law's cost next to the 1D element (`python -m pipeline bench contact`).

The same shroud-like motions as the Yang-Menq table (`bench.shroud_like_motions`), with
a second tangent of the same statistics: forces + Jacobian of `contact.friction2d` by
AFT at 128 and 256 samples, against the exact 1D kernel on the first tangent alone
(ratio = 2D time / 1D exact time), one thread, median of repeats."""
from __future__ import annotations

import numpy as np

from ..contact import forces
from ..contact.friction2d.law import Friction2D


def friction2d_rows(motions, median_time, quick=False) -> list:
    """[(H, E, 1D exact ms, {N: 2D ms}, regimes)] for H = 1, 7 and E = 100, 1000."""
    rows = []
    rep = 3 if quick else 7
    for H in (1, 7):
        for E in (100, 1000):
            U, V, elem = motions(E, H)
            U2 = motions(E, H, seed=1)[0]
            X = np.stack([U, U2, V], axis=1)
            law = Friction2D(ku=elem.ku, kv=elem.kv, mu=np.maximum(elem.mu, 1e-12), n0=elem.n0)
            law.evaluate(X, n_samples=128)                 # compile or load the kernel
            t1 = median_time(lambda: forces(U, V, elem, "exact"), 3 * rep)
            t2 = {N: median_time(lambda N=N: law.evaluate(X, n_samples=N), rep)
                  for N in (128, 256)}
            rows.append((H, E, 1e3 * t1, {N: 1e3 * t for N, t in t2.items()},
                         law.evaluate(X, n_samples=256).regimes))
    return rows


def print_friction2d(rows) -> None:
    print("\n2D friction law (contact.friction2d, AFT), forces + Jacobian, one thread; "
          "ratio = its time / the 1D exact element's on the first tangent")
    print(f"{'H':>3} {'E':>5} | {'1D exact ms':>11} | {'2D AFT128 ms':>12} {'ratio':>5} | "
          f"{'2D AFT256 ms':>12} {'ratio':>5} | separating/stuck/slipping, periods max")
    for H, E, t1, t2, reg in rows:
        print(f"{H:>3} {E:>5} | {t1:11.2f} | {t2[128]:12.2f} {t2[128] / t1:5.1f} | "
              f"{t2[256]:12.2f} {t2[256] / t1:5.1f} | {reg['separating']}/{reg['stuck']}/"
              f"{reg['slipping']}, {reg['periods_max']}")
