"""Finished cases on disk: one small netCDF file per case, read back without trust.

An interrupted run keeps each finished case in `DIR/.<name>.<key>.cases/case-NNNNN.nc`
(`pipeline.study.execution.run`).  The output directory is not a trusted place, so a case file is
data only: netCDF variables and attributes, no code runs when it is read.  A file
that does not read back as a complete case of the expected kind (corrupt, foreign,
from another layout) is ignored and its case is computed again.

The `ResponseCurve` (`pipeline.solve.response.response`) is serialised over its dataclass fields,
whatever they are: numpy arrays become variables (dimensions `<field>_0`,
`<field>_1`, ...; complex arrays as a trailing real/imaginary dimension), plain
scalars and strings go into the JSON attribute `scalars`, dicts (`info`) into JSON
attributes of their own.  A field added to the dataclass later round-trips without
a change here; a file written before it existed reads back with the field's default
(or is ignored when the field has none).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import os
import shutil
import uuid
from pathlib import Path

import numpy as np

from ... import __version__
from ...errors import interrupt_deferred
from ...solve.response.response import ResponseCurve
from ..files.study_types import content_bytes

log = logging.getLogger(__name__)

FORMAT = "shroud-pipeline case checkpoint"
VERSION = 1
SUFFIX = ".nc"


class NotACheckpoint(ValueError):
    """The file is not a complete case checkpoint of the expected kind."""


def _curve_type():
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
    # deferred: xarray (slow import), only when a case is kept
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
        ds = to_dataset(curve, case)
        with interrupt_deferred():   # never interrupted inside the netCDF library
            ds.to_netcdf(tmp, mode="w", format="NETCDF4", engine="netcdf4")
            os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def read(path, cls=None):
    """(case dict, curve) of a checkpoint file; NotACheckpoint for anything else
    (the file is only parsed as netCDF data, never executed)."""
    # deferred: xarray (slow import), only when kept cases are read
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


def checkpoint_dir(study, out_dir, solver) -> Path:
    """`DIR/.<name>.<key>.cases`: the key hashes the study text (or, a study built
    in Python, all its fields: `study_types.content_bytes`), the quick flag, the solver
    function and the pipeline version, so a changed study or software never reuses
    old cases."""
    fields = None if study.text else content_bytes(study)
    content = study.text or (hashlib.sha256(fields).hexdigest() if fields is not None
                             else f"not picklable: never reused {uuid.uuid4()}")
    ident = "\n".join([content, str(study.quick), repr(study.sweep), repr(study.solver),
                       f"{getattr(solver, '__module__', '')}.{getattr(solver, '__qualname__', solver)}",
                       __version__])
    key = hashlib.sha256(ident.encode()).hexdigest()[:16]
    return Path(out_dir) / f".{study.name}.{key}.cases"


def case_file(cdir: Path, k) -> Path:
    """The file of case k in the checkpoint folder `cdir`."""
    return cdir / f"case-{k:05d}{SUFFIX}"


def load_cases(cdir: Path, cases) -> dict:
    """{case index: (curve, None)} of the finished cases kept in `cdir`.  The files
    are read as data (`pipeline.study.execution.checkpoint`); one that is not a complete case of
    this grid position is ignored and that case computed again."""
    found = {}
    for k, (_, case) in enumerate(cases):
        f = case_file(cdir, k)
        if not f.is_file():
            continue
        try:
            kept_case, curve = read(f)
        except NotACheckpoint as exc:  # corrupt or foreign: recompute that case
            log.warning("ignoring %s (%s); that case is computed again", f, exc)
            continue
        if same_case(kept_case, case):
            found[k] = (curve, None)
        else:
            log.warning("ignoring %s (a different case); that case is computed again", f)
    return found


def save_case(cdir: Path, k, case, curve) -> bool:
    """Write case k atomically (`checkpoint.write`); False if it failed."""
    try:
        cdir.mkdir(parents=True, exist_ok=True)
        write(case_file(cdir, k), curve, case)
        return True
    except (OSError, TypeError) as exc:
        log.warning("cannot keep case %d on disk (%s); a rerun will recompute it", k, exc)
        return False


def kept_cases(out_dir, name) -> tuple:
    """(checkpoint folder, number of finished cases in it) of study `name` in
    `out_dir`, or (None, 0) when no folder holds a case."""

    for d in sorted(Path(out_dir).glob(f".{name}.*.cases")):
        n = len(list(d.glob(f"case-*{SUFFIX}")))
        if d.is_dir() and n:
            return d, n
    return None, 0


def remove_stale(out_dir: Path, name: str, keep: Path):
    """Checkpoints of an older version of the same study (other key) and temporary
    files of killed writers are removed."""
    for d in Path(out_dir).glob(f".{name}.*.cases"):
        if d != keep and d.is_dir():
            log.info("removing checkpoints of a different study version: %s", d)
            shutil.rmtree(d, ignore_errors=True)
    stale = (list(Path(out_dir).glob(f".{name}.nc.*.tmp")) + list(keep.glob(".case-*.tmp"))
             + list(keep.glob("case-*.pkl")))  # an older checkpoint format, never loaded
    for t in stale:
        t.unlink(missing_ok=True)
