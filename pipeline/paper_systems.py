"""The source paper's three examples (Sec. 6) as Systems, built directly in code, and
the 3-DOF shrouded blade of the stability checks.

The same data as `studies/paper_example{1,2,3}.toml` and `studies/blade3_stability.toml`,
for benchmarks and tests that should not depend on the study-file layer.
"""
import numpy as np

from .contact import YangMenq
from .model.system import System


def example1(n):
    """m = 1 kg, c = 0.3 N s/m, k = 3.55e4 N/m, Jenkins to ground ku = 1e4 N/m, mu = 0.5,
    normal load n [N], F0 = 1 N (Sec. 6.1)."""
    return System(M=np.array([[1.0]]), C=np.array([[0.3]]), K=np.array([[3.55e4]]),
                  Bt=np.array([[1.0]]), Bn=np.array([[0.0]]),
                  contact=YangMenq(1e4, 0.0, 0.5, n), forcing=np.array([[0, 1.0]]))


def example2(n):
    """ground-k1-m1-k2-m2 (1 kg, 40 kN/m, 4 N s/m), damper ku = 30 kN/m, mu = 1 on mass 1,
    normal load n [N], F0 = 100 N on mass 1 (Sec. 6.2)."""
    k, c = 40e3, 4.0
    K = np.array([[2 * k, -k], [-k, k]])
    C = np.array([[2 * c, -c], [-c, c]])
    return System(M=np.eye(2), C=C, K=K, Bt=np.array([[1.0, 0.0]]), Bn=np.zeros((1, 2)),
                  contact=YangMenq(30e3, 0.0, 1.0, n), forcing=np.array([[0, 100.0], [0, 0]]))


def example3(n0):
    """Modal 2-DOF (u, v), M = Phi^-T Phi^-1, K = Phi^-T W^2 Phi^-1, C = Phi^-T 2 zeta W
    Phi^-1 (w = 1, 10 rad/s, zeta = 0.01); mu = 0.4, ku = kv = 1, 1 N on u and v,
    preload n0 [N] (Sec. 6.3)."""
    Phi = np.array([[0.707, 1.0], [0.707, -0.5]])
    W = np.diag([1.0, 10.0])
    Pi = np.linalg.inv(Phi)
    return System(M=Pi.T @ Pi, C=Pi.T @ (2 * 0.01 * W) @ Pi, K=Pi.T @ W**2 @ Pi,
                  Bt=np.array([[1.0, 0.0]]), Bn=np.array([[0.0, 1.0]]),
                  contact=YangMenq(1.0, 1.0, 0.4, n0), forcing=np.array([[0, 1.0], [0, 1.0]]))


def blade3():
    """3-DOF shrouded-blade model (kg, N/m, N s/m): one Yang-Menq contact, u = x3 - x1,
    v = x2, ku = 16056.9 N/m, kv = 86511.2 N/m, mu = 0.287, preload 178.5 N; 5.85 N on
    x2.  Hill's method calls some of its stable orbits unstable (pipeline/solve/README.md, Stability)."""
    M = np.diag([1.19290, 1.00829, 1.23316])
    K = np.array([[9105.293, -3091.31, 0], [-3091.31, 85922.633, -82831.323],
                  [0, -82831.323, 86828.066]])
    C = np.array([[2.368786, -0.0591258, 0], [-0.0591258, 3.498389, -1.584269],
                  [0, -1.584269, 3.929410]])
    return System(M=M, C=C, K=K, Bt=np.array([[-1.0, 0.0, 1.0]]), Bn=np.array([[0.0, 1.0, 0.0]]),
                  contact=YangMenq(16056.9, 86511.2, 0.287, 178.5),
                  forcing=np.array([[0, 0], [0, 5.85], [0, 0]], complex))
