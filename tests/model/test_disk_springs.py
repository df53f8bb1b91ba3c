"""Linear springs between neighbouring sectors (a flexible disk) in the one-sector
cyclic reduction: the lumped disk of Laxalde et al. (2007) against the closed form
of its cyclic eigenproblem, and the sector's harmonic balance, Jacobians, Hill
problems and linear FRF against the N-sector assembly (no symmetry used)."""
from functools import lru_cache

import numpy as np
import pytest
from scipy.linalg import eigh

from pipeline.contact import YangMenq
from pipeline.model.cyclic import Sector, expand, full_assembly, sector_system, spring_stiffness
from pipeline.model.system import natural_frequencies
from pipeline.solve.harmonic_balance import full_operators
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response.linear_response import frequency_response as linear_frequency_response
from pipeline.solve.response.response import frequency_response
from pipeline.solve.stability.hill import hill_eigenvalues

from helpers import K0, KU, closed_form_hz, fd, laxalde_sector, solve_sector


def test_spring_stiffness_is_the_energy_of_the_stretch():
    """a^T k a + b^T k b and a^T k b: the Hessian of 1/2 k (a.q_j + b.q_{j+1})^2 summed
    over the spring to j+1 and the spring from j-1 (checked on a 3-sector ring)."""
    a, b, k = np.array([1.0, -2.0]), np.array([0.5, 3.0]), 7.0
    Ks, Kn = spring_stiffness([np.r_[a, b]], [k], 2)
    N, n = 3, 2
    Kring = np.zeros((N * n, N * n))
    for j in range(N):
        d = np.zeros(N * n)
        d[j * n:(j + 1) * n] += a
        d[(j + 1) % N * n:((j + 1) % N + 1) * n] += b
        Kring += k * np.outer(d, d)
    np.testing.assert_allclose(Kring[:2, :2], Ks, rtol=1e-15)
    np.testing.assert_allclose(Kring[:2, 2:4], Kn, rtol=1e-15)
    np.testing.assert_allclose(Kring[:2, 4:6], Kn.T, rtol=1e-15)


@pytest.mark.parametrize("stuck", [False, True], ids=["open", "stuck"])
def test_laxalde_frequencies_per_nodal_diameter_equal_the_closed_form_and_the_assembly(stuck):
    """24 sectors, nodal diameters 0..12: the sector's frequencies (cyclic
    reduction, `natural_frequencies`) equal the hand-written 3 x 3 problem to 1e-12,
    and together (0 < nd < 12 twice) the 72 frequencies of the full assembly."""
    sec = laxalde_sector()
    mode = "stuck" if stuck else "open"
    per_nd = [natural_frequencies(sector_system(sec, nd), mode) / (2 * np.pi) for nd in range(13)]
    for nd, f in enumerate(per_nd):
        np.testing.assert_allclose(f, closed_form_hz(nd, stuck, 24), rtol=1e-12)
    full = full_assembly(sec, 0)
    Kf = full.K + (full.Bt.T @ (KU * full.Bt) if stuck else 0.0)
    ref = np.sqrt(eigh(Kf, full.M, eigvals_only=True)) / (2 * np.pi)
    union = np.sort(np.concatenate([f for nd, f in enumerate(per_nd)
                                    for _ in range(1 if nd in (0, 12) else 2)]))
    np.testing.assert_allclose(union, ref, rtol=1e-10)
    # the disk couples the sectors even with the contacts open: the family spreads
    assert per_nd[12][0] > 1.5 * per_nd[0][0]


