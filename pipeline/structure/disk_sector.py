"""A blade on its flexible disk sector: the generated wheel blade and an annular disk
sector under it, one conforming hexahedral mesh with two cyclic cut faces.

The disk sector spans the pitch alpha = 2 pi / N about the disk axis (parallel to X
through c = (0, 0, -R), R the hub radius) from the bore radius r_b to the rim R.  It
is meshed in the blade's flat frame (X, Y, Z) and wrapped onto the annulus: a flat point
(X, Y, Z), -(R - r_b) <= Z <= 0, goes to

    W(X, Y, Z) = (X, (R + Z) sin(Y / R), (R + Z) cos(Y / R) - R)      (polar angle Y / R),

so a flat shift of Y by R alpha is the sector rotation.  Across the pitch, chord line i
of the airfoil root (its nodes E_L,i at eta = -t/2 and E_R,i at eta = +t/2) carries
`n_overhang` elements from the low cut point P_low,i = E_L,i - (0, delta, 0) to E_L,i,
the airfoil's root nodes, and `n_overhang` from E_R,i to P_high,i = P_low,i + (0, R alpha, 0),
delta = (R alpha - t cos gamma) / 2 (gamma the stagger); radially `n_radial` layers.  The
rim under the airfoil must be the blade's flat root: a node with the overhang fraction s
(0 at the airfoil, 1 at a cut) on the level Z_m is placed at

    x = W(X, Y, Z_m) + (1 - s)(1 - Z_m / Z_bore) [(X, Y, 0) - W(X, Y, 0)],

the blade's root nodes exactly at the rim (s = 0, Z = 0), and both cut faces exactly
wrapped (s = 1): the high cut is the low cut turned by alpha, node for node
(`cut_pairing`).  The disk's axial extent is the airfoil root's chord.

Node sets: `root` is the clamped set (the bore), `cyclic_low` / `cyclic_high` the cut
faces; the blade's shroud faces, excitation and response points are the blade's.  The
disk part may have its own material (`DiskSector.E`, `nu`, `rho`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skfem import Basis, ElementHex2, MeshHex

from .disk import wheel_params
from .fe_model import CUT_SETS, BladeParams, DiskPlacement, rotation_z
from .solid import assemble_elasticity, solid_from_mesh, solid_mesh


@dataclass(frozen=True)
class DiskSector:
    """The disk sector under a wheel blade: bore radius [m] (below the hub radius),
    element layers from bore to rim (`n_radial`), elements from the airfoil to each cut
    face (`n_overhang`), and its material (E [Pa], nu [-], rho [kg/m^3]; None: the
    blade's)."""

    bore_radius: float
    n_radial: int = 2
    n_overhang: int = 1
    E: float | None = None
    nu: float | None = None
    rho: float | None = None

    def __post_init__(self):
        if not (np.isfinite(self.bore_radius) and self.bore_radius > 0):
            raise ValueError(f"bore_radius must be a finite number > 0 [m], got "
                             f"{self.bore_radius!r}")
        for name in ("n_radial", "n_overhang"):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {v!r}")
        for name in ("E", "rho"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        if self.nu is not None and not -1.0 < self.nu < 0.5:
            raise ValueError(f"nu must be in (-1, 0.5), got {self.nu!r}")

    def material(self, p: BladeParams) -> tuple:
        """(E [Pa], nu, rho [kg/m^3]) of the disk: its own, else the blade's."""
        return tuple(p_ if d is None else d for d, p_ in
                     ((self.E, p.E), (self.nu, p.nu), (self.rho, p.rho)))


def wrap(X, Y, Z, R: float) -> np.ndarray:
    """W(X, Y, Z) (3, ...) [m]: the flat point wrapped onto the annulus (module doc)."""
    a, r = np.asarray(Y) / R, R + np.asarray(Z)
    return np.array([np.asarray(X, float) + 0 * a, r * np.sin(a), r * np.cos(a) - R])


def root_grid(mesh, root, gamma: float) -> np.ndarray:
    """(n_chord + 1, n_thick + 1) vertex indices of the blade's root nodes, chord index
    first (xi ascending), eta ascending, from their section-frame coordinates."""
    xi, eta, _ = rotation_z(-gamma) @ mesh.p[:, root]
    size = max(np.ptp(xi), np.ptp(eta))
    a, b = np.round(xi / size, 9), np.round(eta / size, 9)
    ux, ue = np.unique(a), np.unique(b)
    grid = -np.ones((ux.size, ue.size), dtype=np.int64)
    grid[np.searchsorted(ux, a), np.searchsorted(ue, b)] = root
    if np.any(grid < 0):
        raise ValueError("disk sector: the blade root is not a structured grid")
    return grid


def sector_mesh(p: BladeParams, disk: DiskPlacement, sector: DiskSector):
    """(MeshHex, node sets, disk cell indices) of the wheel blade (`solid.solid_mesh`)
    on its disk sector (module doc).  ValueError naming disk_sector.bore_radius when the
    bore is not inside the hub."""
    R, rb = disk.hub_radius, sector.bore_radius
    if rb >= R:
        raise ValueError(f"disk_sector.bore_radius: {rb!r} m is not below the hub radius "
                         f"{R!r} m")
    if p.twist or p.camber or p.taper:
        raise ValueError("disk sector: meshed under the straight blade's root; a curved "
                         "blade (twist, camber, taper) stands on the rigid disk only")
    p = wheel_params(p, disk)
    blade, sets = solid_mesh(p, disk)
    grid = root_grid(blade, sets["root"], p.stagger_angle)
    nc, nt = grid.shape[0] - 1, grid.shape[1] - 1
    no, nr = sector.n_overhang, sector.n_radial
    nk = nt + 2 * no
    delta = (R * disk.pitch_angle - p.thickness * np.cos(p.stagger_angle)) / 2
    E_L, E_R = blade.p[:, grid[:, 0]], blade.p[:, grid[:, -1]]          # (3, nc + 1)
    P_low = E_L - np.array([[0.0], [delta], [0.0]])
    P_high = P_low + np.array([[0.0], [R * disk.pitch_angle], [0.0]])
    flat = np.empty((3, nc + 1, nk + 1))
    s = np.zeros(nk + 1)
    for k in range(nk + 1):
        if k <= no:
            s[k] = (no - k) / no
            flat[:, :, k] = (1 - s[k]) * E_L + s[k] * P_low
        elif k >= no + nt:
            s[k] = (k - no - nt) / no
            flat[:, :, k] = (1 - s[k]) * E_R + s[k] * P_high
        else:
            flat[:, :, k] = blade.p[:, grid[:, k - no]]
    Zb = -(R - rb)
    idx = -np.ones((nc + 1, nk + 1, nr + 1), dtype=np.int64)
    idx[:, no:no + nt + 1, nr] = grid
    new = idx < 0
    idx[new] = blade.p.shape[1] + np.arange(new.sum())
    X = np.empty((3, nc + 1, nk + 1, nr + 1))
    corr = flat - wrap(flat[0], flat[1], 0.0, R)        # (X, Y, 0) - W(X, Y, 0)
    for m in range(nr + 1):
        Z = Zb * (1 - m / nr)
        X[..., m] = wrap(flat[0], flat[1], Z, R) + (1 - s) * (1 - Z / Zb) * corr
    box = MeshHex.init_tensor(np.arange(nc + 1.0), np.arange(nk + 1.0), np.arange(nr + 1.0))
    ijk = np.round(box.p).astype(np.int64)
    t = idx[ijk[0], ijk[1], ijk[2]][box.t]
    points = np.hstack([blade.p, X[:, new]])
    cells = np.hstack([blade.t, t])
    mesh = MeshHex(points, cells)
    sets = {k: v for k, v in sets.items() if k != "root"}
    sets["root"] = np.unique(idx[:, :, 0])
    sets["cyclic_low"] = np.unique(idx[:, 0, :])
    sets["cyclic_high"] = np.unique(idx[:, -1, :])
    corners = np.array(np.meshgrid([0.0, 1.0], [0.0, 1.0], [0.0, 1.0])).reshape(3, -1)
    det = mesh.mapping().detDF(corners)
    if np.any(det * np.sign(det[0, 0]) <= 0):
        raise ValueError("disk_sector: a hexahedron of the disk sector is turned inside out; "
                         "use more n_overhang or n_radial elements")
    return mesh, sets, np.arange(blade.t.shape[1], cells.shape[1])


def sector_matrices(disk_sector: DiskSector, p: BladeParams, disk_cells):
    """`solid_from_mesh`'s `matrices(basis, free)`: (K, M) of the blade's cells with the
    blade's material and of the disk cells with the disk sector's."""
    def matrices(sbasis, free):
        mesh = sbasis.mesh
        is_disk = np.zeros(mesh.t.shape[1], dtype=bool)
        is_disk[disk_cells] = True
        K = M = 0
        for cells, (E, nu, rho) in ((~is_disk, (p.E, p.nu, p.rho)),
                                     (is_disk, disk_sector.material(p))):
            part = Basis(mesh, sbasis.elem, intorder=4, elements=np.nonzero(cells)[0])
            Kp, Mp = assemble_elasticity(part, E, nu, rho)
            K, M = K + Kp, M + Mp
        return K.tocsr(), M.tocsr()
    return matrices


def sector_blade(p: BladeParams, disk: DiskPlacement, disk_sector: DiskSector,
                 element=None, rotation_centre=None):
    """The `fe_model.BladeModel` of the wheel blade on its disk sector (`sector_mesh`):
    the bore clamped; the cut faces `cyclic_low`, `cyclic_high` as DOF sets of their
    free points (the bore's edge, clamped on both faces, left out: `solid_from_mesh`).
    `element`: the scalar scikit-fem element (default ElementHex2; ElementHexS2 is
    CalculiX's C3D20).  Turning about the axis through `rotation_centre`: its rotation
    terms with the cut faces joined (`solid.joined_cut`); ValueError naming the disk
    sector's material when it is not the blade's (the prestress is of one material)."""
    if rotation_centre is not None and disk_sector.material(p) != (p.E, p.nu, p.rho):
        raise ValueError("disk_sector.E: a disk sector of its own material does not turn yet "
                         "(the centrifugal prestress is computed for one material)")
    mesh, sets, disk_cells = sector_mesh(p, disk, disk_sector)
    return solid_from_mesh(mesh, sets, wheel_params(p, disk), "<generated disk sector>",
                           element or ElementHex2(),
                           matrices=sector_matrices(disk_sector, p, disk_cells),
                           rotation_centre=rotation_centre, disk=disk)
