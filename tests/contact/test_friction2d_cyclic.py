"""The 2D friction law between neighbouring sectors of a tuned ring: the harmonic
balance of one cyclic sector (the law's next-sector maps shifted by the engine
order's phase) equals that of the full N-sector assembly (no symmetry used), sector 0's
harmonics to 1e-9 of their size, at several engine orders and frequencies."""
import numpy as np
import pytest

from pipeline.contact.element import YangMenq
from pipeline.contact.friction2d.law import Friction2D
from pipeline.contact.laws import LawElements
from pipeline.model.cyclic import Sector, full_assembly, sector_system, wheel_system
from pipeline.solve.continuation.newton import newton
from pipeline.solve.harmonic_balance import hbm

N, H, SAMPLES = 4, 3, 128     # SAMPLES a multiple of N: the shifted grid is the same grid


def ring_sector():
    """Sector: a mass in a plane (x, y), a 2D friction element to the next sector's
    mass (u = q_j - q_{j+1} in both directions, constant normal load)."""
    none = np.zeros((0, 2))
    law = Friction2D(ku=1.0e4, kv=0.0, mu=0.5, n0=3.0)
    maps = (np.array([[1.0, 0.0]]), np.array([[0.0, 1.0]]), np.zeros((1, 2)))
    nxt = (np.array([[-1.0, 0.0]]), np.array([[0.0, -1.0]]), np.zeros((1, 2)))
    F = np.zeros((2, 2), complex)
    F[:, 1] = [10.0, 7.0j]
    return Sector(M=np.eye(2), C=5.0 * np.eye(2), K=np.diag([3.55e4, 4.0e4]), Bt=none,
                  Bn=none, Bt_next=none, Bn_next=none,
                  contact=YangMenq(ku=np.zeros(0), kv=np.zeros(0), mu=np.zeros(0),
                                   n0=np.zeros(0)),
                  forcing=F, sectors=N, dof_names=("x", "y"),
                  laws=(LawElements(law, maps, nxt),))


def solve(system, Om):
    prob = hbm.setup(system, H, "aft", SAMPLES)
    tol = 1e-11 * hbm.force_scale(prob)
    nr = newton(lambda y: hbm.residual(prob, y, Om)[:2], np.zeros(prob.size), tol, max_iter=100)
    assert nr.success
    return hbm.recover(prob, nr.x.reshape(prob.c.size, -1), Om)


@pytest.mark.parametrize("eo", [1, 2])
@pytest.mark.parametrize("Om", [180.0, 230.0])
def test_sector_equals_full_ring(eo, Om):
    sec = ring_sector()
    Q0 = solve(sector_system(sec, eo), Om)
    Qf = solve(full_assembly(sec, eo, sparse=False), Om)
    assert np.abs(Q0).max() > 1e-5
    np.testing.assert_allclose(Qf[:2], Q0, atol=1e-9 * np.abs(Q0).max(), rtol=0)
    # the wheel rebuilt from the sector's System (what the flow-based stability
    # checks integrate) carries the law too: the same solution
    Qw = solve(wheel_system(sector_system(sec, eo)), Om)
    assert len(wheel_system(sector_system(sec, eo)).laws) == 1
    np.testing.assert_allclose(Qw, Qf, atol=1e-9 * np.abs(Q0).max(), rtol=0)


@pytest.mark.parametrize("eo", [0, 1, 2])
def test_stuck_frequencies_of_the_sector_are_the_rings(eo):
    """The stuck limit with the law's springs on the travelling wave (phase of the
    next-sector maps): each of the sector's frequencies is one of the full ring's."""
    from pipeline.model.system import natural_frequencies
    sec = ring_sector()
    own = natural_frequencies(sector_system(sec, eo), "stuck")
    ring = natural_frequencies(full_assembly(sec, eo, sparse=False), "stuck")
    assert own.max() > np.sqrt(3.55e4) * 1.001 or eo == 0
    for w in own:
        assert np.abs(ring - w).min() < 1e-9 * w


@pytest.mark.parametrize("eo", [1, 2])
def test_wave_families_of_the_sector_are_the_rings_hill_problem(eo):
    """Stability of the travelling wave against every wave number: the sector's Hill
    problems for r = 0..N/2 (`full_operators.wave_jacobians`, the law's slots split
    into this sector's and the next's) have together the eigenvalues of the full
    ring's Hill problem."""
    from pipeline.model.cyclic import expand
    from pipeline.solve.harmonic_balance.full_operators import full_jacobian, wave_jacobians
    from pipeline.solve.stability.hill import hill_eigenvalues
    sec, Om = ring_sector(), 230.0
    prob = hbm.setup(sector_system(sec, eo), H, "aft", SAMPLES)
    Q0 = solve(sector_system(sec, eo), Om)
    fam = wave_jacobians(prob, Q0, Om)
    assert [r for r, *_ in fam] == list(range(N // 2 + 1))
    lam = np.concatenate([hill_eigenvalues(J, M, C, Om, H, full_output=True).eigenvalues
                          for _, J, M, C in fam])
    full = hbm.setup(full_assembly(sec, eo, sparse=False), H, "aft", SAMPLES)
    ref = hill_eigenvalues(full_jacobian(full, expand(Q0, N, eo), Om), full.system.M,
                           full.system.C, Om, H, full_output=True).eigenvalues
    assert lam.size == ref.size == 2 * N * 2 * (2 * H + 1)
    assert np.abs(ref[:, None] - lam[None, :]).min(1).max() < 1e-9 * np.abs(ref).max()
