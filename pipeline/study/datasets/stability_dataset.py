"""The stability variables of a response dataset: which method decided each point's
`stable`, its largest multiplier, and the bifurcations where the flag changes.

    stability_method (sweeps..., point)  int8: -1 not computed, 0 Hill, 1 Floquet,
                                         2 monodromy along the harmonic-balance orbit,
                                         3 propagated: the flag of the decided points of
                                         its stretch between two folds ("stretch" mode,
                                         `solve.stability.stretches`), no multiplier of its own,
                                         4 fold rule: a verdict at an end of the branch
                                         flipped at every fold (`solve.stability.fold_rule`)
    max_multiplier   (sweeps..., point)  Floquet: largest |mu| of the exact flow;
                                         monodromy: that of the flow linearised along the
                                         HBM orbit; Hill: exp(max Re lambda T)
    bifurcation_frequency (sweeps..., bifurcation)  where the decided flag changes
    bifurcation_type      (sweeps..., bifurcation)  int8: 1 fold, 2 period doubling,
                                         3 Neimark-Sacker, -1 padding

(`pipeline.solve.stability.branch_stability` decides; `response_dataset` calls these helpers.)
"""
from __future__ import annotations

import numpy as np

from ...solve.stability.methods import (FLOQUET, FOLD_RULE, HILL, KINDS, MONODROMY,
                                     NOT_COMPUTED, PROPAGATED, describe)

METHOD_FLAGS = {"flag_values": np.array([NOT_COMPUTED, HILL, FLOQUET, MONODROMY, PROPAGATED,
                                         FOLD_RULE], np.int8),
                "flag_meanings": "not_computed hill floquet monodromy propagated fold_rule"}
TYPE_FLAGS = {"flag_values": np.array([-1] + list(KINDS), np.int8),
              "flag_meanings": "none " + " ".join(k.replace(" ", "_").replace("-", "_")
                                                  for k in KINDS.values())}


def bifurcation_count(curves) -> int:
    return max([1] + [np.size(c.bifurcation_parameter) for c in curves
                      if getattr(c, "bifurcation_parameter", None) is not None])


def stability_arrays(shape: tuple, P: int, B: int) -> dict:
    """The stability arrays of one dataset, all padding."""
    return dict(stability_method=np.full(shape + (P,), NOT_COMPUTED, np.int8),
                max_multiplier=np.full(shape + (P,), np.nan),
                bifurcation_frequency=np.full(shape + (B,), np.nan),
                bifurcation_type=np.full(shape + (B,), -1, np.int8))


def fill_stability(v: dict, idx, c, converged, computed: bool, to_unit: float):
    """Write curve `c`'s stability arrays at grid index `idx` (only converged points
    carry a method and a multiplier)."""
    p = c.n_points
    if not computed:
        return
    method = getattr(c, "stability_method", None)
    if method is None:          # a curve that records no method: Hill's exponents
        method = np.full(p, HILL, np.int8)
        mult = np.full(p, np.nan)
    else:
        fq, hill = np.asarray(c.floquet_multiplier, float), np.asarray(c.hill_multiplier, float)
        orb = getattr(c, "monodromy_multiplier", None)
        orb = np.full(p, np.nan) if orb is None else np.asarray(orb, float)
        mult = np.where(method == FLOQUET, fq, np.where(method == MONODROMY, orb,
                                                        np.where(method == HILL, hill, np.nan)))
    v["stability_method"][idx][:p] = np.where(converged, method, NOT_COMPUTED)
    v["max_multiplier"][idx][:p] = np.where(converged, mult, np.nan)
    bp = getattr(c, "bifurcation_parameter", None)
    if bp is not None and np.size(bp):
        b = np.size(bp)
        v["bifurcation_frequency"][idx][:b] = np.asarray(bp, float) / to_unit
        v["bifurcation_type"][idx][:b] = c.bifurcation_kind


def stability_meta(unit: str) -> dict:
    """name -> (dims after the sweep axes, units, long_name) of the stability variables."""
    return {
        "stability_method": (("point",), "1", "method that decided 'stable' at this point"),
        "max_multiplier": (("point",), "1", "largest Floquet multiplier modulus of the "
                                            "deciding method"),
        "bifurcation_frequency": (("bifurcation",), unit,
                                  "frequency where the decided stability flag changes"),
        "bifurcation_type": (("bifurcation",), "1",
                             "type of the multiplier leaving the unit circle there")}


def stability_note(mode, notes) -> str:
    """The global `stability` attribute: the cases' own descriptions (a cyclic sector
    whose wheel is too large for the Floquet check keeps Hill), else the mode's."""
    own = sorted({n for n in notes if n})
    return "; ".join(own) if own else describe(mode)


def stability_attrs(data_vars: dict):
    """Flag and comment attributes of the stability variables."""
    data_vars["stability_method"][2].update(
        METHOD_FLAGS, comment="-1 where 'stable' is NaN; where a check ran, its "
                              "multipliers decide (the exact Floquet multipliers; the "
                              "orbit monodromy's on flows beyond the shooting)")
    data_vars["max_multiplier"][2].update(
        comment="stability_method 1 (floquet): max |mu| of the monodromy matrix of the exact "
                "event-driven flow; stability_method 2 (monodromy): max |mu| of the "
                "monodromy of that flow linearised along the harmonic-balance orbit; "
                "stability_method 0 (hill): Hill's equivalent "
                "exp(max Re lambda * T) of its selected Floquet exponents (T = 2 pi / Omega); "
                "stability_method 3 (propagated): NaN, the flag is that of the decided "
                "points of its stretch between two folds; stability_method 4 (fold rule): "
                "NaN, the flag is that of a decided end of the branch flipped at every fold; "
                "NaN where not computed. > 1: unstable")
    data_vars["bifurcation_type"][2].update(
        TYPE_FLAGS, comment="from the multiplier leaving the unit circle on the unstable side: "
                            "a detected fold between the two points, or a real multiplier "
                            "through +1 (fold), through -1 (period doubling), a complex pair "
                            "(Neimark-Sacker); -1: padding")
    data_vars["bifurcation_frequency"][2].update(
        comment="between two converged neighbours of different decided flags: a fold's "
                "frequency, else where the decided multiplier crosses 1 (log-linear "
                "interpolation); NaN: padding")
