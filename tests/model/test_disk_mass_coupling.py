"""A sector that shares mass and damping with its neighbours (a sector cut out of a
flexible disk: `CyclicCoupling.M_next`, `C_next`), in the one-sector cyclic reduction,
against the N-sector assembly built without symmetry: frequencies per nodal diameter,
the harmonic-balance Jacobians against finite differences, the stick-slip solution
and the linear FRF.  The lumped disk of Laxalde et al. (2007) with a consistent-mass
bar between neighbouring disk masses (mass m_b, Rayleigh-damped) is the model."""
from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import eigh

from pipeline.contact import YangMenq
from pipeline.model.cyclic import expand, full_assembly, sector_system
from pipeline.model.system import natural_frequencies
from pipeline.solve.harmonic_balance import full_operators, hbm
from pipeline.solve.nonlinear_modes.epmc import mode_problem
from pipeline.solve.response.linear_response import frequency_response as linear_frequency_response

from helpers import fd, laxalde_sector, solve_sector

M_BAR = 0.4      # kg, the disk between two neighbouring disk masses
BETA = 2e-5      # s, its stiffness-proportional damping


def massive_sector(N=6, **kw):
    """`laxalde_sector` whose disk spring is a bar with a consistent mass: the element
    mass m_b / 6 [[2, 1], [1, 2]] on (xd_j, xd_{j+1}) gives each sector 4 m_b / 6 on its
    own xd (half of each of its two bars) and m_b / 6 towards the next; C = beta K of
    the bar likewise."""
    sec = laxalde_sector(N=N, **kw)
    e = np.zeros((3, 3))
    e[0, 0] = 1.0
    return replace(sec, M=sec.M + 4 * M_BAR / 6 * e, M_next=M_BAR / 6 * e,
                   C=sec.C + BETA * sec.K_spring, C_next=BETA * sec.K_next)


def test_frequencies_per_nodal_diameter_are_the_assembly_frequencies():
    """6 sectors: the sector's open frequencies per nodal diameter 0..3 (mass coupling
    in each family's mass) together are the 18 frequencies of the assembly, to 1e-10;
    without the mass coupling they are not (the bar's mass moves them by > 1e-3)."""
    sec = massive_sector()
    per_nd = [natural_frequencies(sector_system(sec, nd)) for nd in range(4)]
    full = full_assembly(sec, 0, sparse=False)
    ref = np.sqrt(eigh(full.K, full.M, eigvals_only=True))
    union = np.sort(np.concatenate([f for nd, f in enumerate(per_nd)
                                    for _ in range(1 if nd in (0, 3) else 2)]))
    np.testing.assert_allclose(union, ref, rtol=1e-10)
    lumped = natural_frequencies(sector_system(replace(sec, M_next=None), 3))
    assert np.abs(lumped / per_nd[3] - 1).max() > 1e-3


@pytest.mark.parametrize("eo", [1, 2])
def test_condensed_and_full_jacobians_match_finite_differences(eo):
    """The condensed residual (M_h, C_h per harmonic) and the full residual (the
    coupling on the shifted neighbours) against central differences."""
    sec = massive_sector(n0=0.2, kv=3e4, normal=True)
    prob = hbm.setup(sector_system(sec, eo), 3)
    x = np.random.default_rng(eo).normal(size=prob.size) * 1e-5
    R, J, dOm = hbm.residual(prob, x, 2000.0)
    Jfd = fd(lambda y: hbm.residual(prob, y, 2000.0, jacobian=False)[0], x, 1e-9)
    assert np.max(np.abs(Jfd - J)) < 1e-6 * np.max(np.abs(J))
    dfd = (hbm.residual(prob, x, 2000.0 + 1e-3, jacobian=False)[0]
           - hbm.residual(prob, x, 2000.0 - 1e-3, jacobian=False)[0]) / 2e-3
    assert np.max(np.abs(dfd - dOm)) < 1e-6 * np.max(np.abs(dOm))
    # the uncondensed linear operator (Hill's, EPMC's) against the full residual's
    # linear part on the same sector without elements: two codings of the coupling
    lin = hbm.setup(sector_system(no_elements(sec), eo), 3)
    Q = np.random.default_rng(10 + eo).normal(size=(3, 7)) * 1e-5
    L = full_operators.full_linear_operator(lin.system, 2000.0, 3)
    np.testing.assert_allclose(L @ Q.ravel(), (hbm.full_residual(lin, Q, 2000.0) + lin.P).ravel(),
                               rtol=0, atol=1e-12 * np.abs(L).max() * np.abs(Q).max())


def no_elements(sec):
    """The sector without its contact elements (the linear structure)."""
    z = np.zeros((0, 3))
    return replace(sec, Bt=z, Bn=z, Bt_next=z, Bn_next=z,
                   contact=YangMenq(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)))


@pytest.mark.parametrize("eo", [0, 1, 3])
def test_sector_solution_solves_the_assembly(eo):
    """Expanded to 6 sectors (Q_j = T(j phi) Q_0) the sector's stick-slip solution
    solves the 18-DOF assembly with the bars' mass and damping, to 1e-11 of the force
    scale; the sector's own full residual is as small."""
    sec = massive_sector(n0=0.3, kv=3e4, normal=True)
    prob, Q = solve_sector(sec, eo, 1300.0)
    scale = hbm.force_scale(prob)
    assert np.abs(hbm.full_residual(prob, Q, 1300.0)).max() < 1e-11 * scale
    full = hbm.setup(full_assembly(sec, eo), 3)
    assert np.abs(hbm.full_residual(full, expand(Q, 6, eo), 1300.0)).max() < 1e-11 * scale
    plain = hbm.setup(full_assembly(replace(sec, M_next=None, C_next=None), eo), 3)
    assert np.abs(hbm.full_residual(plain, expand(Q, 6, eo), 1300.0)).max() > 1e-6 * scale


def test_linear_frf_equals_the_assembly_frf():
    """No contact: the sector's direct linear FRF equals the assembly's, solved
    directly, at every seventh frequency, and both are stable."""
    sec = no_elements(massive_sector())
    a = linear_frequency_response(sector_system(sec, 2), 1, 800.0, 8000.0)
    f = full_assembly(sec, 2, sparse=False)
    for w, Q in zip(a.omega[::7], a.Q[::7]):
        X = np.linalg.solve(f.K - w**2 * f.M + 1j * w * f.C, f.forcing[:, 1])
        Qf = expand(Q, 6, 2)
        np.testing.assert_allclose(Qf[:, 1] - 1j * Qf[:, 2], X, rtol=0,
                                   atol=1e-9 * np.abs(X).max())
    assert a.stable.all()


def test_hill_and_nonlinear_modes_say_they_do_not_apply():
    """Hill's method per wave number and the EPMC do not take a mass coupling: each
    says so in one line instead of answering for another structure."""
    sec = massive_sector(n0=0.3, kv=3e4, normal=True)
    prob, Q = solve_sector(sec, 1, 1300.0)
    with pytest.raises(ValueError, match="Hill's method on a sector whose mass couples"):
        full_operators.wave_jacobians(prob, Q, 1300.0)
    with pytest.raises(ValueError, match="nonlinear modes of a sector whose mass couples"):
        mode_problem(sector_system(sec, 1), 1)
