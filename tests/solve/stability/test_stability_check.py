"""Decided stability along a branch (pipeline/solve/stability/branch_stability.py): Hill checked by
the Floquet multipliers of the exact flow.

References: the 3-DOF shrouded blade of test_floquet.py, whose stability is settled by
time integration (Hill is wrong at most of its points); a seeded corpus of random
2-4-DOF contact systems against the Floquet multipliers at every point; the stiff
impact orbit that Hill calls stable (pipeline/solve/README.md, hard cases).
"""
import copy
import logging
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

from pipeline.contact import YangMenq
from pipeline.model.system import System
from pipeline.paper_systems import blade3, example1, example3
from pipeline.solve.stability import floquet as fq
from pipeline.solve.stability import branch_stability as sc
from pipeline.solve.stability.orbit_floquet import along_orbit
from pipeline.solve.response.response import frequency_response
from pipeline.study.files.documents import study_from_document

from helpers import BLADE_STABLE, stated, study_doc

STUDIES = Path(__file__).resolve().parents[3] / "studies"
log = logging.getLogger(__name__)


@pytest.mark.parametrize("value, mode", [(True, "hill"), (False, None), (None, None),
                                         ("hill", "hill"), ("floquet", "floquet"),
                                         ("hill+check", "hill+check"),
                                         ("monodromy", "monodromy"),
                                         ("monodromy+check", "monodromy+check")])
def test_stability_mode(value, mode):
    assert sc.stability_mode(value) == mode


@pytest.mark.parametrize("value", ["yes", "Hill", 1, "hill+chek"])
def test_bad_stability_raises_before_the_continuation(value):
    with pytest.raises(ValueError, match="stability must be true, false or one of"):
        frequency_response(blade3(), 3, 112.0, 113.0, stability=value)


# ------------------------------------------------------------------ (a) the 3-DOF blade
@pytest.fixture(scope="module")
def blade_curve():
    return frequency_response(blade3(), 10, 112.0, 121.0, stability="hill+check",
                              dense_output=False)


def test_blade_decided_where_hill_is_wrong(blade_curve):
    """Hill calls the whole window unstable; the multipliers (0.83-0.93 outside
    116.2-117.5 rad/s, a real one below -1 inside) decide, and the loss of stability
    is reported as period doubling on both sides of the unstable window."""
    c = blade_curve
    assert c.success and c.converged.all()
    assert not c.hill_multiplier[c.converged].max() < 1          # Hill: unstable somewhere
    om = c.omega
    calm = (((om >= BLADE_STABLE[0]) & (om <= 115.073))
            | ((om >= 118.120) & (om <= BLADE_STABLE[-1])))
    assert calm.sum() >= 7 and c.stable[calm].all()
    assert (c.stability_method[calm] == sc.FLOQUET).all()
    assert (c.floquet_multiplier[calm] < 0.95).all()
    pd = (om >= 116.186) & (om <= 116.560)
    assert pd.any() and not c.stable[pd].any() and (c.floquet_multiplier[pd] > 1.3).all()
    kinds = dict(zip(np.round(c.bifurcation_parameter, 3), c.bifurcation_kind))
    assert list(kinds.values()) == [sc.PERIOD_DOUBLING, sc.PERIOD_DOUBLING], kinds
    lo, hi = sorted(kinds)
    assert 115.073 < lo < 116.186 and 117.0 < hi < 118.120


def test_blade3_study_states_the_window(blade_curve):
    """studies/blade3_stability.toml: 'Hill's method calls every stable orbit of
    112-121 rad/s unstable and misses a period-doubling window at 115.9-117.5 rad/s'
    (the study builds this blade: test_paper_systems.py): the exact multipliers locate
    the window's ends to the stated digit."""
    lo_hill, hi_hill, lo, hi = stated("blade3_stability.toml",
                                      r"every stable orbit of ([\d.]+)-([\d.]+) rad/s unstable and "
                                      r"misses a\n# period-doubling window at ([\d.]+)-([\d.]+) rad/s")
    c = blade_curve
    kinds = dict(zip(c.bifurcation_parameter, c.bifurcation_kind))
    assert list(kinds.values()) == [sc.PERIOD_DOUBLING] * 2
    np.testing.assert_allclose(sorted(kinds), [lo, hi], atol=0.05)
    stable = c.converged & c.stable
    assert stable.sum() >= 10 and (c.hill_multiplier[stable] > 1).all()
    assert c.omega[stable].min() == lo_hill and c.omega[stable].max() == hi_hill


