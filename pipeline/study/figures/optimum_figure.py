"""The optimum-preload figure: the resonant peak against the preload, every preload the
search evaluated over the band joined in preload order (grid nodes and Brent
refinements marked apart), Brent's trials valued by the peak continued from a nearby
preload as markers (lower bounds of the band's peak), the optimum starred and labelled
with its value and unit."""
from __future__ import annotations


import numpy as np

from .plots import atomic_savefig, label_log_axis, pyplot, wrapped_title

SPAN_FOR_LOG = 10.0  # an axis spanning this factor or more is drawn on a log scale


def optimum_plot(result, dof, title=""):
    """A matplotlib Figure of `result` (`peak_tracking.optimum_preload`): peak [m] against
    preload [N], log axes where the values span a decade or more."""
    ev = np.array(result["evaluations"], dtype=float).reshape(-1, 3)
    ev = ev[np.argsort(ev[:, 0])]
    ok = np.isfinite(ev[:, 1])
    x, y = ev[ok, 0], ev[ok, 1]
    on_grid = np.isin(x, np.asarray(result.get("grid", []), dtype=float))
    local = np.isin(x, np.asarray(result.get("local", []), dtype=float))
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    # the line joins the band peaks; a local one (a lower bound) is a marker only
    ax.plot(x[~local], y[~local], "-", color="#1f77b4", lw=1.2, zorder=1)
    ax.plot(x[on_grid], y[on_grid], "o", ms=4, color="#1f77b4", zorder=2,
            label="grid node")
    if (~on_grid & ~local).any():
        ax.plot(x[~on_grid & ~local], y[~on_grid & ~local], "x", ms=5, color="#ff7f0e",
                zorder=2, label="Brent refinement, band peak")
    if local.any():
        ax.plot(x[local], y[local], "+", ms=6, color="#2ca02c", zorder=2,
                label="Brent trial, peak continued in preload")
    if (~ok).any():
        for n0 in ev[~ok, 0]:
            ax.axvline(n0, color="#9e9e9e", lw=0.8, ls=":", zorder=0)
        ax.plot([], [], ":", color="#9e9e9e", label="incomplete curve (no peak)")
    best = bool(np.isfinite(result.get("peak", np.nan)) and np.isfinite(result["preload"]))
    if result.get("independent"):   # the same peak at every preload: no optimum to mark
        ax.plot([], [], " ", label="no optimum: the peak does not depend on the preload")
    if best:
        p0, a0 = float(result["preload"]), float(result["peak"])
        ax.plot([p0], [a0], "*", ms=14, color="#d62728", zorder=3,
                label=f"optimum {p0:.4g} N: peak {a0:.4g} m")
    logx = x.size > 1 and x.max() >= SPAN_FOR_LOG * x.min() > 0
    logy = y.size > 1 and y.max() >= SPAN_FOR_LOG * y.min() > 0
    ax.set_xscale("log" if logx else "linear")
    ax.set_yscale("log" if logy else "linear")
    if best:  # room under the minimum for its label
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo / (hi / lo) ** 0.12 if logy else lo - 0.12 * (hi - lo), hi)
        ax.annotate(f"{p0:.4g} N", (p0, a0), xytext=(0, -9), textcoords="offset points",
                    ha="center", va="top", fontsize=9, color="#d62728")
    for is_log, axis in ((logx, ax.xaxis), (logy, ax.yaxis)):
        if is_log:
            label_log_axis(axis)
    ax.set_xlabel("preload n0 [N]")
    ax.set_ylabel(f"resonant peak of {dof} [m]")
    wrapped_title(ax, title or "Optimum preload", fontsize=11)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    for axis in (ax.xaxis, ax.yaxis):
        thin_ticks(fig, axis)
    return fig


def thin_ticks(fig, axis):
    """Keep every second, third, ... labelled major tick of `axis` until no two tick
    labels overlap on the drawn canvas (many decades on a narrow axis)."""
    from matplotlib.ticker import FixedLocator

    ticks = np.asarray(axis.get_majorticklocs())
    lo, hi = sorted(axis.get_view_interval())
    ticks = ticks[(ticks >= lo) & (ticks <= hi)]
    for step in range(1, max(ticks.size, 1) + 1):
        axis.set_major_locator(FixedLocator(ticks[::step]))
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        boxes = [t.get_window_extent(renderer) for t in axis.get_ticklabels()
                 if t.get_visible() and t.get_text()]
        if not any(a.overlaps(b) for a, b in zip(boxes, boxes[1:])):
            return


def optimum_figure(path, result, dof, title=""):
    """Write `optimum_plot` to `path` (PNG); returns the Path."""
    fig = optimum_plot(result, dof, title)
    out = atomic_savefig(fig, path)
    pyplot().close(fig)
    return out
