"""The 2D friction law (`contact.friction2d`): a Coulomb slider on the disc |f| <= mu n
with a variable normal load and separation, evaluated by AFT.

Checked against: the 1D Yang-Menq element (motion along one tangent: the 1D AFT sample
for sample, and the exact element with the convergence slope in the sample count);
the closed form of a circular orbit; an independent fine time stepping of elliptic
orbits (written here); central differences of the Jacobian in stick, slip, mixed and
separating cycles; the energy the harmonics dissipate against the loop integral of
the sampled time history."""
import numpy as np
import pytest

from pipeline.contact.aft import aft_forces, play_forces
from pipeline.contact.element import YangMenq
from pipeline.contact.exact import exact_forces
from pipeline.contact.friction2d.law import Friction2D
from pipeline.fourier.harmonics import time_grid

from helpers import law_jacobian_errors, plane_motion

KU, KV, MU = 1.0e4, 1.0e4, 0.5
H = 3
NH = 2 * H + 1


def collinear():
    """Motions along tangent 1 (3 elements: slipping, slipping with a varying normal
    load, separating) with their normal motion; tangent 2 constant."""
    X = np.zeros((3, 3, NH))
    X[:, 0, 1], X[:, 0, 2], X[:, 0, 3] = [1e-3, 1e-3, 3e-4], [2e-4, 0.0, 1e-4], 1e-4
    X[:, 1, 0] = 2e-5
    X[:, 2, 1], X[:, 2, 2] = [0.0, 5e-5, 2e-4], [0.0, 2e-5, 1e-4]
    return X, np.array([2.0, 1.0, 1.0])


def test_along_one_tangent_it_is_the_1d_element_sample_for_sample():
    """Against the 1D element's play operator (`aft.play_forces`, a separate march:
    clamps to the band, its own stuck rest); the 1D `aft_forces` is the compiled
    march itself for such elements, so it must equal the play operator too."""
    X, n0 = collinear()
    law = Friction2D(ku=KU, kv=KV, mu=MU, n0=n0)
    one = play_forces(X[:, 0], X[:, 2], YangMenq(ku=KU, kv=KV, mu=MU, n0=n0), 256, True)
    got = law.evaluate(X, n_samples=256)
    assert got.regimes["separating"] == 1
    scale = MU * n0.max()
    assert np.abs(got.F[:, 0] - one.Fu).max() < 1e-13 * scale
    assert np.abs(got.F[:, 2] - one.Fv).max() < 1e-13 * scale
    assert np.abs(got.F[:, 1]).max() == 0.0
    for p, ref in ((0, one.dFu_dU), (2, one.dFu_dV), (6, one.dFv_dV)):
        assert np.abs(got.J[:, p] - ref).max() < 1e-12 * KU
    fast = aft_forces(X[:, 0], X[:, 2], YangMenq(ku=KU, kv=KV, mu=MU, n0=n0), 256, True)
    for a, b in ((fast.Fu, one.Fu), (fast.Fv, one.Fv)):
        assert np.abs(a - b).max() < 1e-13 * scale
    for a, b in ((fast.dFu_dU, one.dFu_dU), (fast.dFu_dV, one.dFu_dV), (fast.dFv_dV, one.dFv_dV)):
        assert np.abs(a - b).max() < 1e-12 * KU


def test_along_one_tangent_it_converges_to_the_exact_element():
    """Force error ~ N^-2 (the sampled law misses each transition by less than a sample,
    where the force's slope jumps), Jacobian ~ N^-1 (the Jacobian itself jumps there):
    the fitted slopes over N = 128 ... 4096."""
    X, n0 = collinear()
    law = Friction2D(ku=KU, kv=KV, mu=MU, n0=n0)
    exact = exact_forces(X[:, 0], X[:, 2], YangMenq(ku=KU, kv=KV, mu=MU, n0=n0), True)
    Ns = np.array([128, 256, 512, 1024, 2048, 4096])
    ef, ej = [], []
    for N in Ns:
        got = law.evaluate(X, n_samples=int(N))
        ef.append(np.abs(got.F[:, 0] - exact.Fu).max() / (MU * n0.max()))
        ej.append(np.abs(got.J[:, 0] - exact.dFu_dU).max() / KU)
    slope_f = -np.polyfit(np.log(Ns), np.log(ef), 1)[0]
    slope_j = -np.polyfit(np.log(Ns), np.log(ej), 1)[0]
    assert slope_f > 1.6 and ef[-1] < 2e-6, (slope_f, ef)      # measured 1.9
    assert slope_j > 0.7 and ej[-1] < 2e-3, (slope_j, ej)      # measured 1.0


def circle(r, N, n0=2.0):
    law = Friction2D(ku=KU, kv=0.0, mu=MU, n0=n0)
    X = np.zeros((1, 3, 3))
    X[0, 0, 1], X[0, 1, 2] = r, r
    return law.evaluate(X, n_samples=N, jacobian=False), X


def dissipated(F, U):
    """pi sum_k k (F_ck U_sk - F_sk U_ck) over the tangents: the energy per cycle [J]."""
    H_ = (U.shape[-1] - 1) // 2
    k = np.arange(1, H_ + 1)
    return np.pi * sum(np.sum(k * (F[d, 1::2] * U[d, 2::2] - F[d, 2::2] * U[d, 1::2]))
                       for d in range(2))


