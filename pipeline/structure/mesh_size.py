"""The size of a generated blade model from its parameters, without meshing.

`solid.solid_mesh` builds a tensor grid through the breakpoints of the section and
keeps two boxes of cells: the airfoil (chord c x thickness t x span L) and, with a
shroud, the shroud block on the tip (shroud chord x shroud width x shroud height).
The grids, as `solid_mesh` makes them (h_x = c / n_chord, h_z = L / n_span):

    x: through {+-c/2, +-c_s/2}, segments of ceil(length / h_x) cells,
    y: [n_o, n_thick, n_o] cells, n_o = max(1, round((w_s - t) / 2 / h_x)),
    z: [n_span, n_zs] cells, n_zs = max(1, round(h_s / h_z)),

w_s the shroud width (derived from the hub radius and the sector count in a wheel,
`disk.wheel_params`: it is what grows when a hub radius is given in millimetres).  A
box of a x b x c triquadratic hexahedra has (2a+1)(2b+1)(2c+1) nodes; the two boxes
share the (2 o_x + 1)(2 n_thick + 1) nodes of the airfoil's tip face under the shroud
(o_x cells of chord in both).  The root nodes are clamped; 3 DOFs per other node.  A
contact face (y = +-w_s/2 of the shroud box) has (2 s_x + 1)(2 n_zs + 1) nodes.

A beam blade (`beam.beam_blade`) has 6 free DOFs per span node (flap and edge
deflection and slope, axial, twist) but the clamped root's, 6 n_span; its rigid
shroud moves with the tip's 6 DOFs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .disk import wheel_params
from .fe_model import BladeParams, DiskPlacement


@dataclass(frozen=True)
class MeshSize:
    """Counts of a generated blade: elements, nodes, free DOFs [-], and the boundary
    DOFs a Craig-Bampton reduction keeps physical (both contact faces, excitation and
    response nodes)."""

    elements: int
    nodes: int
    free_dofs: int
    boundary_dofs: int


def _cells(bounds, h) -> list:
    """Cells per segment of `solid._grid` with the size limit h."""
    return [max(1, int(math.ceil((b - a) / h - 1e-9))) for a, b in zip(bounds[:-1], bounds[1:])]


def _box_nodes(a: int, b: int, c: int) -> int:
    return (2 * a + 1) * (2 * b + 1) * (2 * c + 1)


def solid_mesh_size(p: BladeParams, disk: DiskPlacement | None = None) -> MeshSize:
    """`MeshSize` of `solid.solid_blade(p, disk)` (ValueError as `disk.wheel_params`
    for a wheel whose blades would overlap)."""
    if disk is not None:
        p = wheel_params(p, disk)
    c, t, L = p.chord, p.thickness, p.length
    hx, hz = c / p.n_chord, L / p.n_span
    xb = sorted({-c / 2, c / 2} | ({-p.shroud_chord / 2, p.shroud_chord / 2} if p.shroud
                                   else set()))
    per = _cells(xb, hx)
    edges = [0]
    for n in per:
        edges.append(edges[-1] + n)
    index = {x: i for x, i in zip(xb, edges)}

    def span(lo, hi):   # cells of the x grid between the breakpoints lo and hi
        return index[hi] - index[lo]

    ax = span(-c / 2, c / 2)
    blade = (ax, p.n_thick, p.n_span)
    nodes = _box_nodes(*blade)
    elements = ax * p.n_thick * p.n_span
    boundary = 0
    if p.shroud:
        n_o = max(1, int(round((p.shroud_width - t) / 2 / hx)))
        n_zs = max(1, int(round(p.shroud_height / hz)))
        sx = span(-p.shroud_chord / 2, p.shroud_chord / 2)
        ox = span(max(-c / 2, -p.shroud_chord / 2), min(c / 2, p.shroud_chord / 2))
        nodes += _box_nodes(sx, p.n_thick + 2 * n_o, n_zs) - (2 * ox + 1) * (2 * p.n_thick + 1)
        elements += sx * (p.n_thick + 2 * n_o) * n_zs
        boundary = 2 * (2 * sx + 1) * (2 * n_zs + 1)
    root = (2 * ax + 1) * (2 * p.n_thick + 1)
    return MeshSize(elements=elements, nodes=nodes, free_dofs=3 * (nodes - root),
                    boundary_dofs=3 * (boundary + 2))


def beam_mesh_size(p: BladeParams, disk: DiskPlacement | None = None) -> MeshSize:
    """`MeshSize` of `beam.beam_blade(p, disk)`: the tip's 6 DOFs carry the shroud,
    the excitation node adds its 3 translations (the response node is the tip)."""
    if disk is not None:
        p = wheel_params(p, disk)
    n = 6 * p.n_span
    return MeshSize(elements=p.n_span, nodes=p.n_span + 1, free_dofs=n,
                    boundary_dofs=min(n, (6 if p.shroud else 3) + 3))


def mesh_size(p: BladeParams, disk: DiskPlacement | None = None) -> MeshSize:
    """`MeshSize` of the generated blade of `p` (solid or beam)."""
    return beam_mesh_size(p, disk) if p.kind == "beam" else solid_mesh_size(p, disk)
