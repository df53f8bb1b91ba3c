"""Blades in a disk: the shroud width of a wheel and the pairing of neighbouring faces.

A `fe_model.DiskPlacement` (hub radius R [m], N sectors) puts the blade in a wheel:
blade j+1 is blade j turned by alpha = 2 pi / N about the disk axis (parallel to X
through (0, 0, -R)).  The right shroud face of blade j then touches the left face of
blade j+1: a point x_R of the right face meets the left face where its image
R(alpha) (x_L - c) + c is x_R (`pairing`): at a left node, or (faces meshed
independently) inside a left facet, whose shape functions interpolate the left face's
displacement there (`structure.facets`).  Generated blades are built so that the faces
match node for node (`solid.solid_mesh`, `beam.shroud_face_geometry`, `pair_faces`).
"""
from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .facets import inside, kind_of, locate, shape
from .fe_model import BladeParams, DiskPlacement
from .mortar import dual_pairing

log = logging.getLogger(__name__)

PAIR_TOLERANCE = 1e-6   # default pairing tolerance, relative to the face size [-]


def wheel_shroud_width(p: BladeParams, disk: DiskPlacement) -> float:
    """Shroud width w_s [m] that puts the centre of the right face (xi = 0,
    eta = w_s / 2, z = L + h_s / 2 in the section frame) at the polar angle alpha / 2
    about the disk axis, half way to the next blade:

        (w_s / 2) cos(gamma) = (R + L + h_s / 2) tan(alpha / 2).
    """
    r = disk.hub_radius + p.length + p.shroud_height / 2
    return 2.0 * r * np.tan(disk.pitch_angle / 2) / np.cos(p.stagger_angle)


def airfoil_angle(p: BladeParams, disk: DiskPlacement) -> float:
    """Angular extent [rad] of the airfoil section at the hub about the disk axis
    (the stagger-turned chord x thickness rectangle at Z = 0)."""
    xi = np.array([-1, 1, 1, -1]) * p.chord / 2
    eta = np.array([-1, -1, 1, 1]) * p.thickness / 2
    g = p.stagger_angle
    y = xi * np.sin(g) + eta * np.cos(g)
    a = disk.polar_angle(np.column_stack([np.zeros(4), y, np.zeros(4)]))
    return float(a.max() - a.min())


def wheel_params(p: BladeParams, disk: DiskPlacement) -> BladeParams:
    """The blade parameters of a wheel: `p` with the shroud width derived from the disk
    (`wheel_shroud_width`; the given width is not used).  ValueError naming the disk
    field when neighbouring blades would overlap: the airfoil spans the pitch angle
    at the hub, or the derived shroud is not wider than the airfoil, or its overhang
    is too narrow for the shroud-angle shear."""
    if not p.shroud:
        raise ValueError(f"disk: a blade in a disk needs a shroud (kind = {p.kind!r}, "
                         f"shroud = {p.shroud!r})")
    span = airfoil_angle(p, disk)
    if span >= disk.pitch_angle:
        raise ValueError(
            f"disk.hub_radius: {disk.hub_radius!r} m is too small for {disk.sectors} blades: "
            f"the airfoil spans {np.rad2deg(span):.3g} deg at the hub, the pitch is "
            f"{np.rad2deg(disk.pitch_angle):.3g} deg (neighbouring blades overlap)")
    ws = wheel_shroud_width(p, disk)
    shear = abs(np.tan(p.shroud_angle - p.stagger_angle)) * p.shroud_chord / 2
    if ws <= p.thickness or shear > 0.5 * (ws - p.thickness) / 2:
        raise ValueError(
            f"disk.hub_radius: the wheel's shroud width {ws:.4g} m (R = {disk.hub_radius!r} m, "
            f"N = {disk.sectors}) leaves no valid overhang beside the airfoil (thickness "
            f"{p.thickness!r} m, shroud-angle shear {shear:.3g} m): use fewer sectors or a "
            "larger hub radius")
    return replace(p, shroud_width=float(ws))