def test_circular_orbit_closed_form():
    """r > a = mu n / ku: the slider on the circle sqrt(r^2 - a^2), |f| = mu n, energy
    2 pi mu n sqrt(r^2 - a^2) -- to 1e-6 at N = 2^21 samples (the sampled return mapping
    lags the slider by about a sample: first order, 1.6 r / N); r < a sticks."""
    n0 = 2.0
    a = MU * n0 / KU
    got, X = circle(2 * a, 2 ** 21)
    d = got.detail
    rho = np.sqrt((d.w[0] ** 2).sum(axis=0))
    ref = np.sqrt(3.0) * a
    assert np.abs(np.sqrt((d.f[0, :2] ** 2).sum(axis=0)) - MU * n0).max() < 1e-12 * MU * n0
    assert np.abs(rho - ref).max() < 1e-6 * 2 * a
    assert dissipated(got.F[0], X[0]) == pytest.approx(2 * np.pi * MU * n0 * ref, rel=1e-6)
    stuck, X = circle(0.9 * a, 256)
    assert stuck.regimes["stuck"] == 1 and abs(dissipated(stuck.F[0], X[0])) < 1e-18
    np.testing.assert_allclose(stuck.F[0, :2], KU * X[0, :2], atol=1e-15 * KU * a)


def reference_march(u, n, steps):
    """An independent time stepping of the law: u(t) (callable, (2,)), n(t), `steps` a
    period, marched until periodic; returns the Fourier coefficients (H = 3) of the
    tangential force by the trapezoid rule."""
    t = 2 * np.pi * np.arange(steps) / steps
    U, Nn = u(t), n(t)
    w = U[:, 0].copy()
    for _ in range(50):
        start = w.copy()
        f = np.empty((2, steps))
        for i in range(steps):
            if Nn[i] <= 0:
                w = U[:, i].copy()
                f[:, i] = 0.0
                continue
            trial = KU * (U[:, i] - w)
            size = np.hypot(*trial)
            if size > MU * Nn[i]:
                trial *= MU * Nn[i] / size
                w = U[:, i] - trial / KU
            f[:, i] = trial
        if np.abs(w - start).max() < 1e-15:
            break
    _, _, Wm = time_grid(H, steps)
    return f @ Wm.T


def test_elliptic_orbits_against_an_independent_fine_time_stepping():
    """Ellipses with a varying normal load (one separating): harmonics to 1e-5 of mu n
    against 1e5 steps a period (N = 2^17 samples here; both first order)."""
    X = np.zeros((2, 3, NH))
    X[:, 0, 1], X[:, 1, 2], X[:, 0, 3] = 8e-4, 3e-4, 1e-4
    X[:, 2, 1] = [5e-5, 2e-4]
    n0 = np.array([2.0, 1.0])
    law = Friction2D(ku=KU, kv=KV, mu=MU, n0=n0)
    got = law.evaluate(X, n_samples=2 ** 17, jacobian=False)
    assert got.regimes["separating"] == 1
    for e in range(2):
        def u(t, e=e):
            from pipeline.fourier.harmonics import basis
            B = basis(t, H)
            return np.stack([B @ X[e, 0], B @ X[e, 1]])

        def n(t, e=e):
            from pipeline.fourier.harmonics import basis
            return n0[e] + KV * (basis(t, H) @ X[e, 2])
        ref = reference_march(u, n, 100_000)
        assert np.abs(got.F[e, :2] - ref).max() < 1e-5 * MU * n0[e], e


CASES = {   # (tangential amplitudes, normal amplitude, n0): the cycle's character
    "stick": ((2e-4, 1e-4), 0.0, 5.0),
    "slip": ((1e-3, 4e-4), 0.0, 1.0),
    "mixed": ((4e-4, 2e-4), 5e-5, 1.0),
    "separating": ((4e-4, 2e-4), 3e-4, 1.0),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_jacobian_against_central_differences(case):
    (a1, a2), av, n0 = CASES[case]
    X = plane_motion(a1, a2, av, NH)
    law = Friction2D(ku=KU, kv=KV, mu=MU, n0=n0)
    N = 128
    got = law.evaluate(X, n_samples=N)
    if case == "stick":
        assert got.regimes["stuck"] == 1
    if case == "separating":
        assert got.regimes["separating"] == 1
    if case in ("slip", "mixed"):
        assert got.regimes["slipping"] == 1
    for pair, err in law_jacobian_errors(law, X, N, 1e-10).items():
        assert err <= 1e-6 * max(KU, KV), (case, pair)


def test_dissipated_energy_from_harmonics_equals_the_loop_integral():
    """pi sum_k k (F_ck U_sk - F_sk U_ck) = (2 pi / N) sum_i f_i . u'(tau_i): the same
    number to 1e-8 (both from the same samples; the normal force does no work over a
    cycle)."""
    X = np.zeros((1, 3, NH))
    X[0, 0, 1], X[0, 1, 2], X[0, 0, 3], X[0, 2, 1] = 8e-4, 3e-4, 1e-4, 5e-5
    law = Friction2D(ku=KU, kv=KV, mu=MU, n0=1.0)
    N = 512
    got = law.evaluate(X, n_samples=N, jacobian=False)
    tau = 2 * np.pi * np.arange(N) / N
    k = np.arange(1, H + 1)
    du = np.stack([(-np.sin(np.outer(tau, k)) * k) @ X[0, d, 1::2]
                   + (np.cos(np.outer(tau, k)) * k) @ X[0, d, 2::2] for d in range(2)])
    loop = 2 * np.pi / N * np.sum(got.detail.f[0, :2] * du)
    harm = dissipated(got.F[0], X[0])
    assert harm > 0 and harm == pytest.approx(loop, rel=1e-8)
