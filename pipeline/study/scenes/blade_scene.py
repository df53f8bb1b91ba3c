"""Blade scenes of study files: `[scene] model = "solid_blade"` or `"beam_blade"`.

A blade scene is an FE blade (`fe_model`, generated from `[scene.blade]` = the
fields of `BladeParams`, or read from `mesh = "file"`), reduced by Craig-Bampton
(`reduction`, the contact faces, excitation and response DOFs kept physical), with
Yang-Menq elements between its shroud contact faces and RIGID neighbours:

    M_r q'' + C_r q' + K_r q + Bt_r^T f_u + Bn_r^T f_v = T^T F(t),
    Bt_r = Bt T,  Bn_r = Bn T  (`reduction.reduce_map`),

one element per contact-face node k with u_k = t . d_k (face tangent) and
v_k = n . d_k (outward normal: v > 0 closes the gap, as `fe_model.ContactFrame`
defines).  `mu` is per node.  With `stiffness = "per_node"` (the default) `ku`, `kv`
[N/m] are per node and the preload `n0` [N] is the TOTAL normal load of the face,
n0_k = n0 / (number of face nodes); the face stiffness then grows with the mesh.
With `stiffness = "per_face"`, ku, kv and n0 are all face totals, shared by the
nodes in proportion to the area they carry, a_k = int_face N_k dA
(`ContactFrame.weights`): ku_k = ku a_k / A, kv_k = kv a_k / A, n0_k = n0 a_k / A.
That is a uniform contact pressure and stiffness per area, the same on every mesh
(a row-sum lumping of the consistent face stiffness).  Damping is modal
(`damping_ratios` of `[scene.blade]`, on the reduced modes) or Rayleigh
C = alpha M + beta K (`rayleigh = [alpha, beta]`), whose projection is exact, so the
reduced and the unreduced model then carry the same damping.

Two study kinds (`[study] kind`, default "modes" when a `[modes]` table is given,
else "response"):
- "modes": full vs Craig-Bampton eigenfrequencies against the mode count, with
  timings, and the mode shapes as VTU (`modes_study.run_modes_study`);
- "response": frequency-response continuation per sweep case, the same command,
  dataset and figures as the lumped scenes (`scene.Study` with a `Scene`).

Validation follows `lumped_scene.py`: every mistake is `UsageError("<file>: <field>: <what>")`.
"""
from __future__ import annotations

import logging
import math
import re
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

from ...errors import UsageError
from ...model.contacts import FaceContact
from ...model.loads import PointLoad, point_forcing
from ...model.scene import Blade, Scene
from ...model.blade_cache import blade_model
from ...structure.fe_model import SHAPE_BOUNDS, BladeParams, boundary_dofs
from ...structure.mesh_io import read_mesh
from ...structure.reduction import DEFAULT_MODES
from . import blade_wheel_scene as blade_disk
from . import lumped_disk_scene as disk_scene
from .blade_size import check_blade_size, check_material, mesh_units
from .matrix_scene import scene_matrices
from ..files.validation import Checker
from ..files.rules import check_optimum_axes, check_scene_rules, contact_rules
from ..files.header import overlay, parse_header, quick_tables
from ..files.sections import (check_windows, output_common, parse_optimum, parse_solver,
                              parse_sweep, quick_response_tables, solver_sweep_tables)
from ..files.study_types import (EFFECTS, MAX_HARMONICS, NAME_PATTERN, ModesStudy, OutputSettings,
                                 Study, Sweep)

log = logging.getLogger(__name__)

BLADE_MODELS = ("solid_blade", "beam_blade")
FACES = ("shroud_left", "shroud_right")
POINTS = ("excitation", "response")
STIFFNESS = ("per_node", "per_face")  # how ku, kv of a face contact are given
COMPONENTS = "xyz"
DEFAULT_MODE_COUNTS = (0, 5, 10, 20, 40)
# an output DOF of a blade study: a direction at the excitation or response node set
OUT_DOF_PATTERN = re.compile(r"^(excitation|response)\.([xyz])$")
# BladeParams fields a study may set (kind comes from the model)
_FLOAT_FIELDS = ("length", "chord", "thickness", "shroud_chord", "shroud_width", "shroud_height",
                 "shroud_angle", "stagger_angle", "E", "nu", "rho")
