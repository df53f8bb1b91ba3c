"""Stability decided at a few points of each stretch between folds and propagated
(pipeline/solve/stability/stretches.py, stability mode "stretch").

References: the same method at every point (the orbit monodromy, "monodromy" mode) on
the paper's Example 3 (two folds, the unstable middle branch between them) and on a
coarse Craig-Bampton solid blade with shroud contacts; hand-built flag sequences for
the propagation and the bisection."""
from pathlib import Path

import numpy as np
import pytest

from pipeline.paper_systems import example3
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.stability import branch_stability as sc
from pipeline.solve.response.response import frequency_response
from pipeline.solve.stability.fold_rule import fold_rule
from pipeline.solve.stability.stretches import fold_parity, propagate, stretches

ROOT = Path(__file__).resolve().parents[3]


def test_stretches_cut_at_gaps_and_turning_points():
    lam = np.array([0.0, 1.0, 2.0, 3.0, 2.5, 2.0, 2.2, 2.4, 2.6, 2.8])
    conv = np.ones(lam.size, bool)
    conv[8] = False                                 # a gap
    parts = [p.tolist() for p in stretches(lam, conv)]
    # turning points at 3 (max) and 5 (min), each a stretch of its own
    assert parts == [[0, 1, 2], [3], [4], [5], [6, 7], [9]]


def _counting(truth):
    calls = []

    def decide(i):
        calls.append(i)
        return bool(truth[i])
    return decide, calls


def test_propagation_decides_few_points_and_bisects_a_change_inside_a_stretch():
    lam = np.arange(40, dtype=float)                # one stretch of 40 points
    truth = np.ones(40, bool)
    truth[23:] = False                              # a secondary bifurcation at 22|23
    decide, calls = _counting(truth)
    stable, done = propagate(stretches(lam, np.ones(40, bool)), decide)
    assert np.array_equal(stable, truth)
    assert len(calls) == len(set(calls)) == done.size
    assert {22, 23} <= set(done.tolist())           # both sides of the change decided
    assert done.size <= 3 + int(np.ceil(np.log2(40))) + 1   # ends, middle, bisection


def test_propagation_decides_beside_each_fold():
    lam = np.concatenate([np.linspace(0, 10, 11), np.linspace(9, 5, 5), np.linspace(6, 14, 9)])
    truth = np.ones(lam.size, bool)
    truth[11:16] = False                            # between the two turning points
    decide, calls = _counting(truth)
    stable, done = propagate(stretches(lam, np.ones(lam.size, bool)), decide)
    assert np.array_equal(stable, truth)
    assert done.size < lam.size


@pytest.mark.parametrize("n0, lo, hi", [(-20.0, 0.9, 1.15), (10.0, 1.15, 1.45)])
def test_example3_propagated_equals_every_point(n0, lo, hi):
    """Example 3 with a fold pair and an unstable middle branch (studies/README.md figure): the
    propagated flags equal the orbit monodromy's at every point, from a fraction of
    the decisions; the bifurcations (the two folds) are the same."""
    full = frequency_response(example3(n0), 5, lo, hi, stability="monodromy",
                              dense_output=False)
    prop = frequency_response(example3(n0), 5, lo, hi, stability="stretch",
                              dense_output=False)
    assert full.fold_parameter.size == 2 and (~full.stable[full.converged]).sum() >= 5
    m = full.converged
    assert np.array_equal(prop.stable[m], full.stable[m])
    decided = prop.stability_method != sc.PROPAGATED
    assert decided.sum() < 0.35 * full.n_points
    assert np.isnan(prop.monodromy_multiplier[~decided]).all()
    np.testing.assert_allclose(prop.bifurcation_parameter, full.bifurcation_parameter,
                               rtol=0, atol=1e-9)
    assert list(prop.bifurcation_kind) == [sc.FOLD, sc.FOLD]


