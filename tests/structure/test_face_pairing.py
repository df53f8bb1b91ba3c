"""Shroud faces meshed independently: each right-face point takes the left face's
displacement interpolated on the left facet under it (`structure.disk.pairing`, the
facets' shape functions in `structure.facets`).  Node to node stays the special case,
exactly; linear fields are interpolated exactly (a uniform strain, a rigid motion of the
wheel load no contact: the patch test of the pairing), so the forces a face passes on
keep their resultant and moment; and a wheel whose left faces are meshed differently
converges to the matching wheel as the mesh is refined."""
import re
from dataclasses import replace

import meshio
import numpy as np
import pytest

from pipeline import load_study, parse_study, read_dataset, run_study
from pipeline.model.build import blade_contact_maps, build_system
from pipeline.model.blade_cache import blade_model
from pipeline.model.contacts import ShroudPair
from pipeline.model.loads import PointLoad
from pipeline.model.scene import Blade, CraigBampton, Cyclic, Scene
from pipeline.model.system import natural_frequencies
from pipeline.structure import facets as fc
from pipeline.structure.blades import build_blade
from pipeline.structure.disk import on_facets, pairing, PAIR_TOLERANCE
from pipeline.structure.fe_model import BladeParams, DiskPlacement
from pipeline.structure.mesh_io import write_mesh

from helpers import STUDIES

PARAMS = BladeParams(n_chord=4, n_thick=1, n_span=4)
DISK = DiskPlacement(hub_radius=0.05, sectors=6)      # R [m], N
PAIR = ShroudPair("shroud", ku=1e5, kv=1e5, mu=0.3, n0=None)   # [N/m] per point
LOAD = PointLoad("excitation", (0.0, 1.0, 0.0), 1.0, 1, 0.0)   # 1 N in Y, first harmonic
REFERENCE = {"tri3": [(0, 0), (1, 0), (0, 1)],
             "tri6": [(0, 0), (1, 0), (0, 1), (0.5, 0), (0.5, 0.5), (0, 0.5)],
             "quad4": [(-1, -1), (1, -1), (1, 1), (-1, 1)],
             "quad8": [(-1, -1), (1, -1), (1, 1), (-1, 1), (0, -1), (1, 0), (0, 1), (-1, 0)],
             "quad9": [(-1, -1), (1, -1), (1, 1), (-1, 1), (0, -1), (1, 0), (0, 1), (-1, 0),
                       (0, 0)]}


@pytest.mark.parametrize("kind", list(REFERENCE))
def test_facet_shape_functions(kind):
    """Each N_i is 1 at its point and 0 at the others; they reproduce 1, r, s (and, on
    the quadratic facets, r^2, r s, s^2) at any point; the derivatives are the
    functions' own (central differences)."""
    P = np.array(REFERENCE[kind], float)
    assert fc.kind_of(len(P)) == kind
    np.testing.assert_allclose([fc.shape(kind, *p)[0] for p in P], np.eye(len(P)), atol=1e-15)
    rng = np.random.default_rng(1)
    for r, s in rng.uniform(0.05, 0.45, (5, 2)):
        N, dr, ds = fc.shape(kind, r, s)
        monomials = [np.ones(len(P)), P[:, 0], P[:, 1]]
        if len(P) > 4:
            monomials += [P[:, 0] ** 2, P[:, 0] * P[:, 1], P[:, 1] ** 2]
        values = [1.0, r, s, r * r, r * s, s * s][:len(monomials)]
        np.testing.assert_allclose([N @ m for m in monomials], values, atol=1e-14)
        h = 1e-6
        np.testing.assert_allclose(dr, (fc.shape(kind, r + h, s)[0] - fc.shape(kind, r - h, s)[0])
                                   / (2 * h), atol=1e-8)
        np.testing.assert_allclose(ds, (fc.shape(kind, r, s + h)[0] - fc.shape(kind, r, s - h)[0])
                                   / (2 * h), atol=1e-8)
        assert fc.locate(kind, P, np.array([N @ P[:, 0], N @ P[:, 1]])) == pytest.approx((r, s),
                                                                                     abs=1e-12)


