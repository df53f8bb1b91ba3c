"""Studies of FE blades in a disk (`studies/shrouded_disk*.toml`): a variant of the
shrouded disk's quick study run through `run_study`, its dataset passing the contract
checker and its numbers checked against independent linear limits; the FE disk's
bad inputs are one-line errors naming the field.  The unmodified quick runs and
their stated numbers: test_shipped_studies.py."""
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import UsageError
from pipeline.model.system import dense
from pipeline.study.datasets.conformance import problems
from pipeline.study.files.documents import load_study, parse_study
from pipeline.study.execution.run import run_study

STUDIES = Path(__file__).resolve().parents[3] / "studies"


def tied_amplitude(system, omega, dof):
    """Amplitude [m] of `dof` of the tied sector's linear response at omega [rad/s]:
    K + B^H ku B + B_n^H kv B_n (B = Bt + e^{i phi} Bt_next), first harmonic."""
    cy, el = system.cyclic, system.contact
    z = np.exp(1j * cy.phase)
    B, Bn = dense(system.Bt) + z * dense(cy.Bt_next), dense(system.Bn) + z * dense(cy.Bn_next)
    K = dense(system.K) + B.conj().T @ (el.ku[:, None] * B) + Bn.conj().T @ (el.kv[:, None] * Bn)
    D = K - omega**2 * dense(system.M) + 1j * omega * dense(system.C)
    return abs(np.linalg.solve(D, np.asarray(system.forcing)[:, 1])[dof])


def test_shrouded_disk_quick_run(tmp_path):
    """Two preloads (no optimum search): a large preload sticks, so the curve is the
    tied sector's linear FRF (checked at its peak, 1e-6); the small one separates
    and slides, its peak far below the stuck frequency; the hysteresis coefficients
    of the most sliding pair redraw a loop; the dataset passes the checker."""
    text = (STUDIES / "shrouded_disk.toml").read_text()
    text = text.replace("preload = [0.3, 3.0, 30.0]", "preload = [0.3, 1000.0]")
    text = "\n".join(line for line in text.splitlines() if not line.startswith("optimum_preload"))
    st = parse_study(text, file=str(tmp_path / "shrouded_disk.toml"), name="sd", quick=True)
    res = run_study(st, tmp_path, progress=False)
    ds = res.dataset
    assert int(ds.converged.sum()) == int(ds.n_points.sum()) and problems(res.path) == []
    stuck = ds.sel(preload=1000.0)
    f_peak = float(stuck.peak_frequency.sel(dof="response.y"))
    system = st.system({"preload": 1000.0})
    dof = st.scene.dof_index("response.y")
    ref = tied_amplitude(system, 2 * np.pi * f_peak, dof)
    assert np.isclose(float(stuck.peak_amplitude.sel(dof="response.y")), ref, rtol=1e-6)
    loose = ds.sel(preload=0.3)
    assert float(loose.peak_frequency.sel(dof="response.y")) < 0.9 * f_peak
    assert int(stuck.hysteresis_element) >= 0 and np.all(np.isfinite(ds.hysteresis_u))
    assert (tmp_path / "sd" / "hysteresis.png").is_file()


@pytest.mark.parametrize("old,new,field", [
    ("engine_order = 3", "engine_order = 19", "scene.disk.engine_order"),
    ("hub_radius = 0.12                # m", "hub_radius = 0.02", "scene.disk.hub_radius"),
    ('pair = "shroud"', 'pair = "platform"', "scene.contact[0].pair"),
    ('effects = ["friction", "normal_load_variation", "separation", "cyclic_coupling"]',
     'effects = ["friction", "normal_load_variation", "separation"]', "scene.effects"),
    ("[scene.disk]\nsectors = 36\nhub_radius = 0.12                # m\nengine_order = 3\n", "",
     "scene.contact[0].pair"),
])
def test_bad_shrouded_disk_studies_name_the_field(old, new, field):
    text = (STUDIES / "shrouded_disk.toml").read_text()
    assert old in text
    with pytest.raises(UsageError) as e:
        parse_study(text.replace(old, new), file="sd.toml", quick=True)
    assert str(e.value).startswith(f"sd.toml: {field}: "), str(e.value)


def test_shrouded_disk_mistuned_builds_a_sparse_wheel_of_beam_blades():
    """The beam-blade wheel: 15 reduced DOFs per blade (tip + excitation node + 6
    modes), each case the full 24-blade wheel stored sparse, blade j's stiffness
    f_j K_r with the seed's factors, every blade's tip reported."""
    import scipy.sparse as sp

    from pipeline.model.build import stiffness_factors

    st = load_study(STUDIES / "shrouded_disk_mistuned.toml", quick=True)
    s = st.system({"preload": 3.0, "mistuning_seed": 2})
    assert sp.issparse(s.K) and s.n_dof == 24 * 15 and s.cyclic is None
    f = stiffness_factors(st.scene, {"mistuning_seed": 2})
    K = s.K.tocsr()
    np.testing.assert_allclose(K[15:30, 15:30].toarray(), f[1] / f[0] * K[:15, :15].toarray(),
                               rtol=1e-12, atol=1e-9 * abs(K[:15, :15]).max())
    assert st.output.dofs == tuple(f"response.y@{j}" for j in range(24))


@pytest.mark.parametrize("contacts", ["open", "stuck"])
def test_lowest_frequencies_of_a_large_wheel_never_densify(monkeypatch, contacts):
    """Above DENSE_EIGEN_MAX DOFs the dataset's lowest frequencies come from sparse
    shift-invert Lanczos: the same 50 as the dense eigen-solve (1e-10), with no
    dense whole-wheel matrix (`dense` patched to fail on anything that large)."""
    import pipeline.model.system as system_mod

    st = load_study(STUDIES / "shrouded_disk_mistuned.toml", quick=True)
    s = st.system({"preload": 3.0, "mistuning_seed": 1})
    ref = system_mod.natural_frequencies(s, contacts)[:50]
    monkeypatch.setattr(system_mod, "DENSE_EIGEN_MAX", 100)
    real = system_mod.dense

    def small_only(A):
        assert min(A.shape) < 100, "a whole-wheel matrix was densified"
        return real(A)
    monkeypatch.setattr(system_mod, "dense", small_only)
    np.testing.assert_allclose(system_mod.lowest_frequencies(s, contacts, 50), ref, rtol=1e-10)


def test_a_load_on_the_clamped_root_is_refused():
    """With one element along the span the excitation node (one third of the span)
    falls on the clamped root: a load there would act on nothing, so it is an error."""
    text = (STUDIES / "shrouded_disk.toml").read_text().replace(
        "[quick.scene.blade]\nn_chord = 2\nn_thick = 1\nn_span = 4",
        "[quick.scene.blade]\nn_chord = 2\nn_thick = 1\nn_span = 1")
    with pytest.raises(UsageError) as e:
        parse_study(text, file="sd.toml", quick=True)
    assert str(e.value).startswith("sd.toml: scene.excitation[0].set: the load at node set "
                                   "'excitation' acts on a clamped DOF"), str(e.value)
