"""Cross-field rules every scene kind shares: the declared physical effects match the
scene's data (friction, normal-load variation, separation, cyclic coupling,
mistuning), the harmonics cover the excitation, swept contact parameters have
contacts to act on.  Failures go through a `checker.Checker`."""
from __future__ import annotations


def check_scene_rules(ck, effects, n0s, kvs, has_normal, h_excited, H, axes, spath, wpath,
                      disk=False, can_turn=False, speed=0.0, mus=()):
    """Cross-field rules shared by every scene: harmonics cover the excitation, swept
    contact parameters have contacts to act on, a preload is given, and the
    declared effects match the scene (friction <=> contacts; normal-load variation
    <=> normal DOFs with kv > 0; separation <=> a gap or a varying normal load;
    an engine order and "cyclic_coupling" only in a disk scene).

    Separation must be declared wherever the declared data make it certain: a
    negative preload (a gap), or a varying normal load n = n0 + kv v with a preload
    n0 <= 0 (it reaches zero as soon as the contact moves).  A varying normal load
    with every preload > 0 and no "separation" declares a contact that stays
    closed; the run checks every solution against that (`pipeline.study.files.declared`).
    `has_normal` is one flag for every contact or one per contact.  A rotation speed
    (`speed` [rpm] of the scene or the sweep axis) needs "centrifugal_stiffening" and a
    scene that can turn (`can_turn`: solid blades in a disk), and the effect a speed.
    A contact with mu = 0 (`mus`, one per contact; not swept) and a constant normal
    load exerts no force at all: refused.
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
    has_contact = bool(n0s)
    for a in ("preload", "mu", "ku", "kv"):
        if a in axes and not has_contact:
            ck.fail(f"{wpath}.{a}", "the scene has no [[scene.contact]] to apply it to")
    check_preload_given(ck, n0s, axes, wpath, has_contact)
    effects = set(effects)
    if has_contact != ("friction" in effects):
        ck.fail("scene.effects", "declare \"friction\" exactly when the scene has contacts"
                if has_contact else "\"friction\" is declared but the scene has no [[scene.contact]]")
    normal = (list(has_normal) if isinstance(has_normal, (list, tuple))
              else [bool(has_normal)] * len(n0s))
    kv_vals = axes.get("kv") or tuple(kvs)
    varies = any(normal) and max(kv_vals, default=0.0) > 0
    if varies != ("normal_load_variation" in effects):
        ck.fail("scene.effects", "normal DOFs with kv > 0 make the normal load vary: declare "
                                 "\"normal_load_variation\"" if varies else
                "\"normal_load_variation\" is declared but no contact has normal DOFs with kv > 0")
    check_forceless(ck, mus, normal, kvs, axes)
    n0_vals = axes.get("preload") or tuple(n0 for n0 in n0s if n0 is not None)
    gap = min(n0_vals, default=0.0) < 0
    if gap and "separation" not in effects:
        ck.fail("scene.effects", "a negative preload (initial gap) means separation: declare "
                                 "\"separation\"")
    if varies and "separation" not in effects:
        for i, (n0, kv, nrm) in enumerate(zip(n0s, kvs, normal)):
            kv_i = max(axes["kv"]) if "kv" in axes else kv
            n0_i = min(axes["preload"]) if "preload" in axes else n0
            if nrm and kv_i > 0 and n0_i is not None and n0_i <= 0:
                where = f"{wpath}.preload" if "preload" in axes else f"scene.contact[{i}].n0"
                ck.fail("scene.effects", f"contact {i} has a varying normal load (normal DOFs, "
                                         f"kv = {kv_i:g} N/m) and a preload of {n0_i:g} N "
                                         f"({where}): n = n0 + kv v reaches zero as soon as it "
                                         "moves, so it separates: declare \"separation\"")
    if "separation" in effects and not (gap or varies):
        ck.fail("scene.effects", "\"separation\" is declared but cannot occur (constant normal "
                                 "load and no negative preload)")


def check_preload_given(ck, n0s, axes, wpath, has_contact):
    """Each contact's preload given once: by its n0, the swept preload or the static
    normal load the sweep asks for (n0 solved for it), never by two of them."""
    if "normal_load" in axes:
        if "preload" in axes:
            ck.fail(f"{wpath}.normal_load", "give either the preload n0 (sweep.preload) or the "
                                            "static normal load (sweep.normal_load), not both")
        for i, n0 in enumerate(n0s):
            if n0 is not None:
                ck.fail(f"scene.contact[{i}].n0", "the static normal load is given "
                                                  "(sweep.normal_load): n0 is solved for it, "
                                                  "give not both")
    elif has_contact and "preload" not in axes:
        for i, n0 in enumerate(n0s):
            if n0 is None:
                ck.fail(f"scene.contact[{i}].n0", "missing (required unless sweep.preload is given)")
    elif "preload" in axes:
        for i, n0 in enumerate(n0s):
            if n0 is not None:
                ck.fail(f"scene.contact[{i}].n0", f"the preload is swept "
                                                  f"({f'{wpath}.preload'.lstrip('.')} sets n0 "
                                                  "of every contact): give not both")


def check_forceless(ck, mus, normal, kvs, axes):
    """A contact with mu = 0 (not swept) and a constant normal load exerts no force."""
    for i, mu in enumerate(mus):
        kv = max(axes["kv"]) if "kv" in axes else kvs[i]
        if mu == 0 and "mu" not in axes and not (normal[i] and kv > 0):
            ck.fail(f"scene.contact[{i}].mu", "mu = 0 under a constant normal load: the "
                                              "contact exerts no force (no friction, no "
                                              "normal spring); remove it or give mu > 0")


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
                "([scene.disk] gives the axis; the package's own assembly)")
    if declared and not can_turn:
        ck.fail("scene.effects", "\"centrifugal_stiffening\" needs a turning structure: solid "
                                 "blades in a disk ([scene.disk], the package's own assembly)")
    if speeds and not declared:
        ck.fail(field if "speed" in axes else "scene.disk.speed",
                "a rotation speed stiffens the blades: declare \"centrifugal_stiffening\"")
    if declared and not speeds:
        ck.fail("scene.effects", "\"centrifugal_stiffening\" is declared but nothing turns: "
                                 f"give scene.disk.speed or {field} [rpm] > 0")


def check_optimum_axes(ck, output, axes, wpath):
    """The optimum search varies n0: a sweep that gives the static normal load instead
    would be compared against a different quantity."""
    if output.optimum is not None and "normal_load" in axes:
        ck.fail("output.optimum_preload", f"searches the preload n0, but {wpath}.normal_load "
                                          "gives the static normal load: sweep preload instead")
