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

and the blade vibrates about its deflected shape x + Omega^2 u_1: its elastic stiffness
is that of the deflected geometry, K(x + Omega^2 u_1) (a twisted blade untwists; this
initial-displacement effect is what CalculiX's `*FREQUENCY, PERTURBATION` step after a
linear `*STATIC` step includes).  K(x + s u_1) is fitted by K + s K_1 + s^2 K_2,
s = Omega^2, through its values at s_ref / 4 and s_ref, s_ref the squared speed at
which the deflection reaches 1 % of the blade's size (`DEFLECTION_FIT`; the fit's
error is below 1e-4 of the exact deflected K's frequencies up to s_ref on a twisted
blade; its first derivative alone would not do: it turns stiff modes into the soft
ones at second order).  So the speed dependence is Omega^2 (K_sigma1 - M_P + K_1) +
Omega^4 K_2 (`RotationTerms.speed_stiffness`).
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
from skfem import Basis, BilinearForm, LinearForm, MeshHex2, MeshTet2
from skfem.helpers import dot, grad, mul
from skfem.models.elasticity import lame_parameters


DEFLECTION_FIT = 0.01   # the deflection [x blade size] of the fit's upper speed s_ref


@dataclass(frozen=True, eq=False)
class RotationTerms:
    """Per Omega^2, over the blade's free DOFs: `load` f_1 (n,) [kg m = N s^2],
    `stiffness` K_sigma1 - M_P (n, n) [kg] (the prestress), `static` u_1 = K^-1 f_1
    (n,) [m s^2]; the deflected geometry's K_1 (n, n) [kg] and, per Omega^4, K_2 (n, n)
    [kg s^2] (`deflected`: (K_1, K_2), or None when K is not the package's)."""

    load: np.ndarray
    stiffness: sp.csr_matrix
    static: np.ndarray
    deflected: tuple | None = None

    def speed_stiffness(self, omega: float) -> sp.csr_matrix:
        """K(Omega) - K (n, n) [N/m] at the speed `omega` [rad/s]."""
        s = omega * omega
        if self.deflected is None:
            return s * self.stiffness
        K1, K2 = self.deflected
        return s * (self.stiffness + K1) + s * s * K2


def rotation_terms(sbasis, free, K, E: float, nu: float, rho: float, centre, axis=(1.0, 0, 0),
                   assemble=None) -> RotationTerms:
    """`RotationTerms` of a solid blade: `sbasis` its scalar scikit-fem basis (vector DOF
    3 s + c), `free` its free vector DOFs, `K` its stiffness on them [N/m]; material E
    [Pa], nu, rho [kg/m^3]; the disk axis through `centre` [m] along `axis`.
    `assemble(basis)`: the stiffness (3 N, 3 N) [N/m] on another basis of the same
    element, for the deflected geometry (`deflected_fit`); None: K stays undeflected."""
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
    if assemble is None:
        return RotationTerms(f1, stiffness, u1[free])
    return RotationTerms(f1, stiffness, u1[free], deflected_fit(sbasis, u1, assemble, free, K))


def deflected_fit(sbasis, u1, assemble, free, K) -> tuple:
    """(K_1, K_2) over the free DOFs: K(x + s u_1) = K + s K_1 + s^2 K_2 through the
    stiffness `assemble`d on the geometry deflected by s = s_ref / 4 and s_ref, s_ref
    max|u_1| = `DEFLECTION_FIT` x the blade's size (u_1 (3 N,) per Omega^2)."""
    geo, D = geometry_field(sbasis, u1)
    amp = float(np.abs(D).max())
    if amp == 0.0:
        zero = sp.csr_matrix(K.shape)
        return zero, zero
    s2 = DEFLECTION_FIT * float(np.ptp(geo.doflocs, axis=1).max()) / amp
    s1 = s2 / 4.0
    Ka, Kb = (assemble(Basis(type(geo)(geo.doflocs + s * D, geo.t), sbasis.elem,
                             quadrature=sbasis.quadrature))[free][:, free] - K
              for s in (s1, s2))
    K2 = (Kb / s2 - Ka / s1) / (s2 - s1)
    return (Ka / s1 - s1 * K2).tocsr(), K2.tocsr()


def geometry_field(sbasis, u) -> tuple:
    """(quadratic mesh, D (3, n_nodes)): the isoparametric MeshHex2 / MeshTet2 of the
    basis' mesh (its own geometry, also for straight-edged cells) and the vector field
    u (3 N,), DOF 3 s + c of the scalar basis, at that mesh's geometry nodes."""
    mesh = sbasis.mesh
    if isinstance(mesh, (MeshHex2, MeshTet2)):
        geo = mesh
    else:
        geo = (MeshHex2 if mesh.t.shape[0] == 8 else MeshTet2).from_mesh(mesh)
    gelem = geo.elem()
    ref = np.asarray(gelem.doflocs, float)
    probe = Basis(mesh, sbasis.elem, quadrature=(ref.T, np.ones(len(ref))))
    gdofs = Basis(geo, gelem, quadrature=(ref.T, np.ones(len(ref)))).element_dofs
    D = np.zeros((3, geo.doflocs.shape[1]))
    for c in range(3):
        D[c, gdofs] = np.asarray(probe.interpolate(u[c::3])).T
    return geo, D
