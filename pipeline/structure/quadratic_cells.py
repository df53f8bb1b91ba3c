"""Quadratic cells as a mesh file has them: node orders and the curved geometry.

A 20-node hexahedron (CalculiX / Abaqus C3D20, ANSYS SOLID186) or a 10-node
tetrahedron (C3D10, SOLID187) maps its reference cell by its own quadratic shape
functions, x(xi) = sum_i N_i(xi) x_i over all its nodes: the midside nodes place the
curved edges.  `curved_mesh` gives scikit-fem that geometry (isoparametric
MeshHex2 / MeshTet2), so every integral -- K, M, the face areas, the centrifugal
load and the stress stiffness -- runs over the cell as drawn, not over the
straight-edged cell of its corners.

The triquadratic MeshHex2 needs nodes at the face and body centres, which a 20-node
cell has not: they are placed at the serendipity map's own values there,

    x(face centre) = -1/4 sum(face corners) + 1/2 sum(face midsides),
    x(body centre) = -1/4 sum(corners) + 1/4 sum(midsides),

so that the 27-node map equals the 20-node one exactly (the serendipity space lies in
the triquadratic one, whose interpolation reproduces it).

Midside node orders (Abaqus / CalculiX, also meshio's):
    C3D20   corners 1-8, then the edges 1-2 2-3 3-4 4-1 5-6 6-7 7-8 8-5 1-5 2-6 3-7 4-8
    C3D10   corners 1-4, then the edges 1-2 2-3 3-1 1-4 2-4 3-4
"""
from __future__ import annotations

import numpy as np
from skfem import Basis, ElementHex2, ElementHexS2, MeshHex, MeshHex2, MeshTet2
from skfem.io.meshio import INV_HEX_MAPPING

HEX20_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4),
               (0, 4), (1, 5), (2, 6), (3, 7))
TET10_EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
EDGES = {"hexahedron20": HEX20_EDGES, "tetra10": TET10_EDGES}
CORNERS = {"hexahedron": 8, "hexahedron20": 8, "hexahedron27": 8, "tetra": 4, "tetra10": 4}


def edge_index(mesh) -> dict:
    """(vertex a, vertex b) sorted -> the mesh's edge index."""
    return {tuple(sorted(e)): k for k, e in enumerate(mesh.edges.T)}


def midside_edges(mesh, cell_type: str, cells, vertex) -> tuple[np.ndarray, np.ndarray]:
    """(file points, mesh edges) of the midside nodes of quadratic `cells` (E, 20 | 10)
    in file point indices, `vertex` mapping a file point to its vertex of `mesh`."""
    n_c = CORNERS[cell_type]
    edges = edge_index(mesh)
    points, index = [], []
    for j, (a, b) in enumerate(EDGES[cell_type]):
        va, vb = vertex[cells[:, a]], vertex[cells[:, b]]
        index.append([edges[(min(x, y), max(x, y))] for x, y in zip(va, vb)])
        points.append(cells[:, n_c + j])
    return np.concatenate(points), np.concatenate(index).astype(np.int64)


def curved_mesh(mesh, cell_type: str, cells, vertex, X_file):
    """The isoparametric mesh of quadratic cells: `mesh` (the MeshHex / MeshTet of the
    corners) with its midside nodes at the file's points `X_file` (3, Np) [m].
    `cells` (E, 20 | 10) file point indices in meshio's order, `vertex` file point ->
    vertex of `mesh`.  27-node hexahedra carry their face and body nodes (read in
    scikit-fem's order, `HEX_MAPPING`); linear cells: `mesh` unchanged."""
    if cell_type == "hexahedron27":
        used, local = np.unique(cells, return_inverse=True)
        t = local.reshape(cells.shape).T[INV_HEX_MAPPING]
        curved = MeshHex2(X_file[:, used], np.ascontiguousarray(t))
        if not (np.array_equal(curved.t, mesh.t) and np.array_equal(curved.p[:, :mesh.nvertices],
                                                                      mesh.p)):
            raise ValueError("27-node hexahedra: the corner numbering is not the mesh's")
        return curved
    if cell_type not in EDGES:
        return mesh
    points, edge = midside_edges(mesh, cell_type, cells, vertex)
    nv, ne = mesh.nvertices, mesh.edges.shape[1]
    if cell_type == "tetra10":
        curved = MeshTet2.from_mesh(mesh)
        X = curved.doflocs.copy()
        X[:, nv + edge] = X_file[:, points]
        return MeshTet2(X, mesh.t)
    curved = MeshHex2.from_mesh(mesh)
    X = curved.doflocs.copy()
    X[:, nv + edge] = X_file[:, points]
    nf = mesh.facets.shape[1]
    centres = serendipity_centres(mesh, X[:, :nv + ne])
    X[:, nv + ne + mesh.t2f] = centres[:, :6]
    X[:, nv + ne + nf + np.arange(mesh.t.shape[1])] = centres[:, 6]
    return MeshHex2(X, mesh.t)


def serendipity_centres(mesh: MeshHex, X_nodes) -> np.ndarray:
    """(3, 7, E) [m]: the 20-node map of each hexahedron at its six face centres (in
    scikit-fem's local facet order) and its body centre; `X_nodes` (3, nv + ne) the
    corner and midside node coordinates, vertices then edges."""
    cube = ElementHex2.refdom
    ref = np.vstack([cube.p.T[np.asarray(cube.facets)].mean(axis=1), [[0.5, 0.5, 0.5]]])
    basis = Basis(mesh, ElementHexS2(), quadrature=(ref.T, np.ones(len(ref))))
    s = np.concatenate([basis.nodal_dofs[0], basis.edge_dofs[0]])
    out = np.empty((3, len(ref), mesh.t.shape[1]))
    for c in range(3):
        values = np.zeros(basis.N)
        values[s] = X_nodes[c]
        out[c] = np.asarray(basis.interpolate(values)).T
    return out
