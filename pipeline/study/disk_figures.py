"""Figures of a mistuned disk study: the peak of every sector against the tuned disk.

A mistuned disk's dataset reports every sector's DOFs, either along a `sector`
dimension (DOF labels plain, `x1`) or in the DOF labels themselves (`x1@4`: x1 of
sector 4); `sector_and_dof` reads a label, `by_sector` gives one array with a
`sector` dimension per sector DOF in either layout.

The tuned reference is not in the dataset: `tuned_reference` solves the same disk
without mistuning (delta_j = 0) with the study's solver settings, on one sector by
the cyclic reduction (one small continuation per combination of the sweep axes other
than `mistuning_seed`, about a second each).  A tuned disk's sectors all have the
same amplitude, so its peak is one number per sector DOF.

Figures (`write_sector_figures`):
- `peak_per_sector_<dof>[_<axis>=<value>...].png`: the peak amplitude of each sector,
  one series per mistuning seed, against the tuned peak (horizontal line); the
  amplification factor max over sectors of the peak / tuned peak per seed in the
  legend, the largest in the title; a right-hand axis reads peak / tuned peak;
- `amplitude_<dof>_<axis>=<value>....png`, one per case: every sector's response
  curve (the sectors with the largest and the smallest peak in colour, the others
  thin grey) and the tuned disk's curve (black).  They replace one figure per
  sector, which spreads what belongs together over N files.
"""
from __future__ import annotations

import itertools
import logging
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..model.scene import build_system
from .cases import default_solver, run_case
from .spec import SWEEP_AXES

log = logging.getLogger("pipeline.study.disk_figures")
AT = "@"
SEED_AXIS = "mistuning_seed"


def sector_and_dof(label: str):
    """(sector or None, sector DOF name) of a DOF label: "x1@4" -> (4, "x1"),
    "x1" -> (None, "x1")."""
    d, sep, j = str(label).rpartition(AT)
    if sep and d and j.isdigit():
        return int(j), d
    return None, str(label)


def is_sector_resolved(study, ds) -> bool:
    """True for a mistuned disk's dataset (every sector's DOFs reported)."""
    if getattr(getattr(study, "scene", None), "mistuning", None) is None:
        return False
    return "sector" in ds.dims or any(sector_and_dof(d)[0] is not None
                                      for d in ds["dof"].values.tolist())


def by_sector(da) -> dict:
    """{sector DOF name: `da` of that DOF with a `sector` dimension (coordinate: the
    sector numbers)}, from either layout: a `sector` dimension, or `<dof>@<sector>`
    labels along `dof` (then `sector` takes the place of `dof`)."""
    import xarray as xr

    if "sector" in da.dims:
        return {str(d): da.sel(dof=d) for d in da["dof"].values.tolist()}
    groups: dict = {}
    for label in da["dof"].values.tolist():
        j, d = sector_and_dof(label)
        if j is not None:
            groups.setdefault(d, []).append((j, label))
    out = {}
    for d, pairs in groups.items():
        pairs.sort()
        parts = [da.sel(dof=label, drop=True) for _, label in pairs]
        out[d] = (xr.concat(parts, dim="sector").assign_coords(sector=[j for j, _ in pairs])
                  .transpose(*("sector" if x == "dof" else x for x in da.dims)))
    return out


@dataclass
class TunedCurve:
    """The tuned disk's response at one combination of the non-seed sweep axes."""

    frequency: np.ndarray    # (P,) in the study's frequency unit
    amplitude: dict          # sector DOF -> (P,) [m]
    stable: np.ndarray       # (P,) float: 1 stable, 0 unstable, NaN not computed
    converged: np.ndarray    # (P,) bool
    peak: dict               # sector DOF -> peak amplitude [m] (NaN if nothing converged)
    error: str | None = None


def tuned_reference(study, case: dict, dofs, solver=None) -> TunedCurve:
    """The disk of `study` without mistuning, one sector by the cyclic reduction,
    with the study's harmonics, forces, tolerances and frequency range; `case`
    holds the sweep values other than `mistuning_seed`."""

    scene = replace(study.scene, assembly=replace(study.scene.assembly, mistuning=None))
    fr, kw = study.sweep.frequency, study.solver.kwargs()
    idx = [scene.sector_dofs.index(d) for d in dofs]
    kw["peak_dofs"] = idx
    case = {a: v for a, v in case.items() if a != SEED_AXIS}
    t0 = time.perf_counter()
    curve, err = run_case(solver or default_solver(study), build_system(scene, case),
                          study.solver.harmonics, fr.omega_start, fr.omega_stop, kw)
    if curve is None:
        nan = {d: np.nan for d in dofs}
        return TunedCurve(np.empty(0), {d: np.empty(0) for d in dofs}, np.empty(0),
                          np.empty(0, bool), nan, err or "failed")
    om = np.asarray(curve.omega, float) / fr.to_rad_s
    amp = np.asarray(curve.amplitude, float)
    conv = np.asarray(curve.converged, bool) & np.isfinite(om)
    stable = (np.asarray(curve.stable, bool).astype(float) if study.solver.stability
              else np.full(om.shape, np.nan))
    amps, peaks = {}, {}
    for d, i in zip(dofs, idx):
        a = amp[:, i]
        ok = conv & np.isfinite(a)
        amps[d] = a
        peaks[d] = float(a[ok].max()) if ok.any() else np.nan
    log.info("%s: tuned reference%s: peak %s in %.1f s", study.name,
             f" ({case})" if case else "",
             ", ".join(f"{d} {p:.4g} m" for d, p in peaks.items()), time.perf_counter() - t0)
    return TunedCurve(om, amps, stable, conv, peaks)


