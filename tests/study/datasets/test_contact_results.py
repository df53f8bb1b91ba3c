"""What the preload becomes and what the contacts do: the static normal load
n0 + kv v0, a requested static normal load, per-contact cycle results."""
from __future__ import annotations

import numpy as np
import pytest

from pipeline.model.static_load import static_normal_load
from pipeline.study.datasets.response_dataset import to_dataset
from pipeline.study.files.documents import parse_study

K1, K2, KV, KU, MU = 4.0e4, 6.0e4, 2.0e4, 3.0e4, 0.3

TWO_MASSES = f"""
[study]
title = "two masses pressed apart by one contact"

[scene]
model = "lumped"
effects = ["friction", "normal_load_variation", "separation"]
dofs = ["x1", "x2", "y1"]

[scene.matrices]
M = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]
C = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]
K = [[{K1}, 0.0, 0.0], [0.0, {K2}, 0.0], [0.0, 0.0, {K1}]]

[[scene.contact]]
name = "gap"
tangential = ["y1"]
normal = ["x1", "-x2"]
ku = {KU}
kv = {KV}
mu = {MU}

[[scene.excitation]]
dof = "y1"
amplitude = 1.0

[sweep]
{{sweep}}
frequency = {{ start = 100.0, stop = 300.0, unit = "rad/s" }}

[solver]
harmonics = 3

[output]
dofs = ["x1", "y1"]
"""


def two_masses(sweep: str):
    return parse_study(TWO_MASSES.replace("{sweep}", sweep), file="two_masses.toml")


def hand_static_load(n0):
    """Two masses on springs k1, k2 to ground, the element between them with
    v = x1 - x2 (v > 0 closes).  The contact force on the structure is -Bn^T n,
    so the static balance is k1 x1 = -n, k2 x2 = +n with n = n0 + kv v:
        v = x1 - x2 = -n (1/k1 + 1/k2) = -n / k_eff,   k_eff = k1 k2 / (k1 + k2),
        n = n0 + kv v = n0 - kv n / k_eff  =>  n = n0 k_eff / (k_eff + kv),
        v0 = -n0 / (k_eff + kv).
    The tangential DOF y1 carries no static force (a stuck slider rests in the
    middle of its band)."""
    k_eff = K1 * K2 / (K1 + K2)
    v0 = -n0 / (k_eff + KV)
    return n0 + KV * v0


def test_static_normal_load_of_two_masses_is_the_hand_computation():
    study = two_masses("preload = [10.0, 250.0]")
    for _, case in study.sweep.cases():
        s = static_normal_load(study.system(case))
        assert s.shape == (1,)
        assert s[0] == pytest.approx(hand_static_load(case["preload"]), rel=1e-12)
        assert s[0] < case["preload"]            # the structure gives way


def test_dataset_stores_the_static_normal_load_per_pair_and_per_contact():
    study = two_masses("preload = [10.0, 250.0]")
    ds = to_dataset(study, [None, None], errors=["not run", "not run"])
    want = np.array([hand_static_load(10.0), hand_static_load(250.0)])
    np.testing.assert_allclose(ds.static_normal_load.sel(contact="gap").values, want, rtol=1e-12)
    np.testing.assert_allclose(ds.static_normal_load_pair.values[:, 0], want, rtol=1e-12)
    np.testing.assert_allclose(ds.preload_total.values[:, 0], [10.0, 250.0], rtol=1e-15)
    assert ds.static_normal_load.attrs["units"] == "N"
    assert "n0 + kv v0" in ds.static_normal_load.attrs["long_name"]
    assert ds.attrs["preload_given"] == "n0"


def assert_unilateral(system, s):
    """The static loads s (E,) [N] checked on their own terms: applied to the structure
    as forces, K0 q = F0 - Bn0^T s (Bn0 = Bn + Bn_next on a cyclic sector), they give
    n0 + kv Bn0 q = s where s > 0, and <= 0 (a gap) where s = 0."""
    from pipeline.model.system import contact_set, coupled_stiffness, dense

    cs = contact_set(system)
    Bn = dense(cs.maps[-1]) + (dense(cs.maps_next[-1]) if cs.maps_next else 0.0)
    K0 = dense(coupled_stiffness(system, 0.0))
    F0 = np.asarray(system.forcing)[:, 0].real
    q = np.linalg.solve(K0, F0 - Bn.T @ s)
    trial = cs.elements.n0 + cs.elements.kv * (Bn @ q)
    scale = np.abs(cs.elements.n0).max()
    assert np.all(s >= 0)
    np.testing.assert_allclose(trial[s > 0], s[s > 0], rtol=1e-8, atol=1e-9 * scale)
    assert np.all(trial[s == 0] <= 1e-9 * scale)


