"""A study's blade on its flexible disk sector (`[scene.disk_sector]`), solved on one
sector with friction at the shrouds, against the wheel of 36 such sectors assembled
without symmetry (`build.full_system`: the cut coupling K, M, C_next placed between
neighbours): the travelling wave expanded to the wheel solves the wheel's equations at
engine orders 0, 1 and N/2 as well as the sector's own (its points sliding, its peaks)."""
from dataclasses import replace

import numpy as np
import pytest

from pipeline.model.build import build_system, full_system
from pipeline.model.cyclic import expand
from pipeline.model.system import natural_frequencies
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response.response import frequency_response
from pipeline.study.files.documents import parse_study

from helpers import STUDIES

# the shrouded disk's quick study (2 x 1 x 4 blade, 36 sectors, EO 3) on a disk sector
SECTOR = """
[scene.disk_sector]
bore_radius = 0.08
cut_face_modes = 6
"""


def scene():
    text = (STUDIES / "shrouded_disk.toml").read_text() + SECTOR
    return parse_study(text, file="sector.toml", name="sector", quick=True).scene


def check_on_the_wheel(sc, case, s, Q, Om):
    """The wave Q (one sector's, at Omega [rad/s]) expanded to the 36 sectors: the
    wheel's full residual equals the sector's own (to 1e-11 of the force scale: the
    same equations summed in another order),
    both within 1e-8 of the force scale."""
    own = hbm.setup(s, (Q.shape[1] - 1) // 2)
    scale = hbm.force_scale(own)
    wheel = hbm.setup(full_system(sc, case), own.H)
    r_wheel = np.abs(hbm.full_residual(wheel, expand(Q, 36, case["eo"]), Om)).max()
    r_own = np.abs(hbm.full_residual(own, Q, Om)).max()
    assert r_own < 1e-8 * scale
    assert abs(r_wheel - r_own) <= 1e-11 * scale      # round-off of the sums
    return own, scale


@pytest.mark.parametrize("eo", [0, 1, 18])
def test_the_sector_with_friction_solves_the_assembled_wheel(eo):
    """EO 0, 1 and N/2 = 18 at 0.1 N preload, H = 1: the sector's curve from 0.97 of the
    family's open frequency up to it converges; at its last point the pairs slide (their
    tangential motion beyond mu n0 / ku) and the wave expanded to the 36 sectors solves
    the wheel's equations as the sector's own (`check_on_the_wheel`); without the disk's
    mass coupling it would not (residual above 1e-6 of the force scale)."""
    sc, case = scene(), {"preload": 0.1, "eo": eo}
    s = build_system(sc, case)
    lo = natural_frequencies(s, "open")[0]
    c = frequency_response(s, 1, 0.97 * lo, lo, tol_rel=1e-8, stability=False)
    assert c.success and c.converged.all()
    Q, Om = c.Q[-1], c.omega[-1]
    own, scale = check_on_the_wheel(sc, case, s, Q, Om)
    el = s.contact
    assert np.abs(hbm.contact_motion(own, Q[own.c])[0]).max() > (el.mu * el.n0 / el.ku).max()
    if eo:
        plain = replace(s, cyclic=replace(s.cyclic, M_next=None))
        assert np.abs(hbm.full_residual(hbm.setup(plain, 1), Q, Om)).max() > 1e-6 * scale


@pytest.mark.slow   # 19 s; default sibling: the sliding points above, on the same wheel
@pytest.mark.parametrize("eo", [1, 18])
def test_the_sector_peak_solves_the_assembled_wheel(eo):
    """The sector's curve through the family's open and stuck frequencies (0.9 open ..
    1.1 stuck, H = 1) converges, and its peak point solves the wheel's equations as the
    sector's own (`check_on_the_wheel`): the wheel's peak is the sector's."""
    sc, case = scene(), {"preload": 1.0, "eo": eo}
    s = build_system(sc, case)
    lo, hi = natural_frequencies(s, "open")[0], natural_frequencies(s, "stuck")[0]
    c = frequency_response(s, 1, 0.9 * lo, 1.1 * hi, tol_rel=1e-8, stability=False)
    assert c.success and c.converged.all()
    i = int(np.argmax(c.amplitude[:, sc.dof_index("response.y")]))
    assert 0.9 * lo < c.omega[i] < 1.1 * hi
    check_on_the_wheel(sc, case, s, c.Q[i], c.omega[i])