@pytest.mark.parametrize("eo", [1, 2, 3])
@pytest.mark.parametrize("normal", [False, True], ids=["jenkins", "normal_load"])
def test_sector_with_springs_jacobians_match_finite_differences(eo, normal):
    """Condensed residual (springs in each harmonic's K_h) and the uncondensed
    Jacobian (springs as slots on the next sector) against central differences."""
    sec = laxalde_sector(N=6, n0=0.2, kv=3e4 if normal else 0.0, normal=normal)
    prob = hbm.setup(sector_system(sec, eo), 3)
    x = np.random.default_rng(eo).normal(size=prob.size) * 1e-5
    R, J, dOm = hbm.residual(prob, x, 2000.0)
    Jfd = fd(lambda y: hbm.residual(prob, y, 2000.0, jacobian=False)[0], x, 1e-9)
    assert np.max(np.abs(Jfd - J)) < 1e-6 * np.max(np.abs(J))
    Q = np.random.default_rng(10 + eo).normal(size=(3, 7)) * 1e-5
    Jf = full_operators.full_jacobian(prob, Q, 2000.0)
    Jffd = fd(lambda q: hbm.full_residual(prob, q.reshape(3, -1), 2000.0).ravel(), Q.ravel(), 1e-9)
    assert np.max(np.abs(Jffd - Jf)) < 1e-6 * np.max(np.abs(Jf))


@pytest.mark.parametrize("eo", [0, 1, 2, 3])
def test_sector_with_springs_solves_the_full_assembly(eo):
    """Expanded to 6 sectors (Q_j = T(j phi) Q_0) the sector's stick-slip solution
    solves the 18-DOF assembly with its disk springs and 6 ordinary elements."""
    sec = laxalde_sector(N=6, n0=0.3, kv=3e4, normal=True)
    prob, Q = solve_sector(sec, eo, 1300.0)
    scale = hbm.force_scale(prob)
    assert np.abs(hbm.full_residual(prob, Q, 1300.0)).max() < 1e-11 * scale
    full = hbm.setup(full_assembly(sec, eo), 3)
    assert np.abs(hbm.full_residual(full, expand(Q, 6, eo), 1300.0)).max() < 1e-11 * scale
    if eo:  # the shrouds slide: a nonlinear point, not the stuck limit (mu n0 = 0.09 N)
        u = hbm.contact_motion(prob, Q[prob.c])[0]
        assert np.abs(KU * u).max() > 0.5


@pytest.mark.parametrize("N,eo", [(4, 1), (6, 3), (5, 2)])
def test_wave_families_with_springs_decompose_the_assembly_hill_problem(N, eo):
    sec = laxalde_sector(N=N, n0=0.3, kv=3e4, normal=True)
    prob, Q = solve_sector(sec, eo, 2300.0)
    fam = full_operators.wave_jacobians(prob, Q, 2300.0)
    lam = np.concatenate([hill_eigenvalues(J, M, C, 2300.0, 3, full_output=True).eigenvalues
                          for _, J, M, C in fam])
    full = hbm.setup(full_assembly(sec, eo), 3)
    ref = hill_eigenvalues(full_operators.full_jacobian(full, expand(Q, N, eo), 2300.0),
                           full.system.M, full.system.C, 2300.0, 3, full_output=True).eigenvalues
    assert lam.size == ref.size
    assert np.abs(ref[:, None] - lam[None, :]).min(1).max() < 1e-9 * np.abs(ref).max()


def test_linear_disk_frf_equals_the_assembly_frf():
    """No contact: the sector's direct linear FRF (K_h per harmonic) equals the
    6-sector assembly's at every frequency, and both are stable."""
    sec = laxalde_sector(N=6)
    sec = Sector(**{**sec.__dict__, "Bt": np.zeros((0, 3)), "Bn": np.zeros((0, 3)),
                    "Bt_next": np.zeros((0, 3)), "Bn_next": np.zeros((0, 3)),
                    "contact": YangMenq(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0))})
    a = linear_frequency_response(sector_system(sec, 2), 1, 800.0, 8000.0)
    f = full_assembly(sec, 2)
    for w, Q in zip(a.omega[::7], a.Q[::7]):   # the assembly solved directly at each frequency
        X = np.linalg.solve(f.K - w**2 * f.M + 1j * w * f.C, f.forcing[:, 1])
        Qf = expand(Q, 6, 2)
        np.testing.assert_allclose(Qf[:, 1] - 1j * Qf[:, 2], X, rtol=0,
                                   atol=1e-9 * np.abs(X).max())
    b = linear_frequency_response(f, 1, 800.0, 8000.0)
    assert a.stable.all() and b.stable.all()
    assert np.isclose(a.amplitude[:, 2].max(), b.amplitude[:, 2].max(), rtol=1e-9)


