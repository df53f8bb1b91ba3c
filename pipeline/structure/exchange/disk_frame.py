"""An exported blade moved from its model's frame into the disk frame.

The package's disk frame (`fe_model.DiskPlacement`): the engine axis parallel to X
through c = (0, 0, -R), Z radial out through the blade, Y = Z x X towards the next
blade (j+1, turned by 2 pi / N about the axis).  A model from another FE code has its
own engine axis: through the point p along the direction d (in the model's frame).
The blade is moved rigidly,

    x_disk = Q (x - p) + c,     Q = [e_x; e_y; e_z] (rows),
    e_x = d / |d|,   e_z = P (g - p) / |P (g - p)|,   e_y = e_z x e_x,

P = I - e_x e_x^T, g the centroid of the root set's nodes (the blade's radial line),
and each node's displacement with it, u_disk = Q u: over the vector DOFs 3 s + d,
T = I_N kron Q and

    K_disk = T K T^T,   M_disk = T M T^T          (the energy u^T K u unchanged),

the stiffness exported at each speed likewise.  Q is a proper rotation (e_x x e_y =
e_z), so the model's right face must face e_y = e_z x e_x: the next blade lies towards
r x d, r radial; a model numbered the other way reverses d.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp


def disk_frame(axis, root_points, centre) -> tuple:
    """(Q (3, 3), b (3,)): x_disk = Q x + b for the engine axis `axis` = (point p,
    direction d) [m] of the model, `root_points` (3, k) [m] its root nodes and `centre`
    c [m] the disk frame's point p maps to (see the module).  ValueError for a
    direction that is zero or not finite, or a root centred on the axis."""
    p, d = (np.asarray(v, float) for v in axis)
    n = float(np.linalg.norm(d)) if np.all(np.isfinite(d)) else 0.0
    if not n > 0:
        raise ValueError(f"the axis direction {tuple(d)} is zero or not finite")
    ex = d / n
    g = np.asarray(root_points, float).mean(axis=1) - p
    r = g - ex * (ex @ g)
    size = float(np.max(np.ptp(root_points, axis=1))) if np.size(root_points) else 0.0
    if not np.linalg.norm(r) > 1e-9 * max(size, float(np.linalg.norm(g))):
        raise ValueError(f"the root's centroid {tuple(g + p)} lies on the axis through "
                         f"{tuple(p)} along {tuple(d)}: no radial direction (is the axis "
                         "the engine's?)")
    ez = r / np.linalg.norm(r)
    Q = np.vstack([ex, np.cross(ez, ex), ez])
    return Q, np.asarray(centre, float) - Q @ p


def moved_mesh(mesh, Q, b):
    """The scikit-fem mesh (linear, or curved MeshHex2 / MeshTet2: every node) moved
    to Q x + b."""
    X = Q @ mesh.doflocs + np.asarray(b, float)[:, None]
    return type(mesh)(np.ascontiguousarray(X), mesh.t)


def turned(A, Q) -> sp.csr_matrix:
    """T A T^T, T = I_N kron Q: a matrix over the vector DOFs 3 s + d turned node by
    node by Q (3, 3)."""
    T = sp.kron(sp.identity(A.shape[0] // 3, format="csr"), sp.csr_matrix(Q), format="csr")
    return (T @ A @ T.T).tocsr()


def moved_volume(vol, Q, b):
    """A `mesh_io.VolumeMesh` moved to Q x + b (sets and numbering unchanged)."""
    return replace(vol, mesh=moved_mesh(vol.mesh, Q, b))


def check_right_face(frame, direction, centre, source) -> None:
    """ValueError when the right shroud face (its `ContactFrame` in the disk frame)
    faces away from the next blade (-Y about the axis through `centre`): the model's
    blades are numbered the other way about the axis `direction` (the model's), which
    reversed fixes it."""
    x = frame.points.mean(axis=0) - np.asarray(centre, float)
    towards_next = np.array([0.0, x[2], -x[1]])
    if frame.normal @ towards_next < 0:
        d = tuple(float(v) for v in direction)
        raise ValueError(f"{source}: the shroud_right face faces the blade before, not the "
                         f"next one, about the axis along {d}: the next blade lies towards "
                         "r x direction (r radial out through the blade): reverse the axis "
                         "direction")
