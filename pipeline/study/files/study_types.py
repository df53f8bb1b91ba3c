"""Study specifications as plain frozen data: what a study file declares once it is
validated (`Study`: a `pipeline.model.scene.Scene`, sweeps, solver and output
settings), what a run returns (`StudyResult`), and what a registry entry of a study
kind holds (`StudyKind`, listed in `kinds`).  A leaf of the study layer: the parsers
(`lumped_scene`, `blade_scene`, `disk_modes_study`, `accuracy_study`) build these, `run` and
`response_dataset` read them.  A study written in Python builds `Study` directly (the header
fields are keywords with defaults; `studies/python_example.py`).
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import numbers
import pickle
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ...contact.registry import law_effects
from ...model.scene import Scene
from ...model.static_load import case_system
from ...model.system import System
from ...solve.stability.methods import MODES as STABILITY_MODES


MODELS = ("lumped", "beam_blade", "solid_blade", "disk")
IMPLEMENTED_MODELS = ("lumped", "disk")
# the effects of the contact laws besides Yang-Menq come with their registry entry
EFFECTS = ("friction", "normal_load_variation", "separation", "cyclic_coupling", "mistuning",
           "disk_coupling", "centrifugal_stiffening") + law_effects()
# grid axes of [sweep]: name -> (units, long_name)
SWEEP_AXES = {
    "preload": ("N", "normal preload n0 of every contact"),
    "normal_load": ("N", "static normal load n0 + kv v0 of every contact (face total), "
                         "n0 solved for it"),
    "mu": ("1", "friction coefficient of every contact"),
    "ku": ("N/m", "tangential contact stiffness of every contact"),
    "kv": ("N/m", "normal contact stiffness of every contact"),
    "excitation_scale": ("1", "factor on every excitation amplitude"),
    "eo": ("1", "engine order EO of the excitation (disk scenes)"),
    "mistuning_seed": ("1", "seed of the random sector stiffness mistuning (disk scenes)"),
    "speed": ("rpm", "rotation speed of the disk: stress stiffening and spin softening of "
                     "its solid blades"),
    "interference": ("m", "overlap (> 0) or gap (< 0) of every shroud pair in the assembled "
                          "position: n0 = kv (interference + centrifugal closure)"),
}
INTEGER_SWEEP_AXES = ("eo", "mistuning_seed")
FREQUENCY_UNITS = ("rad/s", "Hz")
# `[solver] stability = true` selects the method recommended for the scene's model
# (pipeline/solve/README.md, "Which stability flag to trust"): the orbit monodromy checked by the exact Floquet
# multipliers on lumped scenes (their default); Hill on a lumped cyclic sector (its
# default); "stretch" on FE blades and FE disks (decided at a few points of each stretch
# between folds and propagated), whose default is the fold rule ("folds": a cheap verdict
# at each branch's ends flipped at every fold)
STABILITY_WHEN_TRUE = {"lumped": "monodromy+check", "disk": "hill",
                       "beam_blade": "stretch", "solid_blade": "stretch"}
# the quantity an optimum search varies ([output.optimum_<name>]) -> its unit
OPTIMUM_UNITS = {"preload": "N", "interference": "m"}
FIGURES = ("amplitude", "hysteresis")
DEFAULT_FIGURES = ("amplitude",)
MAX_HARMONICS = 200
MAX_DOFS = 2000
# a DOF, contact or study name (letters, digits, '_', '.'; at most 64 characters)
NAME_PATTERN = re.compile(r"^[A-Za-z_][A-Za-z0-9_.]{0,63}$")


@dataclass(frozen=True)
class FrequencyRange:
    """Continuation interval of the excitation frequency, in `unit` ("rad/s" or "Hz";
    a study file must name it: there is no default)."""

    start: float
    stop: float
    unit: str

    def __post_init__(self):   # a Python-built study meets the study file's rules
        if self.unit not in FREQUENCY_UNITS:
            raise ValueError(f"FrequencyRange: unit must be 'rad/s' or 'Hz', got {self.unit!r}")
        for k in ("start", "stop"):
            x = getattr(self, k)
            if isinstance(x, bool) or not isinstance(x, numbers.Real) or not math.isfinite(x) \
                    or not x > 0:
                raise ValueError(f"FrequencyRange: {k} must be a finite number > 0 "
                                 f"[{self.unit}], got {x!r}")
        if self.start == self.stop:
            raise ValueError(f"FrequencyRange: start and stop are equal ({self.start:g} "
                             f"{self.unit}): empty interval")

    @property
    def to_rad_s(self) -> float:
        return 2.0 * math.pi if self.unit == "Hz" else 1.0

    @property
    def omega_start(self) -> float:
        return self.start * self.to_rad_s

    @property
    def omega_stop(self) -> float:
        return self.stop * self.to_rad_s


@dataclass(frozen=True)
class Sweep:
    """Grid axes (ordered as in the file; their product is the set of cases) and
    the continuation axis (frequency)."""

    axes: dict                  # name -> tuple of float
    frequency: FrequencyRange

    @property
    def shape(self) -> tuple:
        return tuple(len(v) for v in self.axes.values())

    def cases(self) -> list:
        """[(index tuple, {axis: value})] in C order over the grid."""
        names = list(self.axes)
        idx = itertools.product(*(range(len(v)) for v in self.axes.values()))
        return [(i, {a: self.axes[a][k] for a, k in zip(names, i)}) for i in idx]


@dataclass(frozen=True)
class SolverSettings:
    harmonics: int = 5
    force_evaluation: str = "exact"
    samples: int = 256
    tolerance: float = 1e-9
    # "hill" | "floquet" | "hill+check" | "monodromy" | "monodromy+check" | False
    # (`solve.stability.branch_stability`); lumped scenes default to "monodromy+check", disks and
    # FE blades to cheaper ones (their parsers)
    stability: bool | str = "monodromy+check"
    initial_step: float | None = None   # None: the solver's default
    max_step: float | None = None
    max_points: int = 1000
    dense_output: bool = True           # points where the drawn curve bends

    def kwargs(self, yscale=None, curves=True) -> dict:
        """Keyword arguments of `pipeline.solve.response.response.frequency_response`; with the
        figures' `yscale` ("linear" or "log"), the dense output smooths the curves
        on that amplitude axis only; without `curves` (`OutputSettings.curves`), each
        case keeps its DOFs' largest peaks only (keep="peaks": no dense output)."""
        dense = yscale if self.dense_output and yscale is not None else self.dense_output
        kw = dict(method=self.force_evaluation, n_samples=self.samples,
                  stability=self.stability, tol_rel=self.tolerance, max_points=self.max_points,
                  dense_output=dense if curves else False, keep="curve" if curves else "peaks")
        if self.initial_step is not None:
            kw["ds"] = self.initial_step
        if self.max_step is not None:
            kw["ds_max"] = self.max_step
        return kw


