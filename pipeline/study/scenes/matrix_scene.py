"""Exported matrices in study files: `[scene.matrices]` of a solid blade.

    [scene]
    model = "solid_blade"
    mesh = "blade.inp"                  # the mesh the matrices belong to (node sets)
    [scene.matrices]
    format = "calculix"                 # calculix | abaqus | ansys | matrix_market
    job = "blade"                       # calculix: blade.sti, blade.mas, blade.dof
    units = "SI"                        # SI (N/m, kg, m) | mm (N/mm, tonne, mm)
    # the model's engine axis, in its frame and units (default: the disk frame's,
    # parallel to X through (0, 0, -R))
    axis = { point = [0.0, 0.0, 0.0], direction = [0.0, 0.0, 1.0] }

    [[scene.matrices.speed]]            # a turning blade: K exported at a speed
    rpm = 15000.0                       # (CalculiX: *STATIC with CENTRIF, then
    job = "blade_15000"                 #  *FREQUENCY, PERTURBATION, SOLVER=MATRIXSTORAGE)

abaqus: `stiffness`, `mass` (`*MATRIX OUTPUT, FORMAT=COORDINATE` files); ansys:
`stiffness`, `mass` (HBMAT files), `mapping`; matrix_market: `stiffness`, `mass`,
`dofs` (the "node direction" table).  Paths are relative to the study file.  The
blade is then `structure.exchange.imported.import_blade`: K and M from the files,
the rest (faces, frames, sets) from the mesh.  [scene.blade] may give rho (the mass
is weighed against it), not E or nu.  A `speed` table per exported speed gives the
stiffness key of the format (`job`, or `stiffness`) of K at `rpm`: two or more speeds
fit K(Omega) = K + Omega^2 K_1 + Omega^4 K_2 (`structure.rotation.fitted_terms`; one
would fix K_1 alone, 12 % off between on a twisted blade), used up to the highest
speed; rho is then needed (the centrifugal load of an interference).  With an `axis`
the blade is moved rigidly into the disk frame (`structure.exchange.disk_frame`): X
along the axis direction, Z radial out through the root's centroid, Y = Z x X towards
the next blade; the study's directions (excitation `direction`, a pair's `tangent`,
the components of `output.dofs`) are that frame's.  It needs [scene.disk].
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from ...errors import UsageError
from ...structure.exchange.imported import FORMATS, UNITS, MatrixFiles, read_exported
from ...structure.exchange.matrix_files import calculix_file

FILES = {"calculix": ("job",), "abaqus": ("stiffness", "mass"),
         "ansys": ("stiffness", "mass", "mapping"),
         "matrix_market": ("stiffness", "mass", "dofs")}


def scene_matrices(ck, tab: dict, mesh, base_dir: Path,
                   fld=lambda path: f"scene.{path}") -> MatrixFiles | None:
    """The `MatrixFiles` of a blade [scene] table's `matrices` (None without one);
    `mesh`: the scene's mesh file, which the matrices need.  The exported K holds the
    material's stiffness: [scene.blade] E and nu are refused (they would do nothing);
    its rho is the density M must weigh (`imported.check_mass`).  `fld(path)`: the
    field of a path inside [scene] (a quick override names its own)."""
    if "matrices" not in tab:
        return None
    if mesh is None:
        ck.fail("scene.matrices", "exported matrices need the mesh they belong to: "
                                  "give scene.mesh (the deck with the node sets)")
    blade = tab.get("blade") if isinstance(tab.get("blade"), dict) else {}
    for key in ("E", "nu"):
        if key in blade:
            ck.fail(fld(f"blade.{key}"), "unused with scene.matrices (the exported K holds "
                                         "the stiffness): remove it")
    axis = parse_axis(ck, ck.table(tab["matrices"], "scene.matrices").get("axis"))
    files = parse_matrices(ck, tab["matrices"], "scene.matrices", base_dir,
                           extra=("speed", "axis"))
    if axis is not None and "disk" not in tab:
        ck.fail("scene.matrices.axis", "the engine axis of a disk: give [scene.disk] (sectors, "
                                       "hub_radius) or remove it")
    if "rho" in blade:      # a number > 0, read with the blade's parameters
        files = replace(files, density=float(blade["rho"]))
    speeds = parse_speeds(ck, tab["matrices"].get("speed", []), files, base_dir)
    if speeds and files.density is None:
        ck.fail(fld("blade.rho"), "needed with scene.matrices.speed: the density [kg/m^3] "
                                  "gives the centrifugal load of the turning blade")
    return replace(files, speeds=speeds, axis=axis)


def parse_axis(ck, value) -> tuple | None:
    """((x, y, z), (dx, dy, dz)) of `scene.matrices.axis` (None when absent): a point
    [the matrices' length unit] and a direction of the model's engine axis, finite, the
    direction not zero."""
    if value is None:
        return None
    field = "scene.matrices.axis"
    t = ck.table(value, field)
    ck.keys(t, field, ("point", "direction"), required=("point", "direction"))
    point = ck.numbers(t["point"], f"{field}.point", 3)
    direction = ck.numbers(t["direction"], f"{field}.direction", 3)
    if not np.linalg.norm(direction) > 0:
        ck.fail(f"{field}.direction", "must not be the zero vector (the engine axis's "
                                      "direction)")
    return tuple(map(float, point)), tuple(map(float, direction))


def parse_speeds(ck, value, files: MatrixFiles, base_dir: Path) -> tuple:
    """((rpm, stiffness path), ...) of the `[[scene.matrices.speed]]` tables, rpm > 0,
    distinct, ascending."""
    field = "scene.matrices.speed"
    if not isinstance(value, list):
        ck.fail(field, "must be an array of tables ([[scene.matrices.speed]])")
    key = FILES[files.format][0]
    out = []
    for i, t in enumerate(value):
        f = f"{field}[{i}]"
        t = ck.table(t, f)
        ck.keys(t, f, ("rpm", key), required=("rpm", key))
        rpm = t["rpm"]
        if isinstance(rpm, bool) or not isinstance(rpm, (int, float)) or not 0 < rpm < 1e6:
            ck.fail(f"{f}.rpm", f"must be a speed in rpm > 0, got {rpm!r}")
        path = parse_matrices(ck, {"format": files.format, "units": files.units,
                                   **_rest(files), key: t[key]}, f, base_dir).stiffness
        out.append((float(rpm), path))
    rpms = [r for r, _ in out]
    if len(rpms) == 1:
        ck.fail(field, "one speed: export K at two or more speeds (K(Omega) = K + Omega^2 K_1 "
                       "+ Omega^4 K_2 needs two; the Omega^4 part of a deflecting blade is "
                       "not small)")
    if len(set(rpms)) != len(rpms):
        ck.fail(field, f"two tables give the same rpm ({sorted(rpms)})")
    return tuple(sorted(out))


def _rest(files: MatrixFiles) -> dict:
    """The non-stiffness keys of a format, as the rest's files give them."""
    keys = FILES[files.format][1:]
    return dict(zip(keys, (files.mass, files.dofs)[:len(keys)]))


def parse_matrices(ck, value, field: str, base_dir: Path, extra=()) -> MatrixFiles:
    """The `MatrixFiles` of a [scene.matrices] table (files checked to exist); `extra`:
    keys the caller reads itself."""
    t = ck.table(value, field)
    if "format" not in t:
        ck.fail(f"{field}.format", f"missing (required): one of {', '.join(FORMATS)}")
    fmt = ck.string(t["format"], f"{field}.format", FORMATS)
    ck.keys(t, field, ("format", "units") + FILES[fmt] + tuple(extra),
            required=("units",) + FILES[fmt])
    units = ck.string(t["units"], f"{field}.units", tuple(UNITS))
    paths = []
    for key in FILES[fmt]:
        s = ck.string(t[key], f"{field}.{key}")
        path = Path(s) if Path(s).is_absolute() else base_dir / s
        needed = ([calculix_file(path, x) for x in (".sti", ".mas", ".dof")] if fmt == "calculix"
                  else [path])
        for f in needed:
            if not f.is_file():
                ck.fail(f"{field}.{key}", f"file {str(f)!r} not found")
        paths.append(str(path))
    stiffness, mass, dofs = (paths + [None, None])[:3]
    return MatrixFiles(fmt, stiffness, mass, dofs, units)


def typed_matrices(ck, t, n):
    """M, C, K of a lumped scene typed into [scene.matrices] (lists of rows)."""
    ck.keys(t, "scene.matrices", ("M", "C", "K"), required=("M", "K"))
    M = ck.matrix(t["M"], "scene.matrices.M", n)
    K = ck.matrix(t["K"], "scene.matrices.K", n)
    C = ck.matrix(t["C"], "scene.matrices.C", n) if "C" in t else np.zeros((n, n))
    for A, nm, need in ((M, "M", "positive definite (mass)"),
                        (K, "K", "positive definite (stiffness; no rigid-body modes)"),
                        (C, "C", "positive semi-definite (damping)")):
        scale = np.abs(A).max()
        if np.abs(A - A.T).max() > 1e-9 * scale:
            ck.fail(f"scene.matrices.{nm}", "must be symmetric")
        lam = np.linalg.eigvalsh(0.5 * (A + A.T))
        if (nm == "C" and lam.min() < -1e-9 * max(scale, 1e-300)) or (nm != "C" and lam.min() <= 1e-12 * scale):
            ck.fail(f"scene.matrices.{nm}", f"must be {need}; smallest eigenvalue {lam.min():.4g}")
    return M, C, K


DIRECTIONS = {1: "x", 2: "y", 3: "z", 4: "rx", 5: "ry", 6: "rz"}


def exported_lumped(ck, tab: dict, base_dir: Path):
    """(M, C, K, DOF names) of a lumped scene whose [scene.matrices] names exported files
    (`format`, as a blade's, plus an optional `damping` file of the stiffness's format),
    or None when the matrices are typed.  The DOFs are named `n<node>.<x|y|z|rx|ry|rz>`."""
    t = tab.get("matrices")
    if not isinstance(t, dict) or "format" not in t:
        return None
    damping = t.get("damping")
    files = parse_matrices(ck, t, "scene.matrices", base_dir, extra=("damping",))
    try:
        ex = read_exported(files)
        C = (read_exported(replace(files, stiffness=str(_path(ck, damping, base_dir))),
                           complete=False).K
             if damping is not None else None)
    except (ValueError, UsageError) as exc:
        ck.fail("scene.matrices", str(exc))
    names = tuple(f"n{node}.{DIRECTIONS[d]}" for node, d in ex.dofs)
    n = len(names)
    C = np.zeros((n, n)) if C is None else C.toarray()
    return ex.M.toarray(), C, ex.K.toarray(), names


def _path(ck, value, base_dir):
    if ck.string(value, "scene.matrices.damping") and not (base_dir / value).is_file():
        ck.fail("scene.matrices.damping", f"file {str(base_dir / value)!r} not found")
    return base_dir / value


def ordered(ck, exported, dofs) -> tuple:
    """M, C, K of `exported_lumped` in the order of the scene's `dofs` (which must name
    exactly the exported DOFs), checked as typed matrices are."""
    M, C, K, names = exported
    if sorted(dofs) != sorted(names):
        extra = sorted(set(dofs) - set(names))[:3]
        ck.fail("scene.dofs", f"must name exactly the exported DOFs ({len(names)}: "
                              f"{', '.join(names[:4])}{' ...' if len(names) > 4 else ''}); "
                              f"unknown: {', '.join(extra) or 'none'}")
    p = [names.index(d) for d in dofs]
    M, C, K = (A[np.ix_(p, p)] for A in (M, C, K))
    typed_matrices(ck, {"M": M.tolist(), "C": C.tolist(), "K": K.tolist()}, len(dofs))
    return M, C, K
