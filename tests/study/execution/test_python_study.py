"""A response study built in Python meets the study file's rules, read on its objects
(`execution.python_study`): each broken rule is one `UsageError` naming the field,
raised by `run_study` before any case runs and with nothing written (before: a
traceback per case for undeclared effects or H = 0, an empty dataset for an empty
sweep); what only the file's syntax limits (numpy scalars in a sweep, ku = 0, more
than 2000 DOFs) is accepted, and nothing is built to check it."""
from pathlib import Path

import numpy as np
import pytest

import pipeline
from pipeline.contact.friction2d.law import Friction2D
from pipeline.contact.laws import LawElements
from pipeline.errors import UsageError
from pipeline.study.datasets.dataset import read_dataset
from pipeline.study.execution import python_study
from pipeline.study.execution import response_study
from pipeline.study.execution.run import run_study
from pipeline.study.files.documents import load_study

ROOT = Path(__file__).resolve().parents[3]
FILE = "<py: built in Python>"


def example1(effects=("friction",), harmonics=3, preloads=(2.0,), ku=1.0e4, n=1, laws=(),
             axes=None, **solver):
    """The paper's Example 1 built in Python (as studies/python_example.py), with one
    field varied: n > 1 masses in a chain, or x, y, z with `laws` on them (the damper
    and the load on the first DOF)."""
    dofs = ("x", "y", "z") if laws else ("x",) if n == 1 else tuple(f"x{i}" for i in range(n))
    nd = len(dofs)
    K = 3.55e4 * np.eye(nd) - 1.0e3 * (np.eye(nd, k=1) + np.eye(nd, k=-1))   # [N/m]
    structure = pipeline.Lumped(M=np.eye(nd), C=0.3 * np.eye(nd), K=K, dofs=dofs)
    bt = np.zeros(nd)
    bt[0] = 1.0
    damper = pipeline.DofContact(name="damper", bt=bt, bn=np.zeros(nd), ku=ku, kv=0.0, mu=0.5,
                                 n0=None)
    F = np.zeros((nd, 2), complex)
    F[0, 1] = 1.0
    scene = pipeline.Scene(structure=structure, contacts=(damper,), loads=(pipeline.Forcing(F),),
                           effects=effects, model="lumped", laws=laws)
    return pipeline.Study(
        name="py", title="Example 1 in Python", scene=scene,
        sweep=pipeline.Sweep(axes={"preload": preloads} if axes is None else axes,
                             frequency=pipeline.FrequencyRange(150.0, 250.0, "rad/s")),
        solver=pipeline.SolverSettings(harmonics=harmonics, **solver),
        output=pipeline.OutputSettings(dofs=(dofs[0],)))


def plane_contact(kv, n0):
    """One 2D friction element: tangents x, y, normal z (as [[scene.friction_2d]])."""
    return (LawElements(Friction2D(ku=[1.0e4], kv=[kv], mu=[0.5], n0=[n0]),
                        (np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]),
                         np.array([[0, 0, 1.0]]))),)


PLANE = dict(force_evaluation="aft", samples=64, stability="hill")


