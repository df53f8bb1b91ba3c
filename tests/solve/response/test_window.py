"""A frequency branch followed out of its window and back (`response.window`): a
hardening resonance that the branch through the window's end reaches only through a
fold outside the window, against the closed form of the one-harmonic balance and a
sweep over a range that holds the whole resonance; peaks read inside the window only;
the optimum preload searched on such a branch."""
import re

import numpy as np
import pytest

from pipeline.contact import YangMenq
from pipeline.contact.cubic_spring import CubicSpring
from pipeline.contact.laws import LawElements
from pipeline.model.system import System
from pipeline.solve.response.peak_tracking import band_peak, optimum_preload
from pipeline.solve.response.response import frequency_response
from pipeline.solve.response.window import rising_ends

m, c, k, k3, F = 1.0, 0.05, 1.0, 0.5, 0.1
BETA = 0.75 * k3

# m x'' + c x' + k x + k3 x^3 = F cos(W t) (m = 1 kg, c = 0.05 N s/m, k = 1 N/m,
# k3 = 0.5 N/m^3, F = 0.1 N): its folds at 1.1337 and 1.3505 rad/s.  In the window
# 1.25-1.5 rad/s the start at 1.25 lies on the lower sheet, which runs to 1.5 without
# a fold; the resonant sheet (peak 1.48 m at 1.35 rad/s) is reached from it only
# through the fold at 1.1337 rad/s, farther below the window than the 20 % of its
# width a branch was followed back (1.2 rad/s): before, the peak was 0.181 m at 1.25.
WINDOW = (1.25, 1.5)


def closed_form_peak():
    """(a, W) of the largest amplitude of the one-harmonic balance
    G = [(k - m W^2 + 3/4 k3 a^2)^2 + (c W)^2] a^2 - F^2 = 0: dG/dW = 0 there, i.e.
    k - m W^2 + 3/4 k3 a^2 = c^2 / (2 m), so a^2 = F^2 / (c^4 / (4 m^2) + c^2 W^2) and
    W^2 = (k + 3/4 k3 a^2 - c^2 / (2 m)) / m (fixed point, a contraction here)."""
    W = 1.3
    for _ in range(200):
        a = F / np.sqrt(c**4 / (4 * m * m) + (c * W) ** 2)
        W = np.sqrt((k + BETA * a * a - c * c / (2 * m)) / m)
    return a, W


@pytest.mark.parametrize("start, end", [WINDOW, WINDOW[::-1]])
@pytest.mark.parametrize("keep", ["curve", "peaks"])
def test_a_resonance_behind_a_fold_outside_the_window_is_found(start, end, keep):
    """Swept up or down, drawn or peaks only: the window's peak is the resonant
    sheet's, the closed form's largest amplitude (1.4815 m at 1.3497 rad/s), reached
    by following the branch below the window (its fold at 1.1337 rad/s) and back."""
    cur = frequency_response(duffing(), 1, start, end, stability=False, tol_rel=1e-12,
                             keep=keep)
    a_ref, W_ref = closed_form_peak()
    a, W, _ = cur.peak(0)
    assert cur.success
    assert a == pytest.approx(a_ref, rel=1e-9)
    assert W == pytest.approx(W_ref, rel=1e-5)
    assert "followed: it came back into the range" in cur.message
    if keep == "curve":   # both folds drawn, the lower one outside the window
        assert np.sort(cur.fold_parameter) == pytest.approx([1.13365, 1.35049], abs=1e-4)
        assert cur.omega.min() < 1.14 and cur.omega.max() == WINDOW[1]


def upper_sheet(W):
    """The largest amplitude a [m] of the one-harmonic balance at W [rad/s]: the
    largest real root s = a^2 of G, a cubic in s."""
    d = k - m * W**2
    s_roots = np.roots([BETA**2, 2 * BETA * d, d * d + (c * W) ** 2, -F**2])
    return float(np.sqrt(max(r.real for r in s_roots if abs(r.imag) < 1e-12)))


