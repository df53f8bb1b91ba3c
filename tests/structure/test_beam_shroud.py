"""The beam blade's rigid tip shroud: its faces move with the tip section as Euler-
Bernoulli plane sections do, a rigid rotation of a beam wheel loads no shroud pair,
its frequencies are those of the solid blade within the beam theory's error, and the
tuned cyclic sector of a beam wheel reproduces the full wheel."""
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as la

from pipeline.model.contacts import ShroudPair, pair_frame
from pipeline.model.cyclic import expand, sector_system
from pipeline.model.loads import PointLoad
from pipeline.model.scene import Blade, CraigBampton, Cyclic, Scene
from pipeline.model.build import blade_contact_maps, build_system, full_system, sector, unassembled
from pipeline.model.blade_cache import blade_model, reduced_model
from pipeline.model.system import dense
from pipeline.solve.harmonic_balance import hbm
from pipeline.structure.beam import beam_dofs, torsion_constant
from pipeline.structure.blades import build_blade
from pipeline.structure.disk import pair_faces
from pipeline.structure.fe_model import BladeParams, DiskPlacement, boundary_dofs, rotation_z
from pipeline.structure.reduction import eigenmodes

from helpers import frequencies, stuck_stiffness

BEAM = BladeParams(kind="beam")                       # 100 x 30 x 4 mm steel, 20 elements
DISK = DiskPlacement(hub_radius=0.05, sectors=6)      # R [m], N
PAIR = ShroudPair("shroud", ku=1e5, kv=1e5, mu=0.3, n0=None)   # [N/m] per point pair
LOAD = PointLoad("excitation", (0.0, 1.0, 0.0), 1.0, 1, 0.0)   # 1 N, first harmonic
MODES = 4                                             # Craig-Bampton modes


def wheel(eo=1):
    return Scene(Blade(BEAM, disk=DISK), contacts=(PAIR,), loads=(LOAD,),
                 assembly=Cyclic(DISK.sectors, eo), reduction=CraigBampton(MODES))


def face_motion(blade, q) -> dict:
    """Face -> (k, 3) global point displacements [m] of the free-DOF vector q."""
    return {k: (f.point_motion(blade.n_dof) @ q).reshape(-1, 3) for k, f in blade.frames.items()}


def section_coordinates(p, x):
    """(xi, eta, z - L) [m] of global points x (k, 3): the lever from the tip node."""
    return x @ rotation_z(p.stagger_angle) - [0.0, 0.0, p.length]


def plane_section(p, x, field, value):
    """Independent reference: displacement (k, 3) [m] in global axes of points x rigidly
    attached to the tip section when one tip quantity is `value`, from the classical
    plane-section field of Euler-Bernoulli beams (Timoshenko & Gere): a flap deflection
    eta(z) moves a section point by (0, eta, -eta_s * eta'), an edge deflection by
    (xi, 0, -xi_s * xi'), a twist phi by phi e_z x (xi_s, eta_s, 0)."""
    xi, eta, dz = section_coordinates(p, x).T
    zero, one = np.zeros_like(xi), np.ones_like(xi)
    local = {"edge": (one, zero, zero), "flap": (zero, one, zero), "axial": (zero, zero, one),
             "edge_slope": (dz, zero, -xi), "flap_slope": (zero, dz, -eta),
             "twist": (-eta, xi, zero)}[field]
    return value * np.stack(local, axis=1) @ rotation_z(p.stagger_angle).T


@pytest.mark.parametrize("field", ["edge", "flap", "axial", "edge_slope", "flap_slope", "twist"])
def test_prescribed_tip_dof_moves_the_faces_as_a_plane_section(field):
    blade = build_blade(BEAM)
    q = np.zeros(blade.n_dof)
    q[beam_dofs(BEAM)[field][-1]] = 1e-3                 # [m] or [rad]
    for name, d in face_motion(blade, q).items():
        ref = plane_section(BEAM, blade.frames[name].points, field, 1e-3)
        np.testing.assert_allclose(d, ref, rtol=0, atol=1e-15)


