"""The dataset contract of a nonlinear modes study (global attribute
`kind = "nonlinear_modes"`, `datasets.nonlinear_modes_dataset`), beyond the rules every
dataset meets (attributes, units, coordinates: `conformance`):

- `frequency` [Hz], `damping_ratio` [1], `modal_amplitude` [kg0.5 m] and `converged`
  on (case axes..., point), `message` on the case axes;
- `converged` is 0 or 1, and 1 on a leading run of each case's points (padding after);
- where converged: frequency and modal amplitude finite and positive (the modal
  amplitude may turn back where the backbone folds), the damping ratio finite; where
  not: all three NaN;
- where present, `stick_fraction` + `slip_fraction` + `separation_fraction` = 1 at
  every converged point and element.
"""
from __future__ import annotations

import numpy as np

REQUIRED = {"frequency": "Hz", "damping_ratio": "1", "modal_amplitude": "kg0.5 m",
            "converged": "1"}


def check_nonlinear_modes(ds, say) -> int:
    """Report departures through `say`; the number of converged backbone points."""
    for v, unit in REQUIRED.items():
        if v not in ds.variables:
            say(f"variable {v!r} is missing")
        elif ds[v].attrs.get("units") != unit:
            say(f"variable {v!r} has units {ds[v].attrs.get('units')!r}, expected {unit!r}")
    if "message" not in ds.variables:
        say("variable 'message' is missing")
    if any(v not in ds.variables for v in REQUIRED) or ds["frequency"].dims[-1:] != ("point",):
        if "frequency" in ds.variables:
            say("variable 'frequency' must end with the dimension 'point'")
        return 0
    conv = ds["converged"].values
    if not np.isin(conv, (0, 1)).all():
        say("variable 'converged' holds values other than 0 and 1")
        return 0
    ok = conv == 1
    if np.any(np.diff(ok.astype(int), axis=-1) > 0):
        say("variable 'converged': a converged point follows padding within a case")
    f, z, a = (ds[v].values for v in ("frequency", "damping_ratio", "modal_amplitude"))
    if not (np.all(np.isfinite(f[ok]) & (f[ok] > 0)) and np.all(np.isfinite(a[ok]) & (a[ok] > 0))
            and np.all(np.isfinite(z[ok]))):
        say("frequency, modal_amplitude (> 0) and damping_ratio must be finite where converged")
    if not np.all(np.isnan(f[~ok]) & np.isnan(a[~ok]) & np.isnan(z[~ok])):
        say("frequency, modal_amplitude and damping_ratio must be NaN where not converged")
    names = ("stick_fraction", "slip_fraction", "separation_fraction")
    if all(n in ds.variables for n in names):
        total = sum(ds[n].values for n in names)
        if np.any(np.abs(total[ok] - 1.0) > 1e-9):
            say("stick, slip and separation fractions must sum to 1 at every converged point")
    return int(ok.sum())
