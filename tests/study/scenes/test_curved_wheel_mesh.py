"""A designer's shrouded wheel blade through the mesh route: 20-node hexahedra on a
twisted, cambered airfoil (`tests/curved_wheel_blade.py`), written as a CalculiX deck
and read by a turning-disk study (`[scene] mesh`, 36 sectors, a shroud gap of 20 um
closed in part by the centrifugal load at 8,000 rpm).

Checked: the deck's midside nodes lie off the straight edges and the mesh route keeps
them (the volume of the volume-preserving map equals the straight blade's); the
shroud faces pair node for node, 33 pairs a face (counted by hand); the static
contact state is partial; and the peak shape written for a turning case is the
Craig-Bampton expansion at the case's speed, against the unreduced blade at that
speed solved for its interior (the reduction at rest put it 0.44 % off)."""
import meshio
import numpy as np
import pytest
import scipy.sparse.linalg as spla
from skfem import Basis, ElementHexS2, MeshHex

from pipeline.fourier.harmonics import amplitude_half_peak_to_peak
from pipeline.model.blade_cache import blade_at_speed, blade_model, reduced_model
from pipeline.model.static_load import static_state
from pipeline.solve.response.response import ResponseCurve
from pipeline.structure.fe_model import BladeParams, point_displacements
from pipeline.structure.mesh_io import read_volume
from pipeline.structure.reduction import reconstruct
from pipeline.study.datasets.response_dataset import to_dataset
from pipeline.study.figures.peak_shapes import write_peak_shapes
from pipeline.study.files.documents import load_study
from curved_wheel_blade import STUDY, curved_wheel_blade, write_curved_wheel_blade

# 6 chordwise elements: a shroud face of 7 x 2 vertices, 6 x 2 chordwise and 7 radial
# midside nodes = 33 node pairs
BLADE = BladeParams(n_chord=6, n_thick=1, n_span=6)
PAIRS = 7 * 2 + 6 * 2 + 7



@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    path = tmp_path_factory.mktemp("curved_wheel")
    write_curved_wheel_blade(path / "blade.inp", BLADE)
    (path / "study.toml").write_text(STUDY)
    return path


def test_the_deck_keeps_its_curved_midside_nodes(folder):
    """The airfoil's midside nodes lie off their straight edges (by up to 0.35 % of
    the chord), and the mesh route keeps them: twist and camber keep volumes, so the
    curved blade weighs what the straight one does (to the quadratic cells'
    approximation of the map: 2.6e-6), and its corners alone do not (7.2e-4 less)."""
    vol = read_volume(folder / "blade.inp", ("root",))
    assert vol.cell_type == "hexahedron20"
    mesh, _, _ = curved_wheel_blade(BLADE)
    bow = np.linalg.norm(mesh.p[:, mesh.nvertices:][:, :mesh.edges.shape[1]]
                         - mesh.p[:, mesh.edges].mean(axis=1), axis=0)
    assert bow.max() > 2e-3 * BLADE.chord          # measured 3.5e-3
    straight = curved_wheel_blade(BLADE, twist=0.0, camber=0.0)[0]

    def volume(m):
        return Basis(m, ElementHexS2(), intorder=4).dx.sum()

    v0 = volume(straight)
    assert abs(volume(vol.mesh) / v0 - 1) < 2e-5                    # measured 2.6e-6
    corners = MeshHex(vol.mesh.p[:, :vol.mesh.nvertices], vol.mesh.t)
    assert abs(volume(corners) / v0 - 1) > 3e-4                     # measured 7.2e-4


def test_shroud_faces_pair_33_nodes_and_touch_in_part(folder):
    """33 node pairs a face, each element a pair; the static state at 8,000 rpm
    with the 20 um gap: some pairs closed (compressive loads), the others open (no
    load)."""
    study = load_study(folder / "study.toml")
    system = study.system(study.sweep.cases()[0][1])
    assert system.contact.n0.size == PAIRS
    st = static_state(system)
    assert 0 < st.closed.sum() < PAIRS
    assert np.all(st.load[st.closed] > 0) and np.all(st.load[~st.closed] == 0)


def test_the_peak_shape_of_a_turning_case_is_expanded_at_its_speed(folder, tmp_path):
    """The VTU of a case at 8,000 rpm: a response of the reduced blade at that speed
    to the excitation (330 Hz) expanded by the VTU equals the unreduced blade at that
    speed given the boundary motion (interior rows solved; the excitation acts on a
    boundary node) to 2e-4 (measured 4.1e-5, Craig-Bampton's own error; expanded by the
    reduction at rest, as before: 4.4e-3)."""
    study = load_study(folder / "study.toml")
    case = study.sweep.cases()[0][1]
    st = study.scene.structure
    red = reduced_model(st, study.scene.reduction, case["speed"])[0]
    w = 2 * np.pi * 330.0
    F = np.zeros(red.M.shape[0], complex)
    F[red.sets["excitation"][0][1]] = 1.0
    q = np.linalg.solve(red.K - w * w * red.M + 1j * w * red.C, F)
    Q = np.zeros((1, q.size, 3))
    Q[0, :, 1], Q[0, :, 2] = q.real, -q.imag
    curve = ResponseCurve(parameter=np.array([w]), omega=np.array([w]), Q=Q,
                          converged=np.ones(1, bool), residual=np.zeros(1),
                          stable=np.ones(1, bool), amplitude=amplitude_half_peak_to_peak(Q),
                          fold_parameter=np.zeros(0), newton_iterations=np.ones(1, int),
                          nfev=1, wall_time=0.1, success=True, status=0, message="ok", H=1,
                          tolerance=1e-8)
    path, = write_peak_shapes(study, to_dataset(study, [curve]), [curve], tmp_path)
    got = meshio.read(path).point_data
    blade = blade_at_speed(st, case["speed"])
    alpha, beta = st.rayleigh
    S = (blade.K * (1 + 1j * w * beta) - w * w * (1 - 1j * alpha / w) * blade.M).tocsr()
    b, i = red.boundary, red.interior
    u = np.zeros(blade.n_dof, complex)
    u[b] = q[:b.size]
    u[i] = spla.spsolve(S[i][:, i].tocsc(), -(S[i][:, b] @ u[b]))
    ref = point_displacements(blade_model(st), u)
    vtu = got["harmonic1_re"] + 1j * got["harmonic1_im"]
    assert np.abs(vtu - ref).max() < 2e-4 * np.abs(ref).max()
    assert np.abs(reconstruct(red, q) - u).max() < 2e-4 * np.abs(u).max()