# ------------------------------------------------------------------ (b) random corpus
def random_system(seed):
    """A ground chain of n = 2-4 masses, a Yang-Menq contact at its tip (normal motion
    of a random mass, or none); the regime by seed: stick (large preload), slip
    (preload below the force), separation (preload near zero with normal motion)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 5))
    m, k = rng.uniform(0.5, 2.0, n), rng.uniform(0.5, 2.0, n) * 1e4
    K = np.diag(k)
    for i in range(n - 1):
        K[i:i + 2, i:i + 2] += k[i] * np.array([[1.0, -1.0], [-1.0, 1.0]])
    M = np.diag(m)
    zeta = 10 ** rng.uniform(-2.3, -1.0)            # 0.5 % ... 10 % at the first mode
    w1 = np.sqrt(np.linalg.eigvals(np.linalg.solve(M, K)).real.min())
    C = 2 * zeta / w1 * K
    Bt, Bn = np.zeros((1, n)), np.zeros((1, n))
    Bt[0, -1] = 1.0
    Bn[0, int(rng.integers(0, n))] = 1.0 if seed % 3 == 2 or rng.random() < 0.6 else 0.0
    ku = 10 ** rng.uniform(3.3, 4.5)
    kv = ku * 10 ** rng.uniform(-0.5, 0.5)
    F = rng.uniform(0.5, 2.0)
    regime = ("stick", "slip", "separation")[seed % 3]
    n0 = {"stick": 30 * F, "slip": rng.uniform(0.1, 1.0) * F,
          "separation": rng.uniform(0.0, 0.3) * F}[regime]
    forcing = np.zeros((n, 2), complex)
    forcing[0, 1] = F
    s = System(M=M, C=C, K=K, Bt=Bt, Bn=Bn, contact=YangMenq(ku, kv, rng.uniform(0.2, 0.8), n0),
               forcing=forcing)
    return s, w1, regime


def corpus_case(seed, H, max_points):
    """(curve, Floquet's max |mu| at every converged point) of one corpus system."""
    s, w1, _ = random_system(seed)
    c = frequency_response(s, H, 0.9 * w1, 1.2 * w1, stability="hill+check",
                           dense_output=False, max_points=max_points, ds_max=0.2)
    ref = np.array(c.floquet_multiplier, float)
    for i in np.flatnonzero(c.converged & ~np.isfinite(ref)):
        r = fq.from_hbm(s, c.omega[i], c.Q[i])
        ref[i] = r.max_modulus if r.orbit_converged else np.nan
    return c, ref


def corpus_counts(seeds, H, max_points):
    """(decided flags that differ from Floquet, Hill flags that differ, points compared)
    over the points whose max |mu| is outside 1 +- 1e-3."""
    wrong = hill_wrong = compared = 0
    for seed in seeds:
        c, ref = corpus_case(seed, H, max_points)
        far = np.isfinite(ref) & (np.abs(ref - 1.0) > 1e-3)
        compared += int(far.sum())
        wrong += int(np.sum(c.stable[far] != (ref[far] < 1.0)))
        hill = c.hill_multiplier[far] <= 1.0
        hill_wrong += int(np.sum(hill != (ref[far] < 1.0)))
    return wrong, hill_wrong, compared


def test_corpus_hill_check_equals_floquet():
    wrong, hill_wrong, compared = corpus_counts(range(10), H=3, max_points=8)
    log.info("corpus H = 3: %d points, Hill wrong at %d, hill+check wrong at %d",
             compared, hill_wrong, wrong)
    print(f"corpus (10 systems, H = 3): {compared} points compared, Hill alone wrong at "
          f"{hill_wrong}, hill+check wrong at {wrong}")
    assert compared >= 50 and wrong == 0


@pytest.mark.slow
def test_corpus_hill_check_equals_floquet_large():
    """pipeline/solve/README.md's number: 40 systems, H = 5, up to 30 points each."""
    wrong, hill_wrong, compared = corpus_counts(range(40), H=5, max_points=30)
    print(f"corpus (40 systems, H = 5): {compared} points compared, Hill alone wrong at "
          f"{hill_wrong}, hill+check wrong at {wrong}")
    assert wrong == 0


# ------------------------------------------------------------------ (c) stiff impact
def test_stiff_impact_orbit_that_hill_calls_stable():
    """Example 3, n0 = 10 N, ku = kv = 1000, H = 14, at 1.6 rad/s: Hill stable
    (rho_H = 0.67), the largest multiplier of the exact flow 1.05: unstable."""
    s = example3(10.0)
    s = replace(s, contact=replace(s.contact, ku=np.array([1e3]), kv=np.array([1e3])))
    c = frequency_response(s, 14, 1.6, 1.6001, stability="hill+check", dense_output=False,
                           max_points=2)
    assert c.converged[0] and c.omega[0] == 1.6
    assert c.hill_multiplier[0] < 1                                # Hill: stable
    assert c.stability_method[0] == sc.FLOQUET and not c.stable[0]
    assert c.floquet_multiplier[0] == pytest.approx(1.051, abs=2e-3)


# ------------------------------------------------------------------ defaults of study files
@pytest.mark.parametrize("name, expected", [("paper_example1.toml", "monodromy+check"),
                                            ("disk_cyclic.toml", "hill")])
def test_default_mode_per_scene(name, expected):
    doc = copy.deepcopy(study_doc(name))
    doc["solver"].pop("stability", None)
    assert study_from_document(doc, file=name, name="s").solver.stability == expected


def separating_sector():
    """The 4-sector cyclic case of tests/model/test_cyclic.py with separation (EO = 1): a
    2-DOF sector, one Yang-Menq element to the next sector's shroud, ku = 2, kv = 3,
    mu = 0.3, n0 = 0.1 N."""
    from pipeline.model.cyclic import Sector, sector_system
    K, M = np.array([[3.0, -1.0], [-1.0, 1.5]]), np.diag([1.0, 0.5])
    e1, e2 = np.array([[1.0, 0.0]]), np.array([[0.0, 1.0]])
    F = np.array([[0.0, 1.0, 0.0], [0.05, 0.3j, 0.1]])
    return sector_system(Sector(M=M, C=0.02 * K, K=K, Bt=-e2, Bn=-e1, Bt_next=e2, Bn_next=e1,
                                contact=YangMenq(2.0, 3.0, 0.3, 0.1), forcing=F, sectors=4,
                                dof_names=("x1", "x2")), 1)


def test_cyclic_sector_decided_by_the_wheels_multipliers():
    """Near separation Hill (H = 3, every wave number) calls stable orbits unstable at
    1.545-1.551 rad/s; the Floquet multipliers of the whole 4-sector wheel (the sector
    solution expanded, shooting on the wheel) are 0.94-0.99 there and decide.  At 1.70
    rad/s both say unstable: the standing wave r = 2 grows (the wheel's flow has every
    wave number, as Hill's problem per wave number)."""
    from pipeline.solve.harmonic_balance import hbm
    s = separating_sector()
    a = frequency_response(s, 3, 1.45, 1.8, stability="hill", peak_dofs=[1])
    pick = [int(np.argmin(np.abs(a.omega - w))) for w in (1.546, 1.548, 1.550, 1.70)]
    assert not a.stable[pick].any()                   # Hill: all four unstable
    bs = sc.branch_stability(hbm.setup(s, 3), a.Q[pick], a.omega[pick], a.omega[pick],
                             lambda lam: s.contact, np.ones(4, bool), "hill+check")
    assert list(bs.method) == [sc.FLOQUET] * 4
    assert list(bs.stable) == [True, True, True, False]
    assert np.all((bs.floquet_multiplier[:3] > 0.9) & (bs.floquet_multiplier[:3] < 0.995))
    assert bs.floquet_multiplier[3] > 1.2
    mono = sc.branch_stability(hbm.setup(s, 3), a.Q[pick], a.omega[pick], a.omega[pick],
                               lambda lam: s.contact, np.ones(4, bool), "monodromy")
    assert list(mono.method) == [sc.MONODROMY] * 4        # along the expanded wheel orbit
    assert list(mono.stable) == [True, True, True, False]
    assert np.allclose(mono.monodromy_multiplier, bs.floquet_multiplier, rtol=0, atol=0.02)
    assert "keeps Hill" in sc.describe("hill+check", sc.MAX_MONODROMY_DOF + 1)
    assert sc.describe(True) == "Hill's method at every point"


@pytest.mark.parametrize("size, mode, expected", [
    (3, "hill+check", ("hill+check", "floquet")), (3, "floquet", ("floquet", "floquet")),
    (352, "hill", ("hill", "floquet")), (352, "hill+check", ("hill+check", "monodromy")),
    (352, "floquet", ("monodromy", "monodromy")),
    (352, "monodromy+check", ("monodromy", "monodromy")),
    (1000, "monodromy", ("hill", "floquet")), (1000, False, (None, "floquet"))])
def test_effective_mode_beyond_the_shooting(size, mode, expected):
    assert sc.effective_mode(mode, size) == expected
    text = sc.describe(mode, size)
    if size == 352 and mode != "hill":
        assert "beyond the shooting" in text and "linearised along the harmonic-balance" in text
    if size == 3:   # a stiff flow of few DOFs (a Craig-Bampton blade): as one of 352
        assert sc.effective_mode(mode, size, stiff=True) == sc.effective_mode(mode, 352)
        assert "too stiff for the event search" in sc.describe(mode, size, stiff=True)


def test_hill_checked_by_the_orbit_monodromy_where_the_shooting_is_out_of_reach(
        blade_curve, monkeypatch):
    """An FE blade's flow (hundreds of DOFs) is beyond the shooting: `hill+check` is
    then checked by the orbit monodromy.  Here the 3-DOF blade stands in for it (the
    shooting's limit lowered below its 3 DOFs): where Hill is wrong, the monodromy
    decides, and the flags equal those the exact multipliers decided."""
    from pipeline.solve.harmonic_balance import hbm
    from pipeline.solve.stability import methods as stability_modes
    monkeypatch.setattr(sc, "MAX_WHEEL_DOF", 2)
    monkeypatch.setattr(stability_modes, "MAX_WHEEL_DOF", 2)
    c, s = blade_curve, blade3()
    ok = np.flatnonzero(c.converged)
    bs = sc.branch_stability(hbm.setup(s, 10), c.Q[ok], c.omega[ok], c.omega[ok],
                             lambda lam: s.contact, np.ones(ok.size, bool), "hill+check",
                             amplitude=c.amplitude[ok])
    assert set(np.unique(bs.method)) <= {sc.HILL, sc.MONODROMY}   # (a lightly damped
    assert np.isnan(bs.floquet_multiplier).all()                 # blade: all checked)
    np.testing.assert_array_equal(bs.stable, c.stable[ok])
    hill_wrong = (c.hill_multiplier[ok] > 1.001) & c.stable[ok]
    assert hill_wrong.sum() >= 5 and (bs.method[hill_wrong] == sc.MONODROMY).all()
    assert "beyond the shooting" in bs.note


# ------------------------------------------------------------------ figure marks
def test_bifurcations_marked_by_type_in_the_amplitude_figure():
    import xarray as xr

    from pipeline.study.figures.plots import pyplot, response_curves_plot
    from pipeline.study.figures.response_figures import bifurcation_marks

    f = np.linspace(1.0, 2.0, 11)
    a = 1.0 + f
    st = np.where((f > 1.25) & (f < 1.75), 0.0, 1.0)
    b = xr.Dataset({"amplitude": ("point", a), "stable": ("point", st),
                    "converged": ("point", np.ones(11, bool)),
                    "bifurcation_frequency": ("bifurcation", [1.25, 1.75, np.nan]),
                    "bifurcation_type": ("bifurcation", np.array([2, 3, -1], np.int8))},
                   coords={"frequency": ("point", f)})
    marks = bifurcation_marks(b)
    assert [(m[0], m[2]) for m in marks] == [(1.25, 2), (1.75, 3)]
    assert marks[0][1] == pytest.approx(2.25)
    fig = response_curves_plot([("x", f, a, st, np.ones(11, bool))], marks=marks)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "period doubling" in labels and "Neimark-Sacker" in labels
    assert "fold bifurcation" not in labels
    pyplot().close(fig)


# ------------------------------------------------------------------ the monodromy along the HBM orbit
# (`orbit_floquet.along_orbit`) against the closed-form stuck limit, the exact orbit's
# multipliers (shooting + saltation product) and the blade where Hill is wrong; the
# `monodromy` and `monodromy+check` modes

@pytest.mark.parametrize("system, H, lo, hi", [(example1(2.0), 7, 150.0, 250.0),
                                               (example3(10.0), 14, 0.5, 1.6),
                                               (example3(-20.0), 14, 0.5, 1.6)])
def test_equals_the_exact_orbits_multipliers(system, H, lo, hi):
    """Stick-slip (Example 1) and separation (Example 3): the largest |mu| equals that of
    the exact periodic orbit to 2e-3 (measured 7e-5 .. 4.3e-4), the verdict everywhere."""
    c = frequency_response(system, H, lo, hi, stability=False, dense_output=False)
    for i in range(0, c.n_points, max(1, c.n_points // 12)):
        r, ref = along_orbit(system, c.omega[i], c.Q[i]), fq.from_hbm(system, c.omega[i], c.Q[i])
        assert r is not None and r.success and ref.orbit_converged
        assert r.max_modulus == pytest.approx(ref.max_modulus, abs=2e-3)
        assert r.verdict == ref.verdict


def test_stuck_limit_is_the_linear_systems():
    """Example 1 with a preload that keeps the contact stuck all period: the multipliers
    are exp(lam T) of the stuck linear system (the slider a neutral direction)."""
    s = example1(1e4)
    c = frequency_response(s, 5, 150.0, 250.0, stability=False, dense_output=False,
                           max_points=5)
    Om = c.omega[2]
    r = along_orbit(s, Om, c.Q[2])
    assert r is not None and r.n_events == 0 and r.neutral_sliders == (0,)
    K = np.asarray(s.K, float) + np.asarray(s.contact.ku)[0] * (s.Bt.T @ s.Bt) \
        + np.asarray(s.contact.kv)[0] * (s.Bn.T @ s.Bn)
    n = K.shape[0]
    Minv = np.linalg.inv(np.asarray(s.M, float))
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ np.asarray(s.C, float)]])
    exact = np.linalg.eigvals(expm(A * 2 * np.pi / Om))
    got = np.sort_complex(r.multipliers)
    assert np.allclose(got, np.sort_complex(exact), rtol=0, atol=1e-10)


