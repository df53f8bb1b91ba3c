"""Exported matrices in study files: `[scene.matrices]` of a solid blade.

    [scene]
    model = "solid_blade"
    mesh = "blade.inp"                  # the mesh the matrices belong to (node sets)
    [scene.matrices]
    format = "calculix"                 # calculix | abaqus | ansys | matrix_market
    job = "blade"                       # calculix: blade.sti, blade.mas, blade.dof
    units = "SI"                        # SI (N/m, kg, m) | mm (N/mm, tonne, mm)

abaqus: `stiffness`, `mass` (`*MATRIX OUTPUT, FORMAT=COORDINATE` files); ansys:
`stiffness`, `mass` (HBMAT files), `mapping`; matrix_market: `stiffness`, `mass`,
`dofs` (the "node direction" table).  Paths are relative to the study file.  The
blade is then `structure.exchange.imported.import_blade`: K and M from the files,
the rest (faces, frames, sets) from the mesh.
"""
from __future__ import annotations

from pathlib import Path

from ...structure.exchange.imported import FORMATS, UNITS, MatrixFiles

FILES = {"calculix": ("job",), "abaqus": ("stiffness", "mass"),
         "ansys": ("stiffness", "mass", "mapping"),
         "matrix_market": ("stiffness", "mass", "dofs")}


def scene_matrices(ck, tab: dict, mesh, base_dir: Path) -> MatrixFiles | None:
    """The `MatrixFiles` of a blade [scene] table's `matrices` (None without one);
    `mesh`: the scene's mesh file, which the matrices need."""
    if "matrices" not in tab:
        return None
    if mesh is None:
        ck.fail("scene.matrices", "exported matrices need the mesh they belong to: "
                                  "give scene.mesh (the deck with the node sets)")
    return parse_matrices(ck, tab["matrices"], "scene.matrices", base_dir)


def parse_matrices(ck, value, field: str, base_dir: Path) -> MatrixFiles:
    """The `MatrixFiles` of a [scene.matrices] table (files checked to exist)."""
    t = ck.table(value, field)
    if "format" not in t:
        ck.fail(f"{field}.format", f"missing (required): one of {', '.join(FORMATS)}")
    fmt = ck.string(t["format"], f"{field}.format", FORMATS)
    ck.keys(t, field, ("format", "units") + FILES[fmt], required=("units",) + FILES[fmt])
    units = ck.string(t["units"], f"{field}.units", tuple(UNITS))
    paths = []
    for key in FILES[fmt]:
        s = ck.string(t[key], f"{field}.{key}")
        path = Path(s) if Path(s).is_absolute() else base_dir / s
        needed = ([path.with_suffix(x) for x in (".sti", ".mas", ".dof")] if fmt == "calculix"
                  else [path])
        for f in needed:
            if not f.is_file():
                ck.fail(f"{field}.{key}", f"file {str(f)!r} not found")
        paths.append(str(path))
    stiffness, mass, dofs = (paths + [None, None])[:3]
    return MatrixFiles(fmt, stiffness, mass, dofs, units)