P_STATIC = 100.0   # N, static load on x2 pulling the masses apart


def pulled_apart(sweep: str):
    """TWO_MASSES with a static load P on x2 (v = x1 - x2 > 0 closes: P opens)."""
    text = TWO_MASSES.replace("{sweep}", sweep).replace("[sweep]", f"""[[scene.excitation]]
dof = "x2"
amplitude = {P_STATIC}
harmonic = 0

[sweep]""")
    return parse_study(text, file="pulled_apart.toml")


def hand_pulled_load(n0):
    """(s [N], closed) of the element with P on x2, by hand.  Closed: k1 x1 = -n,
    k2 x2 = n + P, so v = x1 - x2 = -n / k_eff - P / k2 and n = n0 + kv v gives
        n = (n0 - kv P / k2) k_eff / (k_eff + kv);
    a pair that would pull (n < 0) is open: n = 0 (the gap v0 = -P / k2)."""
    k_eff = K1 * K2 / (K1 + K2)
    n = (n0 - KV * P_STATIC / K2) * k_eff / (k_eff + KV)
    return max(n, 0.0), n > 0


def test_static_normal_load_is_compressive_and_zero_once_the_pair_opens():
    """n0 = 50 N: (50 - 2e4 * 100 / 6e4) 2.4e4 / 4.4e4 = 9.0909 N, in contact; n0 = 20 N
    would pull (-7.2727 N): open, 0 N, no pair in contact."""
    study = pulled_apart("preload = [50.0, 20.0]")
    ds = to_dataset(study, [None, None], errors=["not run", "not run"])
    want = [hand_pulled_load(50.0), hand_pulled_load(20.0)]
    assert want[0][0] == pytest.approx(9.0909090909, rel=1e-9) and want[1] == (0.0, False)
    np.testing.assert_allclose(ds.static_normal_load_pair.values[:, 0], [w[0] for w in want],
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ds.static_normal_load.sel(contact="gap").values,
                               [w[0] for w in want], rtol=1e-12, atol=1e-12)
    assert ds.static_pairs_in_contact.sel(contact="gap").values.tolist() == [1, 0]
    assert ds.static_pairs_in_contact.attrs["units"] == "1"


def test_stuck_limit_has_only_the_closed_pairs():
    """natural_frequency_stuck [rad/s]: n0 = 50 N (closed) adds ku on y1 and kv between
    x1 and x2, K = [[k1 + kv, -kv], [-kv, k2 + kv]] with M = diag(1, 2) kg; n0 = 20 N
    (open) is the bare structure: sqrt(k1 / 1), sqrt(k2 / 2), sqrt(k1 / 1) -- the open
    limit, which stays as it was."""
    study = pulled_apart("preload = [50.0, 20.0]")
    ds = to_dataset(study, [None, None], errors=["not run", "not run"])
    a, b, c = (K1 + KV) / 1.0, (K2 + KV) / 2.0, KV / np.sqrt(2.0)   # M^-1/2 K M^-1/2
    mid, half = (a + b) / 2, np.hypot((a - b) / 2, c)
    closed = np.sort(np.sqrt([mid - half, mid + half, K1 + KU]))
    free = np.sort(np.sqrt([K1, K2 / 2.0, K1]))
    np.testing.assert_allclose(ds.natural_frequency_stuck.values[0], closed, rtol=1e-10)
    np.testing.assert_allclose(ds.natural_frequency_stuck.values[1], free, rtol=1e-10)
    np.testing.assert_allclose(ds.natural_frequency_free.values, [free, free], rtol=1e-10)


