"""Drawn curves are smooth at a figure's resolution: points where the curve bends.

Reference: the linear FRF of the stuck three-mass chain (closed form per
frequency), whose antiresonance depth a coarse branch gets wrong by 4.6x.
"""
import math
from functools import lru_cache

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from pipeline.paper_systems import example2
from pipeline.solve.continuation.dense_output import PLOT_MIN_CHORD, PLOT_TURN
from pipeline.solve.response.response import frequency_response
from helpers import chain_system, stuck_chain_amplitude

F_LO, F_HI = 4.0, 25.0  # Hz


@lru_cache
def example2_curve(n):
    """Example 2 at preload `n` [N], 13-67 Hz, dense output on both axes: computed once,
    read by the tests below that ask for this same curve."""
    return frequency_response(example2(n), 5, 2 * np.pi * 13, 2 * np.pi * 67, stability=False,
                              peak_dofs=[0])


def test_antiresonance_depth_of_a_linear_branch():
    """x1 of the stuck chain has an antiresonance near 16.30 Hz 4.6x deeper than the
    coarse branch shows; the dense output finds its depth to 1 %."""
    r = minimize_scalar(lambda f: stuck_chain_amplitude(2 * np.pi * f, 0), bounds=(15.5, 17.0), method="bounded",
                        options={"xatol": 1e-10})
    c = frequency_response(chain_system(1e5), 5, 2 * np.pi * F_LO, 2 * np.pi * F_HI,
                           stability=False, peak_dofs=[0, 1, 2])
    a = c.amplitude[:, 0]
    assert a.min() == pytest.approx(r.fun, rel=1e-2)
    assert c.info["dense_points"] > 0
    coarse = frequency_response(chain_system(1e5), 5, 2 * np.pi * F_LO, 2 * np.pi * F_HI,
                                stability=False, peak_dofs=[0, 1, 2], dense_output=False)
    assert coarse.amplitude[:, 0].min() > 2 * r.fun  # what the dense output repairs


@pytest.mark.parametrize("n", [100.0, 10.0])
def test_drawn_curve_turns_little_at_every_point(n):
    """Example 2: in axis units (frequency over the range, log amplitude over its
    decades) consecutive chords of the drawn curve meet at less than the turn limit,
    unless they are already shorter than the smallest chord split."""
    c = example2_curve(n)
    P = np.column_stack([c.omega / np.ptp(c.omega), np.log10(c.amplitude[:, 0])])
    P[:, 1] /= max(np.ptp(P[:, 1]), 0.5)
    ch = np.diff(P, axis=0)
    ln = np.linalg.norm(ch, axis=1)
    cos = np.einsum("ij,ij->i", ch[:-1], ch[1:]) / (ln[:-1] * ln[1:])
    turn = np.arccos(np.clip(cos, -1, 1))
    # inserted peak points may add a small kink at the top; everything else is smooth
    bad = (turn > PLOT_TURN + math.radians(2)) & (ln[:-1] > PLOT_MIN_CHORD) & (ln[1:] > PLOT_MIN_CHORD)
    assert bad.sum() <= 2, np.degrees(turn[bad])


def test_solver_key_turns_dense_output_off(tmp_path):
    """`[solver] dense_output = false`: the continuation points only (a study that
    draws nothing need not pay for smooth curves); a non-boolean is a one-line error."""
    from pathlib import Path

    from pipeline.errors import UsageError
    from pipeline.study.files.documents import load_study
    from pipeline.study.execution.run import run_study

    text = (Path(__file__).parents[2] / "studies" / "chain_stuck_resonance.toml").read_text()
    text = text.replace("preload = [0.0, 5.0, 1.0e5]", "preload = [1.0e5]")
    stuck_peak = -minimize_scalar(lambda f: -stuck_chain_amplitude(2 * np.pi * f, 2), bounds=(12.0, 13.0),
                                  method="bounded", options={"xatol": 1e-12}).fun
    n = {}
    for flag in ("true", "false"):
        f = tmp_path / f"chain_{flag}.toml"
        f.write_text(text.replace("stability = false", f"stability = false\ndense_output = {flag}"))
        st = load_study(f)
        assert st.solver.kwargs()["dense_output"] is (flag == "true")
        ds = run_study(st, tmp_path / flag, figures=False, progress=False).dataset
        n[flag] = int(ds.n_points.item())
        assert float(ds.peak_amplitude.sel(dof="x3").item()) == pytest.approx(stuck_peak, rel=1e-6)
    assert n["false"] < n["true"]
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("stability = false", 'stability = false\ndense_output = "yes"'))
    with pytest.raises(UsageError, match=r"solver\.dense_output"):
        load_study(bad)


def test_dense_output_on_one_amplitude_axis():
    """dense_output = "log" (or "linear"): points only where the curve drawn on that
    axis bends, so fewer than for both; the same peak; anything but a bool or an
    axis name is a ValueError before the continuation."""
    sys = example2(100.0)
    kw = dict(stability=False, peak_dofs=[0])
    both = example2_curve(100.0)        # the same call: 5 harmonics, 13-67 Hz, **kw
    n = {}
    for axes in ("linear", "log"):
        c = frequency_response(sys, 5, 2 * np.pi * 13, 2 * np.pi * 67, dense_output=axes, **kw)
        assert 0 < c.info["dense_points"] < both.info["dense_points"]
        assert c.peak(0)[0] == pytest.approx(both.peak(0)[0], rel=1e-9)
        assert c.peak(0)[1] == pytest.approx(both.peak(0)[1], rel=1e-8)
        n[axes] = c.n_points
    with pytest.raises(ValueError, match="dense_output"):
        frequency_response(sys, 5, 2 * np.pi * 13, 2 * np.pi * 67, dense_output="loglog", **kw)


def test_a_study_draws_its_curves_smooth_on_the_axis_of_its_figures(tmp_path):
    """A study's dense output follows `[output] yscale` (linear, then log): its dataset
    has the points of `frequency_response` with dense_output = yscale, not those of both
    axes (that curve, the same for both scales, computed once)."""
    from pathlib import Path

    from pipeline.study.files.documents import load_study
    from pipeline.study.execution.run import run_study

    text = (Path(__file__).parents[2] / "studies" / "chain_stuck_resonance.toml").read_text()
    text = text.replace("preload = [0.0, 5.0, 1.0e5]", "preload = [5.0]")
    both = None
    for yscale in ("linear", "log"):
        f = tmp_path / yscale / "chain.toml"
        f.parent.mkdir()
        f.write_text(text.replace("[output]", f'[output]\nyscale = "{yscale}"'))
        st = load_study(f)
        ds = run_study(st, tmp_path / yscale / "out", figures=False, progress=False).dataset
        fr, case = st.sweep.frequency, st.sweep.cases()[0][1]
        c = frequency_response(st.system(case), st.solver.harmonics, fr.omega_start,
                               fr.omega_stop, **{**st.solver.kwargs(), "dense_output": yscale})
        if both is None:
            both = frequency_response(st.system(case), st.solver.harmonics, fr.omega_start,
                                      fr.omega_stop, **st.solver.kwargs())
        assert int(ds.n_points.item()) == c.n_points < both.n_points, yscale