_INT_FIELDS = ("n_chord", "n_thick", "n_span")
_BLADE_KEYS = _FLOAT_FIELDS + _INT_FIELDS + tuple(SHAPE_BOUNDS) + ("damping_ratios", "shroud")
_MAX_ELEMENTS = 200_000


# ---------------------------------------------------------------------------
# Plain data
# ---------------------------------------------------------------------------


# ---------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------

def is_blade_document(data) -> bool:
    """A document of an FE blade scene (single or in a disk)."""
    return (isinstance(data, dict) and isinstance(data.get("scene"), dict)
            and data["scene"].get("model") in BLADE_MODELS)


TOP = ("study", "scene", "sweep", "solver", "output", "quick", "modes")


def base_dir_of(file: str) -> Path:
    """The folder mesh files are relative to: the study file's."""
    return Path(file).parent if file and not file.startswith("<") else Path(".")


def scene_field(path: str) -> str:
    """The field of a path inside [scene] (a quick override names its own, `header.overlay`)."""
    return f"scene.{path}"


def response_from_mapping(data: dict, *, file: str, name: str, text: str = "",
                          quick: bool = False) -> Study:
    """Validate a blade response study document: a `study_types.Study`."""
    ck = Checker(file)
    ck.keys(data, "", TOP, required=("study", "scene"))
    header = parse_header(ck, data)
    if "modes" in data:
        ck.fail("modes", "only a modes study (study.kind = \"modes\") has a [modes] table")
    if "sweep" not in data:
        ck.fail("sweep", "missing table (required)")
    qt = quick_tables(ck, data, quick, ("scene", "sweep", "solver"))
    full_scene, quick_scene = blade_scenes(ck, data, qt, base_dir_of(file))
    scene = quick_scene if quick else full_scene
    solver_tab, sweep_tab = solver_sweep_tables(ck, data)
    solver = parse_solver(ck, solver_tab, "solver", model=scene.model)
    if "stability" not in solver_tab:
        # the fold rule unless asked (`solve.stability.fold_rule`: a verdict at each branch's ends
        # where it is cheap, flipped at every fold; no cost on the shipped studies).
        # `stability = true` selects "stretch" (a few points of each stretch between
        # folds decided by the orbit monodromy): on the quick blade study about 60 s
        # (61 %), on the full blade with 102 sliding node pairs over 12 min a case
        # against about 45 s for the study; Hill over every wave number of a blade
        # disk 870-910 s a quick case against 20-30 s
        # 2D friction has no event-driven flow for the fold rule's ends: none unless asked
        solver = replace(solver, stability=False if blade_disk.plane_friction(scene.contacts)
                         else "folds")
    axes, freq = parse_sweep(ck, sweep_tab, "sweep")
    output = _output(ck, ck.table(data.get("output"), "output", required=False), scene)
    variants = [(False, solver, axes, freq, "solver", "sweep", full_scene)]
    if quick:
        q_solver, q_sweep = quick_response_tables(ck, qt, sweep_tab)
        q_solver_s = parse_solver(ck, q_solver, "quick.solver", base=solver, model=scene.model)
        q_axes, q_freq = parse_sweep(ck, q_sweep, "quick.sweep", partial=True)
        q_axes = {k: q_axes.get(k, v) for k, v in axes.items()}
        variants.append((True, q_solver_s, q_axes, q_freq or freq,
                         "quick.solver" if q_solver else "solver",
                         "quick.sweep" if q_sweep else "sweep", quick_scene))
    chosen = None
    for is_quick, sv, ax, fr, spath, wpath, sc in variants:
        _consistency(ck, scene, sv, ax, spath, wpath, data)  # the rules need no mesh: the
        # model run is checked (--quick builds and reduces the quick blade only)
        check_optimum_axes(ck, output, ax, wpath)
        blade_disk.check_interference_search(ck, scene.contacts, output.optimum, ax, wpath)
        st = Study(file=file, name=name, **header, text=text, scene=sc,
                   sweep=Sweep(axes=ax, frequency=fr), solver=sv, output=output, quick=is_quick)
        if is_quick == bool(quick):
            chosen = st
    check_windows(ck, output.peak_windows, freq)
    return chosen


