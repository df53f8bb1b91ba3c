"""A wheel blade as a designer's FE code has it, written as a CalculiX deck for the
mesh route (`[scene] mesh = "blade.inp"`): 20-node hexahedra (C3D20) whose midside
nodes lie on a twisted, cambered airfoil, and a tip shroud whose faces pair across the
pitch.

It starts from the package's generated wheel blade (`solid.solid_mesh` with a disk
placement: the left shroud face is the right one turned by -2 pi / N about the disk
axis, node for node) and moves every node of the airfoil below the shroud, midside
nodes included, by a smooth map of the section frame (xi along the chord, eta across
it, s = z / L along the span; gamma the stagger angle, c the chord):

    camber   eta += k c (1 - (2 xi / c)^2) (1 - s^2)       (k = `camber`)
    twist    turned about Z by theta(s) = theta_max sin(pi s)  (theta_max = `twist`)

Both vanish at the shroud's root (s = 1) and above, so the shroud, and the pairing of
its faces, is the generated one; chordwise edges are bent by the camber and spanwise
edges by the twist, so the cells are curved (their corners alone are another blade).
`python tests/curved_wheel_blade.py FOLDER [n_chord n_thick n_span]` writes one as
FOLDER/blade.inp, and beside it the response study `STUDY` on it as FOLDER/study.toml
(EO 3 at 8,000 rpm, a shroud gap of 20 um which the centrifugal load closes in part;
pipeline/bench/README.md "Cost estimates" gives its cost and its variants).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from skfem import MeshHex2

from pipeline.structure.disk import wheel_params
from pipeline.structure.exchange.calculix_deck import write_deck
from pipeline.structure.fe_model import BladeParams, DiskPlacement
from pipeline.structure.solid import solid_mesh

DISK = DiskPlacement(hub_radius=0.12, sectors=36)     # as studies/shrouded_disk*.toml
TWIST = np.deg2rad(12.0)   # rad: the largest twist, at mid-span
CAMBER = 0.08              # camber height / chord at the root

# the response study on it: a turning disk whose shroud gap closes in part
STUDY = """
[study]
title = "curved wheel blade from a deck, 36 sectors, EO 3: shroud gap 20 um at 8,000 rpm"
[scene]
model = "solid_blade"
mesh = "blade.inp"
effects = ["friction", "normal_load_variation", "separation", "cyclic_coupling",
           "centrifugal_stiffening"]
craig_bampton_modes = 20
rayleigh = [20.0, 4e-6]
[scene.disk]
sectors = 36
hub_radius = 0.12
engine_order = 3
[[scene.contact]]
pair = "shroud"
ku = 5e5
kv = 5e5
mu = 0.3
stiffness = "per_face"
interference = -2e-5
[[scene.excitation]]
set = "excitation"
direction = [0.0, 1.0, 0.0]
amplitude = 1.0
[sweep]
speed = [8000.0]
frequency = { start = 180.0, stop = 550.0, unit = "Hz" }
[solver]
harmonics = 1
force_evaluation = "exact"
tolerance = 1e-8
[output]
dofs = ["response.y"]
figures = ["amplitude"]
yscale = "log"
"""


def airfoil_map(X, z, p: BladeParams, twist: float = TWIST, camber: float = CAMBER):
    """The points X (3, n) [m] of the straight wheel blade moved onto the twisted,
    cambered airfoil (module docstring); `z` (n,) [m] their span coordinates on the
    generated grid (the wheel's left overhang is turned about the disk axis, which
    moves its z off the grid's): points at z >= L (the shroud) unmoved."""
    g = p.stagger_angle
    e_c, e_n = np.array([np.cos(g), np.sin(g)]), np.array([-np.sin(g), np.cos(g)])
    s = np.clip(z / p.length, 0.0, 1.0)
    xi, eta = e_c @ X[:2], e_n @ X[:2]
    eta = eta + camber * p.chord * (1 - (2 * xi / p.chord) ** 2) * (1 - s ** 2)
    th = twist * np.sin(np.pi * s)
    xi, eta = xi * np.cos(th) - eta * np.sin(th), xi * np.sin(th) + eta * np.cos(th)
    Y = X.copy()
    Y[:2] = np.outer(e_c, xi) + np.outer(e_n, eta)
    below = z < p.length * (1 - 1e-12)
    Y[:, ~below] = X[:, ~below]
    return Y


def curved_wheel_blade(p: BladeParams = BladeParams(), disk: DiskPlacement = DISK,
                       twist: float = TWIST, camber: float = CAMBER):
    """(MeshHex2 whose edge, face and body nodes lie on the curved blade, vertex sets
    root / shroud_left / shroud_right / excitation / response, the wheel's params)."""
    mesh, sets = solid_mesh(p, disk)
    wp = wheel_params(p, disk)
    grid = MeshHex2.from_mesh(solid_mesh(wp)[0]).doflocs[2]   # the same cells, unturned
    X = airfoil_map(MeshHex2.from_mesh(mesh).doflocs, grid, p, twist, camber)
    return MeshHex2(X, mesh.t), sets, wp


def write_curved_wheel_blade(path, p: BladeParams = BladeParams(), disk: DiskPlacement = DISK,
                             twist: float = TWIST, camber: float = CAMBER):
    """Write the curved wheel blade as a C3D20 deck at `path` (.inp): its nodes, cells,
    the sets as *NSETs (vertices and the midside nodes between them) and the material
    of `p`.  Returns the path."""
    mesh, sets, wp = curved_wheel_blade(p, disk, twist, camber)
    return write_deck(mesh, sets, wp, path)


if __name__ == "__main__":
    folder = Path(sys.argv[1])
    folder.mkdir(parents=True, exist_ok=True)
    counts = [int(a) for a in sys.argv[2:5]]
    params = BladeParams(**dict(zip(("n_chord", "n_thick", "n_span"), counts)))
    print(write_curved_wheel_blade(folder / "blade.inp", params))
    (folder / "study.toml").write_text(STUDY)
    print(folder / "study.toml")