def test_a_face_with_pairs_in_tension_sums_only_its_compressive_pairs():
    """The shrouded disk at 8,000 rpm with a 0.1 mm gap (quick): the speed closes a few of
    the 15 pairs, the others would pull.  The face total is the sum of the compressive
    pairs and the count the pairs with a load; the state is checked on its own terms:
    the reported loads applied to the structure as forces, K0 q = F0 - Bn0^T s, give
    n0 + kv Bn0 q = s where s > 0 and <= 0 (a gap) where s = 0."""
    from pathlib import Path

    from pipeline.model.static_load import static_normal_load
    from pipeline.model.system import contact_set

    text = (Path(__file__).resolve().parents[3] / "studies" /
            "shrouded_disk_speed.toml").read_text()
    study = parse_study(text, file="shrouded_disk_speed.toml", quick=True)
    cases = [(idx, c) for idx, c in study.sweep.cases() if c["speed"] == 8000.0]
    system = study.system(cases[0][1])
    E = contact_set(system).elements.size
    full = [None] * len(study.sweep.cases())
    ds = to_dataset(study, full, errors=["not run"] * len(full)).sel(speed=8000.0)
    s = ds.static_normal_load_pair.values
    assert s.shape == (E,) and np.all(s >= 0)
    n_in = int((s > 0).sum())
    assert 0 < n_in < E                                   # some pairs open
    assert (static_normal_load(system) < 0).any()      # every pair closed: some would pull
    assert int(ds.static_pairs_in_contact.sum()) == n_in
    assert float(ds.static_normal_load.sum()) == pytest.approx(s[s > 0].sum(), rel=1e-12)
    assert_unilateral(system, s)


def test_dataset_records_each_elements_contact_parameters_as_solved():
    """ku, kv, mu per element and case, in SI units, from the systems solved (a swept
    mu varies along its axis; a study changed in Python records its own numbers)."""
    from dataclasses import replace
    study = two_masses("preload = [10.0]\nmu = [0.1, 0.4]")
    ds = to_dataset(study, [None, None], errors=["not run", "not run"])
    assert ds.mu_pair.dims == ("preload", "mu", "pair")
    np.testing.assert_array_equal(ds.mu_pair.values[0, :, 0], [0.1, 0.4])
    np.testing.assert_array_equal(ds.ku_pair.values[0, :, 0], [KU, KU])
    np.testing.assert_array_equal(ds.kv_pair.values[0, :, 0], [KV, KV])
    assert [ds[f"{k}_pair"].attrs["units"] for k in ("ku", "kv", "mu")] == ["N/m", "N/m", "1"]
    s2 = two_masses("preload = [10.0]")
    c = s2.scene.contacts[0]
    s2 = replace(s2, scene=replace(s2.scene, contacts=(replace(c, ku=2 * KU),)))
    ds2 = to_dataset(s2, [None], errors=["not run"])
    assert ds2.ku_pair.values[0, 0] == 2 * KU


# ---------------------------------------------------------------------------
# A requested static normal load (sweep.normal_load)
# ---------------------------------------------------------------------------

def test_requested_static_load_gives_the_preload_of_the_hand_computation():
    study = two_masses("normal_load = [10.0, 250.0]")
    for _, case in study.sweep.cases():
        system = study.system(case)
        s = static_normal_load(system)
        assert s[0] == pytest.approx(case["normal_load"], rel=1e-10)
        # inverse of hand_static_load: n0 = s (k_eff + kv) / k_eff
        k_eff = K1 * K2 / (K1 + K2)
        assert system.contact.n0[0] == pytest.approx(case["normal_load"] * (k_eff + KV) / k_eff,
                                                     rel=1e-12)
    ds = to_dataset(study, [None, None], errors=["not run", "not run"])
    assert ds.attrs["preload_given"] == "static_normal_load"
    np.testing.assert_allclose(ds.static_normal_load.values[:, 0], [10.0, 250.0], rtol=1e-10)
    assert np.all(ds.preload_total.values[:, 0] > ds.static_normal_load.values[:, 0])


def tilted_blade(sweep_line: str):
    """blade_shroud_contact (quick) with 1,000 N static along x at the excitation node:
    the shroud faces tilt against their walls, and with 3 N per face some node pairs
    would pull."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[3] / "studies" /
            "blade_shroud_contact.toml").read_text()
    text = "\n".join(ln for ln in text.splitlines() if not ln.startswith("optimum_preload"))
    text = text.replace("[sweep]", """[[scene.excitation]]
set = "excitation"
direction = [1.0, 0.0, 0.0]
amplitude = 1000.0
harmonic = 0