def modes_from_mapping(data: dict, *, file: str, name: str, text: str = "",
                       quick: bool = False) -> ModesStudy:
    """Validate a blade modes study document: a `ModesStudy`."""
    ck = Checker(file)
    ck.keys(data, "", TOP, required=("study", "scene"))
    header = parse_header(ck, data)
    for k in ("sweep", "solver", "output"):
        if k in data:
            ck.fail(k, "not used by a modes study (study.kind = \"modes\")")
    qt = quick_tables(ck, data, quick, ("scene", "modes"))
    full_scene, quick_scene = blade_scenes(ck, data, qt, base_dir_of(file), contacts=False)
    scene = quick_scene if quick else full_scene
    mt = ck.table(data.get("modes"), "modes", required=False)
    full = _modes(ck, mt, lambda p: f"modes.{p}", full_scene, built=full_scene is scene)
    if not quick:
        counts, nf, ns = full
    else:
        counts, nf, ns = _modes(ck, *overlay(ck, mt, qt.get("modes", {}), "modes"), quick_scene)
    return ModesStudy(file=file, name=name, **header, text=text, scene=scene,
                      mode_counts=counts, n_frequencies=nf, n_shapes=ns, quick=bool(quick))


def blade_scenes(ck, data, quick: dict, base_dir, contacts: bool = True,
                 loaded: bool = True) -> tuple:
    """(scene of the full study, scene of its [quick] variant: the [quick.scene]
    overrides of blade, craig_bampton_modes and mesh merged in, errors naming them).
    `quick` holds the [quick] tables of a --quick load ({} otherwise); when they change
    the scene, the full scene's tables are validated without building its blade.
    `contacts`: the scene has contacts and excitation; `loaded`: an excitation is required."""
    scene_tab = ck.table(data["scene"], "scene")
    q_scene = quick.get("scene", {})
    parts = dict(contacts=contacts, loaded=loaded)
    full_scene = parse_blade_scene(ck, scene_tab, base_dir, build=not q_scene, **parts)
    if not q_scene:
        return full_scene, full_scene
    ck.keys(q_scene, "quick.scene", ("blade", "craig_bampton_modes", "mesh"))
    merged, where = overlay(ck, scene_tab, q_scene, "scene", deep=("blade",))
    return full_scene, parse_blade_scene(ck, merged, base_dir, where, **parts)


def parse_blade_params(ck, t, model, field=scene_field):
    """`fe_model.BladeParams` of the [scene.blade] table `t` for `model`, refusing a
    mesh too fine to generate; `field(path)` is the field of a path inside [scene]
    (a quick override names its own, `header.overlay`), for the error message."""
    def where(k):
        return field(f"blade.{k}")

    allowed = _BLADE_KEYS
    for k in t:
        if k not in allowed:
            ck.keys({k: None}, where(k).rpartition(".")[0], allowed)
    kw = {}
    for k, v in t.items():
        if k in ("shroud_angle", "stagger_angle"):
            kw[k] = ck.number(v, where(k), gt=-math.pi / 2, lt=math.pi / 2)
        elif k == "nu":
            kw[k] = ck.number(v, where(k), gt=-1.0, lt=0.5)
        elif k in SHAPE_BOUNDS:
            kw[k] = ck.number(v, where(k), ge=SHAPE_BOUNDS[k][0], le=SHAPE_BOUNDS[k][1])
        elif k in _FLOAT_FIELDS:
            kw[k] = ck.number(v, where(k), gt=0.0)
        elif k in _INT_FIELDS:
            kw[k] = ck.integer(v, where(k), 1, 1000)
        elif k == "shroud":
            kw[k] = ck.boolean(v, where(k))
        elif k == "damping_ratios":
            kw[k] = tuple(ck.numbers(v, where(k), ge=0.0, lt=1.0))
    kw["kind"] = "beam" if model == "beam_blade" else "solid"
    if kw["kind"] == "solid":  # guard the structured mesh size before generating it
        d = {f.name: f.default for f in fields(BladeParams)}
        g = {**d, **kw}
        hx, hz = g["chord"] / g["n_chord"], g["length"] / g["n_span"]
        nx = math.ceil(max(g["chord"], g["shroud_chord"]) / hx) + 2
        ny = g["n_thick"] + 2 * max(1, round(max(g["shroud_width"] - g["thickness"], 0) / 2 / hx))
        nz = g["n_span"] + max(1, round(g["shroud_height"] / hz))
        n_el = nx * ny * nz
        if n_el > _MAX_ELEMENTS:
            ck.fail("scene.blade", f"mesh too fine (about {n_el:.3g} hexahedra > "
                                   f"{_MAX_ELEMENTS}): fewer elements or a less extreme shroud")
    try:
        return BladeParams(**kw)
    except ValueError as exc:
        msg = str(exc)
        key = msg.split(" ", 1)[0]
        ck.fail(where(key) if key in _BLADE_KEYS else "scene.blade", msg)