def test_blade_where_hill_is_wrong(blade_curve):
    """The 3-DOF blade (H = 10): Hill calls stable orbits unstable; the orbit monodromy's
    verdict equals the exact orbit's at every point away from |mu| = 1.  The branch is
    the fixture's: the exact multipliers (`hill+check` runs them at every point of this
    lightly damped blade, as `floquet` would) and Hill's flags at its points."""
    from pipeline.solve.harmonic_balance import hbm
    c = blade_curve
    assert np.isfinite(c.floquet_multiplier[c.converged]).all()
    far = c.converged & (np.abs(c.floquet_multiplier - 1.0) > 1e-3)
    assert far.sum() >= 15
    mono_wrong = 0
    for i in np.flatnonzero(far):
        r = along_orbit(blade3(), c.omega[i], c.Q[i])
        mono_wrong += int((r.max_modulus < 1) != (c.floquet_multiplier[i] < 1))
    h = sc.branch_stability(hbm.setup(blade3(), 10), c.Q, c.omega, c.omega,
                            lambda lam: blade3().contact, c.converged, "hill")
    calm = (c.omega >= BLADE_STABLE[0]) & (c.omega <= 115.073)  # stable (time integration)
    hill_wrong = int(np.sum(~h.stable & calm & c.converged))
    assert mono_wrong == 0 and hill_wrong > 0


