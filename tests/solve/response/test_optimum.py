"""The global optimum-preload search: grid, brackets, Brent; resumable from its kept
evaluations."""
import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import pipeline.solve.response.peak_tracking as response
from pipeline.solve.response.optimum import (brent, global_minimum, grid_nodes, local_minima,
                                             parabola_floor)
from pipeline.study.execution.search_checkpoint import load_search, save_search, search_file

BOUNDS = (0.1, 100.0)
T_LOCAL, T_GLOBAL = 0.3, 3.0        # ln n0 of the two minima: 1.35 N and 20.09 N


def bimodal(n0):
    """Peak [m] against preload [N]: the smaller of two parabolas in t = ln n0, a broad
    basin at t = 0.3 (value 0.6) and a deeper, narrower one at t = 3 (value 0.4).  The
    global minimum is exactly n0 = e^3 = 20.0855 N, peak 0.4."""
    t = math.log(n0)
    return min(0.6 + 0.2 * (t - T_LOCAL) ** 2, 0.4 + 1.5 * (t - T_GLOBAL) ** 2)


class FakeCurve:
    """Stands for a ResponseCurve whose exact peak is `bimodal(n0)` at 10 n0 rad/s."""

    success, message = True, ""
    Q = np.zeros((1, 1, 3))
    info = {"unresolved_resonance_steps": 0}

    def __init__(self, n0):
        self.n0 = n0

    def peak(self, dof):
        return bimodal(self.n0), 10.0 * self.n0, 0


@pytest.fixture
def fake_peaks(monkeypatch):
    """The search's frequency responses and local peaks replaced by `FakeCurve`
    (build(n0) = n0); returns the list of preloads evaluated over the band, in order,
    with the local ones in its attribute `local`."""
    calls = Calls()

    def fake(system, H, a, b, **kw):
        calls.append(system)
        return FakeCurve(system)

    def fake_local(system, H, omega, Q, dof, a, b, **kw):
        calls.local.append(system)
        return FakeCurve(system)

    monkeypatch.setattr(response, "frequency_response", fake)
    monkeypatch.setattr(response, "local_peak", fake_local)
    return calls


class Calls(list):
    """Preloads evaluated over the band; `local`: those valued by a local peak."""

    def __init__(self):
        super().__init__()
        self.local = []


def test_a_plain_bounded_brent_lands_in_the_local_basin():
    """The constructed curve defeats a bounded Brent over the whole bounds (the first
    golden point, 1.40 N, lies in the broad basin): it returns the local minimum."""
    res = minimize_scalar(lambda t: bimodal(math.exp(t)), bounds=np.log(BOUNDS),
                          method="bounded", options={"xatol": 1e-3})
    assert math.exp(res.x) == pytest.approx(math.exp(T_LOCAL), rel=1e-2)
    assert res.fun == pytest.approx(0.6, rel=1e-4)


def test_optimum_preload_finds_the_global_minimum_of_a_bimodal_curve(fake_peaks):
    """The search returns the deeper basin's minimiser e^3 N to its tolerance (a plain
    bounded Brent, the search's earlier form, returned 1.35 N here); both basins are
    bracketed, the shallow one (its parabola 50 % above the best) not refined, and
    every preload evaluated is listed, sorted, once."""
    opt = response.optimum_preload(lambda n0: n0, 1, 1.0, 2.0, 0, BOUNDS, rtol=1e-3)
    assert opt["success"]
    assert opt["preload"] == pytest.approx(math.exp(T_GLOBAL), rel=2e-3)
    assert opt["peak"] == pytest.approx(0.4, rel=1e-5)
    assert opt["peak_omega"] == pytest.approx(10.0 * opt["preload"], rel=1e-12)
    n0 = [e[0] for e in opt["evaluations"]]
    assert n0 == sorted(n0) and len(set(n0)) == len(n0)
    assert len(set(fake_peaks)) == len(fake_peaks)     # nothing evaluated twice
    assert len(set(fake_peaks.local)) == len(fake_peaks.local)
    assert sorted(set(fake_peaks) | set(fake_peaks.local)) == n0
    # Brent's trials by local peaks, the bracket's result once over the band
    assert set(opt["local"]) == set(fake_peaks.local) - set(fake_peaks)
    assert [v[0] for v in opt["verified"]] == [opt["preload"]]
    assert fake_peaks[-1] == opt["preload"] and opt["preload"] in fake_peaks.local
    nodes = [b[1] for b in opt["brackets"]]
    assert len(nodes) == 2
    assert any(abs(math.log(x) - T_LOCAL) < 0.6 for x in nodes)
    assert any(abs(math.log(x) - T_GLOBAL) < 0.6 for x in nodes)
    assert [abs(math.log(b[1]) - T_LOCAL) < 0.6 for b in opt["skipped"]] == [True]
    # cost: the 13 nodes of 3 decades, then Brent's parabolic steps (exact on a parabola)
    assert len(opt["grid"]) == 13 and len(fake_peaks) == 13 + 1
    assert len(fake_peaks.local) <= 6