@pytest.mark.parametrize("load", ["flap", "edge", "axial", "torque"])
def test_static_tip_load_turns_the_shroud_as_the_closed_form(load):
    """A tip force F = 1 N (torque T = 1 N m) on the unreduced beam: the face points move
    by the closed-form tip deflection and slope, delta = F L^3 / (3 EI), s = F L^2 /
    (2 EI), delta = F L / (EA), phi = T L / (GJ), carried to the points by the plane-
    section field (a sign error in the slope DOFs or in theta = (-eta', xi', phi) shows
    here: the FE slope is the physical one)."""
    p, blade = BEAM, build_blade(BEAM)
    dofs = beam_dofs(p)
    c, t, L = p.chord, p.thickness, p.length
    EI = {"flap": p.E * c * t**3 / 12, "edge": p.E * t * c**3 / 12}
    f = np.zeros(blade.n_dof)
    f[dofs["twist" if load == "torque" else load][-1]] = 1.0
    q = la.solve(blade.K.toarray(), f, assume_a="pos")
    if load in EI:
        parts = [(load, L**3 / (3 * EI[load])), (load + "_slope", L**2 / (2 * EI[load]))]
    elif load == "axial":
        parts = [("axial", L / (p.E * c * t))]
    else:
        parts = [("twist", L / (p.G * torsion_constant(c, t)))]
    for name, d in face_motion(blade, q).items():
        x = blade.frames[name].points
        ref = sum(plane_section(p, x, fld, v) for fld, v in parts)
        # measured 1.5e-11 (bending; the dense solve's round-off), 1e-14 (axial, twist);
        # a flipped slope sign errs by ~0.1 (lever h_s, w_s / 2 against L)
        assert np.abs(d - ref).max() < 1e-9 * np.abs(ref).max()


def test_faces_lie_where_the_solid_puts_them_and_pair_in_a_wheel():
    """Every face point lies on the plane of the solid blade's face (same params), the
    beam's normals are the solid's, the face weights sum to the face area, and in a
    disk the left face is the right one turned by -alpha, point for point."""
    beam, solid = build_blade(BEAM), build_blade(replace(BEAM, kind="solid", n_chord=2,
                                                         n_thick=1, n_span=4))
    for name, fb in beam.frames.items():
        fs = solid.frames[name]
        np.testing.assert_allclose(fb.normal, fs.normal, atol=1e-12)
        off = (fb.points - fs.points.mean(axis=0)) @ fs.normal
        assert np.abs(off).max() < 1e-15
        lo, hi = fs.points.min(axis=0), fs.points.max(axis=0)
        assert np.all(fb.points >= lo) and np.all(fb.points <= hi)
        assert fb.weights.sum() == pytest.approx(fs.weights.sum(), rel=1e-12)
    wb, ws = build_blade(BEAM, DISK), build_blade(replace(BEAM, kind="solid", n_chord=2,
                                                          n_thick=1, n_span=4), DISK)
    assert wb.params.shroud_width == ws.params.shroud_width
    xr, xl = wb.frames["shroud_right"].points, wb.frames["shroud_left"].points
    np.testing.assert_array_equal(pair_faces(xr, xl, DISK), np.arange(4))
    for name in wb.frames:
        off = (wb.frames[name].points - ws.frames[name].points.mean(axis=0)) @ ws.frames[name].normal
        assert np.abs(off).max() < 1e-15


def test_shroud_mass_is_the_rigid_block_about_the_tip():
    """M(shrouded) - M(bare) on the tip DOFs is the block c_s x w_s x h_s of density rho
    on the tip: mass m on each translation, the moments of inertia about the tip node
    (parallel axes, centroid h_s / 2 above it), and the coupling m h_s / 2 of a flap
    (edge) translation with the flap (edge) slope: a slope turns the block so that its
    centroid moves the same way as the deflection (plane sections)."""
    p = BEAM
    dM = build_blade(p).M - build_blade(replace(p, shroud=False)).M
    tip = {k: v[-1] for k, v in beam_dofs(p).items()}
    cs, ws, hs = p.shroud_chord, p.shroud_width, p.shroud_height
    m = p.rho * cs * ws * hs                                    # 0.01884 kg
    ref = {("edge", "edge"): m, ("flap", "flap"): m, ("axial", "axial"): m,
           ("flap_slope", "flap_slope"): m * (ws**2 + hs**2) / 12 + m * hs**2 / 4,
           ("edge_slope", "edge_slope"): m * (cs**2 + hs**2) / 12 + m * hs**2 / 4,
           ("twist", "twist"): m * (cs**2 + ws**2) / 12,
           ("flap", "flap_slope"): m * hs / 2, ("edge", "edge_slope"): m * hs / 2}
    got = dM.toarray()
    for (a, b), v in ref.items():
        assert got[tip[a], tip[b]] == pytest.approx(v, rel=1e-12)
        assert got[tip[b], tip[a]] == pytest.approx(v, rel=1e-12)
    assert abs(got).sum() == pytest.approx(sum(ref.values()) + m * hs * 2 / 2, rel=1e-12)