def pairing(points_right, points_left, placement: DiskPlacement, facets=None,
            tol: float | None = None, facets_right=None) -> sp.csr_matrix:
    """W sparse (k_R, k_L) [-]: the left face's displacement under each right-face point,
    d_L(x_k) = sum_l W_kl d_l, on a blade of `placement` (module doc).

    A right point x_k whose image turned back by the pitch, R(-alpha) (x_k - c) + c,
    coincides with a left point within `tol` [m] (default `PAIR_TOLERANCE` x the right
    face's size) takes that point: W's row is e_l, node to node, exactly.  Any other
    point (faces meshed independently) is projected along the left face's normal onto
    it and interpolated with the shape functions of the left facet it falls on
    (`facets`: (m, n) indices of `points_left`, the local order of `structure.facets`);
    the point keeps its own face's area weight.  ValueError in one line naming the first
    right point (index, coordinates) on no left point (without `facets`) or on no left
    facet, and its distance to the nearest left point."""
    xr = np.asarray(points_right, float).reshape(-1, 3)
    xl = np.asarray(points_left, float).reshape(-1, 3)
    size = float(np.ptp(xr, axis=0).max()) if len(xr) else 0.0
    tol = PAIR_TOLERANCE * size if tol is None else float(tol)
    if not len(xr) or not len(xl):
        raise ValueError(f"shroud faces do not pair: shroud_right has {len(xr)} points, "
                         f"shroud_left {len(xl)}")
    back = placement.rotate(xr, -placement.pitch_angle)
    dist, near = cKDTree(xl).query(back)
    rows, cols, vals = list(np.nonzero(dist <= tol)[0]), list(near[dist <= tol]), []
    vals = [1.0] * len(rows)
    rest = np.nonzero(dist > tol)[0]
    if rest.size and facets is None:
        k = int(rest[0])
        raise ValueError(
            f"shroud faces do not pair: shroud_right point {k} at ({xr[k, 0]:.6g}, {xr[k, 1]:.6g}, "
            f"{xr[k, 2]:.6g}) m has no shroud_left point turned by 2 pi / {placement.sectors} "
            f"onto it (nearest {dist[k]:.3g} m away, tolerance {tol:.3g} m)")
    if rest.size and facets_right is not None:     # faces meshed differently: dual mortar
        centre = xl.mean(axis=0)
        frame = np.linalg.svd(xl - centre, full_matrices=False)[2]
        off = np.abs((np.vstack([xl, back]) - centre) @ frame[2])
        W = (dual_pairing((back - centre) @ frame[:2].T, facets_right,
                          (xl - centre) @ frame[:2].T, facets) if off.max() <= tol else None)
        if W is not None:     # both faces in one plane: else node to segment below decides
            return W
        log.info("shroud faces meshed differently: paired node to segment (the dual mortar "
                 "needs 9-node facets with straight edges, both faces in one plane)")
    if rest.size:
        for k, (ids, w) in zip(rest, on_facets(back[rest], xl, facets, tol)):
            if ids is None:
                raise ValueError(
                    f"shroud faces do not pair: shroud_right point {k} at ({xr[k, 0]:.6g}, "
                    f"{xr[k, 1]:.6g}, {xr[k, 2]:.6g}) m lies on no shroud_left element turned "
                    f"by 2 pi / {placement.sectors} (nearest shroud_left point {dist[k]:.3g} m "
                    f"away, tolerance {tol:.3g} m)")
            rows += [k] * len(ids)
            cols += list(ids)
            vals += list(w)
    W = sp.csr_matrix((vals, (rows, cols)), shape=(len(xr), len(xl)))
    W.sort_indices()
    return W


def on_facets(x, points, facets, tol):
    """[(point indices, shape-function values) or (None, None)] of each location x (k, 3)
    [m] on the planar face of `points` (n, 3) and `facets` (m, p): projected along the
    face's normal, found on a facet (within 1e-6 of its reference size, and at most
    `tol` off the plane)."""
    facets = np.asarray(facets, int)
    kind = kind_of(facets.shape[1])
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
    axes, normal = vt[:2].T, vt[2]
    X2, x2 = (points - centre) @ axes, (x - centre) @ axes
    off = np.abs((x - centre) @ normal)
    centroids = cKDTree(X2[facets].mean(axis=1))
    out = []
    for xk, ok in zip(x2, off <= tol):
        found = (None, None)
        for j in np.atleast_1d(centroids.query(xk, k=min(8, len(facets)))[1]) if ok else ():
            rs = locate(kind, X2[facets[j]], xk)
            if rs is not None and inside(kind, *rs, 1e-6):
                found = (facets[j], shape(kind, *rs)[0])
                break
        out.append(found)
    return out


def pair_faces(points_right, points_left, placement: DiskPlacement, tol: float | None = None
               ) -> np.ndarray:
    """Index of the left-face partner of every right-face point, faces meshed node for
    node: left[k] is the point of `points_left` (m, 3) [m] whose image under the pitch
    rotation, R(alpha) (x_L - c) + c, coincides with `points_right[k]` (m, 3) within
    `tol` [m] (`pairing` without facets).  ValueError in one line naming the first
    unmatched right point (index, coordinates) and its distance."""
    xr = np.asarray(points_right, float).reshape(-1, 3)
    xl = np.asarray(points_left, float).reshape(-1, 3)
    if len(xr) != len(xl) or not len(xr):
        raise ValueError(f"shroud faces do not pair: shroud_right has {len(xr)} points, "
                         f"shroud_left {len(xl)}")
    left = pairing(xr, xl, placement, tol=tol).indices
    if np.unique(left).size != left.size:
        raise ValueError("shroud faces do not pair: two shroud_right points meet the same "
                         "shroud_left point")
    return left
