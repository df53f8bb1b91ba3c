"""Yang-Menq element: exact vs AFT, Jacobians vs finite differences, closed forms."""
import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from pipeline.contact import NSLIP, PSLIP, SEP, STICK, YangMenq, forces
from pipeline.contact.exact import history

from helpers import one

TWO_PI = 2 * np.pi


def random_case(seed, E=240, H=5):
    """Motions with decaying harmonics and parameters spanning every regime."""
    rng = np.random.default_rng(seed)
    dec = np.repeat(1.0 / np.arange(1, H + 1) ** 2, 2)
    U = np.zeros((E, 2 * H + 1))
    V = np.zeros((E, 2 * H + 1))
    U[:, 1:] = rng.normal(size=(E, 2 * H)) * dec * rng.uniform(0.05, 3, (E, 1))
    V[:, 1:] = rng.normal(size=(E, 2 * H)) * dec * rng.uniform(0, 2, (E, 1))
    U[:, 0] = rng.normal(size=E) * 0.3
    V[:, 0] = rng.normal(size=E) * 0.3
    kv = rng.uniform(0.2, 2, E) * (rng.random(E) > 0.2)  # 20 % Jenkins (kv = 0)
    el = YangMenq(ku=rng.uniform(0.5, 2, E), kv=kv, mu=rng.uniform(0.1, 0.6, E),
                  n0=rng.normal(0.5, 1.5, E))
    return U, V, el


