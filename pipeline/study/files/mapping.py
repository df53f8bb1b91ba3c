"""A validated lumped or disk study as the document its study file would be
(`study_to_mapping`): what checks a study built in Python by the file's rules, and
what rebuilds it (`documents.study_from_document`)."""
from __future__ import annotations

import numpy as np

from .spec import Study


def study_to_mapping(study: Study) -> dict:
    """The canonical document of a validated study: explicit M, C, K, coefficient
    rows for contacts, every default spelt out, no [quick] table (the variant that
    was loaded).  `documents.study_from_document(study_to_mapping(s))` rebuilds the same study."""
    sc = study.scene
    cdofs = sc.contact_dofs  # disk scenes: also next.<dof>

    def row(r):
        return {d: float(c) for d, c in zip(cdofs, r) if c != 0}

    contacts = []
    for c in sc.contacts:
        e = {"name": c.name, "tangential": row(c.bt), "ku": c.ku, "kv": c.kv, "mu": c.mu}
        if np.any(c.bn):
            e["normal"] = row(c.bn)
        if c.n0 is not None:
            e["n0"] = c.n0
        contacts.append(e)
    sector_dofs = sc.sector_dofs  # disk scenes: the sector's names
    forcing = sc.loads[0].amplitudes
    excitation = [{"dof": sector_dofs[j], "amplitude": float(abs(F)), "harmonic": int(h),
                   "phase": float(np.angle(F)) if h else 0.0}
                  for j, h in zip(*np.nonzero(forcing)) for F in [forcing[j, h]]]
    fr = study.sweep.frequency
    sweep = {a: list(v) for a, v in study.sweep.axes.items()}
    sweep["frequency"] = {"start": fr.start, "stop": fr.stop, "unit": fr.unit}
    solver = {k: v for k, v in vars(study.solver).items() if v is not None}
    out = study.output
    output = {"dofs": list(out.dofs), "figures": list(out.figures), "yscale": out.yscale,
              "peak_windows": [list(w) for w in out.peak_windows]}
    if out.optimum is not None:
        o = out.optimum
        output["optimum_preload"] = {"dof": o["dof"], "bounds": list(o["bounds"]), "rtol": o["rtol"]}
        if o["window"] is not None:
            w = o["window"]
            output["optimum_preload"]["frequency"] = {"start": w.start, "stop": w.stop, "unit": w.unit}
    scene = {"model": sc.model, "effects": list(sc.effects), "dofs": list(sector_dofs),
             "matrices": {k: getattr(sc.structure, k).tolist() for k in ("M", "C", "K")},
             "contact": contacts, "excitation": excitation}
    if sc.model == "disk":
        scene["disk"] = {"sectors": sc.assembly.sectors}
        if sc.assembly.engine_order is not None:
            scene["disk"]["engine_order"] = sc.assembly.engine_order
        if sc.assembly.springs:
            scene["disk"]["spring"] = [{"name": s.name, "elongation": row(s.row), "k": s.k}
                                       for s in sc.assembly.springs]
        if sc.mistuning is not None and sc.mistuning.factors is not None:
            scene["disk"]["mistuning"] = {"factors": list(sc.mistuning.factors)}
        elif sc.mistuning is not None:
            mis = {"stiffness_std": sc.mistuning.stiffness_std}
            if sc.mistuning.seed is not None:
                mis["seed"] = sc.mistuning.seed
            scene["disk"]["mistuning"] = mis
    return {
        "study": {"title": study.title, "description": study.description,
                  "reference": study.reference},
        "scene": scene,
        "sweep": sweep,
        "solver": solver,
        "output": output,
    }
