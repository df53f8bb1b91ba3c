"""Warnings at the end of a run about peaks that are not peaks of the interval: a
branch cut short (`incomplete_cases`, tests/solve/harmonic_balance/test_roundoff.py)
and a largest amplitude at an end of the interval (`edge_peaks`), for the cases and
for the optimum-preload search."""
import numpy as np
import pytest

from pipeline.__main__ import main as cli
from helpers import example1_study

# Example 1's resonances lie at 188.4 (open) to 213.3 rad/s (stuck)
BELOW = example1_study("a range below the resonance", preload="[0.5, 1000.0]",
                       solver="harmonics = 1\nstability = false",
                       output='dofs = ["x"]\nfigures = []')


def test_a_peak_at_the_ranges_end_is_named_as_no_peak(tmp_path, capsys):
    """150-180 rad/s: the amplitude grows up to 180 rad/s in both cases (a peak
    outside the range), a warning each; 150-250 rad/s: none."""
    f = tmp_path / "below.toml"
    f.write_text(BELOW.replace("stop = 250.0", "stop = 180.0"))
    assert cli(["run", str(f), "--out", str(tmp_path / "a"), "--workers", "1"]) == 0
    warns = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert len(warns) == 2, warns
    for w, n in zip(warns, ("0.5", "1000")):
        assert w == (f"warning: {f}: case preload = {n} N: the largest amplitude of x is its "
                     "value at the range's end, 180 rad/s: not a resonant peak (a peak inside "
                     "150-180 rad/s, if any, is lower; widen [sweep] frequency if a resonance "
                     "lies beyond)")
    f.write_text(BELOW)
    assert cli(["run", str(f), "--out", str(tmp_path / "b"), "--workers", "1"]) == 0
    assert "warning:" not in capsys.readouterr().err


def test_an_optimum_whose_window_holds_no_peak_is_named(tmp_path, capsys):
    """The optimum search over 220-250 rad/s, above every resonance: its 'peak' is the
    amplitude at 220 rad/s, which one printed line says (a progress bar cannot hide
    it), after `run` and after `optimise`."""
    f = tmp_path / "window.toml"
    f.write_text(BELOW + '\n[output.optimum_preload]\ndof = "x"\nbounds = [0.5, 10.0]\n'
                 'frequency = { start = 220.0, stop = 250.0, unit = "rad/s" }\n')
    want = (f"warning: {f}: output.optimum_preload: at the optimum preload the largest "
            "amplitude is its value at an end of the search's window, 220 rad/s: not a "
            "resonant peak (a peak inside 220-250 rad/s, if any, is lower), so the optimum "
            "minimises an off-resonance amplitude (widen [output.optimum_preload] frequency, "
            "or [sweep] frequency)")
    assert cli(["run", str(f), "--out", str(tmp_path / "c"), "--workers", "1"]) == 0
    warns = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert warns == [want]
    assert cli(["optimise", str(f), "--out", str(tmp_path / "d"), "--workers", "1"]) == 0
    warns = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert warns == [want]
    f.write_text(BELOW + '\n[output.optimum_preload]\ndof = "x"\nbounds = [0.5, 10.0]\n')
    assert cli(["optimise", str(f), "--out", str(tmp_path / "e"), "--workers", "1"]) == 0
    assert "warning:" not in capsys.readouterr().err


def test_a_dof_that_never_moves_has_no_peak_at_the_ranges_end(tmp_path, capsys):
    """Example 1 beside a second, unloaded and uncoupled mass y: its amplitude is 0 at
    every point, so its 'largest amplitude' at the first point is no missed peak."""
    f = tmp_path / "still.toml"
    text = example1_study("a mass that never moves", preload="[2.0]",
                          solver="harmonics = 1\nstability = false",
                          output='dofs = ["x", "y"]\nfigures = []')
    text = (text.replace('dofs = ["x"]\n\n[scene.matrices]', 'dofs = ["x", "y"]\n\n[scene.matrices]')
            .replace("M = [[1.0]]", "M = [[1.0, 0.0], [0.0, 1.0]]")
            .replace("C = [[0.3]]", "C = [[0.3, 0.0], [0.0, 0.3]]")
            .replace("K = [[3.55e4]]", "K = [[3.55e4, 0.0], [0.0, 1.0e4]]"))
    f.write_text(text)
    assert cli(["run", str(f), "--out", str(tmp_path / "a"), "--workers", "1"]) == 0
    import xarray as xr
    with xr.open_dataset(tmp_path / "a" / "still.nc") as ds:
        assert float(ds.peak_amplitude.sel(dof="y").max()) == 0.0
    assert "warning:" not in capsys.readouterr().err


