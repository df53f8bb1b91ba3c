"""Shared test references, each written once: finite-difference Jacobians, closed
forms of small systems (the three-mass chain of tests/studies/chain_stuck_resonance.toml,
the lumped disk of Laxalde et al. 2007), a one-sector harmonic-balance solve, the
3-DOF shrouded blade's orbits whose stability time integration settles, and
comparisons of sets of complex numbers.

The paper's example systems live in `pipeline.paper_systems`, not here.
"""
import re
import tomllib
from pathlib import Path

import numpy as np
import scipy.linalg as la
from scipy.optimize import minimize_scalar

from pipeline.contact import YangMenq
from pipeline.model.cyclic import Sector, sector_system, spring_stiffness
from pipeline.model.system import System, dense
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.continuation.newton import newton

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ROOT / "studies"


def study_doc(name):
    """The TOML document of a shipped study, as a dict."""
    return tomllib.loads((STUDIES / name).read_text())


def stated(name, pattern):
    """The numbers of the first match of `pattern` in the shipped study's text (its
    comments state results), as floats."""
    m = re.search(pattern, (STUDIES / name).read_text())
    assert m, f"{name}: {pattern!r} not found"
    return [float(g) for g in m.groups()]


def example1_study(title, *, study="", preload="[0.0, 2.0]", solver="harmonics = 3",
                   output='dofs = ["x"]', extra=""):
    """The text of a study file of the paper's Example 1 (m = 1 kg, c = 0.3 N s/m,
    k = 3.55e4 N/m, a Jenkins damper to ground ku = 1e4 N/m, mu = 0.5, 1 N at x,
    150-250 rad/s): `study` lines go into [study], `solver` and `output` are those
    tables' lines, `extra` further tables."""
    return f"""
[study]
title = "{title}"
{study}

[scene]
model = "lumped"
effects = ["friction"]
dofs = ["x"]

[scene.matrices]
M = [[1.0]]
C = [[0.3]]
K = [[3.55e4]]

[[scene.contact]]
name = "damper"
tangential = ["x"]
ku = 1.0e4
mu = 0.5

[[scene.excitation]]
dof = "x"
amplitude = 1.0

[sweep]
preload = {preload}
frequency = {{ start = 150.0, stop = 250.0, unit = "rad/s" }}

[solver]
{solver}

[output]
{output}
{extra}"""


# --------------------------------------------------------------------------- numerics
def fd(fun, x, h=1e-7):
    """Central-difference Jacobian d fun / d x, column j = (f(x + h e_j) - f(x - h e_j)) / 2h."""
    return np.column_stack([(fun(x + h * e) - fun(x - h * e)) / (2 * h) for e in np.eye(x.size)])


def linear_peak(K, M, C, F, dof, lo, hi):
    """Exact maximum of |x_dof| of the linear first-harmonic response
    |(K - w^2 M + i w C)^-1 F| [m] over w in [lo, hi] [rad/s]: (amplitude, w, the
    amplitude as a function of w)."""
    amp = lambda om: abs(np.linalg.solve(K - om**2 * M + 1j * om * C, F)[dof])  # noqa: E731
    r = minimize_scalar(lambda om: -amp(om), bounds=(lo, hi), method="bounded",
                        options={"xatol": 1e-13})
    return -r.fun, r.x, amp


def assert_same_multiset(got, exact, atol):
    """Same multiset of complex numbers (nearest matching, no fragile sorting)."""
    got, exact = np.asarray(got), list(np.asarray(exact))
    assert got.size == len(exact), (got, exact)
    for g in got:
        j = int(np.argmin(np.abs(np.array(exact) - g)))
        assert abs(exact[j] - g) <= atol, (got, exact)
        exact.pop(j)


def scurve(x, lam):
    """x^3 - 3x = lam: folds at (x, lam) = (-1, 2) and (1, -2)."""
    return np.array([x[0] ** 3 - 3 * x[0] - lam]), np.array([[3 * x[0] ** 2 - 3]]), np.array([-1.0])


def one(U1=(), V1=(), H=3, U0=0.0, V0=0.0):
    """Harmonic coefficients (1, 2H+1) of one contact's u and v: mean U0, V0 and the
    first cos/sin coefficients U1, V1 in order (cos 1, sin 1, cos 2, ...)."""
    U, V = np.zeros((1, 2 * H + 1)), np.zeros((1, 2 * H + 1))
    U[0, 0], V[0, 0] = U0, V0
    U[0, 1:1 + len(U1)] = U1
    V[0, 1:1 + len(V1)] = V1
    return U, V


