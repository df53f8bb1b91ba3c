"""Input guards of study files: what `[solver] stability = true` selects per scene kind,
the plausibility of FE disk dimensions, the size of the model `--quick` builds."""
import copy
from pathlib import Path

import numpy as np
import pytest

from pipeline.study.files.documents import load_study, study_from_document
from pipeline.study.execution.run import run_study

from helpers import study_doc

STUDIES = Path(__file__).resolve().parents[3] / "studies"


# ---------------------------------------------------------------------------
# [solver] stability = true
# ---------------------------------------------------------------------------

def _small_example1(stability):
    """Example 1 at n0 = 2 N (stick-slip), H = 3, through its resonance."""
    doc = study_doc("paper_example1.toml")
    doc["sweep"] = {"preload": [2.0],
                    "frequency": {"start": 185.0, "stop": 200.0, "unit": "rad/s"}}
    doc["solver"] = {"harmonics": 3, "tolerance": 1e-9}
    if stability is not None:
        doc["solver"]["stability"] = stability
    doc["output"].pop("optimum_preload")
    doc.pop("quick")
    return study_from_document(doc, file="ex1.toml", name="ex1")


def test_stability_true_is_the_default_of_a_lumped_scene(tmp_path):
    """`true` and the absent key give the same method at every point: the orbit
    monodromy checked by Floquet, not Hill's method."""
    absent, true = _small_example1(None), _small_example1(True)
    assert absent.solver.stability == true.solver.stability == "monodromy+check"
    methods = []
    for k, st in enumerate((absent, true)):
        res = run_study(st, tmp_path / str(k), workers=1, figures=False, progress=False,
                        checkpoints=False)
        m = res.dataset["stability_method"].values
        methods.append(m[m >= 0])
    assert methods[0].size > 10
    np.testing.assert_array_equal(methods[0], methods[1])
    assert set(np.unique(methods[1])) <= {1, 2}   # Floquet or monodromy: never Hill (0)


def test_stability_true_per_scene_kind():
    """lumped -> monodromy+check; lumped disk -> hill (its default); FE blade and FE
    disk -> stretch (the fold rule when absent: "stretch" costs minutes a case)."""
    disk = study_doc("disk_cyclic.toml")
    assert disk["solver"]["stability"] is True
    assert study_from_document(disk, file="d.toml").solver.stability == "hill"
    del disk["solver"]["stability"]
    assert study_from_document(disk, file="d.toml").solver.stability == "hill"
    for name, absent in (("blade_shroud_contact.toml", "folds"), ("shrouded_disk.toml", "folds")):
        doc = study_doc(name)
        assert study_from_document(copy.deepcopy(doc), file="b.toml",
                                   quick=True).solver.stability == absent
        doc["solver"]["stability"] = True
        st = study_from_document(doc, file="b.toml", quick=True)
        assert st.solver.stability == "stretch"
    assert load_study(STUDIES / "paper_example1.toml").solver.stability == "monodromy+check"


# ---------------------------------------------------------------------------
# Dataset attributes that depend on the scene
# ---------------------------------------------------------------------------

def _curve(system, H, omega):
    """A converged-looking ResponseCurve: the first harmonic of M q'' + C q' + K q = F
    (contacts ignored); the attributes under test do not depend on it."""
    from pipeline.solve.response.response import ResponseCurve

    P, n = omega.size, system.n_dof
    Q = np.zeros((P, n, 2 * H + 1))
    for i, w in enumerate(omega):
        X = np.linalg.solve(system.K - w ** 2 * system.M + 1j * w * system.C,
                            system.forcing[:, 1])
        Q[i, :, 1], Q[i, :, 2] = X.real, -X.imag
    return ResponseCurve(parameter=omega, omega=omega, Q=Q, converged=np.ones(P, bool),
                         residual=np.full(P, 1e-12), stable=np.ones(P, bool),
                         amplitude=np.hypot(Q[:, :, 1], Q[:, :, 2]), fold_parameter=np.zeros(0),
                         newton_iterations=np.ones(P, int), nfev=P, wall_time=0.01 * P,
                         success=True, status=0, message="ok", H=H, tolerance=1e-9)