@pytest.mark.parametrize("keep", ["curve", "peaks"])
def test_a_peak_beyond_the_window_is_never_its_peak(keep):
    """1.3 down to 1.0 rad/s: the branch from 1.3 (on the lower sheet) folds at 1.1337,
    climbs the middle sheet past 1.3 to the fold at 1.3505 (the resonance, 1.4815 m,
    outside the window) and comes back on the upper sheet.  Before, 1.4815 m at
    1.3497 rad/s was reported as the window's peak; now its peak is the upper sheet's
    amplitude on the window's edge, 1.3 rad/s (closed form), and the message says
    where the larger one lies."""
    cur = frequency_response(duffing(), 1, 1.3, 1.0, stability=False, tol_rel=1e-12,
                             keep=keep)
    a, W, _ = cur.peak(0)
    assert cur.success and W == 1.3
    assert a == pytest.approx(upper_sheet(1.3), rel=1e-9)
    said = re.search(r"the largest amplitude traced of model DOF 0, ([0-9.]+) m at lam = "
                     r"([0-9.]+), lies outside the range", cur.message)
    # the largest traced point (not refined: that is the window's peak's job), near the
    # closed-form resonance: measured 4e-4 in amplitude and 9e-4 in frequency
    a_peak, w_peak = closed_form_peak()
    assert float(said.group(1)) == pytest.approx(a_peak, rel=1e-3)
    assert float(said.group(2)) == pytest.approx(w_peak, rel=2e-3)


def jenkins_duffing(n0, ku=0.2):
    """The Duffing oscillator with a friction damper to ground (ku [N/m], mu = 1,
    normal load n0 [N]): the more n0, the more it sticks (stiffer, less damped);
    ku = 0: no damper (its element has no stiffness, and no normal load)."""
    return System(M=np.array([[m]]), C=np.array([[c]]), K=np.array([[k]]),
                  Bt=np.ones((1, 1)), Bn=np.zeros((1, 1)),
                  contact=YangMenq(ku=np.array([ku]), kv=np.zeros(1), mu=np.ones(1),
                                   n0=np.array([float(n0)])),
                  forcing=np.array([[0.0, F]], complex),
                  laws=(LawElements(CubicSpring(k3=[k3], k1=[0.0]), (np.ones((1, 1)),)),))


def duffing():
    """The Duffing oscillator alone (`jenkins_duffing` without the damper)."""
    return jenkins_duffing(0.0, ku=0.0)


def wide_peak(n0):
    """(peak, Omega) of the damped Duffing at n0 over 0.8-2 rad/s, a range that holds
    the whole resonance (the branch starts on its one sheet below it)."""
    cur = frequency_response(jenkins_duffing(n0), 3, 0.8, 2.0, stability=False)
    assert cur.success and cur.fold_parameter.size == 2
    return cur.peak(0)[:2]


def test_a_peak_outside_the_window_is_not_the_windows_peak():
    """n0 = 0.03 N: the resonance has moved below the window (1.110 m at 1.212 rad/s
    over 0.8-2 rad/s); followed there, it is no peak of the window: the band peak is
    the value at the window's end, 1.25 rad/s, and its note says so."""
    a_out, W_out = wide_peak(0.03)
    assert W_out < WINDOW[0]
    a, W, _, notes = band_peak(jenkins_duffing(0.03), 3, *WINDOW, 0, stability=False)
    assert W == WINDOW[0] and a < 0.25 * a_out and notes["outside"]
    cur = frequency_response(jenkins_duffing(0.03), 3, *WINDOW, stability=False)
    assert cur.peak(0)[1] == WINDOW[0]
    # traced outside the window (a point of the branch there, not its located peak)
    said = re.search(r"the largest amplitude traced of model DOF 0, ([0-9.e+-]+) m at lam = "
                     r"([0-9.e+-]+), lies outside the range: not its peak", cur.message)
    assert 0.999 * a_out < float(said.group(1)) <= a_out
    assert float(said.group(2)) == pytest.approx(W_out, rel=1e-2)


