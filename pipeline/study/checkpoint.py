"""Finished cases on disk: one small netCDF file per case, read back without trust.

An interrupted run keeps each finished case in `DIR/.<name>.<key>.cases/case-NNNNN.nc`
(`pipeline.study.run`).  The output directory is not a trusted place, so a case file is
data only: netCDF variables and attributes, no code runs when it is read.  A file
that does not read back as a complete case of the expected kind (corrupt, foreign,
from another layout) is ignored and its case is computed again.

The `ResponseCurve` (`pipeline.solve.response`) is serialised over its dataclass fields,
whatever they are: numpy arrays become variables (dimensions `<field>_0`,
`<field>_1`, ...; complex arrays as a trailing real/imaginary dimension), plain
scalars and strings go into the JSON attribute `scalars`, dicts (`info`) into JSON
attributes of their own.  A field added to the dataclass later round-trips without
a change here; a file written before it existed reads back with the field's default
(or is ignored when the field has none).
"""
from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
import uuid
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

FORMAT = "shroud-pipeline case checkpoint"
VERSION = 1
SUFFIX = ".nc"


class NotACheckpoint(ValueError):
    """The file is not a complete case checkpoint of the expected kind."""


def _curve_type():
    from ..solve.response import ResponseCurve
    return ResponseCurve


def _jsonable(value):
    """Plain Python values for JSON (numpy scalars unwrapped); others rejected."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    raise TypeError(f"cannot keep a {type(value).__name__} in a checkpoint")


def to_dataset(curve, case: dict):
    """An xarray.Dataset holding `curve` (any dataclass of arrays, scalars, strings
    and JSON-able dicts) and the grid case it belongs to."""
    import xarray as xr

    data_vars, scalars, attrs = {}, {}, {}
    for f in dataclasses.fields(curve):
        v = getattr(curve, f.name)
        if isinstance(v, np.ndarray):
            a = v
            if np.iscomplexobj(a):
                a = np.stack([a.real, a.imag], axis=-1)
            dims = tuple(f"{f.name}_{k}" for k in range(a.ndim))
            data_vars[f.name] = (dims, a, {"complex": int(np.iscomplexobj(v)),
                                           "array_dtype": str(v.dtype)})
        elif isinstance(v, dict):
            attrs[f"dict:{f.name}"] = json.dumps(_jsonable(v))
        else:
            scalars[f.name] = _jsonable(v)
    attrs.update({"format": FORMAT, "format_version": VERSION,
                  "type": type(curve).__name__, "case": json.dumps(_jsonable(case)),
                  "scalars": json.dumps(scalars)})
    return xr.Dataset(data_vars, attrs=attrs)


def from_dataset(ds, cls=None):
    """(case dict, curve) from a dataset written by `to_dataset`; NotACheckpoint if
    anything is missing or of the wrong kind."""
    cls = cls or _curve_type()
    a = ds.attrs
    if a.get("format") != FORMAT or int(a.get("format_version", -1)) != VERSION:
        raise NotACheckpoint("not a case checkpoint of this format")
    if a.get("type") != cls.__name__:
        raise NotACheckpoint(f"holds a {a.get('type')!r}, expected {cls.__name__!r}")
    try:
        case = json.loads(a["case"])
        scalars = json.loads(a["scalars"])
    except (KeyError, TypeError, ValueError) as exc:
        raise NotACheckpoint(f"unreadable attributes ({exc})") from None
    if not isinstance(case, dict) or not isinstance(scalars, dict):
        raise NotACheckpoint("unreadable attributes")
    kw = {}
    for f in dataclasses.fields(cls):
        if f.name in ds.variables:
            var = ds[f.name]
            v = np.asarray(var.values)
            if int(var.attrs.get("complex", 0)):
                v = v[..., 0] + 1j * v[..., 1]
            try:
                v = v.astype(np.dtype(str(var.attrs.get("array_dtype", v.dtype))), copy=False)
            except TypeError:
                raise NotACheckpoint(f"{f.name}: unknown dtype") from None
            if v.dtype.kind not in "biufc":
                raise NotACheckpoint(f"{f.name}: not numeric")
            kw[f.name] = v
        elif f"dict:{f.name}" in a:
            try:
                d = json.loads(a[f"dict:{f.name}"])
            except (TypeError, ValueError):
                raise NotACheckpoint(f"{f.name}: unreadable") from None
            if not isinstance(d, dict):
                raise NotACheckpoint(f"{f.name}: not a dict")
            kw[f.name] = d
        elif f.name in scalars:
            kw[f.name] = scalars[f.name]
        elif (f.default is dataclasses.MISSING
              and f.default_factory is dataclasses.MISSING):
            raise NotACheckpoint(f"field {f.name!r} missing")
    try:
        return case, cls(**kw)
    except (TypeError, ValueError) as exc:
        raise NotACheckpoint(f"does not build a {cls.__name__} ({exc})") from None


def write(path, curve, case: dict) -> Path:
    """Write atomically: a temporary `.<name>.<random>.tmp` beside `path`, then
    os.replace, so `path` is absent or complete."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        to_dataset(curve, case).to_netcdf(tmp, mode="w", format="NETCDF4", engine="netcdf4")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def read(path, cls=None):
    """(case dict, curve) of a checkpoint file; NotACheckpoint for anything else
    (the file is only parsed as netCDF data, never executed)."""
    import xarray as xr

    try:
        with xr.open_dataset(path, engine="netcdf4", decode_cf=True,
                             decode_times=False) as ds:
            ds = ds.load()
    except Exception as exc:  # not netCDF at all, truncated, ...
        raise NotACheckpoint(f"not readable as netCDF ({type(exc).__name__})") from None
    return from_dataset(ds, cls)


def same_case(a: dict, b: dict) -> bool:
    """Grid cases equal value by value (numbers as stored in JSON)."""
    if set(a) != set(b):
        return False
    for k in a:
        x, y = a[k], b[k]
        if isinstance(x, (int, float)) and isinstance(y, (int, float)):
            if not (x == y or (math.isnan(x) and math.isnan(y))):
                return False
        elif x != y:
            return False
    return True
