"""A residual tolerance below round-off: the floor of `roundoff`, curves that reach
their range end with the closed-form linear peak, and curves that stop short."""
import logging

import numpy as np
import pytest
import scipy.sparse as sp
import xarray as xr
from scipy.optimize import minimize_scalar

from pipeline.__main__ import main as cli
from pipeline.contact import YangMenq
from pipeline.model.system import System, coupled_stiffness
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.harmonic_balance import roundoff
from pipeline.solve.response.response import frequency_response
from pipeline.paper_systems import example1
from helpers import example1_study

K0, KC, ZETA = 1e4, 1e9, 1e-2   # N/m soft ground spring, N/m stiff coupling, damping ratio


def stiff_chain():
    """Two 1 kg masses: ground -k0- m1 -kc- m2, C = alpha M (ratio ZETA on the soft
    mode w1 = sqrt(k0 / 2)), 1 N on m1; a gap element on m2 (n0 = -1e3 N, kv = 1 N/m)
    that never closes, so the response is linear.  Its internal forces kc (q1 - q2)
    are ~1e5 times the load near w1: their round-off in the residual exceeds 1e-10 N."""
    w1 = np.sqrt(K0 / 2)
    K = np.array([[K0 + KC, -KC], [-KC, KC]])
    return System(M=np.eye(2), C=2 * ZETA * w1 * np.eye(2), K=K, Bt=np.array([[1.0, 0.0]]),
                  Bn=np.array([[0.0, 1.0]]), contact=YangMenq(1.0, 1.0, 0.3, -1e3),
                  forcing=np.array([[0, 1.0], [0, 0]])), w1


def linear_q1(s, om):
    return np.linalg.solve(s.K - om**2 * s.M + 1j * om * s.C, [1.0, 0.0])


def exact_coefficients(s, om, H):
    """Q (2, 2H+1) of the linear response: X1 = Qc_1 - i Qs_1 (`hbm` layout)."""
    X = linear_q1(s, om)
    Q = np.zeros((2, 2 * H + 1))
    Q[:, 1], Q[:, 2] = X.real, -X.imag
    return Q


def test_exact_solution_residual_is_above_the_tolerance_and_below_the_floor():
    s, w1 = stiff_chain()
    prob = hbm.setup(s, 1)
    tols = hbm.tolerances(prob, 1e-10)
    above = 0
    for om in w1 * np.linspace(0.95, 1.05, 11):
        Q = exact_coefficients(s, om, 1)
        rs, rd = hbm.residual_parts(hbm.full_residual(prob, Q, om))
        fs, fd = roundoff.full_floor(prob, Q, om)
        assert rd <= fd and rs <= max(fs, tols[0])
        assert fd > 10 * tols[1]   # the requested 1e-10 N is below what doubles resolve
        norm, ok, on_floor = roundoff.check_point(prob, Q, om, None, tols)
        assert ok and on_floor == (rd > tols[1]) and norm == pytest.approx(np.hypot(rs, rd))
        above += rd > tols[1]
    assert above >= 8   # the exact solution itself mostly misses the tolerance


def test_the_condensed_floor_is_that_of_the_summed_terms():
    s, w1 = stiff_chain()
    prob = hbm.setup(s, 2)
    x = exact_coefficients(s, w1, 2)[prob.c].ravel()
    R, J, _ = hbm.residual(prob, x, w1)
    loads = roundoff.load_scales(prob)
    dense = roundoff.condensed_floor(prob, x, J, loads)
    sparse = roundoff.condensed_floor(prob, x, sp.csr_matrix(J), loads)
    np.testing.assert_allclose(dense, sparse, rtol=1e-14)
    # by hand: 8 eps (|J||x| per block + the load scale); only harmonic 1 moves
    terms = (np.abs(J) @ np.abs(x)).reshape(prob.c.size, prob.nh)
    eps8 = 8 * np.finfo(float).eps
    assert dense[1] == pytest.approx(eps8 * (np.linalg.norm(terms[:, 1:]) + 1.0))
    assert dense[0] == pytest.approx(eps8 * (np.linalg.norm(terms[:, 0]) + 1e3))
    assert np.linalg.norm(R.reshape(prob.c.size, prob.nh)[:, 1:]) <= dense[1]


def test_stiff_chain_reaches_its_range_end_with_the_closed_form_peak(caplog):
    s, w1 = stiff_chain()
    with caplog.at_level(logging.WARNING, logger="pipeline.solve.response.response"):
        c = frequency_response(s, 1, 0.7 * w1, 1.3 * w1, stability=False)
    assert c.success and c.omega[-1] == pytest.approx(1.3 * w1, rel=1e-12), c.message
    assert c.converged.all() and c.info["roundoff_points"] > 0
    assert sum("round-off floor" in r.getMessage() for r in caplog.records) == 1
    ref = minimize_scalar(lambda om: -abs(linear_q1(s, om)[0]), bounds=(0.9 * w1, 1.1 * w1),
                          method="bounded", options={"xatol": 1e-10})
    a, om, _ = c.peak(0)
    assert a == pytest.approx(-ref.fun, rel=1e-8)
    assert om == pytest.approx(ref.x, rel=1e-5)   # a flat maximum: its place is less sharp
    # every point is the linear solution (the gap stays open)
    ref_a = [abs(linear_q1(s, o)[0]) for o in c.omega]
    np.testing.assert_allclose(c.amplitude[:, 0], ref_a, rtol=1e-7)


def test_a_tolerance_above_the_floor_keeps_its_meaning():
    c = frequency_response(example1(0.0), 3, 150, 250, stability=False)
    assert c.success and c.converged.all() and c.info["roundoff_points"] == 0
    prob = hbm.setup(example1(0.0), 3)
    tols = hbm.tolerances(prob, 1e-10)
    floors = [max(roundoff.full_floor(prob, q, om)) for q, om in zip(c.Q, c.omega)]
    assert max(floors) < 0.1 * min(tols)   # the peak's amplification is 230 here


