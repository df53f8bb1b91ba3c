"""Blade FE models as plain data: parameters, contact frames, the clamped model.

A blade is sparse K, M over the free DOFs (root clamped), named DOF sets and the
contact frames of the shroud faces (for a beam blade, faces of a rigid tip shroud
whose points move with the tip's DOFs, `ContactFrame.motion`).  This module imports neither scikit-fem nor
meshio (both slow to import): `beam` and `solid` assemble the two kinds of blade
with scikit-fem, `mesh_io` reads and writes mesh files with meshio, and `blades`
builds one from parameters or a mesh file (`build_blade`, `load_blade`).

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

Contact maps: at a face point k with displacement d_k (3 components),
u_k = t . d_k (tangential) and v_k = n . d_k (normal, n outward: v > 0 closes the
gap, as the Yang-Menq normal load n0 + kv v of `pipeline.contact`).  The frame's
tangent t = n_R x e_Z / |n_R x e_Z| is the same for both faces of a blade; t2 = t x n_R
is the second (radial) tangent.  A shroud pair in a disk slides along its own tangent,
the circumferential direction at the right face's centre projected into the face
(`model.contacts.pair_frame`); the frame's t serves a face against a wall.  Rows of Bt, Bn (as in system.py) carry these direction
cosines on the DOFs of the point; against a rigid neighbour they are the relative
displacements.

A blade in a disk (`DiskPlacement`): the disk axis is parallel to X through
(0, 0, -R), the root at radius R; blade j+1 is blade j turned by 2 pi / N about it.
`disk.wheel_params` derives the shroud width of such a wheel, `solid.solid_mesh`
shapes the left face as the right face turned by -2 pi / N, and `disk.pairing`
pairs the faces of neighbours, node to node or interpolated on the left face's facets.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

CONTACT_SETS = ("shroud_left", "shroud_right")
POINT_SETS = ("excitation", "response")
CUT_SETS = ("cyclic_low", "cyclic_high")   # a disk sector's cyclic cut faces
REQUIRED_SETS = ("root",) + CONTACT_SETS + POINT_SETS
# what a real blade is, SI units: outside, a number in another unit
MAX_LENGTH = 5.0           # [m] a blade dimension (the longest steam-turbine blades: ~2 m)
DENSITY_RANGE = (500.0, 25000.0)   # [kg/m^3] blade materials, polymers to tungsten carbide


# ---------------------------------------------------------------------------
# Parameters
# ---------------------------------------------------------------------------

# the curved airfoil's parameters and their bounds (`airfoil`)
SHAPE_BOUNDS = {"twist": (-np.pi / 4, np.pi / 4), "camber": (-0.25, 0.25), "taper": (-0.5, 1.0)}


@dataclass(frozen=True)
class BladeParams:
    """Blade geometry [m], material (E [Pa], nu [-], rho [kg/m^3]), angles [rad].

    kind: "solid" (Hex2 elements, with tip shroud if `shroud`) or "beam"
    (Euler-Bernoulli, with a rigid tip shroud of the same block if `shroud`).  Mesh resolution: elements across the
    chord (`n_chord`), the thickness (`n_thick`) and along the span (`n_span`);
    the shroud overhang uses the chordwise element size.  `damping_ratios`:
    modal damping ratios zeta_k (the last one repeats for higher modes).  A solid
    blade's airfoil may be curved (`airfoil`): `twist` [rad] the root section's
    stagger beyond the shroud's, `camber` the root section's camber height over its
    chord, `taper` the root chord's excess over `chord` (all vanish at the shroud).
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
    twist: float = 0.0
    camber: float = 0.0
    taper: float = 0.0

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
        for name, (lo, hi) in SHAPE_BOUNDS.items():
            v = getattr(self, name)
            if not (np.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"{name} must be in [{lo:.4g}, {hi:.4g}], got {v!r}")
            if v and self.kind == "beam":
                raise ValueError(f"{name} must be 0 on a beam blade, got {v!r} (a beam is "
                                 "straight; a solid blade may be curved)")
        z = np.atleast_1d(np.asarray(self.damping_ratios, dtype=float))
        if z.ndim != 1 or z.size < 1 or np.any(~np.isfinite(z)) or np.any(z < 0):
            raise ValueError(f"damping_ratios must be a non-empty sequence of ratios >= 0, "
                             f"got {self.damping_ratios!r}")
        object.__setattr__(self, "damping_ratios", tuple(float(x) for x in z))
        if self.shroud and self.shroud_width <= self.thickness:
            raise ValueError(f"shroud_width must exceed thickness ({self.thickness}), "
                             f"got {self.shroud_width!r}")
        if self.shroud and self.kind == "solid":
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


