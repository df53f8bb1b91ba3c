"""Floquet multipliers of the exact flow (pipeline/solve/stability/floquet.py).

References: exp(lambda T) of the linear limits (contacts open, fully stuck); the
finite-difference derivative of the period map; the growth of a small perturbation
integrated over 10 periods; and a 3-DOF shrouded-blade model whose stability along
the harmonic-balance branch is settled by time integration.
"""
from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import expm

from pipeline.contact import YangMenq
from pipeline.paper_systems import blade3, example1, example3
from pipeline.solve.stability import floquet as fq
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.time_integration import timesim as ts
from pipeline.solve.time_integration.events import integrate
from pipeline.solve.continuation.newton import newton
from pipeline.solve.time_integration.piecewise import PiecewiseModel
from pipeline.solve.response.response import frequency_response

from helpers import BLADE_STABLE, BLADE_UNSTABLE, assert_same_multiset


def periodic_start(system, Om):
    """(x0, w0, states0) at t = 0 of the shooting steady state."""
    r = ts.steady_state(system, Om)
    assert r.converged, r.message
    return np.concatenate([r.q0, r.qd0]), r.w0, r.state[0]


def linear_multipliers(system, Om, K_add):
    M, C, K = system.M, system.C, system.K + K_add
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    return np.linalg.eigvals(expm(A * 2 * np.pi / Om))


def sdof_frictionless():
    s = example1(1.0)
    return replace(s, contact=YangMenq(1e4, 0.0, 0.0, 1.0))


# ------------------------------------------------------------------ linear limits
@pytest.mark.parametrize("system, Om", [
    pytest.param(sdof_frictionless(), 150.0, id="sdof mu=0"),
    pytest.param(example3(-100.0), 0.97, id="ex3 separated"),
    pytest.param(example3(-100.0), 4.0, id="ex3 separated, Om=4")])
def test_open_contact_is_the_linear_system(system, Om):
    x0, w0, st = periodic_start(system, Om)
    r = fq.monodromy(system, Om, x0, w0, st)
    assert r.success and r.n_events == 0 and r.stuck_sliders == ()
    assert_same_multiset(r.multipliers, linear_multipliers(system, Om, 0.0), 1e-10)
    assert r.verdict == "stable"


@pytest.mark.parametrize("system, Om, K_add", [
    pytest.param(example1(1e9), 200.0, np.array([[1e4]]), id="jenkins n=1e9"),
    pytest.param(example3(500.0), 1.0, np.diag([1.0, 1.0]), id="ex3 n0=500")])
def test_fully_stuck_contact_adds_the_stuck_stiffness(system, Om, K_add):
    r = fq.from_steady_state(system, ts.steady_state(system, Om))
    assert r.orbit_converged
    assert r.neutral_sliders == (0,) and r.stuck_sliders == ()
    assert_same_multiset(r.multipliers, linear_multipliers(system, Om, K_add), 1e-10)
    # the extended map keeps the neutral slider: one extra multiplier exactly 1
    ext = np.linalg.eigvals(r.extended)
    assert_same_multiset(ext, np.append(r.multipliers, 1.0), 1e-10)


# ------------------------------------------------------------------ stick-slip, separation
NONSMOOTH = [
    pytest.param(example1(1.0), 200.0, {(1, 2), (2, 1), (1, 3), (3, 1)}, id="ex1 stick-slip"),
    pytest.param(example3(10.0), 1.3, {(0, 2), (2, 1), (1, 3), (3, 0)}, id="ex3 n0=10"),
    pytest.param(example3(-20.0), 1.0, {(0, 2), (2, 1), (1, 3), (3, 0)}, id="ex3 gap 20")]


@pytest.mark.parametrize("system, Om, pairs", NONSMOOTH)
def test_saltation_product_equals_finite_differences(system, Om, pairs):
    x0, w0, st = periodic_start(system, Om)
    r = fq.monodromy(system, Om, x0, w0, st)
    ev = integrate(PiecewiseModel(system, Om), 0.0, x0, w0, st, 2 * np.pi / Om, True)["events"]
    assert {(int(a), int(b)) for _, _, a, b in ev} == pairs
    J = fq.finite_difference_monodromy(system, Om, x0, w0, st)
    assert np.linalg.norm(r.monodromy - J) <= 1e-6 * np.linalg.norm(J)
    assert_same_multiset(r.multipliers, np.linalg.eigvals(J), 1e-6)
    assert r.min_transversality > 1e-2 and r.verdict == "stable"


@pytest.mark.parametrize("system, Om, pairs", NONSMOOTH)
def test_multipliers_predict_a_perturbation_over_ten_periods(system, Om, pairs):
    """A perturbation along the dominant eigenvector, integrated 10 periods: the whole
    of it equals Phi^10 times it (to 1e-3), its component on that eigenvector (left
    eigenvector projection) is multiplied by mu^10 (to 1e-3): it decays."""
    x0, w0, st = periodic_start(system, Om)
    r = fq.monodromy(system, Om, x0, w0, st)
    mdl = PiecewiseModel(system, Om)
    kept = list(r.stuck_sliders)
    z0 = np.concatenate([x0, w0[kept]])
    lam, V = np.linalg.eig(r.monodromy)
    k = int(np.argmax(np.abs(lam)))
    d0 = 1e-6 * np.linalg.norm(z0) * (V[:, k].real / np.linalg.norm(V[:, k].real))
    z, zp = z0, z0 + d0
    for _ in range(10):
        z = fq.period_map(mdl, z, w0, st, kept)
        zp = fq.period_map(mdl, zp, w0, st, kept)
    d10, lin = zp - z, np.linalg.matrix_power(r.monodromy, 10) @ d0
    assert np.linalg.norm(d10 - lin) <= 1e-3 * np.linalg.norm(lin)
    left = np.linalg.inv(V)[k]
    ratio = (left @ d10) / (left @ d0)
    assert abs(ratio - lam[k] ** 10) <= 1e-3 * abs(lam[k]) ** 10
    assert abs(lam[k]) == pytest.approx(r.max_modulus) and r.max_modulus < 1


