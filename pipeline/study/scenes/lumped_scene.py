"""Lumped and disk study files (`studies/*.toml`): schema and strict validation into
a `pipeline.model.scene.Scene` value (a `Lumped` structure, single or `Cyclic`).

A study is a scene (model + physical effects), sweeps (grid axes and one
continuation axis) and solver settings (studies/README.md documents the schema).
Everything a user can get wrong raises `UsageError("<file>: <field>: <what>")`,
where <field> is a dotted path with 0-based list indices (`scene.contact[0].mu`);
the command line prints it as one line and exits 2.  Nothing here runs a solver.

Lumped scene (paper Eq. 5-6, Sec. 6):  M q'' + C q' + K q + Bt^T f_u + Bn^T f_v = F(t),
either from `[scene.matrices]` M, C, K or from `[scene.modal]` data with mode
shapes Phi as columns, modal masses m_r, frequencies w_r [rad/s], ratios z_r:

    M = Phi^-T diag(m) Phi^-1,  K = Phi^-T diag(m w^2) Phi^-1,  C = Phi^-T diag(2 z m w) Phi^-1

Disk scene (`model = "disk"`, `lumped_disk_scene`): the same data for ONE sector of a
tuned disk, `[scene.disk] sectors`, contact rows that may name the next sector's
DOFs (`next.<dof>`), and an engine order (`engine_order` or the sweep axis `eo`);
solved by the one-sector cyclic reduction (`model.cyclic`).

The [solver], [sweep] and shared [output] sections are read by `files.sections`.
"""
from __future__ import annotations

import math
import re
from pathlib import Path
from dataclasses import replace

import numpy as np

from ...contact.registry import study_laws
from ...model.contacts import DofContact
from ...model.loads import Forcing
from ...model.scene import Cyclic, Lumped, Scene, Single, Spring
from . import lumped_disk_scene as disk_scene
from ..files.validation import Checker, join_field
from ..files.header import parse_header, quick_tables
from .law_scene import check_law_methods, check_law_solvers, law_tables, supported
from ..files.rules import check_optimum_axes, check_scene_rules, contact_rules
from ..files.sections import (check_windows, output_common, parse_optimum, parse_solver,
                              parse_sweep, quick_response_tables, solver_sweep_tables)
from .matrix_scene import exported_lumped, ordered, typed_matrices
from ..files.study_types import (EFFECTS, IMPLEMENTED_MODELS, MAX_DOFS, MAX_HARMONICS, MODELS,
                                 NAME_PATTERN, OutputSettings, Study, Sweep)

_SIGNED = re.compile(r"^\s*([+-]?)\s*([A-Za-z_][A-Za-z0-9_.]{0,63})\s*$")


# ---------------------------------------------------------------------------
# Loading (every failure names the file and the field)
# ---------------------------------------------------------------------------


_TOP = ("study", "scene", "sweep", "solver", "output", "quick")


def study_from_mapping(data: dict, *, file: str = "<study>", name: str = "study",
                       text: str = "", quick: bool = False) -> Study:
    """Validate an already-parsed lumped or disk study document (the dict `tomllib`
    returns); `documents.study_from_document` dispatches every kind."""
    ck = Checker(file)
    ck.table(data, "(document)")
    ck.keys(data, "", _TOP, required=("study", "scene", "sweep"))
    header = parse_header(ck, data)

    # the main tables first (a typo there is reported as such), then [quick], and
    # [quick] only when the quick variant is asked for: a full run never depends on it
    scene_tab = ck.table(data["scene"], "scene")
    solver_tab, sweep_tab = solver_sweep_tables(ck, data)
    solver = parse_solver(ck, solver_tab, "solver", model=(model := scene_tab.get("model")))
    sweep_axes, freq = parse_sweep(ck, sweep_tab, "sweep")
    scene = parse_scene(ck, scene_tab)
    if "stability" not in solver_tab and (scene.model == "disk" or not supported(scene.laws, solver.stability)):
        solver = replace(solver, stability="hill")  # one sector's flow is not the wheel's, nor has every law events
    output = _output(ck, ck.table(data.get("output"), "output", required=False), scene)
    variants = [(False, solver, sweep_axes, freq, "solver", "sweep")]
    if quick:
        q_solver, q_sweep = quick_response_tables(ck, quick_tables(ck, data, quick, ("sweep", "solver")),
                                                  sweep_tab)
        q_solver_s = parse_solver(ck, q_solver, "quick.solver", base=solver, model=model)
        q_axes, q_freq = parse_sweep(ck, q_sweep, "quick.sweep", partial=True)
        q_axes = {k: q_axes.get(k, v) for k, v in sweep_axes.items()}
        variants.append((True, q_solver_s, q_axes, q_freq or freq,
                         "quick.solver" if q_solver else "solver",
                         "quick.sweep" if q_sweep else "sweep"))
    chosen = None
    for is_quick, sv, axes, fr, spath, wpath in variants:
        _check_consistency(ck, scene, sv, axes, spath, wpath, data)
        check_optimum_axes(ck, output, axes, wpath)
        st = Study(file=file, name=name, **header, text=text, scene=scene,
                   sweep=Sweep(axes=axes, frequency=fr), solver=sv, output=output,
                   quick=is_quick)
        _check_build(ck, st)
        if is_quick == bool(quick):
            chosen = st
    check_windows(ck, output.peak_windows, freq)
    return chosen


