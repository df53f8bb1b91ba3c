"""Systems for the tests: the paper's examples (see pipeline/paper_systems.py) and the
three-mass chain of tests/studies/chain_stuck_resonance.toml, a 3-DOF shrouded
blade whose stability along its branch is settled by time integration, and the
comparison of two sets of complex numbers (eigenvalues, multipliers)."""
import numpy as np

from pipeline.contact import YangMenq
from pipeline.paper_systems import example1, example2, example3  # noqa: F401
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


def blade3():
    """3-DOF shrouded-blade model: one Yang-Menq contact, u = x3 - x1, v = x2; 5.85 N on x2."""
    M = np.diag([1.19290, 1.00829, 1.23316])
    K = np.array([[9105.293, -3091.31, 0], [-3091.31, 85922.633, -82831.323],
                  [0, -82831.323, 86828.066]])
    C = np.array([[2.368786, -0.0591258, 0], [-0.0591258, 3.498389, -1.584269],
                  [0, -1.584269, 3.929410]])
    return System(M=M, C=C, K=K, Bt=np.array([[-1.0, 0.0, 1.0]]), Bn=np.array([[0.0, 1.0, 0.0]]),
                  contact=YangMenq(16056.9, 86511.2, 0.287, 178.5),
                  forcing=np.array([[0, 0], [0, 5.85], [0, 0]], complex))


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