[sweep]""")
    text = text.replace("preload = [0.3, 3.0, 30.0, 1000.0]", sweep_line).replace(
        "preload = [30.0]", sweep_line)
    return parse_study(text, file="tilted_blade.toml", quick=True)


def test_requested_static_load_counts_only_the_pairs_in_contact():
    """normal_load = 3 N per face on the tilted blade: the preload is solved with the
    pairs in contact (iterated with the set), so the compressive pairs' loads sum to
    3 N per face, to 1e-10, and the state is unilateral (`assert_unilateral`)."""
    from pipeline.model.static_load import contact_owner, face_totals

    study = tilted_blade("normal_load = [3.0]")
    system = study.system(study.sweep.cases()[0][1])
    ds = to_dataset(study, [None], errors=["not run"])
    s = ds.static_normal_load_pair.values[0]
    assert_unilateral(system, s)
    owner = contact_owner(study.scene)
    np.testing.assert_allclose(face_totals(s, owner, 2), [3.0, 3.0], rtol=1e-10)
    np.testing.assert_allclose(ds.static_normal_load.values[0], [3.0, 3.0], rtol=1e-10)
    count = ds.static_pairs_in_contact.values[0]
    assert np.all((0 < count) & (count < 27))                 # some of each face's 27 open
    np.testing.assert_array_equal(count, np.bincount(owner[s > 0], minlength=2))


def test_requested_static_load_that_does_not_settle_is_refused():
    """The active set changes with n0: an iteration cut short says so."""
    from pipeline.model.static_load import contact_owner, preload_for_unilateral_load
    from pipeline.model.system import contact_set

    study = tilted_blade("preload = [1.0]")
    unit = study.system(study.sweep.cases()[0][1])
    el = contact_set(unit).elements
    with pytest.raises(ValueError, match=r"3 N per contact did not settle: the elements in "
                                         r"contact still change after 1 sweeps"):
        preload_for_unilateral_load(unit, contact_owner(study.scene), el.n0, [3.0, 3.0],
                                    max_sweeps=1)


@pytest.mark.parametrize("name", ["shrouded_disk", "blade_shroud_contact"])
def test_requested_static_load_is_recovered_per_face_on_fe_scenes(name):
    """Face totals of n0 + kv v0 over every node (pair) of each face, the FE blade
    of two faces against walls and the cyclic shroud pair, to 1e-10."""
    from pathlib import Path
    from pipeline.model.static_load import contact_owner, face_totals

    text = (Path(__file__).resolve().parents[3] / "studies" / f"{name}.toml").read_text()
    text = text.replace("preload = [", "normal_load = [")
    text = "\n".join(ln for ln in text.splitlines() if not ln.startswith("optimum_preload"))
    study = parse_study(text, file=f"{name}.toml", quick=True)
    owner = contact_owner(study.scene)
    for _, case in study.sweep.cases()[:2]:
        system = study.system(case)
        s = face_totals(static_normal_load(system), owner, len(study.scene.contacts))
        np.testing.assert_allclose(s, case["normal_load"], rtol=1e-10)
        n0 = face_totals(system.contact.n0, owner, len(study.scene.contacts))
        assert np.all(n0 > s)                   # the shroud gives way under its preload


# ---------------------------------------------------------------------------
# What the contacts do over a cycle (exact transition times)
# ---------------------------------------------------------------------------

from pipeline.contact import YangMenq                           # noqa: E402
from pipeline.contact.period_results import cycle_results                 # noqa: E402
from pipeline.contact.exact import history                       # noqa: E402


@pytest.mark.parametrize("a_over_slip", [0.5, 1.0, 1.5, 4.0, 40.0])
def test_jenkins_energy_is_the_closed_form(a_over_slip):
    """1-DOF Jenkins element (kv = 0), u = a cos tau: it sticks while |u - w| <
    mu n/ku; for a > mu n/ku the loop is a parallelogram of area
    4 mu n (a - mu n/ku), and each half period sticks for the reversal 2 mu n/ku,
    a (1 - cos tau_s) = 2 mu n / ku.  For a <= mu n/ku it never slips (0 J)."""
    ku, mu, n = 1.0e4, 0.5, 10.0
    d = mu * n / ku
    a = a_over_slip * d
    r = cycle_results(np.array([[0.0, a, 0.0, 0.0, 0.0]]), np.zeros((1, 5)),
                      YangMenq(ku=ku, kv=0.0, mu=mu, n0=n))
    if a <= d:
        assert r["energy"][0] == 0.0 and r["stick"][0] == 1.0
        return
    assert r["energy"][0] == pytest.approx(4 * mu * n * (a - d), rel=1e-12)
    tau_s = np.arccos(1.0 - 2.0 * d / a)
    assert r["stick"][0] == pytest.approx(tau_s / np.pi, rel=1e-10)
    assert r["slip"][0] == pytest.approx(1.0 - tau_s / np.pi, rel=1e-10)
    assert r["normal_mean"][0] == pytest.approx(n, rel=1e-15) and r["normal_amplitude"][0] == 0


def test_energy_fractions_and_normal_load_against_a_sampled_period():
    """Yang-Menq elements with variable normal load, separation, and one frictionless
    element (mu = 0): the dissipated energy against the loop integral
    contour f_u du of the exact time history sampled at 2^18 points
    (trapezoidal rule, error O(h^2) ~ 1e-9), the state fractions against the sampled
    states, the normal force's mean and half peak-to-peak against the samples."""
    rng = np.random.default_rng(7)
    E, H = 6, 3
    U = rng.normal(size=(E, 2 * H + 1)) * 1e-3
    V = rng.normal(size=(E, 2 * H + 1)) * 1e-3
    el = YangMenq(ku=1.0e4, kv=2.0e4, mu=np.array([0.3, 0.3, 0.3, 0.3, 0.3, 0.0]),
                  n0=np.array([5.0, 10.0, 20.0, 40.0, 1000.0, 10.0]))
    r = cycle_results(U, V, el)
    K = 1 << 18
    tau = 2 * np.pi * np.arange(K + 1) / K
    h = history(U, V, el, tau)
    loop = np.sum(0.5 * (h["fu"][:, 1:] + h["fu"][:, :-1]) * np.diff(h["u"], axis=1), axis=1)
    assert np.all(r["energy"][:4] > 1e-3)                  # these slip
    np.testing.assert_allclose(r["energy"][:4], loop[:4], rtol=1e-8)
    assert r["energy"][4] == 0.0 and r["stick"][4] == 1.0  # 1000 N: stuck
    assert r["energy"][5] == 0.0 and abs(loop[5]) < 1e-10   # frictionless
    total = r["stick"] + r["slip"] + r["separation"]
    np.testing.assert_allclose(total, 1.0, rtol=1e-13)
    st = h["state"][:, :-1]
    sampled = {"stick": st == 1, "slip": (st == 2) | (st == 3), "separation": st == 0}
    for k, mask in sampled.items():
        np.testing.assert_allclose(r[k], mask.mean(axis=1), atol=20.0 / K)
    assert np.all(r["separation"][[0, 2]] > 0.2)           # these separate
    fv = h["fv"][:, :-1]
    np.testing.assert_allclose(r["normal_mean"], fv.mean(axis=1), rtol=1e-8)
    np.testing.assert_allclose(r["normal_amplitude"], 0.5 * (fv.max(1) - fv.min(1)), rtol=1e-8)


