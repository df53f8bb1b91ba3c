"""Every key a study file may hold: one row per (table, key) with its unit, default and
meaning -- the table `studies/README.md` shows (`python -m pipeline keys` prints it)
and `tests/study/files/test_keys.py` holds against the parsers: each key a parser accepts is a
row here and each row is accepted by some parser (probed with an unknown key in every
table of the shipped studies, whose one-line error lists the keys allowed there).

Units and defaults are taken from the code where it states them: the sweep axes'
units from `study_types.SWEEP_AXES`, the solver defaults from `study_types.SolverSettings`, the
blade's from `structure.fe_model.BladeParams`, the mode count from
`structure.reduction.DEFAULT_MODES`.

Table paths are dotted as in the error messages, without list indices.  `<case>` is
an accuracy-cost case table, `[lumped]` or `[blade]`; `ALIASES` maps the tables that
take the keys of another one (`[quick.solver]` those of `[solver]`, ...).
"""
from __future__ import annotations

import re
from dataclasses import fields

from ...contact.registry import study_laws
from ...structure.fe_model import BladeParams
from ...structure.reduction import DEFAULT_MODES
from .accuracy_types import Settings
from ...solve.response.optimum import LINEAR_NODES
from .study_types import EFFECTS, FIGURES, SWEEP_AXES, SolverSettings

FILE = ""                    # the top level of a study file
CASE = "<case>"              # an accuracy-cost case: [lumped] or [blade]
# [[arrays of tables]]; each registered contact law placed by study files adds its own
ARRAYS = ("scene.contact", "scene.excitation", "scene.disk.spring") + tuple(
    f"scene.{t}" for t in study_laws())

# tables whose keys are those of another table (a path prefix maps to another prefix)
ALIASES = {
    "quick.sweep": "sweep",
    "quick.solver": "solver",
    "quick.modes": "modes",
    "quick.scene.blade": "scene.blade",
    "output.optimum_preload.frequency": "sweep.frequency",
    "output.optimum_interference.frequency": "sweep.frequency",
    "lumped": CASE,
    "blade": CASE,
    "quick.lumped": CASE,    # a case's keys but `scene`
    "quick.blade": CASE,
    f"{CASE}.scene": "scene",
    f"{CASE}.frequency": "sweep.frequency",
}

_REQ = "required"
_STABILITY = ('`"monodromy+check"` lumped, `"hill"` lumped disk, `"folds"` FE blades')


def _fmt(v) -> str:
    """A default as a study file writes it."""
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return f"{v:.4g}"


def _settings_rows() -> list:
    """[<case>.reference]: the accuracy settings, defaults from `accuracy_types.Settings`
    (a blade's mode count and mesh from the reduction's and the blade's)."""
    d = {f.name: f.default for f in fields(Settings)}
    p = BladeParams()
    d["craig_bampton_modes"] = DEFAULT_MODES
    d["mesh"] = (p.n_chord, p.n_thick, p.n_span)
    meaning = {"harmonics": ("1", "H"), "force_evaluation": ("", '`"exact"` or `"aft"`'),
               "samples": ("1", "AFT samples"), "tolerance": ("1", "Newton tolerance"),
               "max_step": ("1", "largest step"), "initial_step": ("1", "first step"),
               "craig_bampton_modes": ("1", "blade case"),
               "mesh": ("1", "blade case: `[n_chord, n_thick, n_span]`")}
    return [(f"{CASE}.reference", k, u, _fmt(d[k]), t) for k, (u, t) in meaning.items()]


def _solver_rows() -> list:
    """[solver]: defaults from `SolverSettings` (stability per model: its parsers)."""
    d = {f.name: f.default for f in fields(SolverSettings)}
    meaning = {
        "harmonics": ("1", "H, harmonics of the balance (1 ... 200)"),
        "force_evaluation": ("", '`"exact"` (event-based contact forces) or `"aft"` '
                                 "(alternating frequency-time on `samples`)"),
        "samples": ("1", "AFT samples per period (>= 2H + 1)"),
        "tolerance": ("1", "Newton residual tolerance, relative to the force scale "
                           "‖P‖ + Σ|n0|·‖Bn‖"),
        "stability": ("", '`"monodromy+check"`, `"monodromy"`, `"hill"`, `"hill+check"`, '
                          '`"floquet"`, `"stretch"`, `"folds"`, `false`, or `true` (the method '
                          "recommended for the scene); see pipeline/solve/README.md"),
        "initial_step": ("1", "first continuation step (scaled arclength)"),
        "max_step": ("1", "largest continuation step (scaled arclength); peaks and folds are "
                          "refined whatever the step"),
        "max_points": ("1", "most points a branch may have"),
        "dense_output": ("", "add points where the drawn curve bends (on `[output] yscale`)"),
    }
    rows = []
    for k, (unit, text) in meaning.items():
        v = d[k]
        default = _STABILITY if k == "stability" else "the solver's" if v is None else _fmt(v)
        rows.append(("solver", k, unit, default, text))
    return rows


