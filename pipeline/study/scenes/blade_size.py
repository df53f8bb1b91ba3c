"""Plausibility of a generated FE blade's dimensions, checked before anything is meshed.

Lengths in a study file are metres; a length typed in millimetres (hub_radius = 120
for 0.12 m) is accepted by every range check on its own, and then the wheel derives a
shroud width 1000 times too large (`structure.disk.wheel_shroud_width`, proportional
to R + L), meshed at the chordwise element size: hundreds of thousands of DOFs for a
blade of a few thousand.  Three rules, each one error naming the field:

- the blade's own lengths (length, chord, thickness, shroud chord, width, height)
  within a factor MAX_DIMENSION_RATIO of each other (a real airfoil: thickness/length
  ~ 1/25, this blade; 1/1000 is a millimetre value among metres);
- the hub radius at most MAX_HUB_TO_LENGTH blade lengths (hub-to-tip ratio R/(R + L)
  below 0.95; shrouded turbine stages stay below about 0.9);
- the model's free DOFs, counted from the parameters (`structure.mesh_size`), at most
  MAX_FE_DOFS: the Craig-Bampton reduction factorises the interior stiffness, whose
  fill grows faster than the size (`bench blade`: 97,650 DOFs in 41-44 s and 4.2-4.3 GB,
  the largest measured; 35,250 DOFs, 12 s of CPU).  The default blade has 11,934 DOFs
  (8 x 2 x 20 elements), 16 x 4 x 40 elements 82,689.

A generated blade's dimensions are also at most MAX_LENGTH (`structure.fe_model`, which
also bounds a mesh file's span, `mesh_io.check_span`); every blade's [scene.blade]
material (E, rho) lies within the range of blade materials in SI units (`check_material`).  A mesh file
(`mesh = "file"`) is not checked here: its size is the file's.
"""
from __future__ import annotations

from ...structure.disk import wheel_shroud_width
from ...structure.fe_model import DENSITY_RANGE, MAX_LENGTH, BladeParams
from ...structure.mesh_size import mesh_size

MAX_DIMENSION_RATIO = 1000.0
MAX_HUB_TO_LENGTH = 20.0
MAX_FE_DOFS = 100_000
LENGTHS = ("length", "chord", "thickness", "shroud_chord", "shroud_width", "shroud_height")
# [SI] the materials a blade is made of (polymers to tungsten carbide), unit slips outside
MATERIAL = {"E": (1e9, 1e12, "Pa", "Young's modulus", (("MPa", 1e6), ("GPa", 1e9))),
            "rho": (*DENSITY_RANGE, "kg/m^3", "density", (("t/mm^3", 1e12), ("g/cm^3", 1e3)))}


def check_material(ck, p: BladeParams, where) -> None:
    """Fail through `ck` when E or rho lies outside every blade material's range in SI
    units (E = 2.1e5 is MPa, rho = 7.85e-9 t/mm^3: a blade 1e6 times too soft or
    1e12 times too light, solved without a word)."""
    for k, (lo, hi, unit, what, others) in MATERIAL.items():
        x = getattr(p, k)
        if not lo <= x <= hi:
            hint = "; ".join(f"{x:g} {o} is {x * f:g} {unit}" for o, f in others
                             if lo <= x * f <= hi)   # the slips that would make sense
            ck.fail(where(k), f"{x:g} {unit} is no blade material's {what} ({lo:g} to {hi:g} "
                              f"{unit}): SI units" + (f" ({hint})" if hint else ""))


def check_blade_size(ck, given: dict, p: BladeParams, placement, where) -> None:
    """Fail through `ck` when the generated blade of `p` (placed by `placement`, a
    `DiskPlacement` or None) is implausible; `given` is the [scene.blade] table as
    written (the fields to blame), `where(key)` the field of one of its keys (quick
    overrides name their own)."""

    dims = {k: getattr(p, k) for k in LENGTHS
            if p.shroud or not k.startswith("shroud")}
    if placement is not None:   # a wheel derives the shroud width: the given one is unused
        dims.pop("shroud_width", None)
    hi, lo = max(dims, key=dims.get), min(dims, key=dims.get)
    if dims[hi] > MAX_LENGTH:
        ck.fail(where(hi if hi in given else next(iter(k for k in LENGTHS if k in given), hi)),
                f"{dims[hi]:g} m ({hi}) is larger than any turbine blade's (at most "
                f"{MAX_LENGTH:g} m): lengths are in metres (a value in millimetres?)")
    if dims[hi] > MAX_DIMENSION_RATIO * dims[lo]:
        blame = hi if hi in given or lo not in given else lo
        ck.fail(where(blame), f"{dims[hi]:g} m ({hi}) is {dims[hi] / dims[lo]:.3g} times "
                              f"{dims[lo]:g} m ({lo}), more than {MAX_DIMENSION_RATIO:g}: "
                              "lengths are in metres (a value in millimetres?)")
    if placement is not None and placement.hub_radius > MAX_HUB_TO_LENGTH * p.length:
        R = placement.hub_radius
        ck.fail("scene.disk.hub_radius",
                f"{R:g} m is {R / p.length:.3g} times the blade length {p.length:g} m (at most "
                f"{MAX_HUB_TO_LENGTH:g}): lengths are in metres (a value in millimetres?)")
    try:
        size = mesh_size(p, placement)
    except ValueError:   # blades that overlap in the wheel: reported when it is built
        return
    if size.free_dofs > MAX_FE_DOFS:
        what = f"the blade would have {size.free_dofs:,} DOFs ({size.elements:,} elements), " \
               f"more than {MAX_FE_DOFS:,}"
        alone = mesh_size(p).free_dofs if placement is not None else size.free_dofs
        if alone <= MAX_FE_DOFS:   # the wheel's derived shroud width makes it so large
            ws = wheel_shroud_width(p, placement)
            ck.fail("scene.disk.hub_radius",
                    f"{what} ({alone:,} outside the wheel): the shroud width derived from "
                    f"R = {placement.hub_radius:g} m and {placement.sectors} sectors is "
                    f"{ws:.3g} m; check the hub radius (metres) and the sector count")
        mesh_keys = [k for k in ("n_chord", "n_thick", "n_span") if k in given]
        ck.fail(where(mesh_keys[0]) if mesh_keys else "scene.blade", f"{what}: a coarser mesh")


def mesh_units(ck, tab, mesh, matrices, fld) -> float:
    """Metres per unit of the mesh file's coordinates from `[scene] units` ("SI": metres,
    "mm": millimetres); only with a mesh and without `[scene.matrices]`, which gives its
    own `units` for the matrices and the mesh alike."""
    if "units" not in tab:
        return 1.0
    if mesh is None or matrices is not None:
        ck.fail(fld("units"), "the unit of a mesh file's coordinates: needs scene.mesh, and "
                              "with scene.matrices its units says it")
    return {"SI": 1.0, "mm": 1e-3}[ck.string(tab["units"], fld("units"), ("SI", "mm"))]