def test_dataset_energy_balances_the_input_work_at_every_converged_point():
    """Harmonic balance makes the work of the load over a cycle equal the viscous
    and friction work exactly (the balanced residual is orthogonal to q', which has
    only harmonics <= H; stiffness and inertia do no net work), so
        contour F . dq = Omega pi sum_h q'_h^T C q'_h + sum_e W_e
    (q' = dq/dtau, tau = Omega t) checks the stored dissipated energy per contact
    at every converged point, up to the residual tolerance.  The fractions sum to 1."""
    from pipeline.fourier.harmonics import derivative
    from pipeline.solve.response.response import frequency_response

    study = two_masses("preload = [10.0, 40.0]")
    curves = [frequency_response(study.system(case), 3, 180.0, 320.0, stability=False,
                                 tol_rel=1e-10, dense_output=False)
              for _, case in study.sweep.cases()]
    ds = to_dataset(study, curves)
    for k, ((_, case), c) in enumerate(zip(study.sweep.cases(), curves)):
        system = study.system(case)
        F = system.forcing_coefficients(3)
        W = ds.dissipated_energy.isel(preload=k, contact=0).values
        ok = ds.converged.isel(preload=k).values
        assert ok.sum() > 10 and np.all(np.isfinite(W[ok])) and np.all(np.isnan(W[~ok]))
        assert W[ok].max() > 1e-4                          # the contact slips somewhere
        for i in np.flatnonzero(ok):
            dQ = derivative(c.Q[i])
            work_in = np.pi * np.sum(F[:, 1:] * dQ[:, 1:])
            viscous = c.omega[i] * np.pi * np.einsum("ic,ij,jc->", dQ[:, 1:], system.C,
                                                     dQ[:, 1:])
            assert work_in == pytest.approx(viscous + W[i], rel=1e-8, abs=1e-14)
        frac = (ds.stick_fraction + ds.slip_fraction + ds.separation_fraction).isel(preload=k)
        np.testing.assert_allclose(frac.values[ok], 1.0, rtol=1e-12)
        np.testing.assert_allclose(ds.dissipated_energy_pair.isel(preload=k).values[ok, 0],
                                   W[ok], rtol=1e-15)