def monodromy_corpus(seeds, H, max_points):
    """(points compared, orbit-monodromy flags that differ from the exact multipliers')
    over the points whose max |mu| is outside 1 +- 1e-3."""
    compared = wrong = 0
    for seed in seeds:
        c, ref = corpus_case(seed, H, max_points)
        for i in np.flatnonzero(np.isfinite(ref) & (np.abs(ref - 1.0) > 1e-3)):
            r = along_orbit(random_system(seed)[0], c.omega[i], c.Q[i])
            compared += 1
            wrong += int(r is None or (r.max_modulus < 1) != (ref[i] < 1))
    return compared, wrong


def test_corpus_monodromy_equals_floquet():
    """The seeded corpus (10 systems, H = 3): the orbit monodromy's flag equals the exact
    multipliers' at every point away from |mu| = 1."""
    compared, wrong = monodromy_corpus(range(10), 3, 8)
    assert compared >= 50 and wrong == 0


@pytest.mark.slow
def test_corpus_monodromy_equals_floquet_large():
    """pipeline/solve/README.md's number: 40 systems, H = 5, up to 30 points each."""
    compared, wrong = monodromy_corpus(range(40), 5, 30)
    print(f"corpus (40 systems, H = 5): {compared} points compared, monodromy wrong at {wrong}")
    assert wrong == 0


