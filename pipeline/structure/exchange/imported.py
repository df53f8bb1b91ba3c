"""A blade whose stiffness and mass come from another FE code.

The user gives the matrices their code exported (`matrix_files`: CalculiX, Abaqus,
ANSYS, Matrix Market) and the mesh they belong to (a CalculiX / Abaqus deck `.inp`,
or any mesh meshio reads, with the named node sets root, shroud_left, shroud_right,
excitation, response).  The mesh gives what the matrices do not: coordinates, the
contact faces' frames and areas, the node sets; the matrices replace the package's
own K and M, DOF for DOF:

    K_blade[3 s(node) + d - 1, 3 s(node') + d' - 1] = K_file[(node, d), (node', d')]

s(node) the scalar DOF of the mesh's quadratic basis at that node (corner nodes by
vertex, midside nodes by their cell's edge -- so curved edges map too), d = 1, 2, 3
the translations.  The free DOFs of the file must be exactly the mesh's DOFs less the
clamped root's (codes drop the constrained ones; their equations must not stay), the
element of the mesh is the one the code used (C3D20 / SOLID186 -> ElementHexS2,
C3D10 / SOLID187 -> ElementTetP2, 8-node -> ElementHex1, 4-node -> ElementTetP1:
their nodes, not a new discretisation), and K must be positive definite on the free
DOFs (a root set that does not clamp the blade leaves rigid-body modes).

M must weigh what the mesh holds (`check_mass`): its translation mass in each
direction, m_d = r_d^T M r_d (r_d a unit translation of the free DOFs), against the
mesh's volume V (scikit-fem, the cells' corners) times the density.  The clamped DOFs
are not in the files, so m_d = integral of rho (1 - phi)^2 dV, phi the sum of the root
nodes' shape functions (0 outside the cells touching the root, volume V_r; within
-0.31 and 1 for the quadratic and linear elements here): rho (V - V_r) <= m_d <=
rho (V + V_r), widened by RHO_MARGIN for curved cells measured straight.  The density
is the blade's when given (`MatrixFiles.density`), else any of the blade materials'
(`fe_model.DENSITY_RANGE`).  K and M swapped, a stale mass file or a model in mm
read as SI miss it by factors of 1e3 to 1e12.  The mesh must not span more than a
blade can (`mesh_io.check_span`).

Units: "SI" (N/m, kg, m) or "mm" (N/mm, tonne, mm -- the usual consistent set of
Abaqus and ANSYS models): K x 1e3, M x 1e3, coordinates x 1e-3.

Frame: the mesh and matrices are in the disk frame (the engine axis parallel to X
through (0, 0, -R)) unless `MatrixFiles.axis` names the model's own engine axis; the
blade is then moved rigidly into the disk frame, nodes and matrices alike
(`disk_frame`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from skfem import ElementHex1, ElementHex2, ElementHexS2, ElementTetP1, ElementTetP2

from ..fe_model import CUT_SETS, DENSITY_RANGE, REQUIRED_SETS, BladeModel
from ..mesh_io import check_span, read_volume
from ..rotation import centrifugal_load, fitted_terms
from ..solid import solid_from_mesh
from ..quadratic_cells import EDGES, edge_index
from .calculix_deck import node_numbers
from .disk_frame import check_right_face, disk_frame, moved_volume, turned
from .matrix_files import (ExportedMatrices, calculix_file, read_abaqus, read_ansys,
                           read_calculix, read_matrix_market)

FORMATS = ("calculix", "abaqus", "ansys", "matrix_market")
UNITS = {"SI": (1.0, 1.0, 1.0), "mm": (1e3, 1e3, 1e-3)}   # K, M, length factors to SI
RHO_MARGIN = 1.1    # the volume of curved cells, measured on straight ones
ELEMENTS = {"hexahedron": ElementHex1, "hexahedron20": ElementHexS2,
            "hexahedron27": ElementHex2, "tetra": ElementTetP1, "tetra10": ElementTetP2}


@dataclass(frozen=True)
class MatrixFiles:
    """Where an exported structure lies.  calculix: `stiffness` is the job
    (`<job>.sti/.mas/.dof`); abaqus: the stiffness and mass `.mtx`; ansys: the two
    Harwell-Boeing files and the `.mapping` as `dofs`; matrix_market: the two `.mtx`
    and the "node direction" table as `dofs`.  `units`: a key of `UNITS`.  `density`
    [kg/m^3]: the blade's, which M must weigh (None: any blade material's).  `speeds`:
    ((rpm, stiffness), ...) the stiffness exported at each speed of a turning blade (the
    `stiffness` key's file, a job for calculix; the mass and DOF map are the rest's).
    `axis`: ((x, y, z), (dx, dy, dz)) the model's engine axis, a point [the file's
    length unit] and a direction, None: the disk frame's (`disk_frame`)."""

    format: str
    stiffness: str
    mass: str | None = None
    dofs: str | None = None
    units: str = "SI"
    density: float | None = None
    speeds: tuple = ()
    axis: tuple | None = None

    @property
    def mass_file(self) -> str:
        """The file that holds M."""
        if self.format == "calculix":     # the job's, as `read_calculix` finds it
            return str(calculix_file(self.stiffness, ".mas"))
        return str(self.mass)


