"""The words a dataset uses to describe its scene and method: global attributes of
an FE blade (model sizes, damping, contact parameters) and of a cyclic assembly
(sectors, engine order, mistuning), and the solution method of a study."""
from __future__ import annotations

import datetime as _dt

import numpy as np

from ... import __version__

from ...model.scene import Blade
from ...model.build import blade_contact_maps
from ...model.blade_cache import reduced_model
from .conformance import CONVENTIONS
from ..files.study_types import is_linear_scene


def scene_attrs(scene) -> dict:
    """Global attributes that describe a scene's FE structure and its reduction
    (blades), then its cyclic assembly (disks); none for a single lumped structure."""
    attrs = blade_attrs(scene) if isinstance(scene.structure, Blade) else {}
    return {**attrs, **(cyclic_attrs(scene) if scene.cyclic else {})}


def blade_attrs(scene) -> dict:
    """Attributes of an FE blade scene: model sizes, damping, contact parameters."""
    st = scene.structure
    red, reduce_time = reduced_model(st, scene.reduction)
    return {"blade_model": scene.model, "mesh": st.mesh or "generated",
            "n_dof_full": int(red.n_full), "n_boundary_dofs": int(red.n_boundary),
            "craig_bampton_modes": int(red.n_modes),
            "contact_nodes": int(blade_contact_maps(scene)[0].shape[0]),
            "damping": (f"rayleigh alpha = {st.rayleigh[0]:g} 1/s, beta = "
                        f"{st.rayleigh[1]:g} s" if st.rayleigh is not None else
                        f"modal ratios {list(st.params.damping_ratios)}"),
            "contact_parameters": "; ".join(
                f"{c.name}: " + ("ku, kv per contact node [N/m]; preload = total normal load "
                                 "of the face [N], n0 per node = preload / nodes"
                                 if c.stiffness == "per_node" else
                                 "ku, kv [N/m] and preload [N] are face totals, shared by "
                                 "the nodes in proportion to their area")
                for c in scene.contacts),
            "reduced_frequencies_hz": np.asarray(red.frequencies[:10], dtype=float),
            "reduction_time_s": float(reduce_time)}


def points_attrs(output) -> dict:
    """What the `point` dimension holds: the traced curves, or (`[output] curves =
    false`) only the points where a response DOF has its largest amplitude."""
    if output.curves:
        return {"points": "the traced response curves (continuation, dense output, peaks)"}
    return {"points": "peaks only ([output] curves = false): each case keeps the points "
                      "where a response DOF has its largest amplitude over the frequency "
                      "range, located exactly; the curves between them are not kept"}


def cyclic_attrs(scene) -> dict:
    """Attributes of a cyclic assembly: sectors, engine order, mistuning."""
    asm, mis = scene.assembly, scene.mistuning
    attrs = {"sectors": int(asm.sectors), "sector_dofs": int(len(scene.sector_dofs)),
             "cyclic_reduction": "one sector, travelling wave Q_{j,h} = exp(i h j phi) "
                                 "Q_{0,h}, phi = 2 pi EO / sectors (Petrov 2004)",
             "excitation": "engine order EO: sector j loaded by sector 0's load "
                           "shifted by j phi (phase j phi in the first harmonic)"}
    if asm.engine_order is not None:
        attrs["engine_order"] = int(asm.engine_order)
    if asm.springs:
        attrs["disk_springs"] = "; ".join(
            f"{s.name}: k = {s.k:g} N/m on " + " ".join(
                f"{c:+g} {d}" for d, c in zip(scene.contact_dofs, s.row) if c)
            for s in asm.springs)
    if mis is not None:
        attrs["cyclic_reduction"] = ("none: mistuned, the full assembly of all sectors "
                                     "(responses per sector on the sector dimension)")
        if mis.factors is not None:
            attrs["mistuning"] = ("sector j stiffness f_j K with the factors f_j given in the "
                                  "study (variable mistuning_factor)")
            return attrs
        attrs["mistuning"] = ("sector j stiffness (1 + delta_j) K, delta_j ~ N(0, std^2) "
                              "from numpy default_rng(seed), truncated at 3 std and -0.9")
        attrs["mistuning_stiffness_std"] = float(mis.stiffness_std)
        if mis.seed is not None:
            attrs["mistuning_seed"] = int(mis.seed)
    return attrs


def solution_method(study) -> str:
    """What the run composed for the scene's declared effects (a scene pays only
    for what it calls for), in words."""
    if is_linear_scene(study.scene):
        return "direct linear solve per frequency (no contact elements: no Newton, no continuation)"
    eff = set(study.scene.effects)
    laws = sorted({le.law.name for le in getattr(study.scene, "laws", ())})
    further = "; further contact laws: " + ", ".join(laws) if laws else ""
    if laws and "friction" not in eff:
        return "harmonic balance with pseudo-arclength continuation" + further
    normal = ("variable normal load, " + ("searched for separation" if "separation" in eff else "kept closed (a case that separates fails)") if "normal_load_variation" in eff
              else "constant normal load (Jenkins path: no separation search)")
    if "friction_2d" in eff and not laws:   # an FE blade's contacts on the 2D law
        return (f"harmonic balance with pseudo-arclength continuation; 2D friction contacts "
                f"(slip in the contact plane), AFT with {study.solver.samples} samples a "
                f"period: {normal}")
    return (f"harmonic balance with pseudo-arclength continuation; Yang-Menq contacts: {normal}; "
            "fully stuck or open elements evaluated as linear springs" + further)


def provenance(source: str) -> dict:
    """The provenance attributes every dataset of the pipeline carries."""
    return {"pipeline_version": __version__,
            "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "source": source, "Conventions": CONVENTIONS}
