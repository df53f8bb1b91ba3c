"""The optimum search in the study dataset: the optimum and the peak-versus-preload
curve it was found on (`peak_tracking.optimum_preload`).  An interference search
(`[output.optimum_interference]`) names them after its variable (`optimum_interference`
[m], coordinate `optimum_search_interference`) and adds the actual static contact load
of each evaluation and of the optimum (face totals per contact and pairs in contact:
the unilateral static state, as the cases' `static_normal_load`)."""
from __future__ import annotations

import numpy as np

from ..files.study_types import OPTIMUM_UNITS, optimum_variable


def add_optimum(data_vars, coords, opt, study, to_unit, unit):
    """Optimum preload (a search, not a grid read-off) and the peak-versus-preload curve
    it was found on: every preload evaluated, sorted, as the coordinate
    `optimum_search_preload` [N] (NaN peaks: incomplete curves); an interference
    search's the same in m, with its static contact loads."""
    dof = study.output.optimum["dof"]
    var = optimum_variable(study.output.optimum)
    vu = OPTIMUM_UNITS[var]
    ev = np.array(opt["evaluations"], dtype=float).reshape(-1, 3)
    dim = f"optimum_search_{var}"
    grid = np.asarray(opt.get("grid", []), dtype=float)
    coords[dim] = (dim, ev[:, 0], {"units": vu, "long_name": f"{var} evaluated by the "
                                                             "optimum search"})
    data_vars[f"optimum_{var}"] = ((), float(opt["preload"]), {
        "units": vu, "long_name": f"{var} minimising the resonant peak of {dof} (peak on "
                                  f"a grid of {grid.size} {var}s over the bounds, Brent in "
                                  "each bracketed minimum, the best taken)",
        **independence_attrs(opt, var, vu)})
    data_vars["optimum_peak_amplitude"] = ((), float(opt["peak"]), {
        "units": "m", "long_name": f"resonant peak of {dof} at the optimum {var} (at every "
                                   f"{var} where independent_of_{var} is 1)"})
    data_vars["optimum_peak_frequency"] = ((), float(opt["peak_omega"]) / to_unit, {
        "units": unit, "long_name": "frequency of that peak"})
    data_vars["optimum_search_peak"] = ((dim,), ev[:, 1], {
        "units": "m", "long_name": f"resonant peak of {dof} at that {var} (NaN: "
                                   "incomplete curve; where optimum_search_band is 0, the "
                                   f"local peak continued from a nearby {var}, a lower "
                                   "bound)"})
    data_vars["optimum_search_peak_frequency"] = ((dim,), ev[:, 2] / to_unit, {
        "units": unit, "long_name": "frequency of that peak"})
    data_vars["optimum_search_is_optimum"] = ((dim,), (ev[:, 0] == opt["preload"]).astype(
        np.int8), {"units": "1", "long_name": f"1 at the optimum {var}, else 0"})
    data_vars["optimum_search_on_grid"] = ((dim,), np.isin(ev[:, 0], grid).astype(np.int8), {
        "units": "1", "long_name": "1: a node of the search grid, 0: a Brent refinement"})
    local = np.isin(ev[:, 0], np.asarray(opt.get("local", []), dtype=float))
    data_vars["optimum_search_band"] = ((dim,), (~local).astype(np.int8), {
        "units": "1", "long_name": "1: the peak over the whole band; 0: the local peak "
                                   f"continued from the nearest {var} evaluated (a lower "
                                   "bound of the band's, used by Brent's trials only)"})
    steps = opt.get("unresolved", {})
    data_vars["optimum_search_unresolved_steps"] = ((dim,), np.array(
        [steps.get(float(n0), 0) for n0 in ev[:, 0]], dtype=np.int32), {
        "units": "1", "long_name": f"steps of that {var}'s band evaluation across a "
                                   "resonance that could not be shortened to its half-power "
                                   "band: a peak may hide there (0: none)"})
    data_vars["optimum_search_outside_peak"] = ((dim,), np.isin(ev[:, 0], np.asarray(
        opt.get("outside", []), dtype=float)).astype(np.int8), {
        "units": "1", "long_name": "1: that band evaluation's largest amplitude traced lies "
                                   "outside the window (its branch followed beyond it); "
                                   "optimum_search_peak is the largest inside"})
    data_vars["optimum_search_wall_time"] = ((), float(opt.get("wall_time", np.nan)), {
        "units": "s", "long_name": "wall time of the optimum search"})
    if "static" in opt:
        add_static_loads(data_vars, opt, ev[:, 0], dim, len(study.scene.contacts))


def add_static_loads(data_vars, opt, values, dim, C):
    """The static contact state of every evaluation and of the optimum (NaN, -1 where
    there is none: no optimum, or no static solution)."""
    static = opt["static"]
    load = np.array([static.get(float(x), (np.full(C, np.nan),))[0] for x in values],
                    dtype=float).reshape(-1, C)
    pairs = np.array([static.get(float(x), (None, np.full(C, -1)))[1] for x in values],
                     dtype=np.int32).reshape(-1, C)
    at = np.flatnonzero(values == opt["preload"])
    state = ("static normal load n0 + kv v0 summed over the contact's elements in contact "
             "(face total), no excitation, unilateral (as static_normal_load)")
    data_vars["optimum_search_static_normal_load"] = ((dim, "contact"), load, {
        "units": "N", "long_name": f"{state}, at that interference"})
    data_vars["optimum_search_static_pairs_in_contact"] = ((dim, "contact"), pairs, {
        "units": "1", "long_name": "elements (node pairs) of the contact closed in that static "
                                   "state (-1: not solved)"})
    data_vars["optimum_static_normal_load"] = (("contact",), load[at[0]] if at.size else
                                               np.full(C, np.nan), {
        "units": "N", "long_name": f"{state}, at the optimum interference (NaN: none)"})
    data_vars["optimum_static_pairs_in_contact"] = (("contact",), pairs[at[0]] if at.size else
                                                    np.full(C, -1, np.int32), {
        "units": "1", "long_name": "elements of the contact closed at the optimum "
                                   "interference (-1: none)"})


def independence_attrs(opt, var="preload", unit="N") -> dict:
    """The attributes of `optimum_preload` (`optimum_<var>`) that say whether the peak
    depends on the searched variable at all: independent_of_<var> 1 (the value is then
    NaN: no optimum) or 0, and the grid values' relative spread
    (`optimum.relative_spread`); where the smallest peak is shared by a stretch of the
    bounds (`optimum.flat_minimum`), plateau_low, plateau_high [unit] and NaN."""
    spread = float(opt.get("spread", np.nan))
    out = {f"independent_of_{var}": np.int8(bool(opt.get("independent", False))),
           "peak_relative_spread": spread}
    if opt.get("independent", False):
        out["comment"] = (f"NaN: the peak is the same at every {var} of the grid (relative "
                          f"spread {spread:.3g}, below 1e-9): it does not depend on the "
                          f"{var}, so no {var} is optimal")
    elif opt.get("plateau") is not None:
        lo, hi = opt["plateau"]
        out.update(plateau_low=float(lo), plateau_high=float(hi))
        out["comment"] = (f"NaN: the smallest peak is the same from {lo:.6g} to {hi:.6g} "
                          f"{unit} (plateau_low, plateau_high): no single {var} is optimal")
    return out
