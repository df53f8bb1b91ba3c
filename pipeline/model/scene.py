"""One scene: structure x reduction x contacts x loads x assembly.

A `Scene` is plain frozen data that composes independent parts; `build_system`
turns it, with one parameter case applied, into the `System` of paper Eq. 4-6
that every solver takes:

    structure   `Lumped` (M, C, K over named DOFs) | `Blade` (a scikit-fem FE blade,
                generated or read through meshio, `pipeline.structure.blades`)
    reduction   None | `CraigBampton` (fixed-interface modes; keeps contact faces,
                excitation and response DOFs, `pipeline.structure.reduction`)
    contacts    `DofContact` (a row over named DOFs; in a cyclic assembly also over
                the next sector's, `next.<dof>`) | `FaceContact` (every node of an FE
                face against a rigid wall, in the face's frame) | `ShroudPair` (every
                node pair of the right shroud face and the next blade's left face, for
                a `Blade` placed in a disk); friction = "2d" faces and pairs slide in
                their plane (`contacts.blade_contact_sets`: `System.laws`)
    loads       `Forcing` (complex amplitudes F_h over the structure's DOFs) |
                `PointLoad` (at an FE node set)
    assembly    `Single` | `Cyclic` (N sectors, engine-order travelling wave solved
                on one sector, Petrov 2004; with `Mistuning`, the full N-sector
                assembly, `pipeline.model.cyclic`; `Spring`s between neighbouring
                sectors for a flexible disk)

So an FE blade in a cyclic disk is `Scene(Blade(..., disk=DiskPlacement(R, N)),
(ShroudPair(...),), loads, Cyclic(N, EO), CraigBampton(m))`: no other code path.
A case is a dict of overrides (`CASE_KEYS`): `preload` sets n0 of every contact (`mu`,
`ku`, `kv`, `interference` [m]: every shroud pair's), `excitation_scale` scales every load,
`eo` the engine order and `mistuning_seed` the mistuning draw of a cyclic assembly.

FE models and reductions are cached on the frozen specs (`blade_model`,
`reduced_model`, `functools.lru_cache`): scenes sharing a structure share its model.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from ..contact.laws import ContactElements
from . import cyclic
from ..contact.laws import LawElements
from .contacts import (DofContact, FaceContact, ShroudPair, blade_contact_sets, contact_elements,
                       fe_contact_maps)
from .loads import Forcing, point_forcing
from .system import System

CASE_KEYS = ("preload", "mu", "ku", "kv", "interference", "excitation_scale", "eo",
             "mistuning_seed", "speed")
CYCLIC_CASE_KEYS = ("eo", "mistuning_seed", "speed")
RPM = 2.0 * np.pi / 60.0   # rad/s per rpm
NEXT = "next."          # a DOF of the next sector in a cyclic contact row
AT = "@"                # "<dof>@<sector>": a DOF of one sector of a mistuned assembly
POINT_SETS = ("excitation", "response")   # FE node sets named by direction in DOF names
COMPONENTS = "xyz"


# ---------------------------------------------------------------------------
# Parts
# ---------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Lumped:
    """A lumped linear structure: M, C, K over named DOFs (SI units)."""

    M: np.ndarray            # (n, n) [kg]
    C: np.ndarray            # (n, n) [N s/m]
    K: np.ndarray            # (n, n) [N/m]
    dofs: tuple              # n DOF names


@dataclass(frozen=True)
class Blade:
    """A clamped FE blade (`fe_model.BladeParams`), generated or read from `mesh`
    (meshio; node sets root, shroud_left, shroud_right, excitation, response).
    Damping: Rayleigh (alpha [1/s], beta [s]) or, when None, the params' modal ratios.
    disk: where the blade sits in a wheel (`fe_model.DiskPlacement`; a generated
    blade is then shaped for it, `solid.solid_mesh`, `beam.shroud_face_geometry`),
    needed by `ShroudPair`s.  matrices: K and M exported by another FE code for
    `mesh` (`structure.exchange.imported.MatrixFiles`) instead of the package's own.
    rotating: the blade turns about the disk axis at `speed` [rpm] (or a case's)
    (`structure.rotation`: its own assembly's prestress, or exported matrices' fit).
    mesh_scale: metres per unit of the mesh file's coordinates (1e-3: millimetres)."""

    params: object           # fe_model.BladeParams
    mesh: str | None = None
    rayleigh: tuple | None = None
    disk: object = None      # fe_model.DiskPlacement | None
    matrices: object = None  # imported.MatrixFiles | None
    rotating: bool = False   # turns about the disk axis (`structure.rotation`)
    speed: float = 0.0       # [rpm] unless a case sets `speed`
    mesh_scale: float = 1.0  # [m] per mesh-file length unit


@dataclass(frozen=True)
class CraigBampton:
    """Craig-Bampton reduction with `modes` fixed-interface modes."""

    modes: int


@dataclass(frozen=True)
class Single:
    """One structure, no symmetry."""


@dataclass(frozen=True)
class Mistuning:
    """Sector stiffness K_j = f_j K: random, f_j = 1 + delta_j with
    delta_j ~ N(0, stiffness_std^2) drawn from `seed`, or the N factors given."""

    stiffness_std: float = 0.0   # relative standard deviation [-], 0 <= std < 0.5
    seed: int | None = None      # None: the case's `mistuning_seed` sets it
    factors: tuple | None = None  # f_0 ... f_{N-1} > 0 given: no draw


@dataclass(frozen=True, eq=False)
class Spring:
    """A linear spring between neighbouring sectors (disk flexibility): it stretches
    by d = row . (q_j, q_{j+1}) (row over the scene's contact DOFs, this sector's then
    the next one's, `next.<dof>`) with the stiffness k [N/m]."""

    name: str
    row: np.ndarray          # (2n,) [-]
    k: float                 # [N/m]


@dataclass(frozen=True)
class Cyclic:
    """N identical sectors excited by engine order EO (None: the case's `eo`);
    with `mistuning`, every sector's stiffness scaled and the full assembly solved;
    `springs` couple neighbouring sectors linearly (a flexible disk)."""

    sectors: int
    engine_order: int | None = None
    mistuning: Mistuning | None = None
    springs: tuple = ()


@dataclass(frozen=True, eq=False)
class Scene:
    """Structure x reduction x contacts x loads x assembly, and the physical effects
    the study declares (`model` is the study file's name for this combination)."""

    structure: Lumped | Blade
    contacts: tuple = ()
    loads: tuple = ()
    assembly: Single | Cyclic = Single()
    reduction: CraigBampton | None = None
    effects: tuple = ()
    model: str = ""
    laws: tuple = ()         # `contact.laws.LawElements` of further laws over `dofs`

    def __post_init__(self):
        if self.laws and (self.cyclic or not isinstance(self.structure, Lumped)):
            raise ValueError("contact laws other than Yang-Menq act on a single lumped "
                             "structure (not on a cyclic assembly or an FE blade)")
        disk = getattr(self.structure, "disk", None)
        if disk is not None and self.cyclic and self.assembly.sectors != disk.sectors:
            raise ValueError(f"assembly.sectors ({self.assembly.sectors}) must equal the blade's "
                             f"disk.sectors ({disk.sectors})")

    # -- DOF names -----------------------------------------------------------
    @property
    def sector_dofs(self) -> tuple:
        """Names of one structure's (one sector's) system DOFs."""
        if isinstance(self.structure, Lumped):
            return tuple(self.structure.dofs)
        if self.reduction is None:
            return ()
        return reduced_dof_names(reduced_model(self.structure, self.reduction)[0])

    @property
    def dofs(self) -> tuple:
        """Names of a case's `System` DOFs: the structure's (single or tuned cyclic),
        or every sector's as `<dof>@<sector>`, sector-major (mistuned)."""
        if self.mistuning is None:
            return self.sector_dofs
        return tuple(f"{d}{AT}{j}" for j in range(self.assembly.sectors) for d in self.sector_dofs)

    @property
    def contact_dofs(self) -> tuple:
        """Names the rows of `DofContact`s refer to: the system's DOFs, then (cyclic)
        the next sector's as `next.<dof>`."""
        own = self.sector_dofs
        return own + tuple(NEXT + d for d in own) if self.cyclic else own

    @property
    def cyclic(self) -> bool:
        return isinstance(self.assembly, Cyclic)

    @property
    def mistuning(self) -> Mistuning | None:
        return self.assembly.mistuning if self.cyclic else None

    @property
    def coupled(self) -> bool:
        """True if an element reaches the next sector (effect "cyclic_coupling"); the
        structure's DOFs are counted (an FE blade reduced) only for `DofContact` rows."""
        if not self.cyclic or any(isinstance(c, ShroudPair) for c in self.contacts):
            return self.cyclic
        rows = [c for c in self.contacts if isinstance(c, DofContact)]
        n = len(self.sector_dofs) if rows else 0
        return any(np.any(c.bt[n:]) or np.any(c.bn[n:]) for c in rows)

    def dof_index(self, name: str) -> int:
        """Row of DOF `name` in a case's `System` ("x1@3" = 3 n + i when mistuned)."""
        if self.mistuning is None:
            return self.sector_dofs.index(name)
        d, j = self.split_dof(name)
        return j * len(self.sector_dofs) + self.sector_dofs.index(d)

    def split_dof(self, name: str) -> tuple:
        """("x1", 3) of the label "x1@3": the sector's DOF name and the sector number."""
        d, _, j = name.rpartition(AT)
        sectors = self.assembly.sectors if self.cyclic else 1
        if not d or not j.isdigit() or int(j) >= sectors:
            raise ValueError(f"{name!r} is not '<dof>{AT}<sector>' with a sector below {sectors}")
        return d, int(j)


# ---------------------------------------------------------------------------
# Built models, cached on the frozen specs
# ---------------------------------------------------------------------------

def blade_model(structure: Blade):
    """The `fe_model.BladeModel` of a `Blade` spec (built once per spec)."""
    return timed_blade_model(structure)[0]


@lru_cache(maxsize=8)
def timed_blade_model(structure: Blade) -> tuple:
    """(`fe_model.BladeModel` of a `Blade` spec, the wall time [s] its build took)."""
    # deferred: blades imports scikit-fem and meshio (about a second); lumped
    # scenes never need them
    from ..structure.blades import build_blade, load_blade

    t0 = time.perf_counter()
    centre = structure.disk.centre if structure.rotating else None
    if structure.matrices is not None:
        from ..structure.exchange.imported import import_blade
        blade = import_blade(structure.mesh, structure.matrices, structure.params,
                             rotation_centre=centre, disk=structure.disk)
    elif structure.mesh:
        blade = load_blade(structure.mesh, structure.params, required=("root",),
                           rotation_centre=centre, scale=structure.mesh_scale)
    else:
        blade = build_blade(structure.params, structure.disk, rotation_centre=centre)
    return blade, time.perf_counter() - t0


@lru_cache(maxsize=16)
def blade_at_speed(structure: Blade, speed: float):
    """The blade turning at `speed` [rpm]: K + Omega^2 (K_sigma1 - M_P + K_1) + Omega^4 K_2, Omega = speed
    x 2 pi / 60 (`structure.rotation`); at speed 0 the blade itself."""
    blade = blade_model(structure)
    if speed == 0.0:
        return blade
    if blade.rotation is None:
        raise ValueError(f"speed {speed} rpm on a blade that does not turn: declare "
                         "\"centrifugal_stiffening\" (a solid blade in a disk)")
    return replace(blade, K=(blade.K + blade.rotation.speed_stiffness(speed * RPM)).tocsr())


def case_speed(structure, case: dict | None) -> float:
    """The rotation speed [rpm] of a case: its `speed`, else the structure's."""
    return float((case or {}).get("speed", getattr(structure, "speed", 0.0)))


@lru_cache(maxsize=16)
def reduced_model(structure: Blade, reduction: CraigBampton, speed: float = 0.0) -> tuple:
    """(Craig-Bampton `ReducedModel` keeping contact faces, excitation and response
    DOFs, its wall time [s]) of a blade turning at `speed` [rpm] (built once per spec
    pair and speed)."""
    from ..structure.reduction import reduce_blade

    kw = {"rayleigh": structure.rayleigh} if structure.rayleigh is not None else {}
    blade = blade_at_speed(structure, speed)
    t0 = time.perf_counter()
    red = reduce_blade(blade, reduction.modes, **kw)
    return red, time.perf_counter() - t0


def reduced_dof_names(red) -> tuple:
    """Names of reduced coordinates: `<set>.<c>` (point sets), `<face>.<k>.<c>`,
    `mode.<j>` (modal coordinates)."""
    names = [lab.replace(":", ".") for lab in red.labels]
    for s in POINT_SETS:
        if s in red.sets:
            for c, pos in enumerate(red.sets[s][0]):
                names[pos] = f"{s}.{COMPONENTS[c]}"
    return tuple(names)


def full_dof(scene: Scene, name: str) -> int:
    """Free-DOF index in the unreduced FE blade of an output name `<set>.<c>`."""
    s, c = name.split(".")
    return int(blade_model(scene.structure).dof_sets[s][0, COMPONENTS.index(c)])


# ---------------------------------------------------------------------------
# Contacts and loads on the unreduced structure
# ---------------------------------------------------------------------------


def blade_elements(scene: Scene, case: dict | None = None) -> ContactElements:
    """The Yang-Menq parameters of an FE scene's face contacts and shroud pairs, one
    per face node (node pair)."""
    *_, owner, weights = blade_contact_maps(scene, full=True)
    return contact_elements(scene.contacts, case, owner, weights)


def blade_contact_maps(scene: Scene, full: bool = False) -> tuple:
    """(Bt, Bn, owner) of an FE scene's face contacts and shroud pairs on the
    unreduced blade; full=True: (Bt, Bn, Bt_next, Bn_next, owner, weights),
    `contacts.fe_contact_maps`."""
    out = fe_contact_maps(blade_model(scene.structure), scene.contacts, scene.structure.disk)
    return out if full else (out[0], out[1], out[4])


def blade_forcing(scene: Scene, case: dict | None = None) -> np.ndarray:
    """(n_full, Hf+1) complex load amplitudes [N] of an FE scene on the unreduced blade."""
    F = point_forcing(blade_model(scene.structure), scene.loads)
    return F * float((case or {}).get("excitation_scale", 1.0))


# ---------------------------------------------------------------------------
# One sector (or the single structure) with a case applied
# ---------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Parts:
    """The linear part, contact maps (own and next sector's) and load of one
    structure with a case applied, before assembly."""

    M: object
    C: object
    K: object
    Bt: object
    Bn: object
    Bt_next: np.ndarray
    Bn_next: np.ndarray
    contact: ContactElements
    forcing: np.ndarray
    dofs: tuple
    laws: tuple = ()        # `LawElements` of the blade's 2D friction contacts


def check_case(scene: Scene, case: dict | None) -> dict:
    """The case as a dict; ValueError for a key that is not a case key, or a cyclic
    key on a scene that is not cyclic."""
    case = dict(case or {})
    unknown = set(case) - set(CASE_KEYS)
    if unknown:
        raise ValueError(f"case has unknown axes {sorted(unknown)}; known: {sorted(CASE_KEYS)}")
    if not scene.cyclic:
        for a in CYCLIC_CASE_KEYS:
            if a in case:
                raise ValueError(f"case has the disk axis {a!r} but the scene is not a disk")
    return case


def dof_rows(contacts, n: int, cyclic: bool) -> tuple:
    """(Bt, Bn, Bt_next, Bn_next) of `DofContact`s whose rows run over n DOFs, then (in
    a cyclic assembly) over the next sector's n."""
    E, m = len(contacts), 2 * n if cyclic else n
    Bt = np.array([c.bt for c in contacts], dtype=float).reshape(E, m)
    Bn = np.array([c.bn for c in contacts], dtype=float).reshape(E, m)
    return Bt[:, :n], Bn[:, :n], Bt[:, n:], Bn[:, n:]


def dof_parts(scene: Scene, case: dict) -> Parts:
    """`Parts` of a lumped structure with `DofContact`s and one `Forcing`."""
    st = scene.structure
    if len(scene.loads) != 1 or not isinstance(scene.loads[0], Forcing):
        raise ValueError("a lumped structure is loaded by one Forcing (amplitudes over its DOFs)")
    Bt, Bn, Bt_next, Bn_next = dof_rows(scene.contacts, len(st.dofs), scene.cyclic)
    return Parts(M=st.M, C=st.C, K=st.K, Bt=Bt, Bn=Bn, Bt_next=Bt_next, Bn_next=Bn_next,
                 contact=contact_elements(scene.contacts, case),
                 forcing=scene.loads[0].amplitudes * float(case.get("excitation_scale", 1.0)),
                 dofs=tuple(st.dofs))


def blade_parts(scene: Scene, case: dict, reduced: bool = True) -> Parts:
    """`Parts` of an FE blade: face contacts on the full model, then Craig-Bampton
    (dense, `scene.reduction`) or, with reduced=False, the unreduced sparse model
    (Rayleigh damping only).  `DofContact`s name reduced DOFs (one sector's, then the
    next sector's in a cyclic assembly)."""
    st = scene.structure
    faces = tuple(c for c in scene.contacts if isinstance(c, (FaceContact, ShroudPair)))
    rows = tuple(c for c in scene.contacts if isinstance(c, DofContact))
    if rows and faces:
        raise ValueError("a scene mixes face contacts and DOF contacts; give one kind")
    if any(isinstance(c, ShroudPair) for c in faces) and not scene.cyclic:
        raise ValueError("a shroud pair couples neighbouring blades: give a Cyclic assembly")
    speed = case_speed(st, case)
    blade = blade_at_speed(st, speed)
    shift = (speed * RPM) ** 2 * blade.rotation.static if speed and blade.rotation else None
    (Bt, Bn, Bt_next, Bn_next), elem, plane = blade_contact_sets(blade, faces, st.disk, case, shift)
    F = blade_forcing(scene, case)
    if not reduced or scene.reduction is None:
        if rows:
            raise ValueError("DOF contacts on an FE blade name reduced DOFs: give a reduction")
        if st.rayleigh is None:
            raise ValueError("the unreduced system needs Rayleigh damping "
                             "(scene rayleigh = [alpha, beta]); modal damping is dense")
        a, b = st.rayleigh
        C = (a * blade.M + b * blade.K).tocsr()
        return Parts(M=blade.M, C=C, K=blade.K, Bt=Bt, Bn=Bn, Bt_next=Bt_next,
                     Bn_next=Bn_next, contact=elem, forcing=F, dofs=(),
                     laws=(plane,) if plane else ())
    from ..structure.reduction import reduce_map  # deferred like blade_model's imports

    red = reduced_model(st, scene.reduction, case_speed(st, case))[0]
    Fr = np.zeros((red.M.shape[0], F.shape[1]), dtype=complex)
    Fr[:red.n_boundary] = F[red.boundary]
    if np.abs(F).sum() != np.abs(Fr).sum():
        raise ValueError("a load acts on an interior DOF (keep it in the boundary)")
    dofs = reduced_dof_names(red)
    if rows:
        Bt, Bn, Bt_next, Bn_next = dof_rows(rows, len(dofs), scene.cyclic)
        elem = contact_elements(rows, case)
    else:
        Bt, Bn, Bt_next, Bn_next = (reduce_map(red, B) for B in (Bt, Bn, Bt_next, Bn_next))
    if plane:
        plane = LawElements(plane.law, tuple(reduce_map(red, B) for B in plane.maps),
                            tuple(reduce_map(red, B) for B in plane.maps_next))
    return Parts(M=red.M, C=red.C, K=red.K, Bt=Bt, Bn=Bn, Bt_next=Bt_next, Bn_next=Bn_next,
                 contact=elem, forcing=Fr, dofs=dofs, laws=(plane,) if plane else ())


def scene_parts(scene: Scene, case: dict | None = None, reduced: bool = True) -> Parts:
    """`Parts` of the scene's structure (one sector) with a case applied."""
    case = check_case(scene, case)
    if isinstance(scene.structure, Lumped):
        return dof_parts(scene, case)
    return blade_parts(scene, case, reduced)


# ---------------------------------------------------------------------------
# Assembly
# ---------------------------------------------------------------------------

def engine_order(scene: Scene, case: dict | None = None) -> int:
    eo = (case or {}).get("eo", scene.assembly.engine_order)
    if eo is None:
        raise ValueError("the engine order is unset: give [scene.disk] engine_order or "
                         "the sweep axis eo")
    return int(eo)


def stiffness_factors(scene: Scene, case: dict | None = None):
    """The sectors' stiffness factors 1 + delta_j of a case [-] (None when tuned):
    sector j's stiffness f_j K, mass and damping unchanged (`cyclic.full_assembly`).
    On a Craig-Bampton-reduced blade f_j K_r is the reduction of the blade with
    Young's modulus f_j E exactly (same basis; see `cyclic.full_assembly`)."""
    mt = scene.mistuning
    if mt is None:
        return None
    if mt.factors is not None:
        return np.asarray(mt.factors, dtype=float)
    seed = (case or {}).get("mistuning_seed", mt.seed)
    if seed is None:
        raise ValueError("the mistuning seed is unset: give [scene.disk] mistuning.seed "
                         "or the sweep axis mistuning_seed")
    return cyclic.mistuning_factors(scene.assembly.sectors, mt.stiffness_std, int(seed))


def sector(scene: Scene, case: dict | None = None) -> cyclic.Sector:
    """The `cyclic.Sector` of a cyclic scene with a case applied."""
    p = scene_parts(scene, case)
    springs = scene.assembly.springs
    Ks, Kn = (cyclic.spring_stiffness([s.row for s in springs], [s.k for s in springs],
                                      len(p.dofs)) if springs else (None, None))
    return cyclic.Sector(M=p.M, C=p.C, K=p.K, Bt=p.Bt, Bn=p.Bn, Bt_next=p.Bt_next,
                         Bn_next=p.Bn_next, contact=p.contact, forcing=p.forcing,
                         sectors=scene.assembly.sectors, dof_names=p.dofs, K_spring=Ks,
                         K_next=Kn, laws=p.laws)


def build_system(scene: Scene, case: dict | None = None, reduced: bool = True) -> System:
    """The `System` of a scene with one case applied.  Single: the structure itself
    (reduced=False: an FE blade unreduced, sparse).  Cyclic, tuned: the one-sector
    cyclic reduction (`System.cyclic` set); mistuned: the full N-sector assembly with
    DOFs named as `scene.dofs`."""
    if not scene.cyclic:
        p = scene_parts(scene, case, reduced)
        return System(M=p.M, C=p.C, K=p.K, Bt=p.Bt, Bn=p.Bn, contact=p.contact,
                      forcing=p.forcing, dof_names=p.dofs, laws=p.laws + scene.laws)
    if scene.mistuning is None:
        return cyclic.sector_system(sector(scene, case), engine_order(scene, case))
    return replace(full_system(scene, case), dof_names=scene.dofs)


def full_system(scene: Scene, case: dict | None = None) -> System:
    """All N sectors of a cyclic scene assembled (N n DOFs, the case's mistuning if
    any): the reference for the one-sector reduction, never used by tuned runs."""
    return cyclic.full_assembly(sector(scene, case), engine_order(scene, case),
                                stiffness_factors(scene, case))
