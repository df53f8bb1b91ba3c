"""The generated curved blade (`structure.airfoil`: twist, camber, taper of the solid
blade's airfoil, every node of its 27-node hexahedra mapped) against its geometry:
the root section's chord line turned by the twist and stretched by the taper, its
camber line bulged by the camber; the shroud and its faces' pairing across the pitch
untouched (the shipped full-size study's 51 pairs per face); chordwise edges curved (their midside nodes off their corners' chord); the
volume of the airfoil c t L (1 + taper / 2) (twist and camber move its sections
without changing their area), integrated over the curved cells."""
import tomllib

import numpy as np
import pytest
from skfem import Basis, ElementHex2, MeshHex, MeshHex2

from pipeline.structure import airfoil
from pipeline.structure.airfoil import curved_mesh
from pipeline.structure.disk import wheel_params
from pipeline.structure.fe_model import BladeParams, DiskPlacement
from pipeline.structure.solid import solid_blade, solid_mesh

from helpers import STUDIES

DISK = DiskPlacement(hub_radius=0.12, sectors=36)
SHAPE = dict(twist=0.25, camber=0.06, taper=0.4)


def meshes(n_chord=8, n_span=12):
    p = wheel_params(BladeParams(n_chord=n_chord, n_thick=2, n_span=n_span), DISK)
    q = BladeParams(**{**p.__dict__, **SHAPE})
    straight = MeshHex2.from_mesh(solid_mesh(p, DISK)[0])
    curved = curved_mesh(solid_mesh(q, DISK)[0], solid_mesh(q)[0], q)
    return p, straight, curved


def section_frame(p, X):
    g = p.stagger_angle
    return (np.array([np.cos(g), np.sin(g)]) @ X[:2], np.array([-np.sin(g), np.cos(g)]) @ X[:2])


def test_root_section_is_turned_stretched_and_cambered():
    """The root's leading and trailing points on the mid-thickness line: their chord
    is c (1 + taper) long and at the stagger plus the twist; the mid-chord point lies
    camber x c (1 + taper) off that chord (1e-12 m)."""
    p, straight, curved = meshes()
    X0, X = straight.doflocs, curved.doflocs
    xi, eta = section_frame(p, X0)
    root = np.abs(X0[2]) < 1e-12
    mid = root & (np.abs(eta) < 1e-12)
    lead, trail = (np.nonzero(mid & np.isclose(xi, s * p.chord / 2))[0][0] for s in (1, -1))
    centre = np.nonzero(mid & (np.abs(xi) < 1e-12))[0][0]
    chord = X[:2, lead] - X[:2, trail]
    c_root = p.chord * (1 + SHAPE["taper"])
    assert np.linalg.norm(chord) == pytest.approx(c_root, abs=1e-12)
    assert np.arctan2(chord[1], chord[0]) == pytest.approx(p.stagger_angle + SHAPE["twist"],
                                                           abs=1e-12)
    e = chord / np.linalg.norm(chord)
    off = X[:2, centre] - 0.5 * (X[:2, lead] + X[:2, trail])
    assert e[0] * off[1] - e[1] * off[0] == pytest.approx(SHAPE["camber"] * c_root, abs=1e-12)


def test_shroud_and_its_pairing_are_the_straight_blades():
    """Nodes at or above the shroud's root do not move (exactly); the wheel blade built
    on it pairs its faces node for node (the pairing refuses faces off by a pitch)."""
    p, straight, curved = meshes()
    top = straight.doflocs[2] >= p.length * (1 - 1e-12)
    np.testing.assert_array_equal(curved.doflocs[:, top], straight.doflocs[:, top])
    below = ~top & (straight.doflocs[2] > 1e-9)
    assert np.abs(curved.doflocs[:, below] - straight.doflocs[:, below]).max() > 1e-4
    blade = tomllib.loads((STUDIES / "full_size_blade.toml").read_text())["scene"]["blade"]
    assert blade == dict(n_chord=8, n_thick=2, n_span=12, **SHAPE)   # the shipped study's
    b = solid_blade(BladeParams(**blade), DISK)
    assert len(b.dof_sets["shroud_left"]) == len(b.dof_sets["shroud_right"]) == 51


def test_edges_curve_with_the_airfoil():
    """The curved cells against the same corners with straight edges: the root's
    midside nodes sit off their corners' chord by the camber's curvature, about
    camber x c (h / c)^2 / 2 for the root's cells of chord h; the shroud's not at all:
    the cells are curved, not their corners only moved."""
    p, _, curved = meshes()
    flat = MeshHex2.from_mesh(MeshHex(curved.p, curved.t))
    gap = np.linalg.norm(curved.doflocs - flat.doflocs, axis=0)
    root = np.abs(curved.doflocs[2]) < 1e-12
    c = p.chord * (1 + SHAPE["taper"])
    h = c / p.n_chord
    assert gap[root].max() > 0.3 * SHAPE["camber"] * c * (h / c) ** 2
    assert gap[curved.doflocs[2] >= p.length].max() == 0.0


@pytest.mark.parametrize("n", [(4, 6), (8, 12)])
def test_airfoil_volume_is_the_tapered_one(n):
    """Volume over the curved cells = the straight blade's + c t L taper / 2 (1e-5
    relative on 4 x 6 cells, 1e-6 on 8 x 12: the quadratic cells' geometry error)."""
    p, straight, curved = meshes(*n)
    vol = [Basis(m, ElementHex2(), intorder=6).dx.sum() for m in (straight, curved)]
    extra = p.chord * p.thickness * p.length * SHAPE["taper"] / 2
    tol = 1e-5 if n[0] == 4 else 1e-6
    assert vol[1] == pytest.approx(vol[0] + extra, rel=tol)


def test_a_cell_turned_inside_out_is_refused(monkeypatch):
    """No twist, camber and taper within their bounds turned a cell inside out (tried
    at the bounds on 1 x 1 to 8 x 2 cells of a 10 mm span, 50 mm chord); the guard
    itself: a map that mirrors the blade is refused."""
    monkeypatch.setattr(airfoil, "airfoil_map", lambda X, z, p: X * np.array([[-1], [1], [1]]))
    with pytest.raises(ValueError, match="inside out"):
        solid_blade(BladeParams(n_chord=2, n_thick=1, n_span=2, twist=0.1))


def test_a_beam_blade_is_straight():
    with pytest.raises(ValueError, match="twist must be 0 on a beam blade"):
        BladeParams(kind="beam", twist=0.1)