def _dataset(study):
    from pipeline.study.datasets.response_dataset import to_dataset
    fr = study.sweep.frequency
    om = np.linspace(fr.omega_start, fr.omega_stop, 20)
    return to_dataset(study, [_curve(study.system(case), study.solver.harmonics, om)
                              for _, case in study.sweep.cases()])


def test_disk_natural_frequencies_say_nd_equals_eo_and_are():
    """disk_cyclic (EO 0 and 12 of 24 sectors): the stuck frequencies are the sector's at
    psi = 2 pi EO / 24, K(psi) = K + 2 ku (1 - cos psi) on the shroud DOF x2."""
    st = load_study(STUDIES / "disk_cyclic.toml", quick=True)
    ds = _dataset(st)
    M, K = np.diag([0.1, 0.05]), np.array([[1.065e6, -3.55e5], [-3.55e5, 5.325e5]])
    for eo in (0, 12):
        Kp = K + np.diag([0.0, 2 * 7.1e5 * (1 - np.cos(2 * np.pi * eo / 24))])
        w = np.sqrt(np.linalg.eigvals(np.linalg.solve(M, Kp)).real)
        np.testing.assert_allclose(ds["natural_frequency_stuck"].sel(eo=eo).values[:2],
                                   np.sort(w) / (2 * np.pi), rtol=1e-9)
    for k in ("natural_frequency_stuck", "natural_frequency_free"):
        assert "nodal diameter ND = EO" in ds[k].attrs["comment"]


def test_preload_long_name_per_scene_kind():
    """lumped: n0 of every contact; FE faces: the face total, as the elements carry it."""
    from pipeline.study.datasets.meanings import sweep_long_name

    ex1 = load_study(STUDIES / "paper_example1.toml", quick=True)
    assert sweep_long_name("preload", ex1.scene) == "normal preload n0 of every contact"
    blade = load_study(STUDIES / "blade_shroud_contact.toml", quick=True)     # per node
    assert "total normal preload n0 of every contact face, shared equally" in \
        sweep_long_name("preload", blade.scene)
    el = blade.system({"preload": 30.0}).contact   # 2 faces of 27 nodes: 30 N / 27 each
    np.testing.assert_allclose(el.n0, 30.0 / 27, rtol=1e-12)
    disk = load_study(STUDIES / "shrouded_disk.toml", quick=True)              # per face
    ds = _dataset(disk)
    assert ds["preload"].attrs["long_name"].startswith(
        "total normal preload n0 of every contact face, shared by its nodes in proportion "
        "to their areas")
    el = disk.system({"preload": 3.0}).contact     # one face of pairs: the total is 3 N
    assert el.n0.min() > 0 and el.n0.sum() == pytest.approx(3.0, rel=1e-12)
    assert "ND = EO" in ds["natural_frequency_stuck"].attrs["comment"]


# ---------------------------------------------------------------------------
# Dimensions of FE blades: counted before meshing, implausible ones refused
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("kw, disk", [
    (dict(n_chord=2, n_thick=1, n_span=4), None),
    (dict(n_chord=4, n_thick=1, n_span=8), (0.12, 36)),
    (dict(n_chord=3, n_thick=2, n_span=5, shroud_chord=0.04), None),
    (dict(n_chord=3, n_thick=1, n_span=5, shroud_chord=0.02), None),
    (dict(n_chord=5, n_thick=1, n_span=7, shroud=False), None),
    (dict(n_chord=2, n_thick=1, n_span=3, shroud_height=0.02), (0.3, 12)),
    (dict(kind="beam", n_span=10), (0.08, 24)),
])
def test_mesh_size_from_parameters_is_the_built_mesh(kw, disk):
    from pipeline.structure.blades import build_blade
    from pipeline.structure.fe_model import BladeParams, DiskPlacement, boundary_dofs
    from pipeline.structure.mesh_size import mesh_size
    from pipeline.structure.solid import solid_mesh

    p, d = BladeParams(**kw), DiskPlacement(*disk) if disk else None
    size, blade = mesh_size(p, d), build_blade(p, d)
    assert size.free_dofs == blade.n_dof
    assert size.boundary_dofs == boundary_dofs(blade)[0].size
    if p.kind == "solid":
        mesh, _ = solid_mesh(p, d)
        assert size.elements == mesh.t.shape[1]   # (the nodes: through free_dofs)


