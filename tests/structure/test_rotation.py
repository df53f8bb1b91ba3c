"""A turning blade (`structure.rotation`): centrifugal stiffening and spin softening.

Reference: the rotating uniform Euler-Bernoulli cantilever, computed here
independently (Hermite beam elements, 200 of them, with the geometric stiffness of the
tension T(s) = rho A Omega^2 int_s^L (R + x) dx): its Southwell coefficient
S = d(omega^2)/d(Omega^2) of the first bending mode is 1.1933 at zero hub radius (the
published value: Wright, Smith, Thresher & Wang, J. Appl. Mech. 49 (1982) 197; Hodges
& Rutkowski, AIAA J. 19 (1981) 1459) and grows by 1.571 R/L.  The solid blade (a
uniform plate 200 x 20 x 4 mm, Hex2, stagger 0, no shroud) has two bending modes: out
of the plane of rotation (along the chord, X) with S, in the plane (across the
thickness, Y) with S - 1 (spin softening).  Measured: out of plane -0.5 % (L/c = 10;
shear and rotary inertia, -0.05 % at L/c = 20), in plane +0.4 % of S (the 3D clamped
root; converging to +0.3 % as the span mesh is refined); bound 1 %."""
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse.linalg as sla

from pipeline.structure.fe_model import BladeParams
from pipeline.structure.solid import solid_from_mesh, solid_mesh

L, C, T = 0.2, 0.02, 0.004
PLATE = BladeParams(length=L, chord=C, thickness=T, shroud=False, stagger_angle=0.0,
                    n_chord=2, n_thick=1, n_span=16)


def beam_southwell(R, n_el=200):
    """S of the first mode of the rotating uniform Euler-Bernoulli cantilever (EI =
    rho A = 1 -- S does not depend on them) at hub radius R [m], length L."""
    h = L / n_el
    ke = np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                   [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]]) / h**3
    me = np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                   [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]]) * h / 420
    n = 2 * (n_el + 1)
    K, M, G = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    xg, wg = np.polynomial.legendre.leggauss(4)
    for e in range(n_el):
        d = slice(2 * e, 2 * e + 4)
        K[d, d] += ke
        M[d, d] += me
        for xi, w in zip(xg, wg):
            s = (xi + 1) / 2
            x = (e + s) * h
            tension = R * (L - x) + (L * L - x * x) / 2
            dN = np.array([6 * s * s - 6 * s, h * (1 - 4 * s + 3 * s * s), 6 * s - 6 * s * s,
                           h * (3 * s * s - 2 * s)]) / h
            G[d, d] += w * h / 2 * tension * np.outer(dN, dN)
    K, M, G = K[2:, 2:], M[2:, 2:], G[2:, 2:]
    phi = la.eigh(K, M)[1][:, 0]
    return phi @ G @ phi / (phi @ M @ phi)


def bending_modes(R, plate=PLATE):
    """(S of the in-plane mode, S of the out-of-plane mode, the blade, the modes)."""
    mesh, sets = solid_mesh(plate)
    blade = solid_from_mesh(mesh, sets, plate, rotation_centre=(0.0, 0.0, -R))
    w, v = sla.eigsh(blade.K.tocsc(), k=2, M=blade.M.tocsc(), sigma=0)
    Kr = blade.rotation.stiffness
    S = [v[:, k] @ (Kr @ v[:, k]) / (v[:, k] @ (blade.M @ v[:, k])) for k in range(2)]
    return S[0], S[1], blade, w, v


def test_the_beam_reference_is_the_published_coefficient():
    assert beam_southwell(0.0) == pytest.approx(1.1933, abs=1e-4)
    slope = (beam_southwell(0.5 * L) - beam_southwell(0.0)) / 0.5
    assert slope == pytest.approx(np.pi / 2, rel=1e-3)       # measured 1.5709


@pytest.mark.parametrize("R", [0.0, 0.5 * L])
def test_southwell_coefficients_of_the_solid_cantilever(R):
    s_in, s_out, blade, w, v = bending_modes(R)
    ref = beam_southwell(R)
    # mode 0 moves across the thickness (Y, in the plane of rotation), mode 1 along the
    # chord (X); the root takes all three components of its nodes, so the free DOFs
    # come in (x, y, z) triples
    u = v.reshape(-1, 3, 2)
    assert np.abs(u[:, 1, 0]).max() > 10 * np.abs(u[:, 0, 0]).max()
    assert np.abs(u[:, 0, 1]).max() > 10 * np.abs(u[:, 1, 1]).max()
    assert s_out == pytest.approx(ref, rel=1e-2)
    assert s_in + 1.0 == pytest.approx(ref, rel=1e-2)
    # the speed-dependent stiffness gives these slopes: omega^2 at a small speed
    Om = 0.05 * np.sqrt(w[0])
    w1 = sla.eigsh((blade.K + Om**2 * blade.rotation.stiffness).tocsc(), k=2,
                   M=blade.M.tocsc(), sigma=0, return_eigenvectors=False)
    assert np.sort(w1)[0] == pytest.approx(w[0] + s_in * Om**2, rel=1e-6)