def read_exported(files: MatrixFiles, complete: bool = True) -> ExportedMatrices:
    """The matrices of `files` with their (node, direction) map, in SI units;
    `complete`: every row has entries (not so a damping matrix read as `stiffness`)."""
    if files.format == "calculix":
        ex = read_calculix(files.stiffness, complete)
    elif files.format == "abaqus":
        ex = read_abaqus(files.stiffness, files.mass, complete)
    elif files.format == "ansys":
        ex = read_ansys(files.stiffness, files.mass, files.dofs)
    elif files.format == "matrix_market":
        ex = read_matrix_market(files.stiffness, files.mass, files.dofs)
    else:
        raise ValueError(f"unknown matrix format {files.format!r} (known: {', '.join(FORMATS)})")
    fk, fm, _ = UNITS[files.units]
    return ExportedMatrices((fk * ex.K).tocsr(), (fm * ex.M).tocsr(), ex.dofs, ex.source)


def point_dofs(vol, basis) -> np.ndarray:
    """Scalar basis DOF of each point of the mesh file (-1: in no volume cell)."""
    s = -np.ones(vol.vertex.size, dtype=np.int64)
    corner = vol.vertex >= 0
    s[corner] = basis.nodal_dofs[0][vol.vertex[corner]]
    if vol.cell_type in EDGES:
        n_c = 8 if vol.cell_type.startswith("hexa") else 4
        edges = edge_index(vol.mesh)
        for j, (a, b) in enumerate(EDGES[vol.cell_type]):
            va, vb = vol.vertex[vol.cells[:, a]], vol.vertex[vol.cells[:, b]]
            k = [edges[(min(x, y), max(x, y))] for x, y in zip(va, vb)]
            s[vol.cells[:, n_c + j]] = basis.edge_dofs[0][k]
    elif vol.cell_type == "hexahedron27":
        raise ValueError("27-node hexahedra: no exported matrices are read on them "
                         "(export 20-node hexahedra or 10-node tetrahedra)")
    return s


def exported_rows(ex: ExportedMatrices, numbers, s_of_point, free, source) -> np.ndarray:
    """Vector DOF (3 s + d - 1) of each row of the export; the rows must be `free`."""
    point = {int(n): k for k, n in enumerate(numbers)}
    rows = np.empty(ex.n_dof, dtype=np.int64)
    for r, (node, d) in enumerate(ex.dofs):
        k = point.get(node)
        if k is None or s_of_point[k] < 0:
            raise ValueError(f"{ex.source}: row {r + 1} is node {node}, which the mesh "
                             f"{source} has not in a volume cell")
        if d > 3:
            raise ValueError(f"{ex.source}: row {r + 1} is a rotation (node {node}, "
                             f"direction {d}): solid elements have translations only")
        rows[r] = 3 * s_of_point[k] + d - 1
    extra = np.setdiff1d(rows, free)
    missing = np.setdiff1d(free, rows)
    if extra.size or missing.size:
        raise ValueError(f"{ex.source}: the DOF map ({ex.n_dof} rows) does not match the free "
                         f"DOFs of {source} ({free.size}: all but the root set's): "
                         f"{extra.size} rows of clamped DOFs, {missing.size} free DOFs "
                         f"missing")
    return rows


