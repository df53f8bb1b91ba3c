"""What the figures draw: stability styles of response curves, labelled log time
axes, and the mistuned disk's peak-per-sector figure in both dataset layouts."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from pipeline.study.figures.disk_figures import by_sector, sector_and_dof, write_sector_figures
from pipeline.study.execution.mistuned import TunedCurve
from pipeline.study.figures.plots import (NOT_COMPUTED, STABLE, UNSTABLE, pyplot, label_log_axis, log_ticks,
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
        lg = fig.axes[0].get_legend()
        legend = [t.get_text() for t in lg.get_texts()]
        assert "dotted: stability not computed" in legend and "dashed: unstable" in legend
        # the line-style key is grey: not the tuned disk's black, not a branch's colour
        from matplotlib.colors import to_rgb
        for h, t in zip(lg.legend_handles, legend):
            if t.startswith(("dotted", "dashed")):
                assert to_rgb(h.get_color()) not in (to_rgb("k"), to_rgb("C0"))
    finally:
        pyplot().close(fig)


def test_bool_stability_is_solid_and_dashed_only():
    f = np.linspace(0.0, 1.0, 20)
    stable = np.arange(20) < 12
    fig = response_curves_plot([("case", f, f, stable, np.ones(20, bool))])
    try:
        styles = {ls for ls, _ in _lines(fig)}
        assert styles == {"-", "--"}
        legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert not any("stability not computed" in t for t in legend)
    finally:
        pyplot().close(fig)


def test_stability_states_and_placeholder_stability():
    assert stability_states(np.array([True, False])).tolist() == [STABLE, UNSTABLE]
    assert stability_states(np.array([1.0, 0.0, np.nan])).tolist() == [STABLE, UNSTABLE,
                                                                      NOT_COMPUTED]
    placeholder = xr.DataArray(np.ones(3, bool), attrs={"stability_computed": 0})
    assert np.isnan(stability_for_plot(placeholder)).all()
    computed = xr.DataArray(np.ones(3, bool), attrs={"stability_computed": 1})
    assert stability_for_plot(computed).tolist() == [True, True, True]


def test_log_ticks_never_fewer_than_three_over_any_range():
    """Every range from 2 % wide to three decades, at every position in a decade,
    gets at least three labelled ticks inside it."""
    for lo in np.geomspace(0.01, 100.0, 97):
        for ratio in np.geomspace(1.02, 1000.0, 61):
            t = log_ticks(lo, lo * ratio)
            assert t.size >= 3, (lo, lo * ratio, t)
            assert t.min() >= lo * (1 - 1e-9) and t.max() <= lo * ratio * (1 + 1e-9)


@pytest.mark.parametrize("lo,hi", [(1.3, 1.79), (0.52, 1.04), (0.55, 0.87), (1.2, 1.9), (4.6, 30.0),
                                   (0.6, 25.0), (5.5, 6.5)])
def test_log_axis_has_at_least_three_labelled_ticks(lo, hi):
    assert len(log_ticks(lo, hi)) >= 3
    plt = pyplot()
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


def test_sector_and_dof_reads_both_label_forms():
    assert sector_and_dof("x1@4") == (4, "x1")
    assert sector_and_dof("x1@11") == (11, "x1")
    assert sector_and_dof("x1") == (None, "x1")
    assert sector_and_dof("a@b") == (None, "a@b")


def _mistuned_datasets():
    """The same two-seed, three-sector data in both layouts: `<dof>@<sector>` labels
    and a `sector` dimension."""
    rng = np.random.default_rng(0)
    P, N = 25, 3
    f = np.linspace(300.0, 500.0, P)
    amp = 1e-6 * (1 + rng.random((2, P, N)))
    peak = amp.max(axis=1)
    peak[1, 2] = 3e-6                                   # seed 2, sector 2: 1.5 x tuned
    common = {"frequency": (("mistuning_seed", "point"), np.tile(f, (2, 1)), {"units": "Hz"}),
              "converged": (("mistuning_seed", "point"), np.ones((2, P), bool)),
              "stable": (("mistuning_seed", "point"), np.ones((2, P), bool),
                         {"stability_computed": 1})}
    coords = {"mistuning_seed": [1, 2], "point": np.arange(P)}
    labels = xr.Dataset({**common,
                         "amplitude": (("mistuning_seed", "point", "dof"), amp),
                         "peak_amplitude": (("mistuning_seed", "dof"), peak)},
                        coords={**coords, "dof": [f"x1@{j}" for j in range(N)]})
    sectors = xr.Dataset({**common,
                          "amplitude": (("mistuning_seed", "point", "sector", "dof"),
                                        amp[..., None]),
                          "peak_amplitude": (("mistuning_seed", "sector", "dof"),
                                             peak[..., None])},
                         coords={**coords, "sector": np.arange(N), "dof": ["x1"]})
    return labels, sectors, peak


class _Study:
    """The parts of a mistuned disk study the figures read."""

    class scene:
        class mistuning:
            seed = None

    class sweep:
        axes = {"mistuning_seed": (1, 2)}

    class output:
        yscale = "log"

    title = "three-sector disk"


@pytest.mark.parametrize("layout", ["labels", "sector"])
def test_peak_per_sector_figure_from_either_layout(tmp_path, layout, monkeypatch):
    labels, sectors, peak = _mistuned_datasets()
    ds = labels if layout == "labels" else sectors
    got = by_sector(ds["peak_amplitude"])
    assert list(got) == ["x1"] and got["x1"].dims == ("mistuning_seed", "sector")
    np.testing.assert_array_equal(got["x1"].values, peak)

    import pipeline.study.figures.plots as plots
    drawn = {}
    real = plots.sector_peaks_figure

    def spy(path, sec, series, tuned_peak, **kw):
        drawn.update(sectors=list(sec), series=series, tuned=tuned_peak)
        return real(path, sec, series, tuned_peak, **kw)
    monkeypatch.setattr(plots, "sector_peaks_figure", spy)

    f = np.linspace(300.0, 500.0, 25)
    tuned = TunedCurve(f, {"x1": np.full(25, 2e-6)}, np.full(25, np.nan), np.ones(25, bool),
                       {"x1": 2e-6})
    paths = write_sector_figures(_Study, ds, tmp_path, tuned=lambda case: tuned)
    assert sorted(p.name for p in paths) == ["amplitude_x1_mistuning_seed=1.png",
                                             "amplitude_x1_mistuning_seed=2.png",
                                             "peak_per_sector_x1.png"]
    assert all(p.stat().st_size > 5_000 for p in paths)
    assert drawn["sectors"] == [0, 1, 2] and drawn["tuned"] == 2e-6
    assert [lab for lab, _ in drawn["series"]] == ["seed 1", "seed 2"]
    np.testing.assert_array_equal(drawn["series"][1][1], peak[1])


@pytest.fixture
def saved_texts(monkeypatch):
    """The title, then the legend entries, of every figure saved (in order)."""
    import matplotlib.figure

    texts = []
    real_save = matplotlib.figure.Figure.savefig

    def save(fig, *a, **kw):
        texts.append(fig.axes[0].get_title())
        texts.extend(t.get_text() for t in fig.axes[0].get_legend().get_texts())
        return real_save(fig, *a, **kw)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", save)
    return texts


def test_peak_per_sector_figure_states_the_amplification(tmp_path, saved_texts):
    from pipeline.study.figures.plots import sector_peaks_figure

    titles = saved_texts
    sector_peaks_figure(tmp_path / "p.png", [0, 1, 2],
                        [("seed 1", [1e-6, 2.2e-6, 1.8e-6]), ("seed 2", [2.4e-6, 2e-6, 1e-6])],
                        2e-6, dof="x1")
    assert "amplification max peak / tuned peak = 1.200 (seed 2)" in titles[0]
    assert "seed 1: max / tuned = 1.100 (sector 1)" in titles
    assert any(t.startswith("tuned disk: 2e-06 m") for t in titles)


def test_peak_distribution_figure_of_many_seeds_marks_the_worst(tmp_path, saved_texts):
    """Twenty seeds: one P5-P95 bar per sector, the seed with the largest peak marked
    with its amplification (2.5e-6 / 2e-6 = 1.25, sector 2) in the key and title."""
    from pipeline.study.figures.plots import sector_peaks_distribution_figure

    texts = saved_texts
    rng = np.random.default_rng(0)
    series = [(f"seed {k}", 2e-6 * (1 + 0.05 * rng.uniform(-1, 1, 4))) for k in range(20)]
    series[7] = ("seed 7", [2e-6, 2.1e-6, 2.5e-6, 1.9e-6])
    out = sector_peaks_distribution_figure(tmp_path / "d.png", [0, 1, 2, 3], series, 2e-6,
                                           dof="x1")
    assert out.exists()
    assert "largest amplification = 1.250" in texts[0]
    assert "seed 7 (the largest peak): max / tuned = 1.250 (sector 2)" in texts
    assert "P5-P95 over 20 seeds" in texts


def test_zero_mistuning_puts_every_sector_on_the_tuned_peak(tmp_path, monkeypatch):
    """disk_mistuned.toml with stiffness_std = 0 (6 sectors, H = 1, around the peak),
    run with figures: the full assembly's sector peaks all equal the tuned reference
    the figure computes on one sector by the cyclic reduction."""
    import copy
    import tomllib
    from pathlib import Path

    import pipeline.study.figures.plots as plots
    from pipeline.study.files.documents import study_from_document
    from pipeline.study.execution.run import run_study

    path = Path(__file__).resolve().parents[3] / "studies" / "disk_mistuned.toml"
    doc = copy.deepcopy(tomllib.loads(path.read_text()))
    doc["scene"]["disk"].update(sectors=6, engine_order=2, mistuning={"stiffness_std": 0.0})
    doc["solver"].update(harmonics=1, stability=False)
    doc["sweep"] = {"mistuning_seed": [1],
                    "frequency": {"start": 400.0, "stop": 470.0, "unit": "Hz"}}
    doc.pop("quick")
    st = study_from_document(doc, file=str(tmp_path / "zero.toml"), name="zero")
    drawn = {}
    real = plots.sector_peaks_figure

    def spy(path, sec, series, tuned_peak, **kw):
        drawn.update(series=series, tuned=tuned_peak)
        return real(path, sec, series, tuned_peak, **kw)
    monkeypatch.setattr(plots, "sector_peaks_figure", spy)
    res = run_study(st, tmp_path, workers=1, progress=False)
    assert res.ok
    assert sorted(p.name for p in res.figures) == ["amplification_x1.png",
                                                   "amplitude_x1_mistuning_seed=1.png",
                                                   "peak_per_sector_x1.png"]
    (label, peaks), = drawn["series"]
    assert label == "seed 1" and len(peaks) == 6
    np.testing.assert_allclose(peaks, drawn["tuned"], rtol=1e-6)


def test_folds_circled_unless_located_folds_are_marked():
    """A branch turning back twice: its turning points are circled ("fold") when no
    bifurcation marks are given; with the located folds marked (squares), nothing else
    is drawn or listed for them."""
    s = np.linspace(0.0, 1.0, 41)
    f = s + 0.3 * np.sin(2 * np.pi * s)           # turns back twice
    a = 1 + s
    conv = np.ones(s.size, bool)
    turns = np.flatnonzero(np.diff(f)[:-1] * np.diff(f)[1:] < 0) + 1
    assert turns.size == 2
    plain = response_curves_plot([("case", f, a, np.ones(s.size, bool), conv)])
    marks = [(f[i], a[i], 1) for i in turns]
    marked = response_curves_plot([("case", f, a, np.ones(s.size, bool), conv)], marks=marks)
    try:
        def legend(fig):
            return [t.get_text() for t in fig.axes[0].get_legend().get_texts()]

        def circles(fig):
            return [ln for ln in fig.axes[0].get_lines() if ln.get_marker() == "o" and
                    len(ln.get_xdata())]

        assert "fold" in legend(plain) and len(circles(plain)) == 1
        assert np.allclose(circles(plain)[0].get_xdata(), f[turns])
        assert "fold" not in legend(marked) and "fold bifurcation" in legend(marked)
        assert not circles(marked)
        # a turn whose stability does not change (no mark there) keeps its circle
        one = response_curves_plot([("case", f, a, np.ones(s.size, bool), conv)],
                                   marks=marks[:1])
        try:
            assert "fold" in legend(one) and len(circles(one)) == 1
            assert np.allclose(circles(one)[0].get_xdata(), f[turns[1]])
        finally:
            pyplot().close(one)
    finally:
        pyplot().close(plain)
        pyplot().close(marked)


def test_a_single_marked_turn_is_not_circled_too():
    """One turn, its located fold a little off the drawn point (between two points):
    the square alone marks it, whatever the distance between the two compared with
    the (zero) spread of the turns themselves."""
    s = np.linspace(0.0, 1.0, 41)
    f = 1.0 - (s - 0.5) ** 2                      # turns back once, at s = 0.5
    a = 1 + s
    conv = np.ones(s.size, bool)
    turn = np.flatnonzero(np.diff(f)[:-1] * np.diff(f)[1:] < 0) + 1
    assert turn.size == 1
    mark = [(f[turn[0]] + 1e-4, a[turn[0]] + 5e-3, 1)]
    for yscale in ("linear", "log"):
        fig = response_curves_plot([("case", f, a, np.ones(s.size, bool), conv)], marks=mark,
                                   yscale=yscale)
        try:
            legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
            assert "fold" not in legend and "fold bifurcation" in legend
        finally:
            pyplot().close(fig)