def solver_rule_violations(s) -> list:
    """[(setting to blame, what)] for every cross-field rule that solver settings `s`
    (`SolverSettings` or the accuracy study's `Settings`) break: the first step within
    the largest, and with AFT at least 2H+1 samples per period (exact forces sample
    nothing).  The one place these rules live; parsers name the field."""
    out = []
    if s.initial_step is not None and s.max_step is not None and s.initial_step > s.max_step:
        out.append(("initial_step", f"initial_step {s.initial_step:g} exceeds max_step "
                                    f"{s.max_step:g}"))
    if s.force_evaluation == "aft" and s.samples < 2 * s.harmonics + 1:
        out.append(("samples", f"must be >= 2H+1 = {2 * s.harmonics + 1} for H = "
                               f"{s.harmonics}, got {s.samples}"))
    return out


@dataclass(frozen=True)
class OutputSettings:
    dofs: tuple                  # response DOF names
    figures: tuple = DEFAULT_FIGURES
    yscale: str = "linear"
    peak_windows: tuple = ()     # ((lo, hi), ...) in the sweep's frequency unit
    optimum: dict | None = None  # {dof, bounds (N | m), window | None, rtol, variable, nodes}
    curves: bool = True          # False: each case keeps its DOFs' largest peaks only


@dataclass(frozen=True)
class StudyKind:
    """One kind of study in the registry (`kinds.KINDS`): how a document of it is
    recognised and read, how `check` describes a study of it, how it is estimated and
    run.  Each kind's module defines its entry; nothing else branches on the kind."""

    name: str           # the `kind` of its studies (a dataset's `kind` attribute)
    word: str           # what `[study] kind` says for it
    fits: Callable      # document -> True if its scene is one this kind reads
    by_default: Callable  # document -> True if read as this kind when `kind` is not given
    parse: Callable     # (document, *, file, name, text, quick) -> validated study
    describe: Callable  # (study, workers) -> lines `check` prints, the estimate included
    estimate: Callable  # (study, workers) -> estimate [s]: .lo, .hi, .mid
    run: Callable       # (study, out_dir, **options of `run.run_study`) -> StudyResult
    cases: Callable     # study -> number of cases it runs
    optimum: bool = False   # its studies may search the optimum preload (`optimise`)


