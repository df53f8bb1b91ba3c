"""The public Python API (`import pipeline`): cheap to import, and a study written in
Python (`studies/python_example.py`) gives the dataset the command line writes for the
same study written as a file."""
from __future__ import annotations

import runpy
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pipeline
from helpers import example1_study

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "studies" / "python_example.py"

# the scene, sweep and settings of studies/python_example.py as a study file
EXAMPLE_TOML = example1_study(
    "Example 1 in Python: single-DOF oscillator with a friction damper to ground",
    study='reference = "Sec. 6.1, Eq. 12-13, Fig. 2"', preload="[0.0, 2.0, 1000.0]",
    output='dofs = ["x"]\nyscale = "log"')
# attributes that say where a dataset came from, not what it holds
PROVENANCE = ("study", "created")
MEASURED = ("wall_time",)   # [s] each case's continuation took on this machine


def test_import_is_cheap_and_names_resolve():
    code = ("import sys, pipeline; heavy = [m for m in ('xarray', 'matplotlib', 'scipy', "
            "'pipeline.study.datasets.dataset') if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout.strip()
    assert out == "[]"
    for name in pipeline.__all__:
        assert getattr(pipeline, name) is not None, name
    assert pipeline.load_study.__module__ == "pipeline.study.files.documents"
    assert pipeline.Scene.__module__ == "pipeline.model.scene"
    with pytest.raises(AttributeError):
        pipeline.no_such_name  # noqa: B018


def assert_same_attrs(a: dict, b: dict, skip=()):
    assert sorted(a) == sorted(b)
    for k in a:
        if k not in skip:
            assert np.array_equal(np.asarray(a[k]), np.asarray(b[k])), k


def assert_same_dataset(a, b, encodings=True):
    """Same variables, coordinates, attributes (and encodings, both read from files);
    values identical; provenance attributes and measured times aside."""
    assert sorted(a.variables) == sorted(b.variables)
    assert sorted(a.coords) == sorted(b.coords)
    assert_same_attrs(a.attrs, b.attrs, PROVENANCE)
    for name in a.variables:
        x, y = a[name], b[name]
        assert x.dims == y.dims, name
        assert_same_attrs(x.attrs, y.attrs)
        if encodings:
            assert x.encoding.get("dtype") == y.encoding.get("dtype"), name
        if name in MEASURED:
            continue
        np.testing.assert_array_equal(x.values, y.values, err_msg=name)   # NaN == NaN here


def test_python_example_gives_the_dataset_of_the_command_line(tmp_path, monkeypatch):
    from pipeline.__main__ import main as cli
    from pipeline.study.datasets.dataset import read_dataset

    pytest.importorskip("matplotlib")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setattr(sys, "argv", [str(EXAMPLE), str(tmp_path / "python")])
    ns = runpy.run_path(str(EXAMPLE), run_name="__main__")
    assert (tmp_path / "python" / "python_example.png").is_file()

    study = tmp_path / "python_example.toml"
    study.write_text(EXAMPLE_TOML)
    assert cli(["run", str(study), "--out", str(tmp_path / "cli"), "--workers", "1",
                "--no-figures"]) == 0
    with read_dataset(tmp_path / "cli" / "python_example.nc") as from_cli, \
            read_dataset(tmp_path / "python" / "python_example.nc") as from_python:
        assert_same_dataset(from_cli, from_python)
        assert int(from_python["converged"].sum()) > 100
        # the dataset in memory is the one written
        assert_same_dataset(from_python, ns["ds"], encodings=False)
    # the Python study is the validated file's, field by field
    loaded = pipeline.load_study(study)
    for part in ("sweep", "solver", "output"):
        assert getattr(loaded, part) == getattr(ns["study"], part), part


def test_readme_shows_the_example_that_runs():
    """The README's Python block is the code of studies/python_example.py (its docstring
    aside), so the example the README shows is the one this module runs."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = readme.split("<!-- python-example -->", 1)[1].split("```python\n", 1)[1]
    block = block.split("```", 1)[0]
    code = EXAMPLE.read_text(encoding="utf-8").split('"""', 2)[2].lstrip("\n")
    assert block.strip() == code.strip()


def test_a_study_changed_in_python_runs_without_the_text_of_another(tmp_path):
    """A loaded study with a contact's mu replaced in Python: its text describes the
    study as loaded, so the dataset carries no text (not the file's mu = 0.5), its
    checkpoints are another study's folder, and its peak is the new mu's (the same as
    the file edited to mu = 0.25)."""
    from dataclasses import replace
    from pipeline.study.execution.checkpoint import checkpoint_dir
    from pipeline.study.files.documents import text_describes

    text = example1_study("changed in Python", preload="[2.0]",
                          solver="harmonics = 1\nstability = false",
                          output='dofs = ["x"]\nfigures = []')
    (tmp_path / "e1.toml").write_text(text)
    (tmp_path / "e2.toml").write_text(text.replace("mu = 0.5", "mu = 0.25"))
    loaded, edited = (pipeline.load_study(tmp_path / f) for f in ("e1.toml", "e2.toml"))
    assert text_describes(loaded) and text_describes(edited)
    c = loaded.scene.contacts[0]
    changed = replace(loaded, scene=replace(loaded.scene, contacts=(replace(c, mu=0.25),)))
    assert not text_describes(changed)
    # run_study drops the stale text: the checkpoint key then hashes every field, also
    # a change numpy's repr summarises away (one entry of a 40 x 40 matrix)
    big = replace(changed, text="")
    K = np.eye(40)
    keys = []
    for k in (1.0, 2.0):
        K[20, 20] = k
        s = replace(big, scene=replace(big.scene, structure=replace(big.scene.structure,
                                                                    K=K.copy())))
        keys.append(checkpoint_dir(s, tmp_path, None))
    assert repr(np.eye(40)) == repr(K) and keys[0] != keys[1]
    a = pipeline.run_study(changed, tmp_path / "a", figures=False).dataset
    b = pipeline.run_study(edited, tmp_path / "b", figures=False).dataset
    assert a.attrs["study"] == "" and b.attrs["study"] == (tmp_path / "e2.toml").read_text()
    assert float(a["peak_amplitude"].max()) == float(b["peak_amplitude"].max())
