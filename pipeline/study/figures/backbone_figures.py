"""Figures of a nonlinear modes dataset (`datasets.nonlinear_modes_dataset`).

`backbones.png`: the frequency [Hz] (top) and the modal damping ratio (bottom) of
every case's nonlinear mode against its modal amplitude on a log axis; colour = nodal
diameter (or case), line style = preload.  `synthesis_<dof>.png`: per case, the forced
response synthesised from the backbone for every force scale (dashed) and, where it
was computed, the full harmonic balance at force scale 1 (solid black), the two peaks
marked (the synthesis's where the modal amplitude peaks), within the sweep's frequency
range (far from it one mode says nothing); the compared cases first, at most six panels.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import plots

STYLES = ("-", "--", ":", "-.")
MAX_PANELS = 6


def case_labels(ds) -> list:
    """[(index dict for isel, label)] of every case of the dataset's grid."""
    dims = [d for d in ds["frequency"].dims if d != "point"]
    out = [({}, "")]
    for d in dims:
        unit = ds[d].attrs.get("units", "")
        name = "ND" if d == "nodal_diameter" else d
        out = [({**i, d: k}, f"{lab}{', ' if lab else ''}{name} {v:g}"
                 f"{'' if unit in ('', '1') else ' ' + unit}")
               for i, lab in out for k, v in enumerate(ds[d].values)]
    return out


MAX_LEGEND = 9    # more nodal diameters than this: a colour scale instead of a legend


def _colour_and_style(ds, sel):
    nd = sel.get("nodal_diameter", 0)
    others = [v for d, v in sel.items() if d != "nodal_diameter"]
    if "nodal_diameter" not in sel and others:
        return f"C{others[0] % 10}", STYLES[0]
    style = STYLES[(others[0] if others else 0) % len(STYLES)]
    n = ds.sizes.get("nodal_diameter", 1)
    if n > MAX_LEGEND:
        return plots.pyplot().get_cmap("viridis")(nd / max(n - 1, 1)), style
    return f"C{nd % 10}", style


def backbone_figure(path, ds):
    plt = plots.pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.2, 6.0), sharex=True,
                                      layout="constrained")
    for sel, label in case_labels(ds):
        one = ds.isel(sel)
        ok = one["converged"].values == 1
        a = one["modal_amplitude"].values[ok]
        c, ls = _colour_and_style(ds, sel)
        top.plot(a, one["frequency"].values[ok], ls, color=c,
                 label=(label or None) if ds.sizes.get("nodal_diameter", 1) <= MAX_LEGEND
                 else None)
        bottom.plot(a, one["damping_ratio"].values[ok], ls, color=c)
    bottom.set_xscale("log")
    bottom.set_xlabel("modal amplitude a [kg$^{1/2}$ m]")
    top.set_ylabel("frequency [Hz]")
    bottom.set_ylabel("modal damping ratio [-]")
    for ax in (top, bottom):
        ax.grid(alpha=0.3, which="both")
    n = ds.sizes.get("nodal_diameter", 1)
    if n > MAX_LEGEND:    # colour = nodal diameter on a scale; line style = the other axes
        nds = ds["nodal_diameter"].values
        sm = plt.cm.ScalarMappable(cmap="viridis", norm=plt.Normalize(0, n - 1))
        bar = fig.colorbar(sm, ax=[top, bottom], location="right", shrink=0.8)
        ticks = np.unique(np.linspace(0, n - 1, min(n, 7)).round().astype(int))
        bar.set_ticks(ticks, labels=[str(nds[t]) for t in ticks])
        bar.set_label("nodal diameter")
        others = [d for d in ds["frequency"].dims if d not in ("point", "nodal_diameter")]
        if others and ds.sizes[others[0]] > 1:
            d = others[0]
            handles = [top.plot([], [], STYLES[k % len(STYLES)], color="0.3")[0]
                       for k in range(ds.sizes[d])]
            fig.legend(handles, [f"{d} {v:g}" for v in ds[d].values], fontsize=7,
                       loc="outside lower center", ncol=5, frameon=False)
    elif top.get_legend_handles_labels()[0]:
        fig.legend(fontsize=7, loc="outside lower center", ncol=3, frameon=False)
    plots.wrapped_title(fig, ds.attrs.get("title", ""), fontsize=9)
    out = plots.atomic_savefig(fig, path)
    plt.close(fig)
    return out


def synthesis_figure(path, ds, dof: int):
    plt = plots.pyplot()
    cases = case_labels(ds)
    if "hbm_frequency" in ds:    # the cases compared with the harmonic balance first
        compared = [bool(np.isfinite(ds["hbm_frequency"].isel(sel).values).any())
                    for sel, _ in cases]
        cases = [c for c, k in zip(cases, compared) if k] + \
                [c for c, k in zip(cases, compared) if not k]
    cases = cases[:MAX_PANELS]
    cols = min(3, len(cases))
    rows = -(-len(cases) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.3 * cols + 0.6, 2.9 * rows + 0.8),
                             squeeze=False, layout="constrained")
    scales = ds["force_scale"].values
    for ax, (sel, label) in zip(axes.ravel(), cases):
        one = ds.isel(sel)
        ok = one["converged"].values == 1
        amp = one["amplitude"].values[ok, dof]
        for j, f in enumerate(scales):
            lo = one["synthesis_frequency_below"].values[j, ok]
            hi = one["synthesis_frequency_above"].values[j, ok]
            for x, lab in ((lo, f"synthesis, force x {f:g}"), (hi, None)):  # both flanks
                keep = np.isfinite(x)
                ax.plot(x[keep], amp[keep], "--", color=f"C{j % 10}", lw=1.2, label=lab)
            ax.plot(one["synthesis_peak_frequency"].values[j],
                    one["synthesis_peak_amplitude"].values[j, dof], "o", color=f"C{j % 10}",
                    ms=4, mfc="none", label="synthesised peak" if j == 0 else None)
        if "hbm_frequency" in one:
            ax.plot(one["hbm_frequency"].values, one["hbm_amplitude"].values[:, dof], "k-",
                    lw=1.0, label="full harmonic balance, force x 1")
            ax.plot(one["hbm_peak_frequency"].values, one["hbm_peak_amplitude"].values[dof],
                    "k+", ms=8, label="harmonic-balance peak")
        if "frequency_range" in ds.attrs:   # the sweep's range: the single mode's vicinity
            ax.set_xlim(*np.asarray(ds.attrs["frequency_range"], float))
        ax.set_title(label, fontsize=8)
        ax.set_xlabel("excitation frequency [Hz]")
        ax.set_ylabel(f"amplitude {ds['dof'].values[dof]} [m]")
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(cases):]:
        ax.set_visible(False)
    handles, labels = axes.ravel()[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="outside lower center", ncol=3, frameon=False)
    plots.wrapped_title(fig, ds.attrs.get("title", "") + " - synthesised vs full forced "
                        "response", fontsize=9)
    out = plots.atomic_savefig(fig, path)
    plt.close(fig)
    return out


def write_backbone_figures(folder, ds) -> list:
    """Every figure of the module docstring under `folder`; their paths."""
    folder = Path(folder)
    out = [backbone_figure(folder / "backbones.png", ds)]
    for k, name in enumerate(ds["dof"].values):
        out.append(synthesis_figure(folder / f"synthesis_{name}.png", ds, k))
    return out