@lru_cache
def laxalde_eo3_curve():
    """The 24-sector disk at EO = 3, 5 N, 3 harmonics, 185-215 Hz, tolerance 1e-9: the
    response study's reference, traced once for the two tests that read it."""
    return frequency_response(sector_system(laxalde_sector(n0=5.0), 3), 3, 2 * np.pi * 185.0,
                              2 * np.pi * 215.0, tol_rel=1e-9)


def test_continuation_with_springs_peaks_between_the_open_and_stuck_limits():
    """EO = 3 of 24 sectors, 3 harmonics: the traced FRF converges everywhere and its
    blade-tip peak lies between the open and stuck frequencies of nodal diameter 3
    (first family: 1213.0 and 1307.4 rad/s).  The curve is the response study's (5 N,
    185-215 Hz = 1162-1351 rad/s, which holds both limits with margin)."""
    s = sector_system(laxalde_sector(N=24, n0=5.0), 3)
    lo, hi = (natural_frequencies(s, m)[0] for m in ("open", "stuck"))
    c = laxalde_eo3_curve()
    assert c.omega.min() < 0.96 * lo and 1.03 * hi < c.omega.max()
    assert c.success and c.converged.all() and np.all(c.residual <= c.tolerance)
    w = c.omega[np.argmax(c.amplitude[:, 2])]
    assert lo < w < hi


def laxalde_response_text(extra=""):
    """The Laxalde modes study turned into a response study at EO = 3 (family 1)."""
    from pathlib import Path
    text = (Path(__file__).resolve().parents[2] / "studies" / "disk_laxalde.toml").read_text()
    text = text.replace('kind = "modes"\n', "").split("[modes]")[0]
    return text.replace("[scene.disk]\nsectors = 24", "[scene.disk]\nsectors = 24\nengine_order = 3") + """
[[scene.excitation]]
dof = "xb2"
amplitude = 1.0

[sweep]
frequency = { start = 185.0, stop = 215.0, unit = "Hz" }

[solver]
harmonics = 3
tolerance = 1e-9
""" + extra


def test_laxalde_response_study_runs_on_one_sector_and_round_trips(tmp_path):
    """A disk study with springs: parsed, written back canonically and re-parsed to
    the same scene, run on one 3-DOF sector; its peak equals a direct continuation
    of the hand-built sector (same springs, same contact)."""
    from pipeline.study.files.documents import parse_study, study_from_document, study_to_mapping
    from pipeline.study.execution.run import run_study
    s = parse_study(laxalde_response_text(), file="lax.toml", name="lax")
    again = study_from_document(study_to_mapping(s), file="lax.toml", name="lax")
    (sp,), (sp2,) = s.scene.assembly.springs, again.scene.assembly.springs
    assert sp.k == sp2.k == K0 and np.array_equal(sp.row, sp2.row)
    res = run_study(s, tmp_path, figures=False, progress=False)
    ds = res.dataset
    assert ds.attrs["disk_springs"].startswith("disk: k = 5e+07 N/m")
    amp = ds.amplitude.sel(dof="xb2").squeeze()
    ref = laxalde_eo3_curve()
    assert np.isclose(float(amp.max()), ref.amplitude[:, 2].max(), rtol=1e-6)


def test_wheel_of_a_sector_system_keeps_the_disk_springs():
    """The wheel rebuilt from a cyclic sector `System` (the orbit of the monodromy
    stability, `cyclic.wheel_system`) has the springs between sectors: its stiffness
    equals the assembly of the `Sector` (before, the ring of K_next was dropped)."""
    from pipeline.model.cyclic import wheel_system
    sec = laxalde_sector(N=6)
    wheel = wheel_system(sector_system(sec, 2))
    np.testing.assert_array_equal(wheel.K, full_assembly(sec, 2, sparse=False).K)
