"""Write `bladed_disk_sector.inp`: a blade on its disk sector as a designer's FE code has
it -- a CalculiX deck of 20-node hexahedra (C3D20) with the bore clamped (`root`), the
two cyclic cut faces (`cyclic_low`, `cyclic_high`), and shroud faces meshed
differently: the left face's vertices inside its chordwise extent are moved along it by
0.3 of the chordwise element size, so no node of the right face turned by the pitch
lands on one of the left face (the pairing interpolates on the left face's 8-node
facets).  The blade and its disk sector are the package's generated ones
(`pipeline.structure.disk_sector.sector_mesh`): the default blade at 4 x 1 x 8
elements, hub radius 0.12 m, 36 sectors, bore radius 0.08 m.

    python meshes/bladed_disk_sector.py [FOLDER]      (default: this folder)
"""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from pipeline.structure.disk import wheel_params
from pipeline.structure.disk_sector import DiskSector, sector_mesh
from pipeline.structure.exchange.calculix_deck import write_deck
from pipeline.structure.fe_model import BladeParams, DiskPlacement

BLADE = BladeParams(n_chord=4, n_thick=1, n_span=8)
DISK = DiskPlacement(hub_radius=0.12, sectors=36)       # m, N
SECTOR = DiskSector(bore_radius=0.08)                    # m
SHIFT = 0.3        # of the chordwise element size: the left face's inner vertices moved


def moved_left_face(mesh, sets, n_chord: int, shift: float = SHIFT):
    """The mesh with the left shroud face's vertices inside its chordwise extent moved
    along the face's longest extent by `shift` x the chordwise element size (the face
    keeps its outline and its plane)."""
    on = np.asarray(sets["shroud_left"])
    X = mesh.p[:, on].T
    centre = X.mean(axis=0)
    along = np.linalg.svd(X - centre, full_matrices=False)[2][0]
    c = (X - centre) @ along
    h = np.ptp(c) / n_chord
    inner = on[(c > c.min() + 0.1 * h) & (c < c.max() - 0.1 * h)]
    p = mesh.p.copy()
    p[:, inner] += shift * h * along[:, None]
    return replace(mesh, doflocs=p)


def write(folder=Path(__file__).parent) -> Path:
    """Write the deck into `folder`; its path."""
    mesh, sets, _ = sector_mesh(BLADE, DISK, SECTOR)
    mesh = moved_left_face(mesh, sets, BLADE.n_chord)
    return write_deck(mesh, sets, wheel_params(BLADE, DISK), Path(folder) / "bladed_disk_sector.inp")


if __name__ == "__main__":
    print(write(*(Path(a) for a in sys.argv[1:2])))