def parse_blade_scene(ck, tab, base_dir, fld=scene_field, build: bool = True,
                      contacts: bool = True, loaded: bool = True) -> Scene:
    """The `Scene` of a [scene] table, mesh files relative to `base_dir`; the blade is
    built once to check node sets, faces and mode counts (`build`; without it the
    tables only).  `fld`: as `field` of `parse_blade_params`.  `contacts`: the scene
    has contacts and excitation (a response or a disk's modes; a blade's modes have
    none); `loaded`: an excitation is required (a response)."""
    allowed = ("model", "effects", "blade", "mesh", "units", "matrices",
               "craig_bampton_modes", "rayleigh", "disk", "disk_sector")
    if contacts:
        allowed += ("contact", "excitation")
    ck.keys(tab, "scene", allowed, required=("model",))
    model = ck.string(tab["model"], "scene.model", BLADE_MODELS)
    effects = ck.names(tab.get("effects", []), "scene.effects", min_length=0)
    for i, e in enumerate(effects):
        if e not in EFFECTS:
            ck.fail(f"scene.effects[{i}]", f"unknown effect {e!r} (known: {', '.join(EFFECTS)})")
    params = parse_blade_params(ck, ck.table(tab.get("blade", {}), "scene.blade"), model, fld)
    mesh = None
    if "mesh" in tab:
        if model != "solid_blade":
            ck.fail(fld("mesh"), f"a mesh file needs model = \"solid_blade\", got {model!r}")
        mesh = _mesh(ck, tab["mesh"], fld("mesh"), base_dir, tab, contacts)
    matrices = scene_matrices(ck, tab, mesh, base_dir, fld)
    mesh_scale = mesh_units(ck, tab, mesh, matrices, fld)
    n_modes = ck.integer(tab.get("craig_bampton_modes", DEFAULT_MODES),
                         fld("craig_bampton_modes"), 0, 10_000)
    rayleigh = None
    if "rayleigh" in tab:
        a, b = ck.numbers(tab["rayleigh"], "scene.rayleigh", 2, ge=0.0)
        if a == 0 and b == 0:
            ck.fail("scene.rayleigh", "alpha and beta are both zero (no damping)")
        rayleigh = (float(a), float(b))
        if "damping_ratios" in ck.table(tab.get("blade"), "scene.blade", required=False):
            ck.fail("scene.blade.damping_ratios", "unused with scene.rayleigh (Rayleigh damping "
                                                  "replaces the modal ratios): give one of the two")
    placement, assembly = blade_disk.parse_placement(ck, tab)
    check_material(ck, params, lambda k: fld(f"blade.{k}"))   # SI units
    if mesh is None:   # before anything is meshed: lengths in metres, a model of sane size
        check_blade_size(ck, tab.get("blade", {}), params, placement,
                         lambda k: fld(f"blade.{k}"))
    contacts, loads = (_contacts_and_loads(ck, tab, loaded, params) if contacts else ((), ()))
    blade_disk.check_disk_contacts(ck, contacts, placement)
    structure = Blade(params=params, mesh=mesh, rayleigh=rayleigh, disk=placement,
                      matrices=matrices, mesh_scale=mesh_scale)
    scene = Scene(structure=blade_disk.turning(ck, tab, structure, model, effects),
                  contacts=contacts, loads=loads, reduction=blade_disk.reduction(ck, tab, n_modes),
                  effects=effects, model=model, assembly=assembly)
    if not build:
        return scene
    try:
        blade = blade_model(scene.structure)
    except (ValueError, RuntimeError, np.linalg.LinAlgError, UsageError) as exc:  # e.g. a
        field, msg = blade_disk.placement_field(str(exc))   # degenerate mesh, a bad export
        ck.fail(field or ("scene.matrices" if matrices else fld("mesh") if mesh
                          else "scene.blade"), msg)
    nb = boundary_dofs(blade)[0].size
    if n_modes > blade.n_dof - nb:
        ck.fail(fld("craig_bampton_modes"), f"must be <= {blade.n_dof - nb} (free DOFs "
                                            f"{blade.n_dof} - boundary DOFs {nb}), got {n_modes}")
    for i, ld in enumerate(loads):
        if ld.set not in blade.dof_sets:
            ck.fail(f"scene.excitation[{i}].set", f"the blade has no node set {ld.set!r}")
        try:
            point_forcing(blade, (ld,))
        except ValueError as exc:
            ck.fail(f"scene.excitation[{i}].set", str(exc))
    blade_disk.check_pairs(ck, blade, scene, placement, fld("mesh") if mesh else "scene.disk")
    for i, c in enumerate(contacts):
        if not isinstance(c, FaceContact):
            continue
        if c.face not in blade.frames:
            ck.fail(f"scene.contact[{i}].face", f"the blade has no contact face {c.face!r}")
        a = blade.frames[c.face].weights
        if c.stiffness == "per_face" and (a is None or not np.all(a > 0)):
            ck.fail(f"scene.contact[{i}].stiffness", "\"per_face\" needs a positive area per "
                                                     "face node; this mesh gives some none")
    return scene


