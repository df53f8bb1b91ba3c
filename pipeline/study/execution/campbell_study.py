"""The Campbell diagram of a tuned disk of turning blades: a disk modes study with speeds.

    [modes]
    speeds = { start = 0.0, stop = 15000.0, count = 16 }   # rpm (or a list)
    engine_orders = [1, 2, 3, 4, 5, 6]

At each speed Omega the blades carry their stress stiffening and spin softening
(`structure.rotation`: K + Omega^2 (K_sigma1 - M_P), Craig-Bampton reduced at that
speed) and the disk's natural frequencies per nodal diameter are those of
`disk_modes_study` (contacts open and stuck).  An engine order EO excites the family
ND = EO mod N folded into 0..N/2 at the frequency EO x speed / 60 [Hz]; a crossing is
a speed where a natural frequency of that family equals it,

    g(s) = f_k(ND, s) - EO s / 60 = 0,

bracketed by the speed grid (a change of sign of g between two grid speeds) and
located by Brent's method on the eigenproblem at each trial speed (`brentq`, speed
to 1e-9 of the largest speed), not read off the grid.  f_k is the k-th frequency in
increasing order, continuous in the speed; a crossing that the grid brackets twice
over (two roots between two speeds) is not seen -- refine the grid to find it.
"""
from __future__ import annotations

import logging
import time
from contextlib import contextmanager

import numpy as np
from scipy.optimize import brentq

from dataclasses import replace

from ...model.cyclic import sector_system
from ...model.static_load import static_contact
from ...model.scene import Scene
from ...model.build import sector
from ...model.system import natural_frequencies, natural_modes
from ...errors import interrupt_in_chain
from ..figures.nd_figure import excited_nodal_diameter

STATES = {"open": "open", "stuck": "tied"}   # dataset name -> natural_frequencies' limit
STATIC = "static"     # with an interference: the pairs the static contact solution closes
MAX_SPEEDS = 400
XTOL = 1e-9            # of the largest speed
REDUCTION_LOG = "pipeline.structure.reduction"   # one line a reduction: quiet here
PROGRESS = 5.0         # [s] between progress lines

log = logging.getLogger(__name__)


def parse_speeds(ck, modes: dict, where) -> tuple:
    """(speeds [rpm] ascending, engine orders) of a [modes] table; () when absent."""
    if "speeds" not in modes:
        if "engine_orders" in modes:
            ck.fail(where("engine_orders"), "engine-order lines need speeds: give "
                                            "modes.speeds [rpm]")
        return (), ()
    raw = modes["speeds"]
    if isinstance(raw, dict):
        ck.keys(raw, where("speeds"), ("start", "stop", "count"),
                required=("start", "stop", "count"))
        lo = ck.number(raw["start"], where("speeds") + ".start", ge=0.0)
        hi = ck.number(raw["stop"], where("speeds") + ".stop", gt=lo)
        n = ck.integer(raw["count"], where("speeds") + ".count", 2, MAX_SPEEDS)
        speeds = tuple(float(v) for v in np.linspace(lo, hi, n))
    else:
        speeds = tuple(float(v) for v in ck.numbers(raw, where("speeds"), ge=0.0))
        if any(b <= a for a, b in zip(speeds, speeds[1:])):
            ck.fail(where("speeds"), "speeds must increase")
        if len(speeds) > MAX_SPEEDS:
            ck.fail(where("speeds"), f"at most {MAX_SPEEDS} speeds, got {len(speeds)}")
    eos = tuple(ck.integer(v, where(f"engine_orders[{i}]"), 1, 10_000) for i, v in
                enumerate(ck.array(modes.get("engine_orders", []), where("engine_orders"),
                                   min_length=0)))
    if len(set(eos)) != len(eos):
        ck.fail(where("engine_orders"), "an engine order is listed twice")
    return speeds, eos


def states(scene: Scene) -> tuple:
    """The contact states a Campbell diagram draws: open and stuck, and with an
    interference the static state (only the pairs in static contact stuck)."""
    pressed = any(getattr(c, "interference", None) is not None for c in scene.contacts)
    return tuple(STATES) + ((STATIC,) if pressed else ())


