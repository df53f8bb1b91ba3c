"""Figure layout (pipeline/study/figures/plots.py and the figure modules): a long title wraps
instead of widening the canvas, and no two tick labels of the main figures overlap
(window extents of the rendered labels on the Agg canvas)."""
import numpy as np
import pytest
import xarray as xr

from pipeline.study.figures import disk_figures
from pipeline.study.figures import nd_figure
from pipeline.study.figures import plots

LONG = ("Shrouded solid-blade disk, 36 sectors, EO 3: first flap family vs shroud preload, "
        "craig_bampton_modes = 20, harmonics = 3, exact forces, tolerance 1e-8, "
        "a title of two hundred characters or more in all.")


def _branches():
    f = np.linspace(180.0, 400.0, 200)
    a = 1e-5 / np.sqrt((1 - (f / 300.0) ** 2) ** 2 + 0.01)
    st = np.where((f > 290) & (f < 300), 0.0, 1.0)
    return [("preload = 3 N", f, a, st, np.ones(f.size, bool))]


@pytest.fixture
def captured(monkeypatch):
    """Every figure the figure functions save, rendered and kept open."""
    figs = []

    def keep(fig, path):
        fig.canvas.draw()
        figs.append(fig)
        return path
    monkeypatch.setattr(plots, "atomic_savefig", keep)
    monkeypatch.setattr(plots.pyplot(), "close", lambda fig=None: None)
    yield figs
    for f in figs:
        plots.pyplot().close(f)


def _png_size(tmp_path, fig):
    from PIL import Image
    path = plots.atomic_savefig(fig, tmp_path / "f.png")
    with Image.open(path) as im:
        return im.size


def test_200_character_title_keeps_the_canvas_width(tmp_path):
    assert len(LONG) >= 200
    fig = plots.response_curves_plot(_branches(), title=LONG, yscale="log")
    w_set = fig.get_figwidth() * 130          # atomic_savefig's dpi
    w, _ = _png_size(tmp_path, fig)
    plots.pyplot().close(fig)
    assert w <= 1.03 * w_set
    assert "\n" in fig.axes[0].get_title()


def test_wrapped_suptitle_keeps_the_canvas_width(tmp_path):
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 4.0))
    ax.plot([0, 1], [0, 1])
    plots.wrapped_title(fig, LONG, fontsize=10)
    w, _ = _png_size(tmp_path, fig)
    plt.close(fig)
    assert w <= 1.03 * 6.0 * 130


def _overlaps(fig):
    """Pairs of overlapping tick labels on any axis of `fig` (rendered)."""
    renderer = fig.canvas.get_renderer()
    bad = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            boxes = [(t.get_text(), t.get_window_extent(renderer))
                     for t in axis.get_ticklabels() if t.get_visible() and t.get_text()]
            for i in range(len(boxes)):
                for j in range(i + 1, len(boxes)):
                    if boxes[i][1].overlaps(boxes[j][1]):
                        bad.append((boxes[i][0], boxes[j][0]))
    return bad


def _modes_dataset(sectors=36, modes=6):
    nd = np.arange(sectors // 2 + 1)
    base = 200.0 * (1 + np.arange(modes))[None, :] ** 1.6
    stuck = base * (1 + 5 * (1 - np.exp(-nd / 3.0)))[:, None] / (1 + np.arange(modes))[None, :]
    return xr.Dataset({"frequency_stuck": (("nodal_diameter", "mode"), stuck + base),
                       "frequency_open": (("nodal_diameter", "mode"), np.tile(base, (nd.size, 1)))},
                      coords={"nodal_diameter": nd, "mode": np.arange(1, modes + 1)},
                      attrs={"title": LONG, "sectors": sectors, "engine_order": 39})


def test_tick_labels_do_not_overlap(captured, tmp_path):
    rng = np.random.default_rng(0)
    fig = plots.response_curves_plot(_branches(), title=LONG, yscale="log")
    fig.canvas.draw()
    captured.append(fig)
    for n in (12, 36, 100):
        plots.sector_peaks_figure(tmp_path / "p.png", np.arange(n),
                                  [("seed 1", 1e-5 * (1 + 0.05 * rng.random(n)))], 1e-5,
                                  dof="response.y", title=LONG)
    nd_figure.nodal_diameter_figure(tmp_path / "nd.png", _modes_dataset())
    a = xr.DataArray(1 + np.abs(rng.normal(0, 0.04, (3, 100, 1))),
                     dims=("preload", "mistuning_seed", "dof"),
                     coords={"preload": [0.3, 3.0, 30.0], "mistuning_seed": np.arange(100),
                             "dof": ["response.y"]})
    disk_figures.amplification_figure(tmp_path / "a.png", xr.Dataset({"amplification_factor": a}),
                                      "response.y", LONG)
    assert len(captured) == 6
    for fig in captured:
        assert _overlaps(fig) == []


def test_engine_order_folds_into_a_nodal_diameter():
    # ND = EO mod N folded into 0..N/2 (the zig-zag of the interference diagram)
    assert [nd_figure.excited_nodal_diameter(eo, 36) for eo in (0, 3, 18, 19, 35, 36, 39)] \
        == [0, 3, 18, 17, 1, 0, 3]
