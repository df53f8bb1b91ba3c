"""What an accuracy-cost study is: its cases and settings as plain data, and the rules
on settings that need no scene.

`Settings` are the accuracy settings of one run, a `Case` is one scene with its
reference, baseline and knob values, an `AccuracyStudy` is the validated study.
Reading a study file, the scene parts included, is `accuracy_study.study_from_mapping`;
the study itself is described in accuracy_study.py.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from .study_types import StudyHeader, solver_rule_violations


# ---------------------------------------------------------------------------
# Plain data
# ---------------------------------------------------------------------------

MESH_FIELDS = ("n_chord", "n_thick", "n_span")   # the element counts of a blade's `mesh`

@dataclass(frozen=True)
class Settings:
    """Solver and model accuracy settings of one run."""

    harmonics: int = 14
    force_evaluation: str = "exact"
    samples: int = 256                  # AFT samples per period (force_evaluation = "aft")
    tolerance: float = 1e-9             # relative residual tolerance (hbm.tolerances)
    max_step: float = 0.1               # largest continuation step (scaled arclength)
    initial_step: float = 0.02          # first continuation step
    craig_bampton_modes: int | None = None   # blades: fixed-interface modes
    mesh: tuple | None = None           # blades: (n_chord, n_thick, n_span)
    # "harmonic_balance": the forced response traced; "nonlinear_mode": synthesised
    # from the first mode's backbone (`solve.nonlinear_modes`)
    forced_response: str = "harmonic_balance"

    def with_knob(self, knob: str, value) -> "Settings":
        """These settings with one knob changed (`samples` switches to AFT; a max_step
        below the initial step lowers the initial step too)."""
        if knob == "samples":
            return replace(self, force_evaluation="aft", samples=int(value))
        if knob == "max_step":
            return replace(self, max_step=float(value), initial_step=min(self.initial_step, value))
        return replace(self, **{knob: value})

    def value_of(self, knob: str):
        if knob == "samples":
            return self.samples if self.force_evaluation == "aft" else "exact"
        return getattr(self, knob)

    def solver_kwargs(self) -> dict:
        """Keyword arguments of `response.frequency_response`."""
        return dict(method=self.force_evaluation, n_samples=self.samples, tol_rel=self.tolerance,
                    ds=self.initial_step, ds_max=self.max_step, stability=False)

    def describe(self) -> str:
        parts = [f"H = {self.harmonics}",
                 "exact forces" if self.force_evaluation == "exact" else f"AFT N = {self.samples}",
                 f"tolerance {self.tolerance:g}", f"max_step {self.max_step:g}"]
        if self.craig_bampton_modes is not None:
            parts.append(f"{self.craig_bampton_modes} CB modes")
        if self.mesh is not None:
            parts.append("mesh " + "x".join(map(str, self.mesh)))
        if self.forced_response != "harmonic_balance":
            parts.append("synthesised from the nonlinear mode")
        return ", ".join(parts)


@dataclass(frozen=True)
class Case:
    """One scene with its reference, baseline and knob values."""

    name: str                   # "lumped" or "blade"
    scene: object               # pipeline.model.scene.Scene (lumped or FE blade)
    dof: str                    # response DOF whose peak is measured
    preload: float | None       # [N] every contact's n0 (blades: total per face); None: the scene's
    frequency: object           # scene.FrequencyRange
    repeats: int
    time_integration: bool      # lumped only: reference vs event-driven integration
    reference: Settings
    baseline: Settings
    knobs: tuple                # ((knob, (value, ...)), ...) in file order

    def runs(self) -> list:
        """[(knob, value, Settings)]: reference, baseline, then every knob value."""
        out = [("reference", None, self.reference), ("baseline", None, self.baseline)]
        for k, values in self.knobs:
            out += [(k, v, self.baseline.with_knob(k, v)) for v in values]
        return out


@dataclass(frozen=True)
class AccuracyStudy(StudyHeader):
    """A validated accuracy-cost study (`accuracy_study.study_from_mapping`)."""

    cases: tuple                # Case, ...
    target: float               # relative error the recommendation must meet
    quick: bool = False
    kind: str = "accuracy_cost"


# ---------------------------------------------------------------------------
# Rules on settings (failures through the scene `Checker` ck)
# ---------------------------------------------------------------------------

def mesh_value(ck, value, field_):
    """The element counts (n_chord, n_thick, n_span) of a `mesh = [..]` value."""
    vals = ck.array(value, field_, length=3)
    return tuple(ck.integer(v, f"{field_}[{i}]", 1, 1000) for i, v in enumerate(vals))


def check_settings(ck, s, field_of):
    """Rules between the settings of one run: initial_step <= max_step, and N >= 2H+1
    AFT samples; `field_of(key)` is the field a failure names."""
    for key, what in solver_rule_violations(s):
        ck.fail(field_of(key), what)


def beyond_reference(knob, value, ref: Settings) -> str | None:
    """Why `value` of `knob` is more accurate than the reference (None if it is not)."""
    if knob == "harmonics" and value > ref.harmonics:
        return f"H = {value} exceeds the reference's H = {ref.harmonics}"
    if knob == "samples" and ref.force_evaluation == "aft" and value > ref.samples:
        return f"N = {value} exceeds the reference's N = {ref.samples}"
    if knob == "tolerance" and value < ref.tolerance:
        return f"{value:g} is below the reference's tolerance {ref.tolerance:g}"
    if knob == "max_step" and value < ref.max_step:
        return f"{value:g} is below the reference's max_step {ref.max_step:g}"
    if knob == "craig_bampton_modes" and value > ref.craig_bampton_modes:
        return f"{value} modes exceed the reference's {ref.craig_bampton_modes}"
    if knob == "mesh" and any(a > b for a, b in zip(value, ref.mesh)):
        return f"mesh {list(value)} is finer than the reference's {list(ref.mesh)}"
    return None

