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

so the whole speed dependence is Omega^2 times `RotationTerms.stiffness` =
K_sigma1 - M_P.  Assumed: linear prestress (the static step without spin softening
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
from skfem import BilinearForm, LinearForm
from skfem.helpers import dot, grad, mul
from skfem.models.elasticity import lame_parameters


@dataclass(frozen=True, eq=False)
class RotationTerms:
    """Per Omega^2, over the blade's free DOFs: `load` f_1 (n,) [kg m = N s^2] and
    `stiffness` K_sigma1 - M_P (n, n) [kg]; `static` u_1 = K^-1 f_1 (n,) [m s^2]."""

    load: np.ndarray
    stiffness: sp.csr_matrix
    static: np.ndarray


def rotation_terms(sbasis, free, K, E: float, nu: float, rho: float, centre, axis=(1.0, 0, 0)
                   ) -> RotationTerms:
    """`RotationTerms` of a solid blade: `sbasis` its scalar scikit-fem basis (vector DOF
    3 s + c), `free` its free vector DOFs, `K` its stiffness on them [N/m]; material E
    [Pa], nu, rho [kg/m^3]; the disk axis through `centre` [m] along `axis`."""
    e = np.asarray(axis, float) / np.linalg.norm(axis)
    P = np.eye(3) - np.outer(e, e)
    c = np.asarray(centre, float)
    n = 3 * sbasis.N

    def radial(k):
        @LinearForm
        def form(v, w):
            return rho * sum(P[k, j] * (w.x[j] - c[j]) for j in range(3)) * v
        return form

    load = np.zeros(n)
    for comp in range(3):
        load[comp::3] = radial(comp).assemble(sbasis)
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
    return RotationTerms(f1, stiffness, u1[free])
