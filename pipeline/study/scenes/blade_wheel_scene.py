"""FE blades in a disk in study files: `[scene.disk]` and shroud-pair contacts of a
blade scene (`model = "solid_blade"`, or `"beam_blade"`: a beam with a rigid tip
shroud carrying 2 x 2 contact points per face).

    [scene.disk]
    sectors = 24            # N
    hub_radius = 0.25       # R [m]: the blade root sits at radius R
    engine_order = 3        # or the sweep axis eo; 0 <= EO <= N/2

    [[scene.contact]]
    pair = "shroud"         # the right shroud face of blade j against the left face of
    ku = 1e6                # blade j+1, node to node (pairs found by the rotation 2 pi / N)
    kv = 1e6
    mu = 0.3
    stiffness = "per_face"  # ku, kv, preload as face totals shared by node area
    tangent = [1, 0, 0]     # optional slip direction, projected into the face
    friction = "2d"         # optional: slip anywhere in the face plane ("1d": along
                            # the tangent, the default)

With friction = "2d" (a face contact too) the pair's elements are the 2D friction
law's (`contact.friction2d`: tangents t1 = the tangent, t2 = n x t1), declared by
the effect "friction_2d" beside "friction", evaluated by AFT (force_evaluation =
"aft"); a given tangent must then lie in the face plane (within 1e-3 rad), a 1D pair's
within 60 deg of it (projected).

The generated wheel derives the shroud width from R and N so that neighbouring
faces coincide (`structure.disk.wheel_params`); a user mesh (`mesh = "file"`, in the
blade's frame, the disk axis parallel to X through (0, 0, -R), or moved there from its
model's own `[scene.matrices] axis`, `structure.exchange.disk_frame`) is paired by the
same rotation, and faces that do not match are a one-line error naming the first
unmatched node.  Each case is solved on ONE sector by the cyclic reduction
(`model.cyclic`), the neighbour's displacement turned by 2 pi / N into this
sector's frame (`model.contacts.ShroudPair`).  A shroud pair is the effect
"cyclic_coupling"; the engine-order rules are those of the lumped disk
(`lumped_disk_scene.check_disk_rules`).
"""
from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from ...contact.registry import law_class
from ...model.contacts import FRICTION, ShroudPair, fe_contact_maps
from ...solve.stability.methods import require_mode, stability_mode
from ...model.scene import Blade, CraigBampton, Cyclic, Single
from ...structure.cyclic_cut import cut_pairing
from ...structure.disk_sector import DiskSector
from ...structure.fe_model import CUT_SETS, DiskPlacement
from . import lumped_disk_scene as disk_scene

PAIRS = ("shroud",)
SECTOR_KEYS = ("bore_radius", "n_radial", "n_overhang", "E", "nu", "rho", "cut_face_modes")
STIFFNESS = ("per_node", "per_face")


def parse_placement(ck, tab) -> tuple:
    """(DiskPlacement, Cyclic) of the `[scene.disk]` table of a blade scene; (None,
    Single()) without one (a disk sector then refused)."""
    if "disk" not in tab:
        if "disk_sector" in tab:
            ck.fail("scene.disk_sector", "a disk sector is one of N: give [scene.disk] "
                                         "sectors and hub_radius (the disk axis)")
        return None, Single()
    t = ck.table(tab["disk"], "scene.disk")
    ck.keys(t, "scene.disk", ("sectors", "hub_radius", "engine_order", "mistuning", "speed"),
            required=("sectors", "hub_radius"))
    N = ck.integer(t["sectors"], "scene.disk.sectors", 3, disk_scene.MAX_SECTORS)
    R = ck.number(t["hub_radius"], "scene.disk.hub_radius", gt=0.0)
    eo = (disk_scene.check_engine_order(ck, t["engine_order"], "scene.disk.engine_order", N)
          if "engine_order" in t else None)
    mis = disk_scene.parse_mistuning(ck, t["mistuning"], N) if "mistuning" in t else None
    return DiskPlacement(hub_radius=R, sectors=N), Cyclic(sectors=N, engine_order=eo,
                                                         mistuning=mis)