def test_the_optimum_search_sees_the_resonance_behind_the_fold():
    """Preloads 0.001-0.01 N: the resonance lies inside the window, behind the fold
    below it, at every preload, its peak falling with n0 (1.4886 m at 0.001 N to
    1.3664 m at 0.01 N over 0.8-2 rad/s).  The search finds the optimum at the upper
    bound with that peak; before, every evaluation read the lower sheet's value at
    1.25 rad/s and the search reported 0.001 N, peak 0.181 m."""
    res = optimum_preload(jenkins_duffing, 3, *WINDOW, 0, (0.001, 0.01), stability=False)
    a_ref, W_ref = wide_peak(res["preload"])
    assert res["preload"] == pytest.approx(0.01, rel=1e-3)
    assert res["peak"] == pytest.approx(a_ref, rel=1e-8)
    assert res["peak_omega"] == pytest.approx(W_ref, rel=1e-5)
    for n0, a, _ in res["evaluations"][:3]:
        assert a == pytest.approx(wide_peak(n0)[0], rel=1e-8)


def test_rising_ends_are_where_the_windows_largest_amplitude_meets_its_edge():
    """Amplitudes along a branch (columns: two DOFs); lam outside the window ignored."""
    lam = np.array([0.9, 1.0, 1.5, 2.0, 2.1])
    conv = np.ones(5, bool)
    A = np.array([[5.0, 0.0], [3.0, 0.0], [2.0, 0.0], [1.0, 0.0], [9.0, 0.0]])
    ends = rising_ends(lam, A, conv, (1.0, 2.0))
    assert list(ends) == ["first"] and ends["first"].tolist() == [True, False]
    A[:, 1] = [0.0, 1.0, 2.0, 4.0, 0.0]
    ends = rising_ends(lam, A, conv, (1.0, 2.0))
    assert list(ends) == ["first", "last"] and ends["last"].tolist() == [False, True]
    A[:, 0] = [0.0, 1.0, 3.0, 1.0, 0.0]
    A[:, 1] = 0.0   # a peak inside, a DOF that never moves: no end
    assert rising_ends(lam, A, conv, (1.0, 2.0)) == {}
    # a peak inside, and the branch rising out at 1.0 below it: followed there (a larger
    # resonance may lie behind that edge), unless under 5 % of the peak
    lam = np.array([1.0, 1.2, 1.5, 1.8, 2.0])
    ends = rising_ends(lam, np.array([[1.0, 0.8, 3.0, 0.8, 0.5]]).T, np.ones(5, bool),
                       (1.0, 2.0))
    assert list(ends) == ["first"]
    assert rising_ends(lam, np.array([[0.1, 0.08, 3.0, 0.8, 0.5]]).T, np.ones(5, bool),
                       (1.0, 2.0)) == {}


def test_a_check_that_refuses_a_point_outside_the_window_stops_the_excursion_only():
    """The caller's callback (e.g. the separation guard) raising at points below the
    window: the excursion stops at its first point there (its tail not kept), the
    curve over the window stands (the lower sheet's value at 1.25 rad/s, the closed
    form's smallest root there), and a check raising inside the window still raises."""
    def below(x, lam):
        if lam < WINDOW[0]:
            raise ValueError("refused below the window")
        return False

    cur = frequency_response(duffing(), 1, *WINDOW, stability=False, tol_rel=1e-12,
                             callback=below)
    assert cur.success and cur.omega.min() == WINDOW[0]
    assert "stopped at lam = " in cur.message and "(refused below the window)" in cur.message
    d = k - m * WINDOW[0] ** 2
    s = np.roots([BETA**2, 2 * BETA * d, d * d + (c * WINDOW[0]) ** 2, -F**2])
    lower = float(np.sqrt(min(r.real for r in s if abs(r.imag) < 1e-12)))
    assert cur.peak(0)[:2] == (pytest.approx(lower, rel=1e-9), WINDOW[0])

    def inside(x, lam):
        if lam > 1.4:
            raise ValueError("refused inside the window")
        return False

    with pytest.raises(ValueError, match="inside the window"):
        frequency_response(duffing(), 1, *WINDOW, stability=False, callback=inside)
