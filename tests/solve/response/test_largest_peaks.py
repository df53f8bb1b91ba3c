"""Each DOF's largest peak only (`frequency_response(keep="peaks")`, a Monte-Carlo
sample of mistuned disks): the same peaks as the full curves, and a peak hidden
between two coarse branch points is still located exactly.

References: the full curves of the same systems (every local maximum located), and
the closed-form FRF of the stuck chain (a linear system: its peak by a bounded
search to 1e-12 in frequency)."""
import numpy as np
import pytest

from pipeline.solve.continuation.amplitudes import amplitudes_at
from pipeline.solve.continuation.exact_peaks import insert_peaks
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response.response import frequency_response
from pipeline.study.files.documents import load_study

from helpers import ROOT, chain_system, stuck_peak

MISTUNED = ROOT / "studies" / "disk_mistuned.toml"


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_largest_peaks_equal_those_of_the_full_curves(seed):
    """The 12-sector mistuned lumped disk (H = 3, 2 N): every sector blade's peak
    amplitude (1e-6) and frequency (1e-6) kept by keep="peaks" are those of the full
    curve (dense output, every local maximum located; measured 4e-11-4e-10 and 5e-9),
    and the curve keeps only the points where a blade peaks."""
    st = load_study(MISTUNED)
    s = st.system({"mistuning_seed": seed})
    dofs = [st.scene.dof_index(d) for d in st.output.dofs]
    fr = st.sweep.frequency
    full = frequency_response(s, 3, fr.omega_start, fr.omega_stop, peak_dofs=dofs,
                              **(st.solver.kwargs(st.output.yscale) | {"stability": False}))
    kw = st.solver.kwargs(st.output.yscale, curves=False) | {"stability": False}
    assert kw["keep"] == "peaks" and kw["dense_output"] is False
    peaks = frequency_response(s, 3, fr.omega_start, fr.omega_stop, peak_dofs=dofs, **kw)
    assert full.success and peaks.success and peaks.converged.all()
    assert peaks.n_points <= len(dofs) < peaks.info["branch_points"]
    for d in dofs:
        (a, om, _), (b, omb, _) = full.peak(d), peaks.peak(d)
        assert b == pytest.approx(a, rel=1e-6)
        assert omb == pytest.approx(om, rel=1e-6)
    # every kept point is some blade's peak
    top = peaks.amplitude[:, dofs].max(0)
    assert all(np.isin(peaks.amplitude[i, dofs], top).any() for i in range(peaks.n_points))


def test_a_peak_hidden_between_two_coarse_points_is_located():
    """The stuck chain (linear, H = 5): its branch without the point nearest the peak
    of x1, so that the two points straddling it are 21 % below it; the largest-peak
    search finds the closed-form peak between them (amplitude 1e-8, frequency 1e-6;
    measured 6e-10 and 2e-9)."""
    H, s = 5, chain_system(1e5)
    c = frequency_response(s, H, 25.0, 160.0, peak_dofs=[0], stability=False,
                           dense_output=False)
    prob = hbm.setup(s, H)
    X = c.Q[:, prob.c, :].reshape(c.n_points, -1)
    i = int(np.argmax(c.amplitude[:, 0]))
    keep = np.r_[0:i, i + 1:c.n_points]
    pts = {"x": X[keep], "lam": c.omega[keep], "nit": np.zeros(keep.size, int),
           "converged": np.ones(keep.size, bool), "extra_nfev": 0}
    a_ref, om_ref = stuck_peak(0)
    assert c.amplitude[keep, 0].max() < 0.8 * a_ref

    out = insert_peaks(prob, pts, lambda x, lam: hbm.residual(prob, x, lam, s.contact),
                       c.tolerance, s.contact, [0], largest=True)
    a = amplitudes_at(prob, out["x"], out["lam"], [0])[:, 0]
    j = int(np.argmax(a))
    assert out["lam"].size == keep.size + 1 and out["extra_nfev"] > 0
    assert a[j] == pytest.approx(a_ref, rel=1e-8)
    assert out["lam"][j] == pytest.approx(om_ref, rel=1e-6)


@pytest.mark.parametrize("step", [0.5, 3.0])
def test_coarse_steps_keep_the_largest_peak(step):
    """Continuation steps of 0.5 and 3 (scaled arclength, against 0.1 by default):
    the resonance guard shortens the steps across the resonance and keep="peaks"
    finds the stuck chain's closed-form peak (amplitude 1e-8, frequency 1e-6)."""
    c = frequency_response(chain_system(1e5), 5, 25.0, 160.0, peak_dofs=[0],
                           stability=False, keep="peaks", ds=step, ds_max=step)
    a_ref, om_ref = stuck_peak(0)
    assert c.info["unresolved_resonance_steps"] == 0
    assert c.peak(0)[0] == pytest.approx(a_ref, rel=1e-8)
    assert c.peak(0)[1] == pytest.approx(om_ref, rel=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_largest_peaks_of_the_beam_blade_wheel(seed):
    """The Monte-Carlo study's wheel (24 shrouded beam blades, its quick variant: 3 N,
    H = 1, 250-290 Hz): every blade's peak amplitude kept by keep="peaks" is that of
    the full curves to 1e-6 (measured <= 1.4e-8), its frequency to 1e-5 (measured
    <= 5.2e-6): the wheel-wide peak is flat (the amplitude changes 3e-9 over 5e-6 of
    frequency), and where a blade's own search on the coarser branch does not beat its
    point, its largest is another blade's located peak beside it.  bench montecarlo
    measures the full case."""
    st = load_study(ROOT / "studies" / "shrouded_disk_monte_carlo.toml", quick=True)
    s = st.system({"preload": st.sweep.axes["preload"][0], "mistuning_seed": seed})
    dofs = [st.scene.dof_index(d) for d in st.output.dofs]
    fr, H = st.sweep.frequency, st.solver.harmonics
    curves = [frequency_response(s, H, fr.omega_start, fr.omega_stop, peak_dofs=dofs,
                                 **(st.solver.kwargs(st.output.yscale, c) | {"stability": False}))
              for c in (True, False)]
    for d in dofs:
        (a, om, _), (b, omb, _) = curves[0].peak(d), curves[1].peak(d)
        assert b == pytest.approx(a, rel=1e-6)
        assert omb == pytest.approx(om, rel=1e-5)