# ---------------------------------------------------------------------------
# The [scene] and [output] of a lumped or disk study
# ---------------------------------------------------------------------------

def parse_scene(ck, tab, loaded: bool = True) -> Scene:
    """The `Scene` of a lumped or disk [scene] table (a `Lumped` structure, single or
    `Cyclic`); failures through ck.  loaded=False (modes): the excitation is optional."""
    if "disk_sector" in tab:
        ck.fail("scene.disk_sector", "a lumped structure has no disk sector to cut: its sectors "
                                     "couple through [[scene.disk.spring]]; a disk sector is an "
                                     "FE blade's (model = \"solid_blade\")")
    ck.keys(tab, "scene", ("model", "effects", "dofs", "matrices", "modal", "contact",
                           "excitation", "disk") + tuple(study_laws()), required=("model",))
    model = ck.string(tab["model"], "scene.model", MODELS)
    if model not in IMPLEMENTED_MODELS:
        ck.fail("scene.model", f"{model!r} is not implemented yet (available: "
                               f"{', '.join(IMPLEMENTED_MODELS)})")
    disk = model == "disk"  # one sector of a cyclic disk: pipeline/study/scenes/lumped_disk_scene.py
    if disk:
        sectors, engine_order, mistuning = disk_scene.parse_disk(ck, tab)
    elif "disk" in tab:
        ck.fail("scene.disk", "only a disk scene (model = \"disk\") has a [scene.disk] table")
    effects = ck.names(tab.get("effects", []), "scene.effects", min_length=0)
    for i, e in enumerate(effects):
        if e not in EFFECTS:
            ck.fail(f"scene.effects[{i}]", f"unknown effect {e!r} (known: {', '.join(EFFECTS)})")
    if ("matrices" in tab) == ("modal" in tab):
        ck.fail("scene", "give exactly one of [scene.matrices] and [scene.modal]")
    exported = exported_lumped(ck, tab, Path(ck.file).parent)   # M, C, K, DOFs from files
    if "dofs" not in tab and exported is None:
        ck.fail("scene.dofs", "missing (required): the names of the DOFs, e.g. [\"x1\", \"x2\"]")
    dofs = ck.names(tab["dofs"], "scene.dofs") if "dofs" in tab else exported[3]
    if disk:
        disk_scene.check_dof_names(ck, dofs)
    n = len(dofs)
    if n > MAX_DOFS:
        ck.fail("scene.dofs", f"a lumped scene has at most {MAX_DOFS} DOFs, got {n}")
    if exported is not None:
        M, C, K = ordered(ck, exported, dofs)
    elif "matrices" in tab:
        M, C, K = typed_matrices(ck, ck.table(tab["matrices"], "scene.matrices"), n)
    else:
        M, C, K = _modal(ck, ck.table(tab["modal"], "scene.modal"), n)
    contacts_raw = tab.get("contact", [])
    if isinstance(contacts_raw, dict):
        ck.fail("scene.contact", "must be an array of tables: write [[scene.contact]]")
    ck.array(contacts_raw, "scene.contact", min_length=0)
    if disk:  # rows may name the next sector's DOFs, `next.<dof>`
        cdofs = dofs + tuple(disk_scene.NEXT + d for d in dofs)
        contacts_raw = [{k: disk_scene.contact_rows(v) if k in ("tangential", "normal") else v
                         for k, v in c.items()} if isinstance(c, dict) else c
                        for c in contacts_raw]
    else:
        cdofs = dofs
    contacts = tuple(_contact(ck, c, f"scene.contact[{i}]", cdofs, i)
                     for i, c in enumerate(contacts_raw))
    springs = _springs(ck, tab["disk"].get("spring", []), cdofs) if disk else ()
    names = [c.name for c in contacts]
    for i, nm in enumerate(names):
        if nm in names[:i]:
            ck.fail(f"scene.contact[{i}].name", f"duplicate contact name {nm!r}")
    if "excitation" not in tab and loaded:
        ck.fail("scene.excitation", "missing (required): at least one [[scene.excitation]]")
    forcing = (_excitation(ck, tab["excitation"], dofs) if "excitation" in tab
               else np.zeros((n, 2), complex))
    assembly = (Cyclic(sectors=sectors, engine_order=engine_order, mistuning=mistuning,
                       springs=springs) if disk else Single())
    laws = law_tables(ck, tab, dofs, effects, disk, _signed_row)
    return Scene(structure=Lumped(M=M, C=C, K=K, dofs=dofs), contacts=contacts,
                 loads=(Forcing(forcing),), assembly=assembly, effects=effects, model=model,
                 laws=laws)


