"""Hard numerical cases stay stable: each asserts numbers, not just "no exception".

Every curve must reach its end (success), have every point's recomputed residual
within tolerance, contain no NaN/Inf, stay within the Newton and residual-evaluation
budgets, and never fall to the continuation's minimum step.
"""
from dataclasses import replace

import numpy as np
import pytest

from pipeline.contact import YangMenq
from pipeline.solve.harmonic_balance.hbm_state import state_at_zero
from pipeline.solve.response.response import frequency_response
from pipeline.paper_systems import example1, example3

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
    from pipeline.fourier.harmonics import basis
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

    Stiffer contact in this regime: test_stiff_impact_in_the_mixed_regime_kv10 and
    (slow) test_stiff_impact_full_range; the stiff *stuck* contact up to 1e4 is
    covered above."""
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
    from pipeline.paper_systems import example2
    c = frequency_response(example2(300.0), 5, 2 * np.pi * 5, 2 * np.pi * 80, stability=False)
    sound(c)
    om = c.omega / (2 * np.pi)
    a = c.amplitude[:, 0]
    assert a[(om > 15) & (om < 30)].max() > 3 * a[(om > 35) & (om < 45)].max()
    assert a[(om > 45) & (om < 65)].max() > 3 * a[(om > 35) & (om < 45)].max()


# ------------------------- stiff impacts, preload into full stick, starts between folds
def on_curve(c, ref, tol):
    """Largest distance of c's points from the polyline of ref, in the (Omega, amplitude)
    plane normalised by ref's ranges: 0 means every point lies on ref (no branch jump)."""
    sx, sy = np.ptp(ref.omega), np.ptp(ref.amplitude[:, 0])
    P = np.column_stack([c.omega / sx, c.amplitude[:, 0] / sy])
    A = np.column_stack([ref.omega / sx, ref.amplitude[:, 0] / sy])
    a, d = A[:-1], np.diff(A, axis=0)
    t = np.clip(np.einsum("pk,sk->ps", P, d) - np.einsum("sk,sk->s", a, d),
                0, None) / np.maximum(np.einsum("sk,sk->s", d, d), 1e-300)
    t = np.minimum(t, 1.0)
    dist = np.linalg.norm(P[:, None, :] - (a[None] + t[..., None] * d[None]), axis=2).min(1)
    return float(dist.max()) <= tol, float(dist.max())


def unstable_between_folds(c):
    """Hill: unstable exactly between the two turning points of Omega (the samples
    at the turning points themselves have an exponent ~ 0 and are not judged)."""
    dl = np.diff(c.parameter)
    turning = np.flatnonzero(dl[:-1] * dl[1:] < 0) + 1
    assert len(turning) == 2, turning
    inside = np.zeros(c.n_points, bool)
    inside[turning[0] + 1:turning[1]] = True
    outside = ~inside
    outside[turning] = False
    assert not c.stable[inside].any()
    assert c.stable[outside].all()


def stiff(k, n0=10.0):
    """Example 3 in the mixed regime with ku = kv = k (modal stiffnesses 1 and 100)."""
    return replace(example3(n0), contact=YangMenq(k, k, 0.4, n0))


def amplitude_at(s, H, Om, Q, method="exact", N=256):
    """Amplitude of DOF 0 from Newton at fixed Om with H harmonics (and the given
    force evaluation), started from the coefficients Q (zero-padded or cut)."""
    from pipeline.solve.harmonic_balance import hbm
    from pipeline.solve.continuation.newton import newton
    from pipeline.fourier.harmonics import amplitude_half_peak_to_peak
    p = hbm.setup(s, H, method, N)
    wts = hbm.row_weights(p, hbm.tolerances(p, 1e-10, s.contact))
    x0 = np.zeros((s.n_dof, 2 * H + 1))
    m = min(x0.shape[1], Q.shape[1])
    x0[:, :m] = Q[:, :m]

    def f(x):
        R, J, _ = hbm.residual(p, x, Om, s.contact)
        return wts * R, wts[:, None] * J
    r = newton(f, x0[p.c].ravel(), 1.0, max_iter=30)
    assert r.success, r.message
    return amplitude_half_peak_to_peak(hbm.recover(p, r.x.reshape(p.c.size, -1), Om))[0]


