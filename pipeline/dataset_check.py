"""Dataset contract check (placeholder: the full checker is written on another
branch; this minimal version only opens the file and looks for the two
essential variables)."""
from __future__ import annotations


def problems(path) -> list[str]:
    """What is wrong with the dataset at `path` (empty: nothing found)."""
    try:
        import xarray as xr
        with xr.open_dataset(path, engine="netcdf4") as ds:
            names = set(ds.variables)
    except Exception as exc:
        return [f"cannot be opened as netCDF ({type(exc).__name__})"]
    return [f"variable {v!r} missing" for v in ("frequency", "amplitude") if v not in names]
