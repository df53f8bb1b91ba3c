"""FE shroud pairs with 2D friction (`friction = "2d"`, `model.contacts.fe_plane_maps`,
the elements as `System.laws`) on the quick blade of studies/shrouded_disk_2d.toml.

Checked against the 1D path (Yang-Menq elements through `fe_contact_maps`, exact
forces): the 2D pair's first tangent and normal rows are the 1D pair's; its stuck
limit equals two 1D pairs, one along t1 and one along t2 = n x t1 (kv on the first
only), both for the natural frequencies and for the forced response under a preload
that keeps everything stuck; and a mistuned wheel's full assembly (all factors 1)
has a zero residual at the tuned sector's solution spread as the travelling wave."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pipeline.fourier.harmonics import shift
from pipeline.model.contacts import fe_contact_maps, fe_plane_maps, pair_frame
from pipeline.model.scene import Mistuning
from pipeline.model.blade_cache import blade_model
from pipeline.model.build import build_system
from pipeline.model.system import natural_frequencies
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response.response import frequency_response
from pipeline.study.files.documents import load_study

ROOT = Path(__file__).resolve().parents[2]
STUDY = load_study(ROOT / "studies" / "shrouded_disk_2d.toml", quick=True)
PLANE = STUDY.scene
HZ = 2 * np.pi


def two_lines(scene):
    """The same shroud as two 1D pairs: along t1 (ku, kv) and along t2 (ku2, kv = 0)."""
    c = scene.contacts[0]
    t, n = pair_frame(blade_model(scene.structure), c, scene.structure.disk)
    first = replace(c, friction="1d", tangent=tuple(t), ku2=None)
    second = replace(c, name="shroud_t2", friction="1d", kv=0.0, tangent=tuple(np.cross(n, t)),
                     ku=c.ku if c.ku2 is None else c.ku2, ku2=None)
    return replace(scene, contacts=(first, second))


def with_ku2(scene, factor):
    """The scene's 2D pair with ku2 = factor ku (None: isotropic)."""
    c = scene.contacts[0]
    return replace(scene, contacts=(replace(c, ku2=None if factor is None else factor * c.ku),))


def test_first_tangent_and_normal_rows_are_the_1d_pairs():
    blade = blade_model(PLANE.structure)
    disk = PLANE.structure.disk
    line = replace(PLANE.contacts[0], friction="1d")
    Bt, Bn, Bt_x, Bn_x, owner, _ = fe_contact_maps(blade, (line,), disk)
    own, nxt, owner2, _ = fe_plane_maps(blade, PLANE.contacts, disk)
    for a, b in ((Bt, own[0]), (Bn, own[2]), (Bt_x, nxt[0]), (Bn_x, nxt[2])):
        assert abs(a - b).max() <= 1e-15
    np.testing.assert_array_equal(owner, owner2)
    t, n = pair_frame(blade, line, disk)
    assert abs(t @ n) < 1e-14 and abs(np.linalg.norm(np.cross(n, t)) - 1) < 1e-14


@pytest.mark.parametrize("factor", [None, 3.0])
def test_stuck_frequencies_equal_two_1d_pairs(factor):
    """Isotropic, and with the face three times stiffer along t2 (ku2 = 3 ku)."""
    case = {"preload": 30.0}
    scene = with_ku2(PLANE, factor)
    plane = build_system(scene, case)
    lines = build_system(two_lines(scene), case)
    assert plane.contact.size == 0 and plane.laws[0].law.name == "friction_2d"
    f2, f1 = (natural_frequencies(s, "stuck")[:4] for s in (plane, lines))
    # rtol: the lowest eigenvalue of the stiff reduced sector (|K| / lambda_1 ~ 1e6)
    # carries ~1e-10 of round-off between the two assemblies
    np.testing.assert_allclose(f2, f1, rtol=1e-8)
    one = natural_frequencies(build_system(replace(PLANE, contacts=(
        replace(PLANE.contacts[0], friction="1d"),)), case), "stuck")[0]
    assert f2[0] > 1.05 * one      # t2 stuck too: stiffer than the 1D stuck pairs
    if factor:
        iso = natural_frequencies(build_system(PLANE, case), "stuck")[0]
        assert f2[0] > iso * (1 + 1e-3)    # and stiffer still along t2


def test_stuck_forced_response_equals_two_1d_pairs():
    """1000 N per face: every pair sticks over the band, both responses are the linear
    stuck structure's; peaks of response.y to 1e-7."""
    case = {"preload": 1000.0}
    out = []
    for scene, method in ((PLANE, "aft"), (two_lines(PLANE), "exact")):
        s = build_system(scene, case)
        dof = s.dof_names.index("response.y")
        c = frequency_response(s, 1, 320 * HZ, 380 * HZ, method=method, n_samples=64,
                               stability=False, tol_rel=1e-10, peak_dofs=[dof])
        assert c.success
        a = np.asarray(c.amplitude)[:, dof]
        i = int(np.argmax(a))
        out.append((a[i], c.omega[i]))
    (a2, w2), (a1, w1) = out
    assert a2 == pytest.approx(a1, rel=1e-7, abs=0)
    assert w2 == pytest.approx(w1, rel=1e-7, abs=0)


def test_full_wheel_residual_vanishes_at_the_tuned_travelling_wave():
    """96 samples: the inter-sector phase 2 pi 3 / 36 is then 8 whole samples, so
    every sector's AFT samples are the tuned sector's shifted (with 64 the wheel
    differs from the cyclic reduction by the AFT aliasing, 5e-5 N here)."""
    case, S = {"preload": 3.0}, 96
    tuned = build_system(PLANE, case)
    dof = tuned.dof_names.index("response.y")
    c = frequency_response(tuned, 1, 320 * HZ, 340 * HZ, method="aft", n_samples=S,
                           stability=False, tol_rel=1e-10, peak_dofs=[dof])
    assert c.success
    i = int(np.argmax(np.asarray(c.amplitude)[:, dof]))
    Q0, Om = np.asarray(c.Q[i]), float(c.omega[i])
    N = PLANE.assembly.sectors
    wheel = replace(PLANE, assembly=replace(PLANE.assembly, mistuning=Mistuning(
        factors=(1.0,) * N)))
    full = build_system(wheel, case)
    assert full.laws[0].law.size == N * tuned.laws[0].law.size
    phi = 2 * np.pi * PLANE.assembly.engine_order / N
    Q = np.concatenate([shift(Q0, j * phi) for j in range(N)])
    R = hbm.full_residual(hbm.setup(full, 1, "aft", S), Q, Om)
    assert np.abs(R).max() <= 1e-9 * hbm.force_scale(hbm.setup(tuned, 1, "aft", S))
    X = np.stack([np.asarray(B @ Q) for B in full.laws[0].maps], axis=1)
    regimes = full.laws[0].law.evaluate(X, n_samples=S, jacobian=False).regimes
    assert regimes["slipping"] > 0        # a nonlinear state, not the stuck limit