def test_modes_decide_like_the_exact_multipliers():
    """Example 3 (two folds): `monodromy` gives Hill's flags, unstable exactly between
    the two turning points of Omega (the samples at the turning points, exponent ~ 0,
    are not judged), and both folds at a fraction of the cost; `monodromy+check`
    checks by Floquet only where max |mu| is near 1, at flag changes and at peaks,
    and reports which method decided."""
    s = example3(10.0)
    a = frequency_response(s, 14, 0.5, 1.6, stability="hill")
    b = frequency_response(s, 14, 0.5, 1.6, stability="monodromy")
    c = frequency_response(s, 14, 0.5, 1.6, stability="monodromy+check")
    assert np.array_equal(a.omega, b.omega) and np.array_equal(a.omega, c.omega)
    assert np.array_equal(a.stable, b.stable) and np.array_equal(b.stable, c.stable)
    dl = np.diff(b.omega)
    turning = np.flatnonzero(dl[:-1] * dl[1:] < 0) + 1
    assert len(turning) == 2
    assert np.all(~b.stable[turning[0] + 1:turning[1]])
    assert np.all(b.stable[:turning[0]]) and np.all(b.stable[turning[1] + 1:])
    assert set(np.unique(b.stability_method)) == {sc.MONODROMY}
    assert set(np.unique(c.stability_method)) == {sc.MONODROMY, sc.FLOQUET}
    near = (np.abs(np.log(b.monodromy_multiplier)) < sc.MONODROMY_MARGIN) & c.converged
    unchecked = near & (c.stability_method == sc.MONODROMY)
    for i in np.flatnonzero(unchecked):    # only a linear flow (no switch) goes unchecked
        assert along_orbit(s, c.omega[i], c.Q[i]).n_events == 0
    assert np.all(c.stability_method[near & ~unchecked] == sc.FLOQUET)
    assert np.allclose(b.bifurcation_parameter, a.bifurcation_parameter, rtol=0, atol=1e-5)


