"""Solid blade (scikit-fem): structured hexahedral mesh with tip shroud, assembly.

3D linear elasticity with triquadratic hexahedra (ElementHex2, intorder 4 -- linear
elements lock in bending) on a structured mesh; user meshes of tetrahedra use
ElementTetP2.  Weak forms (ex03/ex21 of scikit-fem):

    K: int_V  sigma(u) : eps(v) dV,     M: int_V rho u . v dV.

The root is clamped; named node sets give the DOF sets and the contact frames of
the shroud faces.  Frames and contact conventions: `fe_model`.
"""
from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
from skfem import (Basis, BilinearForm, ElementHex2, ElementHexS2, ElementTetP2, FacetBasis,
                   LinearForm, MeshHex, MeshTet)
from skfem.io.meshio import HEX_MAPPING
from skfem.models.elasticity import lame_parameters

from .airfoil import curved_mesh, is_curved
from .cyclic_cut import cut_maps, cut_pairing
from .disk import wheel_params
from .facets import order_facet
from .rotation import rotation_terms
from .fe_model import (CONTACT_SETS, CUT_SETS, POINT_SETS, BladeModel, BladeParams,
                       ContactFrame, DiskPlacement, rotation_z)

log = logging.getLogger(__name__)

# the element solved on a mesh file's volume cells (meshio cell type): quadratic
# everywhere (linear elements lock in bending); 20-node hexahedra keep their
# serendipity space (CalculiX C3D20, ANSYS SOLID186, Abaqus C3D20)
MESH_ELEMENTS = {"hexahedron": ElementHex2, "hexahedron27": ElementHex2,
                 "hexahedron20": ElementHexS2, "tetra": ElementTetP2, "tetra10": ElementTetP2}


# ---------------------------------------------------------------------------
# Solid blade: mesh generation
# ---------------------------------------------------------------------------

def _grid(bounds, h, counts=None):
    """1D coordinates through the sorted `bounds`, segments of size <= h (or counts)."""
    pts = [bounds[0]]
    for j, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        n = counts[j] if counts is not None else max(1, int(np.ceil((b - a) / h - 1e-9)))
        pts.extend(np.linspace(a, b, n + 1)[1:])
    return np.asarray(pts)


def solid_mesh(p: BladeParams, disk: DiskPlacement | None = None):
    """Structured hexahedral blade (+ shroud): (MeshHex, node sets by vertex index).

    Built in the section frame (xi, eta, z), the shroud overhang |eta| > t/2 is
    sheared, eta' = eta + s(eta) xi tan(a - gamma) with s ramping 0 -> 1 across the
    overhang, so the side faces are planes tilted by a - gamma; the whole blade is
    then turned by the stagger gamma about Z.  The airfoil is not distorted.

    With a `disk` placement (a wheel of N blades, hub radius R) the shroud width is
    derived (`disk.wheel_params`: the right face centre at the polar angle alpha/2,
    alpha = 2 pi / N) and the left overhang is rebuilt (`wheel_left_overhang`) so
    that the left face is the right face turned by -alpha about the disk axis, node
    for node: the left face of blade j+1 is the right face of blade j.  Chord,
    thickness, span, shroud chord and height, angles and mesh counts are the given
    ones.  Without a placement the mesh is the plain blade's.
    """
    if disk is not None:
        p = wheel_params(p, disk)
    c, t, L = p.chord, p.thickness, p.length
    cs, ws, hs = p.shroud_chord, p.shroud_width, p.shroud_height
    hx, hz = c / p.n_chord, L / p.n_span
    shroud = p.shroud
    xb = sorted({-c / 2, c / 2} | ({-cs / 2, cs / 2} if shroud else set()))
    x = _grid(xb, hx)
    if shroud:
        n_o = max(1, int(round((ws - t) / 2 / hx)))
        y = _grid([-ws / 2, -t / 2, t / 2, ws / 2], None, [n_o, p.n_thick, n_o])
        z = _grid([0.0, L, L + hs], None, [p.n_span, max(1, int(round(hs / hz)))])
    else:
        y = _grid([-t / 2, t / 2], None, [p.n_thick])
        z = _grid([0.0, L], None, [p.n_span])
    mesh = MeshHex.init_tensor(x, y, z)
    xc = mesh.p[:, mesh.t].mean(axis=1)
    keep = (abs(xc[0]) < c / 2) & (abs(xc[1]) < t / 2) & (xc[2] < L)
    if shroud:
        keep |= (abs(xc[0]) < cs / 2) & (abs(xc[1]) < ws / 2) & (xc[2] > L)
    mesh = mesh.restrict(np.nonzero(keep)[0])
    X = mesh.p.copy()
    tol = 1e-9 * max(L, c)
    sets = {"root": np.nonzero(abs(X[2]) < tol)[0]}
    if shroud:
        top = X[2] > L - tol
        sets["shroud_left"] = np.nonzero(top & (abs(X[1] + ws / 2) < tol))[0]
        sets["shroud_right"] = np.nonzero(top & (abs(X[1] - ws / 2) < tol))[0]
    d_exc = np.linalg.norm(X.T - [c / 2, t / 2, L / 3], axis=1)
    d_res = np.linalg.norm(X.T - [-c / 2, -t / 2, L], axis=1)
    sets["excitation"] = np.array([np.argmin(d_exc)])
    sets["response"] = np.array([np.argmin(d_res)])
    if shroud:
        over = (X[2] > L - tol) & (abs(X[1]) > t / 2 + tol)
        s = np.clip((abs(X[1]) - t / 2) / ((ws - t) / 2), 0.0, 1.0)
        X[1] = np.where(over, X[1] + s * X[0] * np.tan(p.shroud_angle - p.stagger_angle), X[1])
    X = rotation_z(p.stagger_angle) @ X
    if disk is not None:
        X = wheel_left_overhang(mesh.p, X, (x, y, z), p, disk)
        check_orientation(mesh, X)
    mesh = replace(mesh, doflocs=X)
    return mesh, sets