def _blade_rows() -> list:
    """[scene.blade]: the fields of `BladeParams` a study may set, defaults from it."""
    d = {f.name: f.default for f in fields(BladeParams)}
    units = {"length": ("m", "blade length (span)"), "chord": ("m", "airfoil chord"),
             "thickness": ("m", "airfoil thickness"),
             "shroud_chord": ("m", "tip shroud size along the chord"),
             "shroud_width": ("m", "tip shroud size across (a wheel derives it from R and N)"),
             "shroud_height": ("m", "tip shroud height"),
             "shroud_angle": ("rad", "contact faces' angle from the circumferential axis"),
             "stagger_angle": ("rad", "airfoil stagger about the span"),
             "E": ("Pa", "Young's modulus"), "nu": ("1", "Poisson's ratio"),
             "rho": ("kg/m³", "density"),
             "n_chord": ("1", "elements across the chord"),
             "n_thick": ("1", "elements through the thickness"),
             "n_span": ("1", "elements along the span"),
             "twist": ("rad", "solid blade: root stagger beyond the shroud's, linear along the "
                              "span, ≤ π/4"),
             "camber": ("1", "solid blade: root camber height / chord, fading as 1 - s², "
                             "≤ 0.25"),
             "taper": ("1", "solid blade: root chord / chord - 1, linear along the span, "
                            "-0.5 … 1"),
             "damping_ratios": ("1", "modal damping ratios (the last repeats); not with "
                                     "`rayleigh`"),
             "shroud": ("", "with the tip shroud and its contact faces")}
    rows = []
    for k, (unit, text) in units.items():
        rows.append(("scene.blade", k, unit, _fmt(d[k]), text))
    return rows


def _sweep_rows() -> list:
    """[sweep]: the continuation interval and the grid axes of `study_types.SWEEP_AXES`."""
    rows = [("sweep", "frequency", "", _REQ, "continuation interval `{start, stop, unit}`")]
    for k, (unit, text) in SWEEP_AXES.items():
        extra = {"preload": "; not with a contact's `n0`",
                 "interference": "; FE blades in a disk, not with a pair's `n0` or "
                                 "`interference`, nor `preload` / `normal_load`",
                 "normal_load": "; instead of `preload`, > 0",
                 "eo": "; integers 0 ... N/2", "mistuning_seed": "; integers, or `{first, count}`"}.get(k, "")
        rows.append(("sweep", k, unit, "", f"list: {text}{extra}"))
    rows += [("sweep.frequency", "start", "`unit`", _REQ, "first frequency of the continuation"),
             ("sweep.frequency", "stop", "`unit`", _REQ, "last frequency (below `start`: a "
                                                         "downward sweep)"),
             ("sweep.frequency", "unit", "", _REQ, '`"rad/s"` or `"Hz"` (also the dataset\'s)'),
             ("sweep.mistuning_seed", "first", "1", _REQ, "first seed of a range"),
             ("sweep.mistuning_seed", "count", "1", _REQ, "seeds first ... first + count - 1")]
    return rows


