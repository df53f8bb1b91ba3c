"""What is declared is solved, for the 2D friction contacts of a lumped scene
(`[[scene.friction_2d]]`) as for `[[scene.contact]]`: the effect rules read their
normal loads (a varying normal load may declare "normal_load_variation" and
"separation"; a gap needs "separation"), and a case whose 2D contact separates
without "separation" declared fails.  The normal load is checked against
n0 + kv z(t) sampled from the normal DOF z itself (the contact's normal row is z),
another path than the guard's trigonometric root search on the law's maps."""
import re
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import UsageError
from pipeline.fourier.harmonics import basis
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response.response import frequency_response
from pipeline.study.datasets.dataset import read_dataset
from pipeline.study.datasets.incomplete import absent_effects
from pipeline.study.execution.run import run_study
from pipeline.study.files.declared import SeparationGuard, UndeclaredSeparation, separating
from pipeline.study.files.documents import parse_study

ROOT = Path(__file__).resolve().parents[3]
BASE = (ROOT / "tests" / "studies" / "inplane_oscillator_2d_friction.toml").read_text()
KV, N0 = 1.0e5, 5.0          # [N/m], [N]


def oscillator(effects, kv=KV, n0=N0, z_force=160.0, scales=None):
    """The in-plane oscillator with its normal DOF z forced (z_force [N] at h = 1) so
    that the normal load n = n0 + kv z varies; `scales`: an excitation_scale sweep."""
    t = BASE.replace('effects = ["friction_2d"]', f"effects = {list(effects)!r}".replace("'", '"'))
    t = t.replace("kv = 0.0", f"kv = {kv!r}").replace("n0 = 5.0", f"n0 = {n0!r}")
    t = t.replace('[[scene.excitation]]\ndof = "y"',
                  f'[[scene.excitation]]\ndof = "z"\namplitude = {z_force!r}\n\n'
                  '[[scene.excitation]]\ndof = "y"')
    t = t.replace("harmonics = 5", "harmonics = 3").replace("samples = 512", "samples = 64")
    t = t.replace("[solver]", "[solver]\nstability = false")
    if scales is not None:
        t = t.replace("frequency = { start", f"excitation_scale = {list(scales)!r}\nfrequency = {{ start")
    return t


@pytest.mark.parametrize("effects, kv, n0", [
    (["friction_2d", "normal_load_variation", "separation"], KV, N0),
    (["friction_2d", "normal_load_variation"], KV, N0),      # closed: checked by the run
    (["friction_2d", "normal_load_variation", "separation"], KV, 0.0),
    (["friction_2d", "separation"], 0.0, -1.0)])              # a gap, constant normal load
def test_2d_contact_effects_are_accepted(effects, kv, n0):
    study = parse_study(oscillator(effects, kv, n0), file="ok.toml")
    (law,) = [le.law for le in study.scene.laws]
    assert (law.kv[0], law.n0[0]) == (kv, n0)


@pytest.mark.parametrize("effects, kv, n0, message", [
    (["friction_2d"], KV, N0, r"normal DOFs with kv > 0 .*declare \"normal_load_variation\""),
    (["friction_2d", "normal_load_variation"], KV, 0.0,
     r"scene\.friction_2d\[0\] has a varying normal load .* preload of 0 N "
     r"\(scene\.friction_2d\[0\]\.n0\).*declare \"separation\""),
    (["friction_2d"], 0.0, -1.0, r"a negative preload \(initial gap\).*declare \"separation\""),
    (["friction_2d", "normal_load_variation", "separation"], 0.0, N0,
     r"\"normal_load_variation\" is declared but no contact"),
    (["friction_2d", "separation"], 0.0, N0, r"\"separation\" is declared but cannot occur")])
def test_2d_contact_effects_are_refused(effects, kv, n0, message):
    with pytest.raises(UsageError, match=r"^bad\.toml: scene\.effects: " + message):
        parse_study(oscillator(effects, kv, n0), file="bad.toml")


def sampled_normal_load(system, Q, H):
    """n0 + kv z(tau) [N] at 4096 instants of the period, per point (P, 4096)."""
    z = system.dof_names.index("z")
    tau = np.linspace(0.0, 2.0 * np.pi, 4096, endpoint=False)
    return N0 + KV * np.array([q[z] for q in Q]) @ basis(tau, H).T


def closed_minimum(omega, z_force):
    """The closed contact's lowest normal load [N] in closed form: z is a linear
    oscillator (K_zz = 1e6 N/m plus kv, damping 5 N s/m) about its static rest
    z0 = -n0 / (K_zz + kv), so min n = n0 + kv z0 - kv |z_force / (K_zz + kv - w^2 + 5 i w)|."""
    K = 1.0e6 + KV
    return N0 - KV * N0 / K - KV * np.abs(z_force / (K - omega ** 2 + 5j * omega))


