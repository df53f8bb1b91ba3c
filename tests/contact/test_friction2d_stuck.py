"""The fully stuck cycle of the 2D friction law: the slider at the centre of the stick
discs |u_i - w| <= r_i (the minimiser of max_i (|u_i - w| - r_i)).

Checked against an independent minimiser (scipy's Nelder-Mead on the same convex
function, written here), central differences of the stuck cycle's Jacobian where
the centre rests on two and on three samples, and the 1D band middle along one
tangent.  The motions are those the per-tangent band middle got wrong: every disc
shares a point, but not the middle of the bounding box, so the slider there slips and
a plain period march creeps to the stuck set's edge (a shroud pair of the FE disk
took 17,541 periods)."""
import numpy as np
import pytest
from scipy.optimize import minimize

from pipeline.contact.friction2d.law import Friction2D
from pipeline.contact.friction2d.centre import stick_centres
from pipeline.fourier.harmonics import time_grid

from helpers import law_jacobian_errors

KU, KV, MU = 1.0e4, 1.0e4, 0.5
H, N = 2, 64
NH = 2 * H + 1


def motion(seed):
    """A lopsided in-plane orbit (harmonics 1 and 2) with a varying normal load."""
    rng = np.random.default_rng(seed)
    X = np.zeros((1, 3, NH))
    X[0, :2, 1:] = rng.normal(size=(2, NH - 1)) * 1e-4
    X[0, 2, 1:3] = rng.normal(size=2) * 2e-5
    return X


def discs(X, n0):
    _, S, _ = time_grid(H, N)
    u = X[0, :2] @ S.T
    r = MU * (n0 + KV * (X[0, 2] @ S.T)) / KU
    return u, r


def deepest(u, r, start):
    """The centre by Nelder-Mead from `start`, in coordinates scaled to the orbit
    (independent of the kernel): (w, its value)."""
    L = np.ptp(u, axis=1).max()

    def f(x):
        w = start + L * x
        return np.max(np.hypot(u[0] - w[0], u[1] - w[1]) - r) / L
    res = minimize(f, np.zeros(2), method="Nelder-Mead",
                   options={"initial_simplex": [[0, 0], [0.1, 0], [0, 0.1]], "xatol": 1e-13,
                            "fatol": 1e-15, "maxiter": 40000})
    return start + L * res.x, res.fun * L


def just_stuck(seed, margin=0.02):
    """(X, n0) with every disc sharing a point by `margin` of the largest radius, the
    box middle outside one disc."""
    X = motion(seed)
    u, r = discs(X, 0.0)                 # r: the normal part, n0 = 0
    t0 = deepest(u, r + 1.0, u.mean(axis=1))[1] + 1.0   # value without the preload
    n0 = (t0 * (1 + margin)) * KU / MU   # raises every radius by (1 + margin) t0
    return X, n0


@pytest.mark.parametrize("seed", range(6))
def test_centre_equals_an_independent_minimiser(seed):
    X, n0 = just_stuck(seed)
    u, r = discs(X, n0)
    w, t, sup = np.empty((1, 2)), np.empty(1), np.empty((1, 3), np.int64)
    scale = np.abs(u).max() + r.max()
    stick_centres(u[None].copy(), r[None].copy(), np.array([1e-14 * scale]), w, t, sup)
    ref, val = deepest(u, r, u.mean(axis=1))
    assert t[0] < 0
    assert abs(t[0] - val) <= 1e-9 * scale
    assert np.abs(w[0] - ref).max() <= 1e-7 * scale


def test_the_box_middle_would_slip_where_the_centre_sticks():
    """At least one of the motions has its bounding-box middle outside a disc (what the
    stuck start was before), and each is evaluated fully stuck with no period marched."""
    outside = 0
    for seed in range(6):
        X, n0 = just_stuck(seed)
        u, r = discs(X, n0)
        lo, hi = (u - r).max(axis=1), (u + r).min(axis=1)
        mid = 0.5 * (lo + hi)
        outside += np.any(np.hypot(u[0] - mid[0], u[1] - mid[1]) > r)
        cyc = Friction2D(ku=KU, kv=KV, mu=MU, n0=n0).evaluate(X, n_samples=N).detail
        assert cyc.regimes["stuck"] == 1 and cyc.periods[0] == 0
        assert np.all(cyc.state == 1)
    assert outside >= 1


@pytest.mark.parametrize("seed", range(6))
def test_stuck_jacobian_against_central_differences(seed):
    X, n0 = just_stuck(seed, margin=0.05)
    law = Friction2D(ku=KU, kv=KV, mu=MU, n0=n0)
    got = law.evaluate(X, n_samples=N)
    assert got.regimes["stuck"] == 1
    for pair, err in law_jacobian_errors(law, X, N, 1e-11).items():
        assert err <= 1e-6 * KU, (seed, pair)


def test_supports_of_two_and_three_samples_occur():
    """The Jacobian test covers both kinds of centre (a segment's point, an Apollonius
    point)."""
    kinds = set()
    for seed in range(6):
        X, n0 = just_stuck(seed, margin=0.05)
        u, r = discs(X, n0)
        w, t, sup = np.empty((1, 2)), np.empty(1), np.empty((1, 3), np.int64)
        stick_centres(u[None].copy(), r[None].copy(), np.array([1e-18]), w, t, sup)
        kinds.add(int((sup[0] >= 0).sum()))
    assert {2, 3} <= kinds


