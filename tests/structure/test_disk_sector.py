"""A blade on its flexible disk sector (`structure.disk_sector`) joined to its
neighbours at the cyclic cut faces (`structure.cyclic_cut`), against references that
know nothing of the cyclic condition: CalculiX's cyclic-symmetry modal analysis of
the same mesh (C3D20), the explicitly assembled wheel of N sectors, and the blade on a
rigid disk as the disk stiffens; and the cut-face reduction converging.  Without ccx
the CalculiX test skips saying why."""
import re
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
from scipy.spatial import cKDTree
from skfem import Basis, ElementHex2, ElementHexS2, MeshHex

from pipeline.structure.cyclic_cut import (cut_maps, cut_pairing, cut_sector, cyclic_parts,
                                           wave_matrix)
from pipeline.structure.disk_sector import DiskSector, sector_blade, sector_mesh
from pipeline.structure.exchange.calculix_deck import set_nodes, write_deck
from pipeline.structure.fe_model import BladeParams, DiskPlacement, boundary_dofs
from pipeline.structure.reduction import reduce
from pipeline.structure.rotation import rotation_terms
from pipeline.structure.solid import assemble_elasticity, solid_blade, solid_mesh
from pipeline.structure.disk import wheel_params

from calculix import ccx, needs_ccx

BLADE = BladeParams(n_chord=2, n_thick=1, n_span=4)
DISK = DiskPlacement(hub_radius=0.12, sectors=36)     # as studies/shrouded_disk*.toml
SECTOR = DiskSector(bore_radius=0.08)                  # m
SMALL = DiskPlacement(hub_radius=0.05, sectors=6)     # a wheel small enough to assemble


def cyclic(blade, disk):
    """(K_0, K_1, M_0, M_1) sparse of the unreduced sector joined at its cut faces."""
    high = cut_pairing(blade.set_points["cyclic_low"], blade.set_points["cyclic_high"], disk)
    A, B, _ = cut_maps(blade.n_dof, blade.dof_sets["cyclic_low"],
                       blade.dof_sets["cyclic_high"][high], disk.rotation(disk.pitch_angle))
    (K0, K1), (M0, M1) = (cyclic_parts(X, A, B) for X in (blade.K, blade.M))
    return K0, K1, M0, M1


def lowest_hz(K, M, k):
    """The k lowest frequencies [Hz] of (K, M), real symmetric or complex Hermitian,
    dense or sparse: shift-invert Lanczos about 0 (accurate for the lowest where K spans
    many orders: a stiff disk), or M x = K x / w^2 dense for a small model."""
    if not sp.issparse(K):
        return 1.0 / np.sqrt(la.eigh(M, K, eigvals_only=True)[::-1][:k]) / (2 * np.pi)
    w2 = sp.linalg.eigsh(sp.csc_matrix(K), k, sp.csc_matrix(M), sigma=0.0,
                         return_eigenvectors=False, v0=np.ones(K.shape[0]), tol=1e-14)
    return np.sqrt(np.sort(w2.real)) / (2 * np.pi)


