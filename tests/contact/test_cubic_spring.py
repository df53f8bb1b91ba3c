"""The cubic spring, the second contact law: a Duffing oscillator

    m x'' + c x' + k x + k3 x^3 = F cos(W t)

against the closed form of the one-harmonic balance (forced curve, its folds, the
backbone), against time integration (H = 7), the law's Jacobian against finite
differences, and a lumped study with a `[[scene.spring]]` run end to end.
"""
import re
from pathlib import Path
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pipeline.contact import YangMenq, forces
from pipeline.contact.cubic_spring import CubicSpring, alias_free_samples
from pipeline.contact.laws import LawElements, YangMenqLaw
from pipeline.contact.registry import LAWS, law_class
from pipeline.fourier.harmonics import amplitude_half_peak_to_peak, basis, time_grid
from pipeline.model.system import System
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response.response import frequency_response

m, c, k, k3, F = 1.0, 0.05, 1.0, 0.5, 0.1
BETA = 0.75 * k3


def duffing(damping=c, force=F, k1=0.0):
    """One DOF with a cubic spring to ground and no Yang-Menq element."""
    none = YangMenq(ku=np.zeros(0), kv=np.zeros(0), mu=np.zeros(0), n0=np.zeros(0))
    law = CubicSpring(k3=[k3], k1=[k1])
    return System(M=np.array([[m]]), C=np.array([[damping]]), K=np.array([[k]]),
                  Bt=np.zeros((0, 1)), Bn=np.zeros((0, 1)), contact=none,
                  forcing=np.array([[0.0, force]], complex),
                  laws=(LawElements(law, (np.ones((1, 1)),)),))


def closed_form(a, W):
    """[(k - m W^2 + 3/4 k3 a^2)^2 + (c W)^2] a^2 - F^2 (one-harmonic balance)."""
    return ((k - m * W**2 + BETA * a**2) ** 2 + (c * W) ** 2) * a**2 - F**2


def closed_form_fold(a, W):
    """d/d(a^2) of `closed_form`: zero where dW/da = 0 on the curve."""
    d = k - m * W**2 + BETA * a**2
    return d**2 + 2.0 * BETA * a**2 * d + (c * W) ** 2


def closed_form_fold_point(a, W):
    """(a, W) where `closed_form` and `closed_form_fold` vanish: Newton in (s = a^2, W)
    with the analytic Jacobian, from (a, W)."""
    s = a * a
    for _ in range(50):
        d = k - m * W**2 + BETA * s
        g = np.array([(d * d + (c * W) ** 2) * s - F**2, d * d + 2 * BETA * s * d + (c * W) ** 2])
        J = np.array([[g[1], (-4 * m * W * d + 2 * c * c * W) * s],
                      [4 * BETA * d + 2 * BETA**2 * s, -4 * m * W * (d + BETA * s) + 2 * c * c * W]])
        step = np.linalg.solve(J, -g)
        s, W = s + step[0], W + step[1]
        if abs(step[0]) < 1e-16 * s and abs(step[1]) < 1e-16 * W:
            break
    return np.sqrt(s), W


@pytest.fixture(scope="module")
def curve_h1():
    return frequency_response(duffing(), 1, 0.5, 2.5, stability="hill", tol_rel=1e-12)


def test_registry_names_both_laws():
    assert LAWS["yang_menq"] is YangMenqLaw and law_class("cubic_spring") is CubicSpring
    with pytest.raises(ValueError, match="unknown contact law 'quintic'"):
        law_class("quintic")


def test_forced_curve_meets_the_closed_form(curve_h1):
    cur = curve_h1
    assert cur.success and cur.converged.all()
    a, W = cur.amplitude[:, 0], cur.omega
    rel = np.abs(closed_form(a, W)) / F**2
    assert rel.max() < 1e-8
    # through the resonance: the upper branch reaches well beyond the linear peak
    assert a.max() > 1.0


def test_folds_meet_the_closed_form(curve_h1):
    cur = curve_h1
    assert cur.fold_parameter.size == 2
    for W_f, a_f in zip(cur.fold_parameter, cur.fold_amplitude[:, 0]):
        a_ref, W_ref = closed_form_fold_point(a_f, W_f)
        assert abs(closed_form_fold(a_ref, W_ref)) < 1e-12
        assert abs(W_f - W_ref) < 1e-8 * W_ref
        assert abs(a_f - a_ref) < 1e-8 * a_ref
    # the stable and unstable branches meet at the folds: Hill finds the middle one unstable
    between = (cur.omega > cur.fold_parameter.min()) & (cur.omega < cur.fold_parameter.max())
    assert not cur.stable[between].all()


