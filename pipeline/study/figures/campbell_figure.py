"""The Campbell diagram of a tuned disk (dataset of a modes study with speeds).

Natural frequency [Hz] against speed [rpm] for the nodal-diameter families the
engine orders excite (ND = EO mod N folded), contacts stuck (solid) and open
(dashed) and, with an interference, in the static contact state of each speed
(dotted), one colour per engine order; the engine-order lines EO x speed / 60 in
grey; the crossings the study located (root finding) as black dots.  Every family
of the dataset's first mode upward is drawn for the excited NDs only -- the diagram
designers read first: where a resonance meets its excitation in the running range.
"""
from __future__ import annotations

import numpy as np

from . import plots
from .nd_figure import excited_nodal_diameter


def campbell_figure(path, ds):
    """The diagram of the module docstring, written to `path`."""
    plt = plots.pyplot()
    s = ds.speed.values
    N = int(ds.attrs.get("sectors", 0)) or None
    fig, ax = plt.subplots(figsize=(7.2, 4.8), layout="constrained")
    fmax = float(np.nanmax(ds.frequency_stuck.values)) * 1.05
    nds = list(ds.nodal_diameter.values)
    for c, eo in enumerate(ds.engine_order.values):
        colour = f"C{c % 10}"
        ax.plot(s, eo * s / 60.0, color="0.6", lw=0.8)
        ax.annotate(f"EO {eo}", (s[-1], min(eo * s[-1] / 60.0, fmax)), fontsize=7,
                    color="0.4", ha="right", va="bottom")
        nd = excited_nodal_diameter(int(eo), N) if N else None
        if nd is None or nd not in nds:
            continue
        j = nds.index(nd)
        ax.plot(s, ds.frequency_stuck.values[:, j, :], "-", color=colour, lw=1.2)
        ax.plot(s, ds.frequency_open.values[:, j, :], "--", color=colour, lw=0.9)
        if "frequency_static" in ds:
            ax.plot(s, ds.frequency_static.values[:, j, :], ":", color=colour, lw=1.4)
        ax.plot([], [], "-", color=colour, label=f"ND {nd} (EO {eo})")
    if ds.sizes.get("crossing", 0):
        ax.plot(ds.crossing_speed.values, ds.crossing_frequency.values, "ko", ms=4,
                label="crossing (root found)")
    ax.plot([], [], "k-", label="contacts stuck")
    ax.plot([], [], "k--", label="contacts open")
    if "frequency_static" in ds:
        ax.plot([], [], "k:", lw=1.4, label="static contact state")
    ax.set_ylim(0.0, fmax)
    ax.set_xlim(s[0], s[-1])
    ax.set_xlabel("speed [rpm]")
    ax.set_ylabel("natural frequency [Hz]")
    ax.grid(alpha=0.3)
    fig.legend(fontsize=7, loc="outside right center", frameon=False)
    plots.wrapped_title(fig, ds.attrs.get("title", ""), fontsize=9)
    out = plots.atomic_savefig(fig, path)
    plt.close(fig)
    return out
