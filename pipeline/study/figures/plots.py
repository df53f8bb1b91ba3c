"""Figures (matplotlib, Agg backend): hysteresis loops, response curves, peaks per
sector and modal convergence; the shared helpers (`pyplot`,
`atomic_savefig`, log axes).  The accuracy-cost Pareto figure is `pareto_figure`, the
optimum-preload figure `optimum_figure`."""
from __future__ import annotations

import os
import textwrap
from pathlib import Path

import numpy as np

from ...contact import STATE_NAMES, YangMenq
from ...contact.exact import history

STATE_COLOURS = {0: "#9e9e9e", 1: "#1f77b4", 2: "#d62728", 3: "#2ca02c"}


# matplotlib is imported inside functions throughout: its import takes a noticeable
# time that only code that draws should pay.
def pyplot():
    """matplotlib.pyplot on the Agg backend, imported on first use."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def atomic_savefig(fig, path):
    """Write `fig` to `path` (format from the suffix) through a temporary file and a
    rename, so a reader never sees half a figure; returns the Path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    fig.savefig(tmp, dpi=130, bbox_inches="tight", format=path.suffix.lstrip(".") or "png")
    os.replace(tmp, path)
    return path


def wrap_text(text: str, width_in: float, fontsize: float) -> str:
    """`text` broken into lines of at most width_in [inch] at `fontsize` [pt], taking
    an average glyph as 0.55 fontsize wide (DejaVu Sans); its own line breaks kept."""
    n = max(16, int(width_in * 72.0 / (0.55 * fontsize)))
    return "\n".join(textwrap.fill(line, n) if line else "" for line in str(text).split("\n"))


def wrapped_title(target, text: str, fontsize: float = 10.0):
    """Set a title wrapped to the width it owns, so that a long title adds lines
    instead of widening the canvas: an Axes' title to the axes' width, a Figure's
    (suptitle) to the figure's.  Returns the Text."""
    fig = getattr(target, "figure", None)
    if hasattr(target, "suptitle") and not hasattr(target, "set_title"):
        w = target.get_figwidth() * 0.96
        return target.suptitle(wrap_text(text, w, fontsize), fontsize=fontsize)
    w = target.get_position().width * fig.get_figwidth()
    return target.set_title(wrap_text(text, w, fontsize), fontsize=fontsize)


def MaxNLocator(**kwargs):
    """matplotlib's MaxNLocator (imported on first use)."""
    from matplotlib.ticker import MaxNLocator as locator
    return locator(**kwargs)


def integer_locator(nbins: int = 10):
    """A MaxNLocator of at most `nbins` integer ticks (sector numbers, nodal
    diameters): their labels never crowd into each other."""
    from matplotlib.ticker import MaxNLocator
    return MaxNLocator(nbins=nbins, integer=True)


def demo_motion(H: int = 3):
    """u = 3 cos tau, v = 0.5 cos tau + 2 sin tau [m]: with mu = 0.4, ku = kv = 1 N/m
    and n0 = 1 N it visits separation, positive slip, stick and negative slip."""
    U = np.zeros((1, 2 * H + 1))
    V = np.zeros((1, 2 * H + 1))
    U[0, 1] = 3.0
    V[0, 1], V[0, 2] = 0.5, 2.0
    return U, V


def check_element(mu, ku, kv, n0):
    """ValueError naming the parameter unless (mu, ku, kv, n0) make a contact element
    that transmits a tangential force (ku > 0: a loop of ku = 0 is a flat zero)."""
    YangMenq(ku=ku, kv=kv, mu=mu, n0=n0)
    if not ku > 0:
        raise ValueError(f"ku must be > 0 (a zero tangential stiffness transmits no force), "
                         f"got {ku:g}")


