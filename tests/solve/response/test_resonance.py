"""No branch steps over a resonance; the reported peak is the branch's highest.

References: the linear FRF of the stuck structure (closed form per frequency, its
peak by bounded search), natural frequencies by a generalised eigen-solve, and a
dense trace of the same branch.
"""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response import resonance
from pipeline.paper_systems import example1
from pipeline.solve.response.response import frequency_response
from pipeline.study.files.documents import load_study
from pipeline.study.execution.run import run_study

from helpers import K_CHAIN, chain_system, stuck_peak

CHAIN = Path(__file__).parents[2] / "studies" / "chain_stuck_resonance.toml"


@pytest.mark.parametrize("normal", ["x3", "x2"])
def test_stuck_chain_peak_is_the_linear_resonance(tmp_path, normal):
    """At 1e5 N the contact never slips: the branch is the stuck chain's linear FRF,
    whose sharp first resonance lies inside the range.  Its peak must be found."""
    text = CHAIN.read_text().replace('normal = ["x3"]', f'normal = ["{normal}"]')
    f = tmp_path / "chain.toml"
    f.write_text(text.replace("preload = [0.0, 5.0, 1.0e5]", "preload = [1.0e5]"))
    res = run_study(load_study(f), tmp_path / "out", figures=False, progress=False)
    ds = res.dataset
    amp, w = stuck_peak(2, normal=int(normal[1]) - 1)
    freq = w / (2 * np.pi)   # Hz
    got_a = float(ds.peak_amplitude.sel(dof="x3").squeeze())
    got_f = float(ds.peak_frequency.sel(dof="x3").squeeze())
    assert got_a == pytest.approx(amp, rel=1e-6)
    assert got_f == pytest.approx(freq, rel=1e-6)
    assert bool(ds.peaks_resolved.all())


def test_a_curve_that_cannot_exclude_a_hidden_peak_says_so(tmp_path, monkeypatch):
    """Without the count (here: a structure declared too large for it) the dataset's
    peaks_resolved is 0 and the case's message says why; never a silent 1."""
    monkeypatch.setattr(resonance, "MAX_DENSE_DOF", 2)
    f = tmp_path / "chain.toml"
    f.write_text(CHAIN.read_text().replace("preload = [0.0, 5.0, 1.0e5]", "preload = [1.0e5]"))
    ds = run_study(load_study(f), tmp_path / "out", figures=False, progress=False).dataset
    assert not bool(ds.peaks_resolved.any())
    assert "not checked" in str(ds.message.values.ravel()[0])


@pytest.mark.parametrize("n0, added", [(1e5, (1e4, 1e3)), (-1.0, (0.0, 0.0))])
def test_count_equals_the_natural_frequencies_below(n0, added):
    """Stuck (large preload, small motion) the count is that of K + ku + kv; open (a
    gap never closed) that of K alone: the Sturm count of the linear limits."""
    sys = chain_system(n0)
    prob = hbm.setup(sys, 3)
    rc = resonance.prepare(prob)
    x = np.zeros(prob.size)
    x.reshape(prob.c.size, prob.nh)[:, 1] = 1e-7  # small first-harmonic motion
    K = K_CHAIN.copy()
    K[2, 2] += sum(added)
    wn = np.sqrt(np.linalg.eigvalsh(K))
    for Om in np.linspace(20.0, 200.0, 37):
        assert resonance.counts(rc, prob, x, Om, sys.contact) == (int(np.sum(wn < Om)),)


def test_contact_stiffness_closed_forms():
    """Z_1 of a stuck Jenkins element is ku, of an open one 0, and fully sliding
    (large motion) it is mostly dissipation: |Im| > Re."""
    sys = example1(1.0)
    prob = hbm.setup(sys, 5)
    Q = np.zeros((1, prob.nh))
    Q[0, 1] = 1e-6  # ku |u| = 0.01 N < mu n = 0.5 N: stuck
    assert resonance.contact_stiffness(prob, Q, sys.contact, 1)[0, 0] == pytest.approx(1e4)
    Q[0, 1] = 1.0  # slides almost all the cycle
    z = resonance.contact_stiffness(prob, Q, sys.contact, 1)[0, 0]
    assert 0 <= z.real < abs(z.imag)
    open_el = replace(sys.contact, n0=np.array([0.0]), mu=np.array([0.0]))
    assert resonance.contact_stiffness(prob, Q, open_el, 1)[0, 0] == pytest.approx(0.0)


