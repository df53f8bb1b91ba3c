"""The Campbell diagram of a tuned disk (dataset of a modes study with speeds).

Natural frequency [Hz] against speed [rpm] for the nodal-diameter families the
engine orders excite (ND = EO mod N folded), contacts stuck (solid) and open
(dashed) and, with an interference, in the static contact state of each speed
(dotted), one colour per family; the engine-order lines EO x speed / 60 in grey,
labelled where they leave the axes; the crossings the study located (root finding)
marked in their family's colour and labelled with their engine order and speed; the
frequency axis fitted to the families drawn.  Every family
of the dataset's first mode upward is drawn for the excited NDs only -- the diagram
designers read first: where a resonance meets its excitation in the running range.
"""
from __future__ import annotations

import numpy as np

from . import plots
from .nd_figure import excited_nodal_diameter


LABEL_GAP = 0.04     # the least distance between two engine-order labels, of the axis span
GROUND = {"facecolor": "white", "edgecolor": "none", "pad": 0.5, "alpha": 0.8}   # labels' box


def campbell_figure(path, ds):
    """The diagram of the module docstring, written to `path`."""
    plt = plots.pyplot()
    fig, _ = draw_campbell(ds)
    out = plots.atomic_savefig(fig, path)
    plt.close(fig)
    return out


def draw_campbell(ds):
    """(figure, its engine-order and crossing labels as (text, x, y) in data units)."""
    plt = plots.pyplot()
    s = ds.speed.values
    N = int(ds.attrs.get("sectors", 0)) or None
    fig, ax = plt.subplots(figsize=(7.2, 4.8), layout="constrained")
    nds = list(ds.nodal_diameter.values)
    drawn = {}   # nodal diameter -> colour, the families the engine orders excite
    for c, eo in enumerate(ds.engine_order.values):
        nd = excited_nodal_diameter(int(eo), N) if N else None
        if nd is not None and nd in nds and nd not in drawn:
            drawn[nd] = f"C{c % 10}"
    states = [v for v in ("frequency_stuck", "frequency_open", "frequency_static") if v in ds]
    shown = [ds[v].values[:, nds.index(nd), :] for v in states for nd in drawn]
    fmax = 1.05 * float(np.nanmax(shown if shown else ds.frequency_stuck.values))
    for nd, colour in drawn.items():
        j = nds.index(nd)
        for v, style, lw in zip(states, ("-", "--", ":"), (1.2, 0.9, 1.4)):
            ax.plot(s, ds[v].values[:, j, :], style, color=colour, lw=lw)
        eos = [int(e) for e in ds.engine_order.values if excited_nodal_diameter(int(e), N) == nd]
        ax.plot([], [], "-", color=colour,
                label=f"ND {nd} (EO {', '.join(map(str, eos))})")
    if ds.sizes.get("crossing", 0):
        ax.plot([], [], "o", ms=4, mfc="0.3", mec="0.3", label="crossing, contacts stuck")
        ax.plot([], [], "o", ms=4, mfc="white", mec="0.3", label="crossing, contacts open")
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
    fig.canvas.draw()   # the layout first: the labels are placed by their drawn extents
    labels = engine_order_labels(ax, s, ds.engine_order.values, fmax)
    labels += crossing_labels(ax, ds, drawn, N)
    for t in ax.texts:  # outside the layout, which stays the one they were placed in
        t.set_in_layout(False)
    return fig, labels


def spread(values, gap):
    """`values` moved apart, in their order, to at least `gap` from each other (upward
    from the lowest)."""
    order = np.argsort(values)
    out = np.array(values, float)
    for a, b in zip(order[:-1], order[1:]):
        out[b] = max(out[b], out[a] + gap)
    return out