def parse_pair(ck, c, f, i) -> ShroudPair:
    """A `[[scene.contact]]` with `pair = "shroud"`."""
    ck.keys(c, f, ("name", "pair", "ku", "kv", "mu", "n0", "stiffness", "tangent",
                   "interference", "friction", "ku2"), required=("pair", "ku", "mu"))
    ck.string(c["pair"], f"{f}.pair", PAIRS)
    name = ck.string(c.get("name", "shroud"), f"{f}.name")
    tangent = None
    if "tangent" in c:
        tangent = tuple(float(v) for v in ck.numbers(c["tangent"], f"{f}.tangent", 3))
        if not np.linalg.norm(tangent) > 0:
            ck.fail(f"{f}.tangent", "must not be the zero vector")
    return ShroudPair(name=name, ku=ck.number(c["ku"], f"{f}.ku", gt=0.0),
                      kv=ck.number(c.get("kv", 0.0), f"{f}.kv", ge=0.0),
                      mu=ck.number(c["mu"], f"{f}.mu", ge=0.0),
                      n0=ck.number(c["n0"], f"{f}.n0") if "n0" in c else None,
                      tangent=tangent,
                      stiffness=ck.string(c.get("stiffness", "per_node"), f"{f}.stiffness",
                                          STIFFNESS),
                      interference=(ck.number(c["interference"], f"{f}.interference")
                                    if "interference" in c else None),
                      **parse_friction(ck, c, f))


def parse_friction(ck, c, f) -> dict:
    """A contact's `friction` ("1d" | "2d") and `ku2` (the 2D law's stiffness along the
    second tangent; None: ku); the 2D law needs mu > 0."""
    friction = ck.string(c.get("friction", "1d"), f"{f}.friction", FRICTION)
    if friction == "2d":
        ck.number(c["mu"], f"{f}.mu", gt=0.0)
    elif "ku2" in c:
        ck.fail(f"{f}.ku2", "a stiffness along a second tangent is of friction = \"2d\" "
                            "(slip in the face plane)")
    ku2 = ck.number(c["ku2"], f"{f}.ku2", gt=0.0) if "ku2" in c else None
    return {"friction": friction, "ku2": ku2}


def check_friction(ck, scene, solver, spath):
    """The contacts of a blade scene slide one way; "friction_2d" is declared exactly
    when they slide in the plane, which AFT evaluates.  A disk sector's stability is not
    Hill's (its mass couples it to the neighbours: `full_operators.wave_jacobians`)."""
    contacts, effects = scene.contacts, scene.effects
    if (getattr(scene.structure, "disk_sector", None) is not None
            and stability_mode(solver.stability) in ("hill", "hill+check")):
        ck.fail(f"{spath}.stability", "Hill's method on a disk sector (its mass couples it to "
                                      "its neighbours) is not available: give \"folds\", "
                                      "\"monodromy\" or false")
    kinds = [getattr(c, "friction", "1d") for c in contacts]
    for i, k in enumerate(kinds):
        if k != kinds[0]:
            ck.fail(f"scene.contact[{i}].friction", f"{k!r}, but scene.contact[0] has "
                    f"{kinds[0]!r}: the contacts of a scene slide one way")
    plane = bool(kinds) and kinds[0] == "2d"
    if plane != ("friction_2d" in effects):
        ck.fail("scene.effects", "declare \"friction_2d\" exactly when the contacts have "
                                 "friction = \"2d\"")
    if plane and solver.force_evaluation != "aft":
        ck.fail(f"{spath}.force_evaluation", "friction = \"2d\" is evaluated by AFT only: "
                                             "give force_evaluation = \"aft\" (and samples)")
    if plane:
        try:
            require_mode((SimpleNamespace(law=law_class("friction_2d")),), solver.stability)
        except ValueError as exc:
            ck.fail(f"{spath}.stability", f"{exc}: give stability = \"hill\" or false")


