"""Disk scenes of study files: `[scene] model = "disk"`, a tuned lumped bladed disk.

A disk scene is one lumped SECTOR (`dofs`, `[scene.matrices]` or `[scene.modal]`,
as in a lumped scene), repeated `sectors` = N times around the disk
(`[scene.disk]`), with Yang-Menq elements (paper Eq. 1, 9, 10) that may also act
on the NEXT sector's DOFs: a DOF name `next.<dof>` in `tangential` / `normal`
means that DOF of sector j+1, so a shroud pair reads

    tangential = ["next.x2", "-x2"]        # u = x2_{j+1} - x2_j

Declaring such an element is the effect "cyclic_coupling".  The excitation acts
on sector 0; sector j gets it shifted by the engine order EO,
F_j(tau) = F_0(tau + j phi), phi = 2 pi EO / N (a first-harmonic load has the phase
j phi).  EO is `[scene.disk] engine_order` or the sweep axis `eo`, an integer in
0 <= EO <= N/2 (N - EO is the same wave travelling the other way; EO >= N repeats
EO mod N).  Each case is solved on ONE sector by the cyclic reduction
(`pipeline.model.cyclic.sector_system`, Petrov 2004): only the sector is built, never
the N-sector assembly (`pipeline.model.build.full_system` gives it, for checks).

Linear springs between neighbouring sectors (a flexible disk; effect
"disk_coupling"): `[[scene.disk.spring]] elongation = ["next.xd", "-xd"], k = ...`
[N/m], a row over this sector's and the next sector's DOFs like a contact's; they
enter each harmonic's stiffness, K + e^{i h phi} K_next + e^{-i h phi} K_next^T
(`cyclic.spring_stiffness`), and add no nonlinear unknown.

Mistuning (effect "mistuning", `[scene.disk] mistuning = {stiffness_std, seed}`,
seed or the sweep axis `mistuning_seed`): sector j has the stiffness
(1 + delta_j) K, delta_j ~ N(0, stiffness_std^2) from `numpy.random.default_rng(seed)`
(`cyclic.mistuning_factors`).  Cyclic symmetry is broken, so each case is the full
N-sector assembly (`cyclic.full_assembly`, N n DOFs, `System.cyclic` None) under the
same engine-order load, and the scene's `dofs` are every sector's DOFs, labelled
`<dof>@<sector>` (`x1@3`: x1 of sector 3), sector-major as in the assembly.  A
study is mistuned in all its cases or in none; its dataset reports the response
per sector on a `sector` dimension, with the sector's DOF names on `dof`.
"""
from __future__ import annotations

from ...model.scene import AT, Mistuning, NEXT, Scene
MAX_SECTORS = 10_000
# the assembly of a mistuned disk is stored sparse (O(N)), but its condensed
# harmonic-balance Jacobian (N nc (2H+1))^2, its natural frequencies and Hill's
# stability are dense in all sectors' DOFs: they bound N
MAX_MISTUNED_SECTORS = 200
MAX_STIFFNESS_STD = 0.5


# ---------------------------------------------------------------------------
# Validation (called by lumped_scene.py; every mistake is `<file>: <field>: <what>`)
# ---------------------------------------------------------------------------

def check_dof_names(ck, dofs):
    for i, d in enumerate(dofs):
        if d.startswith(NEXT) or d == NEXT[:-1]:
            ck.fail(f"scene.dofs[{i}]", f"{d!r}: the prefix {NEXT!r} is reserved for the next "
                                        "sector's DOFs in a disk scene")


def contact_rows(value):
    """Nested tables from TOML dotted keys, {next = {x2 = -1}}, as "next.x2" entries."""
    if isinstance(value, dict) and isinstance(value.get(NEXT[:-1]), dict):
        flat = {k: v for k, v in value.items() if k != NEXT[:-1]}
        flat.update({NEXT + k: v for k, v in value[NEXT[:-1]].items()})
        return flat
    return value


def parse_disk(ck, tab) -> tuple:
    """(sectors, engine_order or None, Mistuning or None) of a `[scene.disk]` table."""
    if "disk" not in tab:
        ck.fail("scene.disk", "missing table (required for model = \"disk\"): "
                              "[scene.disk] sectors = N")
    t = ck.table(tab["disk"], "scene.disk")
    ck.keys(t, "scene.disk", ("sectors", "engine_order", "mistuning", "spring"),
            required=("sectors",))
    N = ck.integer(t["sectors"], "scene.disk.sectors", 2, MAX_SECTORS)
    eo = check_engine_order(ck, t["engine_order"], "scene.disk.engine_order", N) \
        if "engine_order" in t else None
    mis = parse_mistuning(ck, t["mistuning"], N) if "mistuning" in t else None
    return N, eo, mis


