"""Dataset contract of the per-contact variables (`contact_dataset`) and the response
coefficients (`harmonics_dataset`), for `dataset_check`:

- `preload_given` is "n0" or "static_normal_load" wherever `static_normal_load` is;
- per-point contact variables are NaN exactly at the points that did not converge;
- fractions lie in [0, 1] and stick + slip + separation = 1 (1e-9);
- dissipated energies and normal-load means are >= 0, and each contact's
  `dissipated_energy` is the sum of its elements' (`pair_contact`, 1e-9 relative);
- `harmonic_coefficient`'s sine part of harmonic 0 is 0, and hypot(cos, sin) is
  `harmonic_amplitude` (1e-9 relative).
"""
from __future__ import annotations

import numpy as np

FRACTIONS = ("stick_fraction", "slip_fraction", "separation_fraction")
PER_POINT = FRACTIONS + ("dissipated_energy_pair", "dissipated_energy",
                         "normal_load_mean_pair", "normal_load_mean",
                         "normal_load_amplitude_pair")
RTOL = 1e-9


def check_contacts(ds, converged, say):
    """Say every departure of the contact variables of `ds` from the module doc's
    rules; `converged` the dataset's converged flags (sweeps..., point)."""
    if "static_normal_load" in ds and ds.attrs.get("preload_given") not in (
            "n0", "static_normal_load"):
        say("global attribute 'preload_given' must be 'n0' or 'static_normal_load' "
            f"(got {ds.attrs.get('preload_given')!r})")
    for name in PER_POINT:
        if name not in ds:
            continue
        v = ds[name]
        ok = converged.broadcast_like(v).values
        vals = v.values
        if np.any(np.isnan(vals[ok])) or np.any(np.isfinite(vals[~ok])):
            say(f"variable {name!r} must be finite exactly at converged points")
        if np.any(vals[ok] < -RTOL * max(1.0, float(np.nanmax(np.abs(vals), initial=0.0)))):
            say(f"variable {name!r} has negative values")
        if name in FRACTIONS and np.any(vals[ok] > 1.0 + RTOL):
            say(f"variable {name!r} exceeds 1")
    if all(f in ds for f in FRACTIONS):
        total = sum(ds[f] for f in FRACTIONS).values
        if np.any(np.abs(total[np.isfinite(total)] - 1.0) > RTOL):
            say("stick_fraction + slip_fraction + separation_fraction must be 1")
    if "dissipated_energy" in ds and "dissipated_energy_pair" in ds and "pair_contact" in ds:
        pair = ds["dissipated_energy_pair"].fillna(0.0)
        summed = pair.groupby(ds["pair_contact"]).sum("pair").values
        face = np.nan_to_num(ds["dissipated_energy"].values)
        idx = ds["pair_contact"].values
        ref = np.take(face, np.unique(idx), axis=-1)
        if not np.allclose(summed, ref, rtol=RTOL, atol=RTOL * (np.abs(face).max() + 1e-300)):
            say("variable 'dissipated_energy' is not the sum of 'dissipated_energy_pair' over "
                "each contact's elements")
    if "harmonic_coefficient" in ds:
        hc = ds["harmonic_coefficient"]
        s0 = hc.sel(component="sin", harmonic=0).values
        if np.any(s0[np.isfinite(s0)] != 0.0):
            say("variable 'harmonic_coefficient' has a sine part at harmonic 0")
        if "harmonic_amplitude" in ds:
            amp = np.hypot(hc.sel(component="cos"), hc.sel(component="sin"))
            ref = ds["harmonic_amplitude"].broadcast_like(amp).values
            a = amp.values
            both = np.isfinite(a) & np.isfinite(ref)
            if not np.allclose(a[both], ref[both], rtol=RTOL, atol=0.0):
                say("hypot of 'harmonic_coefficient' is not 'harmonic_amplitude'")