@pytest.mark.parametrize("change, message", [
    ({"effects": ()}, "scene.effects: declare \"friction\" exactly when the scene has contacts"),
    ({"effects": ("friction", "separation")},
     "scene.effects: \"separation\" is declared but cannot occur (constant normal load and no "
     "negative preload)"),
    ({"preloads": (-1.0, 2.0)},
     "scene.effects: a negative preload (initial gap) means separation: declare \"separation\""),
    ({"effects": ("friction", "stiction")}, "scene.effects[1]: unknown effect 'stiction'"),
    ({"harmonics": 0}, "solver.harmonics: must be an integer >= 1, got 0"),
    ({"harmonics": 2.5}, "solver.harmonics: must be an integer >= 1, got 2.5"),
    ({"preloads": ()}, "sweep.preload: must not be empty"),
    ({"preloads": np.array([])}, "sweep.preload: must not be empty"),
    ({"preloads": (2.0, np.nan)}, "sweep.preload[1]: must be a finite number, got nan"),
    ({"axes": {"preload": (2.0,), "load": (1.0,)}}, "sweep.load: unknown sweep axis"),
    ({"axes": {"preload": (2.0,), "eo": (1,)}}, "sweep.eo: only a disk scene"),
    ({"force_evaluation": "aft", "samples": 4}, "solver.samples: must be >= 2H+1 = 7"),
    ({"effects": ("friction", "friction_2d"), "laws": plane_contact(1.0e5, 5.0), **PLANE},
     "scene.effects: normal DOFs with kv > 0 make the normal load vary: declare "
     "\"normal_load_variation\""),
    ({"effects": ("friction", "friction_2d", "normal_load_variation"),
      "laws": plane_contact(1.0e5, 0.0), **PLANE},
     "scene.effects: scene.friction_2d[0] has a varying normal load"),
    ({"effects": ("friction",), "laws": plane_contact(0.0, 5.0), **PLANE},
     "scene.effects: declare \"friction_2d\" exactly when the scene has [[scene.friction_2d]]"),
    ({"effects": ("friction", "friction_2d"), "laws": plane_contact(0.0, 5.0), **PLANE,
      "force_evaluation": "exact"}, "solver.force_evaluation: the contact law 'friction_2d' is "
                                     "evaluated by aft only")])
def test_each_rule_is_one_error_before_anything_runs(tmp_path, monkeypatch, change, message):
    def never(*a, **k):
        raise AssertionError("a case ran")

    monkeypatch.setattr(response_study, "execute_cases", never)
    with pytest.raises(UsageError) as err:
        run_study(example1(**change), tmp_path / "out", progress=False)
    assert str(err.value).startswith(f"{FILE}: {message}"), str(err.value)
    assert "\n" not in str(err.value)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("change", [
    {"preloads": (np.float64(2.0), np.int64(5))},
    {"preloads": np.array([2.0, 5.0])},
    {"ku": 0.0},
    {"n": 2001},
    {"effects": ("friction", "friction_2d", "normal_load_variation"),
     "laws": plane_contact(1.0e5, 5.0), **PLANE},
    {"effects": ("friction", "friction_2d", "normal_load_variation", "separation"),
     "laws": plane_contact(1.0e5, 5.0), **PLANE}], ids=lambda c: ",".join(c))
def test_what_only_the_file_syntax_limits_is_accepted(change):
    study = example1(**change)
    python_study.check_python_study(study)
    assert len(study.sweep.cases()) >= 1


def test_a_numpy_sweep_runs_as_its_floats(tmp_path):
    """numpy scalars in the sweep run; the dataset's preloads are their values."""
    study = example1(preloads=(np.float64(2.0), np.int64(1000)), stability=False)
    res = run_study(study, tmp_path, workers=1, figures=False, progress=False)
    assert res.ok and res.failures == 0
    ds = read_dataset(res.path)
    assert ds["preload"].values.tolist() == [2.0, 1000.0]
    assert int(ds["converged"].sum()) > 10


def test_the_check_builds_no_model(monkeypatch):
    """An FE disk study (shroud pairs with 2D friction) read from its file and changed in
    Python is checked without meshing, reducing or building a system."""
    from dataclasses import replace

    import pipeline.model.blade_cache as cache_mod
    import pipeline.model.build as build_mod
    import pipeline.model.scene as scene_mod

    def never(*a, **k):
        raise AssertionError("a model was built")

    study = load_study(ROOT / "studies" / "shrouded_disk_2d.toml", quick=True)
    for mod, name in ((scene_mod, "sector_names"), (cache_mod, "reduced_model"),
                      (build_mod, "reduced_model"), (build_mod, "build_system"),
                      (build_mod, "unassembled"), (build_mod, "sector")):
        monkeypatch.setattr(mod, name, never)
    python_study.check_python_study(replace(study, text=""))
    gap = replace(study, text="", sweep=replace(study.sweep, axes={"preload": (-0.3, 3.0)}),
                  scene=replace(study.scene, effects=tuple(
                      e for e in study.scene.effects if e != "separation")))
    with pytest.raises(UsageError, match=r"^<shrouded_disk_2d: built in Python>: scene\.effects: "
                                         r"a negative preload \(initial gap\)"):
        python_study.check_python_study(gap)
