"""FE blades in a disk: the generated wheel closes (left face of blade j+1 = right
face of blade j), shroud pairs see the neighbour's displacement turned into this
sector's frame (a rigid rotation of the wheel loads no contact), and the cyclic
sector reproduces its limits: the clamped blade when the shrouds are open, the
full tied wheel's eigenfrequencies when they stick."""
from dataclasses import replace

import meshio
import numpy as np
import pytest

from pipeline.model.contacts import ShroudPair
from pipeline.model.cyclic import expand, sector_system
from pipeline.model.loads import PointLoad
from pipeline.model.scene import Blade, CraigBampton, Cyclic, Scene, Single
from pipeline.model.build import blade_contact_maps, build_system, full_system, sector, unassembled
from pipeline.model.blade_cache import blade_model, reduced_model
from pipeline.model.system import dense, natural_frequencies
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.continuation.newton import newton
from pipeline.structure.blades import build_blade
from pipeline.structure.disk import pair_faces
from pipeline.structure.fe_model import BladeParams, DiskPlacement
from pipeline.structure.mesh_io import write_mesh

from helpers import frequencies, stuck_stiffness

PARAMS = BladeParams(n_chord=2, n_thick=1, n_span=4)
DISK = DiskPlacement(hub_radius=0.05, sectors=6)      # R [m], N
PAIR = ShroudPair("shroud", ku=1e5, kv=1e5, mu=0.3, n0=None)   # [N/m] per node pair
LOAD = PointLoad("excitation", (0.0, 1.0, 0.0), 1.0, 1, 0.0)   # 1 N in Y, first harmonic


def wheel(blade=Blade(PARAMS, disk=DISK), eo=1, pair=PAIR):
    return Scene(blade, contacts=(pair,), loads=(LOAD,), assembly=Cyclic(DISK.sectors, eo),
                 reduction=CraigBampton(4))


def rigid_rotation(blade, disk, theta=1.0, neighbour_turned=True):
    """Free-DOF field of the infinitesimal rotation theta e_X x (x - c) on both shroud
    faces [m]; with neighbour_turned=False the left face (read by the maps as the
    next sector's) carries R(-alpha) of it, which undoes the maps' R(alpha): the
    neighbour's vector taken as if it were in this sector's frame."""
    q = np.zeros(blade.n_dof)
    for face in ("shroud_right", "shroud_left"):
        x = blade.set_points[face]
        d = theta * np.cross([1.0, 0.0, 0.0], x - disk.centre)
        if face == "shroud_left" and not neighbour_turned:
            d = d @ disk.rotation(disk.pitch_angle)     # rows R(alpha)^T d
        q[blade.dof_sets[face]] = d
    return q


def test_generated_wheel_closes_node_for_node():
    """Left face of blade j+1 (the left face turned by alpha) = right face of blade j,
    every Hex2 DOF point, to 1e-12 m; both faces planar; the right face centre sits
    at the polar angle alpha / 2 (the derived shroud width)."""
    blade = build_blade(PARAMS, DISK)
    xr, xl = blade.set_points["shroud_right"], blade.set_points["shroud_left"]
    left = pair_faces(xr, xl, DISK)
    gap = np.linalg.norm(DISK.rotate(xl[left], DISK.pitch_angle) - xr, axis=1).max()
    assert len(xr) == 15 and gap < 1e-12
    for x in (xr, xl):
        sv = np.linalg.svd(x - x.mean(axis=0), compute_uv=False)
        assert sv[-1] < 1e-12 * sv[0]
    assert DISK.polar_angle(xr.mean(axis=0))[0] == pytest.approx(DISK.pitch_angle / 2, rel=1e-12)
    assert DISK.polar_angle(xl.mean(axis=0))[0] == pytest.approx(-DISK.pitch_angle / 2, rel=1e-12)
    nr, nl = blade.frames["shroud_right"].normal, blade.frames["shroud_left"].normal
    np.testing.assert_allclose(DISK.rotation(DISK.pitch_angle) @ nl, -nr, atol=1e-12)


def test_plain_blade_is_unchanged_by_the_disk_code():
    assert build_blade(PARAMS).params.shroud_width == PARAMS.shroud_width
    assert build_blade(PARAMS, DISK).params.shroud_width == pytest.approx(0.186779, rel=1e-5)


