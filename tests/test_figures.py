"""What the figures draw: stability styles of response curves, labelled log axes."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from pipeline.plots import (NOT_COMPUTED, STABLE, UNSTABLE, _plt, label_log_axis, log_ticks,
                            response_curves_plot, stability_for_plot, stability_states)


def _lines(fig):
    """(linestyle, x data) of every drawn curve (legend proxies have no data)."""
    return [(ln.get_linestyle(), np.asarray(ln.get_xdata(), float))
            for ln in fig.axes[0].get_lines() if len(ln.get_xdata())]


def test_stability_not_computed_is_never_drawn_as_stable():
    f = np.linspace(0.0, 1.0, 30)
    a = 1 + f
    stable = np.full(30, np.nan)                 # 0-9 stable, 10-19 not computed, 20-29 unstable
    stable[:10], stable[20:] = 1.0, 0.0
    fig = response_curves_plot([("case", f, a, stable, np.ones(30, bool))])
    try:
        lines = _lines(fig)
        unknown = f[10:20]
        # no solid line reaches into the not-computed part (its ends meet neighbours)
        for ls, x in lines:
            if ls == "-":
                assert not np.isin(unknown[1:-1], x).any()
        dotted = [x for ls, x in lines if ls == ":"]
        assert len(dotted) == 1 and np.isin(unknown, dotted[0]).all()
        assert any(ls == "--" and np.isin(f[20:], x).all() for ls, x in lines)
        legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert "stability not computed" in legend and "unstable" in legend
    finally:
        _plt().close(fig)


def test_bool_stability_is_solid_and_dashed_only():
    f = np.linspace(0.0, 1.0, 20)
    stable = np.arange(20) < 12
    fig = response_curves_plot([("case", f, f, stable, np.ones(20, bool))])
    try:
        styles = {ls for ls, _ in _lines(fig)}
        assert styles == {"-", "--"}
        legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert "stability not computed" not in legend
    finally:
        _plt().close(fig)


def test_stability_states_and_placeholder_stability():
    assert stability_states(np.array([True, False])).tolist() == [STABLE, UNSTABLE]
    assert stability_states(np.array([1.0, 0.0, np.nan])).tolist() == [STABLE, UNSTABLE,
                                                                      NOT_COMPUTED]
    placeholder = xr.DataArray(np.ones(3, bool), attrs={"stability_computed": 0})
    assert np.isnan(stability_for_plot(placeholder)).all()
    computed = xr.DataArray(np.ones(3, bool), attrs={"stability_computed": 1})
    assert stability_for_plot(computed).tolist() == [True, True, True]


@pytest.mark.parametrize("lo,hi", [(0.52, 1.04), (0.55, 0.87), (1.2, 1.9), (4.6, 30.0),
                                   (0.6, 25.0), (5.5, 6.5)])
def test_log_axis_has_at_least_three_labelled_ticks(lo, hi):
    assert len(log_ticks(lo, hi)) >= 3
    plt = _plt()
    fig, ax = plt.subplots()
    try:
        ax.plot([lo, hi], [1.0, 2.0])
        ax.set_xscale("log")
        ax.set_xlim(lo, hi)
        label_log_axis(ax.xaxis)
        fig.canvas.draw()
        shown = [t.get_text() for t in ax.get_xticklabels(which="both")
                 if t.get_text() and lo <= t.get_position()[0] <= hi]
        assert len(shown) >= 3, shown
    finally:
        plt.close(fig)
