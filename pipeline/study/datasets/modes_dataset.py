"""Datasets of the modal studies: a blade's full vs Craig-Bampton eigenfrequencies
against the mode count (`modes_to_dataset`), and a tuned disk's natural
frequencies per nodal diameter with the contacts open and stuck
(`disk_modes_to_dataset`).  Both carry the same provenance attributes as the
response datasets (`describe.provenance`) and are written by `dataset.write_netcdf`."""
from __future__ import annotations

import numpy as np
import xarray as xr

from .describe import provenance, scene_attrs


def modes_to_dataset(study, res: dict, mode_shapes_file: str = "") -> xr.Dataset:
    """Dataset of a blade modes study (`modes_study.modal_study` result `res`): full and
    Craig-Bampton eigenfrequencies against the mode count, errors and timings."""
    counts = np.asarray(res["mode_counts"], dtype=np.int32)
    nf = len(res["full_hz"])
    ci = list(counts).index(study.scene.reduction.modes)

    def var(dims, data, units, long_name):
        return (dims, np.asarray(data), {"units": units, "long_name": long_name})

    data_vars = {
        "full_frequency": var(("mode",), res["full_hz"], "Hz",
                              "eigenfrequency of the unreduced FE model (shift-invert Lanczos)"),
        "reduced_frequency": var(("mode_count", "mode"), res["reduced_hz"], "Hz",
                                 "eigenfrequency of the Craig-Bampton model"),
        "relative_error": var(("mode_count", "mode"), res["rel_error"], "1",
                              "reduced/full - 1 (Rayleigh-Ritz: >= 0)"),
        "max_relative_error": var(("mode_count",), np.nanmax(res["rel_error"], axis=1), "1",
                                  "largest relative frequency error over the modes"),
        "reduction_time": var(("mode_count",), res["time_reduce_s"], "s",
                              "wall time of the Craig-Bampton reduction (all stages)"),
        "reduction_stage_time": var(("mode_count", "stage"), res["time_stage_s"], "s",
                                    "wall time of each stage of the reduction"),
        "reduced_size": var(("mode_count",), np.asarray(res["reduced_size"], np.int32), "1",
                            "reduced coordinates: boundary DOFs + modes"),
        "full_eigen_time": var((), float(res["time_full_s"]), "s",
                               "wall time of the unreduced eigen solve (factorisation included)"),
        "mac": var(("mode",), res["mac"], "1", "modal assurance criterion, full vs reduced "
                                               f"mode at {study.scene.reduction.modes} modes"),
        "n_dof": var((), np.int32(res["n_dof"]), "1", "free DOFs of the unreduced blade"),
        "n_boundary": var((), np.int32(res["n_boundary"]), "1",
                          "boundary DOFs kept physical (contact faces, excitation, response)"),
    }
    coords = {
        "mode_count": ("mode_count", counts, {"units": "1",
                                              "long_name": "Craig-Bampton fixed-interface modes"}),
        "mode": ("mode", np.arange(1, nf + 1, dtype=np.int32), {"units": "1",
                                                              "long_name": "mode number"}),
        "stage": ("stage", np.asarray(res["stage_names"], dtype=str),
                  {"long_name": "stage of the reduction"}),
    }
    sc = study.scene
    attrs = {
        "title": study.title, "study": study.text, "study_name": study.name,
        "description": study.description, "reference": study.reference,
        "kind": "modes", "model": sc.model, "mesh": sc.structure.mesh or "generated",
        "blade_parameters": repr(sc.structure.params),
        "default_mode_count": int(sc.reduction.modes),
        "max_relative_error_at_default": float(np.nanmax(res["rel_error"][ci])),
        "mode_shapes": mode_shapes_file,
        "quick": int(study.quick),
        **provenance("pipeline (scikit-fem blade, sparse Craig-Bampton reduction)"),
    }
    return xr.Dataset(data_vars=data_vars, coords=coords, attrs=attrs)

def family_frequencies(res: dict, dims: tuple) -> dict:
    """The natural-frequency variables [Hz] of a disk modes result on `dims`: contacts
    open, stuck, and (with an interference) the static contact state."""
    long = {"open": "natural frequency, contacts open",
            "stuck": "natural frequency, every contact closed and stuck (ku, kv)",
            "static": "natural frequency, the pairs of the static contact solution "
                      "(interference and speed) stuck, the others open"}
    return {f"frequency_{k}": (dims, np.asarray(res[k], float),
                               {"units": "Hz", "long_name": text + " (NaN: a negative "
                                "stiffness, omega^2 < 0: the blade diverges, e.g. spin "
                                "softening beyond the speed of divergence)"})
            for k, text in long.items() if k in res}


def family_coords(study, nf: int) -> dict:
    """The nodal-diameter and mode coordinates of a disk modes dataset."""
    return {"nodal_diameter": ("nodal_diameter", np.asarray(study.nodal_diameters, np.int32),
                               {"units": "1", "long_name": "nodal diameter ND (EO = ND "
                                                           "excites it)"}),
            "mode": ("mode", np.arange(1, nf + 1, dtype=np.int32),
                     {"units": "1", "long_name": "mode number within the family"})}