def hysteresis_figure(path, mu=0.4, ku=1.0, kv=1.0, n0=1.0, U=None, V=None, n_points=2000):
    """Time history of f_u, f_v and the loop f_u(u) (paper Fig. 5), coloured by state."""
    if U is None:
        U, V = demo_motion()
    elem = YangMenq(ku=ku, kv=kv, mu=mu, n0=n0)
    tau = np.linspace(0.0, 2 * np.pi, n_points + 1)
    h = history(U, V, elem, tau)
    st, fu, fv, u = h["state"][0], h["fu"][0], h["fv"][0], h["u"][0]
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.6))
    for s, name in STATE_NAMES.items():
        m = np.where(st == s, 1.0, np.nan)
        a1.plot(tau, fu * m, color=STATE_COLOURS[s], lw=2.2, label=name)
        a2.plot(u, fu * m, color=STATE_COLOURS[s], lw=2.2, label=name)
    a1.plot(tau, fv, "k--", lw=1, label="normal force $f_v$")
    a1.plot(tau, mu * np.maximum(h["n"][0], 0), ":", color="0.4", lw=1, label=r"$\pm\mu n$")
    a1.plot(tau, -mu * np.maximum(h["n"][0], 0), ":", color="0.4", lw=1)
    for t, _, _ in h["transitions"][0]:
        a1.axvline(t, color="0.85", lw=0.8, zorder=0)
    a1.set(xlabel=r"$\tau = \Omega t$ [rad]", ylabel="force [N]",
           title="Friction force over one period (paper Fig. 5a)")
    a2.set(xlabel="tangential displacement $u$ [m]", ylabel="friction force $f_u$ [N]",
           title="Hysteresis loop (paper Fig. 5b)")
    for a in (a1, a2):
        a.grid(alpha=0.3)
    wrapped_title(fig, f"Yang-Menq element: mu = {mu}, ku = {ku} N/m, kv = {kv} N/m, n0 = {n0} N",
                  fontsize=12)
    # one legend for both panels, below them: inside it would hide curves of some motion
    fig.legend(*a1.get_legend_handles_labels(), loc="lower center", ncol=6, fontsize=8,
               frameon=False)
    fig.subplots_adjust(bottom=0.2)
    out = atomic_savefig(fig, path)
    plt.close(fig)
    return out


# ---------------------------------------------------------------------------
# Response curves of a study (paper Figs. 2, 4, 6)
# ---------------------------------------------------------------------------

def fold_indices(f):
    """Interior points where the frequency turns back (turning points of the branch)."""
    d = np.diff(f)
    return np.flatnonzero(d[:-1] * d[1:] < 0) + 1


