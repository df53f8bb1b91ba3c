"""Benchmark of the blade FE + Craig-Bampton chain: `python -m pipeline bench blade`.

Three tables:
1. solid cantilever (no shroud) -> Euler-Bernoulli flapwise f1..f3 under refinement;
2. Craig-Bampton convergence of the first 10 frequencies in the mode count;
3. cost of assembly, factorisation of K_ii, fixed-interface modes (40), constraint
   modes (all shroud DOFs kept) and projection for solid blades of ~10k, 50k, 100k
   DOFs, each in a fresh process so that the peak resident memory (ru_maxrss) is
   that of the one size; wall times per step, and the process CPU time of the whole
   (with single-threaded BLAS it stays near the wall time on a quiet machine and
   grows less than it when other work shares the cores).  quick: table 3 for ~10k
   DOFs only, coarse tables 1-2.
"""
from __future__ import annotations

import multiprocessing as mp
import resource
import time
from dataclasses import replace

import numpy as np

from ..structure.beam import euler_bernoulli_frequencies
from ..structure.blades import build_blade
from ..structure.fe_model import BladeParams
from ..structure.reduction import eigenmodes, modal_convergence, reduce_blade

# (n_chord, n_thick, n_span) of the default blade giving ~10k, ~50k, ~100k DOFs
SIZES = {"10k": (8, 2, 20), "50k": (12, 3, 40), "100k": (12, 3, 84)}
N_MODES = 40


def _cost(mesh) -> dict:
    nc, nt, ns = mesh
    c0 = time.process_time()
    t0 = time.perf_counter()
    blade = build_blade(BladeParams(n_chord=nc, n_thick=nt, n_span=ns))
    t_asm = time.perf_counter() - t0
    red = reduce_blade(blade, N_MODES)
    cpu = time.process_time() - c0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2  # KiB -> GiB
    return {"cpu": cpu, "n_dof": blade.n_dof, "n_b": red.n_boundary, "assembly": t_asm,
            "nnz_LU": red.info["nnz_LU"], **red.info["times"], "rss_gb": rss,
            "f1": red.frequencies[0]}


def cost_table(sizes) -> list[dict]:
    """Run `_cost` for each mesh in a fresh (spawned) process."""
    ctx = mp.get_context("spawn")
    rows = []
    for name in sizes:
        with ctx.Pool(1) as pool:
            rows.append({"size": name, **pool.apply(_cost, (SIZES[name],))})
    return rows


def euler_bernoulli_table(quick: bool):
    base = BladeParams(length=0.1, chord=0.01, thickness=0.005, shroud=False,
                       stagger_angle=0.0)
    ref = euler_bernoulli_frequencies(base, 3)
    meshes = [(1, 1, 4), (2, 1, 8), (2, 2, 16)] + ([] if quick else [(4, 2, 32)])
    rows = []
    for nc, nt, ns in meshes:
        blade = build_blade(replace(base, n_chord=nc, n_thick=nt, n_span=ns))
        w2, X = eigenmodes(blade.K, blade.M, 8)
        # flap modes: Y (thickness) displacement dominant and even in the chordwise x
        # (torsion moves Y too, but odd in x)
        dofs = blade.point_dofs
        ok = np.all(dofs >= 0, axis=1)
        U = X[dofs[ok]]  # (points, 3, modes)
        x = blade.points[ok, 0]
        norms = np.linalg.norm(U, axis=0)  # (3, modes)
        odd = abs(x @ U[:, 1]) / (np.linalg.norm(x) * norms[1])
        flap = (norms[1] > np.maximum(norms[0], norms[2])) & (odd < 0.1)
        f = (np.sqrt(w2) / (2 * np.pi))[flap][:3]
        rows.append((blade.n_dof, f, f / ref - 1))
    return ref, rows


def run(quick: bool) -> int:
    """Print the three tables; returns 0 (CLI exit code)."""
    ref, rows = euler_bernoulli_table(quick)
    print("Solid cantilever 0.1 x 0.01 x 0.005 m (Hex2) vs Euler-Bernoulli flapwise")
    print(f"{'DOFs':>8} " + " ".join(f"{'f%d [Hz]' % (k + 1):>11} {'err':>8}" for k in range(3)))
    print(f"{'EB':>8} " + " ".join(f"{x:11.2f} {'':>8}" for x in ref))
    for n, f, e in rows:
        print(f"{n:8d} " + " ".join(f"{x:11.2f} {y:+8.3%}" for x, y in zip(f, e)))

    counts = [0, 5, 10, 20, 40] if quick else [0, 5, 10, 20, 40, 80]
    p = BladeParams() if not quick else BladeParams(n_chord=6, n_thick=1, n_span=12)
    res = modal_convergence(p, counts)
    print(f"\nCraig-Bampton, shrouded blade ({int(res['n_dof'])} DOFs, "
          f"{int(res['n_boundary'])} boundary DOFs): max/mean rel. error of f1..f10")
    print(f"{'modes':>6} {'max err':>10} {'mean err':>10} {'f10 [Hz]':>10} {'time [s]':>9}")
    print(f"{'full':>6} {'':>10} {'':>10} {res['full_hz'][-1]:10.1f} "
          f"{float(res['time_full_s']):9.2f}")
    for m, e, f, t in zip(res["mode_counts"], res["rel_error"], res["reduced_hz"],
                          res["time_reduce_s"]):
        print(f"{m:6d} {e.max():10.2e} {e.mean():10.2e} {f[-1]:10.1f} {t:9.2f}")

    sizes = ["10k"] if quick else ["10k", "50k", "100k"]
    table = cost_table(sizes)
    print(f"\nCost of Craig-Bampton with {N_MODES} modes, all shroud DOFs kept [s]")
    cols = ["n_dof", "n_b", "nnz_LU", "assembly", "factorize", "normal_modes",
            "constraint_modes", "projection", "total", "cpu", "rss_gb"]
    print(" ".join(f"{c:>16}" for c in ["size"] + cols))
    for r in table:
        r["total"] = sum(r[k] for k in ("assembly", "partition", "factorize", "normal_modes",
                                        "constraint_modes", "projection", "damping"))
        vals = [r["size"]] + [r[c] if isinstance(r[c], (int, np.integer)) else f"{r[c]:.2f}"
                              for c in cols]
        print(" ".join(f"{v:>16}" for v in vals))
    return 0


if __name__ == "__main__":
    import sys
    sys.exit(run("--quick" in sys.argv))