def mu_nmax(U, V, el):
    tau = np.linspace(0, TWO_PI, 4001)
    from pipeline.fourier.harmonics import basis
    n = el.n0[:, None] + el.kv[:, None] * (V @ basis(tau, (U.shape[1] - 1) // 2).T)
    return el.mu * np.maximum(n.max(1), 1e-12), np.maximum(n.max(1), 1e-12)


def test_random_cases_cover_every_regime():
    U, V, el = random_case(0)
    f = forces(U, V, el, jacobian=False)
    assert f.regimes["separated"] > 10 and f.regimes["stuck"] >= 3 and f.regimes["transitions"] > 100
    tau = np.linspace(0, TWO_PI, 400)
    states = history(U, V, el, tau)["state"]
    for s in (SEP, STICK, PSLIP, NSLIP):
        assert (states == s).any(axis=1).sum() > 10


def test_exact_matches_aft_at_2_pow_14_and_aft_error_falls():
    U, V, el = random_case(1)
    ex = forces(U, V, el, "exact", jacobian=False)
    su, sv = mu_nmax(U, V, el)
    errs = []
    for N in (256, 1024, 4096, 2**14):
        af = forces(U, V, el, "aft", n_samples=N, jacobian=False)
        eu = np.max(np.abs(af.Fu - ex.Fu), 1) / su
        ev = np.max(np.abs(af.Fv - ex.Fv), 1) / sv
        errs.append(max(eu.max(), ev.max()))
    assert errs[-1] < 1e-4
    assert all(e2 < e1 for e1, e2 in zip(errs, errs[1:])), errs


@settings(max_examples=20, deadline=None)
@given(A=st.floats(0.01, 5), B=st.floats(0, 3), ph=st.floats(0, TWO_PI),
       a2=st.floats(-0.5, 0.5), n0=st.floats(-2, 4), kv=st.sampled_from([0.0, 0.3, 1.0, 3.0]),
       mu=st.floats(0.05, 1.0), ku=st.floats(0.2, 5))
# in contact at the reversals with a normal load of about 3e-7 N under a 3 m motion, the
# contact opening elsewhere: stick arcs of about 1e-4 rad, under one sample
@example(A=3.0, B=1e-6, ph=0.0, a2=0.1875, n0=0.0, kv=0.3, mu=0.5, ku=4.0)
def test_exact_matches_aft_hypothesis(A, B, ph, a2, n0, kv, mu, ku):
    H = 3
    U = np.zeros((1, 2 * H + 1)); V = np.zeros((1, 2 * H + 1))
    U[0, 1], U[0, 4] = A, a2 * A
    V[0, 1], V[0, 2], V[0, 3] = B * np.cos(ph), B * np.sin(ph), 0.2 * B
    el = YangMenq(ku=ku, kv=kv, mu=mu, n0=n0)
    N = 2**14
    ex = forces(U, V, el, jacobian=False)
    af = forces(U, V, el, "aft", n_samples=N, jacobian=False)
    su, sv = mu_nmax(U, V, el)
    # AFT is second order while the stick arcs span samples; a stick arc after a
    # reversal lasts about 2 sqrt(2 mu n / (ku A)) rad, and when that is under four
    # samples (a tiny preload under a large motion: n0 = 1e-6 N, A = 3 m) the force's
    # jumps of 2 mu n fall between samples, an error up to 2 x (2 mu n / pi) dtau per
    # coefficient, first order (measured 1.2e-4 of mu n at N = 2^14 there).  The arc is
    # set by the normal load n_r at the reversals of u (a reversal while open: no arc,
    # no jump; touchdowns: no jump); the contact may open elsewhere in the period
    tau = np.linspace(0, TWO_PI, 4001)
    from pipeline.fourier.harmonics import basis
    n = el.n0[0] + el.kv[0] * (V[0] @ basis(tau, H).T)
    du = np.diff(U[0] @ basis(tau, H).T)
    n_r = n[1:-1][np.sign(du[1:]) != np.sign(du[:-1])]
    n_r = n_r[n_r > 0]
    arc = 2 * np.sqrt(2 * mu * n_r.min() / (ku * A)) if n_r.size else np.inf
    rel = 1e-4 if arc > 4 * TWO_PI / N else 1e-4 + 8 / N
    assert np.max(np.abs(af.Fu - ex.Fu)) <= rel * su[0] + 1e-12
    assert np.max(np.abs(af.Fv - ex.Fv)) <= 1e-4 * sv[0] + 1e-12


def fd_jacobian_error(U, V, el, method, h=1e-6, **kw):
    f = forces(U, V, el, method, **kw)
    worst = np.zeros(len(U))
    for which in ("U", "V"):
        for c in range(U.shape[1]):
            d = np.zeros_like(U); d[:, c] = h
            args_p = (U + d, V) if which == "U" else (U, V + d)
            args_m = (U - d, V) if which == "U" else (U, V - d)
            fp = forces(*args_p, el, method, jacobian=False, **kw)
            fm = forces(*args_m, el, method, jacobian=False, **kw)
            Ju = (f.dFu_dU if which == "U" else f.dFu_dV)[:, :, c]
            Jv = np.zeros_like(Ju) if which == "U" else f.dFv_dV[:, :, c]
            for num, J in (((fp.Fu - fm.Fu) / (2 * h), Ju), ((fp.Fv - fm.Fv) / (2 * h), Jv)):
                worst = np.maximum(worst, np.max(np.abs(num - J), 1) / np.maximum(np.max(np.abs(J), 1), 1.0))
    return worst


@pytest.mark.parametrize("method,kw", [("exact", {}), ("aft", {"n_samples": 512})])
def test_jacobian_matches_central_differences(method, kw):
    U, V, el = random_case(2, E=120)
    err = fd_jacobian_error(U, V, el, method, **kw)
    # away from degenerate transitions: all but a handful of random elements; the
    # FD error itself is ~1e-10 here, so 1e-6 leaves room only for genuine kinks
    assert np.mean(err < 1e-6) >= 0.97, np.sort(err)[-5:]
    assert np.median(err) < 1e-8


def jenkins_describing_function(A, ku, fs):
    """First-harmonic coefficients (a1 cos, b1 sin) of the Jenkins force under
    u = A cos(tau): derived by hand from the stick/slip phases (closed form)."""
    if ku * A <= fs:
        return ku * A, 0.0
    t1 = 2 * np.arcsin(np.sqrt(fs / (ku * A)))  # 1 - cos t1 = 2 fs / (ku A), stably
    a1 = 2 / np.pi * (ku * A * (t1 / 2 + np.sin(2 * t1) / 4) + (2 * fs - ku * A) * np.sin(t1))
    b1 = -4 * fs / np.pi * (1 - fs / (ku * A))
    return a1, b1


@pytest.mark.parametrize("A", [0.05, 0.2, 0.2000001, 0.5, 1.0, 7.3, 100.0])
def test_jenkins_describing_function_and_energy(A):
    ku, mu, n = 10.0, 0.5, 4.0  # slip starts at A = mu n / ku = 0.2
    fs = mu * n
    H = 7
    U = np.zeros((1, 2 * H + 1)); U[0, 1] = A
    el = YangMenq(ku=ku, kv=0.0, mu=mu, n0=n)
    f = forces(U, np.zeros_like(U), el)
    a1, b1 = jenkins_describing_function(A, ku, fs)
    assert f.Fu[0, 1] == pytest.approx(a1, rel=1e-10, abs=1e-12 * fs)
    assert f.Fu[0, 2] == pytest.approx(b1, rel=1e-10, abs=1e-12 * fs)
    # equivalent stiffness and damping of the describing function
    k_eq, c_eq_omega = a1 / A, -b1 / A
    assert f.Fu[0, 1] / A == pytest.approx(k_eq, rel=1e-10)
    assert -f.Fu[0, 2] / A == pytest.approx(c_eq_omega, rel=1e-10, abs=1e-14)
    W = dissipated_energy(U, f.Fu)[0]
    W_ref = 4 * fs * (A - fs / ku) if A > fs / ku else 0.0
    assert W == pytest.approx(W_ref, rel=1e-10, abs=1e-12)


def dissipated_energy(U, Fu):
    """Closed contour integral of f_u du over one period from the coefficients."""
    H = (U.shape[1] - 1) // 2
    k = np.arange(1, H + 1)
    return np.pi * np.sum(k * (Fu[:, 1::2] * U[:, 2::2] - Fu[:, 2::2] * U[:, 1::2]), axis=1)


def test_dissipation_nonnegative_and_normal_force_conservative():
    for seed in range(3):
        U, V, el = random_case(10 + seed)
        f = forces(U, V, el, jacobian=False)
        W = dissipated_energy(U, f.Fu)
        su, _ = mu_nmax(U, V, el)
        assert np.all(W >= -1e-12 * su * np.abs(U).sum(1))
        # the unilateral normal spring stores and returns energy: closed integral 0
        Wv = dissipated_energy(V, f.Fv)
        assert np.all(np.abs(Wv) <= 1e-10 * (1 + np.abs(f.Fv).sum(1) * np.abs(V).sum(1)))


def test_full_stick_is_linear_with_documented_slider_convention():
    # asymmetric motion (cos + sin 2 tau) and variable normal load, fully stuck
    U, V = one(U1=(0.01, 0.0, 0.0, 0.005), V1=(0.01,), U0=0.3)
    el = YangMenq(ku=2.0, kv=1.0, mu=0.5, n0=10.0)
    f = forces(U, V, el)
    assert f.regimes == {"separated": 0, "stuck": 1, "transitions": 0, "frictionless": 0,
                         "normal_load_searched": 1}  # n varies: searched, no root
    # convention: w = middle of the admissible interval [max lo, min hi] (dense check)
    from pipeline.fourier.harmonics import basis
    tau = np.linspace(0, TWO_PI, 200_001)
    u, n = (U @ basis(tau, 3).T)[0], 10.0 + (V @ basis(tau, 3).T)[0]
    w = 0.5 * ((u - 0.25 * n).max() + (u + 0.25 * n).min())
    assert w != pytest.approx(0.3, abs=1e-4)  # differs from the cycle mean here
    expect = 2.0 * U[0].copy()
    expect[0] = 2.0 * (0.3 - w)
    np.testing.assert_allclose(f.Fu[0], expect, atol=1e-9)
    np.testing.assert_allclose(f.dFu_dU[0][1:], 2.0 * np.eye(7)[1:], atol=1e-14)
    # the DC row: w depends on the motion through max lo and min hi (central FD)
    h = 1e-7
    fd = [(forces(U + h * e, V, el, jacobian=False).Fu[0, 0]
           - forces(U - h * e, V, el, jacobian=False).Fu[0, 0]) / (2 * h) for e in np.eye(7)[:, None]]
    np.testing.assert_allclose(f.dFu_dU[0][0], fd, atol=1e-7)
    # the same cycle with the slider fixed at 0.295 m: a parameter, not an accident
    f2 = forces(U, V, YangMenq(2.0, 1.0, 0.5, 10.0, slider_rest=0.295))
    assert f2.Fu[0, 0] == pytest.approx(2.0 * (0.3 - 0.295), rel=1e-13)
    np.testing.assert_allclose(f2.Fu[0, 1:], expect[1:], atol=1e-14)
    af = forces(U, V, el, "aft", n_samples=64)
    np.testing.assert_allclose(af.Fu[0, 1:], f.Fu[0, 1:], atol=1e-13)
    assert af.Fu[0, 0] == pytest.approx(f.Fu[0, 0], abs=1e-5)  # sampled extremes
    assert dissipated_energy(U, f.Fu)[0] == pytest.approx(0.0, abs=1e-15)


def test_stuck_convention_is_continuous_where_slip_starts():
    # grow the amplitude through the onset of slip: forces continuous, no jump in DC
    el = YangMenq(ku=1.0, kv=0.5, mu=0.3, n0=1.0)
    vals = []
    A_onset = None
    for A in np.linspace(0.2, 0.4, 201):
        U, V = one(U1=(A, 0.0, 0.0, 0.4 * A), V1=(0.3 * A,))
        f = forces(U, V, el, jacobian=False)
        if A_onset is None and f.regimes["transitions"]:
            A_onset = A
        vals.append(f.Fu[0])
    vals = np.array(vals)
    assert A_onset is not None and 0.2 < A_onset < 0.4
    assert np.max(np.abs(np.diff(vals, axis=0))) < 5e-3  # steps of 1e-3 in A, Lipschitz


def test_full_separation_is_zero():
    U, V = one(U1=(1.0, 0.5), V1=(0.3, 0.2))
    f = forces(U, V, YangMenq(ku=1.0, kv=1.0, mu=0.4, n0=-5.0))
    assert f.regimes["separated"] == 1
    assert np.all(f.Fu == 0) and np.all(f.Fv == 0) and np.all(f.dFu_dU == 0)


def test_gap_that_closes_normal_force_closed_form():
    # n = -0.5 + cos(tau): contact on |tau| < pi/3
    U, V = one(V1=(1.0,), H=4)
    el = YangMenq(ku=1.0, kv=1.0, mu=0.0, n0=-0.5)
    f = forces(U, V, el)
    t = np.pi / 3
    F0 = (np.sin(t) - 0.5 * t) / np.pi
    F1 = (t + 0.5 * np.sin(2 * t) - 2 * 0.5 * np.sin(t)) / np.pi
    assert f.Fv[0, 0] == pytest.approx(F0, rel=1e-13)
    assert f.Fv[0, 1] == pytest.approx(F1, rel=1e-13)
    assert np.all(f.Fu == 0)


def test_gap_closes_with_friction_touchdown_unstrained():
    U, V = one(U1=(0.0, 1.0), V1=(1.0,))
    el = YangMenq(ku=1.0, kv=1.0, mu=0.4, n0=-0.5)
    # u = sin(tau), n = -0.5 + cos(tau): lift-off at +pi/3, touchdown at -pi/3
    h = history(U, V, el, np.array([np.pi / 3 + 1e-9]))
    assert h["state"][0, 0] == SEP
    hist = history(U, V, el, np.linspace(0, TWO_PI, 1000))
    seq = [s for _, _, s in hist["transitions"][0]]
    assert SEP in seq and (STICK in seq or PSLIP in seq or NSLIP in seq)
    # touchdown at tau = -pi/3: the spring is unstrained there, f_u starts from 0
    h = history(U, V, el, np.array([TWO_PI - np.pi / 3 + 1e-7]))
    assert abs(h["fu"][0, 0]) < 1e-6
    ex = forces(U, V, el, jacobian=False)
    af = forces(U, V, el, "aft", n_samples=2**14, jacobian=False)
    assert np.max(np.abs(ex.Fu - af.Fu)) < 1e-4 * 0.4 * 0.5


@pytest.mark.parametrize("eps", [0.0, 1e-12, -1e-12])
def test_grazing_normal_load_touches_zero(eps):
    # n = 1 + eps - cos(tau) touches 0 at tau = 0 (eps = 0), barely separates or not
    U, V = one(U1=(0.5, 0.3), V1=(-1.0,))
    el = YangMenq(ku=1.0, kv=1.0, mu=0.4, n0=1.0 + eps)
    ex = forces(U, V, el)
    assert np.all(np.isfinite(ex.Fu)) and np.all(np.isfinite(ex.dFu_dU))
    af = forces(U, V, el, "aft", n_samples=2**14, jacobian=False)
    assert np.max(np.abs(ex.Fu - af.Fu)) < 1e-4 * 0.4 * 2
    ref = forces(U, V, YangMenq(ku=1.0, kv=1.0, mu=0.4, n0=1.0), jacobian=False)
    assert np.max(np.abs(ex.Fu - ref.Fu)) < 1e-9  # continuous through grazing


@pytest.mark.parametrize("ku", [1e2, 1e4, 1e6, 1e8])
def test_stiff_tangential_spring_and_coulomb_limit(ku):
    # Jenkins under u = cos(tau) against the closed form; rounding in the stick
    # force grows with the conditioning c = ku A / (mu n) (see pipeline/contact/README.md: limits)
    U, V = one(U1=(1.0,), H=5)
    fs = 0.3 * 2.0
    f = forces(U, V, YangMenq(ku=ku, kv=0.0, mu=0.3, n0=2.0))
    a1, b1 = jenkins_describing_function(1.0, ku, fs)
    cond = ku / fs
    assert f.Fu[0, 1] == pytest.approx(a1, rel=1e-10, abs=100 * np.finfo(float).eps * cond * fs)
    assert f.Fu[0, 2] == pytest.approx(b1, rel=max(1e-12, 100 * np.finfo(float).eps * cond))
    assert f.Fu[0, 3] == pytest.approx(0.0, abs=100 * np.finfo(float).eps * cond * fs)  # half-wave
    if ku >= 1e8:  # full slip: f_u -> mu n sign(u'), harmonics -4 mu n / (k pi)
        assert f.Fu[0, 2] == pytest.approx(-4 * fs / np.pi, rel=1e-7)
        assert f.Fu[0, 6] == pytest.approx(-4 * fs / (3 * np.pi), rel=1e-6)


def jenkins_harmonics_macroslip(A, ku, fs, H):
    """All coefficients of the Jenkins force under u = A cos(tau), ku A > fs, without
    cancellation: by half-wave symmetry only odd harmonics, 2/pi int_0^pi f s_k, with
    stick f = fs - 2 ku A sin^2(tau/2) on [0, t1] (Gauss-Legendre, no differences of
    nearly equal terms), f = -fs on [t1, pi], sin^2(t1/2) = fs/(ku A)."""
    t1 = 2 * np.arcsin(np.sqrt(fs / (ku * A)))
    x, wq = np.polynomial.legendre.leggauss(30)
    t = 0.5 * t1 * (x + 1)
    stick = -2 * np.sin(t / 2) ** 2
    F = np.zeros(2 * H + 1)
    for k in range(1, H + 1, 2):
        qc = 0.5 * t1 * np.sum(wq * stick * np.cos(k * t))
        qs = 0.5 * t1 * np.sum(wq * stick * np.sin(k * t))
        F[2 * k - 1] = 2 / np.pi * (ku * A * qc + 2 * fs * np.sin(k * t1) / k)
        F[2 * k] = 2 / np.pi * (ku * A * qs - 2 * fs * np.cos(k * t1) / k)
    return F


@pytest.mark.parametrize("ratio", [1e2, 3e12, 3e14])
def test_extreme_stiffness_ratio_short_stick_arc(ratio):
    # ku A/(mu n) = ratio: the stick arc is ~ 2/sqrt(ratio) rad long and the force is
    # nearly a square wave of amplitude mu n; its integrals must not lose the arc
    H, A, mu, n = 5, 1.0, 0.3, 2.0
    fs = mu * n
    ku = ratio * fs / A
    U, V = one(U1=(A,), H=H)
    f = forces(U, V, YangMenq(ku=ku, kv=0.0, mu=mu, n0=n), jacobian=False)
    np.testing.assert_allclose(f.Fu[0], jenkins_harmonics_macroslip(A, ku, fs, H),
                               rtol=0, atol=1e-8 * fs)


def test_zero_motion_and_zero_friction():
    U, V = one(U0=0.2)
    f = forces(U, V, YangMenq(ku=1.0, kv=1.0, mu=0.4, n0=3.0))
    np.testing.assert_allclose(f.Fu, 0.0, atol=1e-15)
    assert f.Fv[0, 0] == pytest.approx(3.0) and np.all(f.Fv[0, 1:] == 0)
    U, V = one(U1=(1.0, 0.2), V1=(0.5,))
    f = forces(U, V, YangMenq(ku=1.0, kv=1.0, mu=0.0, n0=1.0))
    assert np.all(f.Fu == 0) and np.all(f.dFu_dU == 0) and f.regimes["frictionless"] == 1
    assert f.Fv[0, 0] == pytest.approx(1.0) and f.Fv[0, 1] == pytest.approx(0.5)


def test_kv_zero_is_jenkins_with_constant_normal_load():
    U, V = one(U1=(1.0, 0.4, 0.1), V1=(5.0, 3.0))  # v is irrelevant when kv = 0
    el = YangMenq(ku=3.0, kv=0.0, mu=0.5, n0=1.0)
    f = forces(U, V, el)
    f0 = forces(U, np.zeros_like(V), el)
    np.testing.assert_allclose(f.Fu, f0.Fu, atol=1e-15)
    np.testing.assert_allclose(f.Fv, [[1.0, 0, 0, 0, 0, 0, 0]], atol=1e-15)
    assert np.all(f.dFu_dV == 0)


def test_many_harmonics_vectorised():
    U, V, el = random_case(5, E=40, H=50)
    f = forces(U, V, el)
    assert f.Fu.shape == (40, 101) and f.dFu_dU.shape == (40, 101, 101)
    af = forces(U, V, el, "aft", n_samples=2**14, jacobian=False)
    su, sv = mu_nmax(U, V, el)
    assert np.max(np.max(np.abs(af.Fu - f.Fu), 1) / su) < 1e-4


@pytest.mark.parametrize("kw,match", [
    (dict(ku=-1.0, kv=1.0, mu=0.3, n0=1.0), "ku"),
    (dict(ku=1.0, kv=-1.0, mu=0.3, n0=1.0), "kv"),
    (dict(ku=1.0, kv=1.0, mu=-0.3, n0=1.0), "mu"),
    (dict(ku=1.0, kv=1.0, mu=0.3, n0=np.nan), "n0"),
    (dict(ku=[1.0, 2.0], kv=[1.0, 2.0, 3.0], mu=0.3, n0=1.0), "kv"),
])
def test_bad_parameters_raise_valueerror_naming_them(kw, match):
    with pytest.raises(ValueError, match=match):
        YangMenq(**kw)


def test_bad_coefficients_raise_valueerror_naming_them():
    el = YangMenq(1.0, 1.0, 0.3, 1.0)
    U, V = one()
    with pytest.raises(ValueError, match="U"):
        forces(np.zeros((1, 6)), V, el)
    with pytest.raises(ValueError, match="V"):
        forces(U, np.full_like(V, np.nan), el)
    with pytest.raises(ValueError, match="U"):
        forces(np.zeros((2, 7)), np.zeros((2, 7)), el)
    with pytest.raises(ValueError, match="method"):
        forces(U, V, el, method="spline")