def tiny_blade_study(extra=""):
    """The shrouded blade study on a coarse mesh (Craig-Bampton 6 modes, 102 DOFs),
    preload 3 N: stick-slip peak at 315.6 Hz between folds at 315.3 and 335.2 Hz."""
    from pipeline.study.files.documents import parse_study
    text = (ROOT / "studies" / "blade_shroud_contact.toml").read_text()
    text = text[:text.index("[quick.scene.blade]")]
    for old, new in [("craig_bampton_modes = 40", "craig_bampton_modes = 6"),
                     ("n_chord = 8\nn_thick = 2\nn_span = 20",
                      "n_chord = 2\nn_thick = 1\nn_span = 4"),
                     ("preload = [0.3, 3.0, 30.0, 1000.0]", "preload = [3.0]"),
                     ("start = 300.0, stop = 550.0", "start = 380.0, stop = 300.0")]:
        assert old in text
        text = text.replace(old, new)
    return parse_study(text + extra, file="tiny_blade.toml", name="tiny_blade")


def tiny_blade_study_with_stability():
    """The same with `[solver] stability = true`."""
    from pipeline.study.files.documents import parse_study
    text = tiny_blade_study().text.replace("[solver]\n", "[solver]\nstability = true\n", 1)
    return parse_study(text, file="tiny_blade.toml", name="tiny_blade")


@pytest.fixture(scope="module")
def fe_curve():
    study = tiny_blade_study()
    system = study.system(study.sweep.cases()[0][1])
    c = frequency_response(system, 3, 2 * np.pi * 380.0, 2 * np.pi * 300.0, stability=False,
                           dense_output=False, peak_dofs=[study.scene.dof_index("response.y")])
    return study, system, c


@pytest.mark.slow   # the orbit monodromy at every point: 255 s measured on a loaded machine
def test_fe_blade_propagated_equals_every_point(fe_curve):
    _, system, c = fe_curve
    prob = hbm.setup(system, 3)
    args = (prob, c.Q, c.omega, c.omega, lambda lam: system.contact, c.converged)
    full = sc.branch_stability(*args, "monodromy", c.fold_parameter, c.amplitude)
    prop = sc.branch_stability(*args, "stretch", c.fold_parameter, c.amplitude)
    m = c.converged
    assert np.array_equal(prop.stable[m], full.stable[m])
    assert (prop.method != sc.PROPAGATED).sum() < c.n_points / 2
    assert (prop.method == sc.MONODROMY).sum() < (full.method == sc.MONODROMY).sum()
    assert c.fold_parameter.size >= 2 and (~full.stable[m]).any() and full.stable[m].any()


@pytest.fixture(scope="module")
def fe_stretch(fe_curve):
    """The coarse FE blade's flags in "stretch" mode (what `stability = true` selects)."""
    _, system, c = fe_curve
    return sc.branch_stability(hbm.setup(system, 3), c.Q, c.omega, c.omega,
                               lambda lam: system.contact, c.converged, "stretch",
                               c.fold_parameter, c.amplitude)


@pytest.fixture(scope="module")
def fe_folds(fe_curve):
    """The coarse FE blade's flags by the fold rule (its default), for the figure and
    the comparison with the stretches."""
    _, system, c = fe_curve
    return sc.branch_stability(hbm.setup(system, 3), c.Q, c.omega, c.omega,
                               lambda lam: system.contact, c.converged, "folds",
                               c.fold_parameter, c.amplitude)


def test_fe_study_figure_draws_stable_solid_and_unstable_dashed(fe_curve, fe_folds):
    """FE blade scenes asked for stability (`stability = true`: "stretch") draw solid
    (stable) and dashed (unstable) stretches and no dotted one.  The flags drawn are the
    fold rule's, which equal the stretches' (`test_fe_blade_fold_rule_equals_stretch`)
    at a tenth of the monodromies: the stretches' own are computed once, in that test."""
    from pipeline.study.figures.plots import pyplot, response_curves_plot
    _, _, c = fe_curve
    assert tiny_blade_study_with_stability().solver.stability == "stretch"
    bs = fe_folds
    stable = np.where(c.converged, bs.stable.astype(float), np.nan)
    fig = response_curves_plot([("preload = 3 N", c.omega / (2 * np.pi), c.amplitude[:, 0],
                                 stable, c.converged)])
    gids = {line.get_gid() for line in fig.axes[0].lines}
    pyplot().close(fig)
    assert {"stability=1", "stability=0"} <= gids and "stability=-1" not in gids


