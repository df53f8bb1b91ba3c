"""Blade FE models: closed forms (Euler-Bernoulli), scikit-fem reference forms,
contact frames, mesh files."""
from dataclasses import replace

import meshio
import numpy as np
import pytest
from skfem import Basis, BilinearForm, ElementHex2, ElementVector, MeshHex, MeshTet, asm
from skfem.models.elasticity import lame_parameters, linear_elasticity

from pipeline.structure.beam import euler_bernoulli_frequencies
from pipeline.structure.blades import build_blade, load_blade
from pipeline.structure.fe_model import BladeParams, boundary_dofs, point_displacements
from pipeline.structure.mesh_io import read_mesh, write_fields, write_mesh
from pipeline.structure.solid import assemble_elasticity
from pipeline.structure.reduction import eigenmodes

COARSE = BladeParams(n_chord=4, n_thick=1, n_span=8)


def freqs(model, k):
    w2, X = eigenmodes(model.K, model.M, k)
    return np.sqrt(w2) / (2 * np.pi), X


@pytest.mark.parametrize("field, value", [
    ("length", 0.0), ("chord", -1.0), ("thickness", np.nan), ("E", 0.0), ("rho", -1.0),
    ("nu", 0.5), ("shroud_angle", 2.0), ("stagger_angle", -1.6), ("n_span", 0),
    ("n_chord", 1.5), ("kind", "shell"), ("damping_ratios", (-0.1,)),
    ("shroud_width", 0.003),
])
def test_params_validation_names_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        replace(BladeParams(), **{field: value})


def test_shroud_angle_far_from_stagger_is_rejected():
    with pytest.raises(ValueError, match="shroud_angle"):
        BladeParams(shroud_angle=np.deg2rad(70), stagger_angle=0.0)


def test_vectorised_elasticity_matches_scikit_fem_forms():
    m = MeshHex.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 0.5, 2), np.linspace(0, 2, 3))
    m = replace(m, doflocs=m.p + 0.05 * np.sin(3 * m.p[[1, 2, 0]]))  # curved cells
    bv = Basis(m, ElementVector(ElementHex2()), intorder=4)
    K0 = asm(linear_elasticity(*lame_parameters(2.0, 0.3)), bv)
    M0 = asm(BilinearForm(lambda u, v, w: 3.0 * (u[0] * v[0] + u[1] * v[1] + u[2] * v[2])), bv)
    K, M = assemble_elasticity(Basis(m, ElementHex2(), intorder=4), 2.0, 0.3, 3.0, chunk=5)
    assert abs(K - K0).max() < 1e-13 * abs(K0).max()
    assert abs(M - M0).max() < 1e-13 * abs(M0).max()


def test_beam_flap_frequencies_match_euler_bernoulli():
    p = BladeParams(kind="beam", n_span=16, shroud=False)
    model = build_blade(p)
    f, X = freqs(model, 12)
    n_flap = 2 * (p.n_span + 1) - 2  # free DOFs of the flap field (first block)
    is_flap = np.linalg.norm(X[:n_flap], axis=0) > 0.99 * np.linalg.norm(X, axis=0)
    f_flap = f[is_flap][:3]
    ref = euler_bernoulli_frequencies(p, 3)
    np.testing.assert_allclose(f_flap, ref, rtol=1e-3)
    assert np.max(abs(f_flap / ref - 1)) < 1e-4  # measured: 2e-5 at 16 elements


def test_solid_cantilever_converges_towards_euler_bernoulli():
    base = BladeParams(length=0.1, chord=0.01, thickness=0.005, shroud=False,
                       stagger_angle=0.0)
    ref = euler_bernoulli_frequencies(base, 1)[0]
    errors = []
    for nc, nt, ns in [(1, 1, 2), (1, 1, 4), (2, 1, 8), (2, 2, 16)]:
        f, _ = freqs(build_blade(replace(base, n_chord=nc, n_thick=nt, n_span=ns)), 1)
        errors.append(f[0] / ref - 1)
    errors = np.array(errors)
    assert np.all(errors > 0)  # conforming FE: from above (plate effect adds ~0.4 %)
    assert np.all(np.diff(errors) < 0), errors
    assert errors[-1] < 0.01