@pytest.mark.parametrize("local, refined", [(0.43, True), (0.6, False)])
def test_a_basin_is_refined_unless_its_parabola_stays_above_the_best(local, refined):
    """Two basins: the deeper one (0.4) is refined first; the other is refined too when
    its nodes' parabola comes within SKIP_REL = 10 % of it (0.43), not when it stays
    50 % above (0.6) -- then the evaluations stop after the first bracket."""
    def curve(n0):
        t = math.log(n0)
        return (min(local + 0.2 * (t - T_LOCAL) ** 2, 0.4 + 1.5 * (t - T_GLOBAL) ** 2), 1.0)

    opt = global_minimum(curve, BOUNDS, rtol=1e-3)
    assert len(opt["brackets"]) == 2 and len(opt["skipped"]) == (0 if refined else 1)
    assert opt["preload"] == pytest.approx(math.exp(T_GLOBAL), rel=2e-3)
    near_local = [n0 for n0, _, _ in opt["evaluations"] if abs(math.log(n0) - T_LOCAL) < 0.05]
    assert bool(near_local) == refined


def test_parabola_floor_is_the_vertex_of_three_nodes():
    """The parabola through three nodes of 3 + 2 (t - 1.3)^2: its vertex value 3 (1e-12);
    concave nodes or an end node: the lowest node value."""
    t = [0.0, 1.0, 2.0]
    assert parabola_floor(t, [3 + 2 * (x - 1.3) ** 2 for x in t], 1) == pytest.approx(3.0, abs=1e-12)
    assert parabola_floor(t, [1.0, 2.0, 1.5], 1) == 1.0
    assert parabola_floor(t, [1.0, 2.0, 1.5], 0) == 1.0


def test_a_dip_narrower_than_the_grid_spacing_can_be_missed():
    """The stated assumption: a basin narrower than the node spacing (here 0.05 in
    ln n0 against 0.58) that lies between two nodes is not bracketed; the search
    returns the best minimum it did bracket.  With four times the nodes it is found."""
    def narrow(n0):
        t = math.log(n0)
        return (min(0.6 + 0.2 * (t - T_LOCAL) ** 2, 0.3 + 400.0 * (t - 2.6) ** 2), 1.0)

    coarse = global_minimum(narrow, BOUNDS, rtol=1e-3)
    assert coarse["preload"] == pytest.approx(math.exp(T_LOCAL), rel=2e-3)
    fine = global_minimum(narrow, BOUNDS, rtol=1e-3, per_decade=16)
    assert fine["preload"] == pytest.approx(math.exp(2.6), rel=2e-3)
    assert fine["peak"] == pytest.approx(0.3, rel=1e-5)


