"""Blades from parameters or mesh files: `build_blade` (beam or generated solid) and
`load_blade` (solid from a mesh file with named node sets)."""
from __future__ import annotations

from .beam import beam_blade
from .fe_model import (CONTACT_SETS, CUT_SETS, REQUIRED_SETS, BladeModel, BladeParams,
                       DiskPlacement)
from .mesh_io import check_span, read_volume
from .solid import MESH_ELEMENTS, solid_blade, solid_from_mesh


def build_blade(p: BladeParams, disk: DiskPlacement | None = None,
                rotation_centre=None) -> BladeModel:
    """Beam or solid blade according to `p.kind`, shaped for a wheel when `disk` is
    given (`solid.solid_mesh`, `beam.shroud_face_geometry`); a solid blade turning
    about the axis through `rotation_centre` carries its `rotation` terms."""
    if p.kind == "beam":
        if rotation_centre is not None:
            raise ValueError("a beam blade does not turn: centrifugal stiffening needs a "
                             "solid blade")
        return beam_blade(p, disk)
    return solid_blade(p, disk, rotation_centre)


def load_blade(path, p: BladeParams = BladeParams(),
               required=("root",) + CONTACT_SETS, rotation_centre=None,
               scale: float = 1.0, disk=None) -> BladeModel:
    """Solid blade from a mesh file (.msh/.vtu/.xdmf/.inp) with named node sets, its
    coordinates times `scale` in metres (1e-3: a mesh in millimetres); material and
    damping from `p`; the sets cyclic_low, cyclic_high make it a disk sector
    (`structure.cyclic_cut`).  A missing set raises ValueError naming file and set, as do
    coordinates that span more than a blade."""
    v = read_volume(path, required, scale=scale)
    check_span(v.mesh.p, path, 'set [scene] units = "mm"' if scale == 1.0
               else f"(read times {scale:g})")
    keep = {k: s for k, s in v.node_sets.items() if k in REQUIRED_SETS + CUT_SETS}
    return solid_from_mesh(v.mesh, keep, p, str(path), MESH_ELEMENTS[v.cell_type](),
                           rotation_centre=rotation_centre, disk=disk)