# --------------------------------------------------------------------------- three-mass chain
# ground-1-2-3, 1 kg and 1e4 N/m each, C = BETA K (zeta = 0.5 % at the first open mode)
K_CHAIN = 1e4 * np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
BETA = 2 * 0.005 / np.sqrt(np.linalg.eigvalsh(K_CHAIN)[0])
KU_CHAIN, KV_CHAIN = 1e4, 1e3


def chain_system(n0, normal=2):
    """The chain with one Yang-Menq contact on x3 (ku = 1e4, kv = 1e3 N/m, mu = 0.5)
    against ground, its normal direction on DOF `normal`, preload n0 [N]; 1 N on x1."""
    Bn = np.zeros((1, 3))
    Bn[0, normal] = 1.0
    return System(M=np.eye(3), C=BETA * K_CHAIN, K=K_CHAIN, Bt=np.array([[0.0, 0.0, 1.0]]),
                  Bn=Bn, contact=YangMenq(KU_CHAIN, KV_CHAIN, 0.5, n0),
                  forcing=np.array([[0, 1.0], [0, 0], [0, 0]]))


def stuck_chain_amplitude(w, dof, normal=2):
    """|X_dof(w)| of the chain with its contact stuck (ku on x3, kv on `normal`), 1 N
    on x1: the linear FRF |(K_s - w^2 M + i w BETA K)^-1 F|, w [rad/s]."""
    Ks = K_CHAIN.copy()
    Ks[2, 2] += KU_CHAIN
    Ks[normal, normal] += KV_CHAIN
    return abs(np.linalg.solve(Ks - w * w * np.eye(3) + 1j * w * BETA * K_CHAIN,
                               [1.0, 0.0, 0.0])[dof])


def stuck_peak(dof, normal=2):
    """(amplitude [m], frequency [rad/s]) of the first resonance peak of |X_dof| of the
    stuck chain (see `stuck_chain_amplitude`), within 3 % of its first natural frequency."""
    Ks = K_CHAIN.copy()
    Ks[2, 2] += KU_CHAIN
    Ks[normal, normal] += KV_CHAIN
    w0 = np.sqrt(np.linalg.eigvalsh(Ks)[0])
    r = minimize_scalar(lambda w: -stuck_chain_amplitude(w, dof, normal),
                        bounds=(0.97 * w0, 1.03 * w0), method="bounded", options={"xatol": 1e-12})
    return -r.fun, r.x


# --------------------------------------------------------------------------- 3-DOF shrouded blade
# pipeline.paper_systems.blade3 at H = 10: orbits whose stability event-driven time
# integration settles (rad/s): stable, and inside the period-doubling window
BLADE_STABLE = [113.156, 113.754, 114.407, 115.073, 118.120, 119.254, 120.927]
BLADE_UNSTABLE = [116.186, 116.560]


# --------------------------------------------------------------------------- lumped disks
# Laxalde et al. (2007), the numbers of studies/disk_laxalde.toml: per sector a disk mass
# md on ground (kG), neighbouring disk masses tied by k0, blade masses mb1 (on the disk
# mass, kb1) and mb2 (on mb1, kb2), a shroud contact ku between mb2 neighbours
MD, MB1, MB2 = 1.2, 0.35, 0.25              # kg
KG, K0, KB1, KB2 = 6e5, 5e7, 1e6, 2e6       # N/m
KU = 2e5                                     # N/m


def closed_form_hz(nd, stuck, N=24):
    """Natural frequencies [Hz] of the Laxalde disk at nodal diameter nd, its 3 x 3
    cyclic eigenproblem written out by hand: the disk spring and (stuck) the shroud
    spring give 2 k (1 - cos psi), psi = 2 pi nd / N."""
    c = 2.0 * (1.0 - np.cos(2 * np.pi * nd / N))
    K = np.array([[KG + KB1 + K0 * c, -KB1, 0.0], [-KB1, KB1 + KB2, -KB2],
                  [0.0, -KB2, KB2 + (KU * c if stuck else 0.0)]])
    return np.sqrt(la.eigh(K, np.diag([MD, MB1, MB2]), eigvals_only=True)) / (2 * np.pi)


