"""Nonlinear modes of tuned cyclic sectors against the assembled wheel.

Six shrouded beam blades (tests/studies/beam_disk6_nonlinear_modes.toml, Craig-Bampton
blades, shroud faces with friction, normal load variation and separation): the
travelling-wave mode of ND 2 (complex: a wave) and ND 3 (N/2: a standing wave) of one
sector, expanded to the six sectors, is a solution of the whole wheel's EPMC
equations; the wheel's EPMC, started from the expanded mode (`mode_problem(start=)`)
and perturbed by 1e-3, converges back to the sector's frequency and damping.  And the
lumped disk's ND 0, whose shrouds never slide, is the uncoupled blade, linear."""
import numpy as np
import pytest

from pipeline.model import cyclic
from pipeline.model.build import full_system
from pipeline.solve.nonlinear_modes import epmc
from pipeline.solve.nonlinear_modes.backbone import continue_mode, newton, point_at
from pipeline.study.files.documents import load_study
from pipeline.solve.nonlinear_modes.epmc import onset_amplitude
from helpers import ROOT, STUDIES

BEAMS = ROOT / "tests" / "studies" / "beam_disk6_nonlinear_modes.toml"


@pytest.fixture(scope="module")
def beams():
    return load_study(BEAMS)


@pytest.mark.parametrize("nd", [2, 3])
def test_sector_mode_is_the_wheels(beams, nd):
    N, H = 6, 3
    case = {"preload": 3.0, "eo": nd}
    sector = beams.response.system(case)
    mp = epmc.mode_problem(sector, H)
    a = onset_amplitude(mp)
    bb = continue_mode(mp, np.log10(0.1 * a), np.log10(100 * a), tol_rel=1e-12)
    assert bb.message == "" and bb.zeta.max() > 1.2 * bb.zeta[0]    # friction damps it
    wheel = full_system(beams.scene, case)
    Q1 = np.zeros((sector.n_dof, 2 * H + 1))
    Q1[:, 1], Q1[:, 2] = mp.shape.real, -mp.shape.imag
    Qf = cyclic.expand(Q1, N, nd)
    mpf = epmc.mode_problem(wheel, H, ref=mp.ref, start=(mp.omega0, Qf[:, 1] - 1j * Qf[:, 2]))
    shift = 0.5 * np.log10(N)          # the wheel's mass norm is N sectors'
    for s in np.log10(a * np.array([0.5, 2.0, 20.0])):
        om, ze, Q = point_at(mp, bb, s, 1e-12)
        scale = np.full(2 * H + 1, 10 ** (s + shift))
        scale[0] = 1.0
        y0 = epmc.pack(mpf, cyclic.expand(Q, N, nd) / scale, om, ze)
        y, it, ok = newton(mpf, y0, s + shift, 1e-10)
        assert it == 0 and ok.converged          # the expanded mode solves the wheel's
        y, it, ok = newton(mpf, y0 * (1 + 1e-3), s + shift, 1e-12)
        assert ok.converged and it >= 2
        assert y[-2] == pytest.approx(om, rel=1e-8) and y[-1] == pytest.approx(ze, rel=1e-8)


def test_nodal_diameter_0_of_the_lumped_disk_is_the_uncoupled_blade():
    """disk_cyclic.toml: at ND 0 neighbouring shrouds move alike, no element slips, the
    mode is the blade alone (377.6 Hz, `natural_frequency_free` of the response study):
    constant frequency and damping over the whole range (1e-10)."""
    study = load_study(STUDIES / "disk_cyclic.toml")
    sector = study.system({"eo": 0})
    mp = epmc.mode_problem(sector, 3)
    assert onset_amplitude(mp) == np.inf
    bb = continue_mode(mp, -6.0, -1.0, tol_rel=1e-12)
    assert bb.message == ""
    blade = np.sqrt(np.linalg.eigvals(np.linalg.solve(sector.M, sector.K)).real.min())
    assert np.abs(bb.omega / bb.omega[0] - 1).max() < 1e-10
    assert np.abs(bb.zeta / bb.zeta[0] - 1).max() < 1e-10
    assert bb.omega[0] == pytest.approx(blade, rel=1e-4)      # EPMC of a damped mode
    assert bb.omega[0] / (2 * np.pi) == pytest.approx(377.6, abs=0.05)