@pytest.mark.parametrize("a", [0.1, 0.8, 2.0])
def test_backbone_of_the_undamped_unforced_balance(a):
    """Fixed amplitude x = a cos(W t), H = 1, no damping, no load: the cosine equation
    (k - m W^2) a + F_c1(a) = 0 solved for W by Newton on the HBM residual."""
    prob = hbm.setup(duffing(damping=0.0, force=0.0), 1)
    x, W = np.array([0.0, a, 0.0]), 1.0
    for _ in range(30):
        R, _, dR = hbm.residual(prob, x, W)
        step = R[1] / dR[1]
        W -= step
        if abs(step) < 1e-15 * W:
            break
    R, _, _ = hbm.residual(prob, x, W)
    assert abs(R[0]) < 1e-14 and abs(R[2]) < 1e-14 and abs(R[1]) < 1e-13 * a
    assert abs(W**2 - (k + BETA * a**2) / m) < 1e-8 * W**2


def hbm_solution(H, W):
    """HBM coefficients (1, 2H+1) at W by Newton from the one-harmonic closed form."""
    roots = np.roots([BETA**2, 0, 2 * BETA * (k - m * W**2), 0,
                      (k - m * W**2) ** 2 + (c * W) ** 2, 0, -F**2])
    a = float(min(abs(r.real) for r in roots if abs(r.imag) < 1e-9 and r.real > 0))
    phi = np.arctan2(c * W, k - m * W**2 + BETA * a**2)
    prob = hbm.setup(duffing(), H)
    x = np.zeros(prob.size)
    x[1], x[2] = a * np.cos(phi), a * np.sin(phi)
    for _ in range(50):
        R, J, _ = hbm.residual(prob, x, W)
        dx = np.linalg.solve(J, R)
        x -= dx
        if np.linalg.norm(dx) < 1e-15 * np.linalg.norm(x):
            break
    assert np.linalg.norm(hbm.residual(prob, x, W, jacobian=False)[0]) < 1e-12 * F
    return hbm.recover(prob, x.reshape(1, -1), W)


@pytest.mark.parametrize("W", [0.7, 0.95, 1.6, 2.2])
def test_h7_amplitude_matches_time_integration(W):
    """Outside the fold interval the one solution is the stable one; the time
    integration starts on the HBM orbit and runs 150 periods (the transient of its
    1e-6-sized error decays by exp(-c/(2m) 150 T) < 1e-3) before one period is read."""
    Q = hbm_solution(7, W)
    amp_hbm = float(amplitude_half_peak_to_peak(Q[0]))
    x0 = float(basis(0.0, 7) @ Q[0])
    v0 = float(W * basis(0.0, 7, 1) @ Q[0])
    T = 2 * np.pi / W

    def rhs(t, y):
        return [y[1], (F * np.cos(W * t) - c * y[1] - k * y[0] - k3 * y[0] ** 3) / m]

    n = 150
    sol = solve_ivp(rhs, (0.0, (n + 1) * T), [x0, v0], method="DOP853", rtol=1e-11,
                    atol=1e-14, dense_output=True)
    t = n * T + T * np.arange(20000) / 20000
    xs = sol.sol(t)[0]
    amp_ti = 0.5 * (xs.max() - xs.min())
    assert abs(amp_hbm - amp_ti) < 1e-4 * amp_ti


def test_law_jacobian_matches_finite_differences():
    rng = np.random.default_rng(3)
    law = CubicSpring(k3=[2.0, -0.7, 5.0], k1=[1.0, 0.0, -0.3])
    H = 4
    X = rng.normal(size=(3, 1, 2 * H + 1)) * 0.5
    out = law.evaluate(X)
    assert out.F.shape == (3, 1, 2 * H + 1) and out.J.shape == (3, 1, 2 * H + 1, 2 * H + 1)
    h = 1e-6
    for j in range(2 * H + 1):
        dX = np.zeros_like(X)
        dX[:, 0, j] = h
        fd = (law.evaluate(X + dX, jacobian=False).F - law.evaluate(X - dX, jacobian=False).F) / (2 * h)
        assert np.abs(fd[:, 0] - out.J[:, 0, :, j]).max() < 1e-7 * np.abs(out.J).max()