def family_attrs(study, solver: str) -> dict:
    """The attributes of a disk modes dataset (provenance of `solver`)."""
    return {"title": study.title, "study": study.text, "study_name": study.name,
            "description": study.description, "reference": study.reference,
            "kind": "modes", "quick": int(study.quick), **scene_attrs(study.scene),
            **provenance(solver)}


def disk_modes_to_dataset(study, res: dict) -> xr.Dataset:
    """Dataset of a disk modes study (`disk_modes_study.nodal_diameter_frequencies` result):
    natural frequencies per nodal diameter with the contacts open and stuck, and their
    mode shapes at the sector's physical DOFs."""
    phys = res["physical"]
    shapes = {f"mode_shape_{m}": (
        ("nodal_diameter", "dof", "mode", "component"),
        np.stack([res[f"shape_{m}"][:, phys].real, res[f"shape_{m}"][:, phys].imag], axis=-1),
        {"units": "1", "long_name": f"mode shape at the sector's DOFs, contacts {m} "
                                    "(component: real and imaginary parts, a travelling "
                                    "wave for 0 < ND < N/2), scaled to max |x| = 1, that "
                                    "entry real and positive"})
        for m in ("open", "stuck")}
    return xr.Dataset(
        {**family_frequencies(res, ("nodal_diameter", "mode")), **shapes,
         "solve_time": ((), float(res["time_s"]), {"units": "s", "long_name": "wall time of "
                                                   "the eigen-solves"})},
        coords={**family_coords(study, res["open"].shape[1]),
                "dof": ("dof", np.asarray([res["dofs"][i] for i in phys], str),
                        {"long_name": "the sector's DOF (a Craig-Bampton boundary DOF "
                                      "<set>.<k>.<x|y|z>, or a lumped DOF)"}),
                "component": ("component", np.asarray(["real", "imag"]),
                              {"long_name": "real or imaginary part"})},
        attrs=family_attrs(study, "pipeline (cyclic eigenproblem of one sector per nodal "
                                  "diameter)"))


def campbell_to_dataset(study, res: dict) -> xr.Dataset:
    """Dataset of a Campbell diagram (`campbell_study.campbell` result): natural frequencies
    on (speed, nodal_diameter, mode), contacts open and stuck, and the engine-order
    crossings located by root finding (dimension `crossing`), each with its mode shape."""
    cr = res["crossings"]
    col = list(zip(*cr)) if cr else [()] * 6

    def cvar(k, dtype, units, long_name):
        return (("crossing",), np.asarray(col[k], dtype=dtype),
                {"units": units, "long_name": long_name} if units else {"long_name": long_name})

    sh = res.get("crossing_shapes") or {"shapes": np.zeros((0, 0), complex), "dofs": (),
                                         "physical": np.zeros(0, int)}
    phys = sh["physical"]
    X = sh["shapes"][:, phys] if len(cr) else np.zeros((0, phys.size), complex)
    return xr.Dataset(
        {**family_frequencies(res, ("speed", "nodal_diameter", "mode")),
         "crossing_mode_shape": (("crossing", "dof", "component"),
                                 np.stack([X.real, X.imag], axis=-1),
                                 {"units": "1", "long_name": "mode shape of the crossing's "
                                  "family at the sector's DOFs, at the crossing speed and "
                                  "contact state (component: real and imaginary parts, a "
                                  "travelling wave for 0 < ND < N/2), scaled to max |x| = 1, "
                                  "that entry real and positive"}),
         "crossing_engine_order": cvar(0, np.int32, "1", "engine order EO of the crossing"),
         "crossing_nodal_diameter": cvar(1, np.int32, "1", "nodal diameter EO excites"),
         "crossing_mode": cvar(2, np.int32, "1", "mode number within the family"),
         "crossing_contacts": cvar(3, str, "", "contacts open, stuck or static"),
         "crossing_speed": cvar(4, float, "rpm", "speed where the frequency equals EO x "
                                                 "speed / 60 (root found, not the grid)"),
         "crossing_frequency": cvar(5, float, "Hz", "frequency at the crossing, EO x "
                                                    "speed / 60"),
         "solve_time": ((), float(res["time_s"]), {"units": "s", "long_name": "wall time of "
                                                   "the eigen-solves and the root finding"}),
         "message": (("speed",), np.asarray(res.get("message", [""] * len(study.speeds)), str),
                     {"long_name": "why the model at this speed could not be built or solved "
                                   "(its frequencies NaN; empty: solved)"})},
        coords={"speed": ("speed", np.asarray(study.speeds, float),
                          {"units": "rpm", "long_name": "rotation speed of the disk"}),
                **family_coords(study, res["open"].shape[2]),
                "engine_order": ("engine_order", np.asarray(study.engine_orders, np.int32),
                                 {"units": "1", "long_name": "engine orders drawn"}),
                "crossing": ("crossing", np.arange(len(cr), dtype=np.int32),
                             {"units": "1", "long_name": "crossing index, by engine order"}),
                "dof": ("dof", np.asarray([sh["dofs"][i] for i in phys], str),
                        {"long_name": "the sector's DOF (a Craig-Bampton boundary DOF "
                                      "<set>.<k>.<x|y|z>)"}),
                "component": ("component", np.asarray(["real", "imag"]),
                              {"long_name": "real or imaginary part"})},
        attrs=family_attrs(study, "pipeline (cyclic eigenproblem of one sector per nodal "
                                  "diameter and speed, stress stiffening and spin softening)"))