@pytest.fixture(scope="module")
def coarse():
    return build_blade(COARSE)


def test_named_sets_and_sizes(coarse):
    assert set(coarse.dof_sets) == {"shroud_left", "shroud_right", "excitation", "response"}
    for name in ("shroud_left", "shroud_right"):
        d = coarse.dof_sets[name]
        assert d.ndim == 2 and d.shape[1] == 3 and np.all(d >= 0)
        # Hex2: vertex, edge and face DOF points of the face, (2 nx + 1)(2 nz + 1)
        assert d.shape[0] == coarse.frames[name].points.shape[0]
    b, labels = boundary_dofs(coarse)
    assert np.unique(b).size == b.size == len(labels)
    assert labels[0] == "shroud_left:0:x"


def test_contact_frames_are_tilted_by_the_shroud_angle(coarse):
    a = COARSE.shroud_angle
    nR, nL = coarse.frames["shroud_right"].normal, coarse.frames["shroud_left"].normal
    np.testing.assert_allclose(nR, [-np.sin(a), np.cos(a), 0.0], atol=1e-12)
    np.testing.assert_allclose(nL, -nR, atol=1e-12)
    for f in coarse.frames.values():
        E = np.stack([f.tangent, f.tangent2, f.normal])
        np.testing.assert_allclose(E @ E.T, np.eye(3), atol=1e-12)
        # all DOF points (incl. edge/face DOFs of Hex2) lie on the plane
        off = (f.points - f.points.mean(axis=0)) @ f.normal
        assert np.max(abs(off)) < 1e-12


def test_contact_maps_project_rigid_translation(coarse):
    d = np.array([1.0, -2.0, 0.5])
    u = np.zeros(coarse.n_dof)
    for c in range(3):
        u[coarse.point_dofs[coarse.point_dofs[:, c] >= 0, c]] = d[c]
        for dofs in coarse.dof_sets.values():
            u[dofs[:, c]] = d[c]
    for f in coarse.frames.values():
        Bt, Bn, Bt2 = f.maps(coarse.n_dof)
        np.testing.assert_allclose(Bt @ u, f.tangent @ d)
        np.testing.assert_allclose(Bn @ u, f.normal @ d)
        np.testing.assert_allclose(Bt2 @ u, f.tangent2 @ d)
        assert Bt.shape == (f.points.shape[0], coarse.n_dof)


@pytest.mark.parametrize("suffix", [".vtu", ".msh", ".xdmf"])
def test_mesh_round_trip_same_frequencies(coarse, tmp_path, suffix):
    if suffix == ".xdmf":
        pytest.importorskip("h5py")  # meshio's XDMF reader/writer needs it
    path = write_mesh(coarse, tmp_path / f"blade{suffix}")
    loaded = load_blade(path, COARSE, required=("root", "shroud_left", "shroud_right",
                                                "excitation", "response"))
    assert loaded.n_dof == coarse.n_dof
    f0, _ = freqs(coarse, 6)
    f1, _ = freqs(loaded, 6)
    np.testing.assert_allclose(f1, f0, rtol=1e-10)
    for name in coarse.dof_sets:
        np.testing.assert_array_equal(loaded.dof_sets[name], coarse.dof_sets[name])


def test_missing_set_names_file_and_set(coarse, tmp_path):
    path = tmp_path / "noshroud.vtu"
    data = {k: np.isin(np.arange(len(coarse.points)), v).astype(np.int32)
            for k, v in coarse.node_sets.items() if k != "shroud_left"}
    meshio.write(path, meshio.Mesh(coarse.points, list(coarse.cells), point_data=data))
    with pytest.raises(ValueError, match=r"noshroud\.vtu.*'shroud_left'"):
        load_blade(path, COARSE)
    with pytest.raises(ValueError, match="does not exist"):
        read_mesh(tmp_path / "nothing.vtu")