def plane_friction(contacts) -> bool:
    """Whether the contacts slide in their plane (friction = "2d")."""
    return any(getattr(c, "friction", "1d") == "2d" for c in contacts)


MAX_TANGENT_TILT = 60.0   # [deg] a 1D pair's tangent out of the face: projected up to this


def check_tangents(ck, blade, contacts):
    """A 2D pair's given first tangent lies in the right shroud face's plane (to
    1e-3 rad): the second is n x t1, so a tilted one would not span the plane.  A 1D
    pair's tangent is projected into the face, but one more than MAX_TANGENT_TILT out
    of it is nearly the face normal (a normal typed to 3 digits left a projection of
    2.5e-5 of it, an arbitrary slip direction), refused."""
    for i, c in enumerate(contacts):
        if not (isinstance(c, ShroudPair) and c.tangent is not None):
            continue
        n = np.asarray(blade.frames["shroud_right"].normal, float)
        t = np.asarray(c.tangent, float)
        tilt = np.degrees(np.arcsin(min(abs(float(t @ n)) / np.linalg.norm(t), 1.0)))
        limit = np.degrees(1e-3) if c.friction == "2d" else MAX_TANGENT_TILT
        if tilt > limit:
            ck.fail(f"scene.contact[{i}].tangent", f"not in the shroud face plane: "
                    f"{tilt:.3g} deg out of it (at most {limit:.3g}; face normal "
                    f"{np.round(n, 4).tolist()}); give a direction in the face")


def check_interference(ck, contacts, axes, wpath):
    """An interference [m] sets the pair's preload: no n0, no swept preload or static
    normal load beside it, and a normal stiffness to turn it into a load.  The sweep
    axis `interference` sets every shroud pair's, which then gives neither its own
    interference nor n0 (`rules.check_scene_rules` refuses it without shroud pairs)."""
    swept = "interference" in axes
    for i, c in enumerate(contacts):
        own = getattr(c, "interference", None) is not None
        if not (own or (swept and isinstance(c, ShroudPair))):
            continue
        f = f"scene.contact[{i}]"
        if own and swept:
            ck.fail(f"{f}.interference", f"the interference is swept ({wpath.lstrip('.')}."
                                         "interference sets every shroud pair's): give not both")
        if c.n0 is not None:
            ck.fail(f"{f}.n0", f"{'the ' if own else wpath.lstrip('.') + '.'}interference sets "
                               "the preload (n0 = kv x interference before the blades "
                               "deflect): give one of the two")
        for a in ("preload", "normal_load"):
            if a in axes:
                ck.fail(f"{wpath}.{a}", f"contact {i} has an interference, which sets its "
                                        "preload: sweep speed (or the interference) instead"
                        if not swept else f"{wpath.lstrip('.')}.interference sets the preload "
                        "of every shroud pair (n0 = kv x interference before the blades "
                        "deflect): sweep one of the two")
        if not c.kv > 0:
            ck.fail(f"{f}.kv", "an interference needs a normal stiffness kv > 0 [N/m] to press")


