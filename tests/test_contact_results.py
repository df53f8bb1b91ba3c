"""What the preload becomes and what the contacts do: the static normal load
n0 + kv v0, a requested static normal load, per-contact cycle results."""
from __future__ import annotations

import numpy as np
import pytest

from pipeline.model.static_load import static_normal_load
from pipeline.study.dataset import to_dataset
from pipeline.study.documents import parse_study

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


@pytest.mark.parametrize("name", ["shrouded_disk", "blade_shroud_contact"])
def test_requested_static_load_is_recovered_per_face_on_fe_scenes(name):
    """Face totals of n0 + kv v0 over every node (pair) of each face, the FE blade
    of two faces against walls and the cyclic shroud pair, to 1e-10."""
    from pathlib import Path
    from pipeline.model.static_load import contact_owner, face_totals

    text = (Path(__file__).resolve().parents[1] / "studies" / f"{name}.toml").read_text()
    text = text.replace("preload = [", "normal_load = [")
    study = parse_study(text, file=f"{name}.toml", quick=True)
    owner = contact_owner(study.scene)
    for _, case in study.sweep.cases()[:2]:
        system = study.system(case)
        s = face_totals(static_normal_load(system), owner, len(study.scene.contacts))
        np.testing.assert_allclose(s, case["normal_load"], rtol=1e-10)
        n0 = face_totals(system.contact.n0, owner, len(study.scene.contacts))
        assert np.all(n0 > s)                   # the shroud gives way under its preload