def test_hub_radius_in_millimetres_is_refused_before_meshing(monkeypatch):
    """hub_radius = 120 (for 0.12 m): one error line naming the field; no mesh is built."""
    import pipeline.structure.solid as solid
    from pipeline.errors import UsageError

    def no_mesh(*a, **k):
        raise AssertionError("meshed")
    monkeypatch.setattr(solid, "solid_mesh", no_mesh)
    bad = Path(__file__).parents[2] / "bad_studies" / "shrouded_disk_hub_radius_mm.toml"
    for quick in (False, True):
        with pytest.raises(UsageError, match=r"scene\.disk\.hub_radius: 120 m is 1\.2e\+03 "
                                             r"times the blade length 0\.1 m"):
            load_study(bad, quick=quick)


# ---------------------------------------------------------------------------
# --quick builds and reduces the quick model only
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["shrouded_disk.toml", "blade_shroud_contact.toml",
                                  "shrouded_disk_modes.toml", "blade_modes.toml"])
def test_quick_builds_only_the_quick_model(name, monkeypatch):
    """Loading (and checking) --quick meshes and reduces the [quick.scene] blade, never the
    full one: every blade built or reduced has the quick mesh counts."""
    import pipeline.structure.blades as blades
    import pipeline.structure.reduction as reduction
    from pipeline.model import blade_cache

    blade_cache.timed_blade_model.cache_clear()
    blade_cache.reduced_model.cache_clear()
    blade_cache.blade_at_speed.cache_clear()
    built, reduced = [], []
    build, reduce_ = blades.build_blade, reduction.reduce_blade

    def counting_build(p, disk=None, **kw):
        built.append((p.n_chord, p.n_thick, p.n_span))
        return build(p, disk, **kw)

    def counting_reduce(blade, *a, **k):
        reduced.append((blade.params.n_chord, blade.params.n_thick, blade.params.n_span))
        return reduce_(blade, *a, **k)
    monkeypatch.setattr(blades, "build_blade", counting_build)
    monkeypatch.setattr(reduction, "reduce_blade", counting_reduce)
    quick_mesh = tuple(study_doc(name)["quick"]["scene"]["blade"][k]
                       for k in ("n_chord", "n_thick", "n_span"))
    st = load_study(STUDIES / name, quick=True)
    if getattr(st, "kind", "response") == "response":
        st.system(st.sweep.cases()[0][1])       # what a case builds
    assert built and set(built) == {quick_mesh}, built
    assert set(reduced) <= {quick_mesh}, reduced


# ---------------------------------------------------------------------------
# check's cost estimate against the measured run
# ---------------------------------------------------------------------------

def _within(m):
    """Fail unless the run's work lies within a factor ACCEPT = 3 of the estimate's
    geometric middle as work (`Measured.cpu_ratio`: its CPU time against the middle
    over the slowdown measured when estimating; all finite and positive).  The wall
    times are not compared: the other test processes start and stop between the
    estimate and the end of the run (a 0.3 s estimate measured 1.38 s wall so)."""
    from pipeline.bench.estimate import ACCEPT
    assert ACCEPT == 3.0 and m.cpu > 0.0 and m.slowdown >= 1.0
    assert 0.0 < m.estimate.lo <= m.estimate.hi < np.inf
    ratio = m.cpu_ratio
    if not 1 / ACCEPT <= ratio <= ACCEPT:
        pytest.fail(f"{m.name}{' --quick' if m.quick else ''}: estimate {m.estimate.lo:.3g}-"
                    f"{m.estimate.hi:.3g} s (middle {m.estimate.mid:.3g} s at slowdown "
                    f"{m.slowdown:.2f}), measured {m.cpu:.3g} s CPU ({m.wall:.3g} s wall): "
                    f"ratio {ratio:.2f}")


@pytest.mark.parametrize("cpu, slowdown, passes", [
    (1.0, 1.0, True), (2.9, 1.0, True), (0.35, 1.0, True), (3.1, 1.0, False), (0.3, 1.0, False),
    (0.5, 2.0, True), (1.45, 2.0, True), (0.16, 2.0, False), (1.6, 2.0, False)])
