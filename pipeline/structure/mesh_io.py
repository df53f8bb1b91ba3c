"""Mesh files (meshio): blade meshes with named node sets, displacement fields.

Node sets are stored as 0/1 point-data masks; read back from masks, meshio point
sets, cell sets or gmsh physical groups, their names ignoring case (pre-processors
write ROOT, SHROUD_LEFT).  An Abaqus / CalculiX deck (.inp) is read with its
`*INCLUDE` files inlined (`deck_lines`).
"""
from __future__ import annotations

import contextlib
import io
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import meshio
import numpy as np
from skfem import MeshHex, MeshTet
from skfem.io.meshio import HEX_MAPPING

from .fe_model import CUT_SETS, MAX_LENGTH, REQUIRED_SETS, BladeModel, point_displacements
from .quadratic_cells import CORNERS, curved_mesh

_INV_HEX = [HEX_MAPPING.index(i) for i in range(8)]
# volume cells of meshio that no element here honours: refused, never dropped
UNSUPPORTED = ("wedge", "wedge12", "wedge15", "wedge18", "pyramid", "pyramid13", "pyramid14",
               "hexahedron24", "tetra4", "tetra20", "hexahedron64")


def write_mesh(model: BladeModel, path, point_data: dict | None = None) -> Path:
    """Write the blade mesh with its named node sets (as 0/1 point-data masks) and
    optional extra point fields; the format follows the suffix (.vtu, .msh, .xdmf)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {}
    for name, nodes in model.node_sets.items():
        mask = np.zeros(len(model.points), dtype=np.int32)
        mask[nodes] = 1
        data[name] = mask
    data.update(point_data or {})
    kw = {"file_format": "gmsh22", "binary": True} if path.suffix == ".msh" else {}
    if path.suffix == ".msh":
        # gmsh needs a physical/geometrical tag per cell
        cd = {"gmsh:physical": [np.ones(len(c[1]), dtype=np.int32) for c in model.cells],
              "gmsh:geometrical": [np.ones(len(c[1]), dtype=np.int32) for c in model.cells]}
    else:
        cd = None
    meshio.write(path, meshio.Mesh(model.points, list(model.cells), point_data=data,
                                   cell_data=cd), **kw)
    return path


@dataclass(frozen=True, eq=False)
class VolumeMesh:
    """A volume mesh file read: `mesh` (scikit-fem: the corner vertices, and for
    quadratic cells the isoparametric MeshHex2 / MeshTet2 of all their nodes, curved
    edges as drawn: `quadratic_cells.curved_mesh`), `node_sets`
    (name -> vertex indices), `cell_type` (meshio's name of the volume cells, e.g.
    "hexahedron20"), `cells` (E, nodes) their full connectivity in file point indices
    (meshio's node order), `vertex` (file point -> vertex index, -1 for a midside or
    unused point) and `point_sets` (name -> file point indices, midside nodes too)."""

    mesh: object
    node_sets: dict
    cell_type: str
    cells: np.ndarray
    vertex: np.ndarray
    point_sets: dict


def read_mesh(path, required=REQUIRED_SETS):
    """Read a volume mesh and its named node sets: (skfem mesh, {name: vertex indices}).

    A set is found as (in order) a point-data mask, a meshio point set, or a cell
    set (its cells' nodes, e.g. gmsh physical surfaces).  Quadratic cells keep their
    midside nodes (their geometry, `read_volume`); the sets hold vertices; unused
    points are dropped.
    """
    v = read_volume(path, required)
    return v.mesh, v.node_sets


def deck_lines(path, depth: int = 0) -> list:
    """The lines of an Abaqus / CalculiX deck with each `*INCLUDE, INPUT=file` replaced
    by that file's lines (a path relative to the file that includes it), recursively."""
    path = Path(path)
    out = []
    for line in path.read_text(errors="replace").splitlines():
        m = re.match(r"\s*\*\s*INCLUDE\s*,.*?INPUT\s*=\s*([^,]+)", line, re.IGNORECASE)
        if not m:
            out.append(line)
            continue
        name = m.group(1).strip().strip("'\"")
        target = Path(name) if Path(name).is_absolute() else path.parent / name
        if not target.is_file():
            raise ValueError(f"{path}: *INCLUDE, INPUT={name}: no such file {target}")
        if depth >= 20:
            raise ValueError(f"{path}: *INCLUDE, INPUT={name}: included more than 20 deep "
                             "(a file that includes itself?)")
        out += deck_lines(target, depth + 1)
    return out


def _read_file(path: Path):
    """The meshio Mesh of a file; a deck read with its includes inlined; a file meshio
    cannot parse a ValueError (meshio.read prints why and exits)."""
    if path.suffix.lower() != ".inp":
        said = io.StringIO()
        try:
            with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
                return meshio.read(path)
        except SystemExit:
            why = " ".join(said.getvalue().split())
            raise ValueError(f"{path}: not a readable mesh (meshio: {why})") from None
    with tempfile.TemporaryDirectory() as tmp:
        flat = Path(tmp) / path.name
        flat.write_text("\n".join(deck_lines(path)) + "\n")
        try:
            return meshio.abaqus.read(flat)
        except (meshio.ReadError, KeyError, IndexError, ValueError, TypeError) as exc:
            raise ValueError(f"{path}: not a readable deck ({type(exc).__name__}: "
                             f"{exc})") from None


def check_span(X, path, hint: str) -> None:
    """ValueError when the points X (3, n) [m] span more than MAX_LENGTH: lengths in
    another unit (a mesh in millimetres read as metres spans 1000 times its size);
    `hint` says what to set."""
    span = float(np.max(np.ptp(X, axis=1))) if X.size else 0.0
    if span > MAX_LENGTH:
        raise ValueError(f"{path}: coordinates span {span:.3g} m, more than any turbine "
                         f"blade (at most {MAX_LENGTH:g} m): a mesh in millimetres? {hint}")


def read_volume(path, required=REQUIRED_SETS, scale: float = 1.0) -> VolumeMesh:
    """`read_mesh` with the file's cell type and point numbering (`VolumeMesh`);
    coordinates multiplied by `scale` (1e-3 for a mesh in millimetres)."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"mesh file {path} does not exist")
    m = _read_file(path)
    other = sorted({c.type for c in m.cells if c.type in UNSUPPORTED})
    if other:
        raise ValueError(f"{path}: {', '.join(other)} cells are not supported (no element here "
                         "honours them, and none is dropped): mesh the blade with hexahedra "
                         "(8, 20 or 27 nodes) or tetrahedra (4 or 10 nodes) only")
    blocks = [c for c in m.cells if c.type in CORNERS]
    if not blocks:
        raise ValueError(f"{path}: no hexahedral or tetrahedral cells "
                         f"(found {[c.type for c in m.cells]})")
    kinds = {c.type for c in blocks}
    if len(kinds) > 1:
        raise ValueError(f"{path}: one kind of volume cell per mesh, found {sorted(kinds)}")
    cell_type = blocks[0].type
    full = np.concatenate([c.data for c in blocks])
    conn = full[:, :CORNERS[cell_type]]
    sets = _named_sets(m, path, tuple(required) + REQUIRED_SETS + CUT_SETS)
    for name in required:
        if len(sets.get(name.lower(), ())) == 0:
            raise ValueError(f"mesh file {path} has no node set {name!r} "
                             f"(found: {sorted(sets) or 'none'}; names ignore case)")
    used = np.unique(conn)
    renum = -np.ones(len(m.points), dtype=np.int64)
    renum[used] = np.arange(used.size)
    X = np.ascontiguousarray(scale * m.points[used, :3].T, dtype=float)
    t = renum[conn].T
    hexa = cell_type.startswith("hexa")
    mesh = MeshHex(X, np.ascontiguousarray(t[_INV_HEX])) if hexa else MeshTet(X, t)
    try:
        mesh = curved_mesh(mesh, cell_type, full, renum, scale * m.points[:, :3].T)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    node_sets = {}
    for k, v in sets.items():
        r = renum[np.asarray(v, dtype=np.int64)]
        node_sets[k] = r[r >= 0]
    return VolumeMesh(mesh, node_sets, cell_type, full, renum,
                      {k: np.asarray(v, dtype=np.int64) for k, v in sets.items()})


def _named_sets(m, path, used=REQUIRED_SETS) -> dict:
    """name in lower case -> file point indices of the named sets of a meshio Mesh
    (masks, point sets, cell sets, gmsh physical groups; the first found wins); two
    sets of a `used` name spelled in different case are an error naming both."""
    sets, spelled, used = {}, {}, {u.lower() for u in used}

    def add(name, nodes):
        key = str(name).lower()
        if key in used and spelled.get(key, name) != name:
            raise ValueError(f"{path}: node sets {spelled[key]!r} and {name!r} differ only "
                             "in case (set names ignore case): rename one")
        if key not in sets:
            sets[key], spelled[key] = nodes, name

    for name, arr in m.point_data.items():
        a = np.asarray(arr).ravel()
        if a.size == len(m.points):
            add(name, np.nonzero(a > 0.5)[0])
    for name, idx in (getattr(m, "point_sets", None) or {}).items():
        add(name, np.asarray(idx).ravel())
    for name, per_block in (m.cell_sets or {}).items():
        nodes = [m.cells[j].data[np.asarray(ix, dtype=np.int64)].ravel()
                 for j, ix in enumerate(per_block) if ix is not None and len(ix)]
        if nodes:
            add(name, np.unique(np.concatenate(nodes)))
    if "gmsh:physical" in m.cell_data and m.field_data:
        for name, (tag, _) in m.field_data.items():
            nodes = [c.data[np.asarray(m.cell_data["gmsh:physical"][j]) == tag].ravel()
                     for j, c in enumerate(m.cells)]
            nodes = np.concatenate(nodes) if nodes else np.array([], int)
            if nodes.size:
                add(name, np.unique(nodes))
    return sets


def write_fields(model: BladeModel, path, fields: dict) -> Path:
    """Write displacement fields (free-DOF vectors (n,)) as VTU point data for
    ParaView; complex fields (operating deflection shapes) as `<name>_re`,
    `<name>_im` and `<name>_abs`."""
    data = {}
    for name, u in fields.items():
        d = point_displacements(model, u)
        if np.iscomplexobj(d):
            data[f"{name}_re"], data[f"{name}_im"] = d.real, d.imag
            data[f"{name}_abs"] = np.abs(d)
        else:
            data[name] = d
    return write_mesh(model, path, data)