def parse_mistuning(ck, value, N) -> Mistuning:
    f = "scene.disk.mistuning"
    if not isinstance(value, dict):
        ck.fail(f, "must be a table, e.g. mistuning = { stiffness_std = 0.02, seed = 1 }")
    ck.keys(value, f, ("stiffness_std", "seed", "factors"))
    if N > MAX_MISTUNED_SECTORS:
        ck.fail(f, f"a mistuned disk is solved on all sectors at once (dense Jacobian, natural "
                   f"frequencies and stability of every sector's DOFs): at most "
                   f"{MAX_MISTUNED_SECTORS} sectors, got {N}")
    if "factors" in value:
        return given_factors(ck, value, f, N)
    if "stiffness_std" not in value:
        ck.fail(f"{f}.stiffness_std", "missing: give stiffness_std (random factors from a seed) "
                                      f"or factors = [f_0, ..., f_{N - 1}]")
    std = ck.number(value["stiffness_std"], f"{f}.stiffness_std", ge=0.0)
    if std >= MAX_STIFFNESS_STD:
        ck.fail(f"{f}.stiffness_std", f"relative standard deviation {std:g} is too large "
                                      "(sector stiffnesses could turn negative); give "
                                      f"0 <= std < {MAX_STIFFNESS_STD:g}")
    seed = ck.integer(value["seed"], f"{f}.seed", 0, 1 << 30) if "seed" in value else None
    return Mistuning(stiffness_std=std, seed=seed)


def given_factors(ck, value, f, N) -> Mistuning:
    """`mistuning = { factors = [...] }`: N positive stiffness factors, sector order."""
    for k in ("stiffness_std", "seed"):
        if k in value:
            ck.fail(f"{f}.{k}", "the factors are given: no random draw (give factors, or "
                                "stiffness_std and a seed)")
    vals = ck.numbers(value["factors"], f"{f}.factors", gt=0.0)
    if len(vals) != N:
        ck.fail(f"{f}.factors", f"one factor per sector: {N} values, got {len(vals)}")
    return Mistuning(factors=tuple(float(v) for v in vals))


def check_engine_order(ck, value, field, N) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        ck.fail(field, f"the engine order must be an integer, got {value!r}")
    if value < 0:
        ck.fail(field, f"the engine order must be >= 0, got {value}")
    if value >= N:
        ck.fail(field, f"engine order {value} is not smaller than the number of sectors {N} "
                       f"(EO and EO mod N are the same excitation); give 0 <= EO <= {N // 2}")
    if 2 * value > N:
        ck.fail(field, f"engine order {value} > N/2 = {N / 2:g}: it is the backward wave of "
                       f"EO = {N - value}; give 0 <= EO <= {N // 2}")
    return int(value)


def check_disk_rules(ck, scene: Scene, axes, wpath, data):
    """EO given once (scene or sweep) and within 0..N/2; "cyclic_coupling" declared
    exactly when an element reaches the next sector; the optimum-preload search
    needs a fixed engine order."""
    if "eo" in axes:
        for i, eo in enumerate(axes["eo"]):
            check_engine_order(ck, eo, f"{wpath}.eo[{i}]", scene.assembly.sectors)
        if scene.assembly.engine_order is not None:
            ck.fail(f"{wpath}.eo", "the engine order is set twice: [scene.disk] engine_order "
                                   "and the sweep axis eo")
    elif scene.assembly.engine_order is None:
        ck.fail("scene.disk.engine_order", "missing: give [scene.disk] engine_order or the "
                                           "sweep axis eo = [...]")
    if scene.coupled != ("cyclic_coupling" in scene.effects):
        ck.fail("scene.effects", "a contact reaches the next sector (next.<dof>): declare "
                                 "\"cyclic_coupling\"" if scene.coupled else
                "\"cyclic_coupling\" is declared but no contact reaches the next sector "
                "(DOF names next.<dof>)")
    springs = bool(scene.assembly.springs)
    if springs != ("disk_coupling" in scene.effects):
        ck.fail("scene.effects", "[[scene.disk.spring]] couples neighbouring sectors "
                                 "linearly: declare \"disk_coupling\"" if springs else
                "\"disk_coupling\" is declared but [scene.disk] has no [[scene.disk.spring]]")
    out = data.get("output") if isinstance(data, dict) else None
    if isinstance(out, dict) and "optimum_preload" in out and scene.assembly.engine_order is None:
        ck.fail("output.optimum_preload", "the optimum search runs at one engine order: "
                                          "give [scene.disk] engine_order")
    check_mistuning_rules(ck, scene, axes, wpath, out)