def test_fold_parity_counts_each_reversal_and_a_reversal_across_a_gap():
    lam = np.array([0.0, 1.0, 2.0, 3.0, 2.5, 2.0, 2.2, 2.4])
    conv = np.ones(lam.size, bool)
    assert fold_parity(lam, conv).tolist() == [0, 0, 0, 0, 1, 1, 2, 2]
    conv[4] = False                                 # the fold's far side lost: 3 -> 2
    assert fold_parity(lam, conv).tolist() == [0, 0, 0, 0, -1, 1, 2, 2]


def test_fold_rule_flips_at_folds_from_a_decided_end():
    lam = np.array([0.0, 1.0, 2.0, 3.0, 2.5, 2.0, 2.2, 2.4])
    conv = np.ones(lam.size, bool)
    stable, decided, note = fold_rule(lam, conv, lambda i: True if i == 0 else None)
    assert stable.tolist() == [True] * 4 + [False] * 2 + [True] * 2
    assert decided == {0: True} and "branch's ends" in note


def test_fold_rule_contradicted_by_its_ends_is_not_a_verdict():
    """Both ends stable across one fold: a secondary bifurcation must lie between,
    so the rule gives no flag rather than a wrong one."""
    lam = np.array([0.0, 1.0, 2.0, 1.5, 1.0])
    stable, _, note = fold_rule(lam, np.ones(5, bool), lambda i: True)
    assert stable is None and "contradicted" in note


def test_fold_rule_without_a_cheap_end_takes_the_first_point_stable_and_says_so():
    stable, decided, note = fold_rule(np.arange(4.0), np.ones(4, bool), lambda i: None)
    assert stable.all() and not decided and "taken stable" in note


@pytest.mark.parametrize("n0, lo, hi", [(-20.0, 0.9, 1.15), (10.0, 1.15, 1.45)])
def test_example3_fold_rule_equals_every_point(n0, lo, hi):
    """Example 3's two folds and unstable middle branch: the fold rule from its ends
    (linear flows, or the orbit monodromy where a contact switches) gives the orbit monodromy's flag at every point
    but the turning points themselves (the fold lies within a step of them)."""
    full = frequency_response(example3(n0), 5, lo, hi, stability="monodromy",
                              dense_output=False)
    prob = hbm.setup(example3(n0), 5)
    folds = sc.branch_stability(prob, full.Q, full.omega, full.omega,
                                lambda lam: example3(n0).contact, full.converged, "folds",
                                full.fold_parameter, full.amplitude)
    m = full.converged
    parity = fold_parity(full.omega, m)
    turning = np.flatnonzero(np.diff(parity[m]) != 0)     # the last point before each fold
    differ = np.flatnonzero(folds.stable[m] != full.stable[m])
    assert set(differ.tolist()) <= set(turning.tolist())
    assert full.fold_parameter.size == 2 and (~folds.stable[m]).sum() >= 5
    assert set(np.unique(folds.method[m]).tolist()) <= {sc.FOLD_RULE, sc.MONODROMY}
    assert (folds.method == sc.MONODROMY).sum() <= 2 and "branch's ends" in folds.note
    assert list(folds.bifurcation_kind) == [sc.FOLD, sc.FOLD]


@pytest.mark.slow   # the orbit monodromy stretch by stretch, 34 s (Example 3's fold rule: by default)
def test_fe_blade_fold_rule_equals_stretch(fe_curve, fe_folds, fe_stretch):
    """The coarse FE blade through two folds: the fold rule (its default) gives the
    flags the orbit monodromy decides stretch by stretch, from the ends alone."""
    _, _, c = fe_curve
    rule = fe_folds
    ref = fe_stretch
    m = c.converged
    parity = fold_parity(c.omega, m)
    turning = set(np.flatnonzero(np.diff(parity[m]) != 0).tolist())
    assert set(np.flatnonzero(rule.stable[m] != ref.stable[m]).tolist()) <= turning
    assert (~rule.stable[m]).any() and rule.stable[m].any()
    assert (rule.method == sc.MONODROMY).sum() < (ref.method == sc.MONODROMY).sum()
    assert tiny_blade_study().solver.stability == "folds"
