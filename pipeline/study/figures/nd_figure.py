"""The frequency - nodal-diameter diagram of a tuned disk (modes study dataset:
`frequency_open`, `frequency_stuck` [Hz] on (nodal_diameter, mode)).

Two panels: every family (left) and the first family alone (right), whose open and
stuck frequencies would otherwise be squashed at the bottom of the full range.
Colour = mode family (index 1, 2, ... by increasing stuck frequency at ND 0), solid
circles = contacts stuck, dashed squares = contacts open; a key names each family
and the two contact states.

Engine orders: an excitation of engine order EO on N sectors excites the nodal
diameter ND = EO mod N folded into 0..N/2 (ND = N - (EO mod N) above N/2), the
zig-zag of the interference (ZZENF) diagram.  Its EO line, frequency = EO x
rotation speed, needs a speed, which a modes study does not have: the excited ND
is drawn as a vertical marker where the dataset names an engine order, else a note
under the axes gives the rule.
"""
from __future__ import annotations

import numpy as np

from . import plots


def excited_nodal_diameter(engine_order: int, sectors: int) -> int:
    """ND = EO mod N folded into 0..N/2."""
    r = int(engine_order) % int(sectors)
    return min(r, int(sectors) - r)


def _families(ax, nd, ds, modes, mark=True):
    for m in modes:
        c = f"C{m % 10}"
        ax.plot(nd, ds.frequency_stuck.values[:, m], "o-", color=c, ms=4 if mark else 3)
        ax.plot(nd, ds.frequency_open.values[:, m], "s--", color=c, ms=3, mfc="none")


def nodal_diameter_figure(path, ds):
    """The diagram of the module docstring, written to `path`."""
    plt = plots.pyplot()
    nd = ds.nodal_diameter.values
    n_modes = ds.sizes["mode"]
    fig, (ax, zoom) = plt.subplots(1, 2, figsize=(8.4, 4.3), width_ratios=(1.5, 1),
                                   layout="constrained")
    _families(ax, nd, ds, range(n_modes))
    _families(zoom, nd, ds, [0])
    first = np.concatenate([ds.frequency_stuck.values[:, 0], ds.frequency_open.values[:, 0]])
    if np.isfinite(first).any():   # NaN: a negative stiffness (no frequency) throughout
        lo, hi = float(np.nanmin(first)), float(np.nanmax(first))
        pad = 0.06 * max(hi - lo, 1e-3 * hi)
        zoom.set_ylim(lo - pad, hi + pad)
    sectors = ds.attrs.get("sectors")
    eo = ds.attrs.get("engine_order")
    for a in (ax, zoom):
        a.set_xlabel("nodal diameter [-]")
        a.xaxis.set_major_locator(plots.integer_locator(12))
        a.grid(alpha=0.3)
    if eo is not None and sectors:
        k = excited_nodal_diameter(int(eo), int(sectors))
        for a in (ax, zoom):
            a.axvline(k, color="k", lw=1.0, ls=":", zorder=0)
        ax.plot([], [], "k:", lw=1.0, label=f"EO {int(eo)} excites ND {k}")
    ax.set_ylabel("natural frequency [Hz]")
    zoom.set_ylabel("natural frequency [Hz]")
    zoom.set_title("first family", fontsize=9)
    handles = [ax.plot([], [], "-", color=f"C{m % 10}", lw=2)[0] for m in range(n_modes)]
    labels = [f"family {m + 1}" for m in range(n_modes)]
    handles += [ax.plot([], [], "ko-", ms=4)[0], ax.plot([], [], "ks--", ms=3, mfc="none")[0]]
    labels += ["contacts stuck", "contacts open"]
    extra = ax.get_legend_handles_labels()
    note = None
    if eo is None:
        n = int(sectors) if sectors else None
        note = ("no engine order in this study: EO excites ND = EO mod N folded into 0..N/2"
                + (f" (N = {n})" if n else "") + "; its EO line (frequency = EO x speed) "
                "needs a rotation speed")
    fig.legend(handles + extra[0], labels + extra[1], fontsize=7, loc="outside lower center",
               ncol=min(len(handles) + len(extra[0]), 5), frameon=False, title=note,
               title_fontsize=7)
    plots.wrapped_title(fig, ds.attrs.get("title", ""), fontsize=9)
    out = plots.atomic_savefig(fig, path)
    plt.close(fig)
    return out
