"""Systems for the tests: the paper's examples (see pipeline/paper_systems.py) and the
three-mass chain of tests/studies/chain_stuck_resonance.toml, a 3-DOF shrouded
blade whose stability along its branch is settled by time integration, and the
comparison of two sets of complex numbers (eigenvalues, multipliers)."""
import numpy as np

from pipeline.contact import YangMenq
from pipeline.paper_systems import blade3, example1, example2, example3  # noqa: F401
from pipeline.model.system import System

# ground-1-2-3, 1 kg and 1e4 N/m each, C = BETA K (zeta = 0.5 % at the first open mode)
K_CHAIN = 1e4 * np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
BETA = 2 * 0.005 / np.sqrt(np.linalg.eigvalsh(K_CHAIN)[0])


def chain_system(n0, normal=2):
    """The chain with one Yang-Menq contact on x3 (ku = 1e4, kv = 1e3 N/m, mu = 0.5)
    against ground, its normal direction on DOF `normal`, preload n0 [N]; 1 N on x1."""
    Bn = np.zeros((1, 3))
    Bn[0, normal] = 1.0
    return System(M=np.eye(3), C=BETA * K_CHAIN, K=K_CHAIN, Bt=np.array([[0.0, 0.0, 1.0]]),
                  Bn=Bn, contact=YangMenq(1e4, 1e3, 0.5, n0),
                  forcing=np.array([[0, 1.0], [0, 0], [0, 0]]))


BLADE_STABLE = [113.156, 113.754, 114.407, 115.073, 118.120, 119.254, 120.927]
BLADE_UNSTABLE = [116.186, 116.560]


def assert_same_multiset(got, exact, atol):
    """Same multiset of complex numbers (nearest matching, no fragile sorting)."""
    got, exact = np.asarray(got), list(np.asarray(exact))
    assert got.size == len(exact), (got, exact)
    for g in got:
        j = int(np.argmin(np.abs(np.array(exact) - g)))
        assert abs(exact[j] - g) <= atol, (got, exact)
        exact.pop(j)
