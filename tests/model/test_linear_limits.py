"""The linear limits' natural frequencies: further laws' linear springs (a cubic
spring's k1) count in every limit, and a negative stiffness is no frequency (NaN) but
a structure that diverges statically, which a response case refuses to solve."""
import numpy as np
import pytest

from pipeline.contact import YangMenq
from pipeline.model.system import (System, lowest_frequencies, natural_frequencies,
                                   negative_stiffness)
from pipeline.paper_systems import example1
from pipeline.solve.response.response import frequency_response
from pipeline.study.execution.cases import run_case
from pipeline.study.files.documents import parse_study

SPRING = """
[study]
title = "one mass on a linear spring and a cubic spring"
[scene]
model = "lumped"
effects = ["cubic_stiffness"]
dofs = ["x"]
[scene.matrices]
M = [[1.0]]
C = [[0.3]]
K = [[100.0]]
[[scene.spring]]
dofs = ["x"]
k3 = 1.0
k1 = K1
[[scene.excitation]]
dof = "x"
amplitude = 0.01
[sweep]
frequency = { start = 5.0, stop = 40.0, unit = "rad/s" }
[solver]
harmonics = 3
stability = "hill"
[output]
dofs = ["x"]
"""


def spring_system(k1):
    study = parse_study(SPRING.replace("K1", repr(k1)), file="spring.toml")
    return study.system(study.sweep.cases()[0][1])


def test_a_springs_k1_is_part_of_every_linear_limit():
    """K = 100 N/m plus k1 = 300 N/m on 1 kg: sqrt(400) = 20 rad/s open and stuck
    (the spring is no contact), as the small-amplitude response peaks."""
    s = spring_system(300.0)
    for limit in ("open", "stuck"):
        assert natural_frequencies(s, limit) == pytest.approx([20.0], rel=1e-14)
        assert lowest_frequencies(s, limit, 1) == pytest.approx([20.0], rel=1e-14)
    c = frequency_response(s, 3, 5.0, 40.0, stability=False)
    assert c.peak(0)[1] == pytest.approx(20.0, rel=1e-3)


def test_a_negative_stiffness_has_no_frequency():
    """k1 = -300 N/m: omega^2 = -200 (rad/s)^2 at rest, NaN, not sqrt(200) rad/s;
    the structure alone (K = 100 N/m) does not diverge: a double well is a valid
    scene."""
    s = spring_system(-300.0)
    assert np.isnan(natural_frequencies(s, "open")).all()
    assert np.isnan(lowest_frequencies(s, "stuck", 1)).all()
    assert negative_stiffness(s) is None


def bare(K):
    """Unit masses on springs K [N/m]; a Jenkins element (ku = 1e4 N/m, preloaded) on the
    last one."""
    n = np.asarray(K, float).shape[0]
    return System(M=np.eye(n), C=0.1 * np.eye(n), K=np.asarray(K, float),
                  Bt=np.eye(1, n, n - 1), Bn=np.zeros((1, n)),
                  contact=YangMenq(ku=1e4, kv=0.0, mu=0.5, n0=1.0),
                  forcing=np.eye(n, 2, 1, dtype=complex))


def test_a_structure_that_diverges_is_refused_and_a_free_body_is_not():
    """K = diag(-50, 10): omega^2 = -50 rad^2/s^2, NaN, and a response case is refused
    with its eigenvalue; a free mass (K = 0) is a zero frequency, solved; a stuck
    preloaded contact that holds the negative spring (K = -50 N/m, ku = 1e4 N/m) is
    stable at rest, solved; a free-free chain's zero mode (round-off) is no negative
    stiffness."""
    s = bare([[-50.0, 0.0], [0.0, 10.0]])
    assert negative_stiffness(s) == pytest.approx(-50.0, rel=1e-12)
    f = natural_frequencies(s, "open")
    assert np.isnan(f[0]) and f[1] == pytest.approx(np.sqrt(10.0), rel=1e-14)
    curve, err = run_case(frequency_response, s, 1, 1.0, 5.0, {})
    assert curve is None and err.startswith(
        "the structure is statically unstable about rest: at vanishing vibration (preloaded "
        "contacts stuck, the others open) its stiffness has a negative eigenvalue, omega^2 = "
        "-50 rad^2/s^2")
    free = bare([[0.0, 0.0], [0.0, 10.0]])
    assert negative_stiffness(free) is None
    assert natural_frequencies(free, "open")[0] == 0.0
    assert negative_stiffness(bare([[-50.0]])) is None     # held by the stuck contact
    assert negative_stiffness(example1(2.0)) is None
    k = 1e9   # a stiff free-free chain of 6 masses: a rigid mode at round-off
    chain = k * (2 * np.eye(6) - np.eye(6, k=1) - np.eye(6, k=-1))
    chain[0, 0] = chain[-1, -1] = k
    ff = bare(chain)
    ff = System(M=ff.M, C=ff.C, K=ff.K, Bt=np.zeros((1, 6)), Bn=np.zeros((1, 6)),
                contact=ff.contact, forcing=ff.forcing)
    assert negative_stiffness(ff) is None
    f0 = natural_frequencies(ff, "open")[0]
    assert np.isfinite(f0) and f0 < 1e-2       # [rad/s] the rigid mode: 0 to round-off


def test_a_gap_contacts_stuck_limit_is_closed_and_stuck():
    """Example 3 with a gap (n0 = -100 N): the stuck limit is the contact closed and
    stuck, ku and kv (1.41366 rad/s, as at every positive preload), not ku alone
    (1.22263 rad/s, neither limit); open: K alone."""
    from pipeline.paper_systems import example3
    gap, pressed = example3(-100.0), example3(10.0)
    np.testing.assert_allclose(natural_frequencies(gap, "stuck"),
                               natural_frequencies(pressed, "stuck"), rtol=1e-14)
    np.testing.assert_allclose(natural_frequencies(gap, "stuck"),
                               natural_frequencies(gap, "tied"), rtol=1e-14)
    assert natural_frequencies(gap, "stuck")[0] == pytest.approx(1.41366, abs=1e-5)