def test_grid_nodes_log_spaced_with_the_cases_added():
    """[0.1, 100] N spans 3 decades: 13 nodes a factor 10^(1/4) apart, the bounds
    exactly; cases inside the bounds join (1 N already is a node: once), each in place
    of a regular node within a third of the spacing (0.3 N for 0.316 N, 3 N for 3.16 N;
    2.4 N, half a spacing from 1.78 N and 3.16 N, joins beside them); the bounds stay."""
    g = grid_nodes(0.1, 100.0)
    assert g.size == 13 and g[0] == 0.1 and g[-1] == 100.0
    np.testing.assert_allclose(np.diff(np.log10(g)), 0.25, rtol=1e-12)
    h = grid_nodes(0.1, 100.0, extra=[0.3, 1.0, 3.0, 1000.0])
    assert h.size == 13 and 0.3 in h and 3.0 in h and 1000.0 not in h
    assert not np.any(np.isclose(h, 10 ** -0.5)) and not np.any(np.isclose(h, 10 ** 0.5))
    assert np.diff(np.log10(h)).max() <= 0.25 * (1 + 1 / 3)
    k = grid_nodes(0.1, 100.0, extra=[2.4, 0.105])
    assert k.size == 15 and 2.4 in k and np.any(np.isclose(k, 10 ** 0.25)) and k[0] == 0.1
    assert grid_nodes(2.0, 5.0).size == 7                 # at least MIN_NODES
    np.testing.assert_allclose(np.diff(grid_nodes(2.0, 5.0, log=False)), 0.5)


def test_local_minima_skip_plateaus_and_failures():
    v = [3.0, 2.0, 2.5, 1.0, 1.0 + 1e-12, 1.0, np.inf, 0.5]
    # 1: a basin; 3: a basin (flat to its right, deep to its left); not 5: its only
    # finite neighbour is equal within FLAT_REL (a plateau beside a failed evaluation);
    # 7: the end node, below a failed evaluation
    assert local_minima(v) == [1, 3, 7]
    assert local_minima([1.0, 1.0 + 1e-13, 1.0 - 1e-13]) == []
    assert local_minima([np.inf, np.inf]) == []


def test_brent_from_a_known_point_converges_on_a_parabola():
    calls = []

    def f(x):
        calls.append(x)
        return (x - 0.7) ** 2

    x, fx = brent(f, 0.0, 2.0, 1e-6, x=0.5, fx=f(0.5))
    assert x == pytest.approx(0.7, abs=1e-6) and fx < 1e-11
    assert all(0.0 < c < 2.0 for c in calls) and len(calls) < 12


def test_failed_evaluations_are_never_the_optimum():
    """An incomplete curve (inf) between good ones is listed as NaN, never chosen."""
    def f(n0):
        return (np.inf, np.nan) if 5.0 < n0 < 12.0 else (abs(math.log(n0 / 8.0)) + 1.0, 1.0)

    res = global_minimum(f, BOUNDS, rtol=1e-3)
    assert res["success"] and res["peak"] > 1.0
    assert not (5.0 < res["preload"] < 12.0)
    assert any(np.isnan(p) for _, p, _ in res["evaluations"])


# ---------------------------------------------------------------------------
# interrupted and resumed
# ---------------------------------------------------------------------------

class Interrupt:
    """evaluate(n0) of `bimodal`, counting calls, raising KeyboardInterrupt at call
    `stop_at` (None: never)."""

    def __init__(self, stop_at=None):
        self.calls, self.stop_at = [], stop_at

    def __call__(self, n0):
        if self.stop_at is not None and len(self.calls) == self.stop_at:
            raise KeyboardInterrupt
        self.calls.append(n0)
        return bimodal(n0), 10.0 * n0


IDENT = {"dof": "x", "bounds": list(BOUNDS), "rtol": 1e-3}


@pytest.mark.parametrize("k", [5, 16])   # during the grid; during the refinement
def test_a_resumed_search_reuses_its_kept_evaluations(tmp_path, k):
    """Interrupted after k evaluations (each kept on disk as it comes), the resumed
    search recomputes none of those k and ends exactly where an uninterrupted one does,
    having evaluated the same preloads."""
    whole = Interrupt()
    ref = global_minimum(whole, BOUNDS, rtol=1e-3)
    assert len(whole.calls) > k

    first = Interrupt(stop_at=k)
    with pytest.raises(KeyboardInterrupt):
        global_minimum(first, BOUNDS, rtol=1e-3, on_evaluation=lambda n0, p, om: save_search(
            tmp_path, IDENT, {**load_search(tmp_path, IDENT), n0: (p, om)}))
    assert first.calls == whole.calls[:k]
    kept = load_search(tmp_path, IDENT)
    assert sorted(kept) == sorted(whole.calls[:k])

    second = Interrupt()
    res = global_minimum(second, BOUNDS, rtol=1e-3, known=kept)
    assert not set(second.calls) & set(first.calls)          # none of the k again
    assert second.calls == whole.calls[k:]
    assert res["preload"] == ref["preload"] and res["peak"] == ref["peak"]
    assert res["evaluations"] == ref["evaluations"]
    assert res["computed"] == len(whole.calls) - k and res["reused"] == k