def flap_edge(blade, k=6):
    """First flap and first edge frequency [Hz]: the modes whose tip section (the
    stagger-turned mean of the tip points' displacements) moves most along eta, xi."""
    w2, X = eigenmodes(blade.K, blade.M, k)
    tip = blade.points[:, 2] >= blade.params.length - 1e-12
    d = X[blade.point_dofs[tip]]                        # (points, 3, k), blade DOF frame
    if blade.params.kind == "solid":
        d = np.einsum("ji,pjk->pik", rotation_z(blade.params.stagger_angle), d)
    d = np.abs(d.mean(axis=0))
    f = np.sqrt(w2) / (2 * np.pi)
    return f[np.argmax(d[1] > d[0] + d[2])], f[np.argmax(d[0] > d[1] + d[2])]


def test_shrouded_beam_frequencies_against_the_solid_blade():
    """Free shroud (no contact), BladeParams defaults (100 x 30 x 4 mm steel airfoil,
    30 x 20 x 4 mm shroud; solid 8 x 2 x 20 Hex2, 11934 DOFs, beam 120 DOFs).

    Measured: flap 244.75 Hz (beam) vs 248.35 Hz (solid), -1.45 %; edge 1832.1 Hz vs
    1755.4 Hz, +4.37 %.  Expected from Euler-Bernoulli theory:
    flap: the solid's 30 mm wide, 4 mm thick airfoil bends partly in plane strain,
      stiffening it up to E / (1 - nu^2): the beam is low by at most
      sqrt(1 - nu^2) - 1 = -4.6 %; rotary inertia and shear are (t/L)^2 ~ 2e-3
      effects and the solid's shroud is not quite rigid (both lower the solid), so
      the beam may be high by a little: -4.6 % < beam/solid - 1 < +1 %;
    edge: in-plane the section is deep (radius of gyration r = c / sqrt 12, L/r = 11.5):
      the beam neglects shear deformation (E / (kappa G) = 3.1, kappa = 5/6) and
      rotary inertia, so it is high, between the tip-mass limit (shear adds
      3 E I / (kappa G A L^2) = 7 % to the tip deflection: +3.4 %) and Timoshenko's
      estimate for the bare cantilever, 1/2 (1.875 r / L)^2 (1 + E / (kappa G)) =
      +5.4 %: +2 % < beam/solid - 1 < +6 %."""
    beam = flap_edge(build_blade(BEAM))
    solid = flap_edge(build_blade(replace(BEAM, kind="solid")))
    flap, edge = beam[0] / solid[0] - 1, beam[1] / solid[1] - 1
    assert np.sqrt(1 - BEAM.nu**2) - 1 < flap < 0.01        # measured -0.0145
    assert 0.02 < edge < 0.06                              # measured +0.0437
    bare = flap_edge(build_blade(replace(BEAM, shroud=False)))
    assert bare[0] > 1.3 * beam[0]                         # the shroud does weigh


def rigid_wheel_rotation(blade, theta=1e-3):
    """Free-DOF field of the infinitesimal wheel rotation theta e_X about the disk axis
    on the tip section: u_tip = theta e_X x (x_tip - c), theta_tip = theta e_X, in the
    section axes (u: edge, flap, axial; theta: -flap slope, edge slope, twist)."""
    p = blade.params
    R = rotation_z(p.stagger_angle)
    e = np.array([theta, 0.0, 0.0])
    u = R.T @ np.cross(e, [0.0, 0.0, p.length] - DISK.centre)
    th = R.T @ e
    q = np.zeros(blade.n_dof)
    dofs = beam_dofs(p)
    for field, v in zip(("edge", "flap", "axial", "flap_slope", "edge_slope", "twist"),
                        (u[0], u[1], u[2], -th[0], th[1], th[2])):
        q[dofs[field][-1]] = v
    return q