def speed_sector(scene: Scene, speed: float):
    """The cyclic sector of `scene` turning at `speed` [rpm] (Craig-Bampton reduced at
    that speed), the contact states not yet chosen."""
    case = {} if all(getattr(c, "n0", None) is not None or getattr(c, "interference", None)
                     is not None for c in scene.contacts) else {"preload": 0.0}  # n0 unused
    if speed:
        case["speed"] = float(speed)
    return sector(scene, case)


def frequencies_at(scene: Scene, speed: float, nodal_diameters, n_frequencies: int,
                   state: str, sec=None) -> np.ndarray:
    """(len(nodal_diameters), n_frequencies) natural frequencies [Hz] at `speed` [rpm]
    with the contacts `state`: "open", "stuck" (every pair), or "static" (the pairs the
    unilateral static contact solution at ND 0 closes, `static_load.static_contact`,
    stuck; the others open).  `sec`: the `speed_sector` at that speed when already
    built (the states share it)."""
    sec = speed_sector(scene, speed) if sec is None else sec
    limit = STATES.get(state, "small")
    if state == STATIC:
        closed = static_contact(sector_system(sec, 0))[1]
        sec = replace(sec, contact=replace(sec.contact, n0=np.where(closed, 1.0, -1.0)))
    return np.array([natural_frequencies(sector_system(sec, nd), limit)[:n_frequencies]
                     for nd in nodal_diameters]) / (2 * np.pi)


def crossings(scene: Scene, speeds, nodal_diameters, freqs: dict, engine_orders) -> list:
    """Every (engine order, nodal diameter, mode, state, speed [rpm], frequency [Hz])
    where f_k(ND, s) = EO s / 60, located by `brentq` inside each bracket of the grid
    (at a bracket's ends Brent reads the grid's own values)."""
    N = scene.assembly.sectors
    s = np.asarray(speeds)
    found = []
    for eo in engine_orders:
        nd = excited_nodal_diameter(eo, N)
        if nd not in nodal_diameters:
            continue
        j = list(nodal_diameters).index(nd)
        for state, f in freqs.items():
            for k in range(f.shape[2]):
                g = f[:, j, k] - eo * s / 60.0
                for i in np.nonzero(np.sign(g[:-1]) * np.sign(g[1:]) <= 0)[0]:
                    if g[i] == 0.0 and i > 0:
                        continue                 # a root on a grid speed: counted once

                    def gap(x, k=k, state=state, eo=eo, nd=nd, i=i, g=g):
                        if x in (s[i], s[i + 1]):   # a grid speed: its value is known
                            return g[i] if x == s[i] else g[i + 1]
                        return frequencies_at(scene, x, [nd], k + 1, state)[0, k] - eo * x / 60

                    try:
                        root = s[i] if g[i] == 0.0 else s[i + 1] if g[i + 1] == 0.0 else \
                            brentq(gap, s[i], s[i + 1], xtol=XTOL * s[-1],
                                   rtol=4 * np.finfo(float).eps)
                    except Exception as exc:  # one crossing lost, not the diagram
                        if interrupt_in_chain(exc):
                            raise
                        log.exception("Campbell: the crossing of EO %d with ND %d mode %d "
                                      "(%s) between %g and %g rpm is not located", eo, nd,
                                      k + 1, state, s[i], s[i + 1])
                        continue
                    found.append((eo, nd, k + 1, state, float(root), eo * float(root) / 60.0))
    return found