def test_a_search_resumed_after_any_evaluation_decides_as_the_uninterrupted_one():
    """With Brent's trials valued locally from the nearest evaluated preload (here a
    lower bound 1e-9 |ln n0 - ln near| below the band's value, as a peak continued from
    another start differs in its last digits), a search interrupted after its k-th band
    evaluation, for every k, and resumed with those k (`replay`) returns the same
    optimum, the same evaluations, local trials, checks and brackets as the
    uninterrupted one, and recomputes none of the k.  Given as `known` from the start,
    a later evaluation changes the decisions made before it (the last check's band
    value taken for Brent's trial at that preload)."""
    def local(n0, near):
        return bimodal(n0) - 1e-9 * abs(math.log(n0 / near)), 10.0 * n0

    def run(stop_at=None, **kw):
        calls = []

        def curve(n0):
            if len(calls) == stop_at:
                raise KeyboardInterrupt
            calls.append(n0)
            return bimodal(n0), 10.0 * n0

        try:
            res = global_minimum(curve, BOUNDS, rtol=1e-3, local=local, **kw)
        except KeyboardInterrupt:
            res = None
        return res, calls

    def decisions(res):
        return {k: v for k, v in res.items() if k not in ("computed", "reused")}

    whole, order = run()
    assert whole["local"] and whole["verified"]
    differs = []
    for k in range(1, len(order) + 1):
        _, first = run(stop_at=k)
        kept = {n0: (bimodal(n0), 10.0 * n0) for n0 in first}
        res, again = run(replay=kept)
        assert not set(again) & set(first) and again == order[k:]
        assert decisions(res) == decisions(whole), k
        differs.append(decisions(run(known=kept)[0]) != decisions(whole))
    assert differs[-1]          # the old resume (the kept values known from the start)


def test_a_kept_search_of_another_search_or_a_broken_file_is_ignored(tmp_path):
    save_search(tmp_path, IDENT, {1.0: (2.0, 3.0), 2.0: (np.inf, np.nan)})
    kept = load_search(tmp_path, IDENT)
    assert kept[1.0] == (2.0, 3.0) and kept[2.0][0] == np.inf
    assert load_search(tmp_path, {**IDENT, "rtol": 1e-2}) == {}
    search_file(tmp_path).write_bytes(b"CDF\x01 truncated")
    assert load_search(tmp_path, IDENT) == {}
    assert load_search(tmp_path / "absent", IDENT) == {}


# ---------------------------------------------------------------------------
# the figure
# ---------------------------------------------------------------------------

def _tick_boxes(fig, axis):
    renderer = fig.canvas.get_renderer()
    return [t.get_window_extent(renderer) for t in axis.get_ticklabels()
            if t.get_visible() and t.get_text()]