def per_nodal_diameter(parts, N, k, nds=None):
    """(len(nds), k) the k lowest frequencies [Hz] of nodal diameters `nds` (default
    0..N/2) of a joined sector's (K_0, K_1, M_0, M_1)."""
    K0, K1, M0, M1 = parts
    return np.array([lowest_hz(wave_matrix(K0, K1, 2 * np.pi * nd / N),
                               wave_matrix(M0, M1, 2 * np.pi * nd / N), k)
                     for nd in (range(N // 2 + 1) if nds is None else nds)])


def test_the_sector_mesh_is_the_blade_on_a_disk_whose_cut_faces_map_by_the_pitch():
    """The generated mesh keeps the blade's vertices (its root at the rim), the high cut
    face is the low one turned by 2 pi / N node for node (to 1e-15 m), every hexahedron
    keeps the blade's orientation, and the cut faces span the bore (0.08 m) to the rim
    (0.12 m)."""
    mesh, sets, disk_cells = sector_mesh(BLADE, DISK, SECTOR)
    blade, _ = solid_mesh(wheel_params(BLADE, DISK), DISK)
    np.testing.assert_array_equal(mesh.p[:, :blade.p.shape[1]], blade.p)
    low, high = mesh.p[:, sets["cyclic_low"]].T, mesh.p[:, sets["cyclic_high"]].T
    turned = DISK.rotate(low, DISK.pitch_angle)
    assert cKDTree(high).query(turned)[0].max() < 1e-15
    corners = np.array(np.meshgrid([0.0, 1.0], [0.0, 1.0], [0.0, 1.0])).reshape(3, -1)
    det = mesh.mapping().detDF(corners)
    assert np.all(det * np.sign(det[0, 0]) > 0)
    r = np.hypot(mesh.p[1, sets["root"]], mesh.p[2, sets["root"]] + DISK.hub_radius)
    np.testing.assert_allclose(r, SECTOR.bore_radius, rtol=1e-14)
    r_cut = np.hypot(low[:, 1], low[:, 2] + DISK.hub_radius)
    assert np.isclose(r_cut.min(), SECTOR.bore_radius) and np.isclose(r_cut.max(),
                                                                      DISK.hub_radius)
    assert disk_cells.size == 2 * 3 * SECTOR.n_radial


@needs_ccx
def test_the_cyclic_sector_equals_calculix_cyclic_symmetry(tmp_path):
    """The same mesh of C3D20 elements (ElementHexS2 here): CalculiX's
    `*CYCLIC SYMMETRY MODEL` (a `*TIE` of the cut faces, the bore clamped) and the
    package's joined sector agree on the first 3 frequencies of every nodal diameter
    0..18 to 1e-6 (measured 4.0e-7: ccx prints 7 digits)."""
    mesh, sets, _ = sector_mesh(BLADE, DISK, SECTOR)
    path = write_deck(mesh, sets, wheel_params(BLADE, DISK), tmp_path / "sector.inp")
    basis = Basis(mesh, ElementHexS2())
    bore = set_nodes(mesh, basis, sets["root"])
    lines = []
    for name, nset in (("cyclic_low", "LOWFREE"), ("cyclic_high", "HIGHFREE")):
        nodes = np.setdiff1d(set_nodes(mesh, basis, sets[name]), bore) + 1
        lines += [f"*NSET, NSET={nset}"] + [", ".join(map(str, nodes[i:i + 8]))
                                           for i in range(0, nodes.size, 8)]
    R = DISK.hub_radius
    lines += ["*SURFACE, NAME=SLOW, TYPE=NODE", "LOWFREE", "*SURFACE, NAME=SHIGH, TYPE=NODE",
              "HIGHFREE", "*TIE, NAME=CYC, CYCLIC SYMMETRY", "SHIGH, SLOW",
              f"*CYCLIC SYMMETRY MODEL, N={DISK.sectors}, NGRAPH=1, TIE=CYC",
              f"0., 0., {-R!r}, 1., 0., {-R!r}", "*STEP", "*FREQUENCY", "6",
              f"*SELECT CYCLIC SYMMETRY MODES, NMIN=0, NMAX={DISK.sectors // 2}", "*END STEP"]
    text = path.read_text()
    path.write_text(text[:text.index("*STEP")] + "\n".join(lines) + "\n")
    dat = ccx(tmp_path, "sector")
    theirs = {}
    for nd, _, _, _, hz, _ in re.findall(r"^\s+(\d+)\s+(\d+)\s+(\S+E\S+)\s+(\S+E\S+)\s+(\S+E\S+)"
                                         r"\s+(\S+E\S+)\s*$", dat, re.M):
        theirs.setdefault(int(nd), []).append(float(hz))
    ours = per_nodal_diameter(cyclic(sector_blade(BLADE, DISK, SECTOR, ElementHexS2()), DISK),
                              DISK.sectors, 3)
    # ccx solves each nodal diameter's cosine and sine parts together: each twice
    ref = np.array([theirs[nd][::2][:3] for nd in range(DISK.sectors // 2 + 1)])
    assert np.abs(ours / ref - 1).max() < 1e-6


def wheel_matrices(mesh, sets, N, placement, speed=0.0):
    """(K, M) sparse of the N sectors of `mesh` turned about the disk axis and merged
    at coincident nodes (the cut faces of neighbours, and of sector N-1 and 0), the
    bore clamped: the wheel assembled without any cyclic condition; turning at `speed`
    [rad/s] (its prestress from its own static deflection)."""
    n = mesh.p.shape[1]
    pts = np.hstack([placement.rotate(mesh.p.T, j * placement.pitch_angle).T for j in range(N)])
    cells = np.hstack([mesh.t + j * n for j in range(N)])
    cut = np.concatenate([np.concatenate([sets["cyclic_low"], sets["cyclic_high"]]) + j * n
                          for j in range(N)])    # the shroud faces stay apart: no contact
    rep = np.arange(pts.shape[1])
    for a, b in sorted(cKDTree(pts[:, cut].T).query_pairs(1e-9)):
        a, b = cut[a], cut[b]
        rep[max(a, b)] = min(rep[a], rep[b])
    uniq, inverse = np.unique(rep, return_inverse=True)
    wheel = MeshHex(pts[:, uniq], inverse[cells])
    basis = Basis(wheel, ElementHex2(), intorder=4)
    K, M = assemble_elasticity(basis, BLADE.E, BLADE.nu, BLADE.rho)
    bore = np.unique(inverse[np.concatenate([sets["root"] + j * n for j in range(N)])])
    fixed = basis.get_dofs(facets=np.nonzero(np.isin(wheel.facets, bore).all(axis=0))[0]).all()
    free = np.setdiff1d(np.arange(3 * basis.N), (3 * fixed[:, None] + np.arange(3)).ravel())
    if speed:     # turning at `speed` [rad/s]: the wheel's own static deflection
        turning = rotation_terms(basis, free, K[free][:, free], BLADE.E, BLADE.nu, BLADE.rho,
                                 placement.centre)
        return (K[free][:, free] + turning.speed_stiffness(speed)).tocsr(), M[free][:, free]
    return K[free][:, free], M[free][:, free]


def test_the_cyclic_sector_equals_the_assembled_wheel():
    """6 sectors at R = 0.05 m: the joined sector's frequencies of nodal diameters 0..3
    (0 < ND < 3 twice) are the 24 lowest of the wheel assembled node by node (no
    cyclic condition), to 1e-8 (measured 1.6e-9)."""
    sector = DiskSector(bore_radius=0.03)
    mesh, sets, _ = sector_mesh(BLADE, SMALL, sector)
    K, M = wheel_matrices(mesh, sets, SMALL.sectors, SMALL)
    w2 = sp.linalg.eigsh(K.tocsc(), 24, M.tocsc(), sigma=0.0, return_eigenvectors=False,
                         v0=np.ones(K.shape[0]))
    wheel = np.sort(np.sqrt(w2)) / (2 * np.pi)
    f = per_nodal_diameter(cyclic(sector_blade(BLADE, SMALL, sector), SMALL), 6, 12)
    union = np.sort(np.concatenate([f[nd] for nd in range(4) for _ in range(1 + (0 < nd < 3))]))
    np.testing.assert_allclose(union[:24], wheel, rtol=1e-8)


def test_a_turning_sector_equals_the_turning_wheel():
    """At 6,000 rpm (prestress, spin softening, initial displacement): the joined
    sector's frequencies of nodal diameters 0..3, its static deflection solved with the
    cut faces joined, are the 24 lowest of the 6-sector wheel turning (its deflection its
    own), to 1e-8; a loose sector's deflection (cut faces free) would be off by more than
    1e-6 (measured 1.3e-5)."""
    sector, speed = DiskSector(bore_radius=0.03), 6000 * np.pi / 30
    mesh, sets, _ = sector_mesh(BLADE, SMALL, sector)
    K, M = wheel_matrices(mesh, sets, SMALL.sectors, SMALL, speed)
    w2 = sp.linalg.eigsh(K.tocsc(), 24, M.tocsc(), sigma=0.0, return_eigenvectors=False,
                         v0=np.ones(K.shape[0]))
    wheel = np.sort(np.sqrt(w2)) / (2 * np.pi)
    b = sector_blade(BLADE, SMALL, sector, rotation_centre=SMALL.centre)

    def union(blade, Kb):
        f = per_nodal_diameter(cyclic(replace(blade, K=Kb), SMALL), 6, 12)
        return np.sort(np.concatenate([f[nd] for nd in range(4) for _ in range(1 + (0 < nd < 3))]))

    np.testing.assert_allclose(union(b, b.K + b.rotation.speed_stiffness(speed))[:24], wheel,
                               rtol=1e-8)
    loose = rotation_terms(Basis(mesh, ElementHex2(), intorder=4), free_dofs(mesh, sets), b.K,
                           BLADE.E, BLADE.nu, BLADE.rho, SMALL.centre)
    off = union(b, b.K + loose.speed_stiffness(speed))[:24] / wheel - 1
    assert np.abs(off).max() > 1e-6


def free_dofs(mesh, sets):
    """The free vector DOFs (3 s + c) of the sector mesh with its bore clamped."""
    basis = Basis(mesh, ElementHex2(), intorder=4)
    fixed = basis.get_dofs(facets=np.nonzero(np.isin(mesh.facets, sets["root"]).all(axis=0))[0])
    s = fixed.all()
    return np.setdiff1d(np.arange(3 * basis.N), (3 * s[:, None] + np.arange(3)).ravel())


def test_a_stiffening_disk_tends_to_the_rigid_disk_linearly():
    """The disk's Young's modulus times s: the first 4 frequencies of nodal diameters
    0, 9 and 18 tend to the blade on a rigid disk (root clamped) as 1/s -- the error
    times s is the same within 2 % for s = 1e3 and 1e5 -- and at s = 1e4 they are
    within 3e-6 (first 3) and 2.4e-5 (the 4th; measured 2.7e-6, 2.3e-5), at s = 1e6
    within 3e-7."""
    rigid = solid_blade(BLADE, DISK)
    ref = lowest_hz(rigid.K, rigid.M, 4)
    err = {}
    for s in (1e3, 1e4, 1e5, 1e6):
        b = sector_blade(BLADE, DISK, DiskSector(SECTOR.bore_radius, E=s * BLADE.E))
        err[s] = np.abs(per_nodal_diameter(cyclic(b, DISK), 36, 4, (0, 9, 18)) / ref - 1).max(0)
    np.testing.assert_allclose(err[1e3] * 1e3, err[1e5] * 1e5, rtol=0.02)
    assert np.all(err[1e4][:3] < 3e-6) and err[1e4][3] < 2.4e-5
    assert np.all(err[1e6] < 3e-7)


def test_the_cut_face_modes_converge_to_the_joined_sector():
    """Craig-Bampton (40 modes) keeping the cut faces, then the cut face's 60 DOFs on
    c modes per phase (`interface_basis`): the first 6 frequencies of nodal diameters
    0, 1, 9 and 18 against the reduced sector with all its cut-face DOFs converge as c
    grows (measured 3.5e-4, 3.6e-5, 3.0e-7 at c = 3, 6, 12: 12, 24, 48 modes; with all
    60 the same model to 1e-12), and the reduced sector is within 4e-5 of the unreduced
    one (measured 3.7e-5: 40 fixed-interface modes)."""
    blade = sector_blade(BLADE, DISK, SECTOR)
    full = per_nodal_diameter(cyclic(blade, DISK), 36, 6, (0, 1, 9, 18))
    b, labels = boundary_dofs(blade)
    red = reduce(blade.K, blade.M, b, 40)
    pos = -np.ones(blade.n_dof, dtype=np.int64)
    pos[b] = np.arange(b.size)
    low, high = pos[blade.dof_sets["cyclic_low"]], pos[blade.dof_sets["cyclic_high"]]
    pair = cut_pairing(blade.set_points["cyclic_low"], blade.set_points["cyclic_high"], DISK)
    names = tuple(f"q{i}" for i in range(red.K.shape[0]))

    def error(count, ref):
        cut = cut_sector(red.K, red.M, red.C, low, high[pair], b.size,
                         DISK.rotation(DISK.pitch_angle), names, count)
        f = per_nodal_diameter((cut.K0, cut.K1, cut.M0, cut.M1), 36, 6, (0, 1, 9, 18))
        return f, np.abs(f / ref - 1).max()

    whole, e_cb = error(None, full)
    errors = [error(c, whole)[1] for c in (3, 6, 12)]
    assert e_cb < 4e-5
    assert errors[0] > errors[1] > errors[2] and errors[2] < 1e-6
    assert error(low.size, whole)[1] < 1e-12
