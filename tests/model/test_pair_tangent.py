"""The slip direction of a shroud pair, in one place (`model.contacts.pair_frame`): the
disk's circumferential direction at the right face's centre, projected into the face
-- computed here from the face's points and the disk axis alone.  On a face inclined to
the axis it differs from the face frame's n_R x e_Z (which a face against a wall uses)."""
import numpy as np

from pipeline.model.contacts import ShroudPair, pair_frame
from pipeline.structure.blades import build_blade
from pipeline.structure.fe_model import BladeParams, DiskPlacement


def test_pair_slides_along_the_circumferential_direction_projected_into_the_face():
    disk = DiskPlacement(hub_radius=0.12, sectors=36)
    blade = build_blade(BladeParams(n_chord=2, n_thick=1, n_span=4,
                                    shroud_angle=np.deg2rad(30.0)), disk)
    face = blade.frames["shroud_right"]
    t, n = pair_frame(blade, ShroudPair("shroud", 1e5, 1e5, 0.3, 1.0), disk)
    # by hand: the centre's position about the axis (X through (0, 0, -R)), e_theta
    c = face.points.mean(axis=0) - np.array([0.0, 0.0, -0.12])
    e_theta = np.array([0.0, c[2], -c[1]]) / np.hypot(c[1], c[2])
    expected = e_theta - (e_theta @ n) * n
    expected /= np.linalg.norm(expected)
    np.testing.assert_allclose(t, expected, atol=1e-14)
    assert abs(t @ n) < 1e-14 and abs(np.linalg.norm(t) - 1) < 1e-14
    # not the face frame's tangent: the two differ by a visible angle on this face
    angle = np.degrees(np.arccos(min(1.0, abs(t @ face.tangent))))
    assert angle > 0.5
