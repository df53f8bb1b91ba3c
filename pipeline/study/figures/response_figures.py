"""The figures of a response study: amplitude against frequency per response DOF and
per combination of the other sweep axes (`write_figures`); a mistuned disk's own
figures come from `disk_figures`."""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from ...contact import YangMenq
from ...contact.exact import history
from .contact_figures import draw_face_loops, draw_plane_orbits
from .disk_figures import is_sector_resolved, write_sector_figures
from .plots import (atomic_savefig, pyplot, response_curves_figure, stability_for_plot,
                    wrapped_title)
from ..files.study_types import Study


def sector_output_dofs(study: Study) -> list:
    """The sector DOF names of a mistuned disk's output labels ("x1@3" -> "x1")."""
    out = []
    for d in study.output.dofs:
        name = str(d).rpartition("@")[0] or str(d)
        if name not in out:
            out.append(name)
    return out

def write_figures(study: Study, ds, fig_dir, tuned=None) -> list:
    """Amplitude-frequency figures (one per response DOF and per combination of
    the non-curve sweep axes); one curve per value of `preload` (or the first axis).
    A mistuned disk gets its own figures (`disk_figures.write_sector_figures`)."""
    from ..datasets.response_dataset import dof_selection   # deferred: xarray, only when figures are drawn

    if "amplitude" not in study.output.figures:
        return hysteresis_figures(study, ds, fig_dir)
    if is_sector_resolved(study, ds):
        return write_sector_figures(study, ds, fig_dir, None if tuned is None else
                                    (lambda case: tuned[tuple(case.values())]))
    axes = list(study.sweep.axes)
    curve_axis = "preload" if "preload" in axes else (axes[0] if axes else None)
    other = [a for a in axes if a != curve_axis]
    unit = ds["frequency"].attrs["units"]
    paths = []
    for combo in itertools.product(*(range(len(study.sweep.axes[a])) for a in other)):
        sel = dict(zip(other, combo))
        sub = ds.isel(sel)
        suffix = "".join(f"_{a}={study.sweep.axes[a][i]:g}" for a, i in sel.items())
        for dof in study.output.dofs:
            d = sub.sel(dof_selection(study, dof))   # "x1@3": dof x1 of sector 3
            branches, marks = [], []
            for j in range(ds.sizes[curve_axis] if curve_axis else 1):
                b = d.isel({curve_axis: j}) if curve_axis else d
                unit_c = ds[curve_axis].attrs["units"] if curve_axis else ""
                label = (f"{curve_axis} = {float(b[curve_axis]):g}" + (f" {unit_c}" if unit_c != "1" else "")
                         if curve_axis else study.name)
                branches.append((label, b["frequency"].values, b["amplitude"].values,
                                 stability_for_plot(b["stable"]), b["converged"].values))
                marks += bifurcation_marks(b)
            title = study.title + "".join(f", {a} = {study.sweep.axes[a][i]:g}" for a, i in sel.items())
            paths.append(response_curves_figure(
                Path(fig_dir) / f"amplitude_{dof}{suffix}.png", branches,
                xlabel=f"excitation frequency [{unit}]", ylabel=f"amplitude of {dof} [m]",
                title=title, yscale=study.output.yscale, marks=marks))
    return paths + hysteresis_figures(study, ds, fig_dir)


def bifurcation_marks(b) -> list:
    """[(frequency, amplitude, type)] of one branch's bifurcations: on the chord
    between the two converged neighbours whose `stable` differ and whose frequencies
    bracket `bifurcation_frequency`, amplitude interpolated linearly."""
    if "bifurcation_type" not in b:
        return []
    f, a, st = (np.asarray(b[k].values, float) for k in ("frequency", "amplitude", "stable"))
    ok = np.flatnonzero(np.asarray(b["converged"].values, bool) & np.isfinite(st))
    out = []
    for fb, kind in zip(b["bifurcation_frequency"].values, b["bifurcation_type"].values):
        if kind < 0 or not np.isfinite(fb):
            continue
        for i, j in zip(ok[:-1], ok[1:]):
            if st[i] != st[j] and min(f[i], f[j]) <= fb <= max(f[i], f[j]):
                s = (fb - f[i]) / (f[j] - f[i]) if f[j] != f[i] else 0.5
                out.append((float(fb), float(a[i] + s * (a[j] - a[i])), int(kind)))
                break
    return out


def hysteresis_figures(study: Study, ds, fig_dir) -> list:
    """`hysteresis.png` when asked for (`[output] figures = [..., "hysteresis"]`): at
    each case's peak, the friction force summed over the contact that dissipates most
    against its elements' mean tangential relative displacement, with that energy per
    cycle (`contact_figures`); a dataset without per-element motions: the loop of the
    contact element that slides most there (paper Fig. 5b).  One loop per case, drawn
    exactly from the dataset's coefficients (`contact.exact.history`)."""
    if "hysteresis" not in study.output.figures or "hysteresis_u" not in ds:
        return []
    plt = pyplot()
    if "peak_contact_u2" in ds or "hysteresis_u2" in ds:     # 2D friction: in-plane orbits
        fig, pair = plt.subplots(1, 2, figsize=(11.0, 5.0))
        draw_plane_orbits(study, ds, pair)
        for ax in pair:
            ax.grid(alpha=0.3)
            ax.legend(fontsize=6)
        fig.suptitle(f"{study.title}\nat the peak: the contact dissipating most, in its plane",
                     fontsize=9)
        out = atomic_savefig(fig, Path(fig_dir) / "hysteresis.png")
        plt.close(fig)
        return [out]
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    if "peak_contact_u" in ds:
        draw_face_loops(study, ds, ax)
    else:
        element_loops(study, ds, ax)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    out = atomic_savefig(fig, Path(fig_dir) / "hysteresis.png")
    plt.close(fig)
    return [out]


def element_loops(study: Study, ds, ax) -> None:
    """One loop per case of the element sliding most at the peak (`hysteresis_*`)."""
    tau = np.linspace(0.0, 2 * np.pi, 1201)
    axes = list(study.sweep.axes)
    for idx in itertools.product(*(range(len(study.sweep.axes[a])) for a in axes)):
        sel = dict(zip(axes, idx))
        sub = ds.isel(sel)
        if int(sub["hysteresis_element"]) < 0:
            continue
        el = YangMenq(*(float(sub[f"hysteresis_{k}"]) for k in ("ku", "kv", "mu", "n0")))
        h = history(sub["hysteresis_u"].values[None], sub["hysteresis_v"].values[None], el, tau)
        label = ", ".join(f"{a} = {study.sweep.axes[a][i]:g} {ds[a].attrs.get('units', '')}"
                          for a, i in sel.items())
        peak = f"{float(sub['hysteresis_frequency']):.4g} {ds['frequency'].attrs['units']}"
        ax.plot(h["u"][0], h["fu"][0], lw=1.6, label=f"{label} (peak at {peak})")
    ax.set_xlabel("tangential relative displacement u [m]")
    ax.set_ylabel("friction force f_u [N]")
    wrapped_title(ax, f"{study.title}\nat the peak: the contact element sliding most",
                  fontsize=9)
