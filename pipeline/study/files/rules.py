"""Cross-field rules every scene kind shares: the declared physical effects match the
scene's data (friction, normal-load variation, separation, cyclic coupling,
mistuning), the harmonics cover the excitation, swept contact parameters have
contacts to act on.  Failures go through a `validation.Checker`.

The contacts are read from the scene under every law alike (`contact_rules`): the
scene's own contacts (`[[scene.contact]]`: lumped rows, FE faces and shroud pairs,
friction = "1d" or "2d") and the elements of every further law with a normal
direction and a preload (`[[scene.friction_2d]]`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...contact.registry import study_laws
from ...model.contacts import DofContact, ShroudPair
from ...model.system import normal_load_laws


@dataclass(frozen=True)
class ContactRule:
    """What the effect rules read of one contact element: `field` names it
    ("scene.contact[0]", "scene.friction_2d[1]"); n0 [N] (None: the case's preload),
    kv [N/m], mu [-]; `normal` whether it has a normal direction (its normal load
    n = n0 + kv v can vary); `swept`: a contact of `Scene.contacts`, which the sweep's
    contact axes (preload, mu, ku, kv) set and "friction" declares (False: an element
    of a further law, `Scene.laws`, its values fixed); `preload_key` the key that
    gives its preload ("n0", or "interference" for a shroud pair's overlap); `pair`: a
    shroud pair, whose preload `[sweep] interference` may set (n0 = kv x interference)."""

    field: str
    n0: float | None
    kv: float
    normal: bool
    mu: float
    swept: bool = True
    preload_key: str = "n0"
    pair: bool = False


def contact_rules(scene) -> tuple:
    """The `ContactRule`s of a scene: its contacts (a lumped row has a normal direction
    where its normal row is not zero, an FE face or shroud pair always; a pair's
    interference gives n0 = kv interference), then the elements of every further law
    with a normal load (`model.system.normal_load_laws`), named by their study-file
    table."""
    out = []
    for i, c in enumerate(getattr(scene, "contacts", ())):
        inter = getattr(c, "interference", None)
        out.append(ContactRule(
            f"scene.contact[{i}]", c.n0 if inter is None else c.kv * inter, float(c.kv),
            bool(np.any(c.bn)) if isinstance(c, DofContact) else True, float(c.mu),
            preload_key="n0" if inter is None else "interference",
            pair=isinstance(c, ShroudPair)))
    tables = {cls: table for table, cls in study_laws().items()}
    counts = {}
    laws = getattr(scene, "laws", ())
    for le in (laws[k] for k in normal_load_laws(laws)):
        law = le.law
        table = tables.get(type(law), law.name)
        normal_map = le.maps[law.directions.index("normal")]
        rows = np.asarray((normal_map != 0).sum(axis=1)).ravel()
        for e in range(law.size):
            j = counts[table] = counts.get(table, -1) + 1
            out.append(ContactRule(f"scene.{table}[{j}]", float(law.n0[e]), float(law.kv[e]),
                                   bool(rows[e]), float(law.mu[e]),
                                   swept=False))
    return tuple(out)


def check_scene_rules(ck, effects, contacts, h_excited, H, axes, spath, wpath,
                      disk=False, can_turn=False, speed=0.0):
    """Cross-field rules shared by every scene: harmonics cover the excitation, swept
    contact parameters have contacts to act on, a preload is given, and the
    declared effects match the scene (friction <=> contacts; normal-load variation
    <=> a contact with a normal direction and kv > 0; separation <=> a gap or a
    varying normal load; an engine order and "cyclic_coupling" only in a disk scene).

    `contacts`: the scene's `ContactRule`s (`contact_rules`), every law alike.
    Separation must be declared wherever the declared data make it certain
    (`check_separation`).  A rotation speed (`speed` [rpm] of the scene or the sweep
    axis) needs "centrifugal_stiffening" and a scene that can turn (`can_turn`: solid
    blades in a disk), and the effect a speed.  A contact with mu = 0 (not swept) and
    a constant normal load exerts no force at all: refused.
    """
    check_speed_rules(ck, effects, axes, wpath, can_turn, speed)
    if not disk:
        for axis, what in (("eo", "has an engine order"), ("mistuning_seed", "can be mistuned")):
            if axis in axes:
                ck.fail(f"{wpath}.{axis}", f"only a disk scene (scene.model = \"disk\") {what}")
        for effect in ("cyclic_coupling", "mistuning", "disk_coupling"):
            if effect in effects:
                ck.fail("scene.effects", f"\"{effect}\" needs a disk scene (scene.model = "
                                         "\"disk\"); this scene is one structure")
    if h_excited > H:
        ck.fail(f"{spath}.harmonics", f"H = {H} is below the excited harmonic {h_excited} "
                                      "(scene.excitation)")
    own = [c for c in contacts if c.swept]
    for a in ("preload", "normal_load", "mu", "ku", "kv"):
        if a in axes and not own:
            ck.fail(f"{wpath}.{a}", "the scene has no [[scene.contact]] to apply it to")
    if "interference" in axes and not any(c.pair for c in own):
        ck.fail(f"{wpath}.interference", "sets the interference of shroud pairs (FE blades in a "
                                         "disk, pair = \"shroud\"): the scene has none")
    check_preload_given(ck, own, axes, wpath)
    effects = set(effects)
    if bool(own) != ("friction" in effects):
        ck.fail("scene.effects", "declare \"friction\" exactly when the scene has contacts"
                if own else "\"friction\" is declared but the scene has no [[scene.contact]]")
    varies = any(c.normal and _kv(c, axes) > 0 for c in contacts)
    if varies != ("normal_load_variation" in effects):
        ck.fail("scene.effects", "normal DOFs with kv > 0 make the normal load vary: declare "
                                 "\"normal_load_variation\"" if varies else
                "\"normal_load_variation\" is declared but no contact has normal DOFs with kv > 0")
    check_forceless(ck, contacts, axes)
    check_separation(ck, effects, contacts, axes, wpath, varies)


def _kv(c: ContactRule, axes) -> float:
    """The largest kv [N/m] of contact c over the sweep."""
    return max(axes["kv"]) if c.swept and "kv" in axes else c.kv


def _n0(c: ContactRule, axes):
    """The smallest preload n0 [N] of contact c over the sweep (None: not given); a
    shroud pair under a swept interference: kv times the smallest (its sign)."""
    if c.pair and "interference" in axes:
        return c.kv * min(axes["interference"])
    return min(axes["preload"]) if c.swept and "preload" in axes else c.n0


def check_separation(ck, effects, contacts, axes, wpath, varies):
    """"separation" wherever the data make it certain, and only where it can occur: a
    negative preload (a gap), or a varying normal load n = n0 + kv v with a preload
    n0 <= 0 (it reaches zero as soon as the contact moves), under every law.  A
    varying normal load with every preload > 0 and no "separation" declares a
    contact that stays closed; the run checks every solution against that
    (`pipeline.study.files.declared`)."""
    gap = any(n0 is not None and n0 < 0 for n0 in (_n0(c, axes) for c in contacts))
    if gap and "separation" not in effects:
        ck.fail("scene.effects", "a negative preload (initial gap) means separation: declare "
                                 "\"separation\"")
    if varies and "separation" not in effects:
        for c in contacts:
            kv, n0 = _kv(c, axes), _n0(c, axes)
            if c.normal and kv > 0 and n0 is not None and n0 <= 0:
                where = (f"{wpath}.interference" if c.pair and "interference" in axes
                         else f"{wpath}.preload" if c.swept and "preload" in axes
                         else f"{c.field}.{c.preload_key}")
                ck.fail("scene.effects", f"{c.field} has a varying normal load (normal DOFs, "
                                         f"kv = {kv:g} N/m) and a preload of {n0:g} N "
                                         f"({where.lstrip('.')}): n = n0 + kv v reaches zero as "
                                         "soon as it moves, so it separates: declare "
                                         "\"separation\"")
    if "separation" in effects and not (gap or varies):
        ck.fail("scene.effects", "\"separation\" is declared but cannot occur (constant normal "
                                 "load and no negative preload)")


def check_preload_given(ck, contacts, axes, wpath):
    """Each contact's preload given once: by its n0, the swept preload or the static
    normal load the sweep asks for (n0 solved for it), never by two of them
    (`contacts`: the `ContactRule`s the sweep acts on); a shroud pair's preload may come
    from the swept interference instead (`blade_wheel_scene.check_interference`)."""
    if "interference" in axes:
        contacts = [c for c in contacts if not c.pair]
    if "normal_load" in axes:
        if "preload" in axes:
            ck.fail(f"{wpath}.normal_load", "give either the preload n0 (sweep.preload) or the "
                                            "static normal load (sweep.normal_load), not both")
        for c in contacts:
            if c.n0 is not None:
                ck.fail(f"{c.field}.n0", "the static normal load is given (sweep.normal_load): "
                                         "n0 is solved for it, give not both")
    elif contacts and "preload" not in axes:
        for c in contacts:
            if c.n0 is None:
                ck.fail(f"{c.field}.n0", "missing (required unless sweep.preload is given)")
    elif "preload" in axes:
        for c in contacts:
            if c.n0 is not None:
                ck.fail(f"{c.field}.n0", f"the preload is swept "
                                         f"({f'{wpath}.preload'.lstrip('.')} sets n0 "
                                         "of every contact): give not both")


def check_forceless(ck, contacts, axes):
    """A contact with mu = 0 (not swept) and a constant normal load exerts no force."""
    for c in contacts:
        if c.mu == 0 and not (c.swept and "mu" in axes) and not (c.normal and _kv(c, axes) > 0):
            ck.fail(f"{c.field}.mu", "mu = 0 under a constant normal load: the contact exerts "
                                     "no force (no friction, no normal spring); remove it or "
                                     "give mu > 0")


def check_speed_rules(ck, effects, axes, wpath, can_turn, speed, axis_field=None):
    """"centrifugal_stiffening" exactly when a speed turns a scene that can turn;
    `axis_field`: the field of the swept speeds (default `<wpath>.speed`)."""
    field = axis_field or f"{wpath}.speed"
    speeds = tuple(v for v in axes.get("speed", ()) if v) + ((speed,) if speed else ())
    if "speed" in axes and min(axes["speed"]) < 0:
        ck.fail(field, f"a speed is >= 0 rpm (the disk turns one way), got "
                       f"{min(axes['speed']):g}")
    declared = "centrifugal_stiffening" in effects
    if speeds and not can_turn:
        ck.fail(field if "speed" in axes else "scene.disk.speed",
                "a rotation speed needs a turning structure: solid blades in a disk "
                "([scene.disk] gives the axis), generated, meshed or imported with their "
                "stiffness exported at the speeds ([[scene.matrices.speed]])")
    if declared and not can_turn:
        ck.fail("scene.effects", "\"centrifugal_stiffening\" needs a turning structure: solid "
                                 "blades in a disk ([scene.disk]; imported matrices with "
                                 "[[scene.matrices.speed]])")
    if speeds and not declared:
        ck.fail(field if "speed" in axes else "scene.disk.speed",
                "a rotation speed stiffens the blades: declare \"centrifugal_stiffening\"")
    if declared and not speeds:
        ck.fail("scene.effects", "\"centrifugal_stiffening\" is declared but nothing turns: "
                                 f"give scene.disk.speed or {field} [rpm] > 0")


def check_optimum_axes(ck, output, axes, wpath):
    """The optimum search varies n0 (or the shroud pairs' interference): a sweep that
    gives the static normal load instead would be compared against a different
    quantity."""
    if output.optimum is not None and "normal_load" in axes:
        v = output.optimum.get("variable", "preload")
        ck.fail(f"output.optimum_{v}", f"searches the {'preload n0' if v == 'preload' else v}, "
                f"but {wpath}.normal_load gives the static normal load: sweep {v} instead")