def engine_order_labels(ax, s, engine_orders, fmax) -> list:
    """The lines EO x speed / 60 in grey, each labelled where it leaves the axes (the
    right edge, or the top one), the labels spread at least LABEL_GAP of the span apart
    on a white ground; [(text, x, y)]."""
    right, top = [], []
    for eo in engine_orders:
        ax.plot(s, eo * s / 60.0, color="0.6", lw=0.8)
        y_end = eo * s[-1] / 60.0
        (right if y_end <= fmax else top).append((int(eo), y_end, 60.0 * fmax / eo))
    out = []
    box = GROUND
    if right:
        ys = spread([y for _, y, _ in right], LABEL_GAP * fmax)
        for (eo, _, _), y in zip(right, ys):
            ax.annotate(f"EO {eo}", (s[-1], y), fontsize=7, color="0.3", ha="right",
                        va="bottom", bbox=box, gid="engine_order_label")
            out.append((f"EO {eo}", s[-1], y))
    if top:
        xs = -spread([-x for _, _, x in top], LABEL_GAP * (s[-1] - s[0]))   # leftward
        for (eo, _, _), x in zip(top, xs):
            ax.annotate(f"EO {eo}", (x, fmax), fontsize=7, color="0.3", ha="right",
                        va="top", bbox=box, gid="engine_order_label")
            out.append((f"EO {eo}", x, fmax))
    return out


def text_box(label, renderer=None):
    """The drawn extent of a label's text (an annotation's own extent holds its leader
    line too) [display units]."""
    # deferred: matplotlib, as every figure module (`plots.pyplot`)
    from matplotlib.text import Text

    renderer = renderer or label.figure.canvas.get_renderer()
    if hasattr(label, "update_positions"):   # an annotation: its text where it is drawn
        label.update_positions(renderer)
    return Text.get_window_extent(label, renderer)


def crossing_labels(ax, ds, drawn, N) -> list:
    """The crossings the study located, in their family's colour (filled: contacts
    stuck or static; open circle: open), each labelled with its engine order and speed
    [rpm] (on the marker's left near the right edge), a label that would overlap another
    moved down beside its marker (with a leader line); [(text, x, y)].  Call with the
    figure's layout drawn."""
    renderer = ax.figure.canvas.get_renderer()
    out, placed = [], [text_box(t, renderer) for t in ax.texts]
    order = np.argsort(ds.crossing_speed.values) if ds.sizes.get("crossing", 0) else []
    for k in order:
        eo, x, y = (int(ds.crossing_engine_order.values[k]),
                    float(ds.crossing_speed.values[k]), float(ds.crossing_frequency.values[k]))
        colour = drawn.get(excited_nodal_diameter(eo, N) if N else None, "k")
        is_open = str(ds.crossing_contacts.values[k]) == "open"
        ax.plot(x, y, "o", ms=4, mfc="white" if is_open else colour, mec=colour)
        text = f"EO {eo}: {x:,.0f} rpm"
        frame = ax.get_window_extent(renderer)
        dx, dy, ha = 4.0, 3.0, "left"
        label = ax.annotate(text, (x, y), xytext=(dx, dy), textcoords="offset points",
                            fontsize=6, color=colour, gid="crossing_label", bbox=GROUND)
        box = text_box(label, renderer)
        if box.x1 > frame.x1:   # near the right edge: on the marker's left
            dx, ha = -4.0, "right"
            label.set_position((dx, dy))
            label.set_horizontalalignment(ha)
            box = text_box(label, renderer)
        while any(box.overlaps(b) for b in placed) and dy > -400:
            dy -= 7.0
            label.set_position((dx, dy))
            box = text_box(label, renderer)
        if dy != 3.0:   # moved: drawn again with a leader line to its marker
            label.remove()
            label = ax.annotate(text, (x, y), xytext=(dx, dy), textcoords="offset points",
                                fontsize=6, color=colour, gid="crossing_label", bbox=GROUND,
                                ha=ha, arrowprops={"arrowstyle": "-", "color": colour,
                                                   "lw": 0.4, "shrinkA": 0, "shrinkB": 2})
            box = text_box(label, renderer)
        placed.append(box)
        out.append((text, x, y))
    return out