_FIXED = [
    (FILE, "study", "", _REQ, "title and description"),
    (FILE, "scene", "", _REQ, "the structure, contacts and loads"),
    (FILE, "sweep", "", "", "grid axes and the frequency interval (response studies: required)"),
    (FILE, "solver", "", "", "solver settings"),
    (FILE, "output", "", "", "response DOFs, figures, peak windows, optimum preload"),
    (FILE, "modes", "", "", "settings of a modes or nonlinear modes study"),
    (FILE, "quick", "", "", "the `--quick` variant, read only with `--quick`, merged key by key"),
    (FILE, "recommendation", "", "", "accuracy-cost study: the error target"),
    (FILE, "lumped", "", "", "accuracy-cost study: the lumped case"),
    (FILE, "blade", "", "", "accuracy-cost study: the FE blade case"),
    ("study", "title", "", _REQ, "text, copied to the dataset"),
    ("study", "description", "", '""', "text, copied to the dataset"),
    ("study", "reference", "", '""', "text (a paper), copied to the dataset"),
    ("study", "kind", "", '"response"', '`"response"`, `"modes"` (blade and disk scenes; '
                                        'default with a `[modes]` table), `"nonlinear_modes"`, '
                                        '`"accuracy_cost"`'),
    ("scene", "model", "", _REQ, '`"lumped"`, `"disk"` (one sector of a tuned disk), '
                                 '`"solid_blade"`, `"beam_blade"`'),
    ("scene", "effects", "", "[]", "subset of " + ", ".join(f'`"{e}"`' for e in EFFECTS)
     + ", checked against the scene; `[]`: a linear scene, solved directly"),
    ("scene", "dofs", "", _REQ, "lumped and disk scenes: DOF names (`x1`, `u`, ...)"),
    ("scene", "matrices", "", "", "lumped and disk scenes: M, C, K (or `modal`); solid blades: "
                                  "K and M exported by another FE code for `mesh`"),
    ("scene", "modal", "", "", "lumped and disk scenes: modal data instead of `matrices`"),
    ("scene", "contact", "", "[]", "Yang–Menq contacts (array of tables)"),
    ("scene", "excitation", "", _REQ, "harmonic loads (array of tables; not in a modes study)"),
    ("scene", "disk", "", "", "a disk: sectors, engine order, mistuning, springs, hub radius"),
    ("scene", "disk_sector", "", "", "solid blades in a disk: the flexible disk sector under "
                                     "the blade (a mesh's: its node sets `cyclic_low`, "
                                     "`cyclic_high`)"),
    ("scene", "blade", "", "{}", "FE blades: `BladeParams` fields"),
    ("scene", "mesh", "", "", "solid blades: a mesh file with named node sets "
                              "(meshes/README.md), relative to the study file"),
    ("scene", "units", "", '"SI"', 'the mesh file\'s coordinates: "SI" (m) or "mm"; the '
                                  "material stays SI"),
    ("scene", "craig_bampton_modes", "1", str(DEFAULT_MODES), "FE blades: fixed-interface modes "
                                                             "of the reduction"),
    ("scene", "rayleigh", "1/s, s", "", "FE blades: `[α, β]`, C = αM + βK (instead of "
                                        "`damping_ratios`)"),
    ("scene.matrices", "M", "kg", _REQ, "list of rows; symmetric positive definite"),
    ("scene.matrices", "K", "N/m", _REQ, "list of rows; symmetric positive definite"),
    ("scene.matrices", "C", "N s/m", "zeros", "list of rows; symmetric positive semi-definite"),
    ("scene.matrices", "format", "", _REQ, "exported by: `calculix`, `abaqus`, `ansys`, "
                                           "`matrix_market` (solid blades; meshes/README.md)"),
    ("scene.matrices", "units", "", _REQ, "`SI` (N/m, kg, m) or `mm` (N/mm, tonne, mm)"),
    ("scene.matrices", "job", "", _REQ, "calculix: the job, `<job>.sti/.mas/.dof`"),
    ("scene.matrices", "stiffness", "", _REQ, "abaqus, ansys, matrix_market: the K file"),
    ("scene.matrices", "mass", "", _REQ, "abaqus, ansys, matrix_market: the M file"),
    ("scene.matrices", "mapping", "", _REQ, "ansys: the `.mapping` file of the HBMAT export"),
    ("scene.matrices", "dofs", "", _REQ, "matrix_market: the \"node direction\" table"),
    ("scene.matrices", "speed", "", "[]", "a turning blade: tables `rpm` and the format's "
                                          "stiffness key, K exported at that speed (two or more)"),
    ("scene.matrices", "axis", "", "X through (0, 0, −R)", "solid blades in a disk: the "
                                                          "model's engine axis, `point` and "
                                                          "`direction` (meshes/README.md)"),
    ("scene.matrices.axis", "point", "m or mm", _REQ, "a point of the engine axis in the "
                                                      "model's frame, in `units`' length"),
    ("scene.matrices.axis", "direction", "1", _REQ, "the axis direction (not zero); the "
                                                    "next blade lies towards r × direction"),
    ("scene.matrices", "damping", "", "zeros", "lumped scenes from files: the C file (the "
                                               "stiffness's format; DOFs `n<node>.<x|y|z|rx|ry|rz>`)"),
    ("scene.modal", "masses", "kg", _REQ, "modal masses m"),
    ("scene.modal", "frequencies", "rad/s", _REQ, "natural frequencies ω"),
    ("scene.modal", "damping_ratios", "1", _REQ, "modal damping ratios ζ"),
    ("scene.modal", "mode_shapes", "1", _REQ, "Φ, the mode shapes as COLUMNS: M = Φ⁻ᵀ diag(m) "
                                              "Φ⁻¹, K = Φ⁻ᵀ diag(mω²) Φ⁻¹, C = Φ⁻ᵀ diag(2ζmω) Φ⁻¹"),
    ("scene.contact", "name", "", "contact0, contact1, …; the face; shroud", "a name (dataset `contact`)"),
    ("scene.contact", "tangential", "1", "", "lumped and disk: DOFs with signs, "
                                             '`["x1", "-x2"]`, or coefficients `{x1 = 0.8}`; '
                                             "`next.<dof>` in a disk (required there)"),
    ("scene.contact", "normal", "1", "none", "lumped and disk: the normal DOFs, as `tangential`"),
    ("scene.contact", "face", "", "", 'FE blade against a rigid wall: `"shroud_left"` or '
                                      '`"shroud_right"`'),
    ("scene.contact", "pair", "", "", 'FE blades in a disk: `"shroud"`, right face of blade j '
                                      "against the left face of blade j+1"),
    ("scene.contact", "ku", "N/m", _REQ, "tangential stiffness (> 0)"),
    ("scene.contact", "ku2", "N/m", "= ku", 'FE contacts with friction = "2d": tangential '
                                            "stiffness along the second tangent n x t1"),
    ("scene.contact", "kv", "N/m", "0", "normal stiffness (kv > 0 needs normal DOFs)"),
    ("scene.contact", "mu", "1", _REQ, "friction coefficient"),
    ("scene.contact", "n0", "N", "the sweep's", "preload (< 0: a gap); a face's total"),
    ("scene.contact", "stiffness", "", '"per_node"', 'FE faces: `"per_node"` (ku, kv per node) '
                                                     'or `"per_face"` (face totals by node area)'),
    ("scene.contact", "tangent", "1", "circumferential", "shroud pairs: slip direction [x, y, z], "
                                                         "projected into the face from within 60° of it (2D: in "
                                                         "it)"),
    ("scene.contact", "interference", "m", "", "shroud pairs: overlap (> 0) or gap (< 0) in "
                                               "the assembled position; sets the preload with "
                                               "the speed (instead of n0)"),
    ("scene.contact", "friction", "", '"1d"', 'FE faces and shroud pairs: `"1d"` (slip along the '
                                              'tangent, Yang-Menq) or `"2d"` (slip in the face '
                                              'plane, t2 = n x t1; effect `friction_2d`, AFT)'),
    ("scene.excitation", "dof", "", "", "lumped and disk: the loaded DOF (required there)"),
    ("scene.excitation", "set", "", "", 'FE blades: `"excitation"` or `"response"` node set'),
    ("scene.excitation", "direction", "1", "", "FE blades: [x, y, z] (required there)"),
    ("scene.excitation", "amplitude", "N", _REQ, "F(t) = amplitude · cos(hΩt + phase)"),
    ("scene.excitation", "harmonic", "1", "1", "h; 0 is a static load"),
    ("scene.excitation", "phase", "rad", "0", "phase of the load, within ±2π"),
    ("scene.disk", "sectors", "1", _REQ, "N, sectors (blades) of the disk"),
    ("scene.disk", "engine_order", "1", "the sweep's `eo`", "EO, 0 ≤ EO ≤ N/2: sector j loaded "
                                                            "with the phase j·2π·EO/N"),
    ("scene.disk", "mistuning", "", "tuned", "`{stiffness_std, seed}` or `{factors}`"),
    ("scene.disk", "speed", "rpm", "0", "FE blades: rotation speed (with the effect "
                                       "`centrifugal_stiffening`; `sweep.speed` sweeps it)"),
    ("scene.disk", "spring", "", "[]", "lumped disks: linear springs to the next sector"),
    ("scene.disk", "hub_radius", "m", "", "FE blades: R, the blade root's radius (required "
                                          "there)"),
    ("scene.disk_sector", "bore_radius", "m", "", "generated: the bore, below the hub "
                                                  "radius, clamped (required there)"),
    ("scene.disk_sector", "n_radial", "1", "2", "generated: element layers bore to rim"),
    ("scene.disk_sector", "n_overhang", "1", "1", "generated: elements from the airfoil to "
                                                  "each cut face"),
    ("scene.disk_sector", "E", "Pa", "the blade's", "generated: the disk's Young's modulus"),
    ("scene.disk_sector", "nu", "1", "the blade's", "generated: the disk's Poisson ratio"),
    ("scene.disk_sector", "rho", "kg/m³", "the blade's", "generated: the disk's density"),
    ("scene.disk_sector", "cut_face_modes", "1", "all DOFs kept", "the cut face reduced to "
                                                                  "its condensed modes, this "
                                                                  "many per phase 0, π/2, π"),
    ("scene.disk.mistuning", "stiffness_std", "1", "", "s: sector j stiffness (1 + δ_j)K, "
                                                        "δ_j ~ N(0, s²) cut at 3s, 0 ≤ s < 0.5"),
    ("scene.disk.mistuning", "seed", "1", "the sweep's `mistuning_seed`",
     "seed of `numpy.random.default_rng`"),
    ("scene.disk.mistuning", "factors", "1", "", "instead: N stiffness factors f_j, sector "
                                                 "order"),
    ("scene.disk.spring", "name", "", "spring0, spring1, …", "a name"),
    ("scene.disk.spring", "elongation", "1", _REQ, 'row as a contact\'s, e.g. '
                                                   '`["next.xd", "-xd"]`'),
    ("scene.disk.spring", "k", "N/m", _REQ, "stiffness"),
    ("output", "dofs", "", "every DOF; `response.x/y/z` (blades)",
     "response DOFs (`x1`, `response.y`, `x1@3` one sector of a mistuned disk)"),
    ("output", "figures", "", '["amplitude"]', "of " + ", ".join(f'`"{f}"`' for f in FIGURES)
     + ": response curves; the face-total loop of the contact dissipating most at each peak"),
    ("output", "yscale", "", '"linear"', '`"linear"` or `"log"`: figures\' amplitude axis'),
    ("output", "peak_windows", "`unit`", "[]", "`[[lo, hi], ...]`: one resonance peak per "
                                               "window"),
    ("output", "optimum_preload", "", "", "the optimum-preload search (lumped and blade scenes)"),
    ("output", "optimum_interference", "", "", "instead: the search over every shroud pair's "
                                              "interference (FE blades in a disk)"),
    ("output", "curves", "", "true", "false (mistuned disks): each case keeps every sector's "
                                     "largest peak only, a Monte-Carlo sample"),
    ("output.optimum_preload", "dof", "", _REQ, "the DOF whose peak is minimised"),
    ("output.optimum_preload", "bounds", "N", _REQ, "`[lo, hi]` of the preload"),
    ("output.optimum_preload", "frequency", "", "the sweep's", "window `{start, stop, unit}`"),
    ("output.optimum_preload", "rtol", "1", "0.01", "tolerance of the optimum in log n0 "
                                                    "(Brent to a tenth of it)"),
    ("output.optimum_interference", "dof", "", _REQ, "the DOF whose peak is minimised"),
    ("output.optimum_interference", "bounds", "m", _REQ, "`[lo, hi]` of the interference "
                                                         "(< 0: a gap)"),
    ("output.optimum_interference", "frequency", "", "the sweep's", "window "
                                                                    "`{start, stop, unit}`"),
    ("output.optimum_interference", "rtol", "1", "0.01", "tolerance of the optimum, of "
                                                         "hi - lo (Brent to a tenth of it)"),
    ("output.optimum_interference", "nodes", "1", str(LINEAR_NODES), "nodes of the linear "
                                                                     "grid over the bounds"),
    ("modes", "mode_counts", "1", "[0, 5, 10, 20, 40]", "blade modes study: Craig–Bampton "
                                                         "mode counts to compare"),
    ("modes", "n_frequencies", "1", "10", "frequencies compared (per nodal diameter on a disk)"),
    ("modes", "mode_shapes", "1", "min(n_frequencies, 6)", "blade: mode shapes written as VTU"),
    ("modes", "nodal_diameters", "1", "0 ... N/2", "disk modes study: the nodal diameters "
                                                   "(nonlinear modes of a disk: required)"),
    ("modes", "speeds", "rpm", "", "disk modes study: a Campbell diagram at these speeds "
                                   "(a list, or `{start, stop, count}`)"),
    ("modes.speeds", "start", "rpm", _REQ, "Campbell speeds: the first"),
    ("modes.speeds", "stop", "rpm", _REQ, "Campbell speeds: the last (> start)"),
    ("modes.speeds", "count", "1", _REQ, "Campbell speeds: how many, evenly spaced (2 ... 400)"),
    ("modes", "engine_orders", "1", "[]", "Campbell diagram: engine-order lines and their "
                                          "crossings (root found)"),
    ("modes", "mode", "1", "0", "nonlinear modes: the family, 0 the lowest small-amplitude "
                                "linear mode (per nodal diameter)"),
    ("modes", "amplitude", "1", "[0.01, 1000]", "nonlinear modes: `[lo, hi]` modal amplitude "
                                                "range in multiples of the slip onset"),
    ("modes", "force_scales", "1", "[1.0]", "nonlinear modes: factors on the excitation for "
                                            "the synthesised forced responses"),
    ("modes", "compare", "", "true", "nonlinear modes: also the full harmonic balance of "
                                     "every case (force scale 1); on a disk: or a list of "
                                     "nodal diameters"),
    ("modes", "reference_dof", "", "largest kinetic share", "nonlinear modes: the DOF whose "
                                                            "velocity vanishes at t = 0"),
    ("quick", "sweep", "", "", "overrides of `[sweep]` (only axes it has)"),
    ("quick", "solver", "", "", "overrides of `[solver]`"),
    ("quick", "scene", "", "", "FE blades: a coarser blade"),
    ("quick", "modes", "", "", "overrides of `[modes]`"),
    ("quick", "lumped", "", "", "accuracy-cost: overrides of `[lumped]` (not `scene`)"),
    ("quick", "blade", "", "", "accuracy-cost: overrides of `[blade]` (not `scene`)"),
    ("quick.scene", "blade", "", "", "`[scene.blade]` fields merged in"),
    ("quick.scene", "craig_bampton_modes", "1", "", "replaces the scene's"),
    ("quick.scene", "mesh", "", "", "replaces the scene's"),
    ("recommendation", "target", "1", "0.001", "error target of the recommended settings"),
    (CASE, "dof", "", _REQ, "the DOF whose peak is measured (`response.y` on a blade)"),
    (CASE, "preload", "N", "the contacts' n0", "preload of every contact"),
    (CASE, "frequency", "", _REQ, "window `{start, stop, unit}`"),
    (CASE, "repeats", "1", "1", "runs per setting, the shortest time counts"),
    (CASE, "time_integration", "", "false", "lumped: check the reference by event-driven time "
                                            "integration"),
    (CASE, "scene", "", _REQ, "written as a study's `[scene]`"),
    (CASE, "reference", "", _REQ, "the most accurate settings"),
    (CASE, "baseline", "", "the reference", "settings each knob is varied around"),
    (CASE, "knobs", "", _REQ, "lists of values per knob"),
    (f"{CASE}.knobs", "harmonics", "1", "", "values of H"),
    (f"{CASE}.knobs", "samples", "1", "", "AFT on N samples instead of exact forces"),
    (f"{CASE}.knobs", "tolerance", "1", "", "Newton tolerances"),
    (f"{CASE}.knobs", "max_step", "1", "", "largest steps"),
    (f"{CASE}.knobs", "craig_bampton_modes", "1", "", "blade case: mode counts"),
    (f"{CASE}.knobs", "mesh", "1", "", "blade case: meshes `[n_chord, n_thick, n_span]`"),
    (f"{CASE}.knobs", "forced_response", "", "", '`"nonlinear_mode"`: the forced response '
                                                 'synthesised from the first nonlinear mode '
                                                 '(baseline: `"harmonic_balance"`)'),
]
# [<case>.baseline] takes the keys of [<case>.reference]
ALIASES[f"{CASE}.baseline"] = f"{CASE}.reference"


