"""Reduced-order study pipeline for shrouded bladed disks with dry friction.

Data flows one way: FE model -> reduction -> assembly with contact -> HBM ->
continuation -> study / dataset.  See README.md.

The names a script needs are here, imported when first used (`import pipeline`
stays cheap: no xarray, no matplotlib until a dataset or figure is made):

    load_study(path, quick=False) -> study      run_study(study, out_dir) -> StudyResult
    Scene, Lumped, DofContact, Forcing, Single, Cyclic   a scene written in Python
    build_system(scene, case) -> System          frequency_response(system, H, w0, w1, ...)
    Study, Sweep, FrequencyRange, SolverSettings, OutputSettings   a response study
    to_dataset(study, curves) -> xarray.Dataset  write_netcdf(ds, path), read_dataset(path)
    mode_problem(system, H, mode=0) -> ModeProblem   continue_mode(problem, s0, s1) -> Backbone
    synthesise(backbone, M, C, F1) -> Synthesis  nonlinear modes and forced responses from them

`studies/python_example.py` writes the paper's Example 1 this way.
"""
import importlib as _importlib
import os as _os

# The dense systems here are small (contact DOFs x harmonics): BLAS threads cost
# more than they give (measured 0.14 ms vs 1.1 ms per 115x115 solve on 2 cores),
# and parallel studies run one process per core.  Set the variables yourself
# before importing to override.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

# The compiled (Numba) kernels, cached once per machine and kernel version: under the
# user's cache folder ($XDG_CACHE_HOME or ~/.cache)/shroud-pipeline/numba-<hash of
# these files>, so that every process, pool worker and test process of an installation
# finds them, and an edit of any kernel file recompiles all of them (Numba checks a
# cached function against its own file only: a caller in another file would keep the
# old code).  A NUMBA_CACHE_DIR of your own wins; an unwritable folder leaves Numba's
# default (next to the sources).
KERNEL_MODULES = ("fourier/harmonics.py", "fourier/trigkernel.py", "contact/exact_kernel.py",
                  "contact/exact_integrals.py", "contact/friction2d/centre.py",
                  "contact/friction2d/kernel.py", "solve/continuation/branch.py")


def kernel_cache_dir() -> str:
    """The folder the compiled kernels are cached in (see KERNEL_MODULES)."""
    import hashlib
    here = _os.path.dirname(_os.path.abspath(__file__))
    digest = hashlib.sha256()
    for name in KERNEL_MODULES:
        with open(_os.path.join(here, name), "rb") as f:
            digest.update(f.read())
    base = _os.environ.get("XDG_CACHE_HOME") or _os.path.join(_os.path.expanduser("~"), ".cache")
    return _os.path.join(base, "shroud-pipeline", f"numba-{digest.hexdigest()[:16]}")


if "NUMBA_CACHE_DIR" not in _os.environ:
    try:
        _os.makedirs(kernel_cache_dir(), exist_ok=True)
        _os.environ["NUMBA_CACHE_DIR"] = kernel_cache_dir()
    except OSError:
        pass

__version__ = "0.1.0"

# public name -> the module that defines it (imported on first use)
_PUBLIC = {
    "load_study": "pipeline.study.files.documents",
    "parse_study": "pipeline.study.files.documents",
    "run_study": "pipeline.study.execution.run",
    "Scene": "pipeline.model.scene",
    "Lumped": "pipeline.model.scene",
    "Single": "pipeline.model.scene",
    "Cyclic": "pipeline.model.scene",
    "build_system": "pipeline.model.build",
    "DofContact": "pipeline.model.contacts",
    "Forcing": "pipeline.model.loads",
    "frequency_response": "pipeline.solve.response.response",
    "Study": "pipeline.study.files.study_types",
    "Sweep": "pipeline.study.files.study_types",
    "FrequencyRange": "pipeline.study.files.study_types",
    "SolverSettings": "pipeline.study.files.study_types",
    "OutputSettings": "pipeline.study.files.study_types",
    "to_dataset": "pipeline.study.datasets.response_dataset",
    "write_netcdf": "pipeline.study.datasets.dataset",
    "read_dataset": "pipeline.study.datasets.dataset",
    "UsageError": "pipeline.errors",
    "mode_problem": "pipeline.solve.nonlinear_modes.epmc",
    "continue_mode": "pipeline.solve.nonlinear_modes.backbone",
    "synthesise": "pipeline.solve.nonlinear_modes.synthesis",
}
__all__ = ["__version__", *_PUBLIC]


def __getattr__(name):
    if name in _PUBLIC:
        value = getattr(_importlib.import_module(_PUBLIC[name]), name)
        globals()[name] = value   # found directly from now on
        return value
    raise AttributeError(f"module 'pipeline' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_PUBLIC))
