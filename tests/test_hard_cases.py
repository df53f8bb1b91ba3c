"""Hard numerical cases stay stable (issue 6): each asserts numbers, not just "no exception".

Every curve must reach its end (success), have every point's recomputed residual
within tolerance, contain no NaN/Inf, stay within the Newton and residual-evaluation
budgets, and never fall to the continuation's minimum step.
"""
from dataclasses import replace

import numpy as np
import pytest

from pipeline.contact import YangMenq
from pipeline.response import frequency_response
from pipeline.system import System
from paper_systems import example1, example3

DS_MIN = 1e-6  # continuation default


def sound(c, max_nfev_per_point=6.0, max_peak_nfev=200):
    """The common budget and health checks of a response curve: residual
    evaluations per continuation point, and for locating the exact peaks."""
    assert c.success, c.message
    assert c.converged.all() and np.all(c.residual <= c.tolerance)
    for a in (c.omega, c.amplitude, c.Q, c.residual):
        assert np.all(np.isfinite(a))
    peak = c.info["peak_nfev"]
    assert (c.nfev - peak) / c.n_points <= max_nfev_per_point, (c.nfev - peak) / c.n_points
    assert peak <= max_peak_nfev * c.Q.shape[1]
    nit = c.newton_iterations[c.newton_iterations > 0]
    assert nit.size == 0 or np.mean(nit) <= 5
    assert c.info["min_step"] > 10 * DS_MIN, c.info["min_step"]


def linear_amp(system, Om, h=1, dof=0, stiff=None):
    K = system.K + (stiff if stiff is not None else 0)
    X = np.linalg.solve(K - (h * Om) ** 2 * system.M + 1j * h * Om * system.C, system.forcing[:, h])
    return np.abs(X[dof])


@pytest.mark.parametrize("n0", [0.0, 1e-12, -1e-12])
def test_grazing_preload(n0):
    """n0 = 0 +- 1e-12 with a variable normal load: contact just touches; the
    three curves are the same curve (continuity through grazing)."""
    c = frequency_response(example3(n0), 7, 0.8, 1.3, stability=False)
    sound(c)
    ref = frequency_response(example3(0.0), 7, 0.8, 1.3, stability=False)
    assert c.peak(0)[0] == pytest.approx(ref.peak(0)[0], rel=1e-6)


def test_normal_load_that_just_touches_zero():
    """A static normal load balanced so that n touches zero once per cycle at the
    peak: n = n0 + kv v with n0 = kv * amplitude of v (found from a first solve)."""
    s = example3(5.0)
    c0 = frequency_response(s, 7, 1.0, 1.6, stability=False)
    sound(c0)
    # along the branch, min_t n(t) crosses zero somewhere: the curve passes grazing
    from pipeline.harmonics import basis
    tau = np.linspace(0, 2 * np.pi, 721)
    nmin = [(5.0 + (s.Bn @ Q) @ basis(tau, 7).T).min() for Q in c0.Q]
    assert min(nmin) < 0 < max(nmin)


@pytest.mark.parametrize("k", [1e-3, 1e-1, 10.0, 1e4])
def test_contact_stiffness_ratio_from_1e_3_to_1e4(k):
    """ku = kv = k relative to modal stiffnesses 1 and 100: the stuck limit equals
    the linear system with the springs added, whatever the stiffness."""
    # preload that keeps the contact stuck (mu n0 well above ku * |u|); not more:
    # rounding in the stick force grows like eps * mu n0 / (ku |u|)
    n0 = max(100.0, 1e3 * k)
    s = replace(example3(n0), contact=YangMenq(k, k, 0.4, n0))
    c = frequency_response(s, 5, 0.5, 1.6, stability=False)
    sound(c)
    ref = [linear_amp(s, om, stiff=np.diag([k, k])) for om in c.omega]
    np.testing.assert_allclose(c.amplitude[:, 0], ref, rtol=1e-7)


@pytest.mark.parametrize("k", [1e-3, 1e-1, 1.0])
def test_stick_slip_separation_with_soft_contact(k):
    """The mixed regime (n0 = 10, stick, slip and separation) for soft contact.

    Stiff impact in this regime (kv/k >= 10 against modal stiffnesses 1 and 100)
    is not yet robust: at kv = 10 the continuation needs steps near its minimum,
    at kv = 1000 the first point fails (a cascade of folds at 1 % of the load in
    the load homotopy).  Listed as open in the README; the stiff *stuck* contact
    up to 1e4 is covered above."""
    s = replace(example3(10.0), contact=YangMenq(k, k, 0.4, 10.0))
    c = frequency_response(s, 14, 0.5, 1.6, stability=False)
    sound(c, max_nfev_per_point=8.0)


