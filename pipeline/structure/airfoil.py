"""A twisted, cambered, tapered airfoil: the generated solid blade's straight section
moved by a smooth map, its 27-node hexahedra curved with it.

In the section frame of the stagger gamma (xi along the chord, eta across it) and
s = z / L along the span (0 at the root, 1 where the shroud begins), each point of the
airfoil below the shroud moves by

    taper    xi  *= 1 + tau (1 - s)                      (tau = `taper`)
    camber   eta += k c_s (1 - (2 xi / c_s)^2) (1 - s^2)  (k = `camber`, c_s = c (1 + tau (1 - s)))
    twist    turned about Z by theta(s) = theta_r (1 - s)  (theta_r = `twist`)

so the root section is tau longer, cambered by k of its chord and staggered by
gamma + theta_r, and the section meets the shroud as generated (all three vanish at
s = 1): the shroud, its faces and their pairing across the pitch are the straight
blade's.  Every node of the quadratic mesh is mapped, midside and face nodes included,
so edges along the chord bend with the camber and edges along the span with the
twist (a 20-node deck of it is what a designer's pre-processor writes); each cell's
Jacobian is checked to keep the straight cell's sign at its integration points.
"""
from __future__ import annotations

import numpy as np
from skfem import MeshHex2

from .fe_model import BladeParams


def is_curved(p: BladeParams) -> bool:
    """True when the blade's airfoil is moved off the straight one."""
    return bool(p.twist or p.camber or p.taper)


def airfoil_map(X, z, p: BladeParams) -> np.ndarray:
    """The points X (3, n) [m] of the straight blade moved onto the airfoil (module
    doc); `z` (n,) [m] their span coordinates on the generated grid (a wheel's left
    overhang is turned about the disk axis, which moves its z off the grid's).
    Points at z >= L (the shroud) do not move."""
    g = p.stagger_angle
    e_c, e_n = np.array([np.cos(g), np.sin(g)]), np.array([-np.sin(g), np.cos(g)])
    s = np.clip(z / p.length, 0.0, 1.0)
    stretch = 1.0 + p.taper * (1.0 - s)
    xi, eta = stretch * (e_c @ X[:2]), e_n @ X[:2]
    c_s = p.chord * stretch
    eta = eta + p.camber * c_s * (1 - (2 * xi / c_s) ** 2) * (1 - s ** 2)
    th = p.twist * (1.0 - s)
    xi, eta = xi * np.cos(th) - eta * np.sin(th), xi * np.sin(th) + eta * np.cos(th)
    Y = np.array(X, dtype=float, copy=True)
    Y[:2] = np.outer(e_c, xi) + np.outer(e_n, eta)
    below = z < p.length * (1 - 1e-12)
    Y[:, ~below] = X[:, ~below]
    return Y


def curved_mesh(mesh, grid, p: BladeParams) -> MeshHex2:
    """The 27-node mesh of the linear blade mesh `mesh` with every node mapped by
    `airfoil_map`; `grid` the same cells unturned (the straight blade's mesh without a
    wheel's left overhang) for the span coordinates.  ValueError when a cell turns
    inside out (its Jacobian's sign not the straight cell's at a point of the 3 x 3 x 3
    Gauss rule)."""
    quad = MeshHex2.from_mesh(mesh)
    z = MeshHex2.from_mesh(grid).doflocs[2]
    out = MeshHex2(airfoil_map(quad.doflocs, z, p), mesh.t)
    g = np.polynomial.legendre.leggauss(3)[0] * 0.5 + 0.5
    pts = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1)
    det = out.mapping().detDF(pts) * np.sign(quad.mapping().detDF(pts))
    if not np.all(det > 0):
        raise ValueError(f"twist {p.twist!r} rad, camber {p.camber!r}, taper {p.taper!r}: "
                         f"{int(np.sum(np.any(det <= 0, axis=1)))} cell(s) of the curved "
                         "blade turn inside out: a smaller twist, camber or taper, or a "
                         "finer mesh")
    return out
