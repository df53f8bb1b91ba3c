"""`check` of a mistuned wheel of FE blades without building the wheel
(`cost.time_point`): its tuned sector timed and scaled, its natural frequencies in the
range counted as the tuned wheel's (against the tuned wheel assembled sector by sector
and solved), the memory its Jacobian and factors need against the machine's."""
import pytest

from pipeline.model import build
from pipeline.model.cyclic import full_assembly
from pipeline.solve.harmonic_balance import hbm
from pipeline.study.execution import cost, response_study
from pipeline.study.files.documents import parse_study

from helpers import STUDIES

# the full-size blade's study, coarse, as a mistuned wheel of 12 blades, 1D friction
WHEEL = {"n_chord = 8                      # 51 node pairs per shroud face": "n_chord = 2",
         "n_thick = 2": "n_thick = 1", "n_span = 12": "n_span = 4",
         "sectors = 36": "sectors = 12\nmistuning = { stiffness_std = 0.03, seed = 1 }",
         '"cyclic_coupling"]': '"cyclic_coupling", "mistuning"]',
         '"friction", "friction_2d",': '"friction",', 'friction = "2d"\n': "",
         'force_evaluation = "aft"': 'force_evaluation = "exact"'}


def wheel_study():
    text = (STUDIES / "full_size_blade.toml").read_text()
    for a, b in WHEEL.items():
        assert a in text
        text = text.replace(a, b)
    return parse_study(text[:text.index("[quick")], file="wheel.toml", name="wheel")


def test_a_large_wheel_is_estimated_on_its_sector_unbuilt(monkeypatch):
    """12 sectors of 630 unknowns (H = 3): above WHEEL_BUILT, so the wheel is never
    assembled; unknowns 12 x the sector's, its times the sector's scaled; the lines name
    the scaling and the memory."""
    study = wheel_study()

    def refuse(*a, **k):
        raise AssertionError("the wheel was assembled to estimate it")
    monkeypatch.setattr(build.cyclic, "full_assembly", refuse)
    tm = cost.time_point(study, repeats=1)
    sector = cost.tuned_sector(study, study.sweep.cases()[0][1])
    assert tm.sectors == 12 and tm.sparse and tm.unknowns > cost.WHEEL_BUILT
    assert tm.unknowns == 12 * hbm.setup(sector, 3).c.size * 7
    lines = response_study.estimate_lines(study, 1, 1, linear=False)
    assert any("not built to estimate it" in line and "GB" in line for line in lines)


def test_wheel_modes_are_the_tuned_wheels():
    """The count over nodal diameters equals the natural frequencies in the range of the
    tuned 12-sector wheel assembled sector by sector (contacts open and stuck)."""
    study = wheel_study()
    case = study.sweep.cases()[0][1]
    fr = study.sweep.frequency
    tuned = full_assembly(build.sector(study.scene, case), build.engine_order(study.scene, case))
    m = cost.modes_in_range(tuned, fr)
    assert m > 0 and cost.wheel_modes(study, fr) == m


def test_a_wheel_beyond_the_machines_memory_is_said(monkeypatch):
    """The warning line when the Jacobian and factors would not fit (the machine's memory
    made 1 kB here); WHEEL_BYTES per entry of the N blocks of (n_u / N)^2."""
    study = wheel_study()
    tm = cost.PointTiming(1.0, 1.0, 12 * 630, 1.0, True, 1.0, 0.0, 0.0, 12)
    need, have = cost.wheel_memory(tm)
    assert need == pytest.approx(cost.WHEEL_BYTES * 12 * 630.0 ** 2) and have > 1e9
    monkeypatch.setattr(response_study, "wheel_memory", lambda tm: (need, 1e3))
    lines = response_study.estimate_lines(study, 1, 1, linear=False)
    assert any(line.startswith("warning: the wheel's Jacobian and factors") for line in lines)