def optimum_variable(optimum: dict | None) -> str:
    """The quantity an optimum search (`OutputSettings.optimum`) varies: "preload" (the
    contacts' n0 [N]) or "interference" (every shroud pair's [m])."""
    return (optimum or {}).get("variable", "preload")


def always(document) -> bool:
    """A `StudyKind.fits` / `by_default` that holds for every document."""
    return True


def never(document) -> bool:
    """A `StudyKind.by_default` of a kind a document must name."""
    return False


@dataclass(frozen=True, kw_only=True)
class StudyHeader:
    """What every study kind carries: where it came from and how it describes itself
    (keywords only; a study written in Python may leave them out)."""

    file: str = "<python>"
    name: str = "study"          # the file's stem: output DIR/<name>.nc
    title: str = ""
    description: str = ""
    reference: str = ""
    text: str = ""               # the study file's text (dataset attribute `study`)


@dataclass(frozen=True)
class Study(StudyHeader):
    """A response study: a scene, its sweep, solver and output settings."""

    scene: Scene
    sweep: Sweep
    solver: SolverSettings
    output: OutputSettings
    quick: bool = False
    kind: str = "response"

    def system(self, case: dict | None = None) -> System:
        return case_system(self.scene, case)


def is_linear_scene(scene) -> bool:
    """A scene without friction, separation and the effect of any further contact law
    (`contact.registry`) has no nonlinear force to solve for."""
    nonlinear = {"friction", "separation"} | set(law_effects())
    return not (nonlinear & set(getattr(scene, "effects", ()) or ()))


@dataclass
class StudyResult:
    study: Study
    dataset: object                 # xarray.Dataset
    path: Path | None               # the netCDF file (None if nothing converged)
    figures: list = field(default_factory=list)
    failures: int = 0               # cases that raised
    failed: list = field(default_factory=list)  # ({axis: value}, reason) of each of them
    stopped: list = field(default_factory=list)  # ({axis: value}, why) of cases cut short
    optimum_error: str | None = None  # why the optimum-preload search stopped
    reused: int = 0                 # cases taken from checkpoints of an interrupted run
    computed: int = 0               # cases computed in this run
    wall_time: float = 0.0          # [s]

    @property
    def ok(self) -> bool:
        return self.path is not None and self.failures == 0 and self.optimum_error is None


@dataclass(frozen=True)
class ModesStudy(StudyHeader):
    """A "modes" study: reduced vs full eigenfrequencies against the mode count."""

    scene: Scene
    mode_counts: tuple
    n_frequencies: int
    n_shapes: int
    quick: bool = False
    kind: str = "modes"


def content_bytes(study) -> bytes | None:
    """Every field of a study of any kind but its text, as bytes (equal for equal
    studies; a checkpoint key and `documents.text_describes` compare them); None for a
    study built in Python with a part that cannot be pickled (a lambda)."""
    try:
        return pickle.dumps(dataclasses.replace(study, text=""))
    except (pickle.PicklingError, AttributeError, TypeError):
        return None