def moved_left_face(tmp_path, params, shift, disk=DISK):
    """A wheel blade's mesh file whose left shroud face is meshed differently: its
    vertices inside the face's chordwise extent moved along it by `shift` x the
    chordwise element size (the face keeps its outline and its plane)."""
    path = write_mesh(build_blade(params, disk), tmp_path / "matching.vtu")
    m = meshio.read(path)
    on = np.nonzero(m.point_data["shroud_left"])[0]
    X = m.points[on]
    centre = X.mean(axis=0)
    along = np.linalg.svd(X - centre, full_matrices=False)[2][0]   # the longest extent
    c = (X - centre) @ along
    h = np.ptp(c) / params.n_chord
    inner = on[(c > c.min() + 0.1 * h) & (c < c.max() - 0.1 * h)]
    assert inner.size == 2 * (params.n_chord - 1)            # both chordwise rows
    m.points[inner] += shift * h * along
    moved = tmp_path / f"moved_{params.n_chord}.vtu"
    meshio.write(moved, m)
    return moved


def wheel(blade, eo=0):
    return Scene(blade, contacts=(PAIR,), loads=(LOAD,), assembly=Cyclic(DISK.sectors, eo),
                 reduction=CraigBampton(4))


def test_matching_faces_through_the_interpolation_are_node_to_node():
    """On the generated (matching) wheel blade every right point also lies on a left
    facet: interpolated there, its row is the node-to-node one to 1e-12."""
    blade = build_blade(PARAMS, DISK)
    R, L = blade.frames["shroud_right"], blade.frames["shroud_left"]
    W = pairing(R.points, L.points, DISK, L.facets)
    assert W.nnz == W.shape[0] == W.shape[1] and np.all(W.data == 1.0)   # node to node
    back = DISK.rotate(R.points, -DISK.pitch_angle)
    size = np.ptp(R.points, axis=0).max()
    rows = on_facets(back, L.points, L.facets, PAIR_TOLERANCE * size)
    Wi = np.zeros(W.shape)
    for k, (ids, w) in enumerate(rows):
        Wi[k, ids] += w
    assert np.abs(Wi - W.toarray()).max() < 1e-12


def test_linear_fields_are_interpolated_exactly_and_forces_keep_resultant_and_moment(tmp_path):
    """Left face meshed differently: the interpolated left points are the right points'
    images (W X_L, any linear field; node to segment and dual mortar), the rows sum to
    1; so the forces f_k a right point passes to the left face's points, W^T f, have the
    same resultant and moment.  A
    rigid rotation of the wheel and its uniform radial and axial strains load no
    contact (u = (Bt + Bt_next) q, v = (Bn + Bn_next) q to round-off): the patch test."""
    blade = blade_model(Blade(PARAMS, mesh=str(moved_left_face(tmp_path, PARAMS, 0.3)),
                              disk=DISK))
    R, L = blade.frames["shroud_right"], blade.frames["shroud_left"]
    W = pairing(R.points, L.points, DISK, L.facets)
    assert W.nnz > W.shape[0]                                # interpolated, not node to node
    back = DISK.rotate(R.points, -DISK.pitch_angle)
    assert np.abs(W @ L.points - back).max() < 1e-12 * np.abs(back).max()
    np.testing.assert_allclose(np.asarray(W.sum(axis=1)).ravel(), 1.0, atol=1e-13)
    f = np.random.default_rng(0).normal(size=(len(back), 3))   # [N] at the right points
    np.testing.assert_allclose((W.T @ f).sum(axis=0), f.sum(axis=0), atol=1e-12)
    np.testing.assert_allclose(np.cross(L.points, W.T @ f).sum(axis=0),
                               np.cross(back, f).sum(axis=0), atol=1e-12)
    # with the right face's facets too: the dual mortar (what the wheel's pairs use),
    # every row an average over the left facets, the same exact linear fields
    Wm = pairing(R.points, L.points, DISK, L.facets, facets_right=R.facets)
    assert abs(Wm - W).max() > 1e-3                         # another operator
    assert np.abs(Wm @ L.points - back).max() < 1e-12 * np.abs(back).max()
    np.testing.assert_allclose(np.asarray(Wm.sum(axis=1)).ravel(), 1.0, atol=1e-13)
    scene = wheel(Blade(PARAMS, mesh=str(tmp_path / "moved_4.vtu"), disk=DISK))
    Bt, Bn, Btn, Bnn, _, _ = blade_contact_maps(scene, full=True)
    radius = DISK.hub_radius + PARAMS.length
    for field in (lambda x: np.cross([1.0, 0.0, 0.0], x - DISK.centre),           # rotation
                  lambda x: (x - DISK.centre) * [0.0, 1e-3, 1e-3],                # radial strain
                  lambda x: (x[:, :1] * [1e-3, 0.0, 0.0])):                       # axial strain
        q = np.zeros(blade.n_dof)
        for face in ("shroud_right", "shroud_left"):
            q[blade.dof_sets[face]] = field(blade.set_points[face])
        for u in ((Bt + Btn) @ q, (Bn + Bnn) @ q):
            assert np.abs(u).max() < 1e-12 * radius
        assert np.abs(Bt @ q).max() > 1e-6 * radius                # each face alone moves


