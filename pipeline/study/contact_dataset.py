"""Per-contact variables of a response dataset: what the preload becomes and what the
contacts do (paper Eq. 1, 9-11).

Dimensions: `contact` (the study's [[scene.contact]] entries: a face, a shroud pair
of faces or one element over named DOFs) and `pair` (the elements: one per face node
or node pair; coordinate `pair_contact`, the contact each belongs to).

Static (sweeps..., pair | contact): the nominal preload n0 and the static normal
load s = n0 + kv v0 (`model.static_load`: the structure deflects under n0 with
every contact closed and stuck, no excitation).  The attribute `preload_given`
says which of the two the study gave (`sweep.normal_load` gives s; n0 is then
solved for it).

Only for scenes whose elements are one sector's (not a mistuned disk's full
assembly); without contacts nothing is added.
"""
from __future__ import annotations

import numpy as np

from ..model.static_load import NORMAL_LOAD, contact_owner, face_totals, static_normal_load


def contact_coords(scene) -> dict:
    """`contact` (names), `pair` (index) and `pair_contact` coordinates."""
    owner = contact_owner(scene)
    names = np.asarray([c.name for c in scene.contacts], dtype=str)
    return {"contact": ("contact", names, {"long_name": "contact of the study "
                                                        "([[scene.contact]] entry)"}),
            "pair": ("pair", np.arange(owner.size, dtype=np.int32),
                     {"units": "1", "long_name": "contact element (face node or node pair) index"}),
            "pair_contact": ("pair", owner.astype(np.int32),
                             {"units": "1", "long_name": "index of the contact the element "
                                                         "belongs to"})}


def static_variables(study, cases, systems) -> dict:
    """Nominal preload and static normal load per pair and per contact."""
    scene = study.scene
    owner, C = contact_owner(scene), len(scene.contacts)
    shape, E = study.sweep.shape, owner.size
    n0 = np.full(shape + (E,), np.nan)
    s = np.full(shape + (E,), np.nan)
    for (idx, _), system in zip(cases, systems):
        n0[idx] = system.contact.n0
        s[idx] = static_normal_load(system)
    sw = tuple(study.sweep.axes)
    closed = ("with every contact closed and stuck and no excitation (the structure deflected "
              "under the preload)")
    return {
        "preload_pair": (sw + ("pair",), n0, {
            "units": "N", "long_name": "preload n0 of the element (nominal normal load, "
                                       "n = n0 + kv v)"}),
        "preload_total": (sw + ("contact",), face_totals(n0, owner, C), {
            "units": "N", "long_name": "preload n0 summed over the contact's elements "
                                       "(face total)"}),
        "static_normal_load_pair": (sw + ("pair",), s, {
            "units": "N", "long_name": f"static normal load n0 + kv v0 of the element {closed}"}),
        "static_normal_load": (sw + ("contact",), face_totals(s, owner, C), {
            "units": "N", "long_name": f"static normal load n0 + kv v0 summed over the contact's "
                                       f"elements (face total) {closed}"}),
    }


def add_contact_variables(data_vars, coords, attrs, study, cases, curves, systems, lay):
    """Add the per-contact variables (module doc) to a response dataset in place."""
    if not study.scene.contacts or lay.sectors is not None:
        return
    coords.update(contact_coords(study.scene))
    data_vars.update(static_variables(study, cases, systems))
    attrs["preload_given"] = ("static_normal_load" if NORMAL_LOAD in study.sweep.axes
                              else "n0")