def _modal(ck, t, n):
    f = "scene.modal"
    ck.keys(t, f, ("masses", "frequencies", "damping_ratios", "mode_shapes"),
            required=("masses", "frequencies", "damping_ratios", "mode_shapes"))
    m = ck.numbers(t["masses"], f"{f}.masses", n, gt=0.0)
    w = ck.numbers(t["frequencies"], f"{f}.frequencies", n, gt=0.0)
    z = ck.numbers(t["damping_ratios"], f"{f}.damping_ratios", n, ge=0.0)
    Phi = ck.matrix(t["mode_shapes"], f"{f}.mode_shapes", n)
    s = np.linalg.svd(Phi, compute_uv=False)
    if s.min() <= 1e-10 * s.max():
        ck.fail(f"{f}.mode_shapes", "must be invertible (the columns are the mode shapes, "
                                    "one row per DOF)")
    Pinv = np.linalg.inv(Phi)

    def sym(d):
        A = Pinv.T @ np.diag(d) @ Pinv
        return 0.5 * (A + A.T)

    return sym(m), sym(2.0 * z * m * w), sym(m * w**2)


def _signed_row(ck, value, field, dofs, required):
    row = np.zeros(len(dofs))
    if value is None:
        if required:
            ck.fail(field, "missing (required)")
        return row
    if isinstance(value, dict):
        if not value:
            ck.fail(field, "must not be empty")
        for name, coef in value.items():
            if name not in dofs:
                ck.fail(join_field(field, name), f"unknown DOF (DOFs: {', '.join(dofs)})")
            row[dofs.index(name)] = ck.number(coef, join_field(field, name))
    else:
        items = ck.array(value, field)
        for i, item in enumerate(items):
            s = ck.string(item, f"{field}[{i}]")
            m = _SIGNED.match(s)
            if not m:
                ck.fail(f"{field}[{i}]", f"{s!r} is not a DOF name with an optional sign, "
                                         "e.g. \"x1\" or \"-x2\"")
            sign, name = m.groups()
            if name not in dofs:
                ck.fail(f"{field}[{i}]", f"unknown DOF {name!r} (DOFs: {', '.join(dofs)})")
            j = dofs.index(name)
            if row[j] != 0:
                ck.fail(f"{field}[{i}]", f"DOF {name!r} appears twice")
            row[j] = -1.0 if sign == "-" else 1.0
    if not np.any(row):
        ck.fail(field, "all coefficients are zero")
    return row


def _contact(ck, c, f, dofs, i) -> DofContact:
    c = ck.table(c, f)
    ck.keys(c, f, ("name", "tangential", "normal", "ku", "kv", "mu", "n0"),
            required=("tangential", "ku", "mu"))
    name = ck.string(c.get("name", f"contact{i}"), f"{f}.name", pattern=NAME_PATTERN)
    bt = _signed_row(ck, c["tangential"], f"{f}.tangential", dofs, True)
    bn = _signed_row(ck, c.get("normal"), f"{f}.normal", dofs, False)
    ku = ck.number(c["ku"], f"{f}.ku", gt=0.0)
    kv = ck.number(c.get("kv", 0.0), f"{f}.kv", ge=0.0)
    mu = ck.number(c["mu"], f"{f}.mu", ge=0.0)
    n0 = ck.number(c["n0"], f"{f}.n0") if "n0" in c else None
    if kv > 0 and not np.any(bn):
        ck.fail(f"{f}.kv", f"kv = {kv:g} N/m needs normal DOFs (`normal = [...]`)")
    return DofContact(name=name, bt=bt, bn=bn, ku=ku, kv=kv, mu=mu, n0=n0)


