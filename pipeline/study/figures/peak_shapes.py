"""The forced-response shape at each case's peak as VTU (meshio, ParaView), for FE
blade scenes (not a mistuned disk's full assembly):

    results/<name>/peak_shape_<axis>_<value>....vtu

holding, on the blade mesh, the harmonic-1 deflection at the peak (the largest
converged amplitude of the first output DOF) as `harmonic1_re`, `harmonic1_im`,
`harmonic1_abs` [m] (x(t) = Re(X1 exp(i W t)) with X1 = c_1 - i s_1), the static
part `static` [m], and on the contact-face nodes (NaN elsewhere) the element
results of that point (`contact_dataset`): `stick_fraction`, `slip_fraction`,
`separation_fraction` [-], `dissipated_energy` [J per cycle], `normal_load_mean` [N].
A shroud pair's element sits on its right-face node; the mesh holds the
vertices only, so elements on mid-side face nodes are not drawn (every element is
in the dataset, with the face totals).  A Craig-Bampton-reduced
solution is expanded to the whole blade (`reduction.reconstruct`) by the reduction
of its case's speed (a turning blade's modes and constraint modes are those of
K(Omega))."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...model.contacts import FaceContact, ShroudPair
from ...model.scene import Lumped
from ...model.blade_cache import blade_model, case_speed, reduced_model, sector_coordinates
from ...model.build import engine_order
from ...structure.fe_model import point_displacements
from ...structure.reduction import reconstruct

FIELDS = {"stick_fraction": "stick_fraction", "slip_fraction": "slip_fraction",
          "separation_fraction": "separation_fraction",
          "dissipated_energy": "dissipated_energy_pair",
          "normal_load_mean": "normal_load_mean_pair"}


def element_points(model, contacts) -> tuple:
    """(elements, mesh points): the contact elements (in the element order of
    `contacts.fe_contact_maps`) whose face node (a shroud pair's right-face node) is
    a point of the output mesh, and that point.  The output mesh holds the elements'
    vertices only: elements on mid-side face nodes have no point there."""
    pts = np.concatenate([np.asarray(model.frames["shroud_right" if isinstance(c, ShroudPair)
                                                 else c.face].points, float)
                          for c in contacts]) if contacts else np.zeros((0, 3))
    d = np.linalg.norm(model.points[None, :, :] - pts[:, None, :], axis=-1)
    near = np.argmin(d, axis=1) if len(pts) else np.zeros(0, int)
    scale = np.ptp(model.points, axis=0).max()
    on = np.flatnonzero(d[np.arange(len(pts)), near] <= 1e-9 * scale) if len(pts) else near
    return on, near[on]


def case_label(case: dict) -> str:
    return "_".join(f"{a}_{v:g}" for a, v in case.items()) or "case"


def write_peak_shapes(study, ds, curves, out_dir) -> list:
    """One VTU per case with a converged peak (module doc); [] for other scenes."""
    # deferred: meshio (slow import), only when mode shapes are written
    from ...structure.mesh_io import write_mesh

    scene = study.scene
    if (isinstance(scene.structure, Lumped) or scene.mistuning is not None
            or not all(isinstance(c, (FaceContact, ShroudPair)) for c in scene.contacts)
            or "pair" not in ds.dims):
        return []
    model = blade_model(scene.structure)
    if not model.cells:
        return []
    elems, nodes = element_points(model, scene.contacts)
    axes, paths = list(study.sweep.axes), []
    for (idx, case), c in zip(study.sweep.cases(), curves):
        sub = ds.isel(dict(zip(axes, idx)))
        ok = sub["converged"].values
        if c is None or not ok.any():
            continue
        amp = sub["amplitude"].isel(dof=0).values
        i = int(np.argmax(np.where(ok, amp, -np.inf)))
        Q = np.asarray(c.Q[i], float)
        speed = case_speed(scene.structure, case)
        red = reduced_model(scene.structure, scene.reduction, speed)[0] if scene.reduction else None
        phi = 2 * np.pi * engine_order(scene, case) / scene.assembly.sectors if scene.cyclic else 0.0
        fields = {"static": (Q[:, 0], 0.0), "harmonic1": (Q[:, 1] - 1j * Q[:, 2], phi)}
        data = {}
        for name, (q, angle) in fields.items():
            if red is not None:    # a disk sector's: from its own and the next sector's parts
                q = reconstruct(red, sector_coordinates(scene.structure, scene.reduction, speed,
                                                        q, angle))
            d = point_displacements(model, q)
            if np.iscomplexobj(d):
                data[f"{name}_re"], data[f"{name}_im"] = d.real, d.imag
                data[f"{name}_abs"] = np.abs(d)
            else:
                data[name] = d
        for name, var in FIELDS.items():
            f = np.full(len(model.points), np.nan)
            f[nodes] = sub[var].isel(point=i).values[elems]
            data[name] = f
        path = Path(out_dir) / f"peak_shape_{case_label(case)}.vtu"
        paths.append(write_mesh(model, path, data))
    return paths