def grid_index(X0, grids) -> np.ndarray:
    """(i_xi, i_eta, i_z) (3, Np) of tensor-grid vertices X0 (3, Np) in the grids."""
    return np.array([np.abs(X0[k][:, None] - g[None, :]).argmin(axis=1)
                     for k, g in enumerate(grids)])


def wheel_left_overhang(X0, X, grids, p: BladeParams, disk: DiskPlacement) -> np.ndarray:
    """Vertices X (3, Np) [m] with the left shroud overhang rebuilt for a wheel.

    A left-overhang vertex with the grid indices (i, k, l) (eta index k from 0 at
    the face to n_o at the airfoil edge eta = -t/2) moves to

        x = (1 - s) x(i, n_o, l) + s [R(-alpha) (x_R(i, l) - c) + c],  s = (n_o - k) / n_o,

    x_R(i, l) the right-face vertex with the same chord and span indices: the left
    face (s = 1) is exactly the right face turned by -alpha about the disk axis.
    X0 (3, Np): the undistorted tensor-grid vertices giving the indices.
    """
    x, y, z = grids
    idx = grid_index(X0, grids)
    at = -np.ones((len(x), len(y), len(z)), dtype=np.int64)
    at[idx[0], idx[1], idx[2]] = np.arange(X0.shape[1])
    n_o = int(np.abs(y + p.thickness / 2).argmin())
    shroud = idx[2] >= int(np.abs(z - p.length).argmin())
    left = np.nonzero(shroud & (idx[1] < n_o))[0]
    i, k, m = idx[:, left]
    edge, right = at[i, n_o, m], at[i, len(y) - 1, m]
    if np.any(edge < 0) or np.any(right < 0):
        raise ValueError("disk: the shroud grid has no vertex beside a left-overhang vertex")
    s = (n_o - k) / n_o
    image = disk.rotate(X[:, right].T, -disk.pitch_angle).T
    X = X.copy()
    X[:, left] = (1.0 - s) * X[:, edge] + s * image
    return X


def check_orientation(mesh, X) -> None:
    """ValueError naming disk.sectors if a hexahedron of `mesh` moved to the vertices
    X (3, Np) is turned inside out (its corner Jacobians change sign)."""
    corners = np.array(np.meshgrid([0.0, 1.0], [0.0, 1.0], [0.0, 1.0])).reshape(3, -1)
    ref = np.sign(mesh.mapping().detDF(corners))
    det = replace(mesh, doflocs=X).mapping().detDF(corners)
    bad = np.nonzero(np.any(det * ref <= 0, axis=1))[0]
    if bad.size:
        raise ValueError(f"disk.sectors: the wheel's shroud turns {bad.size} hexahedra inside out "
                         f"(first: element {bad[0]}); use more sectors or a larger hub radius")


# ---------------------------------------------------------------------------
# Solid blade: assembly from any mesh with named node sets
# ---------------------------------------------------------------------------

