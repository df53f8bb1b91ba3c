"""The Campbell diagram (`study.execution.campbell_study`): a disk modes study with speeds.

At speed 0 it is the frequency - nodal-diameter diagram itself (equal to 1e-10: the
same eigenproblems, no speed term added); every crossing is a root of
f_k(ND, s) - EO s / 60 located to 1e-6 of its speed (the function changes sign across
s (1 -+ 1e-6)), not a grid point; the speed-dependent stiffness reaches the sector
(a frequency at speed equals the blade's K + Omega^2 K_rot reduced and assembled);
bad speed tables are one line naming the field."""
import re

import numpy as np
import pytest

from pipeline.__main__ import main as cli
from pipeline.errors import UsageError
from pipeline.study.datasets.dataset import read_dataset
from pipeline.study.files.documents import load_study, parse_study
from pipeline.study.execution.campbell_study import campbell, frequencies_at
from pipeline.study.execution.disk_modes_study import nodal_diameter_frequencies
from helpers import STUDIES

NDS = (0, 3, 6, 18)


@pytest.fixture(scope="module")
def quick():
    return load_study(STUDIES / "shrouded_disk_campbell.toml", quick=True)


@pytest.fixture(scope="module")
def diagram(quick):
    speeds = (0.0, 5000.0, 10000.0, 15000.0)
    return campbell(quick.scene, speeds, NDS, 2, (3, 6)), speeds


def test_at_rest_the_campbell_diagram_is_the_nodal_diameter_diagram(quick, diagram):
    res, _ = diagram
    plain = nodal_diameter_frequencies(quick.scene, NDS, 2)
    for state in ("open", "stuck"):
        np.testing.assert_allclose(res[state][0], plain[state], rtol=1e-10, atol=0.0)
    # and the modes study without speeds is the shipped modes study's diagram
    modes = load_study(STUDIES / "shrouded_disk_modes.toml", quick=True)
    other = nodal_diameter_frequencies(modes.scene, NDS, 2)
    np.testing.assert_allclose(plain["stuck"], other["stuck"], rtol=1e-10, atol=0.0)


def test_speed_stiffens_the_first_family(diagram):
    res, _ = diagram
    assert np.all(np.diff(res["stuck"][:, :, 0], axis=0) > 0)
    assert np.all(np.diff(res["open"][:, :, 0], axis=0) > 0)


def test_crossings_are_roots_located_to_1e_6_of_speed(quick, diagram):
    res, speeds = diagram
    found = res["crossings"]
    assert {(eo, state) for eo, _, k, state, *_ in found if k == 1} == {
        (3, "open"), (3, "stuck"), (6, "open"), (6, "stuck")}
    for eo, nd, k, state, s, f in found:
        assert s not in speeds
        # the recomputed natural frequency at the root is the engine-order frequency
        at_root = frequencies_at(quick.scene, s, [nd], k, state)[0, k - 1]
        assert at_root == pytest.approx(f, rel=1e-8) and f == pytest.approx(eo * s / 60.0)
        lo, hi = (frequencies_at(quick.scene, x, [nd], k, state)[0, k - 1] - eo * x / 60.0
                  for x in (s * (1 - 1e-6), s * (1 + 1e-6)))
        assert lo * hi < 0, (eo, state, lo, hi)


def test_each_crossing_has_its_mode_shape(quick, diagram):
    """The shape stored with each crossing solves the sector's eigenproblem at the
    crossing's speed, nodal diameter and contact state at its own frequency, rebuilt
    here: (K_phi - w^2 M_phi) x within 1e-12 |K_phi| |x| (an eigenvector to working
    accuracy), w^2 its Rayleigh quotient, w
    that mode's natural frequency and the crossing's EO x speed / 60 to 1e-8; scaled to
    max |x| = 1 over the physical DOFs."""
    from pipeline.model.cyclic import sector_system
    from pipeline.model.system import linear_stiffness, natural_frequencies, wave_mass
    from pipeline.study.execution.campbell_study import STATES, speed_sector
    res, _ = diagram
    sh = res["crossing_shapes"]
    assert sh["shapes"].shape[0] == len(res["crossings"]) > 0
    for (eo, nd, k, state, s, f), x in zip(res["crossings"], sh["shapes"]):
        system = sector_system(speed_sector(quick.scene, s), nd)
        K, M = linear_stiffness(system, STATES[state]), wave_mass(system)
        w2 = np.real(x.conj() @ K @ x) / np.real(x.conj() @ M @ x)   # its Rayleigh quotient
        assert np.sqrt(w2) / (2 * np.pi) == pytest.approx(f, rel=1e-8)
        assert np.sqrt(w2) == pytest.approx(natural_frequencies(system, STATES[state])[k - 1],
                                            rel=1e-8)
        # backward error of a dense eigen-solve: a few eps |K| |x| (measured 7.9e-15 |K| |x|)
        bound = 1e-12 * np.linalg.norm(K, 2) * np.linalg.norm(x)
        assert np.linalg.norm(K @ x - w2 * (M @ x)) < bound
        assert np.abs(x[sh["physical"]]).max() == pytest.approx(1.0, abs=1e-14)