def test_the_figure_is_the_curve_in_preload_order_with_the_optimum_labelled(fake_peaks,
                                                                            tmp_path):
    """Every band evaluation joined in preload order (given here in reverse; Brent's
    local trials drawn as markers), log preload
    axis (3 decades), the optimum starred with its value and unit; a long title wraps
    instead of widening the canvas; no two tick labels overlap."""
    import matplotlib.image as mpimg
    from pipeline.study.figures.optimum_figure import optimum_figure, optimum_plot

    opt = response.optimum_preload(lambda n0: n0, 1, 1.0, 2.0, 0, BOUNDS, rtol=1e-3)
    shuffled = {**opt, "evaluations": list(reversed(opt["evaluations"]))}
    fig = optimum_plot(shuffled, "x", title="a long study title " * 12)
    ax = fig.axes[0]
    x = ax.lines[0].get_xdata()     # the band peaks joined; the local ones markers
    assert len(x) == len(opt["evaluations"]) - len(opt["local"]) and np.all(np.diff(x) > 0)
    assert set(ax.lines[-2].get_xdata()) == set(opt["local"]) and opt["local"]
    assert ax.get_xscale() == "log"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert f"optimum {opt['preload']:.4g} N: peak {opt['peak']:.4g} m" in labels
    assert "\n" in ax.get_title()
    fig.canvas.draw()
    for axis in (ax.xaxis, ax.yaxis):
        boxes = _tick_boxes(fig, axis)
        assert len(boxes) >= 2
        assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    short = mpimg.imread(optimum_figure(tmp_path / "short.png", opt, "x", "short"))
    long = mpimg.imread(optimum_figure(tmp_path / "long.png", opt, "x", "word " * 200))
    assert long.shape[1] <= short.shape[1] + 2


def test_the_figure_of_a_narrow_range_has_linear_axes_and_readable_ticks():
    """Preloads within a factor 2.5 (linear axis), peaks within 1 %: ticks readable."""
    ev = [(n0, 1e-4 * (1 + 0.01 * (n0 - 3.5) ** 2), 200.0) for n0 in np.linspace(2, 5, 9)]
    fig = optimum_plot_of(ev)
    ax = fig.axes[0]
    assert ax.get_xscale() == "linear" and ax.get_yscale() == "linear"
    fig.canvas.draw()
    for axis in (ax.xaxis, ax.yaxis):
        boxes = _tick_boxes(fig, axis)
        assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])


def test_the_figure_of_eighteen_decades_keeps_its_tick_labels_apart():
    """Preloads over 1e-6 to 1e12 N (bounds the study file allows): nineteen decade
    labels overlap side by side (measured); the figure keeps every second one."""
    ev = [(n0, 1e-4 * (1 + np.log10(n0) ** 2), 200.0) for n0 in np.geomspace(1e-6, 1e12, 37)]
    fig = optimum_plot_of(ev)
    ax = fig.axes[0]
    fig.canvas.draw()
    boxes = _tick_boxes(fig, ax.xaxis)
    assert len(boxes) >= 3
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])


def optimum_plot_of(ev):
    from pipeline.study.figures.optimum_figure import optimum_plot

    best = min(ev, key=lambda e: e[1])
    return optimum_plot({"evaluations": ev, "preload": best[0], "peak": best[1],
                         "peak_omega": best[2], "grid": [e[0] for e in ev]}, "x")


def test_a_local_peak_below_the_band_peak_sends_the_bracket_back_to_band_evaluations(caplog):
    """Local values that miss the band's peak (here 0.05 low everywhere, as when the
    largest resonance of the band is another than the one continued) fail the check at
    the bracket's result: the bracket is refined again on band values, and the optimum
    is the plain search's to its tolerance (logged)."""
    def curve(n0):
        return bimodal(n0), 1.0

    plain = global_minimum(curve, BOUNDS, rtol=1e-3)
    low = global_minimum(curve, BOUNDS, rtol=1e-3,
                         local=lambda n0, near: (bimodal(n0) - 0.05, 1.0))
    assert low["preload"] == pytest.approx(plain["preload"], rel=1e-3)
    assert low["preload"] == pytest.approx(math.exp(T_GLOBAL), rel=2e-3)
    assert low["peak"] == pytest.approx(0.4, rel=1e-5)
    (n0, local, full), = low["verified"]
    assert full == pytest.approx(local + 0.05, rel=1e-12)
    assert "refined again on the whole band" in caplog.text
    assert low["computed"] > plain["computed"]