# ------------------------------------------------------------------ an FE blade
@pytest.mark.slow   # 29 s; the orbit monodromy beyond the shooting by default: the 3-DOF blade
def test_fe_blade_beyond_the_shooting_is_decided_by_the_orbit_monodromy():
    """A coarse solid blade (Craig-Bampton, 102 DOFs, 30 shroud-node contacts): its
    reduced model is too stiff for the event search (its boundary DOFs), so the
    shooting is out of reach and `floquet` runs as the orbit monodromy.  Where
    no contact switches, the flow is linear and its monodromy exp(AT) equals Hill's
    (both exact); through the stick-slip peak the two agree to 1e-3 (measured 2e-4)."""
    from pipeline.solve.harmonic_balance import hbm
    from pipeline.study.files.documents import parse_study

    root = Path(__file__).resolve().parents[3]
    text = (root / "studies" / "blade_shroud_contact.toml").read_text()
    text = text[:text.index("[quick.scene.blade]")]
    for old, new in [("craig_bampton_modes = 40", "craig_bampton_modes = 6"),
                     ("n_chord = 8\nn_thick = 2\nn_span = 20",
                      "n_chord = 2\nn_thick = 1\nn_span = 4"),
                     ("preload = [0.3, 3.0, 30.0, 1000.0]", "preload = [3.0]")]:
        assert old in text
        text = text.replace(old, new)
    study = parse_study(text, file="tiny_blade.toml")
    system = study.system(study.sweep.cases()[0][1])
    assert sc.flow_dof(system) == 102    # below MAX_WHEEL_DOF, but stiff:
    assert sc.shooting_samples(system, np.array([2e3])) > 100 * sc.MAX_SHOOTING_SAMPLES
    # down through the stick-slip peak at 315.6 Hz and the folds at 315.3 and 335.2 Hz
    c = frequency_response(system, 3, 2 * np.pi * 380.0, 2 * np.pi * 300.0, stability=False,
                           peak_dofs=[study.scene.dof_index("response.y")])
    ipk = int(np.argmax(c.amplitude[:, 0]))
    assert abs(c.omega[ipk] / (2 * np.pi) - 315.6) < 0.1
    pick = np.array([0, ipk - 3, ipk, ipk + 3, c.n_points - 1])
    bs = sc.branch_stability(hbm.setup(system, 3), c.Q[pick], c.omega[pick], c.omega[pick],
                             lambda lam: system.contact, np.ones(pick.size, bool), "floquet")
    assert (bs.method == sc.MONODROMY).all() and "beyond the shooting" in bs.note
    hill = sc.branch_stability(hbm.setup(system, 3), c.Q[pick], c.omega[pick], c.omega[pick],
                               lambda lam: system.contact, np.ones(pick.size, bool), "hill")
    from pipeline.contact.exact import periodic_segments
    switching = np.array([np.any(~np.isin(periodic_segments(
        system.Bt @ c.Q[i], system.Bn @ c.Q[i], system.contact)["regime"], (0, 1)))
        for i in pick])                      # some element neither open nor stuck all along
    assert list(switching) == [False, True, True, True, False]
    linear = ~switching
    assert np.allclose(bs.monodromy_multiplier[linear], hill.hill_multiplier[linear],
                       rtol=0, atol=1e-4)
    assert np.allclose(bs.monodromy_multiplier, hill.hill_multiplier, rtol=0, atol=1e-3)
    assert bs.stable.all()
    # the exact flow integrated over one period from the HBM state at the peak (event
    # search graded to the stiff modes still present): the same switches and multipliers.
    # The leading pair is real there, near its collision, where each modulus moves like
    # the square root of a perturbation (0.967 / 0.934 against 0.953 / 0.947): their
    # product, smooth, is compared
    i = pick[2]
    ex = np.abs(exact_period_multipliers(system, c.omega[i], c.Q[i]).multipliers)
    orb = along_orbit(system, c.omega[i], c.Q[i])
    mo = np.abs(orb.multipliers)
    assert abs(ex[0] * ex[1] - mo[0] * mo[1]) < 1e-3 and max(ex[0], mo[0]) < 0.97
    np.testing.assert_allclose(ex[2:8], mo[2:8], rtol=0, atol=2e-3)