def _contacts_and_loads(ck, tab, loaded, params) -> tuple:
    """(contacts, loads) of a blade [scene]: face contacts against walls or shroud
    pairs between neighbours (`blade_disk`), point loads (required for a response)."""
    raw = tab.get("contact", [])
    if isinstance(raw, dict):
        ck.fail("scene.contact", "must be an array of tables: write [[scene.contact]]")
    ck.array(raw, "scene.contact", min_length=0)
    if raw and not params.shroud:
        ck.fail("scene.contact", "the blade has no shroud contact faces (shroud = false)")
    contacts = tuple(blade_disk.parse_pair(ck, c, f"scene.contact[{i}]", i)
                     if isinstance(c, dict) and "pair" in c
                     else _face_contact(ck, c, f"scene.contact[{i}]", i)
                     for i, c in enumerate(raw))
    for i, c in enumerate(contacts):
        if isinstance(c, FaceContact) and c.face in [
                d.face for d in contacts[:i] if isinstance(d, FaceContact)]:
            ck.fail(f"scene.contact[{i}].face", f"face {c.face!r} has two contacts")
        if c.name in [d.name for d in contacts[:i]]:
            ck.fail(f"scene.contact[{i}].name", f"duplicate contact name {c.name!r}")
        ck.string(c.name, f"scene.contact[{i}].name", pattern=NAME_PATTERN)
    if "excitation" not in tab and loaded:
        ck.fail("scene.excitation", "missing (required): at least one [[scene.excitation]]")
    loads = _loads(ck, tab["excitation"]) if "excitation" in tab else ()
    return contacts, loads