def test_local_values_start_from_the_nearest_preload_evaluated():
    """Each local value is asked from the evaluated preload nearest in ln n0; with
    exact local values the search visits the band evaluations of the grid and one
    check, and returns the plain search's optimum to its tolerance."""
    asked = []

    def local(n0, near):
        asked.append((n0, near))
        return bimodal(n0), 1.0

    full_calls = []

    def curve(n0):
        full_calls.append(n0)
        return bimodal(n0), 1.0

    res = global_minimum(curve, BOUNDS, rtol=1e-3, local=local)
    assert res["preload"] == pytest.approx(math.exp(T_GLOBAL), rel=2e-3)
    assert len(full_calls) == len(res["grid"]) + 1
    seen = set(res["grid"])
    for n0, near in asked:
        others = [k for k in seen if k != n0]
        assert abs(math.log(near) - math.log(n0)) == pytest.approx(
            min(abs(math.log(k) - math.log(n0)) for k in others), abs=1e-12)
        seen.add(n0)


def test_a_trial_without_a_local_peak_is_evaluated_over_the_band(fake_peaks, monkeypatch,
                                                                 caplog):
    """Where no local maximum is enclosed (the peak left the band, a side stopped
    short), the trial preload is evaluated over the whole band instead (logged): the
    search is then the band search, with its optimum."""
    class NoPeak:
        success, message = False, "no local maximum enclosed"

    def no_local(system, H, omega, Q, dof, a, b, **kw):
        fake_peaks.local.append(system)
        return NoPeak()

    monkeypatch.setattr(response, "local_peak", no_local)
    caplog.set_level("INFO")
    opt = response.optimum_preload(lambda n0: n0, 1, 1.0, 2.0, 0, BOUNDS, rtol=1e-3)
    assert opt["preload"] == pytest.approx(math.exp(T_GLOBAL), rel=2e-3)
    assert opt["local"] == [] and fake_peaks.local
    assert set(fake_peaks.local) <= set(fake_peaks)      # each trial then over the band
    assert "no local peak at" in caplog.text


@pytest.mark.parametrize("wiggle, independent", [(0.0, True), (1e-12, True), (1e-6, False)])
def test_a_peak_the_same_at_every_preload_has_no_optimum(wiggle, independent):
    """A peak that does not depend on the preload (relative spread over the grid below
    1e-9: equal, or round-off) gives preload NaN and `independent`, after the grid alone;
    a spread of 1e-6 is a curve, whose minimum is searched (here at the lower bound)."""
    def peak(n0):
        return 2.0e-5 * (1.0 + wiggle * math.log(n0)), 1000.0

    res = global_minimum(peak, (1.0, 100.0))
    assert res["independent"] is independent
    assert res["spread"] == pytest.approx(wiggle * math.log(100.0) / (1 + wiggle * math.log(100.0)),
                                          abs=1e-15)
    if independent:
        from pipeline.study.figures.optimum_figure import optimum_plot

        assert math.isnan(res["preload"]) and res["brackets"] == []
        assert res["computed"] == len(res["grid"]) and res["peak"] == pytest.approx(2.0e-5)
        labels = [t.get_text() for t in optimum_plot(res, "x").axes[0].get_legend().get_texts()]
        assert "no optimum: the peak does not depend on the preload" in labels
        assert not any(lb.startswith("optimum ") for lb in labels)   # no star
    else:
        assert res["preload"] == 1.0


# --------------------------------------------------------------------------- linear grids
GAP_BOUNDS = (-2.0, 1.0)     # an interference [m] scaled: a gap (< 0) to an overlap


def gap_curve(x):
    """Peak against interference x: a gap that stays open (x <= -1) leaves the free peak
    5 whatever it is; closing, the pairs slide and the peak dips to 3.2 at x = -0.23
    (a parabola); from x = 0.5 they stick, the stuck peak 4.818.  Continuous."""
    if x <= -1.0:
        return 5.0
    return 3.2 + 1.8 * ((min(x, 0.5) + 0.23) / 0.77) ** 2


def open_lowest(x):
    """The gap's plateau is the smallest peak (2, with a round-off of 1e-7 on it: the
    continuation's, measured 8e-8 on the shrouded disk), the curve rising once the gap
    closes at x = -1."""
    if x <= -1.0:
        return 2.0 * (1.0 + 1e-7 * math.sin(1e3 * x))
    return 2.0 + (x + 1.0) ** 2