def _law_rows() -> list:
    """The tables of the contact laws a lumped study file places (`contact.registry`):
    their signed DOF lists and parameters, as each law declares them."""
    out = []
    for table, law in study_laws().items():
        out.append(("scene", table, "", "[]", f"`{law.name}` elements (array of tables; "
                    f'the effect `"{law.effect}"`)'))
        out.append((f"scene.{table}", "name", "", f"{table}0, {table}1, …", "a name"))
        out += [(f"scene.{table}", k, "1", _REQ, f"{d}: DOFs with signs, as `tangential`")
                for k, d in zip(law.study_rows, law.directions)]
        out += [(f"scene.{table}", k, unit, _REQ if default is None else
                 f"= {default}" if isinstance(default, str) else _fmt(default),
                 getattr(law, "study_help", {}).get(k, f"{law.name} parameter"))
                for k, (unit, default) in law.study_keys.items()]
    return out


def rows() -> list:
    """[(table, key, unit, default, meaning)] in the order of a study file."""
    laws = [f"scene.{t}" for t in study_laws()]
    order = ["study", "scene", "scene.matrices", "scene.matrices.axis", "scene.modal", "scene.contact", *laws,
             "scene.excitation", "scene.disk", "scene.disk_sector", "scene.disk.mistuning",
             "scene.disk.spring",
             "scene.blade", "sweep", "sweep.frequency", "sweep.mistuning_seed", "solver", "output",
             "output.optimum_preload", "output.optimum_interference", "modes", "modes.speeds", "quick", "quick.scene", "recommendation",
             CASE, f"{CASE}.reference", f"{CASE}.knobs"]
    every = (_FIXED + _law_rows() + _blade_rows() + _sweep_rows() + _solver_rows()
             + _settings_rows())
    out = [r for r in every if r[0] == FILE]
    for t in order:
        out += [r for r in every if r[0] == t]
    assert len(out) == len(every), "a table missing from the order"
    return out


