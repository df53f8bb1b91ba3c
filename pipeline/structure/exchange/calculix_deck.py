"""The package's solid blade as a CalculiX input deck, and the node numbers of a deck.

`write_deck` writes a blade mesh (corner vertices, named vertex sets) with quadratic
nodes -- 20-node hexahedra (C3D20: the same serendipity space and 27-point rule as
scikit-fem's ElementHexS2 with intorder 4) or 10-node tetrahedra (C3D10: the space of
ElementTetP2; CalculiX integrates its mass with the 4-point rule, degree 2, where the
package integrates it exactly) -- the material of `BladeParams`, the root clamped and
a `*FREQUENCY, SOLVER=MATRIXSTORAGE` step, which makes `ccx` write the stiffness and
mass matrices (`.sti`, `.mas`, `.dof`; `matrix_files.read_calculix`).  Node k of the
deck is scalar DOF k - 1 of the quadratic basis; every named set is written as an
`*NSET` of its vertices and of the midside nodes between two of them.

Midside node orders (Abaqus / CalculiX, also meshio's):
    C3D20   corners 1-8, then the edges 1-2 2-3 3-4 4-1 5-6 6-7 7-8 8-5 1-5 2-6 3-7 4-8
    C3D10   corners 1-4, then the edges 1-2 2-3 3-1 1-4 2-4 3-4
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from skfem import Basis, ElementHexS2, ElementTetP2, MeshHex
from skfem.io.meshio import HEX_MAPPING

from ..mesh_io import deck_lines
from ..quadratic_cells import HEX20_EDGES, TET10_EDGES, edge_index

FIELD = 20        # characters CalculiX reads of a number


def number(x: float) -> str:
    """x with as many significant digits (at most 17) as fit in CalculiX's 20-character
    field."""
    for digits in range(17, 5, -1):
        text = f"{x:.{digits}g}"
        if len(text) <= FIELD:
            return text
    raise ValueError(f"{x!r} does not fit a CalculiX field")


def quadratic_cells(mesh, basis) -> np.ndarray:
    """(E, 20 | 10) scalar DOFs of each cell in the Abaqus node order; tetrahedra
    turned (vertices 1 and 2 swapped) where their corners are ordered left-handed."""
    hexa = isinstance(mesh, MeshHex)
    corners = mesh.t[HEX_MAPPING[:8]] if hexa else mesh.t.copy()
    if not hexa:
        X = mesh.p[:, corners]
        vol = np.einsum("ie,ie->e", np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], axis=0),
                        X[:, 3] - X[:, 0])
        corners[[0, 1]] = np.where(vol < 0, corners[[1, 0]], corners[[0, 1]])
    edges = edge_index(mesh)
    pairs = HEX20_EDGES if hexa else TET10_EDGES
    mid = [[basis.edge_dofs[0][edges[tuple(sorted((c[a], c[b])))]] for a, b in pairs]
           for c in corners.T]
    return np.hstack([basis.nodal_dofs[0][corners].T, np.asarray(mid)])


def set_nodes(mesh, basis, vertices) -> np.ndarray:
    """Scalar DOFs of a vertex set: its vertices and the midsides between two of them."""
    inside = np.zeros(mesh.p.shape[1], dtype=bool)
    inside[vertices] = True
    on = inside[mesh.edges].all(axis=0)
    return np.sort(np.concatenate([basis.nodal_dofs[0][vertices],
                                   basis.edge_dofs[0][np.nonzero(on)[0]]]))


def _rows(values, per_line: int = 8) -> list:
    return [", ".join(str(v) for v in values[i:i + per_line])
            for i in range(0, len(values), per_line)]


def write_deck(mesh, node_sets: dict, p, path) -> Path:
    """Write the blade on `mesh` (MeshHex -> C3D20, MeshTet -> C3D10) with the named
    vertex sets (`root` clamped) and the material of `p` (BladeParams: E [Pa], nu,
    rho [kg/m^3]) as `path` (.inp), SI units.  Returns the path."""
    hexa = isinstance(mesh, MeshHex)
    basis = Basis(mesh, ElementHexS2() if hexa else ElementTetP2())
    X = basis.doflocs.T
    cells = quadratic_cells(mesh, basis) + 1
    lines = ["** solid blade written by pipeline.structure.exchange.calculix_deck",
             "*NODE, NSET=NALL"]
    lines += [f"{k + 1}, " + ", ".join(number(c) for c in x) for k, x in enumerate(X)]
    lines.append(f"*ELEMENT, TYPE={'C3D20' if hexa else 'C3D10'}, ELSET=EALL")
    for e, nodes in enumerate(cells, 1):
        ids = [str(e)] + [str(n) for n in nodes]
        lines += [", ".join(ids[i:i + 16]) + ("," if i + 16 < len(ids) else "")
                  for i in range(0, len(ids), 16)]
    for name, vertices in node_sets.items():
        lines.append(f"*NSET, NSET={name}")
        lines += _rows(set_nodes(mesh, basis, np.asarray(vertices)) + 1)
    lines += ["*MATERIAL, NAME=BLADE", "*ELASTIC", f"{number(p.E)}, {number(p.nu)}",
              "*DENSITY", number(p.rho), "*SOLID SECTION, ELSET=EALL, MATERIAL=BLADE",
              "*BOUNDARY", "root, 1, 3", "*STEP", "*FREQUENCY, SOLVER=MATRIXSTORAGE",
              "*END STEP"]
    path = Path(path)
    path.write_text("\n".join(lines) + "\n")
    return path


def node_numbers(path, count: int) -> np.ndarray:
    """The node number of each point of a mesh file, in meshio's point order: the
    `*NODE` numbers of an Abaqus / CalculiX deck (.inp, its `*INCLUDE` files inlined),
    else 1 ... count."""
    path = Path(path)
    if path.suffix.lower() != ".inp":
        return np.arange(1, count + 1)
    ids, inside = [], False
    for line in deck_lines(path):
        if line.startswith("**"):
            continue
        if line.startswith("*"):
            key = line[1:].split(",")[0].strip().upper()
            if key == "NODE" and ids:
                raise ValueError(f"{path}: several *NODE blocks (one is read)")
            inside = key == "NODE"
        elif inside and line.strip():
            ids.append(int(line.split(",")[0]))
    if len(ids) != count:
        raise ValueError(f"{path}: {len(ids)} *NODE lines for {count} points")
    return np.asarray(ids)