def test_response_rebuilt_from_its_stored_coefficients_has_the_stored_amplitude():
    """x(t) = sum_h c_h cos(h W t) + s_h sin(h W t) from `harmonic_coefficient`,
    sampled finely: its (max - min)/2 is `amplitude` (both of the H-harmonic
    series), and hypot(c_h, s_h) is `harmonic_amplitude`."""
    from pipeline.solve.response.response import frequency_response

    study = two_masses("preload = [10.0]")
    case = study.sweep.cases()[0][1]
    curve = frequency_response(study.system(case), 3, 180.0, 320.0, stability=False,
                               tol_rel=1e-10, dense_output=False)
    ds = to_dataset(study, [curve])
    hc = ds.harmonic_coefficient.isel(preload=0)
    assert hc.dims == ("point", "dof", "harmonic", "component") and hc.attrs["units"] == "m"
    ok = ds.converged.isel(preload=0).values
    tau = 2 * np.pi * np.arange(4096) / 4096
    h = hc.harmonic.values
    c, s = hc.sel(component="cos").values[ok], hc.sel(component="sin").values[ok]
    x = (np.einsum("pdh,ht->pdt", c, np.cos(np.outer(h, tau)))
         + np.einsum("pdh,ht->pdt", s, np.sin(np.outer(h, tau))))
    half = 0.5 * (x.max(axis=-1) - x.min(axis=-1))
    amp = ds.amplitude.isel(preload=0).values[ok]
    # 4096 samples of a 3-harmonic series: the sampled extremes are within
    # (3 * 2 pi / 4096)^2 / 2 ~ 1e-5 of the exact ones, relative to the amplitude
    np.testing.assert_allclose(half, amp, rtol=2e-5)
    assert np.all(half <= amp * (1 + 1e-12))
    np.testing.assert_allclose(np.hypot(c, s), ds.harmonic_amplitude.isel(preload=0).values[ok],
                               rtol=1e-14, atol=1e-300)
    assert np.all(hc.sel(component="sin", harmonic=0).values[ok] == 0.0)


def test_contact_motions_are_the_harmonic_balance_motions_on_a_cyclic_sector():
    """The dataset's U, V of every element (with the next sector's motion shifted by
    phi = 2 pi EO / N) equal the harmonic balance's own `hbm.contact_motion`."""
    from pathlib import Path
    from pipeline.solve.harmonic_balance import hbm
    from pipeline.study.datasets.contact_dataset import contact_motions
    from pipeline.study.files.documents import load_study

    study = load_study(Path(__file__).resolve().parents[3] / "studies" / "shrouded_disk.toml",
                       quick=True)
    system = study.system(study.sweep.cases()[0][1])
    assert system.cyclic is not None
    H = 2
    Q = np.random.default_rng(3).normal(size=(3, system.n_dof, 2 * H + 1))
    U, V = contact_motions(system, Q)
    prob = hbm.setup(system, H)
    for p in range(3):
        Ue, Ve = hbm.contact_motion(prob, Q[p][prob.c])
        np.testing.assert_allclose(U[p], Ue, rtol=1e-12, atol=1e-12 * np.abs(Ue).max())
        np.testing.assert_allclose(V[p], Ve, rtol=1e-12, atol=1e-12 * np.abs(Ve).max())


