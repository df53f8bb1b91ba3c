"""Datasets: xarray/netCDF layout of results and its conformance check."""
