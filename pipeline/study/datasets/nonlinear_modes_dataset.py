"""The dataset of a nonlinear modes study (`nonlinear_modes_study`): per case (the sweep's
axes, a disk's engine orders as `nodal_diameter`) the backbone along `point`, the
synthesised forced response per `force_scale`, and the full harmonic balance's curve
and peak (`hbm_point`) where it was compared.  Every number has its unit; a case's
shorter backbone is padded with NaN (`converged` 0); a case that failed (its backbone
did not start, or it raised) is all padding, with `status` -1 and why in `message`."""
from __future__ import annotations

import numpy as np
import xarray as xr

from ...contact.period_results import cycle_results
from ...fourier.harmonics import amplitude_half_peak_to_peak
from ...solve.nonlinear_modes.backbone import point_at
from .contact_dataset import contact_coords, contact_motions
from .describe import provenance, scene_attrs
from ..files.study_types import SWEEP_AXES

TWO_PI = 2.0 * np.pi
STARTING_STATE = ("each backbone starts from the unilateral static state without excitation: "
                  "an element that would pull (n0 + kv v0 < 0) is open, the others closed and "
                  "stuck; linear_frequency and slip_onset_amplitude are those of the closed "
                  "elements only (static_pairs_in_contact)")


def _var(dims, data, units, long_name):
    return (dims, np.asarray(data), {"units": units, "long_name": long_name})


def axes_of(study) -> tuple:
    """[(dimension name, values, attrs)] of the case grid: `eo` is `nodal_diameter`."""
    out = []
    for a, v in study.response.sweep.axes.items():
        if a == "eo":
            out.append(("nodal_diameter", np.asarray(v, np.int32),
                        {"units": "1", "long_name": "nodal diameter ND of the travelling-wave "
                                                    "mode (engine order EO = ND excites it)"}))
        else:
            out.append((a, np.asarray(v, float), {"units": SWEEP_AXES[a][0],
                                                  "long_name": SWEEP_AXES[a][1]}))
    return out


def case_status(res) -> tuple:
    """(status, message) of one case's result (`nonlinear_modes_study.run_case`): 0 the
    backbone covers the amplitude range; 1 it stopped short, or the compared full
    harmonic balance failed (message: why); -1 the case failed, no backbone point
    (message "failed: <why>")."""
    if "error" in res:
        return -1, f"failed: {res['error']}"
    bb = res["backbone"]
    if not bb.s.size:
        return -1, f"failed: {bb.message or 'no backbone point'}"
    why = [bb.message] if bb.message else []
    if res.get("compare_error"):
        why.append(f"the full harmonic balance failed: {res['compare_error']}")
    return (1 if why else 0), "; ".join(why)


def backbone_values(study, res, dofs):
    """Per backbone point: frequency [Hz], damping, amplitudes, energy, states."""
    bb, mp = res["backbone"], res["problem"]
    system = mp.hbm.system
    P = bb.s.size
    a1 = np.sqrt(np.einsum("pic,ij,pjc->p", bb.Q[:, :, 1:3], mp.M, bb.Q[:, :, 1:3]))
    U, V = contact_motions(system, bb.Q)
    cyc = [cycle_results(U[p], V[p], system.contact) for p in range(P)]
    out = {"frequency": bb.omega / TWO_PI, "damping_ratio": bb.zeta,
           "modal_amplitude": bb.amplitude, "first_harmonic_amplitude": a1,
           "amplitude": np.stack([amplitude_half_peak_to_peak(Q)[dofs] for Q in bb.Q])
           if P else np.zeros((0, len(dofs))),
           "static_displacement": bb.Q[:, dofs, 0],
           "dissipated_energy_pair": np.array([c["energy"] for c in cyc]).reshape(P, -1),
           "dissipated_energy": np.array([np.sum(c["energy"]) for c in cyc]),
           "residual_static": bb.residual_static, "residual_harmonic": bb.residual_harmonic,
           "newton_iterations": bb.newton_iterations}
    for k in ("stick", "slip", "separation"):
        out[f"{k}_fraction"] = np.array([c[k] for c in cyc]).reshape(P, -1)
    return out