def speed_frequencies(scene: Scene, speed: float, nodal_diameters, n_frequencies: int,
                      names) -> tuple:
    """({state: (len(nodal_diameters), n_frequencies) [Hz]} at `speed` [rpm] for the
    states `names`, sharing one reduction, and "" ; or, where the model at that speed
    cannot be built or solved, NaN and why (the other speeds are kept)."""
    try:
        sec = speed_sector(scene, speed)
        return {state: frequencies_at(scene, speed, nodal_diameters, n_frequencies, state, sec)
                for state in names}, ""
    except Exception as exc:  # one speed that fails must not lose the others
        if interrupt_in_chain(exc):
            raise
        log.exception("Campbell: %g rpm failed", speed)
        nan = np.full((len(nodal_diameters), n_frequencies), np.nan)
        return {state: nan for state in names}, f"{type(exc).__name__}: {exc}"


def campbell(scene: Scene, speeds, nodal_diameters, n_frequencies: int, engine_orders) -> dict:
    """{"open", "stuck"[, "static"]}: (speed, nodal diameter, mode) natural frequencies
    [Hz] (`states`); "crossings": the list of `crossings`; "crossing_shapes": their
    mode shapes (`crossing_shapes`); "message": per speed, why it
    failed ("" where solved; NaN frequencies there).  Progress is logged every
    `PROGRESS` seconds and at the end (the reductions' own lines only at debug level)."""
    t0 = shown = time.perf_counter()
    freqs, message = {state: [] for state in states(scene)}, []
    with quiet(REDUCTION_LOG):
        for k, v in enumerate(speeds):   # one reduction a speed, shared by the states
            row, why = speed_frequencies(scene, v, nodal_diameters, n_frequencies, freqs)
            message.append(why)
            for state, f in freqs.items():
                f.append(row[state])
            if time.perf_counter() - shown >= PROGRESS or k + 1 == len(speeds):
                shown = time.perf_counter()
                log.info("Campbell: %d/%d speeds (%g rpm), %.1f s", k + 1, len(speeds), v,
                         shown - t0)
        freqs = {state: np.array(f) for state, f in freqs.items()}
        freqs["crossings"] = crossings(scene, speeds, nodal_diameters, freqs, engine_orders)
        freqs["message"] = message
        freqs["crossing_shapes"] = crossing_shapes(scene, freqs["crossings"])
    log.info("Campbell: %d engine-order crossing(s) located by Brent, %.1f s",
             len(freqs["crossings"]), time.perf_counter() - t0)
    return freqs


def crossing_shapes(scene: Scene, found) -> dict:
    """The mode shape of each crossing of `found` (`crossings`): at its speed, nodal
    diameter and contact state, the mode of its family (`natural_modes`) at the sector's
    coordinates, scaled to max |x| = 1 over the physical DOFs (not `mode.<j>`, `cut.<k>`),
    that entry real and positive: {"shapes": (C, n) complex, "dofs": names, "physical":
    their indices}; NaN where the crossing's model cannot be solved."""
    shapes, names = [], ()
    for eo, nd, mode, state, speed, _ in found:
        try:
            sec = speed_sector(scene, speed)
            if state == STATIC:
                closed = static_contact(sector_system(sec, 0))[1]
                sec = replace(sec, contact=replace(sec.contact, n0=np.where(closed, 1.0, -1.0)))
            names = tuple(sec.dof_names)
            x = natural_modes(sector_system(sec, nd), STATES.get(state, "small"))[1][:, mode - 1]
        except Exception as exc:   # one shape lost, not the diagram
            if interrupt_in_chain(exc):
                raise
            log.exception("Campbell: the shape of the EO %d crossing at %g rpm", eo, speed)
            x = None
        shapes.append(x)
    physical = np.array([i for i, d in enumerate(names) if not d.startswith(("mode.", "cut."))],
                        dtype=np.int64)
    out = np.full((len(shapes), len(names)), np.nan, complex)
    for c, x in enumerate(shapes):
        if x is not None:
            j = physical[np.argmax(np.abs(x[physical]))]
            out[c] = x / x[j]
    return {"shapes": out, "dofs": names, "physical": physical}


@contextmanager
def quiet(name):
    """The logger `name` at WARNING inside the block unless debug output is on."""
    logger = logging.getLogger(name)
    old = logger.level
    if not logger.isEnabledFor(logging.DEBUG):
        logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logger.setLevel(old)