def test_rigid_rotation_of_a_beam_wheel_loads_no_shroud_pair():
    """EO = 0 rigid rotation of every sector: u = (Bt + Bt_next) q, v = (Bn + Bn_next) q
    vanish to round-off on the full and reduced maps; with the neighbour's displacement
    not turned by R(alpha) the pair does move (each face alone moves too)."""
    scene = wheel()
    blade = blade_model(scene.structure)
    Bt, Bn, Btn, Bnn, _, _ = blade_contact_maps(scene, full=True)
    q = rigid_wheel_rotation(blade)
    scale = 1e-3 * (DISK.hub_radius + BEAM.length)         # [m]: the tip's displacement
    assert max(np.abs((Bt + Btn) @ q).max(), np.abs((Bn + Bnn) @ q).max()) < 1e-14 * scale
    red = reduced_model(scene.structure, scene.reduction)[0]
    parts = unassembled(scene, {"preload": 1.0})
    qr = np.zeros(parts.M.shape[0])
    qr[:red.n_boundary] = q[red.boundary]
    for B in (parts.Bt + parts.Bt_next, parts.Bn + parts.Bn_next):
        assert np.abs(B @ qr).max() < 1e-14 * scale       # measured 1.4e-20 m
    t, n = pair_frame(blade, PAIR, DISK)
    d = face_motion(blade, q)
    wrong = d["shroud_left"] - d["shroud_right"]           # R(alpha) left out
    assert np.abs(wrong @ t).max() > 0.5 * scale          # measured 1.3e-4 m (0.89 scale)
    assert np.abs(wrong @ n).max() > 1e-3 * scale         # measured 3.8e-6 m
    assert np.abs(Bt @ q).max() > 0.5 * scale


def test_beam_wheel_sector_is_cheap_and_reproduces_the_full_wheel():
    """The beam wheel's sector keeps the tip's 6 DOFs and the excitation node's 3
    (120 -> 9 + MODES DOFs); its stuck frequencies per nodal diameter are the full tied
    wheel's, and its harmonic balance residual at a random state is the wheel's."""
    scene, case = wheel(), {"preload": 10.0}
    blade = blade_model(scene.structure)
    assert blade.n_dof == 120 and boundary_dofs(blade)[0].size == 9
    sec = sector(scene, case)
    assert sec.n_dof == 9 + MODES and sec.contact.size == 4
    N = DISK.sectors
    systems = [sector_system(sec, nd) for nd in range(N // 2 + 1)]
    parts = [frequencies(stuck_stiffness(s), s.M.astype(complex)) for s in systems]
    cyc = np.sort(np.concatenate([w for nd, w in enumerate(parts)
                                  for _ in range(1 if nd in (0, N // 2) else 2)]))
    f = full_system(scene, case)
    full = frequencies(stuck_stiffness(f), dense(f.M))
    assert full.size == N * sec.n_dof == cyc.size
    assert np.abs(cyc / full - 1).max() < 1e-8              # measured 4.9e-15
    assert parts[1][0] > 1.1 * frequencies(dense(systems[1].K), systems[1].M)[0]

    scene, H = wheel(eo=2), 3
    s, f = build_system(scene, {"preload": 5.0}), full_system(scene, {"preload": 5.0})
    ps, pf = hbm.setup(s, H), hbm.setup(f, H)
    Q = 1e-5 * np.random.default_rng(1).standard_normal((s.n_dof, 2 * H + 1))
    Om = 1500.0                                             # [rad/s]
    assert np.abs(hbm.contact_terms(ps, Q[ps.c], jacobian=False)[0]).max() > 1.0
    Rf = hbm.full_residual(pf, expand(Q, N, 2), Om)
    Rs = expand(hbm.full_residual(ps, Q, Om), N, 2)
    assert np.abs(Rf - Rs).max() < 1e-13 * np.abs(Rf).max()   # measured 1.5e-16