def synthesis_values(study, res, dofs):
    """Per force scale: frequencies below / above [Hz] along the backbone and the peak."""
    bb, mp = res["backbone"], res["problem"]
    P = bb.s.size
    out = {"synthesis_frequency_below": [], "synthesis_frequency_above": [],
           "synthesis_peak_frequency": [], "synthesis_peak_amplitude": [],
           "synthesis_time": res["synthesis_time"]}
    for syn in res["synthesis"]:
        if syn is None:
            out["synthesis_frequency_below"].append(np.full(P, np.nan))
            out["synthesis_frequency_above"].append(np.full(P, np.nan))
            out["synthesis_peak_frequency"].append(np.nan)
            out["synthesis_peak_amplitude"].append(np.full(len(dofs), np.nan))
            continue
        out["synthesis_frequency_below"].append(syn.below / TWO_PI)
        out["synthesis_frequency_above"].append(syn.above / TWO_PI)
        out["synthesis_peak_frequency"].append(syn.peak_omega / TWO_PI)
        if np.isfinite(syn.peak_s):
            _, _, Q = point_at(mp, bb, syn.peak_s, study.response.solver.tolerance,
                               segment=syn.peak_index)
            out["synthesis_peak_amplitude"].append(amplitude_half_peak_to_peak(Q)[dofs])
        else:
            out["synthesis_peak_amplitude"].append(np.full(len(dofs), np.nan))
    return out


def fill_case(arrays, idx, row, res, cur, grid, sizes):
    """Write one case's backbone, synthesis and compared curve into `arrays` at idx."""
    P, Ph, nf, dofs = sizes
    status, message = case_status(res)
    arrays.setdefault("status", grid((), -1, np.int8))[idx] = status
    arrays.setdefault("message", grid((), "", object))[idx] = message
    if row is None:           # failed: no backbone point (a setup that raised: nothing)
        if "problem" in res:
            arrays.setdefault("slip_onset_amplitude", grid(()))[idx] = res["onset"]
            arrays.setdefault("linear_frequency", grid(()))[idx] = \
                res["problem"].omega0 / TWO_PI
            fill_static(arrays, idx, res["problem"], grid)
        if res.get("curve") is not None:
            fill_compared(arrays, idx, res, grid, sizes)
        return
    bv, sv = row
    n = res["backbone"].s.size
    for k, v in bv.items():
        arr = arrays.setdefault(k, grid((P,) + np.shape(v)[1:], 0 if k == "newton_iterations"
                                        else np.nan, np.int32 if k == "newton_iterations"
                                        else float))
        arr[idx][:n] = v
    arrays.setdefault("converged", grid((P,), 0, np.int8))[idx][:n] = 1
    for k in ("synthesis_frequency_below", "synthesis_frequency_above"):
        arr = arrays.setdefault(k, grid((nf, P)))
        arr[idx][:, :n] = np.asarray(sv[k]).reshape(nf, n)
    arrays.setdefault("synthesis_peak_frequency", grid((nf,)))[idx] = sv["synthesis_peak_frequency"]
    arrays.setdefault("synthesis_peak_amplitude", grid((nf, len(dofs))))[idx] = \
        np.asarray(sv["synthesis_peak_amplitude"])
    arrays.setdefault("synthesis_time", grid((nf,)))[idx] = sv["synthesis_time"]
    arrays.setdefault("backbone_time", grid(()))[idx] = res["time"]
    arrays.setdefault("slip_onset_amplitude", grid(()))[idx] = res["onset"]
    arrays.setdefault("linear_frequency", grid(()))[idx] = res["problem"].omega0 / TWO_PI
    fill_static(arrays, idx, res["problem"], grid)
    s_pk, z_pk, w_pk = res["damping_peak"]
    arrays.setdefault("peak_damping_ratio", grid(()))[idx] = z_pk
    arrays.setdefault("peak_damping_amplitude", grid(()))[idx] = 10.0 ** s_pk
    arrays.setdefault("peak_damping_frequency", grid(()))[idx] = w_pk / TWO_PI
    if cur is not None:
        fill_compared(arrays, idx, res, grid, sizes)


def fill_static(arrays, idx, mp, grid):
    """The unilateral static state the case's mode starts from (`epmc.static_start`):
    each element's static normal load and the elements in contact."""
    st = mp.static
    if st is None:
        return
    arrays.setdefault("static_normal_load_pair", grid((st.load.size,)))[idx] = st.load
    arrays.setdefault("static_pairs_in_contact", grid((), -1, np.int32))[idx] = \
        int(st.closed.sum())


def fill_compared(arrays, idx, res, grid, sizes):
    """The compared full harmonic balance's curve and highest point at idx."""
    _, Ph, _, dofs = sizes
    cur = res["curve"]
    m = cur.omega.size
    arrays.setdefault("hbm_frequency", grid((Ph,)))[idx][:m] = cur.omega / TWO_PI
    amp = np.where(cur.converged[:, None], cur.amplitude[:, dofs], np.nan)
    arrays.setdefault("hbm_amplitude", grid((Ph, len(dofs))))[idx][:m] = amp
    k = int(np.nanargmax(amp[:, 0])) if np.any(np.isfinite(amp[:, 0])) else None
    arrays.setdefault("hbm_peak_frequency", grid(()))[idx] = (
        cur.omega[k] / TWO_PI if k is not None else np.nan)
    arrays.setdefault("hbm_peak_amplitude", grid((len(dofs),)))[idx] = (
        amp[k] if k is not None else np.nan)
    arrays.setdefault("hbm_time", grid(()))[idx] = res["curve_time"]


