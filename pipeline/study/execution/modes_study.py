"""Modes studies of an FE blade (`[study] kind = "modes"`, or a `[modes]` table): full
(shift-invert Lanczos) vs Craig-Bampton eigenfrequencies against the number of
fixed-interface modes, with timings per stage, MAC and mode shapes (`modal_study`,
`run_modes_study`).  The cost and accuracy of the reduction, shown before any
response is computed.  The document is read by `blade_scene.modes_from_mapping`;
`KIND` is the registry entry (`kinds`)."""
from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np

from ...model.scene import Scene
from ...model.blade_cache import blade_model
from ...structure.fe_model import boundary_dofs
from ...structure.mesh_io import write_fields
from ...structure.reduction import eigenmodes, reduce, reduced_modes
from ..figures.plots import modal_convergence_figure
from ..scenes.blade_scene import is_blade_document, modes_from_mapping
from .kind_costs import estimate_lines, modes_estimate
from ..files.study_types import ModesStudy, StudyKind, StudyResult

log = logging.getLogger(__name__)


def normalise(X):
    """Each column scaled to max |entry| = 1, the largest entry positive."""
    X = np.array(X, dtype=float)
    j = np.argmax(np.abs(X), axis=0)
    return X / X[j, np.arange(X.shape[1])]


def modal_study(scene: Scene, mode_counts, n_freqs: int, n_shapes: int = 0) -> dict:
    """Full (shift-invert Lanczos) vs Craig-Bampton eigenfrequencies [Hz] per mode count.

    Returns plain arrays: full_hz (n_freqs,), reduced_hz (m, n_freqs) (NaN where the
    reduced model has fewer coordinates), rel_error = reduced/full - 1, times [s]
    (full eigen solve; total and per stage of each reduction), reduced sizes, MAC of
    the scene's mode count, and the first n_shapes mode shapes (full, reduced).
    """
    blade = blade_model(scene.structure)
    b, labels = boundary_dofs(blade)
    t0 = time.perf_counter()
    w2, X = eigenmodes(blade.K, blade.M, n_freqs)
    t_full = time.perf_counter() - t0
    full = np.sqrt(np.maximum(w2, 0)) / (2 * np.pi)
    kw = ({"rayleigh": scene.structure.rayleigh} if scene.structure.rayleigh is not None
          else {"damping_ratios": scene.structure.params.damping_ratios})
    stages = ("partition", "factorize", "normal_modes", "constraint_modes", "projection", "damping")
    m = len(mode_counts)
    red_hz = np.full((m, n_freqs), np.nan)
    t_red, t_stage, sizes = np.zeros(m), np.zeros((m, len(stages))), np.zeros(m, int)
    shapes_red, mac = None, np.full(n_freqs, np.nan)
    for i, k in enumerate(mode_counts):
        t0 = time.perf_counter()
        red = reduce(blade.K, blade.M, b, int(k), labels=labels, **kw)
        t_red[i] = time.perf_counter() - t0
        t_stage[i] = [red.info["times"].get(s, 0.0) for s in stages]
        sizes[i] = red.M.shape[0]
        nk = min(n_freqs, red.frequencies.size)
        red_hz[i, :nk] = red.frequencies[:nk]
        if k == scene.reduction.modes and nk == n_freqs:
            _, U = reduced_modes(red, n_freqs)
            MX = blade.M @ X
            num = (MX.T @ U) ** 2
            mac = np.diag(num) / (np.einsum("ij,ij->j", X, MX) * np.einsum("ij,ij->j", U, blade.M @ U))
            sign = np.sign(np.einsum("ij,ij->j", U, MX))
            shapes_red = normalise(U[:, :n_shapes] * np.where(sign == 0, 1, sign)[:n_shapes])
    shapes_full = normalise(X[:, :n_shapes])
    if shapes_red is not None:  # same sign convention as the full shapes
        s = np.sign(np.einsum("ij,ij->j", shapes_red, shapes_full))
        shapes_red = shapes_red * np.where(s == 0, 1, s)
    return {"mode_counts": np.asarray(mode_counts, int), "full_hz": full, "reduced_hz": red_hz,
            "rel_error": red_hz / full - 1, "time_full_s": t_full, "time_reduce_s": t_red,
            "stage_names": stages, "time_stage_s": t_stage, "reduced_size": sizes,
            "mac": mac, "n_dof": int(blade.n_dof), "n_boundary": int(b.size),
            "shapes_full": shapes_full, "shapes_reduced": shapes_red}


def run_modes_study(study: ModesStudy, out_dir="results", *, figures: bool = True):
    """Run a modes study: `out_dir/<name>.nc`, then `out_dir/<name>/mode_shapes.vtu`
    and `out_dir/<name>/modal_convergence.png`."""
    # deferred: xarray, matplotlib and meshio are slow to import; reading a study needs none
    from ..datasets.dataset import write_netcdf
    from ..datasets.modes_dataset import modes_to_dataset

    t0 = time.perf_counter()
    sc = study.scene
    log.info("%s: %s, mode counts %s, %d frequencies%s", study.name, sc.model,
             list(study.mode_counts), study.n_frequencies, " (quick)" if study.quick else "")
    res = modal_study(sc, study.mode_counts, study.n_frequencies, study.n_shapes)
    out_dir = Path(out_dir)
    fig_dir = out_dir / study.name
    shapes_file = f"{study.name}/mode_shapes.vtu" if study.n_shapes else ""
    ds = modes_to_dataset(study, res, shapes_file)
    path = write_netcdf(ds, out_dir / f"{study.name}.nc")
    log.info("wrote %s", path)
    written = []
    if study.n_shapes:
        fieldsd = {f"full_mode_{j + 1}": res["shapes_full"][:, j] for j in range(study.n_shapes)}
        if res["shapes_reduced"] is not None:
            fieldsd.update({f"reduced_mode_{j + 1}": res["shapes_reduced"][:, j]
                            for j in range(study.n_shapes)})
        written.append(write_fields(blade_model(sc.structure), fig_dir / "mode_shapes.vtu", fieldsd))
    if figures:
        written.append(modal_convergence_figure(fig_dir / "modal_convergence.png", res, study.title))
    for p in written:
        log.info("wrote %s", p)
    i = list(res["mode_counts"]).index(sc.reduction.modes)
    log.info("%s: f1 = %.6g Hz; max error at %d modes %.3g %%; done in %.1f s", study.name,
             res["full_hz"][0], sc.reduction.modes, 100 * np.nanmax(res["rel_error"][i]),
             time.perf_counter() - t0)
    return StudyResult(study=study, dataset=ds, path=path, figures=written, failures=0,
                       wall_time=time.perf_counter() - t0)


def describe(study: ModesStudy, workers: int = 1) -> list:
    """The lines `check` prints for a blade modes study, its cost estimate included."""
    return [f"scene: {study.scene.model}, Craig-Bampton mode counts "
            f"{', '.join(map(str, study.mode_counts))}; {study.n_frequencies} "
            "frequencies compared with the full model"] + estimate_lines(modes_estimate(study))


def is_modes_default(data) -> bool:
    """A blade document with a [modes] table is a modes study unless it says otherwise."""
    return "modes" in data


KIND = StudyKind(name="modes", word="modes", fits=is_blade_document, by_default=is_modes_default,
                 parse=modes_from_mapping, describe=describe,
                 estimate=lambda study, workers=1: modes_estimate(study),
                 run=lambda study, out_dir, figures=True, **_: run_modes_study(
                     study, out_dir, figures=figures),
                 cases=lambda study: 1)