def check_definite(K, M, source) -> None:
    """ValueError unless K is positive definite (its eigenvalue nearest zero, relative
    to M, is positive): a singular K has rigid-body modes the root does not clamp."""
    shift = 1e-8 * float(np.median(K.diagonal() / np.maximum(M.diagonal(), 1e-300)))
    try:
        lam = sla.eigsh(K.tocsc(), k=1, M=M.tocsc(), sigma=-shift, which="LM",
                        return_eigenvectors=False)[0]
    except (RuntimeError, sla.ArpackError) as exc:
        raise ValueError(f"{source}: K is singular on the free DOFs ({exc})") from None
    if not lam > 0.0:
        raise ValueError(f"{source}: K is not positive definite on the free DOFs (an "
                         f"eigenvalue {lam:.3g} rad^2/s^2 <= 0): does the root set clamp "
                         f"the blade?")


def mass_bounds(basis, root) -> tuple:
    """(V [m^3], V_r [m^3], (lo, hi)) of the mesh of `basis` whose vertices `root` are
    clamped: a translation mass m [kg] of the free DOFs implies a density between
    lo m and hi m [kg/m^3] (see the module)."""
    cell = basis.dx.sum(axis=1)                      # [m^3] each cell's volume
    V = float(cell.sum())
    V_r = float(cell[np.isin(basis.mesh.t, root).any(axis=0)].sum())
    lo = 1.0 / (RHO_MARGIN * (V + V_r))
    hi = RHO_MARGIN / (V - V_r) if V > V_r else np.inf
    return V, V_r, (lo, hi)


def check_mass(M, basis, root, files: MatrixFiles, mesh) -> None:
    """ValueError naming the mass file unless M (over the 3 N vector DOFs, clamped ones
    zero) weighs the mesh's volume times the density (see the module)."""
    V, _, (lo, hi) = mass_bounds(basis, root)
    rho_lo, rho_hi = ((files.density, files.density) if files.density is not None
                      else DENSITY_RANGE)
    for d, axis in enumerate("xyz"):
        r = np.zeros(M.shape[0])
        r[d::3] = 1.0
        m = float(r @ (M @ r))
        if m > 0 and lo * m <= rho_hi and rho_lo <= hi * m:
            continue
        want = (f"the blade's density is {files.density:g} kg/m^3" if files.density is not None
                else f"no blade material's ({rho_lo:g} to {rho_hi:g} kg/m^3)")
        causes = ["K and M swapped (the stiffness read as the mass)", "wrong units (a model "
                  "in mm and tonnes read as SI: units = \"mm\")", "a stale file (another "
                  "material or mesh)"]
        if m * lo > rho_hi:                             # too heavy
            first = 0 if m * lo > 1e3 * rho_hi else 2
        else:
            first = 1 if m * hi < 1e-3 * rho_lo else 2
        likely = [causes[first]] + [c for k, c in enumerate(causes) if k != first]
        bounds = (f"{lo * m:.3g} to {hi * m:.3g}" if np.isfinite(hi * m)
                  else f"at least {lo * m:.3g}")
        raise ValueError(f"{files.mass_file}: mass {m:.3g} kg (translation along {axis}) "
                         f"for a volume of {V:.3g} m^3 ({mesh}): density {m / V:.3g} kg/m^3 "
                         f"({bounds} with the clamped root's share), where {want}: likely "
                         f"{likely[0]}; else {likely[1]} or {likely[2]}")


