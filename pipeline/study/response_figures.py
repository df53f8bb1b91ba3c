"""The figures of a response study: amplitude against frequency per response DOF and
per combination of the other sweep axes (`write_figures`); a mistuned disk's own
figures come from `disk_figures`."""
from __future__ import annotations

import itertools
from pathlib import Path

from .spec import Study


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
    from .dataset import dof_selection
    from .disk_figures import is_sector_resolved, write_sector_figures
    from .plots import response_curves_figure, stability_for_plot

    if "amplitude" not in study.output.figures:
        return []
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
            branches = []
            for j in range(ds.sizes[curve_axis] if curve_axis else 1):
                b = d.isel({curve_axis: j}) if curve_axis else d
                unit_c = ds[curve_axis].attrs["units"] if curve_axis else ""
                label = (f"{curve_axis} = {float(b[curve_axis]):g}" + (f" {unit_c}" if unit_c != "1" else "")
                         if curve_axis else study.name)
                branches.append((label, b["frequency"].values, b["amplitude"].values,
                                 stability_for_plot(b["stable"]), b["converged"].values))
            title = study.title + "".join(f", {a} = {study.sweep.axes[a][i]:g}" for a, i in sel.items())
            paths.append(response_curves_figure(
                Path(fig_dir) / f"amplitude_{dof}{suffix}.png", branches,
                xlabel=f"excitation frequency [{unit}]", ylabel=f"amplitude of {dof} [m]",
                title=title, yscale=study.output.yscale))
    return paths