def true_runs(mask):
    """(start, stop) index pairs of the runs of True in `mask`."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    edges = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(edges[::2], edges[1::2]))


STABLE, UNSTABLE, NOT_COMPUTED = 1, 0, -1


def stability_states(stable):
    """Per-point stability as STABLE / UNSTABLE / NOT_COMPUTED from a bool array
    (True stable) or a float array (1.0 stable, 0.0 unstable, NaN not computed)."""
    st = np.asarray(stable)
    if st.dtype == bool:
        return np.where(st, STABLE, UNSTABLE)
    st = st.astype(float)
    return np.where(np.isnan(st), NOT_COMPUTED, np.where(st > 0.5, STABLE, UNSTABLE))


def stability_for_plot(stable):
    """The `stable` variable of a response dataset as floats for the figures: NaN
    where stability was not computed (the variable's attribute `stability_computed`
    = 0 marks a dataset whose `stable` is a placeholder True everywhere)."""
    values = np.asarray(getattr(stable, "values", stable))
    attrs = getattr(stable, "attrs", {})
    if int(attrs.get("stability_computed", 1)) == 0:
        return np.full(values.shape, np.nan)
    return values


# line style per stability state: stable solid, unstable dashed, not computed dotted
_STYLE = {STABLE: dict(ls="-", lw=1.6), UNSTABLE: dict(ls="--", lw=1.4),
          NOT_COMPUTED: dict(ls=":", lw=1.6)}
_STATE_LEGEND = {UNSTABLE: "dashed: unstable", NOT_COMPUTED: "dotted: stability not computed"}
_STATE_COLOUR = "0.55"   # the line-style key in grey: no branch's colour (the tuned disk's black)
# marker per bifurcation type (dataset `bifurcation_type`): 1 fold, 2 period doubling,
# 3 Neimark-Sacker
BIFURCATION_MARKERS = {1: ("s", "fold bifurcation"), 2: ("v", "period doubling"),
                       3: ("*", "Neimark-Sacker")}


def unmarked_turns(turns, marks, drawn, log=False, rel=0.02):
    """The turning points [(frequency, amplitude, colour)] of the drawn curves that no
    located fold among `marks` [(frequency, amplitude, type)] marks already: a fold
    mark within `rel` of the frequency and amplitude spans of the `drawn` points
    (P, 2) (log10 amplitude on a log axis) is the same fold, drawn as its square."""
    folds = np.array([(f, a) for f, a, k in marks if int(k) == 1], float).reshape(-1, 2)
    if not turns or not folds.size:
        return list(turns)

    def coords(fa):
        fa = np.array(fa, float).reshape(-1, 2)
        if log:
            fa[:, 1] = np.log10(np.maximum(fa[:, 1], 1e-300))
        return fa

    pts, ref, every = coords([(f, a) for f, a, _ in turns]), coords(folds), coords(drawn)
    span = np.maximum(np.ptp(every, axis=0), 1e-12 * np.abs(every).max(0) + 1e-300)
    near = (np.abs(pts[:, None, :] - ref[None, :, :]) <= rel * span).all(2).any(1)
    return [t for t, n in zip(turns, near) if not n]


def response_curves_plot(branches, *, xlabel="frequency [rad/s]", ylabel="amplitude [m]",
                         title="", yscale="linear", legend_title=None, marks=()):
    """The figure of `response_curves_figure`, left open (for saving or inspection).

    A branch may carry a sixth element, a dict of Line2D properties (color, lw,
    alpha, zorder) that override its defaults; label None leaves it out of the legend.
    marks: [(frequency, amplitude, type)] bifurcations, a marker per type
    (`BIFURCATION_MARKERS`), each type once in the legend.  The turning points of the
    drawn curves are circled ("fold"), except where a located fold is marked
    (`unmarked_turns`)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    states_seen, turns, drawn = set(), [], []
    for k, (label, f, a, stable, conv, *extra) in enumerate(branches):
        style = dict(extra[0]) if extra else {}
        f, a = np.asarray(f, float), np.asarray(a, float)
        conv = np.asarray(conv, bool) & np.isfinite(f) & np.isfinite(a)
        state = stability_states(stable)
        col = style.pop("color", colours[k % len(colours)])
        lw = style.pop("lw", None)
        first = True
        for i0, i1 in true_runs(conv):
            fs, as_, st = f[i0:i1], a[i0:i1], state[i0:i1]
            n = i1 - i0
            # stable runs solid; unstable (dashed) and not-computed (dotted) runs
            # reach back to the point before and on to a stable point after, so the
            # curve stays connected and every segment is drawn once
            for s in (STABLE, UNSTABLE, NOT_COMPUTED):
                for j0, j1 in true_runs(st == s):
                    if s != STABLE:
                        j0 = max(j0 - 1, 0)
                        j1 = j1 + 1 if j1 < n and st[j1] == STABLE else j1
                    kw = dict(_STYLE[s])
                    if lw is not None:
                        kw["lw"] = lw
                    ax.plot(fs[j0:j1], as_[j0:j1], color=col, label=label if first else None,
                            gid=f"stability={s}", **kw, **style)
                    first = False
                    if s != STABLE:
                        states_seen.add(s)
            folds = fold_indices(fs)
            turns += [(fs[i], as_[i], col) for i in folds]
            drawn.append(np.column_stack([fs, as_]))
    circled = unmarked_turns(turns, marks, np.vstack(drawn) if drawn else np.empty((0, 2)),
                             yscale == "log")
    any_fold = bool(circled)
    by_colour = {}  # one marker line per branch colour
    for f0, a0, col in circled:
        by_colour.setdefault(repr(col), (col, []))[1].append((f0, a0))
    for col, pts in by_colour.values():
        pts = np.array(pts)
        ax.plot(pts[:, 0], pts[:, 1], "o", mfc="none", mec=col, ms=6)
    handles, labels = ax.get_legend_handles_labels()
    for s in (UNSTABLE, NOT_COMPUTED):
        if s in states_seen:
            handles.append(ax.plot([], [], color=_STATE_COLOUR, **_STYLE[s])[0])
            labels.append(_STATE_LEGEND[s])
    if any_fold:
        handles.append(ax.plot([], [], "ko", mfc="none", ms=6)[0])
        labels.append("fold")
    for kind in sorted({int(k) for _, _, k in marks} & set(BIFURCATION_MARKERS)):
        m, name = BIFURCATION_MARKERS[kind]
        pts = np.array([(f, a) for f, a, k in marks if int(k) == kind], float)
        handles.append(ax.plot(pts[:, 0], pts[:, 1], m, color="k", mfc="w", ms=8, zorder=4,
                               gid=f"bifurcation={kind}")[0])
        labels.append(name)
    ax.legend(handles, labels, fontsize=8, title=legend_title, title_fontsize=8)
    ax.set(xlabel=xlabel, ylabel=ylabel, yscale=yscale)
    ax.xaxis.set_major_locator(MaxNLocator(nbins=8, steps=[1, 2, 2.5, 5, 10]))
    wrapped_title(ax, title, fontsize=11)
    ax.grid(alpha=0.3, which="both")
    return fig


