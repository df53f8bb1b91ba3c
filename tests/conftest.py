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


@pytest.fixture(scope="session")
def quick_run(tmp_path_factory):
    """(name, figures=False) -> the shipped study `studies/<name>.toml` run once per
    session in its quick variant, as a user runs it (`pipeline run <file> --quick --out
    <dir>`, with `--no-figures` unless asked): (out dir, dataset path, dataset).  Tests
    that read the same study's quick results share the one run.  A tuned disk response
    study never builds the N-sector assembly (each engine order is solved on one
    sector): asserted here on every such run."""
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
            st = load_study(path, quick=True)
            out = tmp_path_factory.mktemp(name)
            args = ["run", str(path), "--quick", "--out", str(out)] + ["--no-figures"] * (not figures)
            tuned_disk = (isinstance(st, Study) and isinstance(st.scene.assembly, Cyclic)
                          and st.scene.assembly.mistuning is None)
            with pytest.MonkeyPatch.context() as mp:
                if tuned_disk:
                    mp.setattr(cyclic, "full_assembly", forbidden)
                assert cli(args) == 0, name
            nc = out / f"{name}.nc"
            runs[name, figures] = (out, nc, read_dataset(nc))
        return runs[name, figures]
    return get
