"""Figures of a mistuned disk study: the peak of every sector against the tuned disk.

A mistuned disk's dataset reports every sector's DOFs, either along a `sector`
dimension (DOF labels plain, `x1`) or in the DOF labels themselves (`x1@4`: x1 of
sector 4); `sector_and_dof` reads a label, `by_sector` gives one array with a
`sector` dimension per sector DOF in either layout.

The tuned reference (`mistuned.tuned_reference`: the same disk without mistuning, on
one sector by the cyclic reduction) is computed by the run, which stores its peak
and the amplification factors in the dataset; the figures take the run's tuned
curves, or solve them again when drawn from a dataset alone.

Figures (`write_sector_figures`):
- `peak_per_sector_<dof>[_<axis>=<value>...].png`: the peak amplitude of each sector,
  one series per mistuning seed, against the tuned peak (horizontal line); the
  amplification factor max over sectors of the peak / tuned peak per seed in the
  legend, the largest in the title; a right-hand axis reads peak / tuned peak;
  beyond MAX_SEED_SERIES seeds, each sector's distribution over the seeds instead
  (P5-P95 bar, median, the worst seed's peaks marked);
- `amplitude_<dof>_<axis>=<value>....png`, one per case (not with `[output] curves =
  false`: the cases kept their peaks only): every sector's response
  curve (the sectors with the largest and the smallest peak in colour, the others
  thin grey) and the tuned disk's curve (black).  They replace one figure per
  sector, which spreads what belongs together over N files;
- `amplification_<dof>.png` (with a `mistuning_seed` axis): the distribution of the
  amplification factor over the seeds (a Monte-Carlo sample) per preload (or per
  value of the first other axis) as empirical CDFs with P5 / P50 / P95 marked,
  `amplification_figure`.
"""
from __future__ import annotations

import itertools
import logging
from pathlib import Path

import numpy as np

from ..execution.mistuned import SEED_AXIS, TunedCurve, tuned_reference
from . import plots
from ..files.study_types import SWEEP_AXES

log = logging.getLogger("pipeline.study.figures.disk_figures")
AT = "@"


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
    # deferred: xarray (slow import), only when figures are drawn
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
            draw = (plots.sector_peaks_figure if len(series) <= MAX_SEED_SERIES
                    else plots.sector_peaks_distribution_figure)
            paths.append(draw(
                fig_dir / f"peak_per_sector_{d}{_suffix(group)}.png",
                peaks[d]["sector"].values, series, ref.peak[d], dof=d, title=title,
                tuned_note=ref.error))
            for sel, case in (cases if getattr(study.output, "curves", True) else ()):
                sub = ds.isel(sel)
                a = amps[d].isel(sel)            # (point, sector)
                pk = peaks[d].isel(sel).values
                branches = [_tuned_branch(ref, d)] if ref.frequency.size else []
                branches += _sector_branches(sub["frequency"].values,
                                             a.transpose("point", "sector").values,
                                             a["sector"].values, pk,
                                             plots.stability_for_plot(sub["stable"]),
                                             sub["converged"].values)
                paths.append(plots.response_curves_figure(
                    fig_dir / f"amplitude_{d}{_suffix(case)}.png", branches,
                    xlabel=f"excitation frequency [{unit}]",
                    ylabel=f"amplitude of {d} [m]",
                    title=f"{study.title}, {_case_text(case)}: every sector",
                    yscale=study.output.yscale))
    if SEED_AXIS in axes and "amplification_factor" in ds:
        for d in dofs:
            paths.append(amplification_figure(fig_dir / f"amplification_{d}.png", ds, d,
                                              study.title))
    return paths


PERCENTILES = (5, 50, 95)
MAX_SEED_SERIES = 8   # more seeds: each sector's peak distribution, not one series per seed


def amplification_figure(path, ds, dof: str, title: str = ""):
    """The amplification factor's distribution over the mistuning seeds (a Monte-Carlo
    sample) at each value of the first other sweep axis (preload if swept): its
    empirical CDF, F(a) = (number of seeds with factor <= a) / seeds, one step curve
    per value, readable at hundreds of seeds, with the percentiles P5, P50, P95
    (`numpy.percentile`, linear interpolation) marked and given in the key; the tuned
    disk (factor 1) a vertical line."""

    a = ds["amplification_factor"].sel(dof=dof)
    other = [x for x in a.dims if x != SEED_AXIS]
    axis = other[0] if other else None
    a = a.transpose(*([axis] if axis else []), SEED_AXIS, *other[1:])
    values = a[axis].values if axis else [None]
    samples = [np.ravel(a.isel({axis: i}).values) if axis else np.ravel(a.values)
               for i in range(len(values))]
    samples = [np.sort(x[np.isfinite(x)]) for x in samples]
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    unit = _axis_unit(axis) if axis else ""
    marks = ("v", "o", "^")
    for i, x in enumerate(samples):
        if not x.size:
            continue
        col = f"C{i % 10}"
        frac = np.arange(1, x.size + 1) / x.size
        ax.step(np.concatenate([[x[0]], x]), np.concatenate([[0.0], frac]), where="post",
                color=col, lw=1.5)
        pc = np.percentile(x, PERCENTILES)
        for q, v, m in zip(PERCENTILES, pc, marks):
            ax.plot(v, q / 100.0, m, color=col, ms=6, mec="k", mew=0.6, zorder=3)
        head = (f"{axis} = {values[i]:g}" + (f" {unit}" if unit not in ("", "1") else "")
                if axis else "all cases")
        ax.plot([], [], "-", color=col, lw=1.5,
                label=f"{head}: P5 {pc[0]:.3f}, P50 {pc[1]:.3f}, P95 {pc[2]:.3f}")
    for q, m in zip(PERCENTILES, marks):
        ax.plot([], [], m, color="w", mec="k", ms=6, label=f"P{q}")
    ax.axvline(1.0, color="k", lw=1, ls="--", label="tuned disk (factor 1)")
    ax.set_xlabel(f"amplification factor of {dof}: largest sector peak / tuned peak [-]")
    ax.set_ylabel("fraction of seeds [-]")
    ax.set_ylim(-0.02, 1.02)
    ax.xaxis.set_major_locator(plots.MaxNLocator(nbins=7, steps=[1, 2, 2.5, 5, 10]))
    n = a.sizes[SEED_AXIS]
    plots.wrapped_title(ax, f"{title}: empirical CDF over {n} mistuning seeds", fontsize=9)
    fig.legend(fontsize=7, loc="outside lower center", ncol=2, frameon=False)
    ax.grid(alpha=0.3)
    out = plots.atomic_savefig(fig, path)
    plt.close(fig)
    return out


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