def test_campbell_study_dataset_and_figure(tmp_path):
    f = STUDIES / "shrouded_disk_campbell.toml"
    assert cli(["run", str(f), "--quick", "--out", str(tmp_path)]) == 0
    ds = read_dataset(tmp_path / "shrouded_disk_campbell.nc")
    assert ds["frequency_stuck"].dims == ("speed", "nodal_diameter", "mode")
    assert ds["speed"].attrs["units"] == "rpm" and ds.sizes["speed"] == 16
    assert ds.sizes["crossing"] >= 6 and set(ds["crossing_contacts"].values) == {"open", "stuck"}
    assert (tmp_path / "shrouded_disk_campbell" / "campbell_diagram.png").is_file()
    figure_reads(ds)
    edge = ds.copy(deep=True)     # a crossing at the right edge: labelled on its left
    s = 0.998 * float(ds.speed.values[-1])
    edge["crossing_speed"].values[-1] = s
    edge["crossing_frequency"].values[-1] = int(edge.crossing_engine_order.values[-1]) * s / 60
    figure_reads(edge)


def figure_reads(ds):
    """The figure a review can read: every crossing labelled, no two labels (engine
    orders, crossings) overlapping once drawn, the labels inside the axes (a crossing's
    label may hang below the axes' bottom only),
    and the frequency axis 5 % above the families drawn (the excited NDs)."""
    import numpy as np

    from pipeline.study.figures import plots
    from pipeline.study.figures.campbell_figure import draw_campbell, text_box
    from pipeline.study.figures.nd_figure import excited_nodal_diameter

    fig, labels = draw_campbell(ds)
    ax = fig.axes[0]
    fig.canvas.draw()
    texts = [t for t in ax.texts if t.get_gid() in ("engine_order_label", "crossing_label")]
    assert sum(t.get_gid() == "crossing_label" for t in texts) == ds.sizes["crossing"]
    assert sum(t.get_gid() == "engine_order_label" for t in texts) == ds.sizes["engine_order"]
    boxes = [text_box(t) for t in texts]
    assert not [(a.get_text(), b.get_text()) for i, a in enumerate(texts)
                for b, bb in zip(texts[i + 1:], boxes[i + 1:]) if boxes[i].overlaps(bb)]
    frame = ax.get_window_extent()
    for t, b in zip(texts, boxes):   # inside the axes; a crossing's label may hang below
        assert frame.x0 - 1 <= b.x0 and b.x1 <= frame.x1 + 1 and b.y1 <= frame.y1 + 1, \
            t.get_text()
        assert t.get_gid() == "crossing_label" or frame.y0 - 1 <= b.y0, t.get_text()
    nds = list(ds.nodal_diameter.values)
    drawn = {excited_nodal_diameter(int(e), int(ds.attrs["sectors"]))
             for e in ds.engine_order.values} & set(nds)
    top = max(np.nanmax(ds[v].values[:, nds.index(nd), :]) for v in
              ("frequency_stuck", "frequency_open") for nd in drawn)
    assert ax.get_ylim()[1] == pytest.approx(1.05 * top, rel=1e-12)
    assert len(labels) == ds.sizes["crossing"] + ds.sizes["engine_order"]
    plots.pyplot().close(fig)