def test_a_window_whose_largest_amplitude_is_a_flank_is_named(tmp_path, capsys):
    """Example 1 open (188.4 rad/s) and stuck (213.3 rad/s), windows 150-200 and
    200-250 rad/s: the open case's second window and the stuck case's first hold only
    a flank of the other window's resonance, one warning each; the windows around the
    resonances none."""
    f = tmp_path / "windows.toml"
    f.write_text(example1_study("windows", preload="[0.0, 1000.0]",
                                solver="harmonics = 1\nstability = false",
                                output='dofs = ["x"]\nfigures = []\n'
                                       'peak_windows = [[150.0, 200.0], [200.0, 250.0]]'))
    assert cli(["run", str(f), "--out", str(tmp_path / "a"), "--workers", "1"]) == 0
    warns = [ln for ln in capsys.readouterr().err.splitlines()
             if ln.startswith("warning:") and "peak window" in ln]   # (and: never slips)
    assert len(warns) == 2, warns
    for w, (n, k, lo, hi) in zip(warns, (("0", 1, 200, 250), ("1000", 0, 150, 200))):
        assert w.startswith(f"warning: {f}: case preload = {n} N: the largest amplitude in "
                            f"peak window {k} ({lo}-{hi} rad/s) of x at "), w
        assert w.endswith("lies on the curve's flank at the window's edge, not at a resonant "
                          "peak (the amplitude rises beyond the window; move or widen [output] "
                          "peak_windows)"), w
    import xarray as xr
    with xr.open_dataset(tmp_path / "a" / "windows.nc") as ds:   # the flank values named
        edge = ds.window_peak_frequency.sel(dof="x").values      # (preload, window)
    assert 200.0 <= edge[0, 1] < 205.0 and 195.0 < edge[1, 0] <= 200.0   # next to the edge
    assert f"at {edge[0, 1]:.6g} rad/s" in warns[0] and f"at {edge[1, 0]:.6g} rad/s" in warns[1]


def test_a_declared_effect_no_case_shows_is_named(tmp_path, capsys):
    """Example 1 at 1000 N only: the damper never slips (mu n0 = 500 N against ku u of
    at most 160 N at the stuck peak), so "friction" acts as a linear spring: one
    warning; with 0.5 N as well it slips there: none.  A quick variant is not judged (it
    runs some of the cases the declaration is made for)."""
    from dataclasses import replace

    from pipeline.study.datasets.incomplete import absent_effects
    from pipeline.study.files.documents import load_study

    f = tmp_path / "stuck.toml"
    f.write_text(BELOW.replace("[0.5, 1000.0]", "[1000.0]"))
    assert cli(["run", str(f), "--out", str(tmp_path / "a"), "--workers", "1"]) == 0
    warns = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert warns == [f"warning: {f}: scene.effects: \"friction\" is declared but no contact "
                     "slips at any point of any case (slip_fraction 0 everywhere): the "
                     "friction limit is never reached"]
    import xarray as xr
    with xr.open_dataset(tmp_path / "a" / "stuck.nc") as ds:
        assert absent_effects(replace(load_study(f), quick=True), ds) == []
    f.write_text(BELOW)
    assert cli(["run", str(f), "--out", str(tmp_path / "b"), "--workers", "1"]) == 0
    assert "warning:" not in capsys.readouterr().err


def test_continuation_messages_are_in_the_studys_words():
    from pipeline.study.datasets.response_dataset import readable_message

    two_pi = 2 * 3.141592653589793
    assert readable_message("max_points reached before lam_end", two_pi, "Hz") == (
        "solver.max_points reached before the end of the range")
    assert readable_message("step size below ds_min = 1e-06 at lam = 628.3185307179587",
                            two_pi, "Hz") == ("arc-length step below its smallest, ds_min = "
                                              "1e-06 at the frequency = 100 Hz")


def test_absent_effects_judge_response_datasets_only():
    """A nonlinear-modes dataset has contact-state fractions but no peak_complete: no
    verdict (the full run of such a study raised a KeyError here)."""
    import numpy as np
    import xarray as xr
    from dataclasses import replace

    from pipeline.study.datasets.incomplete import absent_effects
    from pipeline.study.files.documents import parse_study

    study = replace(parse_study(BELOW, file="below.toml"), quick=False)
    ds = xr.Dataset({"slip_fraction": (("point", "pair"), np.zeros((3, 1))),
                     "converged": ("point", np.ones(3, np.int8))})
    assert absent_effects(study, ds) == []
    ds["peak_complete"] = ((), np.int8(1))
    assert absent_effects(study, ds) == ["\"friction\" is declared but no contact slips at "
                                         "any point of any case (slip_fraction 0 everywhere): "
                                         "the friction limit is never reached"]