def test_law_forces_are_alias_free():
    """The 6H+3-sample projection equals a finely sampled one (no aliasing of the
    cubic's harmonics 2H+1 .. 3H onto the kept ones)."""
    rng = np.random.default_rng(5)
    law = CubicSpring(k3=[3.0, 0.4], k1=[0.5, 2.0])
    H = 5
    X = rng.normal(size=(2, 1, 2 * H + 1))
    _, S, W = time_grid(H, 4096)
    u = X[:, 0] @ S.T
    ref = (law.k1[:, None] * u + law.k3[:, None] * u**3) @ W.T
    assert alias_free_samples(H) >= 4 * H + 1
    assert np.abs(law.evaluate(X, jacobian=False).F[:, 0] - ref).max() < 1e-12 * np.abs(ref).max()


def test_yang_menq_law_is_the_element():
    """Through the interface the Yang-Menq forces are those of `contact.forces`, bit for bit."""
    rng = np.random.default_rng(1)
    elem = YangMenq(ku=[1e4, 2e4], kv=[5e3, 0.0], mu=[0.3, 0.5], n0=[10.0, 3.0])
    U, V = rng.normal(size=(2, 7)) * 1e-3, rng.normal(size=(2, 7)) * 1e-3
    out = YangMenqLaw(elem).evaluate(np.stack([U, V], axis=1), "exact")
    ref = forces(U, V, elem, "exact")
    assert np.array_equal(out.F[:, 0], ref.Fu) and np.array_equal(out.F[:, 1], ref.Fv)
    assert np.array_equal(out.J[:, 2], ref.dFv_dV) and np.array_equal(out.J[:, 1], ref.dFu_dV)


STUDY = """
[study]
title = "Duffing oscillator with a cubic spring to ground"

[scene]
model = "lumped"
effects = ["cubic_stiffness"]
dofs = ["x1", "x2"]

[scene.matrices]
M = [[1.0, 0.0], [0.0, 1.0]]
C = [[0.05, 0.0], [0.0, 0.05]]
K = [[2.0, -1.0], [-1.0, 2.0]]

[[scene.spring]]
name = "coupling"
dofs = ["x1", "-x2"]
k3 = 0.5

[[scene.excitation]]
dof = "x1"
amplitude = 0.05

[sweep]
frequency = { start = 0.5, stop = 2.5, unit = "rad/s" }

[solver]
harmonics = 3
stability = "hill"

[output]
dofs = ["x1", "x2"]
figures = ["amplitude"]
"""


def test_study_with_a_cubic_spring_runs(tmp_path):
    import xarray as xr

    from pipeline.study.files.documents import parse_study
    from pipeline.study.execution.run import run_study

    study = parse_study(STUDY, file="duffing.toml", name="duffing", quick=True)
    law = study.scene.laws[0]
    assert law.law.name == "cubic_spring" and np.array_equal(law.B, [[[1.0, -1.0]]])
    run_study(study, tmp_path, figures=False, progress=False, checkpoints=False)
    ds = xr.open_dataset(tmp_path / "duffing.nc")
    assert ds.attrs["effects"] == "cubic_stiffness"
    assert ds.attrs["solution_method"].startswith("harmonic balance")
    assert "cubic_spring" in ds.attrs["solution_method"]
    # the spring stretches in the second mode only (sqrt(3) rad/s, x1 = -x2), which it
    # hardens: folds above that frequency
    folds = ds["fold_frequency"].values
    folds = folds[np.isfinite(folds)]
    assert folds.size >= 2 and np.all(folds > np.sqrt(3.0))