@dataclass(frozen=True)
class DiskPlacement:
    """Where a blade sits in a disk of N identical sectors (a wheel).

    The disk axis is the line parallel to X through (Y, Z) = (0, -hub_radius) in the
    blade's frame, so the blade root (Z = 0) sits at radius R = hub_radius [m].
    Blade j+1 is blade j turned by the pitch angle alpha = 2 pi / N [rad] about
    that axis, towards +Y: a point x maps to R(a) (x - c) + c, c = (0, 0, -R), and a
    displacement vector d to R(a) d, with `rotation(a)` turning +Z towards +Y.
    """

    hub_radius: float        # R [m]
    sectors: int             # N [-]

    def __post_init__(self):
        if not (np.isfinite(self.hub_radius) and self.hub_radius > 0):
            raise ValueError(f"hub_radius must be a finite number > 0 [m], got {self.hub_radius!r}")
        if isinstance(self.sectors, bool) or int(self.sectors) != self.sectors or self.sectors < 3:
            raise ValueError(f"sectors must be an integer >= 3, got {self.sectors!r}")
        object.__setattr__(self, "sectors", int(self.sectors))

    @property
    def pitch_angle(self) -> float:
        """alpha = 2 pi / N [rad]."""
        return 2.0 * np.pi / self.sectors

    @property
    def centre(self) -> np.ndarray:
        """c = (0, 0, -R) [m], a point of the disk axis."""
        return np.array([0.0, 0.0, -self.hub_radius])

    @staticmethod
    def rotation(angle: float) -> np.ndarray:
        """R(a) (3, 3): rotation by `angle` [rad] about the X axis turning +Z towards +Y
        (a right-handed rotation by -angle about +X)."""
        c, s = np.cos(angle), np.sin(angle)
        return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])

    def rotate(self, points, angle: float) -> np.ndarray:
        """Points (k, 3) [m] turned by `angle` [rad] about the disk axis."""
        c = self.centre
        return (np.asarray(points, float) - c) @ self.rotation(angle).T + c

    def polar_angle(self, points) -> np.ndarray:
        """Angle [rad] of points (k, 3) about the disk axis, 0 on the blade's radial
        line (Y = 0), positive towards +Y."""
        x = np.atleast_2d(np.asarray(points, float))
        return np.arctan2(x[:, 1], x[:, 2] + self.hub_radius)

    def circumferential(self, point) -> np.ndarray:
        """Unit circumferential direction (towards +Y, increasing polar angle) at a point."""
        x = np.asarray(point, float) - self.centre
        d = np.array([0.0, x[2], -x[1]])
        return d / np.linalg.norm(d)


# ---------------------------------------------------------------------------
# Model data
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class ContactFrame:
    """One planar contact face: unit vectors, its points and how they move.

    normal: outward unit normal n; tangent: t = n_R x e_Z (shared by both faces);
    tangent2: t x n_R (radial, shared).  points (k, 3) [m]; dofs (k, 3) free-DOF indices
    of the X, Y, Z displacement components of each point (-1 when a component is no
    single DOF, see motion).  weights (k,) [m^2]: int_face N_k dA, the face area each
    point carries (its shape function integrated over the face; they sum to the face
    area); None when the face spans no element facet.  motion: sparse (3k, n_dof) [-]
    point motion operator P, the displacements (X, Y, Z of point 0, of point 1, ...) =
    P q; None: the selection of `dofs` (FE nodes).  A rigid body carrying the points
    (the beam blade's shroud) has d_k = u + theta x (x_k - x_0) in P.  facets (m, p):
    the face's element facets as indices of `points` in the local order of
    `structure.facets` (a displacement interpolated anywhere on the face); None: none
    (a rigid shroud's points).
    """

    name: str
    normal: np.ndarray
    tangent: np.ndarray
    tangent2: np.ndarray
    points: np.ndarray
    dofs: np.ndarray
    weights: np.ndarray | None = None
    motion: sp.csr_matrix | None = None
    facets: np.ndarray | None = None

    def point_motion(self, n_dof: int) -> sp.csr_matrix:
        """P sparse (3k, n_dof) [-]: point displacements, point-major, = P q."""
        if self.motion is not None:
            if self.motion.shape != (3 * len(self.points), n_dof):
                raise ValueError(f"face {self.name!r}: motion is {self.motion.shape}, expected "
                                 f"({3 * len(self.points)}, {n_dof})")
            return sp.csr_matrix(self.motion)
        if np.any(self.dofs < 0):
            raise ValueError(f"face {self.name!r}: a face point is clamped")
        k = self.dofs.size
        return sp.csr_matrix((np.ones(k), (np.arange(k), self.dofs.ravel())),
                             shape=(k, n_dof))

    def used_dofs(self, n_dof: int) -> np.ndarray:
        """The free DOFs the points' motion depends on, ascending."""
        return np.unique(self.point_motion(n_dof).tocsc().nonzero()[1])

    def maps(self, n_dof: int):
        """(Bt, Bn, Bt2) sparse (k, n_dof): u = Bt q, v = Bn q, u2 = Bt2 q."""
        P = self.point_motion(n_dof)
        return tuple(project_rows(P, vec) for vec in (self.tangent, self.normal, self.tangent2))


