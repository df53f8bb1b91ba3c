"""`bench disk` builds its tables from real solves: the columns are there, the numbers
finite, the sector's nonlinear unknowns the same for every N, the full wheel sparse.
A correctness check on the smallest sizes, never a timing."""
import math

import numpy as np

from pipeline.bench import disk
from pipeline.structure.disk import wheel_shroud_width
from pipeline.structure.fe_model import DiskPlacement


def finite(row, keys):
    return all(math.isfinite(float(row[k])) for k in keys)


def test_bench_disk_hub_radius_keeps_the_shroud_width():
    for N in (6, 12, 96):
        disk_ = DiskPlacement(disk.hub_radius(disk.WHEEL_BLADE, N), N)
        assert abs(wheel_shroud_width(disk.WHEEL_BLADE, disk_) - disk.SHROUD_WIDTH) < 1e-12


def test_bench_disk_sector_table_has_the_same_unknowns_for_every_n():
    rows = disk.sector_table((6, 12), H=1, max_points=4, sweep_points=3)
    keys = ("N", "R", "dofs", "contact_dofs", "points", "s_curve", "ms_point", "ratio",
            "sweep_cpu_point", "ratio_sweep")
    for r in rows:
        assert set(keys) <= set(r) and finite(r, keys) and r["points"] >= 2
        assert r["sweep_converged"] == 3           # the stepped sine, shortened to 3 points
    assert rows[0]["contact_dofs"] == rows[1]["contact_dofs"] == 90   # 15 pairs x 2 faces x 3
    assert rows[0]["dofs"] == rows[1]["dofs"] and rows[0]["ratio"] == 1.0


def test_bench_disk_wheel_table_is_sparse_and_finite():
    (r,) = disk.wheel_table((12,), H=1, points=3, isolate=False)
    keys = ("N", "dofs", "contact_dofs", "points", "s_frf", "s_point", "growth", "rss_delta",
            "matrix_bytes", "jacobian_bytes")
    assert not r["skipped"] and set(keys) <= set(r) and finite(r, keys)
    assert r["points"] == 3 and r["pairs"] >= 4 and r["growth"] == 1.0
    assert r["dofs"] == 12 * r["sector_dofs"] > 160 and r["sparse"]
    # M, C, K, Bt, Bn stored block-sparse: about 1/N of five dense (N n)^2 matrices
    assert r["matrix_bytes"] < 0.25 * 5 * r["dofs"] ** 2 * 8
    assert r["contact_dofs"] == 12 * 6      # beam blades: the rigid tip shroud's 6 DOFs
    skipped = disk.wheel_table((6,), H=1, points=3, isolate=False, max_jacobian_bytes=1)
    assert skipped[0]["skipped"] and np.isnan(skipped[0]["growth"])
