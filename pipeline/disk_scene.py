"""Disk scenes of study files: `[scene] model = "disk"`, a tuned lumped bladed disk.

A disk scene is one lumped SECTOR (`dofs`, `[scene.matrices]` or `[scene.modal]`,
as in a lumped scene), repeated `sectors` = N times around the disk
(`[scene.disk]`), with Yang-Menq elements (paper Eq. 1, 9, 10) that may also act
on the NEXT sector's DOFs: a DOF name `next.<dof>` in `tangential` / `normal`
means that DOF of sector j+1, so a shroud pair reads

    tangential = ["next.x2", "-x2"]        # u = x2_{j+1} - x2_j

Declaring such an element is the effect "cyclic_coupling".  The excitation acts
on sector 0; sector j gets it shifted by the engine order EO,
F_j(tau) = F_0(tau + j phi), phi = 2 pi EO / N (a first-harmonic load has the phase
j phi).  EO is `[scene.disk] engine_order` or the sweep axis `eo`, an integer in
0 <= EO <= N/2 (N - EO is the same wave travelling the other way; EO >= N repeats
EO mod N).  Each case is solved on ONE sector by the cyclic reduction
(`pipeline.cyclic.sector_system`, Petrov 2004): only the sector is built, never
the N-sector assembly (`DiskScene.full_system` gives it, for checks).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .system import System

NEXT = "next."
MAX_SECTORS = 10_000


@dataclass(frozen=True)
class DiskScene:
    """A validated disk scene: one sector (SI units) and the number of sectors."""

    model: str              # "disk"
    effects: tuple
    dofs: tuple             # the sector's DOF names, one per row of M
    M: np.ndarray           # (n, n) [kg]
    C: np.ndarray           # (n, n) [N s/m]
    K: np.ndarray           # (n, n) [N/m]
    contacts: tuple         # scene.ContactSpec with rows over `contact_dofs` (2n)
    forcing: np.ndarray     # (n, Hf+1) complex load of sector 0 [N]
    sectors: int            # N
    engine_order: int | None = None   # None: the sweep's `eo` sets it

    @property
    def contact_dofs(self) -> tuple:
        """Names the contact rows refer to: the sector's DOFs, then `next.<dof>`."""
        return self.dofs + tuple(NEXT + d for d in self.dofs)

    def dof_index(self, name: str) -> int:
        return self.dofs.index(name)

    @property
    def coupled(self) -> bool:
        """True if an element reaches the next sector (effect "cyclic_coupling")."""
        n = len(self.dofs)
        return any(np.any(c.bt[n:]) or np.any(c.bn[n:]) for c in self.contacts)

    def engine_order_of(self, case: dict | None = None) -> int:
        case = case or {}
        eo = case.get("eo", self.engine_order)
        if eo is None:
            raise ValueError("the engine order is unset: give [scene.disk] engine_order or "
                             "the sweep axis eo")
        return int(eo)

    def sector(self, case: dict | None = None):
        """The `cyclic.Sector` with one grid case applied (preload, mu, ku, kv,
        excitation_scale as in lumped scenes)."""
        from .cyclic import Sector
        from .scene import SWEEP_AXES, contact_elements

        case = dict(case or {})
        unknown = set(case) - set(SWEEP_AXES)
        if unknown:
            raise ValueError(f"case has unknown axes {sorted(unknown)}; known: {sorted(SWEEP_AXES)}")
        n, E = len(self.dofs), len(self.contacts)
        Bt = np.array([c.bt for c in self.contacts], dtype=float).reshape(E, 2 * n)
        Bn = np.array([c.bn for c in self.contacts], dtype=float).reshape(E, 2 * n)
        return Sector(M=self.M, C=self.C, K=self.K, Bt=Bt[:, :n], Bn=Bn[:, :n],
                      Bt_next=Bt[:, n:], Bn_next=Bn[:, n:],
                      contact=contact_elements(self.contacts, case),
                      forcing=self.forcing * float(case.get("excitation_scale", 1.0)),
                      sectors=self.sectors, dof_names=tuple(self.dofs))

    def system(self, case: dict | None = None) -> System:
        """The one-sector cyclic `System` of a case (n DOFs, `System.cyclic` set)."""
        from .cyclic import sector_system
        return sector_system(self.sector(case), self.engine_order_of(case))

    def full_system(self, case: dict | None = None) -> System:
        """All N sectors assembled (N n DOFs): the reference, never used by a run."""
        from .cyclic import full_assembly
        return full_assembly(self.sector(case), self.engine_order_of(case))

    def dataset_attrs(self) -> dict:
        """Global attributes a response dataset of this scene adds."""
        attrs = {"sectors": int(self.sectors), "sector_dofs": int(len(self.dofs)),
                 "cyclic_reduction": "one sector, travelling wave Q_{j,h} = exp(i h j phi) "
                                     "Q_{0,h}, phi = 2 pi EO / sectors (Petrov 2004)",
                 "excitation": "engine order EO: sector j loaded by sector 0's load "
                               "shifted by j phi (phase j phi in the first harmonic)"}
        if self.engine_order is not None:
            attrs["engine_order"] = int(self.engine_order)
        return attrs