SHORT = example1_study(
    "a branch cut short by max_points",
    study='description = "the Example 1 oscillator"\nreference = "Sec. 6.1"',
    solver="harmonics = 3\ntolerance = 1e-9\nstability = false\nmax_points = MAXP",
    output='dofs = ["x"]\nfigures = []')


def test_a_branch_that_stops_short_is_flagged_and_named_once(tmp_path, capsys):
    f = tmp_path / "short.toml"
    f.write_text(SHORT.replace("MAXP", "12"))
    assert cli(["run", str(f), "--out", str(tmp_path / "out"), "--workers", "1"]) == 0
    err = capsys.readouterr().err
    warns = [line for line in err.splitlines() if line.startswith("warning:")]
    assert len(warns) == 2 and warns[0].startswith(f"warning: {f}: case preload = 0 N: ")
    assert "of 150-250 rad/s" in warns[0] and "the peak may lie beyond" in warns[0]
    with xr.open_dataset(tmp_path / "out" / "short.nc") as ds:
        assert not ds["peak_complete"].any() and not ds["success"].any()
        assert ds["peak_complete"].attrs["units"] == "1"
        # the largest amplitude traced lies below the peak of the interval (linear
        # at 0 N: 1 / (c w_n) at w_n = 188.4 rad/s, beyond the last point)
        top = float(ds["frequency"].sel(preload=0.0).max())
        assert top < 188.0
        peak = float(ds["peak_amplitude"].sel(preload=0.0, dof="x"))
        assert peak < 0.5 / (0.3 * np.sqrt(3.55e4))
    f.write_text(SHORT.replace("MAXP", "1000"))
    assert cli(["run", str(f), "--out", str(tmp_path / "out2"), "--workers", "1"]) == 0
    assert "warning:" not in capsys.readouterr().err
    with xr.open_dataset(tmp_path / "out2" / "short.nc") as ds:
        assert ds["peak_complete"].all()
        np.testing.assert_allclose(float(ds["peak_amplitude"].sel(preload=0.0, dof="x")),
                                   1 / (0.3 * np.sqrt(3.55e4)), rtol=1e-4)


WHEEL = """
[study]
title = "6 solid blades, open shrouds"
description = "the shrouded_disk blade on its quick mesh at R = 0.05 m, EO 1"
reference = "linear limit"

[scene]
model = "solid_blade"
effects = ["friction", "normal_load_variation", "separation", "cyclic_coupling"]
craig_bampton_modes = 20
rayleigh = [20.0, 4e-6]

[scene.blade]
n_chord = 2
n_thick = 1
n_span = 4

[scene.disk]
sectors = 6
hub_radius = 0.05
engine_order = 1

[[scene.contact]]
pair = "shroud"
ku = 5e5
kv = 5e5
mu = 0.3
stiffness = "per_face"

[[scene.excitation]]
set = "excitation"
direction = [0.0, 1.0, 0.0]
amplitude = 1.0

[sweep]
preload = [-1e4]
frequency = { start = 90.0, stop = 110.0, unit = "Hz" }

[solver]
harmonics = 3
tolerance = 1e-10

[output]
dofs = ["response.y"]
figures = []
"""


def test_fe_wheel_with_open_shrouds_reaches_the_linear_peak(tmp_path):
    from pipeline.study.files.documents import load_study
    f = tmp_path / "wheel.toml"
    f.write_text(WHEEL)
    study = load_study(f)
    s = study.system(study.sweep.cases()[0][1])
    dof = study.scene.dof_index("response.y")
    c = frequency_response(s, 3, 2 * np.pi * 90, 2 * np.pi * 110, tol_rel=1e-10,
                           stability=False, peak_dofs=[dof])
    assert c.success and c.omega[-1] == pytest.approx(2 * np.pi * 110), c.message
    # the linear response of the sector's engine-order wave (harmonic 1, phase phi)
    K1 = np.asarray(coupled_stiffness(s, s.cyclic.phase if s.cyclic else 0.0))
    M, C, F = np.asarray(s.M), np.asarray(s.C), np.asarray(s.forcing)[:, 1]
    ref = minimize_scalar(lambda om: -abs(np.linalg.solve(K1 - om**2 * M + 1j * om * C, F)[dof]),
                          bounds=(2 * np.pi * 100, 2 * np.pi * 106), method="bounded",
                          options={"xatol": 1e-9})
    a, om, _ = c.peak(dof)
    # |K||Q| / |P| ~ 1e7 here: the closed form itself is exact to ~1e-9 only (3e-9 measured)
    assert a == pytest.approx(-ref.fun, rel=3e-8) and om == pytest.approx(ref.x, rel=1e-5)
    assert a == pytest.approx(1.5960e-5, rel=1e-4)   # at 103.25 Hz; the old stop: 101.16 Hz


def test_the_linear_solver_accepts_exact_solutions_on_the_floor():
    from pipeline.solve.response import linear_response
    s, w1 = stiff_chain()
    lin = System(M=s.M, C=s.C, K=s.K, Bt=np.zeros((0, 2)), Bn=np.zeros((0, 2)),
                 contact=YangMenq(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)),
                 forcing=s.forcing)
    c = linear_response.frequency_response(lin, 1, 0.7 * w1, 1.3 * w1, stability=False,
                                           peak_dofs=[0])
    assert c.success and c.converged.all() and c.info["roundoff_points"] > 0, c.message
    ref = [abs(linear_q1(s, o)[0]) for o in c.omega]
    np.testing.assert_allclose(c.amplitude[:, 0], ref, rtol=1e-12)
