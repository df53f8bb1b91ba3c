"""The optimum-preload figure: the resonant peak against the preload, every preload the
search evaluated over the band joined in preload order (grid nodes and Brent
refinements marked apart), Brent's trials valued by the peak continued from a nearby
preload as markers (lower bounds of the band's peak), the optimum starred and labelled
with its value and unit.  An interference search's the same against the interference
[m] (linear), with the actual static normal load of every evaluation on a second axis
[N] and beside the optimum; a smallest peak shared by a stretch (an open gap) shaded,
no optimum marked."""
from __future__ import annotations


import numpy as np

from .plots import atomic_savefig, label_log_axis, pyplot, wrapped_title

SPAN_FOR_LOG = 10.0  # an axis spanning this factor or more is drawn on a log scale


def optimum_plot(result, dof, title="", variable=("preload", "N")):
    """A matplotlib Figure of `result` (`peak_tracking.optimum_preload`): peak [m] against
    preload [N], log axes where the values span a decade or more; `variable` the
    searched one and its unit (("interference", "m"): linear, its static loads drawn)."""
    var, unit = variable
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
                label=f"Brent trial, peak continued in {var}")
    if (~ok).any():
        for n0 in ev[~ok, 0]:
            ax.axvline(n0, color="#9e9e9e", lw=0.8, ls=":", zorder=0)
        ax.plot([], [], ":", color="#9e9e9e", label="incomplete curve (no peak)")
    best = bool(np.isfinite(result.get("peak", np.nan)) and np.isfinite(result["preload"]))
    if result.get("independent"):   # the same peak at every preload: no optimum to mark
        ax.plot([], [], " ", label=f"no optimum: the peak does not depend on the {var}")
    if result.get("plateau") is not None and not result.get("independent"):
        ax.axvspan(*result["plateau"], color="#d62728", alpha=0.12, lw=0, zorder=0,
                   label=f"smallest peak {float(result['peak']):.4g} m all over: no optimum")
    static = static_total(result, x) if var == "interference" else None
    if best:
        p0, a0 = float(result["preload"]), float(result["peak"])
        load = "" if static is None else f" ({static[x == p0][0]:.3g} N static)"
        ax.plot([p0], [a0], "*", ms=14, color="#d62728", zorder=3,
                label=f"optimum {p0:.4g} {unit}: peak {a0:.4g} m{load}")
    logx = var == "preload" and x.size > 1 and x.max() >= SPAN_FOR_LOG * x.min() > 0
    logy = y.size > 1 and y.max() >= SPAN_FOR_LOG * y.min() > 0
    ax.set_xscale("log" if logx else "linear")
    ax.set_yscale("log" if logy else "linear")
    if best:  # room under the minimum for its label
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo / (hi / lo) ** 0.12 if logy else lo - 0.12 * (hi - lo), hi)
        ax.annotate(f"{p0:.4g} {unit}", (p0, a0), xytext=(0, -9), textcoords="offset points",
                    ha="center", va="top", fontsize=9, color="#d62728")
    for is_log, axis in ((logx, ax.xaxis), (logy, ax.yaxis)):
        if is_log:
            label_log_axis(axis)
    if static is not None:
        draw_static(ax, x, static)
    ax.set_xlabel("preload n0 [N]" if var == "preload" else
                  f"{var} [{unit}] (> 0 overlap, < 0 gap)")
    ax.set_ylabel(f"resonant peak of {dof} [m]")
    wrapped_title(ax, title or f"Optimum {var}", fontsize=11)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="best" if static is None else "upper right", framealpha=0.85)
    fig.tight_layout()
    for axis in (ax.xaxis, ax.yaxis):
        thin_ticks(fig, axis)
    return fig


def static_total(result, x) -> np.ndarray:
    """The static normal load [N] of every contact summed at each of `x` (NaN where
    not solved)."""
    static = result.get("static", {})
    return np.array([np.sum(static[float(v)][0]) if float(v) in static else np.nan
                     for v in x], dtype=float)


def draw_static(ax, x, load):
    """The static normal load [N] against the searched variable on a right-hand axis."""
    twin = ax.twinx()
    twin.plot(x, load, "--", color="#7f7f7f", lw=1.0, marker=".", ms=3)
    twin.set_ylabel("static normal load, all pairs [N]", color="#7f7f7f")
    twin.tick_params(axis="y", colors="#7f7f7f")
    twin.set_ylim(bottom=min(0.0, float(np.nanmin(load))) if np.isfinite(load).any() else 0.0)
    ax.plot([], [], "--", color="#7f7f7f", lw=1.0, label="static normal load (right axis)")


def thin_ticks(fig, axis):
    """Keep every second, third, ... labelled major tick of `axis` until no two tick
    labels overlap on the drawn canvas (many decades on a narrow axis)."""
    # deferred: matplotlib, only when the figure is drawn
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


def optimum_figure(path, result, dof, title="", variable=("preload", "N")):
    """Write `optimum_plot` to `path` (PNG); returns the Path."""
    fig = optimum_plot(result, dof, title, variable)
    out = atomic_savefig(fig, path)
    pyplot().close(fig)
    return out
