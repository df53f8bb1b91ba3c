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