def time_integration(s, c, i, **kw):
    """Event-driven periodic solution (shooting) started from the HBM point i."""
    from pipeline.solve.time_integration import timesim
    q0, qd0, w0 = state_at_zero(s, c.Q[i], c.omega[i])
    return timesim.steady_state(s, c.omega[i], H=c.H, q0=q0, qd0=qd0, w0=w0,
                                transient_periods=0, **kw)


def test_stiff_impact_in_the_mixed_regime_kv10():
    """kv/k = ku/k = 10, n0 = 10 N: stick, slip and separation in one cycle.  The
    window holds the corner at 0.783 rad/s where steps used to fall to 1.4e-6 and
    four folds; checked against event-driven time integration, 2H and AFT.

    Measured: 117 points, 6.3 residual evaluations per point, smallest step 1.2e-3
    (the whole 0.5-1.6 range: test_stiff_impact_full_range).  H = 14 is within 1 %
    of the time integration; the error is truncation (H = 28: within 1e-4); AFT with
    4096 samples equals the exact forces to 4e-6."""
    from pipeline.contact.exact import history

    s = stiff(10.0)
    c = frequency_response(s, 14, 0.7, 1.2, stability=False, peak_dofs=[0])
    sound(c, max_nfev_per_point=7.5)
    assert c.info["min_step"] > 5e-4 and c.info["branch_points"] < 150  # continuation only
    assert c.fold_parameter.size == 4
    i = int(np.argmin(np.abs(c.omega - 0.75)))
    st = history(s.Bt @ c.Q[i], s.Bn @ c.Q[i], s.contact, np.linspace(0, 2 * np.pi, 721))["state"]
    assert {0, 1, 2, 3} <= set(np.unique(st))  # separation, stick, slip both ways
    for target in (0.75, 0.9, 1.17):
        i = int(np.argmin(np.abs(c.omega - target)))
        ts = time_integration(s, c, i)
        assert ts.converged and ts.stable
        assert c.amplitude[i, 0] == pytest.approx(ts.amplitude[0], rel=1e-2), target
        if target == 0.75:
            assert amplitude_at(s, 28, c.omega[i], c.Q[i]) == pytest.approx(ts.amplitude[0],
                                                                            rel=2e-4)
            assert amplitude_at(s, 14, c.omega[i], c.Q[i], "aft", 4096) == pytest.approx(
                c.amplitude[i, 0], rel=1e-5)


# (k, residual evaluations per point, smallest step, frequencies checked against time
# integration, their tolerance); measured: 5.8 / 11.2 / 6.8 / 8.0 per point,
# smallest steps 3.2e-3 / 9.0e-4 / 6.1e-6 / 1.1e-6
STIFF_CASES = [(10.0, 7.0, 1e-3, (0.5, 0.75, 1.17, 1.6), 1e-2),
               (100.0, 13.0, 1e-4, (1.12, 1.6), 1e-2),
               (1000.0, 12.0, 2e-6, (1.6,), 2e-2),
               (1e4, 10.0, 1e-6, (1.6,), 2e-2)]


def test_corner_after_a_bend_located_again_not_crept_to():
    """The stiff impact case at k = 10 (H = 14): at 0.783 rad/s a corrector from the
    higher-order start lands just before a corner that follows a tight bend, and the
    corner's first location overshoots (the point meant to lie before it has turned
    already).  Located once more between the last point and that one, it is passed at
    a step of 1.9e-3; halving instead crept to 2.6e-4 through seven rejections."""
    c = frequency_response(stiff(10.0), 14, 0.5, 1.6, stability=False, peak_dofs=[0],
                           dense_output=False)
    assert c.success and c.converged.all()
    assert c.info["min_step"] > 1e-3


@pytest.mark.slow
@pytest.mark.parametrize("k,nfev_pt,step,check,rtol", STIFF_CASES,
                         ids=[f"k={c[0]:g}" for c in STIFF_CASES])