@pytest.mark.parametrize("name, system, H, band, crossings", [
    ("stuck chain", chain_system(1e5), 5, (2 * np.pi * 4, 2 * np.pi * 25), 2),
    ("chain, slipping", chain_system(5.0), 5, (2 * np.pi * 4, 2 * np.pi * 25), 1),
    ("Example 1, 2 N", example1(2.0), 7, (150.0, 250.0), 1),
])
def test_branch_has_points_inside_every_crossed_resonance(name, system, H, band, crossings):
    """Every step across a natural frequency of the structure linearised along the
    branch (linear or nonlinear) has both ends inside that resonance's half-power
    band, and the peak equals a dense trace's (steps 10x finer) to 1e-8."""
    c = frequency_response(system, H, *band, stability=False, peak_dofs=[0])
    prob = hbm.setup(system, H)
    rc = resonance.prepare(prob)
    w = [resonance.natural_frequencies(rc, prob, q[prob.c], system.contact) for q in c.Q]
    n = 0
    for i in range(len(w) - 1):
        modes = resonance.crossed(rc, w[i], c.omega[i], w[i + 1], c.omega[i + 1])
        if modes:
            n += 1
            assert resonance.detuning_ratio(rc, modes, w[i], c.omega[i], w[i + 1],
                                            c.omega[i + 1]) <= 1 + 1e-12
    assert n >= crossings
    assert c.info["unresolved_resonance_steps"] == 0
    dense = frequency_response(system, H, *band, stability=False, peak_dofs=[0], ds=0.01,
                               ds_max=0.01, max_points=5000, dense_output=False)
    assert c.peak(0)[0] == pytest.approx(dense.peak(0)[0], rel=1e-8)


def test_aft_peak_is_the_highest_ripple():
    """Sampled forces make the amplitude ripple near Example 1's peak at 5 N (three
    local maxima within 0.7 rad/s at 128 samples): the reported peak is the highest
    of the branch, as a dense trace of the peak's neighbourhood finds it."""
    kw = dict(method="aft", n_samples=128, stability=False)
    c = frequency_response(example1(5.0), 7, 150.0, 250.0, **kw)
    dense = frequency_response(example1(5.0), 7, 206.5, 207.9, ds=0.004, ds_max=0.004,
                               max_points=4000, **kw)
    a_ref = dense.amplitude[dense.converged, 0].max()
    a, om, _ = c.peak(0)
    assert a >= a_ref * (1 - 1e-7)
    assert om == pytest.approx(dense.omega[np.argmax(np.where(dense.converged,
                                                              dense.amplitude[:, 0], -1))],
                               abs=0.02)


def test_counts_by_inertia_equal_counts_by_eigenvalues():
    """The count below w of a linearised structure (K Hermitian, complex or real,
    M > 0) by the inertia of K - w^2 M equals the count of its eigenvalues below w^2,
    at every w between them and beyond both ends; mode(k) afterwards agrees."""
    rng = np.random.default_rng(3)
    n = 40
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)
    B = rng.standard_normal((n, n))
    K_real = B @ B.T + n * np.eye(n)
    C = rng.standard_normal((n, n))
    for K in (K_real, K_real + 0.3j * (C - C.T)):
        w_exact = np.sqrt(sla.eigh(K, M, eigvals_only=True))
        spec = resonance.DenseSpectrum(K, M, np.zeros(n))
        probes = np.concatenate([[0.0, 0.5 * w_exact[0]], 0.5 * (w_exact[1:] + w_exact[:-1]),
                                 [2 * w_exact[-1]]])
        assert [spec.count(w) for w in probes] == [0] + list(range(n + 1))
        assert spec.w is None  # counts alone: no eigen-solve
        assert spec.mode(n // 2)[0] == pytest.approx(w_exact[n // 2], rel=1e-10)
        assert resonance.negative_eigenvalues(-K) == n
