"""Reduced-order study pipeline for shrouded bladed disks with dry friction.

Data flows one way: FE model -> reduction -> assembly with contact -> HBM ->
continuation -> study / dataset.  See README.md.
"""
import os as _os

# The dense systems here are small (contact DOFs x harmonics): BLAS threads cost
# more than they give (measured 0.14 ms vs 1.1 ms per 115x115 solve on 2 cores),
# and parallel studies run one process per core.  Set the variables yourself
# before importing to override.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

__version__ = "0.1.0"