def modes_dataset(study, results) -> xr.Dataset | None:
    """The dataset of a finished nonlinear modes study (`nonlinear_modes_study.run`); None
    when no case has a backbone point."""
    axes = axes_of(study)
    shape = tuple(len(v) for _, v, _ in axes)
    cdims = tuple(d for d, _, _ in axes)
    dof_names = list(study.response.output.dofs)
    traced = [r for r in results if case_status(r)[0] >= 0]
    if not traced:
        return None
    system0 = traced[0]["problem"].hbm.system
    dofs = [list(system0.dof_names).index(d) for d in dof_names]
    E = system0.contact.size
    P = max(r["backbone"].s.size for r in traced)
    nf = len(study.force_scales)
    rows = [(backbone_values(study, r, dofs), synthesis_values(study, r, dofs))
            if case_status(r)[0] >= 0 else None for r in results]
    curves = [r.get("curve") for r in results]
    Ph = max((c.omega.size for c in curves if c is not None), default=0)

    def grid(tail, fill=np.nan, dtype=float):
        return np.full(shape + tail, fill, dtype)

    arrays = {}
    for (idx, _), row, res, cur in zip(study.cases(), rows, results, curves):
        fill_case(arrays, idx, row, res, cur, grid, (P, Ph, nf, dofs))
    data_vars = {k: _var(cdims + DIMS[k], arrays[k], *META[k]) for k in arrays if k in META}
    data_vars["message"] = (cdims, arrays["message"].astype(str),
                            {"long_name": "why the backbone stopped before the amplitude range "
                                          "ended, or why the case failed (empty: it covered "
                                          "the range)"})
    coords = {d: (d, v, a) for d, v, a in axes}
    coords.update({"point": ("point", np.arange(P, dtype=np.int32),
                             {"units": "1", "long_name": "point along the backbone"}),
                   "dof": ("dof", np.asarray(dof_names, dtype=str),
                           {"long_name": "response DOF"}),
                   "force_scale": ("force_scale", np.asarray(study.force_scales, float),
                                   {"units": "1", "long_name": "factor on the scene's "
                                                               "excitation (synthesis)"})})
    if Ph:
        coords["hbm_point"] = ("hbm_point", np.arange(Ph, dtype=np.int32),
                               {"units": "1", "long_name": "point of the full harmonic "
                                                           "balance's frequency response"})
    coords.update({k: v for k, v in contact_coords(study).items()
                   if k in ("pair", "pair_contact", "contact")})
    sv, fr = study.response.solver, study.response.sweep.frequency
    attrs = {"title": study.title, "study": study.text, "study_name": study.name,
             "description": study.description, "reference": study.reference,
             "kind": "nonlinear_modes", "quick": int(study.quick), "mode": int(study.mode),
             "harmonics": int(sv.harmonics), "force_evaluation": sv.force_evaluation,
             "tolerance": float(sv.tolerance), "n_elements": int(E),
             "frequency_range": np.array([fr.omega_start, fr.omega_stop]) / TWO_PI,
             "amplitude_range": np.asarray(study.amplitude, float),
             "starting_state": STARTING_STATE,
             "normalisation": ("modal_amplitude a: Q_h = a Psi_h for h >= 1 with sum_h "
                               "Psi_h^T M Psi_h = 1 over the vibration's harmonics (cos and "
                               "sin parts; the static part excluded); first_harmonic_amplitude: "
                               "the same mass norm of the first harmonic alone"),
             **scene_attrs(study.scene),
             **provenance("pipeline (extended periodic motion concept, harmonic balance "
                          "with exact contact forces)")}
    return xr.Dataset(data_vars=data_vars, coords=coords, attrs=attrs)


