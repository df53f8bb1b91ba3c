"""Euler-Bernoulli beam blade (scikit-fem), its rigid tip shroud, and the closed-form
cantilever frequencies.

Bending in flap (eta, EI_flap = E c t^3/12) and edge (xi, EI_edge = E t c^3/12)
with ElementLineHermite, axial (EA) and St Venant torsion (GJ, rho I_p) with P1;
the four fields are uncoupled (Euler-Bernoulli theory: no shear deformation, no
rotary inertia of the sections; e.g. Geradin & Rixen, Mechanical Vibrations, 3rd ed.,
ch. 5; Timoshenko & Gere for the plane-section kinematics):

    K_b: int EI w'' v'' dz,  M_b: int rho A w v dz,
    K_a: int EA u' v' dz,    K_t: int GJ th' ph' dz,   M_t: int rho I_p th ph dz.

Rigid tip shroud (`p.shroud`): the block of the solid blade (shroud_chord x
shroud_width x shroud_height [m] on the tip, side faces sheared by the shroud angle,
`solid.solid_mesh`) moves with the tip section.  Plane sections stay plane and normal
to the axis, so the tip section turns by theta = (-eta', xi', phi) about the section
axes (xi, eta, z) and a shroud point x_k moves by

    d_k = R_gamma [u_tip + theta x R_gamma^T (x_k - x_tip)],   u_tip = (xi, eta, w),

R_gamma the stagger turn (`fe_model.rotation_z`).  Its mass enters M as the 6 x 6
rigid-body mass matrix of a rectangular block about the tip, projected on the tip
DOFs.  Frames and contact conventions: `fe_model`.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from skfem import Basis, BilinearForm, ElementLineHermite, ElementLineP1, MeshLine, asm
from skfem.helpers import dd, dot, grad

from .disk import wheel_params
from .fe_model import BladeModel, BladeParams, ContactFrame, DiskPlacement, rotation_z

log = logging.getLogger(__name__)


@BilinearForm
def _bending(u, v, w):
    return dd(u)[0, 0] * dd(v)[0, 0]


@BilinearForm
def _stretch(u, v, w):
    return dot(grad(u), grad(v))


@BilinearForm
def _mass_scalar(u, v, w):
    return u * v


def torsion_constant(a: float, b: float) -> float:
    """St Venant J of a rectangle a x b (a >= b): a b^3 [1/3 - 0.21 (b/a)(1 - (b/a)^4/12)]."""
    a, b = max(a, b), min(a, b)
    r = b / a
    return a * b**3 * (1 / 3 - 0.21 * r * (1 - r**4 / 12))


GAUSS_2 = np.array([-1.0, 1.0]) / np.sqrt(3.0)   # 2-point Gauss abscissae on [-1, 1] [-]


def line_bases(p: BladeParams):
    """(MeshLine of n_span elements on z in [0, L] [m], Hermite basis, P1 basis)."""
    mesh = MeshLine(np.linspace(0.0, p.length, p.n_span + 1))
    return mesh, Basis(mesh, ElementLineHermite()), Basis(mesh, ElementLineP1())


def field_dofs(bh, b1) -> dict:
    """Unconstrained DOF numbering of the beam fields by node: name -> (n_span + 1,)
    in the blocks [flap (w, w'), edge (w, w'), axial, torsion]."""
    nh, n1 = bh.N, b1.N
    return {"flap": bh.nodal_dofs[0], "flap_slope": bh.nodal_dofs[1],
            "edge": nh + bh.nodal_dofs[0], "edge_slope": nh + bh.nodal_dofs[1],
            "axial": 2 * nh + b1.nodal_dofs[0], "twist": 2 * nh + n1 + b1.nodal_dofs[0]}


def free_numbering(bh, b1) -> np.ndarray:
    """Free-DOF index of every unconstrained DOF (-1: clamped at the root node)."""
    full = field_dofs(bh, b1)
    renum = -np.ones(2 * bh.N + 2 * b1.N, dtype=np.int64)
    free = np.setdiff1d(np.arange(renum.size), [v[0] for v in full.values()])
    renum[free] = np.arange(free.size)
    return renum


def beam_dofs(p: BladeParams) -> dict:
    """Free-DOF numbering of `beam_blade(p)`: name -> (n_span + 1,) indices per node
    (-1 at the clamped root) of "edge" (xi), "flap" (eta), "axial" (z) translations
    [m], "edge_slope" (d xi/dz), "flap_slope" (d eta/dz) [-] and "twist" (phi, right
    handed about +z) [rad]."""
    _, bh, b1 = line_bases(p)
    renum = free_numbering(bh, b1)
    return {k: renum[v] for k, v in field_dofs(bh, b1).items()}


def tip_operator(p: BladeParams, n_dof: int) -> sp.csr_matrix:
    """G sparse (6, n_dof) [-]: the tip section's rigid motion in section axes,
    [u; theta] = G q with u = (xi, eta, w) [m] and theta = (-eta', xi', phi) [rad]
    (plane sections normal to the axis: a flap slope eta' > 0 turns the section about
    -xi, an edge slope xi' > 0 about +eta)."""
    d = {k: v[-1] for k, v in beam_dofs(p).items()}
    cols = [d["edge"], d["flap"], d["axial"], d["flap_slope"], d["edge_slope"], d["twist"]]
    vals = [1.0, 1.0, 1.0, -1.0, 1.0, 1.0]
    return sp.csr_matrix((vals, (np.arange(6), cols)), shape=(6, n_dof))


def skew(r) -> np.ndarray:
    """[r]x (3, 3): [r]x a = r x a."""
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def shroud_block_mass(p: BladeParams) -> np.ndarray:
    """6 x 6 rigid-body mass [kg, kg m, kg m^2] of the shroud block about the tip node,
    for [u; theta] in section axes: m = rho c_s w_s h_s, centroid r_c = (0, 0, h_s/2),

        M6 = [[m I, -m [r_c]x], [m [r_c]x, I_c - m [r_c]x^2]],
        I_c = m/12 diag(w_s^2 + h_s^2, c_s^2 + h_s^2, c_s^2 + w_s^2)

    (kinetic energy of v = u + theta x r; the rectangular block, the shear of the
    overhang by the shroud angle left out)."""
    cs, ws, hs = p.shroud_chord, p.shroud_width, p.shroud_height
    m = p.rho * cs * ws * hs
    S = skew([0.0, 0.0, hs / 2])
    Ic = m / 12 * np.diag([ws**2 + hs**2, cs**2 + hs**2, cs**2 + ws**2])
    return np.block([[m * np.eye(3), -m * S], [m * S, Ic - m * S @ S]])


def shroud_face_geometry(p: BladeParams, disk: DiskPlacement | None = None) -> dict:
    """name -> (points (4, 3) [m], outward unit normal) of the shroud faces, where the
    solid generator puts them (`solid.solid_mesh`, global axes): the right face is
    eta = w_s/2 + xi tan(a - gamma), z in [L, L + h_s], turned by the stagger gamma;
    points at the 2 x 2 Gauss points of (xi, z) in [-c_s/2, c_s/2] x [L, L + h_s].
    The left face is eta = -w_s/2 + xi tan(a - gamma), or with a disk the right face
    turned by -alpha about the disk axis, point for point (`disk.pair_faces`)."""
    xi, zeta = np.meshgrid(p.shroud_chord / 2 * GAUSS_2, GAUSS_2, indexing="ij")
    xi, z = xi.ravel(), p.length + p.shroud_height / 2 * (1.0 + zeta.ravel())
    shear = np.tan(p.shroud_angle - p.stagger_angle)
    R = rotation_z(p.stagger_angle)
    a = p.shroud_angle
    n_right = np.array([-np.sin(a), np.cos(a), 0.0])
    faces = {}
    for name, side in (("shroud_right", 1.0), ("shroud_left", -1.0)):
        eta = side * p.shroud_width / 2 + xi * shear
        faces[name] = (np.stack([xi, eta, z], axis=1) @ R.T, side * n_right)
    if disk is not None:
        R_back = disk.rotation(-disk.pitch_angle)
        faces["shroud_left"] = (disk.rotate(faces["shroud_right"][0], -disk.pitch_angle),
                                R_back @ -n_right)
    return faces


def shroud_frames(p: BladeParams, n_dof: int, disk: DiskPlacement | None = None) -> dict:
    """The two `ContactFrame`s of the rigid shroud: points of `shroud_face_geometry`,
    motion P (12, n_dof) with rows d_k = R_gamma [I, -[rho_k]x] G q, rho_k =
    R_gamma^T (x_k - x_tip) (module doc), and area weights A / 4 each, A = c_s h_s /
    cos(a - gamma) [m^2] (2 x 2 Gauss rule: exact for a bilinear pressure)."""
    G = tip_operator(p, n_dof)
    R = rotation_z(p.stagger_angle)
    tip = np.array([0.0, 0.0, p.length])
    area = p.shroud_chord * p.shroud_height / np.cos(p.shroud_angle - p.stagger_angle)
    geom = shroud_face_geometry(p, disk)
    n_right = geom["shroud_right"][1]
    t = np.cross(n_right, [0.0, 0.0, 1.0])
    t /= np.linalg.norm(t)
    frames = {}
    for name, (x, n) in geom.items():
        rows = [R @ np.hstack([np.eye(3), -skew(R.T @ (xk - tip))]) for xk in x]
        P = sp.csr_matrix(np.vstack(rows)) @ G
        frames[name] = ContactFrame(name, n, t, np.cross(t, n_right), x,
                                    -np.ones((len(x), 3), dtype=np.int64),
                                    np.full(len(x), area / len(x)), P.tocsr())
    return frames


def beam_blade(p: BladeParams, disk: DiskPlacement | None = None) -> BladeModel:
    """Euler-Bernoulli beam blade: free DOFs [flap (w, w'), edge (w, w'), axial, torsion]
    (`beam_dofs`).

    Uncoupled fields on one MeshLine of `n_span` elements, root node clamped.  DOF
    sets hold the local translations (edge xi, flap eta, axial z) of a node.  With
    `p.shroud`, a rigid tip shroud (module doc): its mass in M and the frames of its
    faces, whose points move with the tip's 6 DOFs; with a `disk` placement, shaped
    for the wheel (`disk.wheel_params`: the derived shroud width, the left face the
    right one turned by -alpha).
    """
    if disk is not None:
        p = wheel_params(p, disk)
    c, t, L = p.chord, p.thickness, p.length
    A = c * t
    EI_flap, EI_edge = p.E * c * t**3 / 12, p.E * t * c**3 / 12
    J, Ip = torsion_constant(c, t), (c * t**3 + t * c**3) / 12
    mesh, bh, b1 = line_bases(p)
    z = mesh.p[0]
    Kb, Mb = asm(_bending, bh), asm(_mass_scalar, bh)
    Ks, Ms = asm(_stretch, b1), asm(_mass_scalar, b1)
    K = sp.block_diag([EI_flap * Kb, EI_edge * Kb, p.E * A * Ks, p.G * J * Ks]).tocsr()
    M = sp.block_diag([p.rho * A * Mb, p.rho * A * Mb, p.rho * A * Ms, p.rho * Ip * Ms]).tocsr()
    renum = free_numbering(bh, b1)
    free = np.nonzero(renum >= 0)[0]
    K, M = K[free][:, free].tocsr(), M[free][:, free].tocsr()
    dofs = {k: renum[v] for k, v in field_dofs(bh, b1).items()}
    frames = {}
    if p.shroud:
        G = tip_operator(p, K.shape[0])
        M = (M + G.T @ sp.csr_matrix(shroud_block_mass(p)) @ G).tocsr()
        frames = shroud_frames(p, K.shape[0], disk)
    point_dofs = np.stack([dofs["edge"], dofs["flap"], dofs["axial"]], axis=1)  # xi, eta, z
    points = np.stack([0 * z, 0 * z, z], axis=1)
    nv = z.size
    exc = int(np.argmin(abs(z - L / 3)))
    node_sets = {"root": np.array([0]), "excitation": np.array([exc]),
                 "response": np.array([nv - 1])}
    dof_sets = {k: point_dofs[v] for k, v in node_sets.items() if k != "root"}
    set_points = {k: points[v] for k, v in node_sets.items()}
    set_points.update({k: f.points for k, f in frames.items()})
    log.info("beam blade: %d elements, %d free DOFs%s", p.n_span, K.shape[0],
             ", rigid tip shroud" if p.shroud else "")
    node = np.arange(nv)
    return BladeModel(p, K, M, points, (("line", np.stack([node[:-1], node[1:]], 1)),),
                      point_dofs, rotation_z(p.stagger_angle), dof_sets, set_points, frames,
                      node_sets)


def euler_bernoulli_frequencies(p: BladeParams, n: int = 3, plane: str = "flap") -> np.ndarray:
    """Cantilever bending frequencies [Hz]: f_k = (beta_k L)^2 sqrt(EI/(rho A L^4)) / (2 pi)."""
    roots = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349,
                      14.1371683910])
    if n > roots.size:
        raise ValueError(f"n must be <= {roots.size}, got {n}")
    c, t = p.chord, p.thickness
    I = c * t**3 / 12 if plane == "flap" else t * c**3 / 12
    if plane not in ("flap", "edge"):
        raise ValueError(f"plane must be 'flap' or 'edge', got {plane!r}")
    return roots[:n] ** 2 * np.sqrt(p.E * I / (p.rho * c * t * p.length**4)) / (2 * np.pi)