@pytest.mark.parametrize("edit, field", [
    (("effects = [\"cubic_stiffness\"]", "effects = []"), "scene.effects"),
    (("k3 = 0.5", "k3 = \"stiff\""), "scene.spring[0].k3"),
    (("dofs = [\"x1\", \"-x2\"]", "dofs = [\"x3\"]"), "scene.spring[0].dofs[0]"),
    (("stability = \"hill\"", "stability = \"floquet\""), "solver.stability"),
])
def test_study_keys_are_checked(edit, field):
    from pipeline.errors import UsageError
    from pipeline.study.files.documents import parse_study

    with pytest.raises(UsageError, match=re.escape(f"duffing.toml: {field}: ")):
        parse_study(STUDY.replace(*edit), file="duffing.toml", name="duffing")


def test_event_driven_solvers_name_the_law_they_cannot_run():
    from pipeline.solve.stability.floquet import from_hbm
    from pipeline.solve.stability.orbit_floquet import along_orbit
    from pipeline.solve.time_integration.timesim import simulate

    sysm = duffing()
    Q = np.zeros((1, 3))
    with pytest.raises(ValueError, match="'cubic_spring' is not supported by timesim"):
        simulate(sysm, 1.0, 10.0)
    with pytest.raises(ValueError, match="'cubic_spring' is not supported by shooting"):
        from_hbm(sysm, 1.0, Q)
    with pytest.raises(ValueError, match="'cubic_spring' is not supported by orbit_floquet"):
        along_orbit(sysm, 1.0, Q)
    with pytest.raises(ValueError, match="stability 'monodromy': .*'cubic_spring'"):
        frequency_response(sysm, 1, 0.5, 0.6, stability="monodromy")


def test_default_stability_of_a_spring_study_is_hill():
    from pipeline.study.files.documents import parse_study

    text = STUDY.replace("stability = \"hill\"\n", "")
    assert parse_study(text, file="duffing.toml", name="duffing").solver.stability == "hill"


@pytest.mark.parametrize("method", ["exact", "aft"])
def test_residual_jacobian_with_both_laws(method):
    """A Yang-Menq contact (x2 against ground, with a normal DOF x3) and a cubic spring
    between x1 and x2 in one residual: its Jacobian (the laws' blocks in one padded
    layout) against central differences, and the spring's force as B^T f."""
    elem = YangMenq(ku=[2.0], kv=[1.0], mu=[0.3], n0=[0.5])
    law = CubicSpring(k3=[0.8], k1=[0.2])
    K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, 0.0], [0.0, 0.0, 1.0]])
    sysm = System(M=np.eye(3), C=0.02 * np.eye(3), K=K, Bt=np.array([[0.0, 1.0, 0.0]]),
                  Bn=np.array([[0.0, 0.0, 1.0]]), contact=elem,
                  forcing=np.array([[0, 0.3], [0, 0], [0, 0.1]], complex),
                  laws=(LawElements(law, (np.array([[1.0, -1.0, 0.0]]),)),))
    prob = hbm.setup(sysm, 3, method, 64)
    assert prob.slot_index.shape == (2, 2) and list(prob.c) == [0, 1, 2]
    rng = np.random.default_rng(7)
    x = rng.normal(size=prob.size) * 0.4
    R, J, _ = hbm.residual(prob, x, 1.3)
    h = 1e-7
    fd = np.column_stack([(hbm.residual(prob, x + h * e, 1.3, jacobian=False)[0]
                           - hbm.residual(prob, x - h * e, 1.3, jacobian=False)[0]) / (2 * h)
                          for e in np.eye(prob.size)])
    assert np.abs(J - fd).max() < 1e-5 * np.abs(J).max()
    Q = x.reshape(3, -1)
    f = law.evaluate((Q[0] - Q[1])[None, None], jacobian=False).F[0, 0]
    G = hbm.contact_terms(prob, Q, jacobian=False)[0]
    only_contact = hbm.setup(replace(sysm, laws=()), 3, method, 64)   # c = x2, x3
    G_ym = np.zeros_like(G)
    G_ym[1:] = hbm.contact_terms(only_contact, Q[1:], jacobian=False)[0]
    assert np.allclose(G - G_ym, np.stack([f, -f, 0 * f]), rtol=0, atol=1e-14)


def test_check_counts_the_springs(capsys):
    """`check` names the elements of every law a scene places, not only its contacts."""
    from pipeline.__main__ import main

    path = Path(__file__).resolve().parents[1] / "studies" / "duffing_spring.toml"
    assert main(["check", str(path)]) == 0
    assert "0 contact(s), 1 cubic_spring element(s)" in capsys.readouterr().out