def test_checker_accepts_the_contact_variables_and_names_a_broken_one():
    from pipeline.solve.response.response import frequency_response
    from pipeline.study.datasets.conformance import problems

    study = two_masses("preload = [10.0]")
    curve = frequency_response(study.system(study.sweep.cases()[0][1]), 3, 180.0, 320.0,
                               stability="hill", tol_rel=1e-10, dense_output=False)
    ds = to_dataset(study, [curve])
    assert problems(ds) == []
    bad = ds.copy(deep=True)
    bad["dissipated_energy"][...] = bad["dissipated_energy"] * 1.5
    assert any("'dissipated_energy' is not the sum" in p for p in problems(bad))
    bad = ds.copy(deep=True)
    bad["stick_fraction"][...] = bad["stick_fraction"] + 0.1
    assert any("must be 1" in p for p in problems(bad))
    bad = ds.copy(deep=True)
    bad.attrs["preload_given"] = "nominal"
    assert any("preload_given" in p for p in problems(bad))


def test_hysteresis_figure_draws_the_contact_loop_with_its_energy(tmp_path):
    """The face-total loop at the peak: for a one-element contact it is the
    element's loop, whose enclosed area (contour f du, trapezoidal over the drawn
    samples) is the stored dissipated energy; the legend gives it in J/cycle."""
    from pipeline.solve.response.response import frequency_response
    from pipeline.study.figures.contact_figures import face_loop
    from pipeline.study.figures.response_figures import hysteresis_figures

    text = TWO_MASSES.replace("{sweep}", "preload = [10.0, 40.0]").replace(
        'dofs = ["x1", "y1"]', 'dofs = ["y1"]\nfigures = ["amplitude", "hysteresis"]')
    study = parse_study(text, file="two_masses.toml")
    curves = [frequency_response(study.system(case), 3, 180.0, 320.0, stability="hill",
                                 tol_rel=1e-10, dense_output=False)
              for _, case in study.sweep.cases()]
    ds = to_dataset(study, curves)
    tau = 2 * np.pi * np.arange((1 << 16) + 1) / (1 << 16)
    for k in range(2):
        loop = face_loop(ds, {"preload": k}, tau)
        p = int(ds.peak_contact_point.isel(preload=k))
        assert p == int(np.nanargmax(np.where(ds.converged.isel(preload=k),
                                              ds.amplitude.isel(preload=k, dof=0), np.nan)))
        assert loop["energy"] == float(ds.dissipated_energy.isel(preload=k, point=p, contact=0))
        area = np.sum(0.5 * (loop["f"][1:] + loop["f"][:-1]) * np.diff(loop["u"]))
        assert loop["energy"] > 1e-4 and area == pytest.approx(loop["energy"], rel=1e-6)
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    captured = {}
    real_close = plt.close
    plt.close = lambda fig=None: captured.setdefault("fig", fig)
    try:
        paths = hysteresis_figures(study, ds, tmp_path)
    finally:
        plt.close = real_close
    assert [p.name for p in map(__import__("pathlib").Path, paths)] == ["hysteresis.png"]
    labels = [t.get_text() for t in captured["fig"].axes[0].get_legend().get_texts()]
    assert len(labels) == 2 and all("J/cycle" in t and "gap (1 element) at" in t for t in labels)
    real_close(captured["fig"])