def test_a_file_meshio_cannot_parse_is_a_value_error_and_prints_nothing(tmp_path, capfd):
    """meshio.read prints why and exits the process on such a file; read_mesh says it in
    one ValueError naming the file."""
    (tmp_path / "garbage.vtu").write_text("not a mesh\n")
    (tmp_path / "garbage.inp").write_text("*ELEMENT, TYPE=C3D8\n1, 1, 2, 3, 4, 5, 6, 7, 8\n")
    for name in ("garbage.vtu", "garbage.inp"):
        with pytest.raises(ValueError, match=rf"garbage\.(vtu|inp): not a readable "
                                             r"(mesh|deck) \(.+\)$"):
            read_mesh(tmp_path / name)
    assert capfd.readouterr() == ("", "")


def test_gmsh_physical_groups_are_node_sets(coarse, tmp_path):
    """User meshes may carry sets as tagged cells (gmsh physical groups)."""
    root = coarse.node_sets["root"]
    nh = len(coarse.cells[0][1])
    tags = [np.ones(nh, dtype=int), np.full(root.size, 2)]
    m = meshio.Mesh(coarse.points, list(coarse.cells) + [("vertex", root[:, None])],
                    cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
                    field_data={"blade": np.array([1, 3]), "root": np.array([2, 0])})
    meshio.write(tmp_path / "tagged.msh", m, file_format="gmsh22")
    mesh, sets = read_mesh(tmp_path / "tagged.msh", required=("root",))
    np.testing.assert_array_equal(np.sort(sets["root"]), np.sort(root))
    assert mesh.t.shape[1] == nh


@pytest.mark.parametrize("name, params", [("blade_coarse.vtu", COARSE),
                                          ("blade_default.vtu", BladeParams()),
                                          ("blade_default.msh", BladeParams())])
def test_stored_mesh_files_load(name, params):
    """meshes/<name> is `write_mesh(build_blade(params), ...)`."""
    from pathlib import Path
    path = Path(__file__).parents[2] / "meshes" / name
    loaded = load_blade(path, params)
    ref = build_blade(params)
    assert set(loaded.dof_sets) == set(ref.dof_sets)
    np.testing.assert_allclose(freqs(loaded, 3)[0], freqs(ref, 3)[0], rtol=1e-10)


def test_mode_shape_export(coarse, tmp_path):
    f, X = freqs(coarse, 2)
    path = write_fields(coarse, tmp_path / "modes.vtu",
                        {"mode_1": X[:, 0], "ods": X[:, 1] * (1 + 2j)})
    m = meshio.read(path)
    assert m.point_data["mode_1"].shape == (len(coarse.points), 3)
    np.testing.assert_allclose(m.point_data["ods_im"], 2 * m.point_data["ods_re"])
    root = coarse.node_sets["root"]
    assert np.all(m.point_data["mode_1"][root] == 0)
    d = point_displacements(coarse, X[:, :2])
    assert d.shape == (len(coarse.points), 3, 2)


def test_user_tetrahedral_mesh_uses_p2_and_agrees_with_hex(tmp_path):
    p = BladeParams(length=0.1, chord=0.01, thickness=0.005, shroud=False, stagger_angle=0.0,
                    n_chord=2, n_thick=1, n_span=10)
    tet = MeshTet.init_tensor(np.linspace(-0.005, 0.005, 3), np.linspace(-0.0025, 0.0025, 2),
                              np.linspace(0.0, 0.1, 11))
    root = np.isclose(tet.p[2], 0.0).astype(np.int32)
    path = tmp_path / "tet.vtu"
    meshio.write(path, meshio.Mesh(tet.p.T, [("tetra", tet.t.T)], point_data={"root": root}))
    model = load_blade(path, p, required=("root",))
    assert model.cells[0][0] == "tetra"
    f_tet, _ = freqs(model, 1)
    f_hex, _ = freqs(build_blade(p), 1)
    ref = euler_bernoulli_frequencies(p, 1)
    assert abs(f_tet[0] / f_hex[0] - 1) < 0.01  # TetP2 does not lock (TetP1: +41 %)
    assert abs(f_tet[0] / ref[0] - 1) < 0.02
