"""Finite-element blades (scikit-fem): beam and solid with tip shroud, meshes, contact frames.

The only module that imports scikit-fem.  It turns parameters (or a mesh file) into
plain data: sparse K, M over the free DOFs (root clamped), named DOF sets and the
contact frames of the shroud faces.

Frames and conventions (SI units, angles in radians)
----------------------------------------------------
Global axes: X axial, Y circumferential (towards the next blade, j+1), Z radial
(span, root at Z = 0).  The airfoil is a rectangle chord x thickness in its own
(xi, eta) section frame, turned about Z by the stagger angle gamma:

    X = xi cos(gamma) - eta sin(gamma),   Y = xi sin(gamma) + eta cos(gamma).

The tip shroud is a block (shroud_chord x shroud_width x shroud_height) on top of
the airfoil; its two side faces are the contact faces, `shroud_right` (towards +Y,
blade j+1) and `shroud_left` (towards -Y, blade j-1).  Both are parallel planes with
outward normals n_R = (-sin a, cos a, 0) = -n_L, a = shroud_angle measured from the
circumferential axis Y (a = 0: faces normal to Y).

Solid blade: 3D linear elasticity with triquadratic hexahedra (ElementHex2,
intorder 4 -- linear elements lock in bending) on a structured mesh; user meshes
of tetrahedra use ElementTetP2.  Weak forms (ex03/ex21 of scikit-fem):

    K: int_V  sigma(u) : eps(v) dV,     M: int_V rho u . v dV.

Beam blade: Euler-Bernoulli bending in flap (eta, EI_flap = E c t^3/12) and edge
(xi, EI_edge = E t c^3/12) with ElementLineHermite, axial (EA) and St Venant
torsion (GJ, rho I_p) with P1; the four fields are uncoupled:

    K_b: int EI w'' v'' dz,  M_b: int rho A w v dz,
    K_a: int EA u' v' dz,    K_t: int GJ th' ph' dz,   M_t: int rho I_p th ph dz.

Contact maps: at a face point k with displacement d_k (3 components),
u_k = t . d_k (tangential) and v_k = n . d_k (normal, n outward: v > 0 closes the
gap, as the Yang-Menq normal load n0 + kv v of `pipeline.contact`).  The tangent
t = n_R x e_Z / |n_R x e_Z| is the same for both faces of a blade so that the pair
(right face of blade j, left face of blade j+1) shares one frame; t2 = t x n_R is the
second (radial) tangent.  Rows of Bt, Bn (as in system.py) carry these direction
cosines on the DOFs of the point; against a rigid neighbour they are the relative
displacements.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from pathlib import Path

import meshio
import numpy as np
import scipy.sparse as sp
from skfem import (Basis, BilinearForm, ElementHex2, ElementLineHermite, ElementLineP1,
                   ElementTetP2, FacetBasis, LinearForm, MeshHex, MeshLine, MeshTet, asm)
from skfem.helpers import dd, dot, grad
from skfem.io.meshio import HEX_MAPPING
from skfem.models.elasticity import lame_parameters

log = logging.getLogger(__name__)

CONTACT_SETS = ("shroud_left", "shroud_right")
POINT_SETS = ("excitation", "response")
REQUIRED_SETS = ("root",) + CONTACT_SETS + POINT_SETS
_INV_HEX = [HEX_MAPPING.index(i) for i in range(8)]


# ---------------------------------------------------------------------------
# Parameters
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class BladeParams:
    """Blade geometry [m], material (E [Pa], nu [-], rho [kg/m^3]), angles [rad].

    kind: "solid" (Hex2 elements, with tip shroud if `shroud`) or "beam"
    (Euler-Bernoulli, never shrouded).  Mesh resolution: elements across the
    chord (`n_chord`), the thickness (`n_thick`) and along the span (`n_span`);
    the shroud overhang uses the chordwise element size.  `damping_ratios`:
    modal damping ratios zeta_k (the last one repeats for higher modes).
    """

    length: float = 0.10
    chord: float = 0.03
    thickness: float = 0.004
    shroud_chord: float = 0.03
    shroud_width: float = 0.02
    shroud_height: float = 0.004
    shroud_angle: float = np.deg2rad(30.0)
    stagger_angle: float = np.deg2rad(20.0)
    E: float = 210e9
    nu: float = 0.3
    rho: float = 7850.0
    damping_ratios: tuple = (0.002,)
    shroud: bool = True
    kind: str = "solid"
    n_chord: int = 8
    n_thick: int = 2
    n_span: int = 20

    def __post_init__(self):
        positive = ("length", "chord", "thickness", "shroud_chord", "shroud_width",
                    "shroud_height", "E", "rho")
        for name in positive:
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        if not (-1.0 < self.nu < 0.5):
            raise ValueError(f"nu must be in (-1, 0.5), got {self.nu!r}")
        for name in ("shroud_angle", "stagger_angle"):
            v = getattr(self, name)
            if not (np.isfinite(v) and abs(v) < np.pi / 2):
                raise ValueError(f"{name} must be in (-pi/2, pi/2) rad, got {v!r}")
        for name in ("n_chord", "n_thick", "n_span"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {v!r}")
        if self.kind not in ("solid", "beam"):
            raise ValueError(f"kind must be 'solid' or 'beam', got {self.kind!r}")
        z = np.atleast_1d(np.asarray(self.damping_ratios, dtype=float))
        if z.ndim != 1 or z.size < 1 or np.any(~np.isfinite(z)) or np.any(z < 0):
            raise ValueError(f"damping_ratios must be a non-empty sequence of ratios >= 0, "
                             f"got {self.damping_ratios!r}")
        object.__setattr__(self, "damping_ratios", tuple(float(x) for x in z))
        if self.shroud and self.kind == "solid":
            if self.shroud_width <= self.thickness:
                raise ValueError(f"shroud_width must exceed thickness ({self.thickness}), "
                                 f"got {self.shroud_width!r}")
            # the overhang is sheared by tan(a - gamma); keep every hexahedron valid
            shear = abs(np.tan(self.shroud_angle - self.stagger_angle)) * self.shroud_chord / 2
            if shear > 0.5 * (self.shroud_width - self.thickness) / 2:
                raise ValueError(
                    f"shroud_angle {self.shroud_angle!r} too far from stagger_angle "
                    f"{self.stagger_angle!r} for this shroud (overhang shear "
                    f"{shear:.3g} m > half the overhang): widen the shroud or change the angle")

    @property
    def G(self) -> float:
        return self.E / (2 * (1 + self.nu))


# ---------------------------------------------------------------------------
# Model data
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class ContactFrame:
    """One planar contact face: unit vectors and its points' DOFs (free numbering).

    normal: outward unit normal n; tangent: t = n_R x e_Z (shared by both faces);
    tangent2: t x n_R (radial, shared).  points (k, 3) [m]; dofs (k, 3) free-DOF indices of the X, Y, Z
    displacement components of each point.  weights (k,) [m^2]: int_face N_k dA, the
    face area each point carries (its shape function integrated over the face; they
    sum to the face area); None when the face spans no element facet.
    """

    name: str
    normal: np.ndarray
    tangent: np.ndarray
    tangent2: np.ndarray
    points: np.ndarray
    dofs: np.ndarray
    weights: np.ndarray | None = None

    def maps(self, n_dof: int):
        """(Bt, Bn, Bt2) sparse (k, n_dof): u = Bt q, v = Bn q, u2 = Bt2 q."""
        k = self.dofs.shape[0]
        rows = np.repeat(np.arange(k), 3)
        cols = self.dofs.ravel()
        out = []
        for vec in (self.tangent, self.normal, self.tangent2):
            vals = np.tile(vec, k)
            out.append(sp.csr_matrix((vals, (rows, cols)), shape=(k, n_dof)))
        return tuple(out)


@dataclass(frozen=True, eq=False)
class BladeModel:
    """A clamped blade as plain data.

    K, M: sparse (n, n) over the free DOFs [N/m], [kg].  points (Np, 3) and cells
    (meshio type, connectivity) describe the output mesh (vertices); point_dofs
    (Np, 3) gives the free DOF of each displacement component (-1: clamped), in the
    frame `point_rotation` (global = point_rotation @ local; identity for solids).
    dof_sets: name -> (k, 3) free DOF indices; set_points: name -> (k, 3) coordinates.
    """

    params: BladeParams
    K: sp.csr_matrix
    M: sp.csr_matrix
    points: np.ndarray
    cells: tuple
    point_dofs: np.ndarray
    point_rotation: np.ndarray
    dof_sets: dict = field(default_factory=dict)
    set_points: dict = field(default_factory=dict)
    frames: dict = field(default_factory=dict)
    node_sets: dict = field(default_factory=dict)

    @property
    def n_dof(self) -> int:
        return self.K.shape[0]


def boundary_dofs(model: BladeModel, names=None) -> tuple[np.ndarray, tuple]:
    """Free-DOF indices of the named sets (default: contact faces, excitation,
    response -- those present), de-duplicated in order, and their labels
    `"<set>:<point>:<component>"`."""
    if names is None:
        names = [s for s in CONTACT_SETS + POINT_SETS if s in model.dof_sets]
    dofs, labels, seen = [], [], set()
    comp = "xyz"
    for name in names:
        if name not in model.dof_sets:
            raise ValueError(f"names: blade has no DOF set {name!r} "
                             f"(has {sorted(model.dof_sets)})")
        for k, row in enumerate(model.dof_sets[name]):
            for c, d in enumerate(row):
                if d >= 0 and d not in seen:
                    seen.add(int(d))
                    dofs.append(int(d))
                    labels.append(f"{name}:{k}:{comp[c]}")
    return np.asarray(dofs, dtype=np.int64), tuple(labels)


# ---------------------------------------------------------------------------
# Beam blade
# ---------------------------------------------------------------------------

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


def _rotation_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def beam_blade(p: BladeParams) -> BladeModel:
    """Euler-Bernoulli beam blade: free DOFs [flap (w, w'), edge (w, w'), axial, torsion].

    Uncoupled fields on one MeshLine of `n_span` elements, root node clamped.  DOF
    sets hold the local translations (edge xi, flap eta, axial z) of a node.
    """
    c, t, L = p.chord, p.thickness, p.length
    A = c * t
    EI_flap, EI_edge = p.E * c * t**3 / 12, p.E * t * c**3 / 12
    J, Ip = torsion_constant(c, t), (c * t**3 + t * c**3) / 12
    z = np.linspace(0.0, L, p.n_span + 1)
    mesh = MeshLine(z)
    bh = Basis(mesh, ElementLineHermite())
    b1 = Basis(mesh, ElementLineP1())
    Kb, Mb = asm(_bending, bh), asm(_mass_scalar, bh)
    Ks, Ms = asm(_stretch, b1), asm(_mass_scalar, b1)
    K = sp.block_diag([EI_flap * Kb, EI_edge * Kb, p.E * A * Ks, p.G * J * Ks]).tocsr()
    M = sp.block_diag([p.rho * A * Mb, p.rho * A * Mb, p.rho * A * Ms, p.rho * Ip * Ms]).tocsr()
    nh, n1 = bh.N, b1.N
    off = np.array([0, nh, 2 * nh, 2 * nh + n1])
    nv = z.size
    node = np.arange(nv)
    local = np.stack([off[1] + bh.nodal_dofs[0], off[0] + bh.nodal_dofs[0],
                      off[2] + b1.nodal_dofs[0]], axis=1)  # (nv, 3): xi, eta, z
    fixed = np.concatenate([off[0] + bh.nodal_dofs[:, 0], off[1] + bh.nodal_dofs[:, 0],
                            [off[2] + b1.nodal_dofs[0, 0], off[3] + b1.nodal_dofs[0, 0]]])
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    K, M = K[free][:, free].tocsr(), M[free][:, free].tocsr()
    renum = -np.ones(K.shape[0] + fixed.size, dtype=np.int64)
    renum[free] = np.arange(free.size)
    point_dofs = renum[local]
    R = _rotation_z(p.stagger_angle)
    points = np.stack([0 * z, 0 * z, z], axis=1)
    exc = int(np.argmin(abs(z - L / 3)))
    node_sets = {"root": np.array([0]), "excitation": np.array([exc]),
                 "response": np.array([nv - 1])}
    dof_sets = {k: point_dofs[v] for k, v in node_sets.items() if k != "root"}
    set_points = {k: points[v] for k, v in node_sets.items()}
    log.info("beam blade: %d elements, %d free DOFs", p.n_span, K.shape[0])
    return BladeModel(p, K, M, points, (("line", np.stack([node[:-1], node[1:]], 1)),),
                      point_dofs, R, dof_sets, set_points, {}, node_sets)


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


def solid_mesh(p: BladeParams):
    """Structured hexahedral blade (+ shroud): (MeshHex, node sets by vertex index).

    Built in the section frame (xi, eta, z), the shroud overhang |eta| > t/2 is
    sheared, eta' = eta + s(eta) xi tan(a - gamma) with s ramping 0 -> 1 across the
    overhang, so the side faces are planes tilted by a - gamma; the whole blade is
    then turned by the stagger gamma about Z.  The airfoil is not distorted.
    """
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
    X = _rotation_z(p.stagger_angle) @ X
    mesh = replace(mesh, doflocs=X)
    return mesh, sets


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
    """int_face N_s dA [m^2] of the scalar DOFs `scalar_dofs` over the boundary facets
    spanned by `nodes` (None if they span none): the area each face point carries."""
    bf = mesh.boundary_facets()
    facets = bf[np.isin(mesh.facets[:, bf], nodes).all(axis=0)]
    if not facets.size:
        return None
    fb = FacetBasis(mesh, sbasis.elem, facets=facets, intorder=4)
    return LinearForm(lambda v, w: v).assemble(fb)[scalar_dofs]


def _frame(mesh, name, nodes, points, dofs, n_right, weights=None):
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
    return ContactFrame(name, normal, tangent, np.cross(tangent, ref), points, dofs, weights)


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


def solid_from_mesh(mesh, node_sets: dict, p: BladeParams, source: str = "<generated>"
                    ) -> BladeModel:
    """Assemble a clamped solid blade on a MeshHex/MeshTet with named vertex sets.

    Hexahedra use ElementHex2 with intorder 4 (3 Gauss points per direction; the
    same frequencies as the default rule and much faster); tetrahedra ElementTetP2.
    Linear elements lock in bending and are not offered.  Sets required: root;
    optional: shroud_left/right, excitation, response.
    """
    if "root" not in node_sets:
        raise ValueError(f"{source}: mesh has no node set 'root' (the clamped nodes)")
    if isinstance(mesh, MeshHex):
        sbasis = Basis(mesh, ElementHex2(), intorder=4)
        cell_type = "hexahedron"
    elif isinstance(mesh, MeshTet):
        sbasis = Basis(mesh, ElementTetP2(), intorder=4)
        cell_type = "tetra"
    else:
        raise ValueError(f"{source}: mesh must be hexahedral or tetrahedral, got "
                         f"{type(mesh).__name__}")
    K, M = assemble_elasticity(sbasis, p.E, p.nu, p.rho)
    basis = _VectorDofs(sbasis)
    fixed, _ = _set_dofs(mesh, basis, node_sets["root"])
    fixed = np.unique(fixed)
    free = np.setdiff1d(np.arange(basis.N), fixed)
    K, M = K[free][:, free].tocsr(), M[free][:, free].tocsr()
    renum = -np.ones(basis.N, dtype=np.int64)
    renum[free] = np.arange(free.size)
    dof_sets, set_points, weights = {}, {}, {}
    for name, nodes in node_sets.items():
        if name == "root":
            continue
        if name in POINT_SETS:
            d, x = basis.nodal_dofs[:, nodes].T, mesh.p[:, nodes].T
        else:
            d, x = _set_dofs(mesh, basis, nodes)
        dof_sets[name], set_points[name] = renum[d], x
        if name in CONTACT_SETS:
            weights[name] = _face_weights(mesh, sbasis, nodes, d[:, 0] // 3)
    frames = {}
    n_right = None
    for name in ("shroud_right", "shroud_left"):
        if name in node_sets:
            f = _frame(mesh, name, node_sets[name], set_points[name], dof_sets[name], n_right,
                       weights[name])
            n_right = f.normal if name == "shroud_right" else n_right
            frames[name] = f
    t = mesh.t if cell_type == "tetra" else mesh.t[HEX_MAPPING[:8]]
    log.info("solid blade (%s): %d cells, %d free DOFs", source, mesh.t.shape[1], free.size)
    return BladeModel(p, K, M, mesh.p.T.copy(), ((cell_type, t.T.copy()),),
                      renum[basis.nodal_dofs.T], np.eye(3), dof_sets, set_points, frames,
                      {k: np.asarray(v) for k, v in node_sets.items()})


def solid_blade(p: BladeParams) -> BladeModel:
    """Generated solid blade (see `solid_mesh`)."""
    mesh, sets = solid_mesh(p)
    return solid_from_mesh(mesh, sets, p)


def build_blade(p: BladeParams) -> BladeModel:
    """Beam or solid blade according to `p.kind`."""
    return beam_blade(p) if p.kind == "beam" else solid_blade(p)


# ---------------------------------------------------------------------------
# Mesh files (meshio): node sets stored as 0/1 point data
# ---------------------------------------------------------------------------

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


def read_mesh(path, required=REQUIRED_SETS):
    """Read a volume mesh and its named node sets: (skfem mesh, {name: vertex indices}).

    A set is found as (in order) a point-data mask, a meshio point set, or a cell
    set (its cells' nodes, e.g. gmsh physical surfaces).  Quadratic cells are read
    by their corner nodes; unused points are dropped.
    """
    path = Path(path)
    if not path.exists():
        raise ValueError(f"mesh file {path} does not exist")
    m = meshio.read(path)
    kinds = {"hexahedron": 8, "hexahedron27": 8, "hexahedron20": 8,
             "tetra": 4, "tetra10": 4}
    blocks = [(i, c) for i, c in enumerate(m.cells) if c.type in kinds]
    if not blocks:
        raise ValueError(f"{path}: no hexahedral or tetrahedral cells "
                         f"(found {[c.type for c in m.cells]})")
    hexa = blocks[0][1].type.startswith("hexa")
    conn = np.concatenate([c.data[:, :kinds[c.type]] for _, c in blocks
                           if c.type.startswith("hexa") == hexa])
    sets = {}
    for name, arr in m.point_data.items():
        a = np.asarray(arr).ravel()
        if a.size == len(m.points):
            sets[name] = np.nonzero(a > 0.5)[0]
    for name, idx in (getattr(m, "point_sets", None) or {}).items():
        sets.setdefault(name, np.asarray(idx).ravel())
    for name, per_block in (m.cell_sets or {}).items():
        nodes = [m.cells[j].data[np.asarray(ix, dtype=np.int64)].ravel()
                 for j, ix in enumerate(per_block) if ix is not None and len(ix)]
        if nodes:
            sets.setdefault(name, np.unique(np.concatenate(nodes)))
    if "gmsh:physical" in m.cell_data and m.field_data:
        for name, (tag, _) in m.field_data.items():
            nodes = [c.data[np.asarray(m.cell_data["gmsh:physical"][j]) == tag].ravel()
                     for j, c in enumerate(m.cells)]
            nodes = np.concatenate(nodes) if nodes else np.array([], int)
            if nodes.size:
                sets.setdefault(name, np.unique(nodes))
    for name in required:
        if name not in sets or len(sets[name]) == 0:
            raise ValueError(f"mesh file {path} has no node set {name!r} "
                             f"(found: {sorted(sets) or 'none'})")
    used = np.unique(conn)
    renum = -np.ones(len(m.points), dtype=np.int64)
    renum[used] = np.arange(used.size)
    X = np.ascontiguousarray(m.points[used, :3].T, dtype=float)
    t = renum[conn].T
    mesh = MeshHex(X, np.ascontiguousarray(t[_INV_HEX])) if hexa else MeshTet(X, t)
    node_sets = {}
    for k, v in sets.items():
        r = renum[np.asarray(v, dtype=np.int64)]
        node_sets[k] = r[r >= 0]
    return mesh, node_sets


def load_blade(path, p: BladeParams = BladeParams(),
               required=("root",) + CONTACT_SETS) -> BladeModel:
    """Solid blade from a mesh file (.msh/.vtu/.xdmf) with named node sets; material
    and damping from `p`.  A missing set raises ValueError naming file and set."""
    mesh, sets = read_mesh(path, required)
    keep = {k: v for k, v in sets.items() if k in REQUIRED_SETS}
    return solid_from_mesh(mesh, keep, p, str(path))


def point_displacements(model: BladeModel, u: np.ndarray) -> np.ndarray:
    """Displacements of the output points (Np, 3[, k]) in global axes from free-DOF
    vectors u (n,) or (n, k); clamped components are zero."""
    u = np.asarray(u)
    pad = np.concatenate([u, np.zeros((1,) + u.shape[1:], dtype=u.dtype)])
    d = pad[model.point_dofs]  # -1 picks the zero row
    return np.einsum("ij,pj...->pi...", model.point_rotation, d)


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