def test_along_one_tangent_the_centre_is_the_band_middle():
    X = motion(3)
    X[0, 1] = 0.0
    X[0, 1, 0] = 3e-5
    u, r = discs(X, 0.0)
    n0 = 1.1 * 0.5 * np.ptp(u[0]) * KU / MU + 1.0
    u, r = discs(X, n0)
    w, t, sup = np.empty((1, 2)), np.empty(1), np.empty((1, 3), np.int64)
    stick_centres(u[None].copy(), r[None].copy(), np.array([1e-18]), w, t, sup)
    middle = 0.5 * ((u[0] - r).max() + (u[0] + r).min())
    assert abs(w[0, 0] - middle) <= 1e-15 * np.abs(u).max()
    assert w[0, 1] == pytest.approx(3e-5, rel=1e-14, abs=0)


@pytest.mark.parametrize("seed", range(4))
def test_a_small_orbit_deep_inside_large_discs_is_smooth(seed):
    """A shroud pair under a large preload: the orbit (~2e-7 m) far inside discs of
    radius ~4.5e-5 m whose radii vary by as much as the orbit, away from the origin.
    The centre then rests on nearby samples (an ill-conditioned Apollonius point), and
    a feasibility test at round-off picked either root at random: the forces jumped
    by 0.05 N between motions 1e-15 m apart and Newton stalled.  Now: the Jacobian
    equals central differences, and the forces are continuous."""
    rng = np.random.default_rng(seed)
    X = np.zeros((1, 3, NH))
    X[0, :2, 0] = [-8.5e-5, 4.3e-6]
    X[0, :2, 1:3] = rng.normal(size=(2, 2)) * 1e-7
    X[0, 2, 1:3] = rng.normal(size=2) * 3e-8
    law = Friction2D(ku=KU, kv=KV, mu=MU, n0=1.0)
    got = law.evaluate(X, n_samples=N)
    assert got.regimes["stuck"] == 1
    dX = rng.normal(size=X.shape) * 1e-15
    for eps in (1.0, 2.0, 3.0):
        step = law.evaluate(X + eps * dX, n_samples=N, jacobian=False).F
        assert np.abs(step - got.F).max() <= 1e-15 * eps * KU * 50
    for pair, err in law_jacobian_errors(law, X, N, 1e-12).items():
        assert err <= 1e-6 * KU, (seed, pair)


def test_the_shroud_pair_that_stalled_newton():
    """The element of the quick FE disk (2D pairs, 100 N per face, H = 1, 64 samples)
    whose centre flipped between the two Apollonius roots of adjacent samples: its
    slider now moves continuously along a line of motions 1e-15 m apart."""
    X = np.array([[[-8.5621627893308174e-05, 5.0774081302776954e-08, -9.0640729650539006e-08],
                   [3.9544821337429939e-06, -4.6798438789473869e-08, -5.1892225886707879e-09],
                   [-5.0496359313372417e-05, 7.3411746360254734e-08, 1.8570782649821214e-07]]])
    k = 111111.11111111121
    law = Friction2D(ku=k, kv=k, mu=0.3, n0=22.222222222222243)
    dX = np.random.default_rng(0).normal(size=X.shape) * 5e-15
    w = np.array([law.evaluate(X + e * dX, n_samples=64, jacobian=False).detail.w[0, :, 0]
                  for e in np.linspace(-2.0, 3.0, 11)])
    assert np.abs(np.diff(w, axis=0)).max() <= 1e-12      # the roots were 4e-7 m apart


def test_a_barely_slipping_pair_settles_in_a_few_periods():
    """A shroud pair of the full FE disk (3 N per face, H = 3, 512 samples) that slips at
    5 of 512 samples: the period map contracts by 0.999 a period (det(I - A) = 1e-3),
    so plain periods took 14,740 and the march gave up at 500.  Newton steps on the
    fixed point settle it in a few; the cycle equals 30,000 plain periods'."""
    from pipeline.contact.friction2d.kernel import period_map
    X = np.array([[[-2.1185698175829577e-06, 7.8101244222981639e-10, -1.1155111836957359e-06,
                    3.6590120215214412e-09, -1.5651731996922020e-09, -9.8718678934394398e-10,
                    -3.1365001867655696e-10],
                   [2.8292692578922223e-07, -1.1696238763332251e-06, 3.4231855425728039e-09,
                    -7.2548220880462407e-09, 6.4064456995188582e-09, 1.3829407512597481e-09,
                    7.9517334032404205e-10],
                   [-1.2430278354891205e-06, 1.2518527219624316e-07, 2.6859296951038740e-06,
                    -2.2610022653899917e-09, -9.8673456832917334e-09, -8.0342609607703058e-10,
                    7.9981832821833779e-10]]])
    k, Ns = 13888.888888888952, 512
    law = Friction2D(ku=k, kv=k, mu=0.3, n0=0.08333333333333372)
    got = law.evaluate(X, n_samples=Ns, jacobian=False)
    assert got.regimes["slipping"] == 1 and got.detail.periods[0] <= 10
    _, S, W = time_grid(3, Ns)
    u = np.ascontiguousarray(X[0, :2] @ S.T)
    n = 0.08333333333333372 + k * (X[0, 2] @ S.T)
    w, A = got.detail.w[0, :, -1].copy() + 1e-9, np.empty((2, 2))   # start off the cycle
    for _ in range(30000):
        period_map(u[0], u[1], n, k, k, 0.3, 0, w, A)
    assert np.abs(w - got.detail.w[0, :, -1]).max() <= 1e-8 * np.abs(u).max()