def test_tiny_damping_at_resonance_and_zero_damping_away():
    s0 = example1(0.0)
    k, m = 3.55e4, 1.0
    zeta = 1e-4
    s = replace(s0, C=np.array([[2 * zeta * np.sqrt(k * m)]]))
    c = frequency_response(s, 3, 185, 192, stability=False)
    sound(c)
    assert c.peak(0)[0] == pytest.approx(1 / (2 * zeta * np.sqrt(1 - zeta**2) * k), rel=1e-6)
    s = replace(s0, C=np.array([[0.0]]))
    c = frequency_response(s, 3, 100, 150, stability=True)
    sound(c)
    np.testing.assert_allclose(c.amplitude[:, 0], [linear_amp(s, om) for om in c.omega], rtol=1e-8)


def test_zero_normal_load_full_slip_and_zero_friction():
    # Jenkins with n = 0: no tangential stiffness left; equals (m, c, k)
    c = frequency_response(example1(0.0), 7, 150, 250, stability=False)
    sound(c)
    np.testing.assert_allclose(c.amplitude[:, 0], [linear_amp(example1(0.0), om) for om in c.omega],
                               rtol=1e-8)
    # mu = 0 with a variable normal load: no tangential force at all, so the
    # response equals that of the same system with ku = 0
    s = replace(example3(10.0), contact=YangMenq(1.0, 1.0, 0.0, 10.0))
    s2 = replace(example3(10.0), contact=YangMenq(0.0, 1.0, 0.3, 10.0))
    c, c2 = (frequency_response(x, 7, 0.5, 1.6, stability=False) for x in (s, s2))
    sound(c)
    sound(c2)
    assert c.peak(0)[0] == pytest.approx(c2.peak(0)[0], rel=1e-9)


def test_zero_excitation_gives_the_static_state():
    s = replace(example3(10.0), forcing=np.zeros((2, 2), complex))
    c = frequency_response(s, 5, 0.5, 1.6, stability=False)
    sound(c)
    assert np.all(c.amplitude < 1e-12)
    # static: K q + f_v(n0) = 0 with the contact closed, identical at every frequency
    np.testing.assert_allclose(c.Q[:, :, 0], c.Q[:1, :, 0].repeat(c.n_points, 0), atol=1e-12)


def test_excitation_at_harmonic_two_only():
    s = replace(example1(0.0), forcing=np.array([[0, 0, 1.0]]))
    c = frequency_response(s, 3, 80, 110, stability=False)
    sound(c)
    np.testing.assert_allclose(c.Q[:, 0, 3] - 1j * c.Q[:, 0, 4],
                               [np.linalg.solve(s.K - (2 * om) ** 2 * s.M + 2j * om * s.C, [1.0])[0]
                                for om in c.omega], rtol=1e-8)
    assert np.all(np.abs(c.Q[:, 0, 1:3]) < 1e-14)
    s = replace(example1(2.0), forcing=np.array([[0, 0, 1.0]]))
    sound(frequency_response(s, 5, 80, 110, stability=False))


@pytest.mark.parametrize("H", [1, 50])
def test_few_and_many_harmonics(H):
    c = frequency_response(example1(2.0), H, 185, 200, stability=H < 10)
    sound(c)
    ref = frequency_response(example1(2.0), 7, 185, 200, stability=False).peak(0)[0]
    # H = 1 is the describing-function answer (a few % off); H = 50 converged
    assert c.peak(0)[0] == pytest.approx(ref, rel=5e-2 if H == 1 else 1e-3)


@pytest.mark.parametrize("n0,kv", [(-20.0, 1.0), (10.0, 1.0), (-20.0, 10.0)])
def test_sharp_folds_in_both_sweep_directions(n0, kv):
    s = replace(example3(n0), contact=YangMenq(1.0, kv, 0.4, n0))
    up = frequency_response(s, 7, 0.5, 1.8, stability=True)
    down = frequency_response(s, 7, 1.8, 0.5, stability=True)
    for c in (up, down):
        sound(c)
        assert c.fold_parameter.size == 2
        assert (~c.stable).any()
    np.testing.assert_allclose(np.sort(up.fold_parameter), np.sort(down.fold_parameter), rtol=1e-6)
    assert up.peak(0)[0] == pytest.approx(down.peak(0)[0], rel=1e-6)


def test_range_spanning_several_modes():
    from paper_systems import example2
    c = frequency_response(example2(300.0), 5, 2 * np.pi * 5, 2 * np.pi * 80, stability=False)
    sound(c)
    om = c.omega / (2 * np.pi)
    a = c.amplitude[:, 0]
    assert a[(om > 15) & (om < 30)].max() > 3 * a[(om > 35) & (om < 45)].max()
    assert a[(om > 45) & (om < 65)].max() > 3 * a[(om > 35) & (om < 45)].max()
