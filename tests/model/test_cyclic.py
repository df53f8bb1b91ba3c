"""Cyclic bladed disks: the one-sector reduction (Petrov 2004) against the full
N-sector assembly, and the standing-wave hard cases EO = 0 and EO = N/2 against
closed references."""
import copy
import tomllib
from math import gcd
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import eigh

from pipeline.solve.harmonic_balance import full_operators
from pipeline.solve.harmonic_balance import hbm
from pipeline.contact import YangMenq
from pipeline.solve.continuation.newton import newton
from pipeline.model.cyclic import (Sector, aft_samples_ok, expand, full_assembly, isolated_system,
                                   sector_forcing, sector_system)
from pipeline.fourier.harmonics import evaluate
from pipeline.solve.response.response import frequency_response
from pipeline.solve.stability.hill import hill_eigenvalues, is_stable
from pipeline.study.files.documents import load_study, study_from_document, study_to_mapping
from pipeline.model.system import System, linear_stiffness, natural_frequencies, natural_modes
from pipeline.model.build import full_system

from helpers import fd, linear_peak, solve_sector

KU, MU, N0 = 2.0, 0.3, 0.5


def sector(N=6, kv=0.0, n0=N0, normal=False, static=False):
    """2-DOF sector (x1 blade, x2 shroud) [kg, N/m, N s/m]; a Yang-Menq element
    between the shrouds of neighbours, u = x2_{j+1} - x2_j, and with `normal` a
    normal direction v = x1_{j+1} - x1_j (so EO = 0 moves neither); 1 N on x1 and
    0.3 N (90 deg later) on x2 in the first harmonic (+ static and second-harmonic
    loads with `static`)."""
    K = np.array([[3.0, -1.0], [-1.0, 1.5]])
    M = np.diag([1.0, 0.5])
    e1, e2 = np.array([[1.0, 0.0]]), np.array([[0.0, 1.0]])
    Bn, Bn_next = (-e1, e1) if normal else (0 * e1, 0 * e1)
    F = (np.array([[0.0, 1.0, 0.0], [0.05, 0.3j, 0.1]]) if static
         else np.array([[0.0, 1.0], [0.0, 0.3j]]))
    return Sector(M=M, C=0.02 * K, K=K, Bt=-e2, Bn=Bn, Bt_next=e2, Bn_next=Bn_next,
                  contact=YangMenq(KU, kv, MU, n0), forcing=F, sectors=N, dof_names=("x1", "x2"))


def check_curve(c):
    """success, every point converged with its recomputed full residual within
    tolerance, nothing NaN."""
    assert c.success, c.message
    assert c.converged.all()
    assert np.all(c.residual <= c.tolerance)
    assert np.all(np.isfinite(c.Q)) and np.all(np.isfinite(c.amplitude))


# ---------------------------------------------------------------------------
# The reduction in HBM: exact Jacobians, sector = full assembly at a point
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("eo", [0, 1, 2, 3])
@pytest.mark.parametrize("method", ["exact", "aft"])
@pytest.mark.parametrize("normal", [False, True], ids=["jenkins", "normal_load"])
def test_sector_jacobians_match_finite_differences(eo, method, normal):
    s = sector_system(sector(kv=1.5 if normal else 0.0, n0=0.2, normal=normal, static=True), eo)
    prob = hbm.setup(s, 3, method, n_samples=120)
    assert prob.shift is not None and set(np.unique(prob.shift)) <= {0.0, 2 * np.pi * eo / 6}
    x = np.random.default_rng(eo).normal(size=prob.size) * 0.3
    R, J, dOm = hbm.residual(prob, x, 1.3)
    Jfd = fd(lambda y: hbm.residual(prob, y, 1.3, jacobian=False)[0], x)
    dfd = fd(lambda o: hbm.residual(prob, x, o[0], jacobian=False)[0], np.array([1.3]))[:, 0]
    assert np.max(np.abs(Jfd - J)) < 1e-6 * np.max(np.abs(J))
    assert np.max(np.abs(dfd - dOm)) < 1e-6 * np.max(np.abs(dOm))
    Q = np.random.default_rng(10 + eo).normal(size=(2, 7)) * 0.3  # uncondensed (Hill's method)
    Jf = full_operators.full_jacobian(prob, Q, 1.3)
    Jffd = fd(lambda q: hbm.full_residual(prob, q.reshape(2, -1), 1.3).ravel(), Q.ravel())
    assert np.max(np.abs(Jffd - Jf)) < 1e-6 * np.max(np.abs(Jf))


