"""The optimum-preload search in the study dataset: the optimum and the
peak-versus-preload curve it was found on (`peak_tracking.optimum_preload`)."""
from __future__ import annotations

import numpy as np


def add_optimum(data_vars, coords, opt, study, to_unit, unit):
    """Optimum preload (a search, not a grid read-off) and the peak-versus-preload curve
    it was found on: every preload evaluated, sorted, as the coordinate
    `optimum_search_preload` [N] (NaN peaks: incomplete curves)."""
    dof = study.output.optimum["dof"]
    ev = np.array(opt["evaluations"], dtype=float).reshape(-1, 3)
    dim = "optimum_search_preload"
    grid = np.asarray(opt.get("grid", []), dtype=float)
    coords[dim] = (dim, ev[:, 0], {"units": "N", "long_name": "preload evaluated by the "
                                                              "optimum search"})
    data_vars["optimum_preload"] = ((), float(opt["preload"]), {
        "units": "N", "long_name": f"preload minimising the resonant peak of {dof} (peak on "
                                   f"a grid of {grid.size} preloads over the bounds, Brent in "
                                   "each bracketed minimum, the best taken)",
        **independence_attrs(opt)})
    data_vars["optimum_peak_amplitude"] = ((), float(opt["peak"]), {
        "units": "m", "long_name": f"resonant peak of {dof} at the optimum preload (at every "
                                   "preload where independent_of_preload is 1)"})
    data_vars["optimum_peak_frequency"] = ((), float(opt["peak_omega"]) / to_unit, {
        "units": unit, "long_name": "frequency of that peak"})
    data_vars["optimum_search_peak"] = ((dim,), ev[:, 1], {
        "units": "m", "long_name": f"resonant peak of {dof} at that preload (NaN: "
                                   "incomplete curve; where optimum_search_band is 0, the "
                                   "local peak continued from a nearby preload, a lower "
                                   "bound)"})
    data_vars["optimum_search_peak_frequency"] = ((dim,), ev[:, 2] / to_unit, {
        "units": unit, "long_name": "frequency of that peak"})
    data_vars["optimum_search_is_optimum"] = ((dim,), (ev[:, 0] == opt["preload"]).astype(
        np.int8), {"units": "1", "long_name": "1 at the optimum preload, else 0"})
    data_vars["optimum_search_on_grid"] = ((dim,), np.isin(ev[:, 0], grid).astype(np.int8), {
        "units": "1", "long_name": "1: a node of the search grid, 0: a Brent refinement"})
    local = np.isin(ev[:, 0], np.asarray(opt.get("local", []), dtype=float))
    data_vars["optimum_search_band"] = ((dim,), (~local).astype(np.int8), {
        "units": "1", "long_name": "1: the peak over the whole band; 0: the local peak "
                                   "continued from the nearest preload evaluated (a lower "
                                   "bound of the band's, used by Brent's trials only)"})
    steps = opt.get("unresolved", {})
    data_vars["optimum_search_unresolved_steps"] = ((dim,), np.array(
        [steps.get(float(n0), 0) for n0 in ev[:, 0]], dtype=np.int32), {
        "units": "1", "long_name": "steps of that preload's band evaluation across a "
                                   "resonance that could not be shortened to its half-power "
                                   "band: a peak may hide there (0: none)"})
    data_vars["optimum_search_outside_peak"] = ((dim,), np.isin(ev[:, 0], np.asarray(
        opt.get("outside", []), dtype=float)).astype(np.int8), {
        "units": "1", "long_name": "1: that band evaluation's largest amplitude traced lies "
                                   "outside the window (its branch followed beyond it); "
                                   "optimum_search_peak is the largest inside"})
    data_vars["optimum_search_wall_time"] = ((), float(opt.get("wall_time", np.nan)), {
        "units": "s", "long_name": "wall time of the optimum search"})


def independence_attrs(opt) -> dict:
    """The attributes of `optimum_preload` that say whether the peak depends on the
    preload at all: independent_of_preload 1 (the value is then NaN: no optimum) or
    0, and the grid values' relative spread (`optimum.relative_spread`)."""
    spread = float(opt.get("spread", np.nan))
    out = {"independent_of_preload": np.int8(bool(opt.get("independent", False))),
           "peak_relative_spread": spread}
    if opt.get("independent", False):
        out["comment"] = (f"NaN: the peak is the same at every preload of the grid (relative "
                          f"spread {spread:.3g}, below 1e-9): it does not depend on the "
                          "preload, so no preload is optimal")
    return out
