"""The accuracy-cost Pareto figure (`accuracy_study`): error against wall time per knob."""
from __future__ import annotations

import math

import numpy as np

from .plots import atomic_savefig, label_log_axis, pyplot, wrapped_title


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
    wrapped_title(fig, title if title is not None else ds.attrs.get("title", ""),
                  fontsize=10)
    fig.tight_layout()
    return fig


_KNOB_LABELS = {"harmonics": "harmonics H", "samples": "AFT samples N (then exact)",
                "tolerance": "Newton tolerance", "max_step": "largest continuation step",
                "craig_bampton_modes": "Craig-Bampton modes", "mesh": "mesh (chord x thickness x span)",
                "forced_response": "synthesised from the nonlinear mode"}


def _wrap(text: str) -> str:
    return text.replace(", tolerance", "\ntolerance")


def _knob_value(sub, i, knob):
    """The value of `knob` in run i of a dataset (from its settings variables)."""
    if knob == "samples":
        n = int(sub["samples"].values[i])
        return "exact" if n < 0 else n
    if knob in ("mesh", "forced_response"):
        return str(sub[knob].values[i])
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
    if knob == "forced_response":     # the synthesis, then the harmonic balance (baseline)
        return 0 if v == "nonlinear_mode" else 1
    return v


def _short(sub, i, knob) -> str:
    v = _knob_value(sub, i, knob)
    return f"{v:g}" if isinstance(v, float) else str(v)