def _set_dofs(mesh, basis, nodes):
    """(k, 3) DOF indices and (k, 3) locations of the DOF points on a node set.

    If the nodes span boundary facets, all DOFs of those facets (vertex, edge and
    face DOFs of quadratic elements); otherwise the vertex DOFs of the nodes.
    """
    bf = mesh.boundary_facets()
    inside = np.isin(mesh.facets[:, bf], nodes).all(axis=0)
    facets = bf[inside]
    if facets.size:
        dofs = basis.facet_dofs(facets)
    else:
        dofs = basis.nodal_dofs[:, nodes].T
    return dofs, basis.doflocs[:, dofs[:, 0]].T


def _face_weights(mesh, sbasis, nodes, scalar_dofs):
    """The area [m^2] each face point carries over the boundary facets spanned by
    `nodes` (None if they span none): the consistent a_i = int_face N_i dA where all
    are positive (9-node faces of Hex2, 4-node faces), else the HRZ lumping
    a_i = A int N_i^2 dA / sum_j int N_j^2 dA (Hinton, Rock & Zienkiewicz 1976) --
    the consistent corner areas of an 8-node serendipity face are negative and those
    of a 6-node triangle zero, which no contact stiffness may take."""
    bf = mesh.boundary_facets()
    facets = bf[np.isin(mesh.facets[:, bf], nodes).all(axis=0)]
    if not facets.size:
        return None
    fb = FacetBasis(mesh, sbasis.elem, facets=facets, intorder=4)
    a = LinearForm(lambda v, w: v).assemble(fb)[scalar_dofs]
    if np.all(a > 0):
        return a
    d = BilinearForm(lambda u, v, w: u * v).assemble(fb).diagonal()[scalar_dofs]
    return a.sum() * d / d.sum()


def _face_facets(mesh, sbasis, nodes, scalar_dofs, points):
    """(m, p) the boundary facets spanned by `nodes`, each as indices of the face's
    points (rows of `scalar_dofs`) in the local order of `structure.facets`; None if
    they span none."""
    bf = mesh.boundary_facets()
    facets = bf[np.isin(mesh.facets[:, bf], nodes).all(axis=0)]
    if not facets.size:
        return None
    row = {int(d): i for i, d in enumerate(scalar_dofs)}
    centre = points.mean(axis=0)
    X2 = (points - centre) @ np.linalg.svd(points - centre, full_matrices=False)[2][:2].T
    out = []
    for f in facets:
        view = sbasis.get_dofs(np.array([f]))
        part = [[row[int(d)] for d in getattr(view, kind).get("u", ())]
                for kind in ("nodal", "edge", "facet")]
        out.append(order_facet(X2, part[0], part[1], part[2][0] if part[2] else None))
    return np.asarray(out, dtype=np.int64)


def _frame(mesh, name, nodes, points, dofs, n_right, weights=None, facets=None):
    X = mesh.p[:, nodes].T
    centre = X.mean(axis=0)
    _, sv, vt = np.linalg.svd(X - centre, full_matrices=False)
    normal = vt[-1]
    size = np.ptp(X, axis=0).max()
    if sv[-1] / np.sqrt(len(X)) > 1e-6 * size:
        log.warning("contact face %s is not planar (rms distance %.3g m)", name,
                    sv[-1] / np.sqrt(len(X)))
    # outward: away from the elements that touch the face
    elems = np.nonzero(np.isin(mesh.t, nodes).any(axis=0))[0]
    inner = mesh.p[:, mesh.t[:, elems]].mean(axis=(1, 2))
    if normal @ (centre - inner) < 0:
        normal = -normal
    ref = n_right if n_right is not None else normal
    tangent = np.cross(ref, [0.0, 0.0, 1.0])
    if np.linalg.norm(tangent) < 1e-8:
        tangent = np.cross(ref, [1.0, 0.0, 0.0])
    tangent /= np.linalg.norm(tangent)
    return ContactFrame(name, normal, tangent, np.cross(tangent, ref), points, dofs, weights,
                        facets=facets)