def stuck_peak(c=0.3, k=3.55e4 + 1.0e4, F=1.0):
    """The largest amplitude [m] of m x'' + c x' + k x = F cos(w t), m = 1 kg, over w
    (closed form): F / (c sqrt(k - c^2 / 4))."""
    return F / (c * (k - c * c / 4) ** 0.5)


def test_a_peak_that_does_not_depend_on_the_preload_has_no_optimum(tmp_path, capsys):
    """Bounds 1000-10000 N keep Example 1's damper stuck (|ku u| <= 160 N < mu n0 =
    500 N): the peak is the linear stuck oscillator's at every preload (closed form), so
    no preload is reported as optimal: NaN in the dataset, said by its attributes, and
    one printed line after `run` and after `optimise` (before, the optimum was the
    lower bound, 1000 N, with no warning)."""
    import xarray as xr

    f = tmp_path / "stuck.toml"
    f.write_text(BELOW + '\n[output.optimum_preload]\ndof = "x"\nbounds = [1000.0, 1.0e4]\n')
    assert cli(["run", str(f), "--out", str(tmp_path / "a"), "--workers", "1"]) == 0
    warns = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert len(warns) == 1 and warns[0].startswith(
        f"warning: {f}: output.optimum_preload: the peak of x is the same at every preload "
        "of the search's grid (relative spread ")
    assert "does not depend on the preload" in warns[0]
    with xr.open_dataset(tmp_path / "a" / "stuck.nc") as ds:
        assert np.isnan(float(ds["optimum_preload"]))
        assert int(ds["optimum_preload"].attrs["independent_of_preload"]) == 1
        assert float(ds["optimum_preload"].attrs["peak_relative_spread"]) < 1e-9
        assert float(ds["optimum_peak_amplitude"]) == pytest.approx(stuck_peak(), rel=1e-8)
        assert np.allclose(ds["optimum_search_peak"].values, stuck_peak(), rtol=1e-8)
    assert cli(["optimise", str(f), "--out", str(tmp_path / "b"), "--workers", "1"]) == 0
    out = capsys.readouterr()
    assert "preload minimising the peak of x: none, the peak does not depend on it" in out.out
    warns = [ln for ln in out.err.splitlines() if ln.startswith("warning:")]
    assert len(warns) == 1 and "does not depend on the preload" in warns[0]


def test_a_peak_that_may_hide_between_two_points_is_printed(tmp_path, capsys, monkeypatch):
    """Every branch made to count 2 steps across a resonance not resolved (the
    continuation's own count, here set): each case's message says 'a peak may hide
    there', and so does one printed line per case after `run`, and one line naming
    the preloads after `optimise` (before, the dataset's message only)."""
    import dataclasses

    import pipeline.solve.response.response as resp

    real = resp.cover_range

    def unresolved(*args, **kwargs):
        br, spent = real(*args, **kwargs)
        return dataclasses.replace(br, n_unresolved=2), spent

    monkeypatch.setattr(resp, "cover_range", unresolved)
    f = tmp_path / "hidden.toml"
    f.write_text(BELOW + '\n[output.optimum_preload]\ndof = "x"\nbounds = [0.5, 10.0]\n')
    assert cli(["run", str(f), "--out", str(tmp_path / "a"), "--workers", "1"]) == 0
    warns = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    note = ("2 step(s) across a resonance could not be shortened to its half-power band: a "
            "peak may hide there")
    assert f"warning: {f}: case preload = 0.5 N: {note}" in warns
    assert f"warning: {f}: case preload = 1000 N: {note}" in warns
    search = [w for w in warns if w.startswith(f"warning: {f}: output.optimum_preload: at "
                                               "preload(s) ")]   # the cases' reused
    assert len(search) == 1 and "a peak may hide there" in search[0]
    assert cli(["optimise", str(f), "--out", str(tmp_path / "b"), "--workers", "1"]) == 0
    warns = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert len(warns) == 1 and warns[0].startswith(
        f"warning: {f}: output.optimum_preload: at preload(s) 0.5 N (2), ")
    assert warns[0].endswith("a peak may hide there (its band peak, and so the optimum, may "
                             "be too low)")
