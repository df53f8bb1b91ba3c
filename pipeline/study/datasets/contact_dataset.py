"""Per-contact variables of a response dataset: what the preload becomes and what the
contacts do (paper Eq. 1, 9-11).

Dimensions: `contact` (the study's [[scene.contact]] entries: a face, a shroud pair
of faces or one element over named DOFs) and `pair` (the elements: one per face node
or node pair; coordinate `pair_contact`, the contact each belongs to).

Static (sweeps..., pair | contact): the nominal preload n0 and the static normal
load s = n0 + kv v0 (`model.static_load`: the structure deflects under n0, no
excitation, with unilateral contact: a pair that would pull is open, s = 0, and the
face totals sum the compressive pairs only), and the pairs in contact per contact.
The attribute `preload_given` says which of the two the study gave
(`sweep.normal_load` gives s; n0 is then solved for it).  The elements' ku, kv, mu as solved (`element_parameters`).

Per point (sweeps..., point, pair | contact), from the exact transition times of
each converged point's periodic contact motion (`contact.period_results`): the fractions
of the period stuck, slipping and separated, the energy dissipated per cycle by
friction per element and per contact, and the normal contact force's mean and half
peak-to-peak.  NaN at points that did not converge and at padding.

A mistuned disk is solved as its full assembly: there `pair` runs over the elements
of every sector (sector-major, coordinate `pair_sector`), and the per-contact
totals sum a contact's elements over the whole wheel (per sector: group the `_pair`
variables by `pair_sector`).  Without contacts nothing is added.
"""
from __future__ import annotations

import numpy as np

from ...contact import YangMenq
from ...contact.period_results import cycle_results
from ...contact.friction2d.law import cycle_results as plane_cycle_results
from ...fourier.harmonics import shift
from .free_direction import WARNED, free_direction_variables
from .harmonics_dataset import add_harmonic_coefficients
from ...model.static_load import NORMAL_LOAD, contact_owner, face_totals, static_state
from ...model.system import contact_set


def wheel_sectors(study) -> int | None:
    """N where a case's system is a mistuned disk's full assembly, else None."""
    sc = study.scene
    return sc.assembly.sectors if getattr(sc, "mistuning", None) is not None else None


def element_owner(study) -> np.ndarray:
    """The index in `scene.contacts` of each element of a case's `System`: one sector's
    (`contact_owner`), tiled over the sectors of a full assembly (sector-major)."""
    owner = contact_owner(study.scene)
    N = wheel_sectors(study)
    return owner if N is None else np.tile(owner, N)