def test_rigid_rotation_of_the_wheel_loads_no_contact():
    """theta e_X x (x - c) on every sector (EO = 0): u = (Bt + Bt_next) q and
    v = (Bn + Bn_next) q vanish to round-off, on the full and on the reduced maps;
    with the neighbour's vector not turned by R(alpha) they do not."""
    scene = wheel()
    blade = blade_model(scene.structure)
    Bt, Bn, Btn, Bnn, _, _ = blade_contact_maps(scene, full=True)
    radius = DISK.hub_radius + PARAMS.length     # [m]
    q, q_wrong = rigid_rotation(blade, DISK), rigid_rotation(blade, DISK, neighbour_turned=False)
    red = reduced_model(scene.structure, scene.reduction)[0]
    p = unassembled(scene, {"preload": 1.0})
    for field, ok in ((q, True), (q_wrong, False)):
        qr = np.zeros(p.M.shape[0])
        qr[:red.n_boundary] = field[red.boundary]
        for u, v in (((Bt + Btn) @ field, (Bn + Bnn) @ field),
                     ((p.Bt + p.Bt_next) @ qr, (p.Bn + p.Bn_next) @ qr)):
            worst = max(np.abs(u).max(), np.abs(v).max())
            if ok:
                assert worst < 1e-12 * radius       # measured 2.8e-17 m
            else:
                assert worst > 1e-3 * radius        # measured about 0.1 m
    assert np.abs(Bt @ q).max() > 1e-3 * radius     # each face alone does move


def test_open_shrouds_give_the_clamped_blade():
    """A wide gap (n0 < 0 per pair, kv > 0): the EO = 1 sector's harmonic balance
    solution (Newton from rest, 3 harmonics, residual below 1e-6 of the 1 N load) is
    the single clamped blade's linear response, at and beside its first resonance;
    the contact forces are zero and no other harmonic is excited."""
    scene = wheel()
    s = build_system(scene, {"preload": -1e4})        # n0 = -667 N per pair
    single = build_system(replace(scene, contacts=(), assembly=Single()))
    w0 = natural_frequencies(single, "open")[0]
    assert natural_frequencies(s, "open")[0] == w0
    prob = hbm.setup(s, 3)
    for Om in (0.9 * w0, w0, 1.1 * w0):
        nr = newton(lambda x: hbm.residual(prob, x, Om)[:2], np.zeros(prob.c.size * prob.nh),
                    1e-6, max_iter=5)
        assert nr.success
        Qc = nr.x.reshape(prob.c.size, prob.nh)
        Q = hbm.recover(prob, Qc, Om)
        X = np.linalg.solve(single.K - Om**2 * single.M + 1j * Om * single.C, single.forcing[:, 1])
        # measured 4e-10 beside the resonance, 1.4e-8 on it (damping ratio 0.002)
        assert np.abs(Q[:, 1] - 1j * Q[:, 2] - X).max() < 1e-7 * np.abs(X).max()
        assert max(np.abs(Q[:, 0]).max(), np.abs(Q[:, 3:]).max()) < 1e-12 * np.abs(X).max()
        assert np.abs(hbm.contact_terms(prob, Qc, jacobian=False)[0]).max() == 0