def test_2d_contact_that_separates_undeclared_fails_its_case(tmp_path):
    """Without "separation", z forced by 16 N keeps the contact closed (n >= 3.0 N, the
    closed form's) and is solved; by 160 N the normal load reaches -11.6 to -12.1 N
    at every point, so that case fails, nothing of it stored as a solution, the run
    saying what to declare (as Example 3's 1D contact,
    tests/study/execution/test_study_execution.py)."""
    study = parse_study(oscillator(["friction_2d", "normal_load_variation"],
                                   scales=[0.1, 1.0]), file="closed.toml", name="closed")
    res = run_study(study, tmp_path, workers=1, figures=False, progress=False)
    assert res.failures == 1 and not res.ok
    ((case, reason),) = res.failed
    assert case == {"excitation_scale": 1.0}
    assert re.fullmatch(r"friction_2d element 0 separates at [0-9.]+ rad/s \(its normal load "
                        r"n = n0 \+ kv v, n0 = 5 N, reaches 0 N\) but scene\.effects does not "
                        r"declare \"separation\": add it to solve with separation", reason), reason
    ds = read_dataset(res.path)
    assert int(ds["converged"].sel(excitation_scale=1.0).sum()) == 0
    assert int(ds["converged"].sel(excitation_scale=0.1).sum()) > 10
    # the kept case stays closed at every point, the failed one separates at every point
    H, fr = study.solver.harmonics, study.sweep.frequency
    for scale in (0.1, 1.0):
        system = study.system({"excitation_scale": scale})
        curve = frequency_response(system, H, fr.omega_start, fr.omega_stop, method="aft",
                                   n_samples=study.solver.samples, stability=False)
        assert curve.success
        n_min = sampled_normal_load(system, curve.Q, H).min(axis=1)
        if scale == 0.1:
            np.testing.assert_allclose(n_min, closed_minimum(np.asarray(curve.omega), 16.0),
                                       atol=1e-6)
            assert n_min.min() > 3.0
        else:
            assert n_min.max() < -11.0


def with_damper(text):
    """A Jenkins damper on x ([[scene.contact]], n0 = 50 N constant: it never separates
    nor slips here) beside the 2D contact."""
    return text.replace("[[scene.friction_2d]]", '[[scene.contact]]\nname = "damper"\n'
                        'tangential = ["x"]\nku = 1.0e3\nmu = 0.5\nn0 = 50.0\n\n'
                        '[[scene.friction_2d]]', 1)


def test_the_guard_reads_a_2d_contact_beside_a_1d_one():
    """The guard reads the 2D contact's normal load beside a Jenkins damper's (before,
    only the Yang-Menq set), and names it."""
    study = parse_study(with_damper(oscillator(["friction", "friction_2d",
                                                "normal_load_variation"])), file="mixed.toml")
    system = study.system()
    assert system.contact.size == 1 and len(system.laws) == 1
    fr = study.sweep.frequency
    curve = frequency_response(system, 3, fr.omega_start, fr.omega_stop, method="aft",
                               n_samples=64, stability=False)
    assert curve.success
    n_min = sampled_normal_load(system, curve.Q, 3).min(axis=1)
    assert n_min.max() < -11.0            # the 2D contact is open somewhere at every point
    prob = hbm.setup(system, 3)
    assert not any(separating(prob, q[prob.c], system.contact).any() for q in curve.Q)
    with pytest.raises(UndeclaredSeparation, match=r"^friction_2d element 0 separates at "):
        SeparationGuard(names=("damper",)).check_curve(system, curve)


def test_no_absent_separation_warning_where_a_2d_contact_separates(tmp_path):
    """The dataset's contact-state fractions are the damper's only; the 2D contact,
    which separates at every point (n down to -12 N: the guard test above samples it), is not recorded there,
    so "separation" is not called absent.  The damper's slip fraction is recorded: it
    never slips (n0 = 50 N), and that warning stays."""
    study = parse_study(with_damper(oscillator(
        ["friction", "friction_2d", "normal_load_variation", "separation"], scales=[1.0])),
        file="mixed.toml", name="mixed")
    res = run_study(study, tmp_path, workers=1, figures=False, progress=False)
    assert res.ok
    ds = read_dataset(res.path)
    assert float(ds["separation_fraction"].where(ds["converged"] == 1).max()) == 0.0
    assert float(ds["slip_fraction"].where(ds["converged"] == 1).max()) == 0.0
    said = absent_effects(study, ds)
    assert not any("separation" in w for w in said), said
    assert len(said) == 1 and said[0].startswith("\"friction\" is declared but no contact slips")
