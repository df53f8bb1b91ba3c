"""One `Scene` value composes structure x reduction x contacts x loads x assembly:
an FE blade in a cyclic cascade is a combination of existing parts, checked against
its own full assembly; the parts' seams (case keys, caches, mixed contacts) hold."""
from dataclasses import replace

import numpy as np
import pytest

from pipeline.model.cyclic import expand
from pipeline.model.contacts import DofContact
from pipeline.model.loads import Forcing, PointLoad
from pipeline.model.scene import (CASE_KEYS, Blade, CraigBampton, Cyclic, Lumped, Mistuning, Scene,
                                  Single)
from pipeline.model.blade_cache import blade_model
from pipeline.model.build import build_system, full_system, stiffness_factors
from pipeline.model.system import dense, natural_frequencies
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response.response import frequency_response
from pipeline.structure.fe_model import BladeParams
from pipeline.study.files.study_types import SWEEP_AXES

PARAMS = BladeParams(n_chord=2, n_thick=1, n_span=4)   # 100 reduced DOFs with 4 modes
KU = 5e4          # [N/m] per node pair
PAIRS = (0, 5, 10)


def fe_cascade(sectors=2, engine_order=1, mistuning=None, ku=KU):
    """Two (or N) coarse FE blades whose right shroud nodes rub the next blade's left
    shroud nodes (Jenkins elements in y), excited in y at the excitation node."""
    dofs = Scene(Blade(PARAMS), reduction=CraigBampton(4)).sector_dofs
    n = len(dofs)

    def row(k):
        r = np.zeros(2 * n)
        r[n + dofs.index(f"shroud_left.{k}.y")] = 1.0     # next sector's left face
        r[dofs.index(f"shroud_right.{k}.y")] = -1.0       # this sector's right face
        return r

    contacts = tuple(DofContact(f"pair{k}", row(k), np.zeros(2 * n), ku, 0.0, 0.3, None)
                     for k in PAIRS)
    return Scene(Blade(PARAMS), contacts=contacts,
                 loads=(PointLoad("excitation", (0.0, 1.0, 0.0), 1.0, 1, 0.0),),
                 assembly=Cyclic(sectors, engine_order, mistuning), reduction=CraigBampton(4),
                 effects=("friction", "cyclic_coupling"), model="solid_blade")


def test_case_keys_are_the_study_sweep_axes():
    """build_system takes every sweep axis but the requested static normal load, which
    static_load.case_system turns into the preload n0 that produces it."""
    from pipeline.model.static_load import NORMAL_LOAD
    assert set(SWEEP_AXES) == set(CASE_KEYS) | {NORMAL_LOAD}


def test_fe_blade_cascade_tuned_sector_equals_its_full_assembly():
    """N = 2, EO = 1: the one-sector cyclic reduction of an FE blade pair.  Its linear
    limits are among the assembly's eigenfrequencies, and every point of its
    nonlinear (slipping) response expanded to both sectors solves the 200-DOF
    assembly's harmonic balance (exact forces).  (Measured once: the assembly's own
    continuation gives the same peak, 1.82191701982e-6 m at 3746.65 rad/s.)"""
    scene = fe_cascade()
    case = {"preload": 0.5}
    s, f = build_system(scene, case), full_system(scene, case)
    assert s.n_dof == 100 and f.n_dof == 200 and s.cyclic.sectors == 2 and f.cyclic is None
    for contacts in ("open", "stuck"):
        ws, wf = natural_frequencies(s, contacts), natural_frequencies(f, contacts)
        assert np.abs(wf[:, None] - ws[None, :4]).min(axis=0).max() < 1e-6 * ws[3]
    open_, stuck = natural_frequencies(s, "open")[0], natural_frequencies(s, "stuck")[0]
    assert stuck > 2 * open_        # the shroud pairs stiffen the antiphase mode a lot
    dof = scene.dof_index("response.y")
    a = frequency_response(s, 3, 3650.0, 3850.0, stability=False, dense_output=False,
                           peak_dofs=[dof])
    assert a.success
    amp, om = a.peak(dof)[:2]
    assert amp == pytest.approx(1.8219170198e-6, rel=1e-8)
    assert open_ < om < stuck       # slipping: between the open and stuck limits
    full = hbm.setup(f, 3)
    for Q, w in list(zip(a.Q, a.omega))[::4]:
        assert np.linalg.norm(hbm.full_residual(full, expand(Q, 2, 1), w)) <= 2 * a.tolerance


def test_fe_blade_cascade_mistuned_is_the_assembly_with_scaled_sectors():
    scene = fe_cascade(sectors=3, mistuning=Mistuning(0.05, seed=4))
    s = build_system(scene, {"preload": 0.5})
    tuned = full_system(replace(scene, assembly=Cyclic(3, 1)), {"preload": 0.5})
    f = stiffness_factors(scene, {})
    n = len(scene.sector_dofs)
    assert s.n_dof == 3 * n and s.cyclic is None and s.dof_names[n] == scene.sector_dofs[0] + "@1"
    for j in range(3):
        blk = slice(j * n, (j + 1) * n)
        np.testing.assert_allclose(dense(s.K)[blk, blk], f[j] * dense(tuned.K)[blk, blk],
                                   rtol=1e-14)   # 300 DOFs: stored sparse, densified here
    np.testing.assert_array_equal(dense(s.Bt), dense(tuned.Bt))
    assert scene.dof_index("response.y@2") == 2 * n + scene.sector_dofs.index("response.y")


def test_lumped_single_scene_is_its_matrices_rows_and_load():
    M, K = np.diag([1.0, 2.0]), np.array([[3.0, -1.0], [-1.0, 2.0]])
    F = np.zeros((2, 2), complex)
    F[0, 1] = 2.0
    c = DofContact("c", np.array([0.0, 1.0]), np.array([0.0, 1.0]), 5.0, 7.0, 0.2, None)
    scene = Scene(Lumped(M, 0.01 * K, K, ("a", "b")), contacts=(c,), loads=(Forcing(F),),
                  effects=("friction", "normal_load_variation"))
    s = build_system(scene, {"preload": 3.0, "excitation_scale": 0.5})
    assert s.cyclic is None and s.dof_names == ("a", "b") and s.n_elements == 1
    assert s.Bt.tolist() == [[0.0, 1.0]] and s.contact.n0.tolist() == [3.0]
    assert s.forcing[0, 1] == 1.0
    with pytest.raises(ValueError, match="unknown axes"):
        build_system(scene, {"temperature": 1.0})
    with pytest.raises(ValueError, match="not a disk"):
        build_system(scene, {"preload": 1.0, "eo": 1})
    with pytest.raises(ValueError, match="one Forcing"):
        build_system(replace(scene, loads=()), {"preload": 1.0})


def test_equal_structure_specs_share_one_built_model():
    """Caches sit on the frozen specs: two scenes with equal blades build it once."""
    a = Scene(Blade(PARAMS), reduction=CraigBampton(4))
    b = fe_cascade()
    assert blade_model(a.structure) is blade_model(b.structure)
    assert isinstance(Single(), Single) and a.sector_dofs == b.sector_dofs
