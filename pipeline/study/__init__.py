"""Study files, their execution (sweeps, checkpoints, Dask), datasets and figures."""