def import_blade(mesh_path, files: MatrixFiles, p, required=("root",),
                 rotation_centre=None, disk=None) -> BladeModel:
    """The clamped blade of an exported structure on its mesh (see the module): sets,
    frames and face areas from the mesh, K and M from the files (M weighed against
    the mesh's volume, `check_mass`); `p` (BladeParams) supplies the damping ratios
    only.  With `files.axis`, moved from the model's frame into the frame of the disk
    `disk` (`fe_model.DiskPlacement`: its axis along X through its `centre`, `disk_frame`).  Turning about the
    axis (along X) through `rotation_centre` [m]: K(Omega) fitted through the
    stiffnesses exported at `files.speeds` (`rotation.fitted_terms`) and the centrifugal
    load of the density `files.density` on the mesh."""
    _, _, length = UNITS[files.units]
    vol = read_volume(mesh_path, required, scale=length)
    check_span(vol.mesh.p, mesh_path, 'set [scene.matrices] units = "mm"' if files.units == "SI"
               else f'(read with units = "{files.units}")')
    ex = read_exported(files)
    spun = [read_exported(replace(files, stiffness=path, speeds=())) for _, path in files.speeds]
    for rpm, other in zip((r for r, _ in files.speeds), spun):
        if other.dofs != ex.dofs or relative_change(other.M, ex.M) > 1e-9:
            raise ValueError(f"{other.source}: the matrices exported at {rpm:g} rpm are not on "
                             f"the DOFs and mass of {ex.source} (another mesh, material or "
                             f"constraint?)")
    numbers = node_numbers(mesh_path, vol.vertex.size)
    source = str(mesh_path)
    place = sp.csr_matrix          # the model's frame is the disk's
    if files.axis is not None:
        if disk is None:
            raise ValueError(f"{source}: an engine axis places the blade in a disk: give the "
                             "disk (its hub radius)")
        point, direction = files.axis
        Q, b = disk_frame((length * np.asarray(point, float), direction),
                          vol.mesh.p[:, vol.node_sets["root"]], disk.centre)
        vol = moved_volume(vol, Q, b)
        place = partial(turned, Q=Q)
    kept = {}

    def matrices(basis, free):
        rows = exported_rows(ex, numbers, point_dofs(vol, basis), free, source)
        n = 3 * basis.N
        P = sp.csr_matrix((np.ones(rows.size), (rows, np.arange(rows.size))),
                          shape=(n, rows.size))
        K, M = (place(P @ A @ P.T) for A in (ex.K, ex.M))
        check_mass(M, basis, vol.node_sets["root"], files, source)
        check_definite(K[free][:, free], M[free][:, free], ex.source)
        kept.update(basis=basis, free=free,
                    spun=[place(P @ o.K @ P.T)[free][:, free] for o in spun])
        return K, M

    sets = {k: v for k, v in vol.node_sets.items() if k in REQUIRED_SETS + CUT_SETS}
    blade = solid_from_mesh(vol.mesh, sets, p, source, ELEMENTS[vol.cell_type](), matrices)
    if files.axis is not None and "shroud_right" in blade.frames:
        check_right_face(blade.frames["shroud_right"], files.axis[1], disk.centre, source)
    if rotation_centre is None:
        return blade
    if not files.speeds or files.density is None:
        raise ValueError(f"{source}: an imported blade turns with its stiffness exported at "
                         "one or more speeds and its density (for the centrifugal load)")
    load = centrifugal_load(kept["basis"], files.density, rotation_centre)[kept["free"]]
    omegas = [rpm * np.pi / 30.0 for rpm, _ in files.speeds]
    return replace(blade, rotation=fitted_terms(load, blade.K, omegas, kept["spun"]))


def relative_change(A, B) -> float:
    """max |A - B| / max |B| of two sparse matrices (inf when their shapes differ)."""
    if A.shape != B.shape:
        return float("inf")
    return float(abs(A - B).max() / max(abs(B).max(), 1e-300))