def assemble_elasticity(basis, E: float, nu: float, rho: float, chunk: int = 512):
    """Sparse (K, M) of 3D linear elasticity from a SCALAR basis, DOF 3 s + c.

    Vectorised over elements (scikit-fem's generic form loop makes one numpy call
    per local DOF pair: 6561 for Hex2, too slow at 100k DOFs).  With g_i = grad phi_i,
    W = quadrature weight x det J, the element matrices are

        K[(i,a),(j,b)] = sum_q W (lam g_ia g_jb + mu g_ib g_ja + mu delta_ab g_i.g_j),
        M[(i,a),(j,b)] = rho delta_ab sum_q W phi_i phi_j,

    i.e. int sigma(u):eps(v) and int rho u.v; identical to
    `linear_elasticity(*lame_parameters(E, nu))` on ElementVector (tested).
    """
    lam, mu = lame_parameters(E, nu)
    nb = len(basis.basis)
    G = np.stack([basis.basis[i][0].grad for i in range(nb)], axis=1)  # (3, nb, E, q)
    P = np.stack([np.asarray(basis.basis[i][0]) for i in range(nb)])  # (nb, E, q)
    W = basis.dx
    s = basis.element_dofs  # (nb, E)
    ne = s.shape[1]
    Kd = np.empty((ne, 3 * nb, 3 * nb))
    Md = np.empty((ne, nb, nb))
    for lo in range(0, ne, chunk):
        e = slice(lo, min(lo + chunk, ne))
        Ge = G[:, :, e].transpose(2, 0, 1, 3).reshape(-1, 3 * nb, W.shape[1])  # (e, a i, q)
        S = (Ge * W[e, None, :]) @ Ge.transpose(0, 2, 1)
        S = S.reshape(-1, 3, nb, 3, nb)  # (e, a, i, b, j)
        Kl = lam * S + mu * S.transpose(0, 3, 2, 1, 4)
        tr = np.einsum("ecicj->eij", S)
        for a in range(3):
            Kl[:, a, :, a, :] += mu * tr
        Kd[e] = Kl.transpose(0, 2, 1, 4, 3).reshape(-1, 3 * nb, 3 * nb)
        Pe = P[:, e].transpose(1, 0, 2)
        Md[e] = rho * (Pe * W[e, None, :]) @ Pe.transpose(0, 2, 1)
    dofs = (3 * s.T[:, :, None] + np.arange(3)).reshape(ne, 3 * nb)  # (E, (i,a))
    rows = np.broadcast_to(dofs[:, :, None], Kd.shape).ravel()
    cols = np.broadcast_to(dofs[:, None, :], Kd.shape).ravel()
    n = 3 * basis.N
    K = sp.coo_matrix((Kd.ravel(), (rows, cols)), shape=(n, n)).tocsr()
    del rows, cols, Kd
    rs = np.broadcast_to(s.T[:, :, None], Md.shape).ravel()
    cs = np.broadcast_to(s.T[:, None, :], Md.shape).ravel()
    Ms = sp.coo_matrix((Md.ravel(), (rs, cs)), shape=(basis.N, basis.N)).tocsr()
    M = sp.kron(Ms, sp.identity(3), format="csr")
    return K, M


class _VectorDofs:
    """DOF bookkeeping of ElementVector(e) from the scalar basis: DOF = 3 s + c."""

    def __init__(self, basis):
        self.b = basis
        self.N = 3 * basis.N
        self.nodal_dofs = 3 * basis.nodal_dofs[0][None, :] + np.arange(3)[:, None]
        self.doflocs = np.repeat(basis.doflocs, 3, axis=1)

    def facet_dofs(self, facets):
        """(k, 3) DOFs of all DOF points (vertex, edge, face) on the facets."""
        view = self.b.get_dofs(facets)
        s = np.concatenate([part["u"] for part in (view.nodal, view.edge, view.facet)
                            if "u" in part])
        return 3 * s[:, None] + np.arange(3)


