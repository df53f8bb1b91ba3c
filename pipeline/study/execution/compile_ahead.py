"""The compiled kernels a parallel run needs, compiled before its worker processes start.

On a machine whose kernel cache (`pipeline.kernel_cache_dir()`) is cold, each worker of a
parallel run would compile every kernel its first case meets: the same work once per
core, side by side (about 25 s of CPU each for the exact forces on a two-core machine).
Instead the run compiles each group of kernels once, here, one group per process, and
marks the group as compiled in the cache folder; the workers then load the kernels from
the cache (about 1 s).  A group that fails to compile is only logged: the workers then
compile what they need themselves, as they would without this step.

The groups, each called through its public entry points on small inputs of the types
the package passes (so that the signatures compiled are the ones a run uses):

  * "exact": the exact Yang-Menq forces with their Jacobian and the periodic state
    segments (`contact.exact`), with the certified root search beneath them;
  * "sampled": the sampled (AFT) 1D and 2D friction march and the stuck slider's centre
    (`contact.friction2d`), for AFT studies and the 2D friction law;
  * "continuation": the continuation's Hermite predictor and the sampled extrema.

The floor: the exact forces' call tree is nine levels deep, and Numba optimises and
generates each caller together with every callee compiled in the same process, so the
tree cannot be cut across cores without compiling its levels twice.  Compiled level by
level in separate processes (each loading the levels below from the cache), it cost
4.8 + 5.5 + 6.7 + 7.8 s of CPU on the development machine, no less than in one process.
"""
from __future__ import annotations

import logging
import os
import time
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

from ... import kernel_cache_dir
from ...contact import YangMenq, forces
from ...contact.exact import periodic_segments
from ...contact.friction2d.kernel import march
from ...contact.friction2d.law import Friction2D
from ...fourier.harmonics import amplitude_half_peak_to_peak
from ...solve.continuation.branch import hermite_on_plane

log = logging.getLogger(__name__)


def motions(E: int = 8, H: int = 3):
    """Small contact motions U, V (E, 2H+1) [m] and Yang-Menq elements whose preloads
    give separation, stick-slip and full stick."""
    rng = np.random.default_rng(0)
    scale = np.repeat(0.3 ** np.arange(H), 2)
    U = np.zeros((E, 2 * H + 1))
    V = np.zeros((E, 2 * H + 1))
    U[:, 1:] = rng.normal(size=(E, 2 * H)) * scale
    V[:, 1:] = rng.normal(size=(E, 2 * H)) * scale * 0.5
    return U, V, YangMenq(ku=1.0, kv=1.0, mu=0.4, n0=np.linspace(-0.5, 2.0, E))


def exact():
    """The exact forces with their Jacobian, and the periodic segments."""
    U, V, elem = motions()
    forces(U, V, elem, jacobian=True)
    periodic_segments(U, V, elem)


def sampled():
    """The sampled (AFT) forces and the 2D friction march, slipping and stuck."""
    U, V, elem = motions()
    forces(U, V, elem, method="aft", n_samples=64, jacobian=True)
    E, nh = 4, 7
    X = np.random.default_rng(0).normal(size=(E, 3, nh)) * 0.1
    for n0 in (0.5, 50.0):                     # slipping, and stuck throughout
        march(np.ones((E, 2)), np.ones(E), np.full(E, 0.3), np.full(E, n0), X, 64, True, True)


def continuation():
    """The continuation's Hermite predictor and the sampled extrema."""
    rng = np.random.default_rng(0)
    Y = np.cumsum(rng.normal(size=(3, 5)), axis=0)
    T = np.diff(np.vstack([Y, Y[-1:] + 1.0]), axis=0)
    T /= np.linalg.norm(T, axis=1)[:, None]
    hermite_on_plane(Y, T, T[-1], 0.1)
    amplitude_half_peak_to_peak(rng.normal(size=(5, 7)))


GROUPS = {"exact": exact, "sampled": sampled, "continuation": continuation}


def groups_for(system, method: str) -> tuple:
    """The groups a run of `system` with force evaluation `method` ("exact" or "aft")
    meets: the continuation always, the exact or sampled forces of its Yang-Menq
    elements, the sampled march of a 2D friction law."""
    groups = ["continuation"]
    if isinstance(system.contact, YangMenq) and system.contact.size:
        groups.append("exact" if method == "exact" else "sampled")
    if any(isinstance(law.law, Friction2D) for law in system.laws) and "sampled" not in groups:
        groups.append("sampled")
    return tuple(groups)


def marker(group: str) -> Path:
    """The file that marks `group` as compiled in the kernel cache (per Python and Numba
    version: a new Numba recompiles, and so does this step)."""
    try:
        numba = version("numba")
    except PackageNotFoundError:
        numba = "unknown"
    folder = os.environ.get("NUMBA_CACHE_DIR") or kernel_cache_dir()
    return Path(folder) / f"{group}.compiled-numba{numba}"


def compile_ahead(groups, workers: int = 2) -> float:
    """Compile the `groups` (names of GROUPS) not yet marked as compiled, in up to
    `workers` fresh processes side by side; returns the wall time spent [s] (0 when all
    were marked)."""
    todo = [g for g in groups if not marker(g).exists()]
    if not todo:
        return 0.0
    # deferred: only a cold cache needs processes
    from concurrent.futures import ProcessPoolExecutor

    t0 = time.perf_counter()
    log.info("compiling the kernels (%s) once for this machine: %d process(es)",
             ", ".join(todo), min(workers, len(todo)))
    # the platform's default start, as the run's own pool (`cases.map_jobs`): a spawned
    # process would run a calling script's unguarded top level again
    with ProcessPoolExecutor(min(workers, len(todo))) as pool:
        futures = {g: pool.submit(GROUPS[g]) for g in todo}
        for g, fut in futures.items():
            try:
                fut.result()
            except Exception as exc:  # the workers compile what they need themselves
                log.warning("compiling the %s kernels ahead failed (%s: %s); each worker "
                            "compiles them", g, type(exc).__name__, exc)
                continue
            try:
                marker(g).touch()
            except OSError:
                pass
    wall = time.perf_counter() - t0
    log.info("kernels compiled in %.1f s", wall)
    return wall