def contact_coords(study) -> dict:
    """`contact` (names), `pair` (index), `pair_contact` (and on a full assembly
    `pair_sector`) coordinates."""
    scene = study.scene
    owner = element_owner(study)
    names = np.asarray([c.name for c in scene.contacts], dtype=str)
    out = {"contact": ("contact", names, {"long_name": "contact of the study "
                                                       "([[scene.contact]] entry)"}),
           "pair": ("pair", np.arange(owner.size, dtype=np.int32),
                    {"units": "1", "long_name": "contact element (face node or node pair) index"}),
           "pair_contact": ("pair", owner.astype(np.int32),
                            {"units": "1", "long_name": "index of the contact the element "
                                                        "belongs to"})}
    N = wheel_sectors(study)
    if N is not None:
        out["pair_sector"] = ("pair", np.repeat(np.arange(N, dtype=np.int32),
                                                owner.size // N),
                              {"units": "1", "long_name": "sector j of the element (0 ... "
                                                          "sectors - 1)"})
    return out


def static_variables(study, cases, systems) -> dict:
    """Nominal preload, and the unilateral static state (`static_load.static_state`):
    the static normal load per pair (0 where the pair opens) and per contact (the
    compressive pairs' sum), and the pairs in contact per contact."""
    scene = study.scene
    owner, C = element_owner(study), len(scene.contacts)
    shape, E = study.sweep.shape, owner.size
    n0 = np.full(shape + (E,), np.nan)
    s = np.full(shape + (E,), np.nan)
    count = np.full(shape + (C,), -1, dtype=np.int32)
    for (idx, _), system in zip(cases, systems):
        if system is None:   # a failed case whose model cannot be built
            continue
        n0[idx] = contact_set(system).elements.n0
        st = static_state(system)
        s[idx] = st.load
        count[idx] = np.bincount(owner[st.closed], minlength=C)
    sw = tuple(study.sweep.axes)
    state = ("with no excitation: the structure deflected under the preload against the "
             "normal springs kv of the pairs in contact, unilateral (a pair that would pull "
             "is open and carries 0); a stuck slider rests at its static position, so ku "
             "carries no static force")
    return {
        "preload_pair": (sw + ("pair",), n0, {
            "units": "N", "long_name": "preload n0 of the element (nominal normal load, "
                                       "n = n0 + kv v)"}),
        "preload_total": (sw + ("contact",), face_totals(n0, owner, C), {
            "units": "N", "long_name": "preload n0 summed over the contact's elements "
                                       "(face total)"}),
        "static_normal_load_pair": (sw + ("pair",), s, {
            "units": "N", "long_name": f"static normal load n0 + kv v0 of the element, 0 where "
                                       f"it opens, {state}"}),
        "static_normal_load": (sw + ("contact",), face_totals(s, owner, C), {
            "units": "N", "long_name": f"static normal load n0 + kv v0 summed over the contact's "
                                       f"elements in contact (face total) {state}"}),
        "static_pairs_in_contact": (sw + ("contact",), count, {
            "units": "1", "long_name": "elements (node pairs) of the contact in contact in the "
                                       "static state (-1: a case whose model was not built)"}),
        **element_parameters(study, cases, systems),
    }


PARAMETERS = {"ku": ("N/m", "tangential stiffness"), "kv": ("N/m", "normal stiffness"),
              "mu": ("1", "friction coefficient"),
              "ku2": ("N/m", "tangential stiffness along the second tangent")}


def element_parameters(study, cases, systems) -> dict:
    """`ku_pair`, `kv_pair`, `mu_pair` (and `ku2_pair` with 2D friction) of every
    element per case: the contact law's parameters as the solver used them (on an FE
    face, its share of the face total by node area; a Python-built study's own numbers)."""
    E = element_owner(study).size
    plane = any(getattr(c, "friction", "1d") == "2d" for c in study.scene.contacts)
    k = {n: np.full(study.sweep.shape + (E,), np.nan)
         for n in (("ku", "kv", "mu", "ku2") if plane else ("ku", "kv", "mu"))}
    for (idx, _), system in zip(cases, systems):
        if system is None:   # a failed case whose model cannot be built
            continue
        for n in k:
            k[n][idx] = getattr(contact_set(system).elements, n)
    sw = tuple(study.sweep.axes)
    return {f"{n}_pair": (sw + ("pair",), v, {"units": PARAMETERS[n][0], "long_name":
                                              f"{PARAMETERS[n][1]} of the element"})
            for n, v in k.items()}


def contact_motions(system, Q):
    """U, V (P, E, 2H+1) [m] of the elements for the DOF coefficients Q (P, n, 2H+1):
    u = Bt q + Bt_next q(tau + phi) on a cyclic sector (the travelling wave), else
    u = Bt q; likewise v (for 2D friction elements u along their first tangent)."""
    X = set_motions(system, Q)
    return X[:, :, 0], X[:, :, -1]


def set_motions(system, Q):
    """X (P, E, D, 2H+1) [m] along the directions of the system's `contact_set` (D = 2:
    u, v; D = 3 for the 2D friction law: u1, u2, v), as `contact_motions`."""
    P, n, nh = Q.shape
    flat = np.moveaxis(Q, 0, 1).reshape(n, P * nh)
    cs = contact_set(system)

    def along(B, X):
        return np.moveaxis(np.asarray(B @ X).reshape(-1, P, nh), 0, 1)

    X = np.stack([along(B, flat) for B in cs.maps], axis=2)
    cy = system.cyclic
    if cy is not None and cs.maps_next:
        nxt = np.moveaxis(shift(Q, cy.phase), 0, 1).reshape(n, P * nh)
        X = X + np.stack([along(B, nxt) for B in cs.maps_next], axis=2)
    return X


def element_cycles(system, X, samples: int) -> dict:
    """`period_results.cycle_results` of the system's contact elements for the motions X
    (P, E, D, 2H+1), flattened to (P E,): exact for Yang-Menq, from the AFT cycle of
    `samples` samples for the 2D friction law."""
    P, E, D, nh = X.shape
    el = contact_set(system).elements
    if D == 3:
        return plane_cycle_results(X.reshape(P * E, D, nh), el.tile(P), samples)
    rest = None if el.slider_rest is None else np.tile(el.slider_rest, P)
    tiled = YangMenq(*(np.tile(getattr(el, k), P) for k in ("ku", "kv", "mu", "n0")),
                     slider_rest=rest)
    return cycle_results(X[:, :, 0].reshape(-1, nh), X[:, :, 1].reshape(-1, nh), tiled)


CYCLE_META = {
    "stick_fraction": ("pair", "1", "fraction of the period the element sticks"),
    "slip_fraction": ("pair", "1", "fraction of the period the element slips (either way)"),
    "separation_fraction": ("pair", "1", "fraction of the period the element is separated"),
    "dissipated_energy_pair": ("pair", "J", "energy dissipated per cycle by the element's "
                                            "friction (slider work, contour integral f_u dw)"),
    "dissipated_energy": ("contact", "J", "energy dissipated per cycle by friction, summed over "
                                          "the contact's elements"),
    "normal_load_mean_pair": ("pair", "N", "mean over the period of the element's normal "
                                           "contact force max(n0 + kv v, 0)"),
    "normal_load_mean": ("contact", "N", "mean over the period of the normal contact force "
                                         "summed over the contact's elements"),
    "normal_load_amplitude_pair": ("pair", "N", "half peak-to-peak of the element's normal "
                                                "contact force max(n0 + kv v, 0)"),
}
PAIR_KEYS = {"stick_fraction": "stick", "slip_fraction": "slip",
             "separation_fraction": "separation", "dissipated_energy_pair": "energy",
             "normal_load_mean_pair": "normal_mean",
             "normal_load_amplitude_pair": "normal_amplitude"}


def cycle_variables(study, cases, curves, systems, converged) -> dict:
    """The per-point contact results of every case (module doc) at the dataset's
    converged points (`converged` (sweeps..., point))."""
    P = converged.shape[-1]
    owner, C = element_owner(study), len(study.scene.contacts)
    shape, E = study.sweep.shape, owner.size
    out = {k: np.full(shape + (P, C if dim == "contact" else E), np.nan)
           for k, (dim, _, _) in CYCLE_META.items()}
    for (idx, _), c, system in zip(cases, curves, systems):
        if c is None:
            continue
        Q = np.asarray(c.Q, float)
        ok = np.flatnonzero(converged[idx][:c.n_points] & np.all(np.isfinite(Q), axis=(1, 2)))
        if not ok.size:
            continue
        r = element_cycles(system, set_motions(system, Q[ok]), study.solver.samples)
        for name, key in PAIR_KEYS.items():
            out[name][idx][ok] = r[key].reshape(ok.size, E)
        out["dissipated_energy"][idx][ok] = face_totals(out["dissipated_energy_pair"][idx][ok],
                                                        owner, C)
        out["normal_load_mean"][idx][ok] = face_totals(out["normal_load_mean_pair"][idx][ok],
                                                       owner, C)
    sw = tuple(study.sweep.axes)
    where = ("computed at every converged point from the exact transition times of its "
             "periodic contact motion (2D friction: from its AFT cycle, fractions of the "
             "samples); NaN at points that did not converge and at padding")
    return {k: (sw + ("point", dim), out[k], {"units": u, "long_name": ln, "comment": where})
            for k, (dim, u, ln) in CYCLE_META.items()}


def peak_motion_variables(study, cases, curves, systems, data_vars) -> dict:
    """Every element's relative motion at each case's peak (the largest converged
    amplitude of the first output DOF, as the `hysteresis_*` variables): enough to
    redraw the loop of a whole contact face (`response_figures.hysteresis_figures`)."""
    owner = contact_owner(study.scene)
    shape, E, nh = study.sweep.shape, owner.size, 2 * study.solver.harmonics + 1
    plane = any(getattr(c, "friction", "1d") == "2d" for c in study.scene.contacts)
    X = np.full(shape + (E, 3 if plane else 2, nh), np.nan)
    point = np.full(shape, -1, dtype=np.int32)
    amp, conv = data_vars["amplitude"][1][..., 0], data_vars["converged"][1]
    for (idx, _), c, system in zip(cases, curves, systems):
        if c is None or not conv[idx].any() or c.Q.shape[-1] != nh:
            continue
        i = int(np.argmax(np.where(conv[idx], amp[idx], -np.inf)))
        X[idx], point[idx] = set_motions(system, np.asarray(c.Q, float)[i:i + 1])[0], i
    sw = tuple(study.sweep.axes)
    first = " along the first tangent" if plane else ""
    out = {"peak_contact_point": (sw, point, {"units": "1", "long_name": "point of the largest "
                                              "converged amplitude of the first output DOF "
                                              "(-1: none)"}),
           "peak_contact_u": (sw + ("pair", "coefficient"), X[..., 0, :], {
               "units": "m", "long_name": f"tangential relative displacement{first} of the "
                                          "element at the peak point, Fourier coefficients"}),
           "peak_contact_v": (sw + ("pair", "coefficient"), X[..., -1, :], {
               "units": "m", "long_name": "normal relative displacement of the element at "
                                          "the peak point, Fourier coefficients"})}
    if plane:
        out["peak_contact_u2"] = (sw + ("pair", "coefficient"), X[..., 1, :], {
            "units": "m", "long_name": "tangential relative displacement along the second "
                                       "tangent (n x t1) of the element at the peak point, "
                                       "Fourier coefficients"})
    return out


def add_contact_variables(data_vars, coords, attrs, study, cases, curves, systems, lay):
    """Add the per-contact variables (module doc) and the response's Fourier
    coefficients (`harmonics_dataset`) to a response dataset in place."""
    add_harmonic_coefficients(data_vars, coords, study, cases, curves, lay)
    if not study.scene.contacts:
        return
    coords.update(contact_coords(study))
    data_vars.update(static_variables(study, cases, systems))
    data_vars.update(cycle_variables(study, cases, curves, systems, data_vars["converged"][1]))
    free, warned = free_direction_variables(study, cases, curves, systems, int(lay.rows[0, 0]))
    if free:   # 1D shroud pairs: how far their faces move along the direction left free
        data_vars.update(free)
        attrs[WARNED] = ", ".join(warned)
    if "hysteresis" in study.output.figures and wheel_sectors(study) is None:
        data_vars.update(peak_motion_variables(study, cases, curves, systems, data_vars))
        coords.setdefault("coefficient", ("coefficient", np.arange(2 * study.solver.harmonics + 1,
                                                                   dtype=np.int32),
                                          {"units": "1", "long_name": "Fourier coefficient "
                                                                      "[a0, a1, b1, a2, b2, ...]"}))
    if wheel_sectors(study) is not None:
        for k in ("preload_total", "static_normal_load", "dissipated_energy", "normal_load_mean"):
            data_vars[k][2]["comment"] = "; ".join(
                filter(None, (data_vars[k][2].get("comment"),
                              "a mistuned disk's full assembly: summed over every sector")))
    attrs["preload_given"] = ("static_normal_load" if NORMAL_LOAD in study.sweep.axes
                              else "n0")