def check_interference_search(ck, contacts, optimum, axes, wpath):
    """The optimum search varies one quantity, the one that sets the shroud pairs'
    preload: an optimum-preload search varies n0, which an interference (the pair's own
    or `sweep.interference`) fixes (n0 = kv x interference, the blades' closure), so
    every trial would give the same response: refused; an optimum-interference search
    varies every shroud pair's interference, so each pair's preload must come from one
    (not from its n0, a swept preload or a static normal load)."""
    if optimum is None:
        return
    variable = optimum.get("variable", "preload")
    field = f"output.optimum_{variable}"
    pressed = [i for i, c in enumerate(contacts) if getattr(c, "interference", None) is not None]
    if variable == "preload":
        if pressed or "interference" in axes:
            sets = (f"scene.contact[{pressed[0]}].interference" if pressed
                    else f"{wpath.lstrip('.')}.interference")
            ck.fail(field, f"searches the preload n0, but {sets} sets it (n0 = kv x "
                    "interference): the response does not depend on the searched preload; "
                    "remove one of the two (or search [output.optimum_interference])")
        return
    pairs = [i for i, c in enumerate(contacts) if isinstance(c, ShroudPair)]
    if not pairs:
        ck.fail(field, "searches the interference of the shroud pairs (pair = \"shroud\"), "
                       "but the scene has none")
    for i in pairs:
        if contacts[i].interference is None and "interference" not in axes:
            ck.fail(field, f"searches the interference, but scene.contact[{i}] has its preload "
                           f"from n0 or [sweep] preload / normal_load, which the search would "
                           f"not change: give scene.contact[{i}].interference [m] instead")


def check_disk_contacts(ck, contacts, placement):
    """Shroud pairs need a disk, and a disk of FE blades needs a shroud pair (checked
    before the blade is built)."""
    pairs = [i for i, c in enumerate(contacts) if isinstance(c, ShroudPair)]
    if pairs and placement is None:
        ck.fail(f"scene.contact[{pairs[0]}].pair", "a shroud pair couples neighbouring blades: "
                                                  "give [scene.disk] sectors and hub_radius")
    if placement is not None and not pairs:
        ck.fail("scene.contact", "a disk of FE blades couples them through their shrouds: give "
                                 "a [[scene.contact]] with pair = \"shroud\"")


def check_pairs(ck, blade, scene, placement, mesh_field):
    """Cut faces that join (`check_cut_faces`) and shroud faces that pair by the
    rotation 2 pi / N (one line naming the first unmatched node otherwise)."""
    contacts = scene.contacts
    check_cut_faces(ck, blade, placement, mesh_field, scene.reduction)
    if any(isinstance(c, ShroudPair) for c in contacts):
        try:
            fe_contact_maps(blade, contacts, placement)
        except ValueError as exc:
            ck.fail(mesh_field, str(exc))
        check_tangents(ck, blade, contacts)


def parse_disk_sector(ck, tab, model: str, mesh) -> DiskSector | None:
    """The `DiskSector` of `[scene.disk_sector]` (a generated blade on its flexible disk
    sector), None without one or for a mesh (a sector read as drawn: its cut faces are
    its node sets cyclic_low, cyclic_high; the table may then set cut_face_modes only)."""
    if "disk_sector" not in tab:
        return None
    f = "scene.disk_sector"
    t = ck.table(tab["disk_sector"], f)
    if "disk" not in tab or model != "solid_blade":
        ck.fail(f, "a disk sector is a solid blade's (model = \"solid_blade\") in a disk: "
                   "give [scene.disk] sectors and hub_radius")
    if mesh is not None:     # the mesh's own disk: the generator's keys are unknown here
        ck.keys(t, f, ("cut_face_modes",))
        return None
    ck.keys(t, f, SECTOR_KEYS, required=("bore_radius",))
    blade = tab.get("blade") if isinstance(tab.get("blade"), dict) else {}
    for k in ("twist", "camber", "taper"):
        if blade.get(k):
            ck.fail(f"scene.blade.{k}", "a disk sector is meshed under the straight blade's "
                                        "root: a curved blade stands on the rigid disk only")
    kw = {k: ck.number(t[k], f"{f}.{k}", gt=0.0) for k in ("bore_radius", "E", "rho") if k in t}
    kw.update({k: ck.integer(t[k], f"{f}.{k}", 1, 100) for k in ("n_radial", "n_overhang")
               if k in t})
    if "nu" in t:
        kw["nu"] = ck.number(t["nu"], f"{f}.nu", gt=-1.0, lt=0.5)
    R = ck.number(tab["disk"].get("hub_radius", 0.0), "scene.disk.hub_radius")
    if kw["bore_radius"] >= R:
        ck.fail(f"{f}.bore_radius", f"{kw['bore_radius']!r} m is not below the hub radius "
                                     f"{R!r} m")
    return DiskSector(**kw)