# ---------------------------------------------------------------------------
# Validation (called by scene.py; every mistake is `<file>: <field>: <what>`)
# ---------------------------------------------------------------------------

def check_dof_names(ck, dofs):
    for i, d in enumerate(dofs):
        if d.startswith(NEXT) or d == NEXT[:-1]:
            ck.fail(f"scene.dofs[{i}]", f"{d!r}: the prefix {NEXT!r} is reserved for the next "
                                        "sector's DOFs in a disk scene")


def contact_rows(value):
    """Nested tables from TOML dotted keys, {next = {x2 = -1}}, as "next.x2" entries."""
    if isinstance(value, dict) and isinstance(value.get(NEXT[:-1]), dict):
        flat = {k: v for k, v in value.items() if k != NEXT[:-1]}
        flat.update({NEXT + k: v for k, v in value[NEXT[:-1]].items()})
        return flat
    return value


def parse_disk(ck, tab) -> tuple:
    """(sectors, engine_order or None) of a `[scene.disk]` table."""
    if "disk" not in tab:
        ck.fail("scene.disk", "missing table (required for model = \"disk\"): "
                              "[scene.disk] sectors = N")
    t = ck.table(tab["disk"], "scene.disk")
    ck.keys(t, "scene.disk", ("sectors", "engine_order"), required=("sectors",))
    N = ck.integer(t["sectors"], "scene.disk.sectors", 2, MAX_SECTORS)
    eo = check_engine_order(ck, t["engine_order"], "scene.disk.engine_order", N) \
        if "engine_order" in t else None
    return N, eo


def check_engine_order(ck, value, field, N) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        ck.fail(field, f"the engine order must be an integer, got {value!r}")
    if value < 0:
        ck.fail(field, f"the engine order must be >= 0, got {value}")
    if value >= N:
        ck.fail(field, f"engine order {value} is not smaller than the number of sectors {N} "
                       f"(EO and EO mod N are the same excitation); give 0 <= EO <= {N // 2}")
    if 2 * value > N:
        ck.fail(field, f"engine order {value} > N/2 = {N / 2:g}: it is the backward wave of "
                       f"EO = {N - value}; give 0 <= EO <= {N // 2}")
    return int(value)


def check_disk_rules(ck, scene: DiskScene, axes, wpath, data):
    """EO given once (scene or sweep) and within 0..N/2; "cyclic_coupling" declared
    exactly when an element reaches the next sector; the optimum-preload search
    needs a fixed engine order."""
    if "eo" in axes:
        for i, eo in enumerate(axes["eo"]):
            check_engine_order(ck, eo, f"{wpath}.eo[{i}]", scene.sectors)
        if scene.engine_order is not None:
            ck.fail(f"{wpath}.eo", "the engine order is set twice: [scene.disk] engine_order "
                                   "and the sweep axis eo")
    elif scene.engine_order is None:
        ck.fail("scene.disk.engine_order", "missing: give [scene.disk] engine_order or the "
                                           "sweep axis eo = [...]")
    if scene.coupled != ("cyclic_coupling" in scene.effects):
        ck.fail("scene.effects", "a contact reaches the next sector (next.<dof>): declare "
                                 "\"cyclic_coupling\"" if scene.coupled else
                "\"cyclic_coupling\" is declared but no contact reaches the next sector "
                "(DOF names next.<dof>)")
    out = data.get("output") if isinstance(data, dict) else None
    if isinstance(out, dict) and "optimum_preload" in out and scene.engine_order is None:
        ck.fail("output.optimum_preload", "the optimum search runs at one engine order: "
                                          "give [scene.disk] engine_order")
