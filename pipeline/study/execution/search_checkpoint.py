"""The optimum-preload search's evaluations on disk, so an interrupted search resumes.

Beside the finished cases (`pipeline.study.execution.checkpoint`), the search keeps every
evaluation preload -> (peak, its frequency) in `DIR/.<name>.<key>.cases/optimum-search.nc`,
rewritten atomically after each one.  A resumed search (`peak_tracking.optimum_preload`,
replay = these values) reuses each when it comes to its preload, not before; its trial
preloads depend only on the values, so it visits the same preloads as an uninterrupted
search, values Brent's trials alike and ends at the same optimum.

The file is data only (netCDF variables `preload` [N] (an interference search's
`interference` [m], its identity's `variable`), `peak` [m], `peak_omega`
[rad/s] on one dimension, `state` [m] the Fourier coefficients of all DOFs at each
peak (where the peak continued in preload starts: a resumed search needs no band
evaluation again for them; NaN where not kept), and the search's identity as a JSON
attribute: the DOF, bounds, window, tolerance and grid density).  A file that is not
readable, of another kind, or of a different search is ignored: the search then
starts afresh.
"""
from __future__ import annotations

import json
import logging
import os
import uuid
from pathlib import Path

import numpy as np

from ...errors import interrupt_deferred
from ..files.study_types import OPTIMUM_UNITS

log = logging.getLogger(__name__)

FORMAT = "shroud-pipeline optimum-search checkpoint"
VERSION = 2
FILE = "optimum-search.nc"


def search_file(cdir) -> Path:
    """The search's file in the checkpoint folder `cdir`."""
    return Path(cdir) / FILE


def save_search(cdir, identity: dict, evaluations: dict, states=None) -> bool:
    """Write {n0: (peak, omega)} and the peak states {n0: Q (n_dof, 2H+1) or None}
    atomically (temporary file, then os.replace); False (logged) if it cannot be
    written: the search goes on, a rerun recomputes."""
    # deferred: xarray (slow import), only when a search is kept
    import xarray as xr

    keys = sorted(evaluations)
    arr = np.array([[k, *evaluations[k]] for k in keys], dtype=float).reshape(-1, 3)
    given = [q for q in (states or {}).values() if q is not None]
    shape = np.shape(given[0]) if given else (0, 0)
    Q = np.full((len(keys), *shape), np.nan)
    for i, k in enumerate(keys):
        if (states or {}).get(k) is not None:
            Q[i] = states[k]
    var = identity.get("variable", "preload")
    ds = xr.Dataset(
        {var: ("evaluation", arr[:, 0], {"units": OPTIMUM_UNITS[var]}),
         "peak": ("evaluation", arr[:, 1], {"units": "m"}),
         "peak_omega": ("evaluation", arr[:, 2], {"units": "rad/s"}),
         "state": (("evaluation", "dof", "coefficient"), Q, {"units": "m"})},
        attrs={"format": FORMAT, "format_version": VERSION,
               "identity": json.dumps(identity, sort_keys=True)})
    path = search_file(cdir)
    tmp = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with interrupt_deferred():   # never interrupted inside the netCDF library
            ds.to_netcdf(tmp, mode="w", format="NETCDF4", engine="netcdf4")
            os.replace(tmp, path)
        return True
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        log.warning("cannot keep the optimum search on disk (%s); a rerun recomputes it", exc)
        return False
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def load_search(cdir, identity: dict, with_states: bool = False):
    """{n0: (peak, omega)} kept by an interrupted search with the same `identity`;
    {} when there is none or the file is not one (then it is ignored, and logged).
    with_states: (that dict, {n0: Q} of the peak states kept)."""
    # deferred: xarray (slow import), only when a kept search is read
    import xarray as xr

    empty = ({}, {}) if with_states else {}
    path = search_file(cdir)
    if not path.is_file():
        return empty
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            ds = ds.load()
        if ds.attrs.get("format") != FORMAT or int(ds.attrs.get("format_version", -1)) != VERSION:
            raise ValueError("not an optimum-search checkpoint of this format")
        if json.loads(ds.attrs["identity"]) != json.loads(json.dumps(identity, sort_keys=True)):
            raise ValueError("kept by a different search")
        arr = [np.asarray(ds[v].values, dtype=float)
               for v in (identity.get("variable", "preload"), "peak", "peak_omega")]
        if any(a.ndim != 1 or a.size != arr[0].size for a in arr):
            raise ValueError("arrays of different shapes")
        if not np.all(np.isfinite(arr[0])):
            raise ValueError("a preload is not finite")
        Q = np.asarray(ds["state"].values, dtype=float)
        if Q.ndim != 3 or Q.shape[0] != arr[0].size:
            raise ValueError("states of another shape")
    except Exception as exc:  # corrupt, foreign, another search: start afresh
        log.warning("ignoring %s (%s); the optimum search starts afresh", path, exc)
        return empty
    kept = {float(n0): (float(p), float(om)) for n0, p, om in zip(*arr)}
    if not with_states:
        return kept
    return kept, {float(n0): q for n0, q in zip(arr[0], Q) if q.size and np.isfinite(q).all()}
