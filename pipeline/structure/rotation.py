"""A blade turning about the disk axis: centrifugal load, stress stiffening, spin softening.

In the frame turning with the disk at the speed Omega [rad/s] about the axis e through
the point c, small vibrations u about the static deflection u_s obey (e.g. Geradin &
Rixen, Mechanical Vibrations, 3rd ed., sec. 5.9; the prestressed modal analysis of
every FE code):

    M u'' + G u' + [K + Omega^2 (K_sigma1 - M_P)] u = f(t),      K u_s = Omega^2 f_1,

    f_1      = int rho P (x - c) . v dV                         centrifugal load per Omega^2
    M_P      = int rho (P u) . (P v) dV,   P = I - e e^T          spin softening
    K_sigma1 = int sigma_1 : (grad u^T grad v) dV               stress (geometric) stiffness
               of the stress sigma_1 = C : eps(u_1), K u_1 = f_1,

and the blade vibrates about its deflected shape u_s = Omega^2 u_1: linearised about it
(total Lagrangian, the Green-Lagrange strain E(u) = sym(H) + H^T H / 2, H = grad u),
the strain of a vibration v is sym(grad v) + sym(H_s^T grad v), so the elastic
stiffness gains the initial-displacement terms

    K_u1 = int sym(H_1^T grad u) : C : sym(grad v) + sym(grad u) : C : sym(H_1^T grad v) dV,
    K_u2 = int sym(H_1^T grad u) : C : sym(H_1^T grad v) dV,          H_1 = grad u_1,

exactly Omega^2 K_u1 + Omega^4 K_u2 (a twisted blade untwists: its in-plane and
out-of-plane modes couple differently; CalculiX's `*FREQUENCY, PERTURBATION` after a
linear `*STATIC` step builds the same tangent: on a twisted blade at 15,000 rpm the
frequencies agree to 5e-7, without these terms two were off by 1.0 % and 0.8 %).  So
K(Omega) - K = Omega^2 (K_sigma1 - M_P + K_u1) + Omega^4 K_u2
(`RotationTerms.speed_stiffness`).
Assumed: linear prestress (the static step without spin softening
and at small displacement, so sigma grows exactly with Omega^2 -- spin softening of the
static radial stretch is (Omega / omega_axial)^2, below 1e-3 for blades well under
their axial frequencies); the Coriolis (gyroscopic) matrix
G = 2 Omega int rho u . (e x v) dV is neglected: it couples the in-plane and radial
motions, whose frequencies are far apart on a blade, and moves the frequencies at
second order: on the default wheel blade at 15,000 rpm by at most 0.2 %
(`tests/structure/test_rotation.py`).
The in-plane bending modes lose Omega^2 through M_P (their Southwell coefficient is
the out-of-plane one less 1); the out-of-plane (flap) ones keep S Omega^2 of the
stress stiffness (S_1 = 1.193 for a uniform cantilever at zero hub radius).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from skfem import Basis, BilinearForm, ElementVector, LinearForm
from skfem.helpers import ddot, dot, eye, grad, mul, sym_grad, trace, transpose
from skfem.models.elasticity import lame_parameters


@dataclass(frozen=True, eq=False)
class RotationTerms:
    """Per Omega^2, over the blade's free DOFs: `load` f_1 (n,) [kg m = N s^2],
    `stiffness` K_sigma1 - M_P (n, n) [kg] (the prestress), `static` u_1 = K^-1 f_1
    (n,) [m s^2]; `deflected` (K_1 (n, n) [kg], K_2 (n, n) [kg s^2]): the further terms
    of Omega^2 and Omega^4 (the initial displacement K_u1, K_u2, or a fit), None: none.
    `limit` [rad/s]: the highest speed the terms hold at (exported matrices are fitted
    up to their highest speed, `fitted_terms`), None: any."""

    load: np.ndarray
    stiffness: sp.csr_matrix
    static: np.ndarray
    deflected: tuple | None = None
    limit: float | None = None

    def speed_stiffness(self, omega: float) -> sp.csr_matrix:
        """K(Omega) - K (n, n) [N/m] at the speed `omega` [rad/s]."""
        s = omega * omega
        if self.deflected is None:
            return s * self.stiffness
        K1, K2 = self.deflected
        return s * (self.stiffness + K1) + s * s * K2


def rotation_terms(sbasis, free, K, E: float, nu: float, rho: float, centre, axis=(1.0, 0, 0)
                   ) -> RotationTerms:
    """`RotationTerms` of a solid blade: `sbasis` its scalar scikit-fem basis (vector DOF
    3 s + c), `free` its free vector DOFs, `K` its stiffness on them [N/m]; material E
    [Pa], nu, rho [kg/m^3]; the disk axis through `centre` [m] along `axis`."""
    e = np.asarray(axis, float) / np.linalg.norm(axis)
    P = np.eye(3) - np.outer(e, e)
    n = 3 * sbasis.N
    load = centrifugal_load(sbasis, rho, centre, axis)
    f1 = load[free]
    u1 = np.zeros(n)
    u1[free] = sla.spsolve(K.tocsc(), f1)
    lam, mu = lame_parameters(E, nu)
    g = np.stack([sbasis.interpolate(u1[comp::3]).grad for comp in range(3)])  # (c, a, E, q)
    eps = 0.5 * (g + g.transpose(1, 0, 2, 3))
    sigma = lam * np.einsum("aaeq->eq", eps)[None, None] * np.eye(3)[:, :, None, None] \
        + 2.0 * mu * eps

    @BilinearForm
    def stress(u, v, w):
        return dot(mul(w.sigma, grad(u)), grad(v))

    @BilinearForm
    def mass(u, v, w):
        return rho * u * v

    Ks = stress.assemble(sbasis, sigma=sigma)
    Ms = mass.assemble(sbasis)
    full = sp.kron(Ks, sp.identity(3)) - sp.kron(Ms, sp.csr_matrix(P))
    stiffness = full.tocsr()[free][:, free].tocsr()
    K_u1, K_u2 = initial_displacement(sbasis, u1, lam, mu)
    return RotationTerms(f1, stiffness, u1[free],
                         (K_u1.tocsr()[free][:, free].tocsr(), K_u2.tocsr()[free][:, free].tocsr()))


def initial_displacement(sbasis, u1, lam: float, mu: float) -> tuple:
    """(K_u1, K_u2) (3 N, 3 N) [kg, kg s^2]: the initial-displacement stiffness of the
    static deflection u_1 (3 N,) per Omega^2 (module doc), Lame parameters lam, mu [Pa],
    on the vector DOFs 3 s + c (scikit-fem's ElementVector order)."""
    vb = Basis(sbasis.mesh, ElementVector(sbasis.elem), quadrature=sbasis.quadrature)
    H1 = vb.interpolate(u1).grad

    def strain(a):
        return 0.5 * (a + transpose(a))

    def stress(e):
        return 2.0 * mu * e + lam * eye(trace(e), 3)

    @BilinearForm
    def linear(u, v, w):
        nu_, nv = strain(mul(transpose(w.h), grad(u))), strain(mul(transpose(w.h), grad(v)))
        return ddot(stress(nu_), sym_grad(v)) + ddot(sym_grad(u), stress(nv))

    @BilinearForm
    def quadratic(u, v, w):
        nu_, nv = strain(mul(transpose(w.h), grad(u))), strain(mul(transpose(w.h), grad(v)))
        return ddot(stress(nu_), nv)

    return linear.assemble(vb, h=H1), quadratic.assemble(vb, h=H1)


def centrifugal_load(sbasis, rho: float, centre, axis=(1.0, 0, 0)) -> np.ndarray:
    """f_1 (3 N,) [kg m]: int rho P (x - c) . v dV, the centrifugal load per Omega^2 on
    the vector DOFs 3 s + c of the scalar basis `sbasis` (P = I - e e^T, the axis e
    through `centre`)."""
    e = np.asarray(axis, float) / np.linalg.norm(axis)
    P = np.eye(3) - np.outer(e, e)
    c = np.asarray(centre, float)

    def radial(k):
        @LinearForm
        def form(v, w):
            return rho * sum(P[k, j] * (w.x[j] - c[j]) for j in range(3)) * v
        return form

    load = np.zeros(3 * sbasis.N)
    for comp in range(3):
        load[comp::3] = radial(comp).assemble(sbasis)
    return load


def fitted_terms(load, K, omegas, stiffnesses) -> RotationTerms:
    """`RotationTerms` of a blade whose stiffness was exported at the speeds `omegas`
    [rad/s] (`stiffnesses`: K(Omega_k) (n, n) [N/m] over the free DOFs, stress
    stiffening, spin softening and deflection included by the exporting code):
    K(Omega) = K + s K_1 + s^2 K_2, s = Omega^2, through them -- two speeds fix K_1 and
    K_2, more are fitted by least squares.  One speed is refused: it would fix K_1 alone,
    and the deflected geometry's Omega^4 part is not small (on a twisted blade a fit
    through 15,000 rpm alone misses the frequencies at 10,000 rpm by 12 %, two speeds by
    3e-7).  `load` f_1 (n,) [kg m] the centrifugal load per Omega^2 (u_1 = K^-1 f_1 for
    the interference).  The fit holds up to the highest speed (`RotationTerms.limit`)."""
    s = np.asarray(omegas, float) ** 2
    if s.size < 2 or np.unique(s).size != s.size or np.any(s <= 0):
        raise ValueError(f"the stiffness must be exported at two or more distinct speeds > 0 "
                         f"(got {s.size}): K(Omega) = K + Omega^2 K_1 + Omega^4 K_2")
    C = np.linalg.pinv(np.column_stack([s, s * s]))     # (2, speeds)
    D = [sp.csr_matrix(Ks - K) for Ks in stiffnesses]
    K1, K2 = (sum(C[i, k] * D[k] for k in range(s.size)).tocsr() for i in range(2))
    static = sla.spsolve(K.tocsc(), load)
    return RotationTerms(load, K1, static, (sp.csr_matrix(K.shape), K2),
                         limit=float(np.sqrt(s.max())))