def response_curves_figure(path, branches, **kwargs):
    """Amplitude against frequency, one curve per branch (paper Figs. 2, 4, 6).

    branches: [(label, frequency (P,), amplitude (P,), stable (P,), converged (P,))];
    `stable` is bool (True stable) or float (1.0 stable, 0.0 unstable, NaN not
    computed).  Stable parts solid, unstable parts dashed, parts whose stability was
    not computed dotted and labelled so (same colour); folds (turning points of the
    frequency) marked with open circles; non-converged points are gaps.  Keyword
    arguments as `response_curves_plot`.
    """
    plt = pyplot()
    fig = response_curves_plot(branches, **kwargs)
    out = atomic_savefig(fig, path)
    plt.close(fig)
    return out


def sector_peaks_distribution_figure(path, sectors, series, tuned_peak, *, dof="x",
                                     title="", tuned_note=None):
    """`sector_peaks_figure` for many mistuning seeds: each sector's peak over the
    seeds as a P5-P95 bar with its median, the seed with the largest amplification
    marked; axes, tuned line and right-hand ratio axis as there."""
    plt = pyplot()
    sectors = np.asarray(sectors)
    P = np.array([np.asarray(pk, float) for _, pk in series])      # (seeds, N)
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    lo, mid, hi = np.nanpercentile(P, (5, 50, 95), axis=0)
    ax.vlines(sectors, lo, hi, color="C0", lw=4, alpha=0.5,
              label=f"P5-P95 over {len(series)} seeds")
    ax.plot(sectors, mid, "_", color="C0", ms=12, mew=2, label="median")
    tuned_ok = bool(np.isfinite(tuned_peak))
    head = f"peak of {dof} per sector over {len(series)} mistuning seeds"
    if np.isfinite(P).any():
        w = int(np.nanargmax(np.nanmax(P, axis=1)))
        label, k = series[w][0], int(np.nanargmax(P[w]))
        ratio = (f": max / tuned = {P[w, k] / tuned_peak:.3f}" if tuned_ok
                 else f": max {P[w, k]:.4g} m")
        ax.plot(sectors, P[w], "o", color="C3", ms=4, label=f"{label} (the largest peak)"
                + ratio + f" (sector {sectors[k]})", zorder=3)
        if tuned_ok:
            head += f"; largest amplification = {P[w, k] / tuned_peak:.3f}"
    return _finish_sector_figure(plt, fig, ax, path, sectors, tuned_peak, tuned_note, dof,
                                 (title + "\n" if title else "") + head)


def sector_peaks_figure(path, sectors, series, tuned_peak, *, dof="x", title="",
                        tuned_note=None):
    """Peak amplitude per sector of a mistuned disk against the tuned disk's peak.

    sectors: (N,) sector numbers; series: [(label, peaks (N,) [m])], one per
    mistuning pattern; tuned_peak: the tuned disk's peak [m] (NaN if unknown, then
    `tuned_note` says why).  Each sector's peak is a marker on a stem from the tuned
    line; the legend gives each series' amplification factor max peak / tuned peak
    and its sector, the title the largest; the right-hand axis reads peak / tuned peak."""
    plt = pyplot()
    sectors = np.asarray(sectors)
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    markers = "osD^v<>p"
    n = max(len(series), 1)
    width = min(0.7 / n, 0.25)
    tuned_ok = bool(np.isfinite(tuned_peak))
    worst = None
    for i, (label, pk) in enumerate(series):
        pk = np.asarray(pk, float)
        x = sectors + (i - (n - 1) / 2) * width
        col = colours[i % len(colours)]
        text = label or "mistuned"
        if np.isfinite(pk).any():
            k = int(np.nanargmax(pk))
            if tuned_ok:
                amp = pk[k] / tuned_peak
                text += f": max / tuned = {amp:.3f} (sector {sectors[k]})"
                if worst is None or amp > worst[0]:
                    worst = (amp, label)
                ax.vlines(x, tuned_peak, pk, color=col, lw=1.2)
            else:
                text += f": max {pk[k]:.4g} m (sector {sectors[k]})"
        ax.plot(x, pk, markers[i % len(markers)], color=col, ms=6, label=text, zorder=3)
    head = f"peak of {dof} per sector"
    if worst is not None:
        head += f"; amplification max peak / tuned peak = {worst[0]:.3f}"
        head += f" ({worst[1]})" if worst[1] and len(series) > 1 else ""
    return _finish_sector_figure(plt, fig, ax, path, sectors, tuned_peak, tuned_note, dof,
                                 (title + "\n" if title else "") + head)