def reduction(ck, tab, modes: int) -> CraigBampton:
    """The Craig-Bampton reduction with `modes` modes and `[scene.disk_sector]
    cut_face_modes` (a disk sector's cut faces: modes per phase; absent: all kept)."""
    t = tab.get("disk_sector")
    if not isinstance(t, dict) or "cut_face_modes" not in t:
        return CraigBampton(modes)
    return CraigBampton(modes, ck.integer(t["cut_face_modes"], "scene.disk_sector.cut_face_modes",
                                          1, 10_000))


def check_cut_faces(ck, blade, placement, field: str, reduction=None) -> None:
    """A blade with cut faces has both, in a disk, its high face is its low face
    turned by 2 pi / N, node for node (one line naming the farthest node otherwise),
    and `reduction.cut_face_modes` does not exceed the face's DOFs."""
    present = [s for s in CUT_SETS if s in blade.dof_sets]
    if not present:
        return
    if len(present) == 1:
        ck.fail(field, f"a disk sector needs both cut faces: node set {present[0]!r} has no "
                       f"{(set(CUT_SETS) - set(present)).pop()!r}")
    if placement is None:
        ck.fail(field, "cut faces cyclic_low, cyclic_high need [scene.disk] (the disk axis)")
    try:
        cut_pairing(*(blade.set_points[s] for s in CUT_SETS), placement)
    except ValueError as exc:
        ck.fail(field, str(exc))
    count, dofs = getattr(reduction, "cut_face_modes", None), blade.dof_sets["cyclic_low"].size
    if count is not None and count > dofs:
        ck.fail("scene.disk_sector.cut_face_modes", f"{count} modes per phase, but the cut face "
                                                    f"has {dofs} DOFs: give at most {dofs}")


def placement_field(message: str) -> tuple:
    """(the study field a geometry error of the wheel names, or None; the message
    without its `disk.<key>: ` prefix)."""
    for key in ("hub_radius", "sectors"):
        if message.startswith(f"disk.{key}: "):
            return f"scene.disk.{key}", message[len(f"disk.{key}: "):]
    if message.startswith("disk_sector"):
        field, _, rest = message.partition(": ")
        return f"scene.{field}", rest
    return None, message


def turning(ck, tab, structure: Blade, model: str, effects) -> Blade:
    """The blade spec with its speed (`scene.disk.speed` [rpm]) and whether it turns
    (the effect "centrifugal_stiffening" on a solid blade in a disk, its own assembly or
    matrices exported at speeds), and its disk sector (`parse_disk_sector`)."""
    sector = parse_disk_sector(ck, tab, model, structure.mesh)
    if (sector is not None and "centrifugal_stiffening" in effects
            and sector.material(structure.params) != tuple(
                getattr(structure.params, k) for k in ("E", "nu", "rho"))):
        ck.fail("scene.effects", "a disk sector of its own material does not turn yet (the "
                                 "centrifugal prestress is computed for one material): leave "
                                 "out \"centrifugal_stiffening\" or the disk's E, nu, rho")
    structure = replace(structure, disk_sector=sector)
    if structure.disk is None:
        return structure
    speed = ck.number(tab["disk"].get("speed", 0.0), "scene.disk.speed", ge=0.0)
    rotating = ("centrifugal_stiffening" in effects and model == "solid_blade"
                and (structure.matrices is None or bool(structure.matrices.speeds)))
    return replace(structure, speed=float(speed), rotating=rotating)


def can_turn(scene) -> bool:
    """Whether the scene's blades can turn: solid, in a disk, the package's assembly or
    matrices exported at one or more speeds."""
    st = scene.structure
    return (scene.model == "solid_blade" and st.disk is not None
            and (st.matrices is None or bool(st.matrices.speeds)))
