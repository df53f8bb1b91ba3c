"""A blade moved from its model's frame into the disk frame (`structure.exchange.disk_frame`),
against the map that put it there and against elasticity assembled in either frame."""
import numpy as np
import pytest
from skfem import Basis, ElementHex2

from pipeline.structure.exchange.disk_frame import disk_frame, moved_mesh, turned
from pipeline.structure.solid import assemble_elasticity, solid_mesh
from calculix import BLADE, DISK

# the model's engine axis along (1, 2, 2) / 3 through an offset point [m], the blade's
# radial line along (2, -2, 1) / 3 (orthogonal to it): x_model = Q0 x_disk + b0
POINT = np.array([0.4, -0.3, 0.25])
AXIS, RADIAL = np.array([1.0, 2.0, 2.0]) / 3, np.array([2.0, -2.0, 1.0]) / 3
Q0 = np.column_stack([AXIS, np.cross(RADIAL, AXIS), RADIAL])
B0 = POINT - Q0 @ DISK.centre


@pytest.fixture(scope="module")
def blade():
    """The wheel blade's mesh in the disk frame and in the model frame, its root nodes."""
    mesh, sets = solid_mesh(BLADE, DISK)
    return mesh, moved_mesh(mesh, Q0, B0), sets["root"]


def test_the_map_into_the_disk_frame_undoes_the_models(blade):
    """Q = Q0^T, b = -Q0^T b0 to 1e-15 (the wheel blade's root centroid lies at Y = 0);
    the disk frame's points recovered to 1e-15 m (the round-off of coordinates near
    0.7 m: measured 1.4e-16 m); any scale of the direction alike."""
    disk, model, root = blade
    for scale in (1.0, 7.5e-3):
        Q, b = disk_frame((POINT, scale * 3 * AXIS), model.p[:, root], DISK.centre)
        assert np.abs(Q - Q0.T).max() < 1e-15 and np.abs(b + Q0.T @ B0).max() < 1e-15
        assert np.isclose(np.linalg.det(Q), 1.0, atol=1e-15)
        assert np.abs(moved_mesh(model, Q, b).p - disk.p).max() < 1e-15


def test_stiffness_and_mass_turned_node_by_node_equal_the_disk_frames(blade):
    """T K T^T, T = I kron Q, of K and M assembled on the model-frame mesh equal K and M
    assembled on the disk-frame mesh (elasticity is frame-covariant) to 1e-13 of the
    largest entry (measured 9e-15); unturned, the stiffness differs by 0.5 of it."""
    disk, model, root = blade
    Q, _ = disk_frame((POINT, AXIS), model.p[:, root], DISK.centre)
    (Kd, Md), (Km, Mm) = (assemble_elasticity(Basis(m, ElementHex2(), intorder=4),
                                              2.0e11, 0.3, 7850.0) for m in (disk, model))
    for A, B in ((Kd, Km), (Md, Mm)):
        scale = abs(A).max()
        assert abs(turned(B, Q) - A).max() < 1e-13 * scale
    assert abs(Km - Kd).max() > 0.1 * abs(Kd).max()


@pytest.mark.parametrize("direction, why", [((0.0, 0.0, 0.0), "zero or not finite"),
                                            ((np.nan, 0.0, 1.0), "zero or not finite"),
                                            (RADIAL, "lies on the axis")])
def test_no_axis_direction_or_radial_line_is_refused(blade, direction, why):
    """A zero or non-finite direction, and a root centred on the axis (the axis through
    the root's centroid along the radial line: no radial direction left)."""
    _, model, root = blade
    point = model.p[:, root].mean(axis=1) if why == "lies on the axis" else POINT
    with pytest.raises(ValueError, match=why):
        disk_frame((point, direction), model.p[:, root], DISK.centre)