def test_non_cyclic_problem_has_no_shift():
    s = isolated_system(sector())
    assert s.cyclic is None and hbm.setup(s, 3).shift is None


@pytest.mark.parametrize("eo", [0, 1, 2, 3])
@pytest.mark.parametrize("normal", [False, True], ids=["jenkins", "normal_load"])
def test_sector_solution_satisfies_the_full_assembly(eo, normal):
    """Expanded to 6 sectors, Q_j = T(j phi) Q_0, the sector solution is a solution
    of the 12-DOF assembly with its 6 ordinary elements (exact forces)."""
    sec = sector(kv=1.5 if normal else 0.0, n0=0.2, normal=normal, static=True)
    prob, Q = solve_sector(sec, eo, 1.3)
    scale = hbm.force_scale(prob)
    assert np.abs(hbm.full_residual(prob, Q, 1.3)).max() < 1e-11 * scale
    full = hbm.setup(full_assembly(sec, eo), 3)
    assert np.abs(hbm.full_residual(full, expand(Q, 6, eo), 1.3)).max() < 1e-11 * scale
    if normal:  # the case separates: the normal load goes negative over the cycle
        _, V = hbm.contact_motion(prob, Q[prob.c])
        assert (eo == 0) == (np.abs(V).max() < 1e-12)
        if eo:
            assert (0.2 + 1.5 * evaluate(V, np.linspace(0, 2 * np.pi, 256))).min() < 0


