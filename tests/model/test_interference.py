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
from pipeline.model.scene import RPM, blade_at_speed, blade_model, build_system
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
