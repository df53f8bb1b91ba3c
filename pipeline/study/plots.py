"""Figures (matplotlib, Agg backend): hysteresis loops, response curves and the
accuracy-cost Pareto figure."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..contact import STATE_NAMES, YangMenq
from ..contact.exact import history

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


def demo_motion(H: int = 3):
    """u = 3 cos tau, v = 0.5 cos tau + 2 sin tau [m]: with mu = 0.4, ku = kv = 1 N/m
    and n0 = 1 N it visits separation, positive slip, stick and negative slip."""
    U = np.zeros((1, 2 * H + 1))
    V = np.zeros((1, 2 * H + 1))
    U[0, 1] = 3.0
    V[0, 1], V[0, 2] = 0.5, 2.0
    return U, V


def hysteresis_figure(path, mu=0.4, ku=1.0, kv=1.0, n0=1.0, U=None, V=None, n_points=2000):
    """Time history of f_u, f_v and the loop f_u(u) (paper Fig. 5), coloured by state."""
    if U is None:
        U, V = demo_motion()
    elem = YangMenq(ku=ku, kv=kv, mu=mu, n0=n0)
    tau = np.linspace(0.0, 2 * np.pi, n_points + 1)
    h = history(U, V, elem, tau)
    st, fu, fv, u = h["state"][0], h["fu"][0], h["fv"][0], h["u"][0]
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
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
    a1.legend(fontsize=8, loc="lower left")
    a2.legend(fontsize=8)
    for a in (a1, a2):
        a.grid(alpha=0.3)
    fig.suptitle(f"Yang-Menq element: mu = {mu}, ku = {ku} N/m, kv = {kv} N/m, n0 = {n0} N")
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
_STATE_LEGEND = {UNSTABLE: "unstable", NOT_COMPUTED: "stability not computed"}
# marker per bifurcation type (dataset `bifurcation_type`): 1 fold, 2 period doubling,
# 3 Neimark-Sacker
BIFURCATION_MARKERS = {1: ("s", "fold bifurcation"), 2: ("v", "period doubling"),
                       3: ("*", "Neimark-Sacker")}


def response_curves_plot(branches, *, xlabel="frequency [rad/s]", ylabel="amplitude [m]",
                         title="", yscale="linear", legend_title=None, marks=()):
    """The figure of `response_curves_figure`, left open (for saving or inspection).

    A branch may carry a sixth element, a dict of Line2D properties (color, lw,
    alpha, zorder) that override its defaults; label None leaves it out of the legend.
    marks: [(frequency, amplitude, type)] bifurcations, a marker per type
    (`BIFURCATION_MARKERS`), each type once in the legend.  Without located folds
    among them, the turning points of the drawn curves are circled ("fold")."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    states_seen, any_fold = set(), False
    circle_folds = not any(int(k) == 1 for _, _, k in marks)  # else squares mark them
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
            folds = fold_indices(fs) if circle_folds else np.empty(0, int)
            if folds.size:
                any_fold = True
                ax.plot(fs[folds], as_[folds], "o", mfc="none", mec=col, ms=6)
    handles, labels = ax.get_legend_handles_labels()
    for s in (UNSTABLE, NOT_COMPUTED):
        if s in states_seen:
            handles.append(ax.plot([], [], color="k", **_STYLE[s])[0])
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
    ax.set(xlabel=xlabel, ylabel=ylabel, title=title, yscale=yscale)
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
    if tuned_ok:
        ax.axhline(tuned_peak, color="k", lw=1.5, zorder=2,
                   label=f"tuned disk: {tuned_peak:.4g} m (no mistuning: one sector by the "
                         "cyclic reduction, same solver settings)")
        sec = ax.secondary_yaxis("right", functions=(lambda y: y / tuned_peak,
                                                     lambda r: r * tuned_peak))
        sec.set_ylabel("peak / tuned peak [-]")
    else:
        ax.plot([], [], color="k", lw=1.5,
                label="tuned disk: not available" + (f" ({tuned_note})" if tuned_note else ""))
    head = f"peak of {dof} per sector"
    if worst is not None:
        head += f"; amplification max peak / tuned peak = {worst[0]:.3f}"
        head += f" ({worst[1]})" if worst[1] and len(series) > 1 else ""
    ax.set(xlabel="sector", ylabel=f"peak amplitude of {dof} [m]",
           title=(title + "\n" if title else "") + head)
    ax.title.set_fontsize(9)
    if sectors.size <= 36:
        ax.set_xticks(sectors)
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


def optimum_figure(path, result, dof, title=""):
    """Resonant peak vs preload from the optimum search (log-log), optimum marked."""
    ev = np.array(result["evaluations"], dtype=float).reshape(-1, 3)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.loglog(ev[:, 0], ev[:, 1], "o-", color="#1f77b4", label="evaluated by the search")
    ax.loglog([result["preload"]], [result["peak"]], "*", ms=14, color="#d62728",
              label=f"optimum {result['preload']:.4g} N")
    ax.set(xlabel="preload n0 [N]", ylabel=f"resonant peak of {dof} [m]",
           title=title or "Optimum preload")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    out = atomic_savefig(fig, path)
    plt.close(fig)
    return out


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
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
    return path


# ---------------------------------------------------------------------------
# Accuracy against cost (accuracy_cost.py): error against wall time
# ---------------------------------------------------------------------------

def pareto_figure(path, ds, title: str | None = None):
    """`pareto_plot` written to `path` (PNG)."""
    fig = pareto_plot(ds, title)
    out = atomic_savefig(fig, path)
    pyplot().close(fig)
    return out