def test_a_wheel_with_differently_meshed_faces_converges_to_the_matching_wheel(tmp_path):
    """The stuck wheel's first three frequencies at EO 0 and 1 with the left faces'
    inner vertices moved by 0.3 of an element: their distance from the matching wheel's
    shrinks as the chord is refined (n_chord = 2, 4, 8)."""
    gaps = []
    for n in (2, 4, 8):
        params = replace(PARAMS, n_chord=n)
        moved = moved_left_face(tmp_path, params, 0.3)
        worst = 0.0
        for eo in (0, 1):
            case = {"preload": 10.0}
            w_match = natural_frequencies(build_system(wheel(Blade(params, disk=DISK), eo), case),
                                          "stuck")[:3]
            w_moved = natural_frequencies(build_system(
                wheel(Blade(params, mesh=str(moved), disk=DISK), eo), case), "stuck")[:3]
            worst = max(worst, np.abs(w_moved / w_match - 1).max())
        gaps.append(worst)
    print("stuck frequency gap to the matching wheel, n_chord 2, 4, 8:", gaps)
    assert gaps[0] > gaps[1] > gaps[2] and gaps[2] < 0.5 * gaps[0]


def test_the_modes_study_runs_on_a_blade_whose_faces_do_not_match(tmp_path):
    """`studies/shrouded_disk_modes.toml` on its blade read from a mesh file, as
    generated and with the left faces' inner vertices moved by 0.3 of an element: the
    open frequencies per nodal diameter are nearly the same blade's (the mesh moved
    inside the shroud only), the stuck ones within 2e-4 of the matching wheel's."""
    path = STUDIES / "shrouded_disk_modes.toml"
    blade = load_study(path).scene.structure
    moved = moved_left_face(tmp_path, blade.params, 0.3, blade.disk)
    text = path.read_text().split("[quick")[0]
    text = re.sub(r"\[scene\.blade\]\n(n_\w+ = \d+\n)+", "[scene.blade]\nrho = 7850.0\n", text)
    out = {}
    for name, mesh in (("matching", tmp_path / "matching.vtu"), ("moved", moved)):
        study = parse_study(text.replace("craig_bampton_modes = 20",
                                         f'craig_bampton_modes = 20\nmesh = "{mesh}"'),
                            file=str(tmp_path / f"{name}.toml"), name=name)
        res = run_study(study, tmp_path / "out", figures=False, progress=False)
        assert res.ok
        out[name] = read_dataset(res.path)
    # measured 4.3e-5 (the shroud's elements moved) and 8.4e-5 (dual mortar; 8.5e-5 node to segment)
    for var, lo, hi in (("frequency_open", 0.0, 1e-4), ("frequency_stuck", 1e-6, 2e-4)):
        a, b = out["matching"][var].values, out["moved"][var].values
        assert np.isfinite(a).all() and a.shape == b.shape, var
        gap = np.abs(b / a - 1).max()
        assert lo <= gap < hi, (var, gap)


def test_the_curved_deck_of_20_node_hexahedra_pairs_through_its_8_node_facets(tmp_path):
    """A designer's deck (`tests/curved_wheel_blade.py`: C3D20, twisted and cambered
    airfoil, inclined shroud faces): its faces are 8-node facets, and every right point
    interpolated on them (not taken node to node) gives the node-to-node row to 1e-12."""
    from curved_wheel_blade import write_curved_wheel_blade
    from curved_wheel_blade import DISK as CURVED_DISK

    params = BladeParams(n_chord=6, n_thick=1, n_span=4)
    deck = write_curved_wheel_blade(tmp_path / "blade.inp", params)
    blade = blade_model(Blade(params, mesh=str(deck), disk=CURVED_DISK))
    R, L = blade.frames["shroud_right"], blade.frames["shroud_left"]
    assert L.facets.shape[1] == 8 and len(R.points) >= 30
    W = pairing(R.points, L.points, CURVED_DISK, L.facets)
    assert W.nnz == W.shape[0] and np.all(W.data == 1.0)           # node to node
    back = CURVED_DISK.rotate(R.points, -CURVED_DISK.pitch_angle)
    rows = on_facets(back, L.points, L.facets, PAIR_TOLERANCE * np.ptp(R.points, axis=0).max())
    Wi = np.zeros(W.shape)
    for k, (ids, w) in enumerate(rows):
        Wi[k, ids] += w
    assert np.abs(Wi - W.toarray()).max() < 1e-12
