"""Test configuration: single-threaded BLAS (small dense systems), headless plots.

Set before numpy is imported by any test module (see pipeline/__init__.py).
"""
import os

for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")
os.environ.setdefault("MPLBACKEND", "Agg")