def exact_period_multipliers(system, omega, Q):
    """`floquet.monodromy` of one period of the event-driven integration started on the
    HBM state (no shooting): the exact flow's multipliers about the HBM orbit."""
    from pipeline.solve.time_integration.piecewise import PiecewiseModel
    q0, qd0, w0 = fq.hbm_initial_state(system, omega, Q)
    x0 = np.concatenate([q0, qd0])
    st, w = PiecewiseModel(system, omega).classify(x0, w0)
    return fq.monodromy(system, omega, x0, w, st, 1e-6)


@pytest.mark.slow
def test_fe_blade_quick_mesh_exact_period_sides_with_the_orbit_monodromy_not_hill():
    """The quick mesh of `blade_shroud_contact` (208 DOFs, 54 contacts, 30 N) at 2559.8
    rad/s, just above its peak: Hill's resonant pair 0.962 (0.9624-0.9628 at H = 3-7),
    the orbit monodromy 0.9332, one period of the exact flow from the HBM state 0.9332
    (about a minute)."""
    from pipeline.solve.harmonic_balance import hbm
    from pipeline.study.files.documents import load_study

    study = load_study(Path(__file__).resolve().parents[3] / "studies"
                       / "blade_shroud_contact.toml", quick=True)
    system = study.system(study.sweep.cases()[0][1])
    c = frequency_response(system, 3, 2 * np.pi * 385.0, 2 * np.pi * 425.0, stability=False,
                           peak_dofs=[study.scene.dof_index(d) for d in study.output.dofs])
    i = int(np.argmin(np.abs(c.omega - 2559.81)))
    assert abs(c.omega[i] - 2559.81) < 1.0
    hill = sc.branch_stability(hbm.setup(system, 3), c.Q[i:i + 1], c.omega[i:i + 1],
                               c.omega[i:i + 1], lambda lam: system.contact,
                               np.ones(1, bool), "hill").hill_multiplier[0]
    orb = along_orbit(system, c.omega[i], c.Q[i])
    ex = exact_period_multipliers(system, c.omega[i], c.Q[i])
    assert abs(ex.max_modulus - orb.max_modulus) < 1e-3 and ex.n_events == orb.n_events
    np.testing.assert_allclose(np.abs(ex.multipliers[:8]), np.abs(orb.multipliers[:8]),
                               rtol=0, atol=1e-3)
    assert hill - ex.max_modulus > 0.02