def test_stiff_impact_full_range(k, nfev_pt, step, check, rtol):
    """The mixed regime over 0.5-1.6 rad/s for kv/k = ku/k = 10 ... 1e4 (H = 14).

    From k = 100 the first point at 0.5 rad/s needs the stiffness homotopy and lies
    on an arc that turns back below 0.5 (followed there through its fold).  From
    k = 1000 the period-1 orbit is unstable over much of the range (time integration
    settles on period-2 or chaotic motion), so it is checked against the unstable
    periodic orbit found by shooting, and H = 14 is a truncation within 2 % (H = 56
    agrees with shooting to 1e-4 at 1.6 rad/s); steps fall to ~1e-6 at the many
    small corners of the stiff branch (pipeline/solve/README.md, hard cases)."""
    s = stiff(k)
    c = frequency_response(s, 14, 0.5, 1.6, stability=False, peak_dofs=[0])
    assert c.success, c.message
    assert c.converged.all() and np.all(c.residual <= c.tolerance)
    for a in (c.omega, c.amplitude, c.Q, c.residual):
        assert np.all(np.isfinite(a))
    assert (c.nfev - c.info["peak_nfev"]) / c.n_points <= nfev_pt
    assert c.info["min_step"] > step
    for om in check:
        i = int(np.argmin(np.abs(c.omega - om)))
        ts = time_integration(s, c, i, accept_unstable=True)
        assert ts.converged, om
        assert c.amplitude[i, 0] == pytest.approx(ts.amplitude[0], rel=rtol), om


@pytest.mark.parametrize("start,end,max_points,max_rejected", [(0.5, 50.0, 55, 6),
                                                                (50.0, 0.5, 65, 14)])
def test_preload_continuation_into_full_stick(start, end, max_points, max_rejected):
    """Example 1 at 200 rad/s: the damper sticks fully from n* = ku A_stuck / mu =
    3.636 N on, where dF/dn0 jumps to zero (a corner of the branch).  The branch
    0.5 -> 50 N (and back) passes it in one corner step; every point equals a fixed-
    preload solve at the same (n0, Omega); above n* the response is the linear one
    of (m, c, k + ku).

    Measured: up 51 points, 3.2 residual evaluations per point, 5 rejected steps,
    smallest step 0.011; down 61 points, 4.3 per point, 13 rejected, smallest 3.1e-3
    (before the resonance guard, whose steps resolve the crossing of the linearised
    natural frequency through 200 rad/s near 2.6 N: 42 / 56 points, 1 / 10 rejected;
    before the corner steps: 51 / 67 points, 9 / 21 rejected, 6.4e-4 / 2.4e-5)."""
    from pipeline.solve.response.response import preload_response
    om = 200.0
    c = preload_response(example1(1.0), 7, om, start, end, stability=False)
    sound(c, max_nfev_per_point=5.0)
    assert c.n_points <= max_points and c.info["n_rejected"] <= max_rejected
    assert c.info["min_step"] > 1e-3
    assert c.parameter[0] == start and c.parameter[-1] == end
    assert np.all(np.diff(c.parameter) * np.sign(end - start) > 0)  # no turning back
    k, ku, mu, m, cc = 3.55e4, 1e4, 0.5, 1.0, 0.3
    a_stuck = 1 / abs(k + ku - m * om**2 + 1j * cc * om)
    n_star = ku * a_stuck / mu
    stuck = c.parameter >= n_star
    assert stuck.any() and (~stuck).any()
    np.testing.assert_allclose(c.amplitude[stuck, 0], a_stuck, rtol=1e-9)
    assert np.all(np.abs(c.amplitude[~stuck, 0] / a_stuck - 1) > 1e-5)  # slipping
    # the corner is resolved: the last slipping point lies within 1 % of n*
    assert np.any(np.abs(c.parameter[~stuck] / n_star - 1) < 0.01)
    # point-wise: the first point of a frequency response at fixed preload, i.e. a
    # direct Newton solve at (n0, Omega) from the linear guesses
    near = np.argsort(np.abs(c.parameter - n_star))[:3]
    for i in sorted(set(range(0, c.n_points, 4)) | set(near)):
        f = frequency_response(example1(c.parameter[i]), 7, om, om + 1.0, stability=False,
                               max_points=2, peak_dofs=[])
        assert f.omega[0] == om
        np.testing.assert_allclose(f.Q[0], c.Q[i], rtol=0, atol=1e-8 * np.abs(c.Q[i]).max())