def _case_text(case: dict) -> str:
    parts = []
    for a, v in case.items():
        if a == SEED_AXIS:
            parts.append(f"seed {v:g}")
        else:
            unit = _axis_unit(a)
            parts.append(f"{a} = {v:g}" + (f" {unit}" if unit not in ("", "1") else ""))
    return ", ".join(parts)


def _axis_unit(axis: str) -> str:
    return SWEEP_AXES.get(axis, ("",))[0]


def _suffix(case: dict) -> str:
    return "".join(f"_{a}={v:g}" for a, v in case.items())


def write_sector_figures(study, ds, fig_dir, tuned=None) -> list:
    """The figures of a mistuned disk study (module docstring); `tuned`: a function
    (case without the seed) -> TunedCurve, by default `tuned_reference`."""
    from .plots import response_curves_figure, sector_peaks_figure, stability_for_plot

    fig_dir = Path(fig_dir)
    axes = dict(study.sweep.axes)
    other = [a for a in axes if a != SEED_AXIS]
    peaks, amps = by_sector(ds["peak_amplitude"]), by_sector(ds["amplitude"])
    dofs = list(peaks)
    unit = ds["frequency"].attrs.get("units", "")
    if tuned is None:
        def tuned(case):
            return tuned_reference(study, case, dofs)
    fixed_seed = getattr(study.scene.mistuning, "seed", None)
    paths = []
    for combo in itertools.product(*(range(len(axes[a])) for a in other)):
        group = {a: axes[a][i] for a, i in zip(other, combo)}
        ref = tuned(group)
        seeds = range(len(axes[SEED_AXIS])) if SEED_AXIS in axes else [None]
        cases = []
        for s in seeds:
            sel = dict(zip(other, combo))
            case = dict(group)
            if s is not None:
                sel[SEED_AXIS] = s
                case = {a: (axes[SEED_AXIS][s] if a == SEED_AXIS else group[a]) for a in axes}
            elif fixed_seed is not None:
                case = {SEED_AXIS: fixed_seed, **group}
            cases.append((sel, case))
        group_text = _case_text(group)
        for d in dofs:
            series = [(_case_text({SEED_AXIS: c[SEED_AXIS]}) if SEED_AXIS in c else "",
                       peaks[d].isel(sel).values) for sel, c in cases]
            title = f"{study.title}" + (f", {group_text}" if group_text else "")
            paths.append(sector_peaks_figure(
                fig_dir / f"peak_per_sector_{d}{_suffix(group)}.png",
                peaks[d]["sector"].values, series, ref.peak[d], dof=d, title=title,
                tuned_note=ref.error))
            for sel, case in cases:
                sub = ds.isel(sel)
                a = amps[d].isel(sel)            # (point, sector)
                pk = peaks[d].isel(sel).values
                branches = [_tuned_branch(ref, d)] if ref.frequency.size else []
                branches += _sector_branches(sub["frequency"].values,
                                             a.transpose("point", "sector").values,
                                             a["sector"].values, pk,
                                             stability_for_plot(sub["stable"]),
                                             sub["converged"].values)
                paths.append(response_curves_figure(
                    fig_dir / f"amplitude_{d}{_suffix(case)}.png", branches,
                    xlabel=f"excitation frequency [{unit}]",
                    ylabel=f"amplitude of {d} [m]",
                    title=f"{study.title}, {_case_text(case)}: every sector",
                    yscale=study.output.yscale))
    return paths


def _tuned_branch(ref: TunedCurve, d: str):
    return ("tuned disk (no mistuning)", ref.frequency, ref.amplitude[d], ref.stable,
            ref.converged, dict(color="k", lw=2.2, zorder=3))


def _sector_branches(f, a, sectors, peak, stable, conv) -> list:
    """Sector curves: the largest and the smallest peak in colour, the others grey."""
    ok = np.isfinite(peak)
    hi = int(np.nanargmax(peak)) if ok.any() else -1
    lo = int(np.nanargmin(peak)) if ok.any() else -1
    out, grey_labelled = [], False
    for k, j in enumerate(sectors):
        if k in (hi, lo):
            continue
        label = None if grey_labelled else "other sectors"
        grey_labelled = True
        out.append((label, f, a[:, k], stable, conv, dict(color="0.6", lw=0.8, zorder=1)))
    if lo >= 0 and lo != hi:
        out.append((f"sector {sectors[lo]}: smallest peak", f, a[:, lo], stable, conv,
                    dict(color="tab:blue", lw=1.4, zorder=2)))
    if hi >= 0:
        out.append((f"sector {sectors[hi]}: largest peak", f, a[:, hi], stable, conv,
                    dict(color="tab:red", lw=1.4, zorder=2)))
    return out


def nodal_diameter_figure(path, ds):
    """Frequency against nodal diameter (the interference diagram's frequency axis),
    one line per mode family, contacts stuck (solid) and open (dashed): an engine
    order EO excites the column ND = EO, between its open and stuck frequencies."""
    from .plots import atomic_savefig, pyplot   # deferred: matplotlib on first figure

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    nd = ds.nodal_diameter.values
    for m in range(ds.sizes["mode"]):
        c = f"C{m % 10}"
        ax.plot(nd, ds.frequency_stuck.values[:, m], "o-", color=c, ms=4,
                label="stuck" if m == 0 else None)
        ax.plot(nd, ds.frequency_open.values[:, m], "s--", color=c, ms=3, mfc="none",
                label="open" if m == 0 else None)
    ax.set_xlabel("nodal diameter [-]")
    ax.set_ylabel("natural frequency [Hz]")
    ax.set_xticks(nd if nd.size <= 25 else nd[::max(1, nd.size // 12)])
    ax.set_title(ds.attrs.get("title", ""), fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(title="contacts", fontsize=8)
    out = atomic_savefig(fig, path)
    plt.close(fig)
    return out