def laxalde_sector(N=24, n0=5.0, mu=0.3, kv=0.0, normal=False, forcing=1.0):
    """DOFs (xd, xb1, xb2); the disk spring k0 stretches by xd_{j+1} - xd_j; a
    Jenkins element between neighbouring tip masses, u = xb2_{j+1} - xb2_j (with
    `normal`, v = xb1_{j+1} - xb1_j also loads it); `forcing` N on xb2 [SI]."""
    M = np.diag([MD, MB1, MB2])
    K = np.array([[KG + KB1, -KB1, 0.0], [-KB1, KB1 + KB2, -KB2], [0.0, -KB2, KB2]])
    Ks, Kn = spring_stiffness([[-1, 0, 0, 1, 0, 0]], [K0], 3)
    e = np.eye(3)
    Bn, Bn_next = (-e[[1]], e[[1]]) if normal else (0 * e[[1]], 0 * e[[1]])
    F = np.zeros((3, 2), complex)
    F[2, 1] = forcing
    return Sector(M=M, C=2e-5 * K, K=K, Bt=-e[[2]], Bn=Bn, Bt_next=e[[2]], Bn_next=Bn_next,
                  contact=YangMenq(KU, kv, mu, n0), forcing=F, sectors=N,
                  dof_names=("xd", "xb1", "xb2"), K_spring=Ks, K_next=Kn)


def solve_sector(sec, eo, Om, method="exact", n_samples=120, H=3):
    """One sector's harmonic balance at engine order eo and frequency Om [rad/s], by
    Newton from rest to 1e-12 of the force scale: (problem, Q (n, 2H+1))."""
    prob = hbm.setup(sector_system(sec, eo), H, method, n_samples)
    tol = 1e-12 * hbm.force_scale(prob)
    nr = newton(lambda y: hbm.residual(prob, y, Om)[:2], np.zeros(prob.size), tol, max_iter=80)
    assert nr.success
    return prob, hbm.recover(prob, nr.x.reshape(prob.c.size, -1), Om)


# --------------------------------------------------------------------------- FE blades
def frequencies(K, M):
    """All undamped frequencies [rad/s] of (K, M), each from the formulation that is
    accurate for it: K x = w^2 M x above the geometric mean of the range, M x = K x / w^2
    below it (a dense solver's error is eps times the largest eigenvalue of the
    formulation; Craig-Bampton models span w_max / w_min ~ 3e4)."""
    hi = np.sqrt(la.eigh(K, M, eigvals_only=True))
    lo = 1.0 / np.sqrt(la.eigh(M, K, eigvals_only=True)[::-1])
    return np.where(hi < np.sqrt(hi[0] * hi[-1]), lo, hi)


def stuck_stiffness(s):
    """K + B^H ku B + B_n^H kv B_n of a system (B = Bt + exp(i phi) Bt_next for a
    cyclic sector), the elements in contact (n0 > 0) stuck."""
    Bt, Bn = dense(s.Bt), dense(s.Bn)     # a full wheel is stored sparse
    if s.cyclic is not None:
        z = np.exp(1j * s.cyclic.phase)
        Bt, Bn = Bt + z * s.cyclic.Bt_next, Bn + z * s.cyclic.Bn_next
    el = s.contact
    return (dense(s.K) + Bt.conj().T @ (el.ku[:, None] * Bt)
            + Bn.conj().T @ ((el.kv * (el.n0 > 0))[:, None] * Bn))


def plane_motion(a1, a2, av, nh):
    """One 2D friction element's motion (1, 3, nh): tangents with first and second
    harmonics of amplitudes a1, a2 and no symmetry (no tied extrema), the normal av."""
    X = np.zeros((1, 3, nh))
    X[0, 0, 1], X[0, 0, 4], X[0, 1, 2], X[0, 1, 3] = a1, 0.2 * a1, a2, 0.3 * a2
    X[0, 0, 2], X[0, 1, 1] = 0.13 * a1, 0.17 * a2
    X[0, 2, 1], X[0, 2, 2] = av, 0.5 * av
    return X


def law_jacobian_errors(law, X, n_samples, h):
    """{(d, d'): max |J - central differences|} [N/m] of element 0 of a contact law at
    the motion X (E, D, 2H+1), step h [m] on each coefficient of X[0, d']."""
    got = law.evaluate(X, n_samples=n_samples).J
    nh = X.shape[-1]
    out = {}
    for p, (d, k) in enumerate(law.pairs):
        fd = np.empty((nh, nh))
        for j in range(nh):
            Xp, Xm = X.copy(), X.copy()
            Xp[0, k, j] += h
            Xm[0, k, j] -= h
            fd[:, j] = (law.evaluate(Xp, n_samples=n_samples, jacobian=False).F[0, d]
                        - law.evaluate(Xm, n_samples=n_samples, jacobian=False).F[0, d]) / (2 * h)
        out[(d, k)] = float(np.abs(got[0, p] - fd).max())
    return out
