"""The EPMC condensed onto the contact DOFs (`condensed`) against the EPMC on all DOFs
(`mode_problem(condense=False)`): the same equations, so the same frequency, damping
and motion at every amplitude; and its Jacobian against central differences.

Models: the FE sector of `studies/shrouded_disk.toml` (quick mesh, Craig-Bampton,
ND 3 at 3 N: 116 DOFs, 90 of them contact DOFs, the phase reference among them) and
the matrix-imported sector of `studies/disk_nonlinear_modes.toml` (ND 3)."""
import numpy as np
import pytest

from pipeline.solve.nonlinear_modes import epmc
from pipeline.solve.nonlinear_modes.backbone import continue_mode, newton
from pipeline.study.files.documents import load_study

from helpers import STUDIES


def systems():
    fe = load_study(STUDIES / "shrouded_disk.toml", quick=True).system({"preload": 3.0})
    lumped = load_study(STUDIES / "disk_nonlinear_modes.toml").response
    return {"fe": fe, "lumped": lumped.system({"preload": 2.0, "eo": 3})}


@pytest.fixture(scope="module")
def models():
    return systems()


def sliding_point(mp, factor):
    """A point off the solution (shape perturbed by 5 %, omega by 1 %, zeta 0.01) at
    `factor` times the slip onset."""
    rng = np.random.default_rng(1)
    y = epmc.linear_guess(mp)
    y[:-2] *= 1 + 0.05 * rng.standard_normal(y.size - 2)
    y[-2] *= 1.01
    y[-1] = 0.01
    return y, np.log10(factor * epmc.onset_amplitude(mp)), rng


@pytest.mark.parametrize("ref", [None, "interior"])
def test_condensed_jacobian_equals_central_differences(models, ref):
    """H = 3 at 3 slip onsets: dR/dy along a random direction (every unknown, omega
    and zeta included) and dR/ds against central differences, step 1e-4, to 1e-9 of
    |J v| (the differences' own error falls as the step squared: 1e-13 at 1e-3).  With
    the phase reference on a recovered DOF its row is the chain rule through the
    recovery."""
    sysm = models["fe"]
    mp0 = epmc.mode_problem(sysm, 3)
    r = None if ref is None else int(np.setdiff1d(np.arange(sysm.n_dof), mp0.kept)[0])
    mp = epmc.mode_problem(sysm, 3, ref=r)
    assert mp.condensed is not None and mp.size == mp.kept.size * 7 + 2 < mp.n * 7 + 2
    assert (mp.ref in mp.kept) == (ref is None)
    y, s, rng = sliding_point(mp, 3.0)
    _, J, dRs = epmc.residual(mp, y, s)
    v = rng.standard_normal(y.size) * np.abs(y)
    e = 1e-4
    fd = (epmc.residual(mp, y + e * v, s, False)[0] - epmc.residual(mp, y - e * v, s, False)[0])
    assert np.abs(fd / (2 * e) - J @ v).max() <= 1e-9 * np.abs(J @ v).max()
    fs = (epmc.residual(mp, y, s + e, False)[0] - epmc.residual(mp, y, s - e, False)[0])
    assert np.abs(fs / (2 * e) - dRs).max() <= 1e-6 * np.abs(dRs).max()


@pytest.mark.parametrize("model", ["fe", "lumped"])
def test_condensed_mode_is_the_mode_on_all_dofs(models, model):
    """H = 3, 0.01 to 1000 slip onsets: the condensed backbone covers the range; at
    each point of the backbone on all DOFs, Newton on the condensed equations from
    that point (its contact DOFs) converges at once (0 or 1 iteration), and omega,
    zeta and the recovered motion of every DOF are the same to 1e-8."""
    sysm = models[model]
    full = epmc.mode_problem(sysm, 3, condense=False)
    mp = epmc.mode_problem(sysm, 3)
    assert mp.condensed is not None and mp.kept.size < mp.n     # interior DOFs recovered
    a = epmc.onset_amplitude(full)
    lo, hi = np.log10(0.01 * a), np.log10(1000 * a)
    ref = continue_mode(full, lo, hi, tol_rel=1e-10)
    bb = continue_mode(mp, lo, hi, tol_rel=1e-10)
    assert ref.message == bb.message == "" and bb.s.max() >= hi
    assert ref.zeta.max() > 2 * ref.zeta[0]           # the friction damps it
    for i in np.linspace(0, ref.s.size - 1, 6).astype(int):
        s, Q = ref.s[i], ref.Q[i]
        Z = Q.copy()
        Z[:, 1:] /= 10.0 ** s
        y, it, ok = newton(mp, epmc.pack(mp, Z, ref.omega[i], ref.zeta[i]), s, 1e-10)
        assert ok.converged and it <= 1
        Zc, om, ze, scale = epmc.unpack(mp, y, s)
        assert om == pytest.approx(ref.omega[i], rel=1e-8)
        assert ze == pytest.approx(ref.zeta[i], rel=1e-8)
        assert np.abs(Zc * scale - Q).max() <= 1e-8 * np.abs(Q).max()
