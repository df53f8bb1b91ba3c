"""`check`'s estimate of a response study (`study.execution.cost`) counts the work a
speed sweep and an interference add: one reduction for each speed after the first
(the run reduces the blade once a speed) and one at rest (the dataset's description,
counted in a run) and the static contact solution of every
case whose shrouds are set by an interference (the dataset's static state), by the
module's formula, checked by hand on a constructed timing (no time measured)."""
from dataclasses import replace

import pytest

from pipeline.study.execution import cost
from pipeline.study.files.documents import load_study
from helpers import STUDIES


@pytest.fixture(scope="module")
def speed_study():
    return load_study(STUDIES / "shrouded_disk_speed.toml", quick=True)


def timing(reduction=0.0, static=0.0):
    """A constructed `PointTiming` [s] (the machine's slowdown as calibrated)."""
    return cost.PointTiming(t_residual=1e-3, t_solve=2e-3, unknowns=91, setup=1.5,
                            reduction=reduction, static=static)


def test_each_speed_adds_a_reduction_and_each_case_its_static_solution(speed_study):
    """The quick speed study: 3 cases at 6,000, 7,250 and 8,000 rpm, a shroud gap
    (interference -0.1 mm): beside the first case's reduction, 2 further speeds' and
    the one at rest the dataset describes, and 3 static solutions, on one worker as
    on two (the main process builds every case's model and writes the dataset)."""
    assert [c["speed"] for _, c in speed_study.sweep.cases()] == [6000.0, 7250.0, 8000.0]
    assert cost.speeds_of(speed_study) == 3
    for workers in (1, 2):
        bare = cost.estimate(speed_study, workers, timing())
        more = cost.estimate(speed_study, workers, timing(reduction=0.4, static=0.01))
        assert more.lo - bare.lo == pytest.approx(3 * 0.4 + 3 * 0.01, rel=1e-12)
        assert more.hi - bare.hi == pytest.approx(3 * 0.4 + 3 * 0.01, rel=1e-12)


def test_one_speed_adds_the_reduction_at_rest(speed_study):
    """The same study at one speed (the sweep's first) adds the reduction at rest and
    its static solution; at rest, nothing but the static solution."""
    sw = speed_study.sweep
    one = replace(speed_study, sweep=replace(sw, axes={"speed": (6000.0,)}))
    assert cost.speeds_of(one) == 1
    assert cost.model_work(one, timing(reduction=0.4, static=0.01)) == pytest.approx(0.41)
    rest = replace(speed_study, sweep=replace(sw, axes={"speed": (0.0,)}))
    assert cost.model_work(rest, timing(reduction=0.4, static=0.01)) == pytest.approx(0.01)


@pytest.mark.parametrize("workers", [1, 2])
def test_the_reductions_counted_are_the_ones_a_run_makes(speed_study, tmp_path, monkeypatch,
                                                         workers):
    """Counted in the run (figures and peak shapes written), serially and on a pool of
    two (whose workers get each case's model built by the main process): the quick
    speed study reduces its blade 4 times, at each of its 3 speeds and at rest (the
    dataset's reduced frequencies), which the estimate counts (the first in its
    setup)."""
    from pipeline.model import blade_cache
    from pipeline.structure import reduction
    from pipeline.study.execution.run import run_study

    made = []
    real = reduction.reduce_blade
    monkeypatch.setattr(reduction, "reduce_blade",
                        lambda blade, *a, **k: made.append(1) or real(blade, *a, **k))
    for cached in (blade_cache.reduced_model, blade_cache.blade_at_speed):
        cached.cache_clear()
    run_study(speed_study, tmp_path, workers=workers, progress=False, checkpoints=False)
    assert len(made) == 4                   # the run, against the count by hand
    # the estimate, one second per further reduction (the one at rest is in its setup):
    # the run's 4 reductions less that one, 3.0 s
    further = cost.model_work(speed_study, timing(reduction=1.0))
    assert further == pytest.approx(3.0, abs=1e-12), f"estimate counts {further} reductions"


def test_the_point_is_timed_with_the_studys_own_harmonics_and_samples(monkeypatch):
    """The residual and the Newton solve are timed on the harmonic-balance problem of
    the study's H and AFT samples (2D friction: H = 1 and 64 samples quick, 3 and 128
    in full), so their growth with (2H + 1) x contact DOFs and samples x elements is
    measured, not assumed: the quick 2D disk has 90 contact DOFs, (2 x 1 + 1) x 90 =
    270 unknowns."""
    from pipeline.solve.harmonic_balance import hbm

    seen = []
    setup = hbm.setup
    monkeypatch.setattr(hbm, "setup", lambda system, H, method, samples, *a, **k: (
        seen.append((H, method, samples)) or setup(system, H, method, samples, *a, **k)))
    quick = load_study(STUDIES / "shrouded_disk_2d.toml", quick=True)
    tm = cost.time_point(quick, repeats=1)
    assert seen == [(1, "aft", 64)] and tm.unknowns == 270