def project_rows(P, vec) -> sp.csr_matrix:
    """Rows vec . d_k of the point displacements d = P q: sparse (k, n_dof) =
    (I_k kron vec^T) P, P (3k, n_dof) point-major, vec (3,)."""
    k = P.shape[0] // 3
    V = sp.kron(sp.identity(k, format="csr"), sp.csr_matrix(np.reshape(vec, (1, 3))),
                format="csr")
    return (V @ P).tocsr()


@dataclass(frozen=True, eq=False)
class BladeModel:
    """A clamped blade as plain data.

    K, M: sparse (n, n) over the free DOFs [N/m], [kg].  points (Np, 3) and cells
    (meshio type, connectivity) describe the output mesh (vertices); point_dofs
    (Np, 3) gives the free DOF of each displacement component (-1: clamped), in the
    frame `point_rotation` (global = point_rotation @ local; identity for solids).
    dof_sets: name -> (k, 3) free DOF indices; set_points: name -> (k, 3) coordinates.
    rotation: the terms of a blade turning about its disk axis (`rotation`), or None.
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
    rotation: object = None   # rotation.RotationTerms (per Omega^2) of a turning blade

    @property
    def n_dof(self) -> int:
        return self.K.shape[0]


def boundary_dofs(model: BladeModel, names=None) -> tuple[np.ndarray, tuple]:
    """Free-DOF indices of the named sets (default: contact faces, excitation,
    response, a disk sector's cut faces -- those present), de-duplicated in order, and their labels
    `"<set>:<point>:<component>"`.  A contact face whose points move with several DOFs
    (a frame with a `motion`, no DOF set) contributes the DOFs that motion uses,
    labelled `"<face>:dof<index>"`."""
    if names is None:
        names = [s for s in CONTACT_SETS + POINT_SETS + CUT_SETS
                 if s in model.dof_sets or s in model.frames]
    dofs, labels, seen = [], [], set()

    def keep(d, label):
        if d >= 0 and d not in seen:
            seen.add(int(d))
            dofs.append(int(d))
            labels.append(label)

    for name in names:
        if name in model.dof_sets:
            for k, row in enumerate(model.dof_sets[name]):
                for c, d in enumerate(row):
                    keep(d, f"{name}:{k}:{'xyz'[c]}")
        elif name in model.frames and model.frames[name].motion is not None:
            for d in model.frames[name].used_dofs(model.n_dof):
                keep(d, f"{name}:dof{d}")
        else:
            raise ValueError(f"names: blade has no DOF set {name!r} "
                             f"(has {sorted(model.dof_sets)})")
    return np.asarray(dofs, dtype=np.int64), tuple(labels)


def rotation_z(angle: float) -> np.ndarray:
    """Rotation by `angle` [rad] about Z (global = R @ local): the stagger turn of the
    section frame (xi, eta, z) into the global axes (X, Y, Z)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def point_displacements(model: BladeModel, u: np.ndarray) -> np.ndarray:
    """Displacements of the output points (Np, 3[, k]) in global axes from free-DOF
    vectors u (n,) or (n, k); clamped components are zero."""
    u = np.asarray(u)
    pad = np.concatenate([u, np.zeros((1,) + u.shape[1:], dtype=u.dtype)])
    d = pad[model.point_dofs]  # -1 picks the zero row
    return np.einsum("ij,pj...->pi...", model.point_rotation, d)