def test_a_linear_search_across_zero_finds_the_dense_grid_minimum():
    """Over bounds that cross zero, on a linear grid of 13 nodes, the search brackets the
    dip and refines it to rtol (hi - lo) / 10: the minimum a grid of 30,001 points
    finds, to its spacing; the open gap's plateau (equal nodes) is no basin."""
    calls = []
    res = global_minimum(lambda x: (calls.append(x), (gap_curve(x), 1.0))[1], GAP_BOUNDS,
                         rtol=1e-3, log=False, min_nodes=13)
    np.testing.assert_allclose(res["grid"], np.linspace(-2.0, 1.0, 13), rtol=0, atol=1e-15)
    dense = np.linspace(*GAP_BOUNDS, 30_001)
    values = np.array([gap_curve(x) for x in dense])
    k = int(np.argmin(values))
    assert abs(res["preload"] - dense[k]) <= 1e-4 + 3e-4     # the grid's spacing + xatol
    assert res["peak"] <= values[k] + 1e-12 and res["peak"] == pytest.approx(3.2, abs=1e-6)
    assert res["plateau"] is None and not res["independent"]
    assert len(res["brackets"]) == 1 and len(calls) < 13 + 30


def test_a_smallest_peak_shared_by_a_stretch_is_no_optimum():
    """Where the open gap's plateau holds the smallest peak, every interference up to the
    gap's closing is as good: no optimum (NaN), the stretch reported (from the lower
    bound to the last node of the plateau, -1), whatever round-off picks as the least;
    the whole grid flat is `independent` as before."""
    res = global_minimum(lambda x: (open_lowest(x), 1.0), GAP_BOUNDS, rtol=1e-3, log=False,
                         min_nodes=13, plateau_rel=100 * 1e-8)   # the search's at tolerance 1e-8
    assert math.isnan(res["preload"]) and not res["independent"]
    assert res["plateau"][0] == -2.0 and -1.0 - 1e-3 <= res["plateau"][1] <= -1.0
    assert res["peak"] == pytest.approx(2.0, rel=1e-7)
    flat = global_minimum(lambda x: (7.0, 1.0), GAP_BOUNDS, rtol=1e-3, log=False, min_nodes=13)
    assert flat["independent"] and flat["plateau"] is None and math.isnan(flat["preload"])


GAP_IDENT = {"dof": "x", "bounds": list(GAP_BOUNDS), "rtol": 1e-3, "variable": "interference",
             "nodes": 13}


@pytest.mark.parametrize("k", [4, 14])   # during the grid; during the refinement
def test_an_interference_search_resumes_from_its_checkpoint(tmp_path, k):
    """Killed after k evaluations, each kept on disk as it comes (the interference [m]
    named and with its unit in the file, a preload search's identity not reading it),
    the resumed search computes none of them again and ends where the uninterrupted one
    does, at the same interferences."""
    import xarray as xr

    def run(stop_at=None, known=None, save=False):
        calls = []

        def evaluate(x):
            if stop_at is not None and len(calls) == stop_at:
                raise KeyboardInterrupt
            calls.append(x)
            return gap_curve(x), 1.0 + x

        keep = (lambda x, p, om: save_search(tmp_path, GAP_IDENT, {
            **load_search(tmp_path, GAP_IDENT), x: (p, om)})) if save else None
        return calls, lambda: global_minimum(evaluate, GAP_BOUNDS, rtol=1e-3, log=False,
                                             min_nodes=13, known=known, on_evaluation=keep)

    whole, go = run()
    ref = go()
    assert len(whole) > k
    first, go = run(stop_at=k, save=True)
    with pytest.raises(KeyboardInterrupt):
        go()
    with xr.open_dataset(search_file(tmp_path)) as ds:
        assert ds["interference"].attrs["units"] == "m" and "preload" not in ds
        assert sorted(ds["interference"].values) == sorted(whole[:k])
    as_preload = {k: v for k, v in GAP_IDENT.items() if k not in ("variable", "nodes")}
    assert load_search(tmp_path, as_preload) == {}          # another search's file
    kept = load_search(tmp_path, GAP_IDENT)
    second, go = run(known=kept)
    res = go()
    assert second == whole[k:] and res["evaluations"] == ref["evaluations"]
    assert res["preload"] == ref["preload"] and res["reused"] == k