def _finish_sector_figure(plt, fig, ax, path, sectors, tuned_peak, tuned_note, dof, title):
    """What both sector-peak figures share: the tuned disk's line and the right-hand
    axis peak / tuned peak (or the note why there is none), axes, title, legend
    below; saved atomically and closed."""
    if np.isfinite(tuned_peak):
        ax.axhline(tuned_peak, color="k", lw=1.5, zorder=2,
                   label=f"tuned disk: {tuned_peak:.4g} m (no mistuning: one sector by the "
                         "cyclic reduction, same solver settings)")
        sec = ax.secondary_yaxis("right", functions=(lambda y: y / tuned_peak,
                                                     lambda r: r * tuned_peak))
        sec.set_ylabel("peak / tuned peak [-]")
    else:
        ax.plot([], [], color="k", lw=1.5,
                label="tuned disk: not available" + (f" ({tuned_note})" if tuned_note else ""))
    ax.set(xlabel="sector", ylabel=f"peak amplitude of {dof} [m]")
    wrapped_title(ax, title, fontsize=9)
    if sectors.size <= 24:
        ax.set_xticks(sectors)
    else:
        ax.xaxis.set_major_locator(integer_locator(16))
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=1,
              frameon=False)
    out = atomic_savefig(fig, path)
    plt.close(fig)
    return out


# ---------------------------------------------------------------------------
# Log axes over a narrow range
# ---------------------------------------------------------------------------

_LOG_SUBS = ((1.0,), (1.0, 2.0, 5.0), (1.0, 2.0, 3.0, 5.0), (1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 7.0),
             (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0))


def log_ticks(lo: float, hi: float, at_least: int = 3) -> np.ndarray:
    """Tick values for a log axis from lo to hi (> 0): the coarsest of the
    1 / 1-2-5 / 1-2-3-5 / ... sequences per decade with at least `at_least` values
    inside; over a range too narrow for any of them, evenly spaced round values."""
    lo, hi = sorted((float(lo), float(hi)))
    for subs in _LOG_SUBS:
        decades = np.arange(np.floor(np.log10(lo)) - 1, np.ceil(np.log10(hi)) + 1)
        t = np.unique(np.round((np.asarray(subs)[None, :] * 10.0 ** decades[:, None]).ravel(), 12))
        t = t[(t >= lo * (1 - 1e-9)) & (t <= hi * (1 + 1e-9))]
        if t.size >= at_least:
            return t
    from matplotlib.ticker import MaxNLocator
    for nbins in range(at_least + 1, 4 * at_least + 8):
        t = MaxNLocator(nbins=nbins, steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
        t = t[(t >= lo * (1 - 1e-12)) & (t <= hi * (1 + 1e-12))]
        if t.size >= at_least:
            return t
    return np.linspace(lo, hi, at_least)


def label_log_axis(axis):
    """Labelled major ticks (plain numbers, `log_ticks`) over the visible range of a
    log-scaled matplotlib axis (ax.xaxis / ax.yaxis), unlabelled minor ticks."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, LogLocator, NullFormatter
    ax = axis.axes
    get, set_ = (ax.get_xlim, ax.set_xlim) if axis.axis_name == "x" else (ax.get_ylim, ax.set_ylim)
    lo, hi = get()          # autoscaled to the data drawn so far; kept from here on
    set_(lo, hi)
    axis.set_major_locator(FixedLocator(log_ticks(lo, hi)))
    axis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    axis.set_minor_locator(LogLocator(base=10, subs=np.arange(1, 10), numticks=100))
    axis.set_minor_formatter(NullFormatter())


def modal_convergence_figure(path, res, title):
    """Relative error of each Craig-Bampton eigenfrequency against the mode count
    (modes study result `res`), log scale, the 0.1 % line dashed."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6, 4))
    err = np.abs(res["rel_error"])
    for j in range(err.shape[1]):
        ax.semilogy(res["mode_counts"], np.maximum(err[:, j], 1e-16), "o-", ms=3,
                    label=f"f{j + 1} = {res['full_hz'][j]:.4g} Hz")
    ax.axhline(1e-3, color="k", lw=0.8, ls="--")
    ax.set_xlabel("Craig-Bampton fixed-interface modes")
    ax.set_ylabel("relative frequency error (reduced/full - 1)")
    wrapped_title(ax, title, fontsize=9)
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
    return path