@pytest.fixture(scope="module")
def ex3_sweeps():
    """Normal sweeps 0.5 -> 1.6 rad/s of Example 3 (H = 7), the references."""
    return {n0: frequency_response(example3(n0), 7, 0.5, 1.6, peak_dofs=[0])
            for n0 in (10.0, -20.0)}


# (n0, start, end, start on the middle branch?): Newton from the linear guesses lands
# on the lower (n0 = 10) or the open (n0 = -20) branch; the middle-branch starts are
# given as initial coefficients taken from the reference sweep
INSIDE = [(10.0, 1.26, 1.6, False), (10.0, 1.26, 0.5, True), (-20.0, 1.037, 0.5, False),
          (-20.0, 1.037, 1.6, True)]


@pytest.mark.parametrize("n0,om0,end,middle", INSIDE)
def test_start_between_the_folds(n0, om0, end, middle, ex3_sweeps):
    """A sweep that starts inside the fold region, also on the unstable middle branch:
    the branch is followed back past the start (through the fold there) and, from a
    middle-branch start, traced both ways from the first point, so the curve holds
    the whole S: both folds at the reference's frequencies, Hill unstable exactly
    between them, every point on the reference curve (no branch jump)."""
    ref = ex3_sweeps[n0]
    initial = None
    if middle:
        unstable = np.flatnonzero(~ref.stable)
        j = unstable[np.argmin(np.abs(ref.omega[unstable] - om0))]
        om0, initial = ref.omega[j], ref.Q[j]
    c = frequency_response(example3(n0), 7, om0, end, initial=initial)
    sound(c)
    i0 = int(np.argmin(np.abs(c.parameter - om0) + np.abs(c.amplitude[:, 0] - (
        ref.amplitude[j, 0] if middle else c.amplitude[0, 0]))))
    assert c.parameter[i0] == om0 and c.stable[i0] != middle  # the first point kept
    np.testing.assert_allclose(np.sort(c.fold_parameter), np.sort(ref.fold_parameter),
                               rtol=1e-7)
    unstable_between_folds(c)
    ok, dist = on_curve(c, ref, 1e-2)  # chords of the reference; the branches lie >= 0.1 apart
    assert ok, dist
    assert c.parameter[0] == end or c.parameter[-1] == end


@pytest.mark.parametrize("n0", [10.0, -20.0])
def test_reversed_sweep_equals_forward(n0, ex3_sweeps):
    """omega_start > omega_end: the same curve traced the other way, with the same
    folds and peak, Hill unstable exactly between the folds, every point of each
    curve on the other."""
    up = ex3_sweeps[n0]
    down = frequency_response(example3(n0), 7, 1.6, 0.5, peak_dofs=[0])
    sound(down)
    assert down.parameter[0] == 1.6 and down.parameter[-1] == 0.5
    np.testing.assert_allclose(np.sort(down.fold_parameter), np.sort(up.fold_parameter),
                               rtol=1e-7)
    assert down.peak(0)[0] == pytest.approx(up.peak(0)[0], rel=1e-7)
    assert down.peak(0)[1] == pytest.approx(up.peak(0)[1], rel=1e-5)
    unstable_between_folds(down)
    unstable_between_folds(up)
    for a, b in ((down, up), (up, down)):
        ok, dist = on_curve(a, b, 1e-2)  # measured <= 5.5e-3: chords of the other curve
        assert ok, dist


def test_first_point_homotopies_accept_on_the_roundoff_floor(monkeypatch):
    """Stiff impact (k = 100) at 0.5 rad/s: Newton from the linear guesses fails and
    the homotopies find the first point.  With a tolerance below what double precision
    resolves (1e-17 of the force scale), they accept on the residual's round-off floor
    as the continuation does, instead of failing the curve at its first point."""
    from pipeline.solve.response import response

    used = []
    for name in ("_cold_start", "_stiffness_start"):
        real = getattr(response, name)
        monkeypatch.setattr(response, name,
                            lambda *a, _real=real, _name=name: used.append(_name) or _real(*a))
    c = frequency_response(stiff(100.0), 8, 0.5, 0.505, stability=False, peak_dofs=[0],
                           dense_output=False, tol_rel=1e-17)
    assert used and c.converged[0] and c.n_points >= 2
    assert c.info["roundoff_points"] >= 1