BAD = {   # (old, new, field, pattern) on the shipped Campbell study
    "speeds_without_effect": (',\n           "centrifugal_stiffening"', "", "modes.speeds",
                              'declare "centrifugal_stiffening"'),
    "effect_without_speeds": ("speeds = { start = 0.0, stop = 15000.0, count = 16 }   # rpm\n"
                              "engine_orders = [1, 2, 3, 4, 5, 6]", "", "scene.effects",
                              "nothing turns"),
    "orders_without_speeds": ("speeds = { start = 0.0, stop = 15000.0, count = 16 }   # rpm", "",
                              "modes.engine_orders", "need speeds"),
    "speeds_decrease": ("speeds = { start = 0.0, stop = 15000.0, count = 16 }",
                        "speeds = [0.0, 9000.0, 3000.0]", "modes.speeds", "must increase"),
    "speeds_negative": ("speeds = { start = 0.0, stop = 15000.0, count = 16 }",
                        "speeds = [-10.0, 3000.0]", "modes.speeds", ">= 0"),
    "order_twice": ("engine_orders = [1, 2, 3, 4, 5, 6]", "engine_orders = [3, 3]",
                    "modes.engine_orders", "twice"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_campbell_table_is_one_line(case):
    old, new, field, pattern = BAD[case]
    text = (STUDIES / "shrouded_disk_campbell.toml").read_text()
    assert old in text
    with pytest.raises(UsageError, match=f"^bad.toml: {re.escape(field)}[^:]*: .*{pattern}"):
        parse_study(text.replace(old, new), file="bad.toml", quick=True)


def test_a_forced_response_at_speed_has_the_campbells_frequencies(tmp_path, quick):
    """The shrouded-disk response study swept over speed: its stuck natural frequencies
    (EO 3, ND 3) at 15,000 rpm are the Campbell diagram's, and the peak follows them."""
    text = (STUDIES / "shrouded_disk.toml").read_text().split("[quick.sweep]")[0]
    text = text.replace('"cyclic_coupling"]', '"cyclic_coupling",\n           '
                                              '"centrifugal_stiffening"]')
    text = re.sub(r"\noptimum_preload = .*", "", text).replace(
        "preload = [0.3, 1.0, 3.0, 10.0, 30.0]", "preload = [30.0]\nspeed = [0.0, 15000.0]")
    text = text.replace("stop = 400.0", "stop = 550.0")
    (tmp_path / "speed.toml").write_text(text)
    assert cli(["run", str(tmp_path / "speed.toml"), "--quick", "--out", str(tmp_path),
                "--no-figures"]) == 0
    ds = read_dataset(tmp_path / "speed.nc")
    assert ds["speed"].attrs["units"] == "rpm"
    for speed in (0.0, 15000.0):
        got = ds["natural_frequency_stuck"].sel(speed=speed, preload=30.0).values
        ref = frequencies_at(quick.scene, speed, [3], got.size, "stuck")[0]
        np.testing.assert_allclose(got, ref, rtol=1e-10)
        peak = float(ds["peak_frequency"].sel(speed=speed, preload=30.0).max())
        assert peak == pytest.approx(ref[0], rel=0.02)     # 30 N: nearly stuck


def test_the_static_contact_state_stiffens_only_where_the_pairs_close(quick):
    """With a 0.1 mm shroud gap: the static state is the open one while every pair is
    open (to the dense eigen-solver's round-off), and lies between open and stuck once
    the speed closes pairs (the quick disk's first pair closes at 6,953 rpm)."""
    from dataclasses import replace as replace_
    pair = replace_(quick.scene.contacts[0], interference=-1e-4, n0=None)
    scene = replace_(quick.scene, contacts=(pair,))
    for speed, closed in ((3000.0, False), (9000.0, True)):
        f = {s: frequencies_at(scene, speed, [3], 2, s) for s in ("open", "stuck", "static")}
        if not closed:
            np.testing.assert_allclose(f["static"], f["open"], rtol=1e-8)
        else:
            assert np.all(f["static"][0, 0] > f["open"][0, 0] * 1.01)
            assert np.all(f["static"][0, 0] < f["stuck"][0, 0])


def test_progress_is_logged_without_a_line_per_reduction(quick, caplog, monkeypatch):
    """A Campbell sweep re-reduces the blade at every speed: the reductions' own lines
    stay at debug level, the sweep logs its progress (here every speed: PROGRESS = 0)
    and the crossings found; the reduction logger's level is restored after."""
    import logging
    import pipeline.study.execution.campbell_study as cb

    monkeypatch.setattr(cb, "PROGRESS", 0.0)
    caplog.set_level(logging.INFO)
    before = logging.getLogger(cb.REDUCTION_LOG).level
    speeds = (0.0, 7000.0, 14000.0)
    res = campbell(quick.scene, speeds, (3,), 1, (3,))
    text = [r.getMessage() for r in caplog.records]
    assert not any("Craig-Bampton" in t for t in text), text
    assert [t.split(",")[0] for t in text if "speeds (" in t] == [
        "Campbell: 1/3 speeds (0 rpm)", "Campbell: 2/3 speeds (7000 rpm)",
        "Campbell: 3/3 speeds (14000 rpm)"]
    assert any(f"{len(res['crossings'])} engine-order crossing(s)" in t for t in text)
    assert logging.getLogger(cb.REDUCTION_LOG).level == before


def test_a_speed_that_fails_loses_no_other(quick, diagram, tmp_path, monkeypatch):
    """The model at 10,000 rpm cannot be built: that speed's frequencies are NaN and its
    message says why, every other speed's frequencies equal the diagram computed
    without the failure, and so does every crossing whose bracket does not end at that
    speed; the dataset and figure are written, the run reports the one failure."""
    from dataclasses import replace

    import pipeline.study.execution.campbell_study as cb
    from pipeline.study.execution.disk_modes_study import run_disk_modes_study

    whole, speeds = diagram
    real = cb.speed_sector

    def failing(scene, speed):
        if speed == 10000.0:
            raise np.linalg.LinAlgError("Singular matrix")
        return real(scene, speed)

    monkeypatch.setattr(cb, "speed_sector", failing)
    study = replace(quick, speeds=speeds, nodal_diameters=NDS, n_frequencies=2,
                    engine_orders=(3, 6))
    res = run_disk_modes_study(study, tmp_path, figures=True)
    assert res.failed == [({"speed": 10000.0}, "LinAlgError: Singular matrix")]
    assert not res.ok and (tmp_path / study.name / "campbell_diagram.png").is_file()
    ds = read_dataset(res.path)
    assert ds["message"].values.tolist() == ["", "", "LinAlgError: Singular matrix", ""]
    for state in ("open", "stuck"):
        f = ds[f"frequency_{state}"].values
        assert np.isnan(f[2]).all()
        np.testing.assert_array_equal(f[[0, 1, 3]], whole[state][[0, 1, 3]])
    kept = {c for c in whole["crossings"] if not 5000.0 < c[4] < 15000.0}
    found = set(zip(*(ds[f"crossing_{k}"].values.tolist() for k in (
        "engine_order", "nodal_diameter", "mode", "contacts", "speed", "frequency"))))
    assert kept and found == kept


def test_a_crossing_that_cannot_be_located_loses_no_other(quick, monkeypatch, caplog):
    """Flat 100 Hz families: EO 6 meets ND 6 on the grid speed 1000 rpm (no root
    finding), EO 3 meets ND 3 between 1000 and 3000 rpm, where the model fails at
    Brent's first trial speed: that crossing is left out (logged), the other kept."""
    import pipeline.study.execution.campbell_study as cb

    def failing(*args, **kw):
        raise np.linalg.LinAlgError("Singular matrix")

    monkeypatch.setattr(cb, "frequencies_at", failing)
    freqs = {"open": np.full((3, 2, 1), 100.0)}
    found = cb.crossings(quick.scene, (0.0, 1000.0, 3000.0), (3, 6), freqs, (3, 6))
    assert found == [(6, 6, 1, "open", 1000.0, 100.0)]
    assert "crossing of EO 3 with ND 3 mode 1 (open) between 1000 and 3000 rpm is not " \
           "located" in caplog.text


def test_check_counts_each_speed_and_the_crossings_the_run_locates(quick, diagram, monkeypatch):
    """`check`'s Campbell estimate (`kind_costs.campbell_estimate`) counts what the run
    does: the diagram's speeds, nodal diameters and contact states, and as many
    engine-order crossings as the run locates by Brent on the grid (here EO 3 and 6 on
    the first family, open and stuck, and more); each further speed adds a reduction,
    the static solution and D Z eigen-solves, each crossing BRENT trials of a reduction
    and one solve (the formula of `kind_costs`, by hand)."""
    from dataclasses import replace

    from pipeline.study.execution import kind_costs

    res, speeds = diagram
    counted = []
    monkeypatch.setattr(kind_costs, "campbell_cost", lambda *a: counted.append(a[4:]) or 1.0)
    study = replace(quick, speeds=speeds, nodal_diameters=NDS, n_frequencies=2,
                    engine_orders=(3, 6))
    kind_costs.disk_modes_estimate(study)
    assert counted == [(len(speeds), len(NDS), 2, len(res["crossings"]))]
    assert len(res["crossings"]) >= 4
    monkeypatch.undo()
    cost = kind_costs.campbell_cost
    t = dict(t_blade=3.0, t_red=0.25, t_eig=0.004, t_static=0.002)   # [s]
    base = cost(**t, speeds=16, nodal_diameters=19, states=2, crossings=11)
    assert base == pytest.approx(3.0 + (16 + 4.5 * 11) * 0.25 + 16 * 0.002
                                 + (16 * 19 * 2 + 4.5 * 11) * 0.004, rel=1e-12)
    assert cost(**t, speeds=17, nodal_diameters=19, states=2, crossings=11) - base == \
        pytest.approx(0.25 + 0.002 + 19 * 2 * 0.004, rel=1e-12)
    assert cost(**t, speeds=16, nodal_diameters=19, states=2, crossings=12) - base == \
        pytest.approx(4.5 * (0.25 + 0.004), rel=1e-12)
