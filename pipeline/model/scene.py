"""One scene: structure x reduction x contacts x loads x assembly, as plain frozen data.

A `Scene` composes independent parts; `pipeline.model.build.build_system` turns it,
with one parameter case applied, into the `System` of paper Eq. 4-6 that every solver
takes:

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
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .blade_cache import sector_names
from .contacts import DofContact, ShroudPair

CASE_KEYS = ("preload", "mu", "ku", "kv", "interference", "excitation_scale", "eo",
             "mistuning_seed", "speed")
CYCLIC_CASE_KEYS = ("eo", "mistuning_seed", "speed")
NEXT = "next."          # a DOF of the next sector in a cyclic contact row
AT = "@"                # "<dof>@<sector>": a DOF of one sector of a mistuned assembly




# ---------------------------------------------------------------------------
# The parts a scene composes
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
    mesh_scale: metres per unit of the mesh file's coordinates (1e-3: millimetres).
    disk_sector: a flexible disk sector generated under the blade
    (`structure.disk_sector`); a mesh with the node sets cyclic_low, cyclic_high is a
    sector read as drawn.  Either is joined to its neighbours at its cut faces."""

    params: object           # fe_model.BladeParams
    mesh: str | None = None
    rayleigh: tuple | None = None
    disk: object = None      # fe_model.DiskPlacement | None
    matrices: object = None  # imported.MatrixFiles | None
    rotating: bool = False   # turns about the disk axis (`structure.rotation`)
    speed: float = 0.0       # [rpm] unless a case sets `speed`
    mesh_scale: float = 1.0  # [m] per mesh-file length unit
    disk_sector: object = None  # structure.disk_sector.DiskSector: the disk under it


@dataclass(frozen=True)
class CraigBampton:
    """Craig-Bampton reduction with `modes` fixed-interface modes; a disk sector's cut
    faces reduced to `cut_face_modes` modes per phase (None: all their DOFs kept;
    `structure.cyclic_cut.interface_basis`)."""

    modes: int
    cut_face_modes: int | None = None


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
        return sector_names(self.structure, self.reduction)

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