def test_one_recorded_period_per_monodromy(monkeypatch):
    calls = []
    real = fq.integrate

    def counted(*a, **k):
        calls.append(a[-1] if len(a) > 6 else k.get("record"))
        return real(*a, **k)

    x0, w0, st = periodic_start(example1(1.0), 200.0)
    monkeypatch.setattr(fq, "integrate", counted)
    fq.monodromy(example1(1.0), 200.0, x0, w0, st)
    assert calls == [True]


@pytest.mark.parametrize("mu, verdict, critical, leaving", [
    ([0.5, -0.2], "stable", "fold", ()),
    ([-1.3, 0.5], "unstable", "period doubling", ("period doubling",)),
    ([1.1 * np.exp(0.4j), 1.1 * np.exp(-0.4j), 1.05], "unstable", "Neimark-Sacker",
     ("Neimark-Sacker", "fold")),
    ([1.0, 0.3], "marginal", "fold", ())])
def test_classify(mu, verdict, critical, leaving):
    assert fq.classify(mu) == (verdict, critical, leaving)


@pytest.mark.parametrize("kwargs, match", [
    (dict(Omega=-1.0), "Omega must be a positive"),
    (dict(x0=np.zeros(3)), "x0 must have 2 entries"),
    (dict(states0=[7]), "states0 must hold element states"),
    (dict(system="ex1"), "system must be a pipeline.model.system.System")])
def test_misuse_raises(kwargs, match):
    args = dict(system=example1(1.0), Omega=200.0, x0=np.zeros(2), w0=[0.0], states0=[1])
    with pytest.raises(ValueError, match=match):
        fq.monodromy(**(args | kwargs))


# ------------------------------------------------------------------ 3-DOF blade, H = 10 HBM


@pytest.fixture(scope="module")
def blade_points():
    """HBM (H = 10, exact forces) at each frequency, Newton from the nearest branch point."""
    s = blade3()
    br = frequency_response(s, 10, 112.5, 121.5, stability=False, dense_output=False)
    assert br.success
    prob = hbm.setup(s, 10)
    out = {}
    for Om in BLADE_STABLE + BLADE_UNSTABLE:
        i = int(np.argmin(np.abs(br.omega - Om)))
        nr = newton(lambda x: hbm.residual(prob, x, Om)[:2], br.Q[i][prob.c].ravel(),
                    1e-9 * hbm.force_scale(prob), max_iter=40)
        assert nr.success
        out[Om] = hbm.recover(prob, nr.x.reshape(prob.c.size, prob.nh), Om)
    return s, out


def perturbed_run(s, r, rel, periods):
    """Distances |z_k - z*| / |z*| of the orbit's start perturbed by rel along the
    dominant eigenvector, over `periods` periods, and its components along it."""
    mdl = PiecewiseModel(s, r.Omega)
    kept = list(r.stuck_sliders)
    z0 = np.concatenate([r.x0, r.w0[kept]])
    lam, V = np.linalg.eig(r.monodromy)
    v = V[:, 0].real / np.linalg.norm(V[:, 0].real)
    left = np.linalg.inv(V)[0].real
    z, dist, along = z0 + rel * np.linalg.norm(z0) * v, [], []
    for _ in range(periods):
        z = fq.period_map(mdl, z, r.w0, r.states0, kept)
        dist.append(np.linalg.norm(z - z0) / np.linalg.norm(z0))
        along.append(left @ (z - z0))
    return np.array(dist), np.array(along)


@pytest.mark.parametrize("Om", BLADE_STABLE)
def test_blade_stable_where_time_integration_settles(blade_points, Om):
    s, pts = blade_points
    r = fq.from_hbm(s, Om, pts[Om])
    assert r.orbit_converged and r.verdict == "stable", (r.multipliers, r.message)
    assert 0.8 < r.max_modulus < 0.95
    dist, _ = perturbed_run(s, r, 1e-3, 100)
    assert dist[-1] < 1e-2 * dist[0]                  # the orbit attracts its neighbours


@pytest.mark.parametrize("Om", BLADE_UNSTABLE)
def test_blade_unstable_by_period_doubling(blade_points, Om):
    """The orbit exists (shooting converges) but a real multiplier is below -1: a
    perturbation grows and flips sign every period."""
    s, pts = blade_points
    r = fq.from_hbm(s, Om, pts[Om])
    assert r.orbit_converged and r.verdict == "unstable"
    assert r.leaving == ("period doubling",) and r.multipliers[0].real < -1.3
    dist, along = perturbed_run(s, r, 1e-9, 12)
    assert dist[-1] > 30 * dist[0]
    assert np.all(np.sign(along[1:]) == -np.sign(along[:-1]))