def check_mistuning_rules(ck, scene: Scene, axes, wpath, out):
    """"mistuning" declared exactly when `[scene.disk] mistuning` is given; its seed
    given once (table or sweep axis `mistuning_seed`)."""
    mis = scene.mistuning
    declared = "mistuning" in scene.effects
    if mis is not None and "normal_load" in axes:
        ck.fail(f"{wpath}.normal_load", "a static normal load per contact is solved on one "
                                        "sector: not available for a mistuned disk")
    if mis is None:
        if "mistuning_seed" in axes:
            ck.fail(f"{wpath}.mistuning_seed", "the disk is tuned: give [scene.disk] mistuning "
                                               "= { stiffness_std = ... } (and declare "
                                               "\"mistuning\")")
        if declared:
            ck.fail("scene.effects", "\"mistuning\" is declared but [scene.disk] has no "
                                     "mistuning = { stiffness_std = ..., seed = ... }")
        return
    if not declared:
        ck.fail("scene.effects", "[scene.disk] mistuning breaks cyclic symmetry: declare "
                                 "\"mistuning\"")
    if mis.factors is not None:
        if "mistuning_seed" in axes:
            ck.fail(f"{wpath}.mistuning_seed", "the mistuning factors are given "
                                               "([scene.disk] mistuning.factors): nothing to draw")
    elif "mistuning_seed" in axes:
        if mis.seed is not None:
            ck.fail(f"{wpath}.mistuning_seed", "the mistuning seed is set twice: [scene.disk] "
                                               "mistuning.seed and the sweep axis "
                                               "mistuning_seed")
    elif mis.seed is None:
        ck.fail("scene.disk.mistuning.seed", "missing: give mistuning.seed or the sweep axis "
                                             "mistuning_seed = [...]")
    if isinstance(out, dict) and "optimum_preload" in out:
        ck.fail("output.optimum_preload", "the optimum-preload search is not available for a "
                                          "mistuned disk")


def output_dofs(ck, t, scene: Scene) -> tuple:
    """`[output] dofs` of a mistuned disk: a sector DOF name ("x1") stands for that
    DOF in every sector ("x1@0" ... "x1@<N-1>"); "x1@3" names one sector's."""
    raw = t["dofs"] if "dofs" in t else list(scene.sector_dofs)
    vals = ck.array(raw, "output.dofs")
    out = []
    for i, d in enumerate(vals):
        d = ck.string(d, f"output.dofs[{i}]")
        if d in scene.sector_dofs:
            out.extend(f"{d}{AT}{j}" for j in range(scene.assembly.sectors))
        elif d in scene.dofs:
            out.append(d)
        else:
            ck.fail(f"output.dofs[{i}]", f"unknown DOF {d!r} (a sector DOF, "
                                         f"{', '.join(scene.sector_dofs)}, for every sector, "
                                         f"or one sector's, e.g. {scene.dofs[-1]!r})")
    for i, d in enumerate(out):
        if d in out[:i]:
            ck.fail("output.dofs", f"DOF {d!r} is reported twice")
    return tuple(out)


def parse_curves(ck, t, scene, windows) -> bool:
    """`[output] curves` (default true); false (each case keeps its DOFs' largest
    peaks: a Monte-Carlo sample of a mistuned disk) only for a mistuned disk and
    without peak windows (which read the curves)."""
    if "curves" not in t:
        return True
    curves = ck.boolean(t["curves"], "output.curves")
    if not curves and getattr(scene, "mistuning", None) is None:
        ck.fail("output.curves", "false keeps each sector's largest peak only: for a "
                                 "mistuned disk (give [scene.disk] mistuning)")
    if not curves and windows:
        ck.fail("output.curves", "false keeps the largest peaks only; peak_windows read the "
                                 "curves")
    return curves