def _mesh(ck, value, field_, base_dir, tab, contacts):
    s = ck.string(value, field_)
    path = Path(s) if Path(s).is_absolute() else base_dir / s
    if not path.is_file():
        ck.fail(field_, f"mesh file {str(path)!r} not found")
    required = ["root"]
    if contacts:
        for c in tab.get("contact", []) if isinstance(tab.get("contact"), list) else []:
            if isinstance(c, dict) and isinstance(c.get("face"), str):
                required.append(c["face"])
            if isinstance(c, dict) and "pair" in c:
                required += ["shroud_right", "shroud_left"]
        for e in tab.get("excitation", []) if isinstance(tab.get("excitation"), list) else []:
            if isinstance(e, dict) and isinstance(e.get("set"), str):
                required.append(e["set"])
        required.append("response")
    try:
        read_mesh(path, tuple(dict.fromkeys(required)))
    except ValueError as exc:
        ck.fail(field_, str(exc))
    except Exception as exc:  # meshio's many parse errors: still one line
        ck.fail(field_, f"cannot read mesh file {str(path)!r}: {type(exc).__name__}: {exc}")
    return str(path)


def _face_contact(ck, c, f, i) -> FaceContact:
    c = ck.table(c, f)
    if "interference" in c:
        ck.fail(f"{f}.interference", "an interference is of a shroud pair (pair = \"shroud\" "
                                     "between neighbouring blades), not of a face against a wall")
    ck.keys(c, f, ("name", "face", "ku", "kv", "mu", "n0", "stiffness", "friction", "ku2"),
            required=("face", "ku", "mu"))
    face = ck.string(c["face"], f"{f}.face", FACES)
    name = ck.string(c.get("name", face), f"{f}.name")
    ku = ck.number(c["ku"], f"{f}.ku", gt=0.0)
    kv = ck.number(c.get("kv", 0.0), f"{f}.kv", ge=0.0)
    mu = ck.number(c["mu"], f"{f}.mu", ge=0.0)
    n0 = ck.number(c["n0"], f"{f}.n0") if "n0" in c else None
    stiffness = ck.string(c.get("stiffness", "per_node"), f"{f}.stiffness", STIFFNESS)
    return FaceContact(name=name, face=face, ku=ku, kv=kv, mu=mu, n0=n0, stiffness=stiffness,
                       **blade_disk.parse_friction(ck, c, f))


def _loads(ck, raw) -> tuple:
    if isinstance(raw, dict):
        ck.fail("scene.excitation", "must be an array of tables: write [[scene.excitation]]")
    items = ck.array(raw, "scene.excitation")
    out, seen = [], set()
    for i, e in enumerate(items):
        f = f"scene.excitation[{i}]"
        e = ck.table(e, f)
        ck.keys(e, f, ("set", "direction", "amplitude", "harmonic", "phase"),
                required=("set", "direction", "amplitude"))
        s = ck.string(e["set"], f"{f}.set", POINTS)
        d = ck.numbers(e["direction"], f"{f}.direction", 3)
        nrm = float(np.linalg.norm(d))
        if not nrm > 0:
            ck.fail(f"{f}.direction", "must not be the zero vector")
        amp = ck.number(e["amplitude"], f"{f}.amplitude")
        h = ck.integer(e.get("harmonic", 1), f"{f}.harmonic", 0, MAX_HARMONICS)
        phase = ck.phase(e.get("phase", 0.0), f"{f}.phase")
        if h == 0 and phase != 0.0:
            ck.fail(f"{f}.phase", "a static load (harmonic = 0) has no phase")
        dir_ = tuple(float(x) for x in d / nrm)
        if (s, h, dir_) in seen:
            ck.fail(f, f"set {s!r} is excited twice in the same direction at harmonic {h}")
        seen.add((s, h, dir_))
        out.append(PointLoad(set=s, direction=dir_, amplitude=amp, harmonic=h, phase=phase))
    if not any(ld.amplitude for ld in out):
        ck.fail("scene.excitation", "every amplitude is zero: nothing excites the structure")
    return tuple(out)