def test_the_estimate_check_fails_outside_a_factor_3(cpu, slowdown, passes):
    """The check above on constructed measurements (estimate 1/3-3 s, middle 1 s; made
    at slowdown 2 it is 0.5 s of work)."""
    from pipeline.bench.estimate import Measured
    from pipeline.study.execution.kind_costs import RangeEstimate

    m = Measured("constructed", False, 1, RangeEstimate(1 / 3, 3.0, ""), 10.0, cpu, slowdown)
    if passes:
        _within(m)
    else:
        with pytest.raises(pytest.fail.Exception, match="ratio"):
            _within(m)


@pytest.mark.slow   # a timing: with the other test process on the sibling vCPU a 1 s run's
#                    CPU time swings 1.4-2.3x (disk_laxalde, the same code), past the factor 3
@pytest.mark.parametrize("name", ["paper_example2", "disk_mistuned", "disk_laxalde"])
def test_cost_estimate_within_3x_of_the_quick_run(name):
    """`check --quick`'s estimate (model timed now) and the serial --quick run: the
    run's work within a factor 3 of the estimate's geometric middle (`_within`); a
    benchmark, as `python -m pipeline bench estimate --quick` prints it."""
    from pipeline.bench.estimate import measure

    _within(measure(STUDIES / f"{name}.toml", quick=True))


@pytest.mark.slow   # every shipped study in full: about 45 min serially
@pytest.mark.parametrize("name", sorted(p.stem for p in STUDIES.glob("*.toml")))
def test_cost_estimate_within_3x_of_the_full_run(name):
    from pipeline.bench.estimate import measure

    _within(measure(STUDIES / f"{name}.toml"))


def test_check_reports_the_model_the_run_builds():
    """`check --quick` on the FE disk: the quick mesh's size, counted from its parameters
    (2 x 1 x 4 elements: 630 DOFs, 96 kept on the faces and points, + 20 modes)."""
    import io

    from pipeline.study.files.check import check

    out = io.StringIO()
    assert check(STUDIES / "shrouded_disk.toml", quick=True, workers=1, out=out) == 0
    text = out.getvalue()
    assert ("model: solid blade, 14 elements, 630 DOFs (from the mesh parameters) -> "
            "Craig-Bampton 96 boundary DOFs + 20 modes = 116 DOFs per sector") in text, text
    # 2 faces x 15 nodes x 3 components = 90 contact DOFs, x (2H + 1) = 3 at H = 1
    assert "of 270 unknowns, timed now on this model" in text, text


def test_check_counts_the_resonances_of_a_range_traced_downwards():
    """Example 1 traced 250 -> 150 rad/s has the same two natural frequencies in its
    range (open 188.4, stuck 213.3 rad/s) as 150 -> 250, hence the same estimate."""
    from dataclasses import replace

    from pipeline.study.execution.cost import modes_in_range
    from pipeline.study.files.documents import load_study

    study = load_study(STUDIES / "paper_example1.toml")
    fr = study.sweep.frequency
    system = study.system(study.sweep.cases()[0][1])
    down = replace(fr, start=fr.stop, stop=fr.start)
    assert modes_in_range(system, fr) == modes_in_range(system, down) == 2


def test_check_warns_of_a_range_without_natural_frequency(tmp_path):
    """Example 1's range typed in Hz (150-250 Hz, its resonances lie at 30-34 Hz): one
    warning line that no natural frequency lies in it; the rad/s range has none."""
    from pipeline.study.execution.response_study import describe
    from pipeline.study.files.documents import load_study, parse_study

    text = (STUDIES / "paper_example1.toml").read_text()
    assert 'unit = "rad/s"' in text
    hz = parse_study(text.replace('unit = "rad/s"', 'unit = "Hz"'), file="hz.toml", name="hz")
    warns = [ln for ln in describe(hz) if ln.startswith("warning:")]
    assert warns == ["warning: no natural frequency (contacts open or stuck) lies in 150-250 "
                     "Hz: the curves may hold no resonant peak (is the range's unit the one "
                     "meant?)"]
    assert not [ln for ln in describe(load_study(STUDIES / "paper_example1.toml"))
                if ln.startswith("warning:")]