def _springs(ck, raw, cdofs) -> tuple:
    """`[[scene.disk.spring]]`: linear springs between neighbouring sectors, each
    stretching by a row over this sector's and the next sector's DOFs."""
    f = "scene.disk.spring"
    if isinstance(raw, dict):
        ck.fail(f, "must be an array of tables: write [[scene.disk.spring]]")
    out = []
    for i, c in enumerate(ck.array(raw, f, min_length=0)):
        c = ck.table(c, f"{f}[{i}]")
        ck.keys(c, f"{f}[{i}]", ("name", "elongation", "k"), required=("elongation", "k"))
        name = ck.string(c.get("name", f"spring{i}"), f"{f}[{i}].name", pattern=NAME_PATTERN)
        row = _signed_row(ck, disk_scene.contact_rows(c["elongation"]),
                          f"{f}[{i}].elongation", cdofs, True)
        if not np.any(row[len(cdofs) // 2:]):
            ck.fail(f"{f}[{i}].elongation", "a spring between sectors names a DOF of the next "
                                            "sector (next.<dof>); one within a sector "
                                            "belongs in K")
        out.append(Spring(name=name, row=row, k=ck.number(c["k"], f"{f}[{i}].k", gt=0.0)))
    return tuple(out)


def _excitation(ck, raw, dofs) -> np.ndarray:
    if isinstance(raw, dict):
        ck.fail("scene.excitation", "must be an array of tables: write [[scene.excitation]]")
    items = ck.array(raw, "scene.excitation")
    entries, seen = [], set()
    for i, e in enumerate(items):
        f = f"scene.excitation[{i}]"
        e = ck.table(e, f)
        ck.keys(e, f, ("dof", "amplitude", "harmonic", "phase"), required=("dof", "amplitude"))
        dof = ck.string(e["dof"], f"{f}.dof")
        if dof not in dofs:
            ck.fail(f"{f}.dof", f"unknown DOF {dof!r} (DOFs: {', '.join(dofs)})")
        amp = ck.number(e["amplitude"], f"{f}.amplitude")
        h = ck.integer(e.get("harmonic", 1), f"{f}.harmonic", 0, MAX_HARMONICS)
        phase = ck.phase(e.get("phase", 0.0), f"{f}.phase")
        if h == 0 and phase != 0.0:
            ck.fail(f"{f}.phase", "a static load (harmonic = 0) has no phase")
        if (dof, h) in seen:
            ck.fail(f, f"DOF {dof!r} is excited twice at harmonic {h}")
        seen.add((dof, h))
        entries.append((dofs.index(dof), h, amp * complex(math.cos(phase), math.sin(phase))))
    F = np.zeros((len(dofs), max(h for _, h, _ in entries) + 1), dtype=complex)
    for j, h, a in entries:
        F[j, h] = a
    if not np.any(F):
        ck.fail("scene.excitation", "every amplitude is zero: nothing excites the structure")
    return F


def _output(ck, t, scene) -> OutputSettings:
    ck.keys(t, "output", ("dofs", "figures", "yscale", "peak_windows", "optimum_preload",
                          "curves"))
    if scene.mistuning is not None:  # every sector's DOFs, "x1@3"
        dofs = disk_scene.output_dofs(ck, t, scene)
        if "optimum_preload" in t:
            ck.fail("output.optimum_preload", "the optimum-preload search is not available for "
                                              "a mistuned disk")
    else:
        dofs = ck.names(t["dofs"], "output.dofs") if "dofs" in t else scene.dofs
    for i, d in enumerate(dofs):
        if d not in scene.dofs:
            ck.fail(f"output.dofs[{i}]", f"unknown DOF {d!r} (DOFs: {', '.join(scene.dofs)})")
    figs, yscale, windows = output_common(ck, t)
    optimum = parse_optimum(ck, t, scene)
    return OutputSettings(dofs=tuple(dofs), figures=tuple(figs), yscale=yscale,
                          peak_windows=tuple(windows), optimum=optimum,
                          curves=disk_scene.parse_curves(ck, t, scene, windows))


def _check_consistency(ck, scene, solver, axes, spath, wpath, data):
    """Cross-field rules of a lumped or disk scene (`check_scene_rules`,
    `lumped_disk_scene.check_disk_rules`, `check_law_solvers`)."""
    check_law_solvers(ck, scene.laws, solver.stability, f"{spath}.stability")
    check_law_methods(ck, scene.laws, solver.force_evaluation, f"{spath}.force_evaluation")
    disk = scene.model == "disk"
    if disk:
        disk_scene.check_disk_rules(ck, scene, axes, wpath, data)
    check_scene_rules(ck, scene.effects, contact_rules(scene),
                      scene.loads[0].amplitudes.shape[1] - 1, solver.harmonics, axes, spath, wpath,
                      disk=disk)


def _check_build(ck, study: Study):
    # Safety net: the System constructors must accept every case we validated.
    try:
        for _, case in study.sweep.cases()[:1] + study.sweep.cases()[-1:]:
            study.system(case)
    except ValueError as exc:
        ck.fail("scene", str(exc))
