"""Blade studies: the Craig-Bampton modal study and the shroud-contact study in quick
mode; the reduced contact model against the UNREDUCED FE model at stick, stick-slip
and separation; blade schema errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.solve.harmonic_balance import hbm
from pipeline.__main__ import main as cli
from pipeline.study.scenes.blade_scene import ModesStudy
from pipeline.contact import forces
from pipeline.solve.continuation.newton import newton
from pipeline.study.datasets.dataset import read_dataset
from pipeline.study.datasets.conformance import problems
from pipeline.errors import UsageError
from pipeline.structure.blades import build_blade
from pipeline.structure.fe_model import BladeParams
from pipeline.structure.mesh_io import write_mesh
from pipeline.fourier.harmonics import amplitude_half_peak_to_peak, evaluate
from pipeline.solve.response.response import initial_guess
from pipeline.study.files.documents import load_study, parse_study
from pipeline.model.blade_cache import blade_model, reduced_model
from pipeline.model.build import build_system, full_dof

ROOT = Path(__file__).resolve().parents[3]
MODES = ROOT / "studies" / "blade_modes.toml"
CONTACT = ROOT / "studies" / "blade_shroud_contact.toml"
QUICK_BLADE = BladeParams(n_chord=4, n_thick=1, n_span=6)


# ---------------------------------------------------------------------------
# Modal convergence of the Craig-Bampton reduction (studies/blade_modes.toml)
# ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def modes_run(quick_run):
    """The quick study, run through `pipeline run --quick` once per session (conftest)."""
    out, _, ds = quick_run("blade_modes", figures=True)
    return out, ds


def test_modes_converge_from_above_and_within_0p1_percent(modes_run):
    _, ds = modes_run
    err = ds["relative_error"].values                      # (mode_count, mode)
    counts = ds["mode_count"].values.tolist()
    assert counts == [0, 5, 10, 20, 40]
    assert np.all(err > -1e-9), err                        # Rayleigh-Ritz upper bounds
    assert np.all(np.diff(err, axis=0) <= 1e-9)            # monotone in the mode count
    assert np.all(np.diff(ds["max_relative_error"].values) < 0)
    at_default = err[counts.index(ds.attrs["default_mode_count"])]
    assert ds.attrs["default_mode_count"] == 40
    assert at_default.max() < 1e-3, at_default
    assert ds.attrs["max_relative_error_at_default"] == pytest.approx(at_default.max())
    # coarse quick mesh: first flap 250.32 Hz (Euler-Bernoulli 247 Hz without shroud mass)
    assert ds["full_frequency"].values[0] == pytest.approx(250.318, rel=1e-4)
    assert np.all(ds["mac"].values > 0.999)


def test_modes_dataset_metadata_and_mode_shapes(modes_run):
    import meshio

    out, ds = modes_run
    assert problems(out / "blade_modes.nc") == []     # a modal dataset: attributes, units
    for a in ("title", "study", "pipeline_version", "created"):
        assert ds.attrs[a]
    assert ds.attrs["Conventions"] == "CF-1.10"
    for name, v in ds.variables.items():
        if name != "stage":
            assert "units" in v.attrs and "long_name" in v.attrs, name
    assert np.all(ds["reduction_time"].values > 0) and float(ds["full_eigen_time"]) > 0
    assert int(ds["n_dof"]) == 1458 and int(ds["n_boundary"]) == 168
    np.testing.assert_array_equal(ds["reduced_size"].values, 168 + ds["mode_count"].values)
    vtu = out / ds.attrs["mode_shapes"]
    assert vtu == out / "blade_modes" / "mode_shapes.vtu" and vtu.is_file()
    assert (out / "blade_modes" / "modal_convergence.png").is_file()
    m = meshio.read(vtu)
    for j in range(1, 7):
        full, red = m.point_data[f"full_mode_{j}"], m.point_data[f"reduced_mode_{j}"]
        assert 0.9 < np.abs(full).max() <= 1 + 1e-12  # unit max DOF; it may sit on a mid-node
        assert np.abs(red - full).max() < 1e-2            # same shape, same sign
    assert {"root", "shroud_left", "shroud_right"} <= set(m.point_data)


def test_modes_from_a_user_mesh_equal_the_generated_blade(tmp_path):
    write_mesh(build_blade(QUICK_BLADE), tmp_path / "meshes" / "blade.vtu")
    text = MODES.read_text().split("[quick.scene.blade]")[0]
    text = text.replace('craig_bampton_modes = 40', 'craig_bampton_modes = 10\nmesh = "meshes/blade.vtu"')
    text = text.replace("mode_counts = [0, 5, 10, 20, 40, 80]", "mode_counts = [0, 10]")
    (tmp_path / "user.toml").write_text(text)
    study = load_study(tmp_path / "user.toml")
    assert isinstance(study, ModesStudy) and study.scene.structure.mesh.endswith("blade.vtu")
    assert cli(["run", str(tmp_path / "user.toml"), "--out", str(tmp_path / "out")]) == 0
    ds = read_dataset(tmp_path / "out" / "user.nc")
    assert ds["full_frequency"].values[0] == pytest.approx(250.318, rel=1e-4)


# ---------------------------------------------------------------------------
# Blade schema errors: one line, exit 2, nothing written
# ---------------------------------------------------------------------------

def _modes_text(**subs):
    text = MODES.read_text()
    for old, new in subs.items():
        assert old in text or old.startswith("+")
        text = text + new if old.startswith("+") else text.replace(old, new)
    return text


BAD = {
    "mesh_missing": ('craig_bampton_modes = 40', 'craig_bampton_modes = 40\nmesh = "nope/blade.vtu"',
                     r"scene\.mesh: mesh file .*nope/blade\.vtu' not found"),
    "unknown_blade_key": ("n_span = 20", "n_span = 20\nwidth = 0.1",
                          r"scene\.blade\.width: unknown key"),
    "negative_length": ("length = 0.10", "length = -0.10", r"scene\.blade\.length: must be > 0"),
    "poisson": ("nu = 0.3", "nu = 0.5", r"scene\.blade\.nu: must be < 0\.5"),
    "float_elements": ("n_span = 20", "n_span = 2.5", r"scene\.blade\.n_span: must be an integer"),
    "counts_not_increasing": ("mode_counts = [0, 5, 10, 20, 40, 80]", "mode_counts = [0, 10, 5]",
                              r"modes\.mode_counts\[2\]: must increase strictly"),
    "unknown_modes_key": ("n_frequencies = 10", "n_frequencies = 10\nfrequencies = 3",
                          r"modes\.frequencies: unknown key"),
    "modes_with_sweep": ("+", '\n[sweep]\npreload = [1.0]\n', r"sweep: not used by a modes study"),
    "bad_kind": ('kind = "modes"', 'kind = "static"', r"study\.kind: must be one of"),
    "quick_unknown": ("n_chord = 4", "n_chord = 4\nlenght = 1.0",
                      r"quick\.scene\.blade\.lenght: unknown key.*did you mean 'length'"),
    "shear": ("shroud_angle = 0.5235987755982988", "shroud_angle = 1.5",
              r"scene\.blade\.shroud_angle: shroud_angle 1\.5 too far from stagger_angle"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_blade_study_is_one_line_exit_2(tmp_path, case, capsys):
    old, new, pattern = BAD[case]
    f = tmp_path / "bad.toml"
    f.write_text(_modes_text(**{old: new}))
    quick = case.startswith("quick")   # [quick] is read only for --quick
    with pytest.raises(UsageError, match=pattern):
        load_study(f, quick=quick)
    assert cli(["run", str(f), "--out", str(tmp_path / "out")] + ["--quick"] * quick) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {f}: "), err
    assert not (tmp_path / "out" / "bad.nc").exists()


def test_mesh_without_contact_face_node_set(tmp_path, capsys):
    blade = build_blade(QUICK_BLADE)
    sets = dict(blade.node_sets)
    del sets["shroud_right"]
    from dataclasses import replace
    write_mesh(replace(blade, node_sets=sets), tmp_path / "m.vtu")
    text = CONTACT.read_text().replace("craig_bampton_modes = 40",
                                       'craig_bampton_modes = 40\nmesh = "m.vtu"')
    (tmp_path / "c.toml").write_text(text)
    assert cli(["run", str(tmp_path / "c.toml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "scene.mesh: " in err[0] and "'shroud_right'" in err[0], err


def test_contact_schema_errors():
    text = CONTACT.read_text()
    for old, new, pattern in [
        ('face = "shroud_right"', 'face = "shroud_top"', r"scene\.contact\[0\]\.face: must be one of"),
        ('face = "shroud_left"', 'face = "shroud_right"', r"scene\.contact\[1\]\.face: face 'shroud_right' has two"),
        ("direction = [0.0, 1.0, 0.0]", "direction = [0.0, 0.0, 0.0]",
         r"scene\.excitation\[0\]\.direction: must not be the zero vector"),
        ('set = "excitation"', 'set = "root"', r"scene\.excitation\[0\]\.set: must be one of"),
        ('dofs = ["response.x"', 'dofs = ["tip.x"', r"output\.dofs\[0\]: 'tip\.x' is not"),
        ('effects = ["friction", "normal_load_variation", "separation"]', 'effects = ["friction"]',
         r"scene\.effects: normal DOFs with kv > 0 make the normal load vary"),
        ("rayleigh = [20.0, 4e-6]", "rayleigh = [20.0]", r"scene\.rayleigh: must have 2 entries"),
        ("[scene.blade]\n", "[scene.blade]\nshroud = false\n",
         r"scene\.contact: the blade has no shroud"),
    ]:
        assert old in text, old
        with pytest.raises(UsageError, match=pattern):
            parse_study(text.replace(old, new, 1), file="c.toml", quick=True)


# ---------------------------------------------------------------------------
# Shroud contact study (studies/blade_shroud_contact.toml), reduced vs unreduced
# ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def scene():
    study = load_study(CONTACT, quick=True)
    assert blade_model(study.scene.structure).n_dof == 1458
    return study.scene


H = 3
TOL_REL = 1e-9


def _weights(prob):
    """1/tolerance per condensed row: static rows against the preload + load scale,
    harmonic rows against the excitation [N]."""
    bn = np.linalg.norm(prob.bn, axis=1)
    dyn = float(np.linalg.norm(prob.P[:, 1:]))
    stat = float(np.linalg.norm(prob.P[:, 0])) + float(np.sum(np.abs(prob.system.contact.n0) * bn)) + dyn
    w = np.full((prob.c.size, prob.nh), 1.0 / (TOL_REL * dyn))
    w[:, 0] = 1.0 / (TOL_REL * stat)
    return w.ravel(), TOL_REL * stat, TOL_REL * dyn


def _solve(system, Om, x0=None):
    """HBM at fixed Om: Newton on the condensed residual (rows scaled by their
    tolerances), all DOFs recovered, the full residual recomputed."""
    prob = hbm.setup(system, H)
    w, tol_s, tol_d = _weights(prob)
    if x0 is None:
        x0 = initial_guess(prob, Om, system.contact)

    def fun(x):
        R, J, _ = hbm.residual(prob, x, Om)
        return w * R, w[:, None] * J

    r = newton(fun, x0, 1.0, max_iter=60)
    assert r.success, r.message
    Q = hbm.recover(prob, r.x.reshape(prob.c.size, prob.nh), Om)
    R = hbm.full_residual(prob, Q, Om)
    assert np.linalg.norm(R[:, 0]) <= tol_s and np.linalg.norm(R[:, 1:]) <= tol_d, (
        np.linalg.norm(R[:, 0]), tol_s, np.linalg.norm(R[:, 1:]), tol_d)
    return prob, Q, r


# (total preload per face [N], frequency [Hz], expected regime)
POINTS = {"stick": (1000.0, 400.0), "stick-slip": (30.0, 405.0), "separation": (0.3, 330.0)}


@pytest.mark.parametrize("regime", list(POINTS))
def test_reduced_equals_unreduced_fe_model(scene, regime):
    n0, f = POINTS[regime]
    Om = 2 * np.pi * f
    red_sys = build_system(scene, {"preload": n0})
    full_sys = build_system(scene, {"preload": n0}, reduced=False)
    assert full_sys.K.shape == (1458, 1458) and red_sys.K.shape == (208, 208)
    p_r, Q_r, _ = _solve(red_sys, Om)
    # the regime the point is meant to test
    U, V = hbm.contact_motion(p_r, Q_r[p_r.c])
    reg = forces(U, V, red_sys.contact, jacobian=False).regimes
    n = red_sys.contact.n0[:, None] + red_sys.contact.kv[:, None] * evaluate(
        V, np.linspace(0, 2 * np.pi, 512, endpoint=False))
    separated = int((n.min(axis=1) < 0).sum())
    if regime == "stick":
        assert reg["stuck"] == 54 and separated == 0, reg
    elif regime == "stick-slip":
        assert reg["transitions"] == 54 and separated == 0, reg
    else:
        assert separated == 54, (reg, separated)
    # unreduced FE model (sparse), started from the reduced solution on its contact DOFs
    red = reduced_model(scene.structure, scene.reduction)[0]
    p_f = hbm.setup(full_sys, H)
    phys = {d: k for k, d in enumerate(red.boundary[p_r.c])}
    assert set(phys) == set(p_f.c.tolist())
    x0 = np.array([Q_r[p_r.c][phys[d]] for d in p_f.c]).ravel()
    _, Q_f, _ = _solve(full_sys, Om, x0)
    for name in ("response.x", "response.y", "response.z"):
        a_r = amplitude_half_peak_to_peak(Q_r[scene.dof_index(name)])
        a_f = amplitude_half_peak_to_peak(Q_f[full_dof(scene, name)])
        assert a_r == pytest.approx(a_f, rel=5e-3), name
    a_r = amplitude_half_peak_to_peak(Q_r[p_r.c])
    a_f = amplitude_half_peak_to_peak(Q_f[red.boundary[p_r.c]])
    assert np.max(np.abs(a_r - a_f)) <= 5e-3 * np.max(a_f)
    big = a_f > 0.1 * a_f.max()
    np.testing.assert_allclose(a_r[big], a_f[big], rtol=5e-3)


def test_contact_study_quick_writes_a_conforming_dataset(tmp_path):
    # the study file as shipped: stability by the fold rule, the FE scenes' default
    # ("stretch", what `true` selects, is checked on a coarser blade in test_stretches)
    study_file = tmp_path / "blade_shroud_contact.toml"
    study_file.write_text(CONTACT.read_text())
    assert cli(["run", str(study_file), "--quick", "--out", str(tmp_path)]) == 0
    nc = tmp_path / "blade_shroud_contact.nc"
    assert problems(nc) == []
    ds = read_dataset(nc)
    assert ds["preload"].values.tolist() == [30.0]
    assert bool(ds["converged"].sum() > 20)
    assert ds["frequency"].attrs["units"] == "Hz"
    assert ds.attrs["craig_bampton_modes"] == 40 and ds.attrs["contact_nodes"] == 54
    # first flap mode, stiffened by the stuck contacts (403.6 Hz) and softened by slip
    f_pk = float(ds["peak_frequency"].sel(dof="response.y").squeeze())
    assert 395.0 < f_pk < 403.6
    assert (tmp_path / "blade_shroud_contact" / "amplitude_response.y.png").is_file()
    # the fold rule: this curve has no fold, and its ends (stuck: a linear damped flow)
    # are stable, so every point is (method 4, or 2 where an end took the monodromy)
    conv = ds["converged"].values
    assert ds["stable"].attrs["stability_computed"] == 1
    assert (ds["stable"].values[conv] == 1).all()
    m = ds["stability_method"].values[conv]
    assert set(np.unique(m)) <= {2, 4} and (m == 4).sum() >= conv.sum() - 2
    assert ds.attrs["stability"].startswith("fold rule")
