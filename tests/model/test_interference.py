"""The shroud preload from an interference and the speed (`ShroudPair.interference`,
`static_load.static_contact`).

On the quick 36-blade shrouded disk: zero interference at rest is zero preload; the
static normal load grows linearly with the interference while every pair is closed and
equals the stuck linear static solution of the unreduced sector (full FE model, one
sparse solve); a gap that the centrifugal deflection closes closes, in the static
contact solution of the speed sweep, within 0.5 % of the speed computed from the
centrifugal relative displacement of the first pair, interference + Omega^2 v_c1 = 0."""
import re

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from pipeline.model.contacts import fe_contact_maps
from pipeline.model.blade_cache import RPM, blade_at_speed, blade_model
from pipeline.model.build import build_system
from pipeline.model.static_load import static_contact, static_normal_load
from pipeline.model.system import coupled_stiffness
from pipeline.study.files.documents import parse_study
from helpers import STUDIES


def disk(interference, speeds="[0.0, 1000.0]"):
    text = (STUDIES / "shrouded_disk.toml").read_text()
    text = re.sub(r"(?m)^#.*\n", "", text)
    text = text.replace('"cyclic_coupling"]', '"cyclic_coupling", "centrifugal_stiffening"]')
    text = text.replace('stiffness = "per_face"', f'stiffness = "per_face"\n'
                                                  f'interference = {interference!r}')
    text = re.sub(r"\noptimum_preload = .*", "", text)
    text = text.replace("preload = [0.3, 1.0, 3.0, 10.0, 30.0]", f"speed = {speeds}")
    text = text.replace("[quick.sweep]\npreload = [0.3, 3.0, 30.0]", "")
    return parse_study(text, file="disk.toml", quick=True)


def test_zero_interference_at_rest_is_zero_preload():
    st = disk(0.0)
    s = build_system(st.scene, {"speed": 0.0})
    assert s.contact.size == 15 and np.all(s.contact.n0 == 0.0)
    load, closed = static_contact(s)
    assert np.all(load == 0.0)


def stuck_full_static(system):
    """s = n0 + kv Bn0 q0 with (K0 + Bn0^T kv Bn0) q0 = -Bn0^T n0 on the unreduced sector."""
    cy = system.cyclic
    Bn0 = sp.csr_matrix(system.Bn) + sp.csr_matrix(cy.Bn_next)
    el = system.contact
    A = (sp.csr_matrix(coupled_stiffness(system, 0.0)) + Bn0.T @ sp.diags(el.kv) @ Bn0).tocsc()
    q0 = spla.spsolve(A, -(Bn0.T @ el.n0))
    return el.n0 + el.kv * (Bn0 @ q0)


def test_static_load_is_linear_in_the_interference_and_the_stuck_solution():
    loads = []
    for delta in (1e-6, 2e-6, 4e-6):
        s = build_system(disk(delta).scene, {"speed": 0.0})
        load, closed = static_contact(s)
        assert closed.all() and np.all(load > 0)
        np.testing.assert_allclose(load, static_normal_load(s), rtol=1e-12)
        full = build_system(disk(delta).scene, {"speed": 0.0}, reduced=False)
        np.testing.assert_allclose(load, stuck_full_static(full), rtol=1e-8)
        loads.append(load)
    np.testing.assert_allclose(loads[1], 2 * loads[0], rtol=1e-12)
    np.testing.assert_allclose(loads[2], 4 * loads[0], rtol=1e-12)


def test_a_gap_that_speed_closes_closes_at_the_computed_speed():
    gap = -2e-6
    st = disk(gap)
    blade = blade_model(st.scene.structure)
    assert blade_at_speed(st.scene.structure, 0.0) is blade
    _, Bn, _, Bn_next, _, _ = fe_contact_maps(blade, st.scene.contacts, st.scene.structure.disk)
    v1 = (Bn + Bn_next) @ blade.rotation.static          # v_c per Omega^2 [m s^2]
    assert v1.max() > 0                                    # the speed closes the gap
    closing = np.sqrt(-gap / v1.max()) / RPM               # rpm
    counts = []
    for f in (0.995, 1.005):
        s = build_system(st.scene, {"speed": f * closing})
        counts.append(int(static_contact(s)[1].sum()))
    assert counts[0] == 0 and counts[1] >= 1, (closing, counts)


def test_a_swept_interference_is_n0_by_hand_at_the_speed():
    """A case's interference x (`[sweep] interference`, studies/shrouded_disk_interference.toml
    quick at 8,000 rpm) gives every pair n0_k = kv_k (x + v_c,k), kv_k = kv a_k / A (per
    face), v_c the pair's relative normal displacement under the centrifugal load,
    computed here from the blade at rest and its static deflection per Omega^2; the
    harmonic-balance residual of that case equals the one of the same scene given
    those n0 by hand, and of the scene whose pair states x in the file."""
    from pipeline.model.system import with_preload
    from pipeline.solve.harmonic_balance import hbm
    from pipeline.solve.response.response import initial_guess
    from pipeline.study.files.documents import load_study

    st = load_study(STUDIES / "shrouded_disk_interference.toml", quick=True)
    assert st.scene.structure.speed == 8000.0 and st.scene.contacts[0].interference is None
    pair = st.scene.contacts[0]
    blade = blade_model(st.scene.structure)
    _, Bn, _, Bn_next, _, weights = fe_contact_maps(blade, st.scene.contacts,
                                                     st.scene.structure.disk)
    vc = (Bn + Bn_next) @ ((8000.0 * RPM) ** 2 * blade.rotation.static)
    kv = pair.kv * weights[0] / weights[0].sum()
    text = re.sub(r"\[output\.optimum_interference\]\n(.+\n)+", "",
                  (STUDIES / "shrouded_disk_interference.toml").read_text())
    fixed = parse_study(text.replace(
        'stiffness = "per_face"\n', 'stiffness = "per_face"\ninterference = -3e-05\n').replace(
        "interference = [-2e-4, -1e-4, -5e-5, 0.0, 1e-4]", "speed = [8000.0]").replace(
        "interference = [-2e-4, -5e-5, 1e-4]", ""), file="fixed.toml", quick=True)
    for x in (-1e-4, -3e-5, 2e-5):
        s = build_system(st.scene, {"interference": x})
        n0 = kv * (x + vc)
        assert np.any(n0 < 0) or x > 0           # some pairs open at the gaps
        np.testing.assert_allclose(s.contact.n0, n0, rtol=1e-12, atol=1e-12 * np.abs(n0).max())
        by_hand = with_preload(build_system(st.scene, {"interference": 0.0}), n0)
        others = [by_hand] + ([build_system(fixed.scene, {"speed": 8000.0})] if x == -3e-5 else [])
        prob = hbm.setup(s, 1, "exact", 64)
        q = initial_guess(prob, 2 * np.pi * 370.0, s.contact)
        q = q + 1e-6 * np.random.default_rng(1).standard_normal(q.size)  # slips and opens
        R = hbm.residual(prob, q, 2 * np.pi * 370.0, s.contact)[0]
        for o in others:
            Ro = hbm.residual(hbm.setup(o, 1, "exact", 64), q, 2 * np.pi * 370.0, o.contact)[0]
            np.testing.assert_allclose(Ro, R, rtol=0, atol=1e-12 * np.abs(R).max())
