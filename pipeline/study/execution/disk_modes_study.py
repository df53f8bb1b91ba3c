"""Modes of a tuned disk per nodal diameter: `[study] kind = "modes"` on a disk scene.

A tuned disk of N sectors has, for each nodal diameter ND = 0..N/2, the modes of
one sector whose neighbour moves as this sector times exp(i psi), psi = 2 pi ND / N
(the cyclic eigenproblem; ND and N - ND are the same pair of standing waves):

    [K + e^{i psi} K_next + e^{-i psi} K_next^T + B(psi)^H k B(psi)] x = w^2 M x,
    B(psi) = B + e^{i psi} B_next,

with the contact springs k = (ku along the tangents, kv along the normals) left
out (contacts OPEN) or added for every contact (contacts STUCK: closed and stuck,
whatever the preload) -- the two linear limits between which every friction-damped
resonance lies (`model.system.natural_frequencies`).  Frequency against nodal
diameter is the diagram engineers read engine-order crossings from: an engine
order EO excites only the family ND = EO (mod N, folded into 0..N/2).

    [study] kind = "modes"            [modes] n_frequencies = 3   (default: all)
                                              nodal_diameters = [0, 1, ...]  (default 0..N/2)

The dataset has `frequency_open` and `frequency_stuck` [Hz] on (nodal_diameter,
mode) and their mode shapes at the sector's physical DOFs; the figure
`<name>/nodal_diameter_diagram.png` draws both, and on an FE disk
`<name>/mode_shapes.vtu` holds the shapes on the blade mesh.  With `[modes]
speeds` (and `engine_orders`) the disk turns: the Campbell diagram (`campbell_study`),
frequencies on (speed, nodal_diameter, mode) and the engine-order crossings, drawn
in `<name>/campbell_diagram.png`, each crossing's mode shape in the dataset and on the
mesh in `<name>/crossing_shapes.vtu`.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...model.cyclic import sector_system
from ...model.scene import Lumped, Scene
from ...model.build import sector
from ...model.system import natural_frequencies, natural_modes
from ...model.blade_cache import blade_model, cut_model, reduced_model, sector_coordinates
from ...structure.mesh_io import write_fields
from ...structure.reduction import reconstruct
from ..figures.nd_figure import nodal_diameter_figure
from ..files.rules import check_speed_rules
from ..scenes.blade_scene import BLADE_MODELS, base_dir_of, blade_scenes
from ..scenes.blade_wheel_scene import can_turn
from .campbell_study import campbell, parse_speeds
from ..files.validation import Checker
from ..files.header import overlay, parse_header, quick_tables
from ..scenes.lumped_scene import parse_scene
from .kind_costs import disk_modes_estimate, estimate_lines
from ..files.study_types import StudyHeader, StudyKind, StudyResult, never

log = logging.getLogger(__name__)
TOP = ("study", "scene", "modes", "quick")
DEFAULT_FREQUENCIES = 10      # per nodal diameter, when [modes] n_frequencies is not given


@dataclass(frozen=True)
class DiskModesStudy(StudyHeader):
    """Natural frequencies of a tuned disk per nodal diameter, contacts open and stuck."""

    scene: Scene
    nodal_diameters: tuple
    n_frequencies: int
    quick: bool = False
    kind: str = "disk_modes"
    speeds: tuple = ()          # [rpm]: a Campbell diagram (`campbell_study`)
    engine_orders: tuple = ()


def is_disk_document(data) -> bool:
    """A document of a lumped disk (model "disk") or of FE blades in a disk (a blade
    model with a [scene.disk] table)."""
    scene = data.get("scene")
    return isinstance(scene, dict) and (scene.get("model") == "disk" or (
        scene.get("model") in BLADE_MODELS and "disk" in scene))


def study_from_mapping(data: dict, *, file: str = "<study>", name: str = "study",
                       text: str = "", quick: bool = False) -> DiskModesStudy:
    """Validate a disk modes study document; every mistake `<file>: <field>: <what>`."""
    ck = Checker(file)
    ck.keys(data, "", TOP, required=("study", "scene"))
    header = parse_header(ck, data)
    if data["scene"].get("model") == "disk":
        qt = quick_tables(ck, data, quick, ("modes",))
        scene = parse_scene(ck, ck.table(data["scene"], "scene"), loaded=False)
    else:   # FE blades: [quick.scene] may coarsen the mesh
        qt = quick_tables(ck, data, quick, ("scene", "modes"))
        full, q_scene = blade_scenes(ck, data, qt, base_dir_of(file), loaded=False)
        scene = q_scene if quick else full
    check_modes_scene(ck, scene)
    modes, where = overlay(ck, ck.table(data.get("modes"), "modes", required=False),
                           qt.get("modes", {}), "modes")
    for k in modes:
        ck.keys({k: None}, where(k).rpartition(".")[0], ("n_frequencies", "nodal_diameters",
                                                         "speeds", "engine_orders"))
    N, n = scene.assembly.sectors, len(scene.sector_dofs)
    nf = ck.integer(modes.get("n_frequencies", min(n, DEFAULT_FREQUENCIES)),
                    where("n_frequencies"), 1, n)
    nds = tuple(ck.integer(v, where(f"nodal_diameters[{i}]"), 0, N // 2) for i, v in
                enumerate(ck.array(modes.get("nodal_diameters", list(range(N // 2 + 1))),
                                   where("nodal_diameters"))))
    if len(set(nds)) != len(nds):
        ck.fail(where("nodal_diameters"), "a nodal diameter is listed twice")
    speeds, eos = parse_speeds(ck, modes, where)
    check_speed_rules(ck, scene.effects, {"speed": speeds} if speeds else {}, "modes",
                      can_turn(scene), 0.0, axis_field=where("speeds"))
    return DiskModesStudy(file=file, name=name, **header, text=text, scene=scene,
                          nodal_diameters=nds, n_frequencies=nf, quick=bool(quick),
                          speeds=speeds, engine_orders=eos)


def check_modes_scene(ck, scene: Scene):
    """Contacts to open and stick, a tuned disk, and the couplings declared exactly."""
    if not scene.contacts:
        ck.fail("scene.contact", "a modes study compares the contacts open and stuck: give at "
                                 "least one [[scene.contact]]")
    if scene.mistuning is not None:
        ck.fail("scene.disk.mistuning", "modes per nodal diameter need a tuned disk (a mistuned "
                                        "disk has no nodal diameters)")
    for effect, present, what in (("cyclic_coupling", scene.coupled,
                                   "a contact reaches the next sector (next.<dof>)"),
                                  ("disk_coupling", bool(scene.assembly.springs),
                                   "[[scene.disk.spring]] couples neighbouring sectors")):
        if present != (effect in scene.effects):
            ck.fail("scene.effects", f"{what}: declare \"{effect}\"" if present else
                    f"\"{effect}\" is declared but nothing in the scene needs it")


def nodal_diameter_frequencies(scene: Scene, nodal_diameters, n_frequencies: int) -> dict:
    """{"open", "stuck"}: (len(nodal_diameters), n_frequencies) natural frequencies [Hz]
    of the tuned disk per nodal diameter; {"shape_open", "shape_stuck"}: their mode
    shapes (len(nodal_diameters), n, n_frequencies) at the sector's n DOFs ("dofs"),
    complex (a travelling wave for 0 < ND < N/2), each scaled to max |x| = 1 over the
    physical DOFs ("physical": not a Craig-Bampton modal coordinate `mode.<j>` nor a disk
    sector's cut-face mode `cut.<k>`), that
    entry real and positive; "time_s": the wall time [s]."""
    t0 = time.perf_counter()
    preset = all(getattr(c, "n0", None) is not None for c in scene.contacts)
    sec = sector(scene, None if preset else {"preload": 0.0})  # n0 plays no part here
    physical = np.array([i for i, d in enumerate(sec.dof_names)
                         if not d.startswith(("mode.", "cut."))])
    out = {"dofs": tuple(sec.dof_names), "physical": physical}
    for m, c in (("open", "open"), ("stuck", "tied")):
        w, shapes = [], []
        for nd in nodal_diameters:
            system = sector_system(sec, nd)
            X = natural_modes(system, c)[1][:, :n_frequencies]
            j = np.argmax(np.abs(X[physical]), axis=0)
            shapes.append(X / X[physical[j], np.arange(X.shape[1])][None, :])
            # the frequencies as every other study reports them (the eigenvalues alone:
            # with the vectors LAPACK's round-off differs, 3e-9 on the lowest here)
            w.append(natural_frequencies(system, c)[:n_frequencies])
        out[m], out[f"shape_{m}"] = np.array(w) / (2 * np.pi), np.array(shapes, complex)
    out["time_s"] = time.perf_counter() - t0
    return out


def write_mode_shapes(study, res: dict, path) -> Path | None:
    """The mode shapes of an FE disk's sector on its blade mesh, VTU point data
    `<open|stuck>_nd<ND>_mode<j>_re|im|abs` [-] (`structure.mesh_io.write_fields`),
    recovered from the Craig-Bampton coordinates (a disk sector's: from its own and
    its next neighbour's, `cyclic_cut.CutSector.coordinates`); None for a lumped disk."""
    sc = study.scene
    if isinstance(sc.structure, Lumped) or sc.reduction is None:
        return None
    red = reduced_model(sc.structure, sc.reduction)[0]
    cut = cut_model(sc.structure, sc.reduction)
    fields = {}
    for m in ("open", "stuck"):
        for i, nd in enumerate(study.nodal_diameters):
            q = res[f"shape_{m}"][i]
            if cut is not None:
                q = cut.coordinates(q, 2 * np.pi * nd / sc.assembly.sectors)
            full = reconstruct(red, q)
            for j in range(full.shape[1]):
                fields[f"{m}_nd{nd}_mode{j + 1}"] = full[:, j]
    return write_fields(blade_model(sc.structure), path, fields)


def write_crossing_shapes(study, res: dict, path) -> Path | None:
    """The mode shape of each engine-order crossing of a Campbell diagram on the sector
    mesh, VTU point data `eo<EO>_<state>_mode<k>_<rpm>rpm_re|im|abs` [-], recovered at the
    crossing's speed (its reduction, a disk sector's own and next sector's parts); None for
    a lumped disk or no crossing."""
    sc, sh = study.scene, res.get("crossing_shapes")
    if isinstance(sc.structure, Lumped) or sc.reduction is None or not res["crossings"]:
        return None
    fields = {}
    for (eo, nd, k, state, speed, _), q in zip(res["crossings"], sh["shapes"]):
        if not np.all(np.isfinite(q)):
            continue
        red = reduced_model(sc.structure, sc.reduction, float(speed))[0]
        q = sector_coordinates(sc.structure, sc.reduction, float(speed), q,
                               2 * np.pi * nd / sc.assembly.sectors)
        fields[f"eo{eo}_{state}_mode{k}_{speed:.0f}rpm"] = reconstruct(red, q)
    return write_fields(blade_model(sc.structure), path, fields) if fields else None


def run_disk_modes_study(study: DiskModesStudy, out_dir="results", *, figures: bool = True):
    """`out_dir/<name>.nc` and `out_dir/<name>/nodal_diameter_diagram.png`."""
    # deferred: xarray and matplotlib cost a second to import; validation needs neither
    from ..datasets.dataset import write_netcdf
    from ..datasets.modes_dataset import campbell_to_dataset, disk_modes_to_dataset
    from ..figures.campbell_figure import campbell_figure

    t0 = time.perf_counter()
    sc = study.scene
    log.info("%s: %d sectors, nodal diameters %s, %d frequencies", study.name,
             sc.assembly.sectors, list(study.nodal_diameters), study.n_frequencies)
    if study.speeds:
        t1 = time.perf_counter()
        res = campbell(sc, study.speeds, study.nodal_diameters, study.n_frequencies,
                       study.engine_orders)
        res["time_s"] = time.perf_counter() - t1
        ds = campbell_to_dataset(study, res)
    else:
        res = nodal_diameter_frequencies(sc, study.nodal_diameters, study.n_frequencies)
        ds = disk_modes_to_dataset(study, res)
    path = write_netcdf(ds, Path(out_dir) / f"{study.name}.nc")
    log.info("wrote %s", path)
    written = []
    folder = Path(out_dir) / study.name
    shapes = (write_crossing_shapes(study, res, folder / "crossing_shapes.vtu") if study.speeds
              else write_mode_shapes(study, res, folder / "mode_shapes.vtu"))
    if shapes is not None:
        written.append(shapes)
        log.info("wrote %s", shapes)
    if figures:
        written.append(campbell_figure(Path(out_dir) / study.name / "campbell_diagram.png", ds)
                       if study.speeds else nodal_diameter_figure(
                           Path(out_dir) / study.name / "nodal_diameter_diagram.png", ds))
        log.info("wrote %s", written[-1])
    failed = [({"speed": v}, why) for v, why in zip(study.speeds, res.get("message", ()))
              if why]
    return StudyResult(study=study, dataset=ds, path=path, figures=written,
                       failures=len(failed), failed=failed, wall_time=time.perf_counter() - t0)


def describe(study: DiskModesStudy, workers: int = 1) -> list:
    """The lines `check` prints for a disk modes study, its cost estimate included."""
    sc = study.scene
    return [f"scene: disk of {sc.assembly.sectors} sectors, {len(sc.sector_dofs)} DOF(s) "
            f"per sector, {len(sc.contacts)} contact(s); nodal diameters "
            f"{', '.join(map(str, study.nodal_diameters))}; {study.n_frequencies} "
            "frequencies each, contacts open and stuck"] + estimate_lines(
                disk_modes_estimate(study))


KIND = StudyKind(name="disk_modes", word="modes", fits=is_disk_document, by_default=never,
                 parse=study_from_mapping, describe=describe,
                 estimate=lambda study, workers=1: disk_modes_estimate(study),
                 run=lambda study, out_dir, figures=True, **_: run_disk_modes_study(
                     study, out_dir, figures=figures),
                 cases=lambda study: 1)