@pytest.mark.parametrize("samples", [120, 125])
def test_aft_sector_equals_aft_assembly_only_for_shift_invariant_samples(samples):
    """AFT samples a grid; the sector's element sees its neighbour shifted by
    phi = 2 pi / 6, the assembly's elements are sampled on one grid.  Both agree
    exactly only if the grid is invariant under phi: samples a multiple of
    N / gcd(N, EO) = 6 (technical notes)."""
    sec = sector(static=True)
    prob, Q = solve_sector(sec, 1, 1.3, "aft", samples)
    full = hbm.setup(full_assembly(sec, 1), 3, "aft", samples)
    err = np.abs(hbm.full_residual(full, expand(Q, 6, 1), 1.3)).max() / hbm.force_scale(prob)
    assert aft_samples_ok(6, 1, samples) == (samples == 120)
    if samples == 120:
        assert err < 1e-12
    else:
        assert err > 1e-6
    assert aft_samples_ok(6, 0, 7) and aft_samples_ok(6, 3, 2) and not aft_samples_ok(6, 3, 3)
    assert all(aft_samples_ok(24, eo, 24 // gcd(24, eo)) for eo in range(24))


@pytest.mark.parametrize("N,eo", [(4, 1), (5, 2), (6, 3)])
def test_wave_families_decompose_the_assembly_hill_problem(N, eo):
    """The sector's Hill problems for the wave numbers r = 0..N/2 (`full_operators.wave_jacobians`)
    have together exactly the eigenvalues of the N-sector assembly's Hill problem,
    so the stability of a travelling wave against every perturbation (not only
    those with its own symmetry) needs no assembly."""
    sec = sector(N=N, kv=3.0, n0=0.1, normal=True, static=True)
    prob, Q = solve_sector(sec, eo, 1.6)
    fam = full_operators.wave_jacobians(prob, Q, 1.6)
    assert [r for r, *_ in fam] == list(range(N // 2 + 1))
    lam = np.concatenate([hill_eigenvalues(J, M, C, 1.6, 3, full_output=True).eigenvalues
                          for _, J, M, C in fam])
    full = hbm.setup(full_assembly(sec, eo), 3)
    ref = hill_eigenvalues(full_operators.full_jacobian(full, expand(Q, N, eo), 1.6), full.system.M,
                           full.system.C, 1.6, 3, full_output=True).eigenvalues
    assert lam.size == ref.size == 2 * N * 2 * 7
    assert np.abs(ref[:, None] - lam[None, :]).min(1).max() < 1e-10 * np.abs(ref).max()
    J0 = full_operators.full_jacobian(prob, Q, 1.6)  # r = 0: the sector's own symmetry
    np.testing.assert_allclose(fam[0][1], J0, rtol=0, atol=1e-12 * np.abs(J0).max())
    assert len(full_operators.wave_jacobians(hbm.setup(isolated_system(sec), 3), Q, 1.6)) == 1


def test_a_travelling_wave_can_lose_stability_to_another_wave_number():
    """N = 4, EO = 1 with separation at 1.7 rad/s: stable against perturbations with
    its own symmetry (the sector's Hill problem), unstable to the standing wave
    r = 2, as the 8-DOF assembly's Hill problem says too."""
    sec = sector(N=4, kv=3.0, n0=0.1, normal=True, static=True)
    prob, Q = solve_sector(sec, 1, 1.7)
    verdict = [is_stable(J, M, C, 1.7, 3)[0] for _, J, M, C in full_operators.wave_jacobians(prob, Q, 1.7)]
    assert verdict == [True, True, False]
    full = hbm.setup(full_assembly(sec, 1), 3)
    assert not is_stable(full_operators.full_jacobian(full, expand(Q, 4, 1), 1.7), full.system.M,
                         full.system.C, 1.7, 3)[0]


# ---------------------------------------------------------------------------
# Plain data
# ---------------------------------------------------------------------------

def test_full_assembly_layout_and_travelling_wave_load():
    sec = sector(N=4, static=True)
    full = full_assembly(sec, 1)
    assert full.n_dof == 8 and full.n_elements == 4 and full.cyclic is None
    assert full.dof_names[:3] == ("s0.x1", "s0.x2", "s1.x1")
    # element j: u = x2_{j+1} - x2_j, the last one closes the ring
    np.testing.assert_array_equal(full.Bt[3], [0, 1, 0, 0, 0, 0, 0, -1])
    # sector j loaded with F_{j,h} = exp(i h j phi) F_{0,h}: phase j phi in harmonic 1
    np.testing.assert_allclose(full.forcing[2:4, 1], sec.forcing[:, 1] * np.exp(1j * np.pi / 2))
    np.testing.assert_allclose(full.forcing[4:6, 2], sec.forcing[:, 2] * np.exp(2j * np.pi))
    np.testing.assert_allclose(full.forcing[6:8, 0], sec.forcing[:, 0])
    np.testing.assert_allclose(sector_forcing(sec, 1, 3), full.forcing[6:8])
    s = sector_system(sec, 1)
    assert s.n_dof == 2 and s.cyclic.sectors == 4 and s.cyclic.phase == pytest.approx(np.pi / 2)


@pytest.mark.parametrize("eo", [0, 1, 2, 3])
def test_stuck_frequencies_of_an_engine_order_are_those_of_the_assembly(eo):
    sec = sector()
    f_sector = natural_frequencies(sector_system(sec, eo), "stuck")
    f_full = natural_frequencies(full_assembly(sec, eo), "stuck")
    for f in f_sector:
        assert np.min(np.abs(f_full - f)) < 1e-10 * f
    np.testing.assert_allclose(natural_frequencies(sector_system(sec, eo), "open"),
                               natural_frequencies(isolated_system(sec), "open"))


@pytest.mark.parametrize("eo", [0, 1, 2])
def test_natural_modes_solve_the_sector_problem_at_its_frequencies(eo):
    """`natural_modes`: the frequencies are `natural_frequencies`' and each shape x
    solves (K_stuck - w^2 M) x = 0 (the Hermitian sector stiffness of the engine order),
    scaled to max |x| = 1 with that entry real."""
    s = sector_system(sector(), eo)
    w, X = natural_modes(s, "stuck")
    np.testing.assert_allclose(w, natural_frequencies(s, "stuck"), rtol=1e-13)
    K = linear_stiffness(s, "stuck")
    for j in range(X.shape[1]):
        r = K @ X[:, j] - w[j] ** 2 * (s.M @ X[:, j])
        assert np.linalg.norm(r) < 1e-12 * np.linalg.norm(K) * np.linalg.norm(X[:, j])
    peak = X[np.argmax(np.abs(X), axis=0), np.arange(X.shape[1])]
    np.testing.assert_array_equal(peak, 1.0)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="engine_order"):
        sector_system(sector(), 6)
    with pytest.raises(ValueError, match="engine_order"):
        full_assembly(sector(), 1.5)
    with pytest.raises(ValueError, match="sectors"):
        sector(N=1)
    from pipeline.solve.time_integration import timesim
    with pytest.raises(ValueError, match="full_assembly"):
        timesim.simulate(sector_system(sector(), 1), 1.0, 1.0)


# ---------------------------------------------------------------------------
# Hard cases: standing waves, closed references
# ---------------------------------------------------------------------------

def test_eo0_is_the_isolated_linear_sector():
    """EO = 0: all sectors in phase, no relative motion in any contact (u = v = 0,
    stuck, zero force; the preloads cancel between the two shroud faces), so the
    response is the linear FRF of one sector without its interblade contacts."""
    sec = sector(kv=1.0, n0=0.3, normal=True)
    c = frequency_response(sector_system(sec, 0), 3, 1.0, 1.8, stability=True, peak_dofs=[1])
    check_curve(c)
    assert c.stable.all() and c.fold_parameter.size == 0
    ref_peak, ref_om, amp = linear_peak(sec.K, sec.M, sec.C, sec.forcing[:, 1], 1, 1.1, 1.4)
    np.testing.assert_allclose(c.amplitude[:, 1], [amp(om) for om in c.omega], rtol=1e-9)
    a, om, _ = c.peak(1)
    assert a == pytest.approx(ref_peak, rel=1e-9) and om == pytest.approx(ref_om, rel=1e-6)
    assert a == pytest.approx(19.0307725490, rel=1e-9) and om == pytest.approx(1.2592280, rel=1e-6)
    prob = hbm.setup(sector_system(sec, 0), 3)
    for Q in c.Q:
        U, V = hbm.contact_motion(prob, Q[prob.c])
        assert np.abs(U).max() < 1e-12 * np.abs(Q).max() and np.abs(V).max() < 1e-12 * np.abs(Q).max()


def test_eo_half_is_a_ground_jenkins_with_four_ku_and_twice_the_slip_load():
    """EO = N/2 with a Jenkins coupling (kv = 0) and a first-harmonic load: the
    standing wave x_{j+1}(tau) = x_j(tau + pi) = -x_j(tau) (odd harmonics only), so
    the shroud element of sector j sees u = x2_{j+1} - x2_j = -2 x2_j and sector j
    receives f(-2 x2) from it and -f(2 x2) from the element on its other side.  The
    Jenkins force is odd and positively homogeneous, f_{ku, mu n}(a u) =
    a f_{ku, mu n / a}(u), and c f_{ku, mu n} = f_{c ku, c mu n}; so the total is
    -2 f_{ku, mu n}(2 x2) = -f_{4 ku, 2 mu n}(x2): a single sector with a ground
    Jenkins element ku' = 4 ku, mu n' = 2 mu n (independent closed reference)."""
    sec = sector(N=6)
    s = sector_system(sec, 3)
    ref = System(M=sec.M, C=sec.C, K=sec.K, Bt=np.array([[0.0, 1.0]]), Bn=np.zeros((1, 2)),
                 contact=YangMenq(4 * KU, 0.0, MU, 2 * N0), forcing=sec.forcing)
    kw = dict(tol_rel=1e-12, peak_dofs=[1])  # peaks compared to 1e-9
    a = frequency_response(s, 5, 1.1, 1.5, stability=True, **kw)
    b = frequency_response(ref, 5, 1.1, 1.5, stability=False, **kw)
    check_curve(a)
    check_curve(b)
    assert a.stable.all() and a.fold_parameter.size == 0
    assert a.peak(1)[0] == pytest.approx(b.peak(1)[0], rel=1e-9)
    assert a.peak(1)[1] == pytest.approx(b.peak(1)[1], rel=1e-7)
    assert a.peak(1)[0] == pytest.approx(9.50410766, rel=1e-8)
    assert a.peak(1)[1] == pytest.approx(1.2608839, rel=1e-6)
    # the shrouds slip and damp: half the peak of the uncoupled sector (19.03)
    assert a.peak(1)[0] < 0.6 * linear_peak(sec.K, sec.M, sec.C, sec.forcing[:, 1], 1, 1.1, 1.4)[0]
    # point by point: the reference solved at the sector's frequencies
    prob = hbm.setup(ref, 5)
    tol = 1e-12 * hbm.force_scale(prob)
    for Q, om in zip(a.Q, a.omega):
        nr = newton(lambda y: hbm.residual(prob, y, om)[:2], Q[prob.c].ravel(), tol, max_iter=20)
        Qr = hbm.recover(prob, nr.x.reshape(prob.c.size, -1), om)
        assert np.abs(Qr - Q).max() < 1e-8 * np.abs(Q).max()
        assert np.abs(Q[:, [0, 3, 4, 7, 8]]).max() < 1e-14 * np.abs(Q).max()  # no even harmonics
    np.testing.assert_allclose(natural_frequencies(s, "stuck"), natural_frequencies(ref, "stuck"))


# ---------------------------------------------------------------------------
# Travelling waves: sector against the full assembly, frequency responses
# ---------------------------------------------------------------------------

def test_travelling_wave_jenkins_sector_equals_full_assembly():
    """N = 6, EO = 2 (phi = 120 deg), Jenkins shroud coupling: the one-sector
    response equals the 12-DOF assembly's."""
    sec = sector(N=6)
    a = frequency_response(sector_system(sec, 2), 3, 1.15, 1.4, stability=False, peak_dofs=[1])
    b = frequency_response(full_assembly(sec, 2), 3, 1.15, 1.4, stability=False, peak_dofs=[1])
    check_curve(a)
    check_curve(b)
    assert a.peak(1)[0] == pytest.approx(b.peak(1)[0], rel=1e-8)
    assert a.peak(1)[1] == pytest.approx(b.peak(1)[1], rel=1e-6)
    assert a.peak(1)[0] == pytest.approx(10.7774714, rel=1e-7)
    assert a.peak(1)[1] == pytest.approx(1.2605452, rel=1e-6)


def test_travelling_wave_with_separation_sector_equals_full_assembly():
    """N = 4, EO = 1 (phi = 90 deg), normal-load variation with separation: the
    sector's response, folds included, equals the 8-DOF assembly's, and every
    sector point expanded to the ring satisfies the ring's residual."""
    sec = sector(N=4, kv=3.0, n0=0.1, normal=True, static=True)
    s = sector_system(sec, 1)
    a = frequency_response(s, 3, 1.45, 1.8, stability=True, peak_dofs=[1])
    b = frequency_response(full_assembly(sec, 1), 3, 1.45, 1.8, stability=False, peak_dofs=[1])
    check_curve(a)
    check_curve(b)
    assert a.peak(1)[0] == pytest.approx(b.peak(1)[0], rel=1e-8)
    assert a.peak(1)[1] == pytest.approx(b.peak(1)[1], rel=1e-6)
    np.testing.assert_allclose(np.sort(a.fold_parameter), np.sort(b.fold_parameter), rtol=1e-4)
    assert a.fold_parameter.size >= 2 and not a.stable.all()
    prob = hbm.setup(s, 3)
    full = hbm.setup(full_assembly(sec, 1), 3)
    nmin = np.inf
    for Q, om in zip(a.Q, a.omega):
        R = hbm.full_residual(full, expand(Q, 4, 1), om)
        assert np.linalg.norm(R) <= 2 * a.tolerance  # N = 4 copies of the sector residual
        _, V = hbm.contact_motion(prob, Q[prob.c])
        nmin = min(nmin, (0.1 + 3.0 * evaluate(V, np.linspace(0, 2 * np.pi, 128))).min())
    assert nmin < -1.0  # the contact separates
    # the curve's stability covers every wave number: near 1.7 rad/s the sector's own
    # Hill problem (r = 0) says stable, the standing wave r = 2 does not (see
    # test_a_travelling_wave_can_lose_stability_to_another_wave_number)
    near = np.flatnonzero(a.converged & (np.abs(a.omega - 1.7) < 0.01))
    assert near.size >= 1
    for i in near:
        own = is_stable(full_operators.full_jacobian(prob, a.Q[i], a.omega[i]), s.M, s.C, a.omega[i], 3)[0]
        assert own and not a.stable[i]
    assert a.peak(1)[0] == pytest.approx(2.39190129, rel=1e-7)
    assert a.peak(1)[1] == pytest.approx(1.7371435, rel=1e-6)
    np.testing.assert_allclose(np.sort(a.fold_parameter), [1.4998483, 1.5004554, 1.5517259,
                                                           1.5517328], rtol=1e-6)


# ---------------------------------------------------------------------------
# Disk scenes: studies/disk_cyclic.toml
# ---------------------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[2]
DISK = ROOT / "studies" / "disk_cyclic.toml"


def test_disk_scene_builds_only_its_sector():
    st = load_study(DISK)
    assert st.sweep.axes == {"eo": (0, 3, 12)}
    s = st.system({"eo": 3})
    assert s.n_dof == 2 and s.dof_names == ("x1", "x2")
    assert (s.cyclic.sectors, s.cyclic.engine_order) == (24, 3)
    np.testing.assert_array_equal(s.Bt, [[0, -1]])
    np.testing.assert_array_equal(s.cyclic.Bt_next, [[0, 1]])
    assert s.contact.n0[0] == 2.0 and s.forcing[0, 1] == 1.0
    # the stuck EO = 12 family: x2 held by 4 ku (neighbours in antiphase)
    K = st.scene.structure.K + np.diag([0.0, 4 * 7.1e5])
    ref = np.sqrt(eigh(K, st.scene.structure.M, eigvals_only=True))
    np.testing.assert_allclose(natural_frequencies(st.system({"eo": 12}), "stuck"), ref)
    full = full_system(st.scene, {"eo": 3})  # only on request: the reference assembly
    assert full.n_dof == 48 and full.n_elements == 24
    # a one-structure scene builds no cyclic system
    lumped = load_study(ROOT / "studies" / "paper_example1.toml")
    assert lumped.system({"preload": 1.0}).cyclic is None
    # dotted-key and signed-list rows agree; the canonical document round-trips
    doc = tomllib.loads(DISK.read_text())
    doc["scene"]["contact"][0]["tangential"] = {"x2": -1.0, "next": {"x2": 1.0}}
    t = study_from_document(copy.deepcopy(doc), file="dict.toml")
    np.testing.assert_array_equal(t.system({"eo": 3}).cyclic.Bt_next, s.cyclic.Bt_next)
    u = study_from_document(study_to_mapping(st), file="canonical.toml")
    assert (u.sweep, u.solver, u.output) == (st.sweep, st.solver, st.output)
    assert study_to_mapping(u) == study_to_mapping(st)


