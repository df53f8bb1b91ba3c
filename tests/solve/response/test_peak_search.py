"""The exact peak search: several DOFs peaking between the same branch points share
their trial points, and a peak is located to 1e-8 in frequency.

References: each DOF's peak searched alone, and the closed-form FRF of the stuck
chain (a linear system: its peak by a bounded search to 1e-12 in frequency)."""
import numpy as np
import pytest

from pipeline.paper_systems import example3
from pipeline.solve.response.response import frequency_response

from helpers import chain_system, stuck_peak

H, BAND = 5, (25.0, 160.0)  # rad/s: the chain's first resonance, open to stuck


@pytest.mark.parametrize("n0", [5.0, 1e5])
def test_dofs_peaking_together_share_their_trials(n0):
    """Each DOF's peak is the one its search alone finds (amplitude 1e-10,
    frequency 1e-8), for fewer evaluations than the three searches alone."""
    s = chain_system(n0)
    together = frequency_response(s, H, *BAND, peak_dofs=[0, 1, 2], stability=False)
    alone_nfev = 0
    for d in range(3):
        alone = frequency_response(s, H, *BAND, peak_dofs=[d], stability=False)
        alone_nfev += alone.info["peak_nfev"]
        (a, om, _), (b, omb, _) = alone.peak(d), together.peak(d)
        assert b == pytest.approx(a, rel=1e-10)
        assert omb == pytest.approx(om, rel=1e-8)
    assert together.info["peak_nfev"] < 0.75 * alone_nfev


def test_stuck_peak_to_1e_8_in_frequency():
    """At 1e5 N the contact never slips: every DOF's peak is the linear FRF's, its
    frequency to 1e-8 and its amplitude to 1e-10."""
    c = frequency_response(chain_system(1e5), H, *BAND, peak_dofs=[0, 1, 2], stability=False)
    for d in range(3):
        a, om, _ = c.peak(d)
        a_ref, om_ref = stuck_peak(d)
        assert a == pytest.approx(a_ref, rel=1e-10)
        assert om == pytest.approx(om_ref, rel=1e-8)


def test_peaks_of_several_dofs_keep_the_branch_order():
    """Example 3 at 10 N traced from its middle branch (H = 7): the two DOFs' peaks are
    found from different triples of points but fall between the same two; inserted
    by their place on that chord, the frequency turns back only at the two folds
    (ordered by each search's own sigma, the later DOF's peak was put first: a
    backward step of 1e-5 rad/s at the peak)."""
    ref = frequency_response(example3(10.0), 7, 0.5, 1.6, peak_dofs=[0])
    unstable = np.flatnonzero(~ref.stable)
    j = unstable[np.argmin(np.abs(ref.omega[unstable] - 1.26))]
    c = frequency_response(example3(10.0), 7, ref.omega[j], 0.5, initial=ref.Q[j],
                           peak_dofs=[0, 1], stability=False)
    dl = np.diff(c.parameter)
    turning = np.flatnonzero(dl[:-1] * dl[1:] < 0) + 1
    assert len(turning) == len(c.fold_parameter) == 2
    assert np.all(np.abs(dl) > 0)