def test_peak_shape_vtu_holds_the_peak_deflection_and_the_contact_results(tmp_path):
    """The VTU of each case's peak on the FE blade (Craig-Bampton expanded): at the
    response node the harmonic-1 deflection is the dataset's (c_1, -s_1) of
    response.x/y/z at the peak; on the face nodes the dissipated energy is the
    dataset's per element, NaN off the faces."""
    import meshio
    from pathlib import Path
    from pipeline.fourier.harmonics import amplitude_half_peak_to_peak
    from pipeline.solve.response.response import ResponseCurve
    from pipeline.study.files.documents import load_study
    from pipeline.study.figures.peak_shapes import element_points, write_peak_shapes
    from pipeline.model.blade_cache import blade_model

    study = load_study(Path(__file__).resolve().parents[3] / "studies" /
                       "blade_shroud_contact.toml", quick=True)
    system = study.system(study.sweep.cases()[0][1])
    H, P, n = study.solver.harmonics, 4, system.n_dof
    rng = np.random.default_rng(5)
    Q = rng.normal(size=(P, n, 2 * H + 1)) * 1e-5
    om = np.linspace(2500.0, 2600.0, P)
    curve = ResponseCurve(parameter=om, omega=om, Q=Q, converged=np.ones(P, bool),
                          residual=np.zeros(P), stable=np.ones(P, bool),
                          amplitude=amplitude_half_peak_to_peak(Q), fold_parameter=np.zeros(0),
                          newton_iterations=np.ones(P, int), nfev=P, wall_time=0.1,
                          success=True, status=0, message="ok", H=H, tolerance=1e-8)
    ds = to_dataset(study, [curve])
    paths = write_peak_shapes(study, ds, [curve], tmp_path)
    assert [p.name for p in paths] == ["peak_shape_preload_30.vtu"]
    mesh = meshio.read(paths[0])
    i = int(np.argmax(ds.amplitude.isel(preload=0, dof=0).values))
    model = blade_model(study.scene.structure)
    resp = int(np.argmin(np.linalg.norm(model.points - model.set_points["response"][0], axis=1)))
    hc = ds.harmonic_coefficient.isel(preload=0, point=i, harmonic=1)
    for k, d in enumerate("xyz"):
        c1 = float(hc.sel(dof=f"response.{d}", component="cos"))
        s1 = float(hc.sel(dof=f"response.{d}", component="sin"))
        assert mesh.point_data["harmonic1_re"][resp, k] == pytest.approx(c1, rel=1e-9, abs=1e-20)
        assert mesh.point_data["harmonic1_im"][resp, k] == pytest.approx(-s1, rel=1e-9, abs=1e-20)
    elems, nodes = element_points(model, study.scene.contacts)
    assert elems.size == 20 and np.unique(nodes).size == 20     # the faces' 2 x 10 vertices
    np.testing.assert_allclose(model.points[nodes], np.concatenate(
        [model.frames[c.face].points for c in study.scene.contacts])[elems], atol=1e-12)
    W = mesh.point_data["dissipated_energy"]
    np.testing.assert_allclose(
        W[nodes], ds.dissipated_energy_pair.isel(preload=0, point=i).values[elems], rtol=1e-12)
    off = np.setdiff1d(np.arange(len(W)), nodes)
    assert off.size and np.all(np.isnan(W[off]))
    assert W[nodes].max() > 0                       # random motion slides somewhere


def test_mistuned_wheel_contacts_per_sector_balance_the_input_work():
    """A mistuned disk's full assembly: `pair` runs over every sector's elements
    (`pair_sector`), and the wheel's friction work plus its viscous work equals the
    work of the travelling-wave load at every converged point (as on one sector:
    the harmonic balance makes the balance exact up to its tolerance)."""
    from pathlib import Path

    from pipeline.fourier.harmonics import derivative
    from pipeline.model.system import dense
    from pipeline.solve.response.response import frequency_response
    from pipeline.study.files.documents import load_study

    study = load_study(Path(__file__).resolve().parents[3] / "studies" / "disk_mistuned.toml",
                       quick=True)
    cases = study.sweep.cases()[:1]
    system = study.system(cases[0][1])
    c = frequency_response(system, 1, 2 * np.pi * 400.0, 2 * np.pi * 460.0, stability=False,
                           tol_rel=1e-10, dense_output=False)
    curves = [c] + [None] * (len(study.sweep.cases()) - 1)
    ds = to_dataset(study, curves)
    N = study.scene.assembly.sectors
    assert ds.sizes["pair"] == N and np.array_equal(ds.pair_sector.values, np.arange(N))
    W = ds.dissipated_energy_pair.isel(mistuning_seed=0).values
    ok = ds.converged.isel(mistuning_seed=0).values
    assert ok.sum() > 10 and np.nanmax(W[ok]) > 0.0
    np.testing.assert_allclose(ds.dissipated_energy.isel(mistuning_seed=0, contact=0).values[ok],
                               W[ok].sum(axis=1), rtol=1e-12)
    F, C = system.forcing_coefficients(1), dense(system.C)
    for i in np.flatnonzero(ok):
        dQ = derivative(c.Q[i])
        work_in = np.pi * np.sum(F[:, 1:] * dQ[:, 1:])
        viscous = c.omega[i] * np.pi * np.einsum("ic,ij,jc->", dQ[:, 1:], C, dQ[:, 1:])
        assert work_in == pytest.approx(viscous + W[i].sum(), rel=1e-8, abs=1e-14)
    # the sectors dissipate differently: the mistuning localises the response
    peak = int(np.nanargmax(np.where(ok, W.sum(axis=1), np.nan)))
    assert np.ptp(W[peak]) > 0.05 * W[peak].max()
