"""Condensation from dense blocks gathered once (`interior`, strategy "blocks" of
`dynamic_stiffness`) against the condensation of the whole System per call (strategy
"dense"): condensed dynamic stiffness, load and their Omega-derivatives, and the
recovered interior DOFs."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pipeline.model.system import System
from pipeline.solve.harmonic_balance import dynamic_stiffness
from pipeline.solve.harmonic_balance import hbm
from pipeline.study.files.documents import load_study
from pipeline.paper_systems import example1

ROOT = Path(__file__).resolve().parents[3]


def whole(prob):
    """The same problem condensed from the whole dense S_h per call."""
    return replace(prob, linear=dynamic_stiffness.prepare(prob.system, prob.H, prob.c, prob.o,
                                                          prob.P, strategy="dense"))


def blade_problem(H=3):
    st = load_study(ROOT / "studies" / "blade_shroud_contact.toml", quick=True)
    return hbm.setup(st.system({"preload": 3.0}), H)


def sector_problem(H=3):
    st = load_study(ROOT / "studies" / "shrouded_disk.toml", quick=True)
    return hbm.setup(st.system({"preload": 3.0}), H)


@pytest.mark.parametrize("make", [blade_problem, sector_problem], ids=["blade", "disk-sector"])
def test_block_condensation_equals_the_whole(make):
    """Craig-Bampton blades (a single one, a disk sector): every harmonic's S~,
    dS~/dOmega, P~, dP~/dOmega to 1e-12 of their largest entry, near and away from
    resonance, and the interior DOFs recovered from a contact motion to 1e-12."""
    prob = make()
    assert prob.linear.strategy == "blocks" and prob.o.size > 0
    direct = whole(prob)
    rng = np.random.default_rng(0)
    Qc = 1e-5 * rng.standard_normal((prob.c.size, prob.nh))
    for f_hz in (150.0, 318.0, 493.0):
        Om = 2 * np.pi * f_hz
        for a, b in zip(hbm.linear_part(prob, Om), hbm.linear_part(direct, Om)):
            a, b = np.asarray(a), np.asarray(b)
            assert a.shape == b.shape
            assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
        Qa, Qb = hbm.recover(prob, Qc, Om), hbm.recover(direct, Qc, Om)
        assert np.abs(Qa - Qb).max() <= 1e-12 * np.abs(Qb).max()
        assert_applied_equals_matrix(direct, prob, Qc, Om)


def assert_applied_equals_matrix(direct, prob, Qc, Om):
    """dS~/dOmega applied to the motion by matrix-vector products (what the residual
    uses) equals the whole condensation's matrix times the motion, to 1e-12; the same
    S~, P~, dP~/dOmega."""
    q = hbm.complex_harmonics(Qc)
    St, dSt, Pt, dPt = hbm.linear_part(direct, Om)
    a = hbm.linear_part(prob, Om, motion=q)
    ref = np.einsum("hij,hj->hi", np.asarray(dSt), q)
    assert np.abs(a[1] - ref).max() <= 1e-12 * np.abs(ref).max()
    for x, y in ((a[0], St), (a[2], Pt), (a[3], dPt)):
        assert np.abs(np.asarray(x) - np.asarray(y)).max() <= 1e-12 * np.abs(np.asarray(y)).max()


def test_unsymmetric_blocks_take_the_transposed_solve():
    """A structure whose K is not symmetric (no shortcut Y = X^T): the same numbers as
    the condensation of the whole."""
    M = np.diag([1.0, 2.0, 1.5])
    K = np.array([[3e4, -1e4, 0.0], [-1.2e4, 2e4, -1e4], [0.0, -1e4, 1e4]])
    C = np.diag([5.0, 0.0, 0.0])
    base = example1(2.0)
    s = System(M=M, C=C, K=K, Bt=np.array([[0.0, 0.0, 1.0]]), Bn=np.zeros((1, 3)),
               contact=base.contact, forcing=np.array([[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], complex))
    prob = hbm.setup(s, 3)
    assert prob.linear.strategy == "blocks" and not prob.linear.blocks.symmetric
    for a, b in zip(hbm.linear_part(prob, 120.0), hbm.linear_part(whole(prob), 120.0)):
        a, b = np.asarray(a), np.asarray(b)
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
    Qc = 1e-3 * np.random.default_rng(1).standard_normal((prob.c.size, prob.nh))
    assert_applied_equals_matrix(whole(prob), prob, Qc, 120.0)


def test_static_harmonic_condensed_once_with_a_static_load():
    """The static harmonic (S = K at any Omega) is condensed once with the blocks:
    with a static load on an interior DOF, every harmonic's S~, P~ and their
    derivatives equal the whole condensation's, at two frequencies; a singular
    interior stiffness has no static part (each evaluation solves, as before)."""
    from pipeline.solve.harmonic_balance.interior import interior_blocks

    M = np.diag([1.0, 2.0, 1.5])
    K = np.array([[3e4, -1e4, 0.0], [-1e4, 2e4, -1e4], [0.0, -1e4, 1e4]])
    C = 1e-4 * K
    base = example1(2.0)
    s = System(M=M, C=C, K=K, Bt=np.array([[0.0, 0.0, 1.0]]), Bn=np.zeros((1, 3)),
               contact=base.contact, forcing=np.array([[0.0, 0.0], [3.0, 1.0], [0.0, 0.0]], complex))
    prob = hbm.setup(s, 3)
    assert prob.linear.blocks.static is not None
    for Om in (80.0, 150.0):
        for a, b in zip(hbm.linear_part(prob, Om), hbm.linear_part(whole(prob), Om)):
            a, b = np.asarray(a), np.asarray(b)
            assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
    free = np.zeros((3, 3))
    free[2, 2] = 1.0
    ib = interior_blocks(free, np.eye(3), np.zeros((3, 3)), np.array([2]), np.array([0, 1]))
    assert ib.static is None