def test_static_stretch_equals_the_bar_under_centrifugal_load():
    """The tip's radial displacement per Omega^2 against the bar: int_0^L T / (E A) ds =
    rho / E (R L^2 / 2 + L^3 / 3).  Exact without Poisson's ratio (measured 2e-12);
    with nu = 0.3 the clamped root holds Poisson's contraction back (measured -0.56 %)."""
    R = 0.1
    bar = PLATE.rho / PLATE.E * (R * L**2 / 2 + L**3 / 3)
    for nu, rel in ((0.0, 1e-9), (0.3, 1e-2)):
        blade = bending_modes(R, replace(PLATE, nu=nu))[2]
        tip = blade.dof_sets["response"][0, 2]
        assert blade.rotation.static[tip] == pytest.approx(bar, rel=rel, abs=0.0)


def test_coriolis_coupling_moves_the_frequencies_little():
    """The neglected Coriolis matrix G = 2 Omega int rho u . (e_X x v) dV on the default
    wheel blade (clamped, shrouds free) at 15,000 rpm: the quadratic eigenproblem on its
    12 lowest modes at that speed moves them by at most 0.2 % (measured 0.20 %, 0.13 %,
    0.08 %, ...)."""
    import scipy.sparse as sp

    from pipeline.structure.disk import wheel_params
    from pipeline.structure.fe_model import DiskPlacement

    disk = DiskPlacement(0.12, 36)
    p = BladeParams(n_chord=4, n_thick=1, n_span=8)
    mesh, sets = solid_mesh(p, disk)
    blade = solid_from_mesh(mesh, sets, wheel_params(p, disk), rotation_centre=disk.centre)
    Om = 15000 * 2 * np.pi / 60
    w, Phi = sla.eigsh((blade.K + Om**2 * blade.rotation.stiffness).tocsc(), k=12,
                       M=blade.M.tocsc(), sigma=0)
    turn = sp.csr_matrix([[0, 0, 0], [0, 0, -1], [0, 1, 0.0]])       # v -> e_X x v
    G = 2 * Om * (blade.M @ sp.kron(sp.identity(blade.n_dof // 3), turn))
    A = np.block([[np.zeros((12, 12)), np.eye(12)], [-np.diag(w), -Phi.T @ (G @ Phi)]])
    f = np.sort(np.abs(la.eigvals(A).imag))[::2]
    shift = np.abs(f / np.sqrt(w) - 1)
    assert 1e-4 < shift.max() < 3e-3


def forms_reference(sbasis, u1, lam, mu):
    """(K_u1, K_u2) by scikit-fem's generic form assembly of the module's weak forms
    (one numpy call per local DOF pair): the reference of the vectorised kernel."""
    from skfem import Basis, BilinearForm, ElementVector
    from skfem.helpers import ddot, eye, grad, mul, sym_grad, trace, transpose

    vb = Basis(sbasis.mesh, ElementVector(sbasis.elem), quadrature=sbasis.quadrature)

    def strain(a):
        return 0.5 * (a + transpose(a))

    def stress(e):
        return 2.0 * mu * e + lam * eye(trace(e), 3)

    @BilinearForm
    def linear(u, v, w):
        nu_, nv = strain(mul(transpose(w.h), grad(u))), strain(mul(transpose(w.h), grad(v)))
        return ddot(stress(nu_), sym_grad(v)) + ddot(sym_grad(u), stress(nv))

    @BilinearForm
    def quadratic(u, v, w):
        nu_, nv = strain(mul(transpose(w.h), grad(u))), strain(mul(transpose(w.h), grad(v)))
        return ddot(stress(nu_), nv)

    H1 = vb.interpolate(u1).grad
    return linear.assemble(vb, h=H1), quadratic.assemble(vb, h=H1)


@pytest.mark.parametrize("element", ["Hex2", "HexS2", "TetP2"])
def test_initial_displacement_kernel_equals_the_weak_forms(element):
    """The vectorised initial-displacement stiffness (`rotation.initial_displacement`)
    equals scikit-fem's assembly of its weak forms to 1e-12 of the largest entry, on a
    twisted shrouded blade (its midside nodes curved) with a random deflection, on
    triquadratic and serendipity hexahedra and quadratic tetrahedra."""
    from skfem import Basis, ElementHex2, ElementHexS2, ElementTetP2, MeshHex2, MeshTet2
    from skfem.models.elasticity import lame_parameters
    from pipeline.structure.rotation import initial_displacement

    mesh, _ = solid_mesh(BladeParams(n_chord=2, n_thick=1, n_span=3))
    if element == "TetP2":
        q = MeshTet2.from_mesh(mesh.to_meshtet())
        el = ElementTetP2()
    else:
        q = MeshHex2.from_mesh(mesh)
        el = ElementHex2() if element == "Hex2" else ElementHexS2()
    X = q.doflocs.copy()
    th = 0.3 * X[2] / X[2].max()
    X[0], X[1] = X[0] * np.cos(th) - X[1] * np.sin(th), X[0] * np.sin(th) + X[1] * np.cos(th)
    sbasis = Basis(type(q)(X, q.t), el, intorder=4)
    u1 = np.random.default_rng(3).normal(size=3 * sbasis.N) * 1e-4
    lam, mu = lame_parameters(2.1e11, 0.3)
    for ours, ref in zip(initial_displacement(sbasis, u1, lam, mu),
                         forms_reference(sbasis, u1, lam, mu)):
        assert abs(ours - ref).max() <= 1e-12 * abs(ref).max()