def pareto_plot(ds, title: str | None = None):
    """Error against wall time (log-log) from an accuracy dataset: one panel per case,
    one series per knob (through the baseline, from the cheapest to the most accurate
    value), the baseline (open square), the recommended combination (star), the
    target (dashed), the reference's wall time (dotted) and, for the lumped case, the
    reference's discrepancy to event-driven time integration (dash-dot).  An error of
    0 (the reference itself) is drawn on the bottom edge, a missed fold on the top.
    Returns the open figure."""
    plt = pyplot()
    cases = list(dict.fromkeys(ds["case"].values.tolist()))
    target = float(ds.attrs["target"])
    fig, axes = plt.subplots(1, len(cases), figsize=(6.0 * len(cases), 5.6), squeeze=False)
    markers = "osD^v<>p"
    for ax, c in zip(axes[0], cases):
        sub = ds.isel(run=np.flatnonzero(ds["case"].values == c))
        knob = sub["knob"].values.tolist()
        t, err = sub["wall_time"].values, sub["error"].values
        i_ref, i_base, i_rec = (knob.index(k) for k in ("reference", "baseline", "recommended"))
        ti = None
        if f"{c}_time_integration_amplitude_error" in ds:
            ti = max(float(ds[f"{c}_time_integration_amplitude_error"]),
                     float(ds[f"{c}_time_integration_peak_frequency_error"]))
        pos = [e for e in list(err) + [ti or np.nan, target] if np.isfinite(e) and e > 0]
        lo = 10 ** np.floor(np.log10(min(pos))) / 10

        def shown(e):
            return lo if e == 0 else 2.0 if np.isinf(e) else e

        series = [k for k in dict.fromkeys(knob) if k not in ("reference", "baseline",
                                                               "recommended")]
        for j, k in enumerate(series):
            idx = sorted([i_base] + [i for i, kk in enumerate(knob) if kk == k],
                         key=lambda i: _order(sub, i, k))
            ax.plot(t[idx], [shown(err[i]) for i in idx], marker=markers[j % len(markers)],
                    ms=5, lw=1, label=_KNOB_LABELS.get(k, k))
            dense = k in ("tolerance", "max_step")   # values on one level: label the ends
            ends = [i for i in idx if i != i_base]
            for i in idx:
                if i == i_base or (dense and i not in (ends[0], ends[-1])):
                    continue
                ax.annotate(_short(sub, i, k), (t[i], shown(err[i])), fontsize=6,
                            xytext=(3, 3), textcoords="offset points")
        val = sub["value"].values
        ax.plot([t[i_base]], [shown(err[i_base])], "ks", mfc="none", ms=10,
                label="baseline: " + _wrap(str(val[i_base])))
        ax.plot([t[i_rec]], [shown(err[i_rec])], "*", color="gold", mec="k", ms=14,
                label="recommended: " + _wrap(str(val[i_rec])))
        ax.axvline(t[i_ref], color="k", ls=":", lw=1,
                   label="reference: " + _wrap(str(val[i_ref])))
        ax.axhline(target, color="grey", ls="--", lw=1, label=f"target {target:g}")
        if ti is not None:
            ax.axhline(shown(ti), color="tab:purple", ls="-.", lw=1,
                       label=f"reference vs event-driven time integration: {ti:.1e}")
        if np.isinf(err).any():
            ax.text(0.99, 0.985, "top edge: a fold missed", transform=ax.transAxes, fontsize=6,
                    ha="right", va="top")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylim(lo / 1.5, 3.0)
        label_log_axis(ax.xaxis)   # 1-2-5 (or finer) seconds over the range drawn
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("largest relative error (bottom edge: the reference itself)")
        dof = str(sub["response_dof"].values[0])
        pre = ds.attrs.get(f"{c}_preload")
        ax.set_title(f"{c}: peak of {dof}" + (f", preload {pre:g} N" if pre is not None else "")
                     + "\nerror of peak amplitude, peak and fold frequencies vs the reference",
                     fontsize=8)
        ax.grid(True, which="major", lw=0.3)
        ax.legend(fontsize=6, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2,
                  frameon=False)
    fig.suptitle(title if title is not None else ds.attrs.get("title", ""), fontsize=10)
    fig.tight_layout()
    return fig


_KNOB_LABELS = {"harmonics": "harmonics H", "samples": "AFT samples N (then exact)",
                "tolerance": "Newton tolerance", "max_step": "largest continuation step",
                "craig_bampton_modes": "Craig-Bampton modes", "mesh": "mesh (chord x thickness x span)"}


def _wrap(text: str) -> str:
    return text.replace(", tolerance", "\ntolerance")


def _knob_value(sub, i, knob):
    """The value of `knob` in run i of a dataset (from its settings variables)."""
    if knob == "samples":
        n = int(sub["samples"].values[i])
        return "exact" if n < 0 else n
    if knob == "mesh":
        return str(sub["mesh"].values[i])
    v = sub[knob].values[i]
    return float(v) if knob in ("tolerance", "max_step") else int(v)


def _order(sub, i, knob):
    """Sort key along a knob's series: from the cheapest to the most accurate value."""
    v = _knob_value(sub, i, knob)
    if knob == "samples":
        return math.inf if v == "exact" else v
    if knob in ("tolerance", "max_step"):
        return -v
    if knob == "mesh":
        counts = tuple(int(x) for x in v.split("x"))
        return (int(np.prod(counts)), counts)
    return v


def _short(sub, i, knob) -> str:
    v = _knob_value(sub, i, knob)
    return f"{v:g}" if isinstance(v, float) else str(v)
