"""FE blades and their Craig-Bampton reductions, built once per frozen spec.

`blade_model`, `blade_at_speed` and `reduced_model` are cached on the frozen
`scene.Blade` and `scene.CraigBampton` specs (`functools.lru_cache`): scenes sharing a
structure share its model.  `reduced_dof_names` names a reduction's coordinates.
"""
from __future__ import annotations

import time
from dataclasses import replace
from functools import lru_cache, wraps
from inspect import signature

import numpy as np

RPM = 2.0 * np.pi / 60.0   # rad/s per rpm
POINT_SETS = ("excitation", "response")   # FE node sets named by direction in DOF names
CUT_SETS = ("cyclic_low", "cyclic_high")  # a disk sector's cut faces (`fe_model.CUT_SETS`)
COMPONENTS = "xyz"


def spec_cache(maxsize: int):
    """`functools.lru_cache` keyed on the arguments with their defaults filled in: a call
    with `speed` left out and one with speed = 0.0 share one entry (one reduction, not
    two); `cache_clear` as lru_cache's."""
    def wrap(fun):
        store, sig = lru_cache(maxsize=maxsize)(fun), signature(fun)

        @wraps(fun)
        def call(*args, **kwargs):
            bound = sig.bind(*args, **kwargs)
            bound.apply_defaults()
            return store(*bound.args)
        call.cache_clear = store.cache_clear
        return call
    return wrap


def blade_model(structure):
    """The `fe_model.BladeModel` of a `Blade` spec (built once per spec)."""
    return timed_blade_model(structure)[0]


@lru_cache(maxsize=8)
def timed_blade_model(structure) -> tuple:
    """(`fe_model.BladeModel` of a `Blade` spec, the wall time [s] its build took)."""
    # deferred: blades imports scikit-fem and meshio (about a second); lumped
    # scenes never need them
    from ..structure.blades import build_blade, load_blade

    t0 = time.perf_counter()
    centre = structure.disk.centre if structure.rotating else None
    if structure.matrices is not None:
        # deferred: an imported blade alone reads exported matrices
        from ..structure.exchange.imported import import_blade
        blade = import_blade(structure.mesh, structure.matrices, structure.params,
                             rotation_centre=centre, disk=structure.disk)
    elif structure.disk_sector is not None:
        from ..structure.disk_sector import sector_blade
        blade = sector_blade(structure.params, structure.disk, structure.disk_sector,
                             rotation_centre=centre)
    elif structure.mesh:
        blade = load_blade(structure.mesh, structure.params, required=("root",),
                           rotation_centre=centre, scale=structure.mesh_scale,
                           disk=structure.disk)
    else:
        blade = build_blade(structure.params, structure.disk, rotation_centre=centre)
    return blade, time.perf_counter() - t0


@lru_cache(maxsize=16)
def blade_at_speed(structure, speed: float):
    """The blade turning at `speed` [rpm]: K + Omega^2 (K_sigma1 - M_P + K_1) + Omega^4 K_2, Omega = speed
    x 2 pi / 60 (`structure.rotation`); at speed 0 the blade itself."""
    blade = blade_model(structure)
    if speed == 0.0:
        return blade
    if blade.rotation is None:
        raise ValueError(f"speed {speed} rpm on a blade that does not turn: declare "
                         "\"centrifugal_stiffening\" (a solid blade in a disk)")
    return replace(blade, K=(blade.K + blade.rotation.speed_stiffness(speed * RPM)).tocsr())


def case_speed(structure, case: dict | None) -> float:
    """The rotation speed [rpm] of a case: its `speed`, else the structure's."""
    return float((case or {}).get("speed", getattr(structure, "speed", 0.0)))


@spec_cache(maxsize=16)
def reduced_model(structure, reduction, speed: float = 0.0) -> tuple:
    """(Craig-Bampton `ReducedModel` keeping contact faces, excitation and response
    DOFs, its wall time [s]) of a blade turning at `speed` [rpm] (built once per spec
    pair and speed)."""
    # looked up at each call: a replaced `reduction.reduce_blade` is the one called
    from ..structure.reduction import reduce_blade

    kw = {"rayleigh": structure.rayleigh} if structure.rayleigh is not None else {}
    blade = blade_at_speed(structure, speed)
    t0 = time.perf_counter()
    red = reduce_blade(blade, reduction.modes, **kw)
    return red, time.perf_counter() - t0


def reduced_dof_names(red) -> tuple:
    """Names of reduced coordinates: `<set>.<c>` (point sets), `<face>.<k>.<c>`,
    `mode.<j>` (modal coordinates)."""
    names = [lab.replace(":", ".") for lab in red.labels]
    for s in POINT_SETS:
        if s in red.sets:
            for c, pos in enumerate(red.sets[s][0]):
                names[pos] = f"{s}.{COMPONENTS[c]}"
    return tuple(names)


@spec_cache(maxsize=16)
def cut_model(structure, reduction, speed: float = 0.0):
    """The `cyclic_cut.CutSector` of a reduced blade whose structure has cyclic cut
    faces (a disk sector: `cyclic_low`, `cyclic_high`), its cut faces joined to the
    neighbours' and reduced to `reduction.cut_face_modes` modes per phase (None: all
    their DOFs); None for a blade without cut faces."""
    from ..structure.cyclic_cut import cut_pairing, cut_sector

    red = reduced_model(structure, reduction, speed)[0]
    if not all(s in red.sets for s in CUT_SETS):
        return None
    disk = structure.disk
    if disk is None:
        raise ValueError("cyclic_low, cyclic_high: cut faces need [scene.disk] (sectors, "
                         "hub_radius: the disk axis)")
    blade = blade_at_speed(structure, speed)
    high = cut_pairing(*(blade.set_points[s] for s in CUT_SETS), disk)
    return cut_sector(red.K, red.M, red.C, red.sets["cyclic_low"], red.sets["cyclic_high"][high],
                      red.n_boundary, disk.rotation(disk.pitch_angle), reduced_dof_names(red),
                      getattr(reduction, "cut_face_modes", None))


def sector_names(structure, reduction) -> tuple:
    """Names of a reduced sector's coordinates: the reduction's (`reduced_dof_names`), or
    a disk sector's after its cut (`cut_model`; `cut.<k>` the cut-face modes)."""
    cut = cut_model(structure, reduction)
    return cut.names if cut is not None else reduced_dof_names(reduced_model(structure,
                                                                             reduction)[0])


def sector_map(structure, reduction, speed: float, B) -> np.ndarray:
    """A map B (E, n_full) of the blade's boundary DOFs on a case's sector coordinates
    (dense): B T of the reduction (`reduction.reduce_map`), and for a disk sector B T
    T_own after its cut (`cut_model`; B must not touch the high cut face)."""
    from ..structure.reduction import reduce_map

    out = reduce_map(reduced_model(structure, reduction, speed)[0], B)
    cut = cut_model(structure, reduction, speed)
    if cut is None:
        return out
    if np.abs(out @ cut.T_next).max(initial=0.0) > 0:
        raise ValueError("a contact or a load touches the cut face cyclic_high")
    return out @ cut.T_own


def sector_coordinates(structure, reduction, speed: float, q, angle: float = 0.0):
    """The reduction's coordinates r of a case's sector coordinates q (n, ...): q itself,
    or a disk sector's own and next sector's parts on a wave of inter-sector phase
    `angle` [rad] (`cyclic_cut.CutSector.coordinates`)."""
    cut = cut_model(structure, reduction, speed)
    return q if cut is None else cut.coordinates(q, angle)