def keys_by_table() -> dict:
    """{table: set of keys}."""
    out: dict = {}
    for t, k, *_ in rows():
        out.setdefault(t, set()).add(k)
    return out


def canonical(path: str) -> str:
    """The table whose keys the table at dotted `path` takes (list indices dropped,
    `ALIASES` applied)."""
    path = re.sub(r"\[\d+\]", "", path)
    for _ in range(8):
        hit = max((a for a in ALIASES if path == a or path.startswith(a + ".")),
                  key=len, default=None)
        if hit is None:
            return path
        path = ALIASES[hit] + path[len(hit):]
    return path


def _shown(table: str) -> str:
    if table == FILE:
        return "(file)"
    if table.startswith(CASE):
        rest = table[len(CASE):]
        return f"`[lumped{rest}]`, `[blade{rest}]`"
    return f"`[[{table}]]`" if table in ARRAYS else f"`[{table}]`"


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|")


# the tables that take another's keys, as the markdown says it
_ALIAS_TEXT = ("`[quick.sweep]`, `[quick.solver]`, `[quick.modes]`, `[quick.scene.blade]` take "
               "the keys of `[sweep]`, `[solver]`, `[modes]`, `[scene.blade]`; "
               "`[sweep.frequency]` is also `[output.optimum_preload.frequency]`, "
               "`[output.optimum_interference.frequency]` and a case's "
               "`frequency`; `[lumped.scene]`, `[blade.scene]` are written as `[scene]`; "
               "`[lumped.baseline]`, `[blade.baseline]` take the keys of their `reference`; "
               "`[quick.lumped]`, `[quick.blade]` those of their case but `scene`.")


def markdown() -> str:
    """The table as markdown, with the tables that take another's keys below it."""
    lines = ["| table | key | unit | default | meaning |", "|---|---|---|---|---|"]
    last = None
    for t, k, unit, default, meaning in rows():
        cell = _shown(t) if t != last else ""
        last = t
        lines.append("| " + " | ".join(_cell(c) for c in (cell, f"`{k}`", unit, default,
                                                             meaning)) + " |")
    return "\n".join(lines) + "\n\n" + _ALIAS_TEXT + "\n"