DIMS = {
    "frequency": ("point",), "damping_ratio": ("point",), "modal_amplitude": ("point",),
    "first_harmonic_amplitude": ("point",), "amplitude": ("point", "dof"),
    "static_displacement": ("point", "dof"), "dissipated_energy": ("point",),
    "dissipated_energy_pair": ("point", "pair"),
    "residual_static": ("point",), "residual_harmonic": ("point",),
    "newton_iterations": ("point",), "converged": ("point",),
    "stick_fraction": ("point", "pair"), "slip_fraction": ("point", "pair"),
    "separation_fraction": ("point", "pair"),
    "synthesis_frequency_below": ("force_scale", "point"),
    "synthesis_frequency_above": ("force_scale", "point"),
    "synthesis_peak_frequency": ("force_scale",),
    "synthesis_peak_amplitude": ("force_scale", "dof"), "synthesis_time": ("force_scale",),
    "status": (), "backbone_time": (), "slip_onset_amplitude": (), "linear_frequency": (),
    "peak_damping_ratio": (), "peak_damping_amplitude": (), "peak_damping_frequency": (),
    "static_normal_load_pair": ("pair",), "static_pairs_in_contact": (),
    "hbm_frequency": ("hbm_point",), "hbm_amplitude": ("hbm_point", "dof"),
    "hbm_peak_frequency": (), "hbm_peak_amplitude": ("dof",), "hbm_time": (),
}
META = {
    "frequency": ("Hz", "frequency of the nonlinear mode"),
    "damping_ratio": ("1", "modal damping ratio zeta (friction and viscous)"),
    "modal_amplitude": ("kg0.5 m", "modal amplitude a (mass norm of the vibration's harmonics)"),
    "first_harmonic_amplitude": ("kg0.5 m", "mass norm of the first harmonic of the motion"),
    "amplitude": ("m", "half peak-to-peak amplitude of the DOF over the period"),
    "static_displacement": ("m", "static (mean) displacement of the DOF"),
    "dissipated_energy": ("J", "energy dissipated per cycle by friction (slider work; one "
                               "sector's elements on a disk)"),
    "dissipated_energy_pair": ("J", "energy dissipated per cycle by the element's friction"),
    "residual_static": ("N", "recomputed residual of the static equations"),
    "residual_harmonic": ("N", "recomputed residual of the harmonic equations"),
    "newton_iterations": ("1", "Newton iterations of the point"),
    "converged": ("1", "1: a converged backbone point, 0: padding"),
    "stick_fraction": ("1", "fraction of the period the element sticks"),
    "slip_fraction": ("1", "fraction of the period the element slips (either way)"),
    "separation_fraction": ("1", "fraction of the period the element is separated"),
    "synthesis_frequency_below": ("Hz", "synthesised response: excitation frequency below the "
                                        "peak at which the backbone point's amplitude is reached "
                                        "(NaN above the peak and under the quasi-static "
                                        "amplitude, which the response never falls to there)"),
    "synthesis_frequency_above": ("Hz", "synthesised response: excitation frequency above the "
                                        "peak at which the backbone point's amplitude is reached"),
    "synthesis_peak_frequency": ("Hz", "synthesised response: frequency of the peak (NaN: "
                                       "the peak lies beyond the backbone's amplitude range)"),
    "synthesis_peak_amplitude": ("m", "synthesised response: amplitude of the DOF at the peak "
                                      "(NaN: beyond the backbone's range)"),
    "synthesis_time": ("s", "wall time of the synthesis (peak located exactly)"),
    "status": ("1", "0: the backbone covers the amplitude range; 1: it stopped short, or "
                    "the compared full harmonic balance failed (see message); -1: the case "
                    "failed, no backbone point (see message)"),
    "backbone_time": ("s", "wall time of the backbone"),
    "slip_onset_amplitude": ("kg0.5 m", "modal amplitude at which the first closed element "
                                        "of the linear mode slips or lifts off, from its static "
                                        "normal load (inf: none does, the mode is linear; drawn "
                                        "over the unit amplitude range)"),
    "linear_frequency": ("Hz", "frequency of the small-amplitude linear mode (the elements "
                               "closed in the static state stuck, the open ones open)"),
    "static_normal_load_pair": ("N", "static normal load n0 + kv v0 of the element in the "
                                     "unilateral static state the mode starts from (0: open)"),
    "static_pairs_in_contact": ("1", "elements closed (and stuck) in the static state the mode "
                                     "starts from"),
    "peak_damping_ratio": ("1", "largest modal damping ratio along the backbone (located "
                                "between the points)"),
    "peak_damping_amplitude": ("kg0.5 m", "modal amplitude of the largest damping ratio"),
    "peak_damping_frequency": ("Hz", "frequency of the mode at the largest damping ratio"),
    "hbm_frequency": ("Hz", "full harmonic balance: excitation frequency"),
    "hbm_amplitude": ("m", "full harmonic balance: half peak-to-peak amplitude of the DOF"),
    "hbm_peak_frequency": ("Hz", "full harmonic balance: frequency of the highest point"),
    "hbm_peak_amplitude": ("m", "full harmonic balance: amplitude at the highest point"),
    "hbm_time": ("s", "wall time of the full harmonic balance's frequency response"),
}
