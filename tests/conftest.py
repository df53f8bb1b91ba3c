"""Test configuration: single-threaded BLAS (small dense systems), headless plots, and
the shipped studies' quick runs shared by the tests that read them.

The environment is set before numpy is imported by any test module (see
pipeline/__init__.py).
"""
import os

import pytest   # imports no numpy

for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")
os.environ.setdefault("MPLBACKEND", "Agg")

pytest_plugins = ["cost_profile"]   # --cost-profile=FILE: where the suite's time goes


def pytest_configure(config):
    """With test processes (pytest-xdist), the compiled kernels are compiled before they
    start, as a parallel run compiles them before its workers start (`compile_ahead`):
    once per machine rather than once in each test process (about 25 s of each on two
    cores)."""
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return
    from pipeline.study.execution.compile_ahead import GROUPS, compile_ahead

    compile_ahead(tuple(GROUPS), workers=2)


def pytest_addoption(parser):
    parser.addoption("--cost-profile", default=None, metavar="FILE",
                     help="write a table of where the tests' time goes to FILE (markdown)")


def shared_root(tmp_path_factory):
    """A folder every test process of this run sees: the parent of the workers' own
    temporary folders under pytest-xdist, the run's own folder without it."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def once_per_run(folder, make, timeout=1800.0):
    """make(folder) once per test run, whichever test process asks first; the others
    wait for its `done` mark (or its `failed` one: they fail with its message).  The
    lock is the folder's creation, which succeeds in one process only."""
    import time
    done, failed = folder / "done", folder / "failed"
    try:
        folder.mkdir(parents=True)
    except FileExistsError:
        t0 = time.monotonic()
        while not (done.exists() or failed.exists()):
            if time.monotonic() - t0 > timeout:
                pytest.fail(f"{folder.name}: another test process did not finish it in "
                            f"{timeout:.0f} s")
            time.sleep(0.2)
        if failed.exists():
            pytest.fail(f"{folder.name} failed in another test process: {failed.read_text()}")
        return
    try:
        make(folder)
    except BaseException as exc:
        failed.write_text(f"{type(exc).__name__}: {exc}"[:2000])
        raise
    done.touch()


@pytest.fixture(scope="session")
def quick_run(tmp_path_factory):
    """(name, figures=False) -> the shipped study `studies/<name>.toml` run once per
    test run in its quick variant, as a user runs it (`pipeline run <file> --quick --out
    <dir>`, with `--no-figures` unless asked): (out dir, dataset path, dataset).  Tests
    that read the same study's quick results share the one run, in whichever test
    process they run (`once_per_run`).  A tuned disk response study never builds the
    N-sector assembly (each engine order is solved on one sector): asserted here on
    every such run."""
    from pipeline.__main__ import main as cli
    import pipeline.model.cyclic as cyclic
    from pipeline.model.scene import Cyclic
    from pipeline.study.datasets.dataset import read_dataset
    from pipeline.study.files.documents import Study, load_study

    from helpers import STUDIES

    runs = {}

    def forbidden(*a, **k):
        raise AssertionError("a tuned disk run must not assemble all sectors")

    def get(name, figures=False):
        if (name, figures) not in runs:
            path = STUDIES / f"{name}.toml"
            out = shared_root(tmp_path_factory) / "quick_runs" / (
                f"{name}-figures" if figures else name)

            def make(out):
                st = load_study(path, quick=True)
                args = ["run", str(path), "--quick", "--out", str(out)] + (
                    ["--no-figures"] * (not figures))
                tuned_disk = (isinstance(st, Study) and isinstance(st.scene.assembly, Cyclic)
                              and st.scene.assembly.mistuning is None)
                with pytest.MonkeyPatch.context() as mp:
                    if tuned_disk:
                        mp.setattr(cyclic, "full_assembly", forbidden)
                    assert cli(args) == 0, name

            once_per_run(out, make)
            nc = out / f"{name}.nc"
            runs[name, figures] = (out, nc, read_dataset(nc))
        return runs[name, figures]
    return get