def shrouded_row(n0):
    """Six 2-DOF blades (root, tip) on a ground, tips coupled by springs, one Yang-Menq
    element between neighbouring tips (tangential: tip_i - tip_i+1; normal: root_i,
    so the normal load varies), 1 % damping at the first mode, forced at two tips."""
    rng = np.random.default_rng(0)
    B = 6
    n = 2 * B
    K, M = np.zeros((n, n)), np.diag(rng.uniform(0.8, 1.2, n))
    for i in range(B):
        a, b = 2 * i, 2 * i + 1
        kg, kab = rng.uniform(0.9, 1.1) * 2e4, rng.uniform(0.9, 1.1) * 1e4
        K[a, a] += kg
        K[np.ix_([a, b], [a, b])] += kab * np.array([[1.0, -1.0], [-1.0, 1.0]])
    for i in range(B - 1):
        K[np.ix_([2 * i + 1, 2 * i + 3], [2 * i + 1, 2 * i + 3])] += 2e3 * np.array(
            [[1.0, -1.0], [-1.0, 1.0]])
    w1 = np.sqrt(np.linalg.eigvals(np.linalg.solve(M, K)).real.min())
    E = B - 1
    Bt, Bn = np.zeros((E, n)), np.zeros((E, n))
    for i in range(E):
        Bt[i, 2 * i + 1], Bt[i, 2 * i + 3], Bn[i, 2 * i] = 1.0, -1.0, 1.0
    F = np.zeros((n, 2), complex)
    F[1, 1], F[5, 1] = 3.0, 1.5
    contact = YangMenq(np.full(E, 8e3), np.full(E, 4e3), np.full(E, 0.3), np.full(E, n0))
    return System(M=M, C=2 * 0.01 / w1 * K, K=K, Bt=Bt, Bn=Bn, contact=contact,
                  forcing=F), w1


@pytest.mark.slow   # 33 s; the orbit monodromy against the exact multipliers by default: the corpus
def test_many_contacts_monodromy_equals_the_exact_multipliers_where_hill_overestimates():
    """Five stick-slip contacts with a varying normal load (12 DOFs): the orbit
    monodromy is within 2e-3 of the exact orbit's largest |mu| (measured 1.9e-3), while
    Hill's multiplier lies 0.01-0.03 above both (the sign and size of the gap on the
    FE blade of `blade_shroud_contact`, where no exact reference runs)."""
    from pipeline.solve.harmonic_balance import hbm
    s, w1 = shrouded_row(0.5)
    c = frequency_response(s, 5, 0.85 * w1, 1.3 * w1, stability=False, dense_output=False,
                           peak_dofs=[1])
    pick = np.unique(np.linspace(0, c.n_points - 1, 14).round().astype(int))[[0, 2, 7, 10]]
    hill = sc.branch_stability(hbm.setup(s, 5), c.Q[pick], c.omega[pick], c.omega[pick],
                               lambda lam: s.contact, np.ones(pick.size, bool), "hill")
    mono = np.array([along_orbit(s, c.omega[i], c.Q[i]).max_modulus for i in pick])
    exact = []
    for i in pick:
        r = fq.from_hbm(s, c.omega[i], c.Q[i])
        assert r.orbit_converged and r.n_events >= 16        # every contact sticks and slips
        exact.append(r.max_modulus)
    assert np.allclose(mono, exact, rtol=0, atol=2e-3)
    gap = hill.hill_multiplier - np.array(exact)
    assert (gap > 0.01).all() and (gap < 0.04).all(), gap


def test_stiffness_measure_only_where_a_check_could_shoot(monkeypatch):
    """`shooting_samples` is paid only by the modes that might shoot, and a singular
    mass matrix counts as beyond the shooting, not as an error."""
    from pipeline.solve.harmonic_balance import hbm
    s = example1(2.0)
    # closed form: (2 pi / 150) (6 / pi) (c/m + sqrt((k + ku) / m)) samples a period
    lam = 0.3 + np.sqrt(3.55e4 + 1e4)
    assert sc.shooting_samples(s, np.array([150.0, 200.0])) == pytest.approx(12 / 150 * lam,
                                                                            rel=1e-12)
    calls = []

    def counted(system, omega):
        calls.append(omega.size)
        return 17.0

    c = frequency_response(s, 3, 150.0, 152.0, stability=False, dense_output=False)
    args = (hbm.setup(s, 3), c.Q[:2], c.omega[:2], c.omega[:2], lambda lam: s.contact,
            np.ones(2, bool))
    monkeypatch.setattr(sc, "shooting_samples", counted)
    for mode, n in (("hill", 0), (False, 0), ("hill+check", 1), ("monodromy+check", 2)):
        sc.branch_stability(*args, mode)
        assert len(calls) == n, mode
    monkeypatch.undo()
    assert sc.shooting_samples(replace(s, M=np.zeros_like(s.M)), np.array([150.0])) == np.inf
    empty = sc.branch_stability(hbm.setup(s, 3), np.zeros((0, s.n_dof, 7)), np.zeros(0),
                                np.zeros(0), lambda lam: s.contact, np.zeros(0, bool),
                                "hill+check")
    assert empty.stable.size == 0