def _output(ck, t, scene):
    ck.keys(t, "output", ("dofs", "figures", "yscale", "peak_windows", "optimum_preload",
                          "optimum_interference", "curves"))
    dofs = (ck.names(t["dofs"], "output.dofs") if "dofs" in t
            else tuple(f"response.{c}" for c in COMPONENTS))
    searched = [k for k in ("optimum_preload", "optimum_interference") if k in t]
    if len(searched) > 1:
        ck.fail("output.optimum_interference", "one optimum search a study: give "
                                               "optimum_preload or optimum_interference")
    if scene.mistuning is not None:   # every blade's: "response.y@3"
        if searched:
            ck.fail(f"output.{searched[0]}", "the optimum search is not available for "
                                             "a mistuned disk")
        for i, d in enumerate(dofs):
            if not OUT_DOF_PATTERN.match(d.rpartition("@")[0] or d):
                ck.fail(f"output.dofs[{i}]", f"{d!r} is not '<set>.<component>[@<sector>]'")
        figs, yscale, windows = output_common(ck, t)
        return OutputSettings(dofs=disk_scene.output_dofs(ck, {"dofs": list(dofs)}, scene),
                              figures=figs, yscale=yscale, peak_windows=windows,
                              curves=disk_scene.parse_curves(ck, t, scene, windows))
    for i, d in enumerate(dofs):
        if not OUT_DOF_PATTERN.match(d):
            ck.fail(f"output.dofs[{i}]", f"{d!r} is not '<set>.<component>' with set excitation "
                                         "or response and component x, y or z")
    figs, yscale, windows = output_common(ck, t)
    optimum = parse_optimum(ck, t, scene, "interference" if "optimum_interference" in t
                            else "preload")
    return OutputSettings(dofs=tuple(dofs), figures=figs, yscale=yscale, peak_windows=windows,
                          optimum=optimum,
                          curves=disk_scene.parse_curves(ck, t, scene, windows))


def _modes(ck, t, where, scene, built: bool = True):
    """(mode counts, frequencies, shapes) of a [modes] table, `where(key)` the field of
    a key (`header.overlay`); bounds from the blade of `scene` if `built` (a --quick
    load does not build the full blade)."""
    for k in t:
        ck.keys({k: None}, where(k).rpartition(".")[0],
                ("mode_counts", "n_frequencies", "mode_shapes"))
    counts = (ck.array(t["mode_counts"], where("mode_counts")) if "mode_counts" in t
              else list(DEFAULT_MODE_COUNTS))
    vals = [ck.integer(v, where(f"mode_counts[{i}]"), 0, 10_000) for i, v in enumerate(counts)]
    for i in range(1, len(vals)):
        if vals[i] <= vals[i - 1]:
            ck.fail(where(f"mode_counts[{i}]"), f"must increase strictly, got {vals[i - 1]} "
                                                f"then {vals[i]}")
    blade = blade_model(scene.structure) if built else None
    n_int = blade.n_dof - boundary_dofs(blade)[0].size if built else math.inf
    if vals and vals[-1] > n_int:
        ck.fail(where(f"mode_counts[{len(vals) - 1}]"), f"must be <= {n_int} (interior DOFs), "
                                                        f"got {vals[-1]}")
    if scene.reduction.modes not in vals:  # the scene's own count is always reported
        vals = sorted(vals + [scene.reduction.modes])
    nf = ck.integer(t.get("n_frequencies", 10), where("n_frequencies"), 1, 200)
    if built and nf >= blade.n_dof - 1:
        ck.fail(where("n_frequencies"), f"must be < {blade.n_dof - 1} (DOFs of the blade)")
    ns = ck.integer(t.get("mode_shapes", min(nf, 6)), where("mode_shapes"), 0, nf)
    return tuple(vals), nf, ns


def _consistency(ck, scene, solver, axes, spath, wpath, data):
    """Cross-field rules (scene.check_scene_rules); every face contact has a normal."""
    blade_disk.check_interference(ck, scene.contacts, axes, wpath)
    blade_disk.check_friction(ck, scene, solver, spath)
    check_scene_rules(ck, scene.effects, contact_rules(scene),
                      max([ld.harmonic for ld in scene.loads] + [0]), solver.harmonics,
                      axes, spath, wpath, disk=scene.cyclic, can_turn=blade_disk.can_turn(scene),
                      speed=scene.structure.speed)
    if scene.cyclic:  # engine order, "cyclic_coupling", mistuning: as a lumped disk's
        disk_scene.check_disk_rules(ck, scene, axes, wpath, data)




