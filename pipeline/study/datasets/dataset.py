"""A study dataset on disk: netCDF written atomically (`write_netcdf`) and read back
fully into memory (`read_dataset`), for every study kind's dataset (the response
layout: `response_dataset`; the contract: `conformance.dataset_check`).
"""
from __future__ import annotations

import os
import uuid
from pathlib import Path

import xarray as xr


def _encoding(ds: xr.Dataset) -> dict:
    enc = {}
    for name, var in ds.variables.items():
        if var.dtype.kind in "fiub" and var.ndim > 0:
            enc[name] = {"zlib": True, "complevel": 4, "shuffle": True}
    return enc


def write_netcdf(ds: xr.Dataset, path) -> Path:
    """Write `ds` to `path` atomically: a temporary file in the same directory,
    then os.replace, so `path` is either the old file, absent or complete."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # a fresh name in the same directory (same file system, so os.replace is atomic);
    # netCDF creates it, so the final file gets the usual umask permissions
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        ds.to_netcdf(tmp, mode="w", format="NETCDF4", engine="netcdf4", encoding=_encoding(ds))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def read_dataset(path) -> xr.Dataset:
    """Load a study dataset fully into memory (the file is closed on return)."""
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return ds.load()
