"""What a response study will cost, from the model it will run (`shroud check`).

A continuation case costs its points times the work per point.  Per point the solver
evaluates the condensed harmonic-balance residual with its Jacobian (`hbm.residual`:
the condensation of the linear part onto the contact DOFs, the contact forces) and
solves the bordered Newton system of the n_u = n_c (2H + 1) unknowns, a few times;
bookkeeping, dense output and the recovery of every DOF add a part that grows with
the system's n DOFs, and stability its own (a full wheel's sparse Jacobian has its own
c and k, its factors kept as a dense one's):

    t_case  = P t_point,    t_point = c t_R + k t_S + s0 + s1 n + s_stab,
    P       = 60 (1 + m)^0.6 x POINTS,
    s_stab  = STABILITY[mode] (+ HILL_CUBE N_h^3 for Hill, N_h = 2 n (2H + 1); Hill's
              method on a tuned cyclic sector once per wave number, N/2 + 1),

t_R and t_S the residual + Jacobian and one solve of its Newton system (as the solver
does it: a float32 LU from SINGLE_ROWS rows; k = c below KEEP_ROWS rows, where every
Newton step factorises afresh, else about one LU a point), timed now on
the first case's model (the one the run builds: the quick one with --quick) at the
geometric middle of the frequency range, from the linear response there; m the
natural frequencies (contacts open and stuck) inside the frequency range, which set
how many points the curve needs.  c, s0, s1, s_stab and the spread of P are ranges
calibrated on the shipped studies (`python -m pipeline bench estimate`,
pipeline/bench/README.md "Cost estimates"); the estimate is the range they give, its middle the geometric mean.  The
study costs n_cases t_case / workers, plus the model's build and reduction (timed),
a reduction for every further speed of a speed sweep and one at rest for the
dataset's description when no case is at rest, the static contact solution
of every case whose shrouds are set by an `interference` (the dataset's
static_contact_load_pair; both timed on the first case), and
an optimum-preload search: SEARCH_GRID cases' worth without stability on the
workers and SEARCH_SERIAL in one process:

    t = n_cases t_case / w + setup + r t_red + n_cases t_static
        + slowdown OUTPUT [+ search],

r = S' - 1 further reductions, S' the distinct speeds of the cases with 0 rpm (the
main process builds every case's model, on a pool too, and describes the blade at
rest).  t_R and t_S are timed at
the study's own H and AFT samples: their growth with the (2H + 1) n_c unknowns and
with samples x elements is measured, not modelled; OUTPUT the dataset and its
figures, written once (pipeline/bench/README.md "Cost
estimates" gives the exponents measured on the shipped models).  It assumes
the compiled kernels are cached (a first run compiles them: up to 50 s more) and a
machine as loaded as when it timed: the constant terms are scaled by the slowdown
measured then (wall / CPU time of one thread, `slowdown`) against CALIBRATION_SLOWDOWN.
A curve with many more folds costs more.

A mistuned wheel of more than WHEEL_BUILT unknowns is estimated without building it
(`time_point`): its tuned
sector at the first case's engine order is timed, t_R and t_S scaled by N and by
WHEEL_RESIDUAL, WHEEL_SOLVE (the wheel's sparse Jacobian and its solve over the ring of
blades against N sectors' dense ones, measured on wheels of 24-48 FE blades), and its
natural frequencies are
counted as the tuned wheel's, the sector's at every nodal diameter (`wheel_modes`);
the memory of its Jacobian and factors, about WHEEL_BYTES per entry of its N dense blocks
of n_u^2, is compared with the machine's (`wheel_memory`).
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ...model.build import engine_order, sector
from ...model.cyclic import sector_system
from ...model.static_load import static_contact
from ...model.system import lowest_frequencies
from ...solve.continuation.newton import linear_solve
from ...solve.harmonic_balance import hbm
from ...solve.response.response import initial_guess
from ...structure.mesh_size import mesh_size

# t_point = c t_R + k t_S + s0 + s1 n + s_stab  [s] (module docstring):
PAIRS_PER_POINT = (2.0, 5.0)          # c: residual evaluations per point (measured 1.9-6.5)
FACTORISATIONS_PER_POINT = (1.0, 2.5)  # dense Newton systems of KEEP_ROWS rows or more keep
#                                        their factors: about one LU a point, not one a
#                                        Newton step (`newton.KeptFactors`)
KEEP_ROWS, SINGLE_ROWS = 300, 500      # as `newton`: kept factors; float32 factorisation
SPARSE_PAIRS_PER_POINT = (2.5, 6.0)   # c of a sparse Jacobian (a mistuned wheel): 2.6-5.1
#                                       evaluations a point of the curve, 4.3 a branch point
SPARSE_FACTORISATIONS_PER_POINT = (0.5, 2.0)   # its LUs (kept factors too): 0.6-1.1 a point
#                                                of the curve, 1.9 a branch point
OVERHEAD = ((0.002, 0.008), (1e-4, 1.5e-3))   # s0 [s], s1 [s per DOF]: bookkeeping, dense
#                                             output, recovery of every DOF
STABILITY = {"off": (0.0, 0.0), "monodromy": (0.001, 0.03),
             "monodromy+check": (0.002, 0.25),   # + Floquet checks where in doubt
             # a Floquet check (shooting + monodromy) at most points of a lightly damped
             # structure: the 3-DOF blade's 100-140 points took 54-70 s on a quiet machine
             "hill": (0.001, 0.008), "hill+check": (1.0, 10.0), "floquet": (1.0, 10.0),
             # the fold rule: a verdict at a branch's ends, nothing per point (the full
             # blade study took 28.2 s with it, 29.6 s without); "stretch": a few orbit
             # monodromies a stretch, 0.75 s a point on the quick blade, 2.4 on the full
             "folds": (0.0, 0.002), "stretch": (0.05, 3.0)}
HILL_CUBE = (3e-9, 1.5e-8)            # [s] per N_h^3 of Hill's eigenproblem, N_h = 2n(2H+1);
#                                       a tuned cyclic sector solves one per wave number
# the constant terms (s0, s1, s_stab, HILL_CUBE) were measured with the machine this busy
# (wall / CPU time of a single thread, load 8-11 on the 2 cores); they scale with the
# slowdown measured when estimating (`slowdown`); t_R and t_S carry it already
CALIBRATION_SLOWDOWN = 5.0
# P: points of a case grow with the m natural frequencies (open and stuck) in the range
POINTS = (0.6, 2.0)                   # x the middle 60 (1 + m)^0.6
PEAKS_ONLY = 0.4   # x P for a case keeping its largest peaks only (`[output] curves = false`:
#                    no dense output; the mistuned wheel at 1 N: 373 points against 958)
OUTPUT = 1.0   # [s] on an idle core: the dataset and its figures (lumped disk_cyclic, load 6
#                and wall / CPU about 1: dataset 0.17 s, amplitude figures 0.65-0.96 s)
SEARCH_GRID = (6.0, 13.0)   # an optimum-preload search's band evaluations (its grid nodes,
#                             cases' worth without stability, spread on the workers: the
#                             full shrouded disk's 8, Example 3's 12)
SEARCH_SERIAL = (1.0, 3.0)  # ... and in one process: each refined bracket's band check and
#                             its 10-20 trials by the peak continued in preload (0.06 of a
#                             band evaluation each on the FE sector)


# a mistuned wheel from its tuned sector (module docstring): residual + Jacobian and one
# solve of the wheel's Newton matrix over its ring of blades (`harmonic_balance.ring`,
# its pattern found and gathered in that time) against N times the sector's, the middles
# of the ratios measured on wheels of the curved FE blade (24 and 48 blades, 630 and 1134
# unknowns a sector, 2026-12-07): 2.8-3.4 and 4.9-8.8 (17 with the general sparse LU)
WHEEL_RESIDUAL, WHEEL_SOLVE = 3.0, 7.0
WHEEL_BYTES = 70   # at least, per entry of the wheel's N n_u^2 blocks: its Jacobian pattern,
#                    values and ring factors (48 blades of 2142 unknowns: 10.4 GB for the
#                    set-up and a residual, 6.8 GB for a factorisation with the Jacobian)
WHEEL_BUILT = 5000  # a wheel of at most this many unknowns is built and timed itself (the
#                     shipped ones: up to 1008; 7560 took 11 s to time)


@dataclass(frozen=True)
class PointTiming:
    """Measured on the model a study runs: t_R [s] (residual + Jacobian), t_S [s] (one
    Newton solve), n the unknowns, setup [s] (model build and reduction)."""

    t_residual: float
    t_solve: float
    unknowns: int
    setup: float
    sparse: bool = False        # the Jacobian is scipy.sparse (a full wheel)
    slowdown: float = CALIBRATION_SLOWDOWN   # wall / CPU time of one thread, now
    reduction: float = 0.0      # [s] one reduction of an FE blade (a further speed's)
    static: float = 0.0         # [s] the static contact solution of a case (interference)
    sectors: int = 0            # N of a mistuned wheel timed on its tuned sector, else 0


@dataclass(frozen=True)
class Estimate:
    """The cost of a study [s] on `workers` workers: a range (lo, hi), and its parts."""

    lo: float
    hi: float
    case: tuple                 # (lo, hi) [s] of one case
    n_cases: int
    workers: int
    timing: PointTiming
    per_point: tuple            # (lo, hi) [s] per continuation point
    points: tuple               # (lo, hi) points per case
    search: tuple | None        # (lo, hi) [s] of the optimum-preload search, or None
    modes: int = 0              # m: natural frequencies in the range (open and stuck)
    pairs: tuple = (0.0, 0.0)   # c: (residual, solve) pairs per point

    @property
    def mid(self) -> float:
        """Geometric middle of the range [s]."""
        return math.sqrt(self.lo * self.hi)


def stability_key(stability) -> str:
    return "off" if not stability else str(stability)


def tuned_sector(study, case, eo=None):
    """The tuned one-sector system of a mistuned wheel's scene at engine order `eo`
    (default the case's)."""
    return sector_system(sector(study.scene, case),
                         engine_order(study.scene, case) if eo is None else eo)


def is_wheel(study) -> bool:
    """A mistuned wheel: every case the N-sector assembly."""
    return study.scene.cyclic and study.scene.mistuning is not None


def time_point(study, repeats: int = 5) -> PointTiming:
    """`PointTiming` of the first case of `study` at the geometric middle of its
    frequency range, from the linear response there (medians of `repeats`); a mistuned
    wheel's from its tuned sector, scaled (module docstring)."""
    sv, fr = study.solver, study.sweep.frequency
    t0 = time.perf_counter()
    case = study.sweep.cases()[0][1]
    system = tuned_sector(study, case) if is_wheel(study) else study.system(case)
    setup = time.perf_counter() - t0
    st, t_red, t_static = study.scene.structure, 0.0, 0.0
    if getattr(st, "params", None) is not None:   # FE: as first built
        # deferred: FE blades only (scikit-fem, meshio)
        from ...model.blade_cache import case_speed, reduced_model, timed_blade_model
        t_red = reduced_model(st, study.scene.reduction, case_speed(st, case))[1]
        setup += timed_blade_model(st)[1] + t_red
    if "interference" in study.sweep.axes or any(
            getattr(c, "interference", None) is not None for c in study.scene.contacts):
        t1 = time.perf_counter()
        static_contact(system)
        t_static = time.perf_counter() - t1
    t_r, t_s, unknowns, sparse = time_system_point(
        system, sv.harmonics, sv.force_evaluation, sv.samples,
        math.sqrt(fr.omega_start * fr.omega_stop), repeats)
    N = study.scene.assembly.sectors if is_wheel(study) else 0
    if N and N * unknowns > WHEEL_BUILT:
        return PointTiming(N * WHEEL_RESIDUAL * t_r, N * WHEEL_SOLVE * t_s, N * unknowns,
                           setup, True, slowdown(), t_red, t_static, N)
    if N:   # a small wheel: built and timed itself
        t_r, t_s, unknowns, sparse = time_system_point(
            study.system(case), sv.harmonics, sv.force_evaluation, sv.samples,
            math.sqrt(fr.omega_start * fr.omega_stop), repeats)
    return PointTiming(t_r, t_s, unknowns, setup, sparse, slowdown(), t_red, t_static)


def wheel_modes(study, fr) -> int:
    """m of a mistuned wheel counted on the tuned wheel: its tuned sector's natural
    frequencies in the range at every nodal diameter, those of 0 < ND < N/2 twice (a
    travelling pair)."""
    N, case = study.scene.assembly.sectors, study.sweep.cases()[0][1]
    return sum((1 if nd in (0, N / 2) else 2) * modes_in_range(tuned_sector(study, case, nd), fr)
               for nd in range(N // 2 + 1))


def wheel_memory(tm: PointTiming) -> tuple:
    """(bytes [B] a mistuned wheel's Jacobian and factors take, about; the machine's memory
    [B]), WHEEL_BYTES per entry of its N blocks of (unknowns / N)^2."""
    b = tm.unknowns / max(tm.sectors, 1)
    have = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    return WHEEL_BYTES * tm.sectors * b * b, float(have)


def time_system_point(system, H: int, method: str, samples: int, omega: float,
                      repeats: int = 5) -> tuple:
    """(t_R, t_S [s], unknowns, sparse) of one continuation point of `system` at H
    harmonics, forces by `method` ("exact" / "aft" with `samples`), at `omega`
    [rad/s] from the linear response there (medians of `repeats`)."""
    prob = hbm.setup(system, H, method, samples)
    x = initial_guess(prob, omega, system.contact)
    hbm.residual(prob, x, omega, system.contact)          # compiled / warmed once, not timed
    t_r, t_s = [], []
    J = None
    for _ in range(repeats):
        t1 = time.perf_counter()
        R, J, dR = hbm.residual(prob, x, omega, system.contact)
        t2 = time.perf_counter()
        A = _bordered(J, dR)
        t3 = time.perf_counter()
        try:
            if sp.issparse(A) or A.shape[0] < SINGLE_ROWS:
                linear_solve(A, np.append(R, 0.0))
            else:   # the solver's mixed precision: a float32 LU, solves refined in float64
                lu = sla.lu_factor(A.astype(np.float32), check_finite=False)
                sla.lu_solve(lu, np.append(R, 0.0).astype(np.float32), check_finite=False)
        except Exception:   # a singular Newton matrix at the guess: its cost is what counts
            pass
        t_r.append(t2 - t1)
        t_s.append(time.perf_counter() - t3)
    return float(np.median(t_r)), float(np.median(t_s)), int(x.size), bool(sp.issparse(J))


def slowdown(repeats: int = 5) -> float:
    """Wall / CPU time of a single-threaded pure-Python loop (about 20 ms of CPU),
    the median of `repeats`: 1 on an idle core, about 5 with 10 busy processes on 2."""
    ratios = []
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        acc = 0
        for i in range(300_000):
            acc += i * i
        cpu = time.process_time() - c0
        ratios.append((time.perf_counter() - w0) / cpu if cpu > 0 else 1.0)
    return max(1.0, float(np.median(ratios)))


def _bordered(J, dR):
    """[[J, dR/dOm], [t^T]]: the continuation's Newton matrix, t a unit row."""
    n = J.shape[0]
    row = np.zeros(n + 1)
    row[-1] = 1.0
    if sp.issparse(J):
        return sp.bmat([[J, dR[:, None]], [row[None, :-1], row[None, -1:]]]).tocsc()
    A = np.empty((n + 1, n + 1))
    A[:n, :n] = J
    A[:n, n] = dR
    A[n] = row
    return A


def modes_in_range(system, fr) -> int:
    """m: natural frequencies of `system`, contacts open and stuck (counted apart), in
    the frequency range `fr` (the lowest 200 of each), traced up or down."""
    w = np.concatenate([lowest_frequencies(system, c, 200) for c in ("open", "stuck")])
    lo, hi = sorted((fr.omega_start, fr.omega_stop))
    return int(np.sum((w >= lo) & (w <= hi)))


def estimate(study, workers: int = 1, timing: PointTiming | None = None) -> Estimate:
    """The `Estimate` of a response study (timing measured now unless given)."""
    timing = timing or time_point(study)
    sv, fr = study.solver, study.sweep.frequency
    n_cases = len(study.sweep.cases())
    w = max(1, min(workers, n_cases))
    if timing.sectors:     # a mistuned wheel, not built (`time_point`)
        n = timing.sectors * tuned_sector(study, study.sweep.cases()[0][1]).n_dof
        m = wheel_modes(study, fr)
    else:
        system = study.system(study.sweep.cases()[0][1])
        n, m = system.n_dof, modes_in_range(system, fr)
    f = timing.slowdown / CALIBRATION_SLOWDOWN      # the machine now against then
    key = stability_key(sv.stability)
    stab = STABILITY.get(key, STABILITY["hill+check"])
    if key.startswith("hill"):
        cube = (2.0 * n * (2 * sv.harmonics + 1)) ** 3
        waves = (study.scene.assembly.sectors // 2 + 1
                 if study.scene.cyclic and study.scene.mistuning is None else 1)
        stab = tuple(waves * (st + k * cube) for st, k in zip(STABILITY["hill"], HILL_CUBE)) \
            if key == "hill" else (stab[0] + HILL_CUBE[0] * cube, stab[1] + HILL_CUBE[1] * cube)
    pairs, lus = work_per_point(timing.unknowns, timing.sparse)
    point = tuple(c * timing.t_residual + k * timing.t_solve + f * (s0 + s1 * n + st)
                  for c, k, s0, s1, st in zip(pairs, lus, *OVERHEAD, stab))
    points = points_per_case(m, sv.max_points,
                             1.0 if getattr(study.output, "curves", True) else PEAKS_ONLY)
    case = (points[0] * point[0], points[1] * point[1])
    search = None
    fixed = timing.setup + model_work(study, timing) + timing.slowdown * OUTPUT
    lo = n_cases * case[0] / w + fixed
    hi = n_cases * case[1] / w + fixed
    if study.output.optimum is not None:
        bare = tuple(c * timing.t_residual + k * timing.t_solve + f * (s0 + s1 * n)
                     for c, k, s0, s1 in zip(pairs, lus, *OVERHEAD))
        search = tuple((g / w + k) * p * b
                       for g, k, p, b in zip(SEARCH_GRID, SEARCH_SERIAL, points, bare))
        lo, hi = lo + search[0], hi + search[1]
    return Estimate(lo=lo, hi=hi, case=case, n_cases=n_cases, workers=w, timing=timing,
                    per_point=point, points=points, search=search, modes=m, pairs=pairs)


def case_speeds(study) -> set:
    """The distinct rotation speeds [rpm] of a study's cases (a case's `speed`, else
    the structure's; 0 for a blade at rest or a lumped scene)."""
    st = study.scene.structure
    return {float(case.get("speed", getattr(st, "speed", 0.0))) for _, case in study.sweep.cases()}


def speeds_of(study) -> int:
    """S: the distinct rotation speeds of a study's cases (1 without a speed axis)."""
    return len(case_speeds(study))


def further_reductions(study) -> int:
    """Reductions of an FE blade beyond the first case's (module docstring): one at
    each further case speed and the one at rest that the dataset describes (its
    reduced frequencies and DOF names) when no case is at rest.  All are made in the
    main process, on a pool too (each case's model is built there and sent to a
    worker), one after another."""
    return len(case_speeds(study) | {0.0}) - 1


def model_work(study, timing: PointTiming) -> float:
    """[s] beyond the first case's model (module docstring): the further reductions
    (`further_reductions`) and each case's static contact solution."""
    return (further_reductions(study) * timing.reduction
            + len(study.sweep.cases()) * timing.static)


def work_per_point(unknowns: int, sparse: bool) -> tuple:
    """((lo, hi) residual evaluations, (lo, hi) Newton solves) a point (module docstring)."""
    if sparse:
        return SPARSE_PAIRS_PER_POINT, SPARSE_FACTORISATIONS_PER_POINT
    return PAIRS_PER_POINT, (FACTORISATIONS_PER_POINT if unknowns + 1 >= KEEP_ROWS
                             else PAIRS_PER_POINT)


def points_per_case(m: int, max_points: int, scale: float = 1.0) -> tuple:
    """(lo, hi) points of a curve through m natural frequencies (module docstring),
    times `scale`, at most 1.1 max_points."""
    p_mid = 60.0 * (1 + m) ** 0.6 * scale
    return tuple(min(x * p_mid, max_points * 1.1) for x in POINTS)


def model_line(study) -> str:
    """What the run builds: an FE blade's size counted from its mesh parameters
    (`structure.mesh_size`) and reduced size; a lumped scene's DOFs."""
    sc = study.scene
    structure = sc.structure
    sectors = sc.assembly.sectors if sc.cyclic else 1
    whole = (f"; the mistuned wheel: {sectors} x that" if sc.mistuning is not None
             else " per sector (cyclic)" if sc.cyclic else "")
    params = getattr(structure, "params", None)
    if params is None:
        return f"model: {len(sc.sector_dofs)} DOF(s), {len(sc.contacts)} contact(s){whole}"
    modes = sc.reduction.modes
    if structure.mesh:
        return (f"model: solid blade from {structure.mesh}, Craig-Bampton {modes} modes + the "
                f"boundary DOFs{whole}")

    s = mesh_size(params, structure.disk)
    return (f"model: {params.kind} blade, {s.elements:,} elements, {s.free_dofs:,} DOFs (from "
            f"the mesh parameters) -> Craig-Bampton {s.boundary_dofs} boundary DOFs + {modes} "
            f"modes = {s.boundary_dofs + modes} DOFs{whole}")


def seconds(t: float) -> str:
    """A duration [s] as the estimates print it."""
    if t < 1.0:
        return "under 1 s"
    if t < 120.0:
        return f"{t:.0f} s"
    if t < 7200.0:
        return f"{t / 60:.0f} min"
    return f"{t / 3600:.1f} h"


def time_range(lo: float, hi: float) -> str:
    """A range of durations [s] as the estimates print it."""
    a, b = seconds(lo), seconds(hi)
    if a == b:
        return a
    return f"up to {b}" if lo < 1.0 else f"{a} to {b}"