def solid_from_mesh(mesh, node_sets: dict, p: BladeParams, source: str = "<generated>",
                    element=None, matrices=None, rotation_centre=None, disk=None) -> BladeModel:
    """Assemble a clamped solid blade on a MeshHex/MeshTet with named vertex sets.

    `element` (a scalar scikit-fem element): by default ElementHex2 on hexahedra and
    ElementTetP2 on tetrahedra, with intorder 4 (3 Gauss points per direction on
    hexahedra; the same frequencies as the default rule and much faster); a mesh file
    of 20-node hexahedra gives ElementHexS2 (`MESH_ELEMENTS`).  Linear elements lock in
    bending and are used only for matrices imported with them.  `matrices(basis,
    free)`: (K, M) over the 3 N vector DOFs (3 s + c) instead of assembling them -- an
    imported structure (`structure.imported`).  `disk`: the placement of a disk sector
    (its cut faces joined for the static deflection of a turning one).
    `rotation_centre`: a point [m] of the
    disk axis (along X) for a blade that turns (`rotation.rotation_terms`).  Sets
    required: root; optional: shroud_left/right, excitation, response, cyclic_low/high
    (a disk sector's cut faces, `disk_sector`: their free points only).
    """
    if "root" not in node_sets:
        raise ValueError(f"{source}: mesh has no node set 'root' (the clamped nodes)")
    if not isinstance(mesh, (MeshHex, MeshTet)):
        raise ValueError(f"{source}: mesh must be hexahedral or tetrahedral, got "
                         f"{type(mesh).__name__}")
    cell_type = "hexahedron" if isinstance(mesh, MeshHex) else "tetra"
    if element is None:
        element = ElementHex2() if cell_type == "hexahedron" else ElementTetP2()
    sbasis = Basis(mesh, element, intorder=4)
    basis = _VectorDofs(sbasis)
    fixed, _ = _set_dofs(mesh, basis, node_sets["root"])
    fixed = np.unique(fixed)
    free = np.setdiff1d(np.arange(basis.N), fixed)
    if matrices is None:
        K, M = assemble_elasticity(sbasis, p.E, p.nu, p.rho)
    else:
        K, M = matrices(sbasis, free)
    K, M = K[free][:, free].tocsr(), M[free][:, free].tocsr()
    renum = -np.ones(basis.N, dtype=np.int64)
    renum[free] = np.arange(free.size)
    dof_sets, set_points, weights, facets = {}, {}, {}, {}
    for name, nodes in node_sets.items():
        if name == "root":
            continue
        if name in POINT_SETS:
            d, x = basis.nodal_dofs[:, nodes].T, mesh.p[:, nodes].T
        else:
            d, x = _set_dofs(mesh, basis, nodes)
        dof_sets[name], set_points[name] = renum[d], x
        if name in CUT_SETS:   # a disk sector's cut face: its free points (not the bore's)
            free_rows = np.all(renum[d] >= 0, axis=1)
            if np.any(renum[d][~free_rows] >= 0):
                raise ValueError(f"{source}: node set {name!r} has partly clamped points")
            dof_sets[name], set_points[name] = renum[d][free_rows], x[free_rows]
        if name in CONTACT_SETS:
            weights[name] = _face_weights(mesh, sbasis, nodes, d[:, 0] // 3)
            facets[name] = _face_facets(mesh, sbasis, nodes, d[:, 0] // 3, x)
    frames = {}
    n_right = None
    for name in ("shroud_right", "shroud_left"):
        if name in node_sets:
            f = _frame(mesh, name, node_sets[name], set_points[name], dof_sets[name], n_right,
                       weights[name], facets[name])
            n_right = f.normal if name == "shroud_right" else n_right
            frames[name] = f
    turning = None if rotation_centre is None else rotation_terms(
        sbasis, free, K, p.E, p.nu, p.rho, rotation_centre,
        joined=joined_cut(free.size, dof_sets, set_points, disk))
    t = mesh.t if cell_type == "tetra" else mesh.t[HEX_MAPPING[:8]]
    log.info("solid blade (%s): %d cells, %d free DOFs", source, mesh.t.shape[1], free.size)
    vertices = mesh.p[:, :mesh.nvertices]   # a curved mesh's p holds its midside nodes too
    return BladeModel(p, K, M, vertices.T.copy(), ((cell_type, t.T.copy()),),
                      renum[basis.nodal_dofs.T], np.eye(3), dof_sets, set_points, frames,
                      {k: np.asarray(v) for k, v in node_sets.items()}, turning)


def joined_cut(n: int, dof_sets, set_points, disk):
    """u = J q (sparse (n, n')) of a disk sector's n free DOFs with its cut faces joined at
    nodal diameter 0 (`cyclic_cut.cut_maps`: A + B), None without cut faces; ValueError
    when it has them and no `disk` placement."""
    if not all(s in dof_sets for s in CUT_SETS):
        return None
    if disk is None:
        raise ValueError("cyclic_low, cyclic_high: a turning disk sector needs its disk "
                         "placement (sectors, hub radius)")
    high = cut_pairing(set_points["cyclic_low"], set_points["cyclic_high"], disk)
    A, B, _ = cut_maps(n, dof_sets["cyclic_low"], dof_sets["cyclic_high"][high],
                       disk.rotation(disk.pitch_angle))
    return A + B


def solid_blade(p: BladeParams, disk: DiskPlacement | None = None,
                rotation_centre=None) -> BladeModel:
    """Generated solid blade (see `solid_mesh`; curved by `airfoil.curved_mesh` when
    its twist, camber or taper is set); in a disk, its params carry the derived shroud
    width; turning about the axis through `rotation_centre`, its `rotation` terms."""
    mesh, sets = solid_mesh(p, disk)
    wp = p if disk is None else wheel_params(p, disk)
    if is_curved(p):
        mesh = curved_mesh(mesh, solid_mesh(wp)[0], wp)
    return solid_from_mesh(mesh, sets, wp, rotation_centre=rotation_centre)
