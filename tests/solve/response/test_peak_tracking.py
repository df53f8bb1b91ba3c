"""The resonant peak continued in preload (`local_peak`) against the whole band's."""
import numpy as np
import pytest

from pipeline.paper_systems import example1, example3
from pipeline.solve.response.peak_tracking import local_peak, optimum_preload
from pipeline.solve.response.response import frequency_response


def band_peak(system, H, band, dof=0):
    c = frequency_response(system, H, *band, stability=False, keep="peaks", peak_dofs=[dof])
    assert c.success
    a, om, i = c.peak(dof)
    return a, om, c.Q[i], c.nfev


@pytest.mark.parametrize("build, H, band, start, at", [
    (example1, 7, (150.0, 250.0), 2.0, 2.3),     # stick-slip, the peak moves 3 rad/s
    (example1, 7, (150.0, 250.0), 5.0, 4.0),     # towards the stuck limit
    (example3, 7, (0.8, 1.3), 9.0, 10.0),        # separation, two folds
])
def test_the_peak_continued_from_a_nearby_preload_is_the_band_peak(build, H, band, start, at):
    """From the band peak's state at `start` N, the local maximum at `at` N equals the
    band peak there: amplitude to 1e-7, frequency to 1e-6 (both exact maxima located
    along the branch, measured <= 1e-8), at a fraction of the residual evaluations;
    its full residual meets the tolerance."""
    _, om0, Q0, _ = band_peak(build(start), H, band)
    a, om, _, nfev = band_peak(build(at), H, band)
    c = local_peak(build(at), H, om0, Q0, 0, *band)
    assert c.success and c.converged.all(), c.message
    a_l, om_l, _ = c.peak(0)
    assert a_l == pytest.approx(a, rel=1e-7, abs=0)
    assert om_l == pytest.approx(om, rel=1e-6, abs=0)
    assert c.residual.max() <= c.tolerance
    assert c.nfev < nfev / 2


def test_a_maximum_beyond_the_band_is_no_local_peak():
    """The band ends below Example 1's resonance (peak at ~196 rad/s at 2 N): the
    amplitude still rises at its upper end, so no maximum is enclosed."""
    _, om0, Q0, _ = band_peak(example1(2.0), 7, (150.0, 250.0))
    c = local_peak(example1(2.0), 7, 180.0, Q0, 0, 150.0, 185.0)
    assert not c.success and "no local maximum" in c.message
    assert om0 > 185.0


@pytest.mark.parametrize("band", [(185.0, 250.0), (250.0, 185.0)])
def test_a_start_at_an_end_of_the_band_continues_inwards(band):
    """A start state at an end of the band (a nearby preload's largest amplitude lay
    there): one side only, inwards.  From 185 rad/s (below the 2 N peak) the peak
    inside is enclosed and equals the band peak; from the other end over 220-250 rad/s
    the amplitude only falls inwards: no local maximum, said (not a ValueError)."""
    lo = min(band)
    c0 = frequency_response(example1(2.0), 7, lo, lo + 1.0, stability=False,
                            dense_output=False)
    a, om, _, _ = band_peak(example1(2.0), 7, band)
    c = local_peak(example1(2.0), 7, lo, c0.Q[0], 0, *band)
    assert c.success, c.message
    a_l, om_l, _ = c.peak(0)
    assert a_l == pytest.approx(a, rel=1e-7) and om_l == pytest.approx(om, rel=1e-6)
    c1 = frequency_response(example1(2.0), 7, 220.0, 221.0, stability=False,
                            dense_output=False)
    d = local_peak(example1(2.0), 7, 220.0, c1.Q[0], 0, 220.0, 250.0)
    assert not d.success and "no local maximum" in d.message


def test_the_search_with_local_peaks_equals_the_band_search():
    """Example 1 over 0.5-100 N: the optimum found with Brent on local peaks (verified
    over the band) is the one Brent on band peaks finds, to 1e-6 in preload and peak;
    the local trials are checked where they ended (one band evaluation)."""
    kw = dict(rtol=1e-3)
    ref = optimum_preload(example1, 7, 190.0, 210.0, 0, (0.5, 100.0), local=False, **kw)
    new = optimum_preload(example1, 7, 190.0, 210.0, 0, (0.5, 100.0), **kw)
    assert new["preload"] == pytest.approx(ref["preload"], rel=1e-6)
    assert new["peak"] == pytest.approx(ref["peak"], rel=1e-6)
    assert len(new["verified"]) == len(ref["brackets"]) - len(ref["skipped"])
    for n0, local, full in new["verified"]:
        assert full == pytest.approx(local, rel=1e-6)
    assert new["local"] and new["computed"] < ref["computed"]


def two_modes(n0):
    """2 DOFs (1 kg each; k 3.55e4 and 6e4 N/m, coupled by 8e3 N/m; c 0.3 and
    0.4 N s/m; 1 N on both), a Jenkins damper (ku = 1e4 N/m, mu = 0.5) on the first:
    the band peak of DOF 0 is the first mode's (203-223 rad/s) below 1.6 N and above
    about 6 N, the second's (265-266 rad/s) between: its minimum, 4.35e-4 m near 5.1 N."""
    from pipeline.contact import YangMenq
    from pipeline.model.system import System

    kc = 8e3
    return System(M=np.eye(2), C=np.diag([0.3, 0.4]),
                  K=np.array([[3.55e4 + kc, -kc], [-kc, 6.0e4 + kc]]),
                  Bt=np.array([[1.0, 0.0]]), Bn=np.zeros((1, 2)),
                  contact=YangMenq(np.array([1e4]), np.zeros(1), np.array([0.5]),
                                   np.array([n0])),
                  forcing=np.array([[0, 1.0], [1, 1.0]]))


def test_a_local_peak_on_the_other_mode_is_caught_and_the_bracket_refined_on_the_band(caplog):
    """Brent's trials continued from the grid node above the optimum follow the first
    mode into the basin where the second mode's peak is the larger: the check at
    Brent's result finds the band peak above the local one (the second mode's, 0.54 %
    higher), the bracket is refined again on band evaluations, and the optimum is the
    one Brent on band peaks alone finds (measured equal to 1e-15; asserted 1e-9)."""
    band, bounds = (150.0, 320.0), (3.0, 10.0)
    ref = optimum_preload(two_modes, 3, *band, 0, bounds, rtol=1e-2, local=False)
    new = optimum_preload(two_modes, 3, *band, 0, bounds, rtol=1e-2)
    (n0, local, full), = new["verified"]
    assert full > (1 + 1e-3) * local
    assert "refined again on the whole band" in caplog.text
    assert new["preload"] == pytest.approx(ref["preload"], rel=1e-9)
    assert new["peak"] == pytest.approx(ref["peak"], rel=1e-9)
    assert 250.0 < new["peak_omega"] < 280.0 and 4.5 < new["preload"] < 5.5
