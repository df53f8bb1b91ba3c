"""A `Scene` with one parameter case applied, built into the `System` of paper
Eq. 4-6 that every solver takes (`build_system`), or into one cyclic `Sector`
(`sector`), or all N sectors assembled (`full_system`).

A case is a dict of overrides (`scene.CASE_KEYS`); FE blades and their reductions come
from `blade_cache`, built once per spec.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..contact.laws import ContactElements, LawElements
from ..structure.reduction import reduce_map
from . import cyclic
from .blade_cache import (COMPONENTS, RPM, blade_at_speed, blade_model, case_speed, cut_model,
                          reduced_dof_names, reduced_model)
from .contacts import (DofContact, FaceContact, ShroudPair, blade_contact_sets, contact_elements,
                       fe_contact_maps)
from .loads import Forcing, point_forcing
from .scene import CASE_KEYS, CYCLIC_CASE_KEYS, Lumped, Scene
from .system import System


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
class Unassembled:
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
    next: tuple = ()        # (K, M, C) towards the next sector (a disk sector's cut), or ()


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


def lumped_unassembled(scene: Scene, case: dict) -> Unassembled:
    """`Unassembled` of a lumped structure with `DofContact`s and one `Forcing`."""
    st = scene.structure
    if len(scene.loads) != 1 or not isinstance(scene.loads[0], Forcing):
        raise ValueError("a lumped structure is loaded by one Forcing (amplitudes over its DOFs)")
    Bt, Bn, Bt_next, Bn_next = dof_rows(scene.contacts, len(st.dofs), scene.cyclic)
    return Unassembled(M=st.M, C=st.C, K=st.K, Bt=Bt, Bn=Bn, Bt_next=Bt_next,
                       Bn_next=Bn_next, contact=contact_elements(scene.contacts, case),
                       forcing=scene.loads[0].amplitudes * float(case.get("excitation_scale", 1.0)),
                       dofs=tuple(st.dofs))


def blade_unassembled(scene: Scene, case: dict, reduced: bool = True) -> Unassembled:
    """`Unassembled` of an FE blade: face contacts on the full model, then Craig-Bampton
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
        if st.disk_sector is not None or "cyclic_low" in blade.dof_sets:
            raise ValueError("a disk sector is solved reduced: give craig_bampton_modes")
        if rows:
            raise ValueError("DOF contacts on an FE blade name reduced DOFs: give a reduction")
        if st.rayleigh is None:
            raise ValueError("the unreduced system needs Rayleigh damping "
                             "(scene rayleigh = [alpha, beta]); modal damping is dense")
        a, b = st.rayleigh
        C = (a * blade.M + b * blade.K).tocsr()
        return Unassembled(M=blade.M, C=C, K=blade.K, Bt=Bt, Bn=Bn, Bt_next=Bt_next,
                           Bn_next=Bn_next, contact=elem, forcing=F, dofs=(),
                           laws=(plane,) if plane else ())

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
    p = Unassembled(M=red.M, C=red.C, K=red.K, Bt=Bt, Bn=Bn, Bt_next=Bt_next,
                    Bn_next=Bn_next, contact=elem, forcing=Fr, dofs=dofs,
                    laws=(plane,) if plane else ())
    cut = cut_model(st, scene.reduction, speed)
    if cut is not None and rows:
        raise ValueError("DOF contacts on a disk sector: give face contacts or shroud pairs")
    return p if cut is None else joined(p, cut)


def joined(p: Unassembled, cut) -> Unassembled:
    """A reduced disk sector's `Unassembled` with its cut faces joined to the neighbours'
    (`cyclic_cut.CutSector`): maps B T_own, load T_own^T F, (K, M, C)_0 and the coupling
    (K, M, C)_1 towards the next sector.  ValueError when a contact or a load touches
    the high cut face (it belongs to the next sector)."""
    def own(B):
        if np.abs(np.asarray(B) @ cut.T_next).max(initial=0.0) > 0:
            raise ValueError("a contact or a load touches the cut face cyclic_high")
        return np.asarray(B) @ cut.T_own

    maps = [own(B) for B in (p.Bt, p.Bn, p.Bt_next, p.Bn_next)]
    laws = tuple(LawElements(le.law, tuple(own(B) for B in le.maps),
                             tuple(own(B) for B in le.maps_next)) for le in p.laws)
    return Unassembled(M=cut.M0, C=cut.C0, K=cut.K0, Bt=maps[0], Bn=maps[1], Bt_next=maps[2],
                       Bn_next=maps[3], contact=p.contact, forcing=own(np.asarray(p.forcing).T).T,
                       dofs=cut.names, laws=laws, next=(cut.K1, cut.M1, cut.C1))


def unassembled(scene: Scene, case: dict | None = None, reduced: bool = True) -> Unassembled:
    """`Unassembled` of the scene's structure (one sector) with a case applied."""
    case = check_case(scene, case)
    if isinstance(scene.structure, Lumped):
        return lumped_unassembled(scene, case)
    return blade_unassembled(scene, case, reduced)


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
    p = unassembled(scene, case)
    springs = scene.assembly.springs
    Ks, Kn = (cyclic.spring_stiffness([s.row for s in springs], [s.k for s in springs],
                                      len(p.dofs)) if springs else (None, None))
    Kc, Mc, Cc = p.next or (None, None, None)     # a disk sector's cut
    return cyclic.Sector(M=p.M, C=p.C, K=p.K, Bt=p.Bt, Bn=p.Bn, Bt_next=p.Bt_next,
                         Bn_next=p.Bn_next, contact=p.contact, forcing=p.forcing,
                         sectors=scene.assembly.sectors, dof_names=p.dofs, K_spring=Ks,
                         K_next=Kn if Kc is None else Kc, laws=p.laws, M_next=Mc, C_next=Cc)


def build_system(scene: Scene, case: dict | None = None, reduced: bool = True) -> System:
    """The `System` of a scene with one case applied.  Single: the structure itself
    (reduced=False: an FE blade unreduced, sparse).  Cyclic, tuned: the one-sector
    cyclic reduction (`System.cyclic` set); mistuned: the full N-sector assembly with
    DOFs named as `scene.dofs`."""
    if not scene.cyclic:
        p = unassembled(scene, case, reduced)
        if p.next:
            raise ValueError("a disk sector is one of N: give [scene.disk] (a cyclic assembly)")
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