def test_stuck_sector_frequencies_are_the_tied_wheel_frequencies():
    """Nodal diameters 0..N/2 of the tied sector (B = Bt + exp(i ND alpha) Bt_next)
    together, 0 < ND < N/2 twice, equal all N n eigenfrequencies of the full tied
    wheel (K + Bt^T ku Bt + Bn^T kv Bn of the N-blade assembly, real symmetric)."""
    scene, case = wheel(), {"preload": 10.0}
    N = DISK.sectors
    sec = sector(scene, case)
    systems = [sector_system(sec, nd) for nd in range(N // 2 + 1)]
    parts = [frequencies(stuck_stiffness(s), s.M.astype(complex)) for s in systems]
    cyc = np.sort(np.concatenate([w for nd, w in enumerate(parts)
                                  for _ in range(1 if nd in (0, N // 2) else 2)]))
    f = full_system(scene, case)
    full = frequencies(stuck_stiffness(f), dense(f.M))
    assert full.size == N * sec.n_dof == cyc.size
    assert np.abs(cyc / full - 1).max() < 1e-9        # measured 3.0e-11
    # the system's own (one-formulation) solver agrees within its round-off
    for s, w in zip(systems, parts):
        assert np.abs(natural_frequencies(s, "stuck") / w - 1).max() < 3e-8   # measured 4.5e-9
    open_ = natural_frequencies(systems[1], "open")[0]
    assert parts[1][0] > 1.1 * open_                 # the tied shrouds stiffen ND 1


def test_sector_residual_is_the_wheel_residual():
    """Nonlinear: at a state where the pairs stick, slip and separate (random
    coefficients of 10 um, 3 harmonics, EO = 2), the full-wheel harmonic balance
    residual of the expanded travelling wave is the sector's residual shifted
    sector by sector (Petrov 2004)."""
    scene, case, H = wheel(eo=2), {"preload": 5.0}, 3
    s, f = build_system(scene, case), full_system(scene, case)
    ps, pf = hbm.setup(s, H), hbm.setup(f, H)
    Q = 1e-5 * np.random.default_rng(1).standard_normal((s.n_dof, 2 * H + 1))   # [m]
    Om = 700.0                                                                  # [rad/s]
    G = hbm.contact_terms(ps, Q[ps.c], jacobian=False)[0]
    assert np.abs(G).max() > 1.0                     # [N]: the contacts do act
    Rf = hbm.full_residual(pf, expand(Q, DISK.sectors, 2), Om)
    Rs = expand(hbm.full_residual(ps, Q, Om), DISK.sectors, 2)
    assert np.abs(Rf - Rs).max() < 1e-13 * np.abs(Rf).max()   # measured 7.7e-16


def test_case_keys_and_face_totals():
    """preload, mu, ku, kv of a case act on shroud pairs; "per_face" shares the face
    totals by node area, "per_node" shares the preload equally."""
    case = {"preload": 30.0, "mu": 0.1, "ku": 2e5, "kv": 3e5}
    el = build_system(wheel(), case).contact
    assert el.size == 15 and np.all(el.mu == 0.1) and np.all(el.ku == 2e5)
    assert el.n0.sum() == pytest.approx(30.0) and np.ptp(el.n0) == 0
    el = build_system(wheel(pair=replace(PAIR, stiffness="per_face")), case).contact
    assert el.kv.sum() == pytest.approx(3e5) and el.n0.sum() == pytest.approx(30.0)
    assert np.ptp(el.n0) > 0
    assert wheel().coupled


def test_user_mesh_pairs_by_rotation_and_a_perturbed_face_fails(tmp_path):
    """A wheel blade written through meshio and read back pairs like the generated one;
    moving one left-face vertex 0.1 mm radially, out of the face's plane (the left face
    is the right one turned about the disk axis), gives the one-line pairing error."""
    blade = build_blade(PARAMS, DISK)
    path = write_mesh(blade, tmp_path / "wheel_blade.vtu")
    user = wheel(Blade(PARAMS, mesh=str(path), disk=DISK))
    ref = blade_contact_maps(wheel(), full=True)
    got = blade_contact_maps(user, full=True)
    for a, b in zip(got[:4], ref[:4]):
        assert abs(a - b).max() < 1e-12
    m = meshio.read(path)
    k = int(np.nonzero(m.point_data["shroud_left"])[0][2])
    m.points[k, 2] += 1e-4
    bad = tmp_path / "perturbed.vtu"
    meshio.write(bad, m)
    with pytest.raises(ValueError, match=r"^shroud faces do not pair: shroud_right point \d+ "
                                         r"at \(.*\) m lies on no shroud_left element "
                                         r"turned by 2 pi / 6 \(nearest shroud_left point "
                                         r"[0-9.e-]+ m away"):
        build_system(wheel(Blade(PARAMS, mesh=str(bad), disk=DISK)), {"preload": 1.0})


@pytest.mark.parametrize("disk, field", [(DiskPlacement(0.01, 6), "disk.hub_radius"),
                                         (DiskPlacement(0.05, 4), "disk.sectors")])
def test_overlapping_or_inverted_wheels_are_rejected(disk, field):
    with pytest.raises(ValueError, match=field):
        build_blade(PARAMS, disk)


def test_misuse_is_named():
    with pytest.raises(ValueError, match="must equal the blade's disk.sectors"):
        Scene(Blade(PARAMS, disk=DISK), assembly=Cyclic(5, 1))
    with pytest.raises(ValueError, match="needs the blade's disk placement"):
        build_system(wheel(Blade(PARAMS)), {"preload": 1.0})
    with pytest.raises(ValueError, match="normal to the shroud face"):
        n = blade_model(wheel().structure).frames["shroud_right"].normal
        build_system(wheel(pair=replace(PAIR, tangent=tuple(n))), {"preload": 1.0})


def test_tuned_full_wheel_solution_is_the_expanded_sector_along_an_frf():
    """Along a sector FRF through stick, slip and separation (EO 1, H = 1, preload 2 N
    per face), every 6th point expanded to the 6 blades starts Newton on the full
    wheel's own harmonic balance (no symmetry used; sparse); the wheel's solution
    equals the expansion to 1e-8 of its size.  Over those points, shroud pairs
    stick, slip, stay closed and separate (first-harmonic estimates of the states)."""
    from pipeline.solve.response.response import frequency_response

    scene, case, H = wheel(eo=1), {"preload": 20.0}, 1
    s, f = build_system(scene, case), full_system(scene, case)
    lo, hi = natural_frequencies(s, "open")[0], natural_frequencies(s, "stuck")[0]
    c = frequency_response(s, H, 0.9 * lo, 1.05 * hi, tol_rel=1e-10, stability=False,
                           peak_dofs=[scene.dof_index("response.y")], dense_output=False)
    assert c.success and c.converged.all()
    pf = hbm.setup(f, H)
    states = set()
    for i in range(0, c.omega.size, 6):
        Qe = expand(c.Q[i], DISK.sectors, 1)
        Om = c.omega[i]
        tol = 1e-10 * hbm.force_scale(pf)                # the sector's own tolerance [N]
        nr = newton(lambda x: hbm.residual(pf, x, Om)[:2], Qe[pf.c].ravel(), tol, max_iter=20)
        assert nr.success
        Qf = hbm.recover(pf, nr.x.reshape(pf.c.size, -1), Om)
        assert np.abs(Qf - Qe).max() < 1e-8 * np.abs(Qe).max()
        U, V = hbm.contact_motion(pf, Qf[pf.c])
        el = f.contact
        n = el.n0[:, None] + el.kv[:, None] * (V[:, :1] - np.hypot(V[:, 1], V[:, 2])[:, None])
        t = el.ku * np.hypot(U[:, 1], U[:, 2])
        states.update("separation" if m < 0 else "closed" for m in n[:, 0])
        states.update("slip" if a > b else "stick"
                      for a, b in zip(t, el.mu * (el.n0 + el.kv * V[:, 0])))
    assert states == {"separation", "closed", "slip", "stick"}


def test_full_wheel_jacobian_is_sparse_and_exact():
    """The 6-blade wheel's condensed Jacobian (1620 unknowns at H = 1) comes back
    sparse, block-cyclic: equal to the dense assembly to 1e-13, under a fifth of it
    nonzero, and equal to central differences of the residual."""
    scene, case, H = wheel(eo=1), {"preload": 20.0}, 1
    pf = hbm.setup(full_system(scene, case), H)
    x = 1e-6 * np.random.default_rng(3).standard_normal(pf.size)
    R, J, dR = hbm.residual(pf, x, 800.0)
    assert hasattr(J, "tocsr") and J.nnz < 0.2 * pf.size**2
    St = hbm.linear_part(pf, 800.0, derivatives=False)[0]
    Jd = hbm.real_blocks(St, pf.nh) + hbm.contact_terms(pf, x.reshape(pf.c.size, -1))[1]
    assert np.abs(J.toarray() - Jd).max() < 1e-13 * np.abs(Jd).max()
    rng = np.random.default_rng(4)
    for j in rng.choice(pf.size, 5, replace=False):
        e = np.zeros(pf.size)
        e[j] = 1e-12
        col = (hbm.residual(pf, x + e, 800.0, jacobian=False)[0]
               - hbm.residual(pf, x - e, 800.0, jacobian=False)[0]) / 2e-12
        assert np.abs(col - J[:, j].toarray().ravel()).max() < 1e-5 * np.abs(Jd).max()
