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
from skfem.helpers import dot, grad, mul
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
        """K(Omega) - K (n, n) [N/m] at the speed `omega` [rad/s]; ValueError beyond
        `limit` (a fit is not extrapolated)."""
        if self.limit is not None and omega > self.limit * (1.0 + 1e-9):
            raise ValueError(f"speed {omega * 30 / np.pi:g} rpm is beyond the highest speed of "
                             f"the exported stiffness ({self.limit * 30 / np.pi:g} rpm): the fit "
                             "K + Omega^2 K_1 + Omega^4 K_2 is not extrapolated; export K at "
                             "the highest speed studied")
        s = omega * omega
        if self.deflected is None:
            return s * self.stiffness
        K1, K2 = self.deflected
        return s * (self.stiffness + K1) + s * s * K2


def rotation_terms(sbasis, free, K, E: float, nu: float, rho: float, centre, axis=(1.0, 0, 0),
                   joined=None) -> RotationTerms:
    """`RotationTerms` of a solid blade: `sbasis` its scalar scikit-fem basis (vector DOF
    3 s + c), `free` its free vector DOFs, `K` its stiffness on them [N/m]; material E
    [Pa], nu, rho [kg/m^3]; the disk axis through `centre` [m] along `axis`.  `joined`
    (sparse (n_free, m)): u = joined q for a sector of a disk whose cut faces are joined
    to its neighbours' (nodal diameter 0, `cyclic_cut.cut_maps` A + B), so that its static
    deflection u_1 = J (J^T K J)^-1 J^T f_1 is the wheel's, not a loose sector's."""
    e = np.asarray(axis, float) / np.linalg.norm(axis)
    P = np.eye(3) - np.outer(e, e)
    n = 3 * sbasis.N
    load = centrifugal_load(sbasis, rho, centre, axis)
    f1 = load[free]
    u1 = np.zeros(n)
    if joined is None:
        u1[free] = sla.spsolve(K.tocsc(), f1)
    else:
        J = sp.csr_matrix(joined)
        u1[free] = J @ sla.spsolve((J.T @ K @ J).tocsc(), J.T @ f1)
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


def initial_displacement(sbasis, u1, lam: float, mu: float, chunk: int = 256) -> tuple:
    """(K_u1, K_u2) (3 N, 3 N) [kg, kg s^2]: the initial-displacement stiffness of the
    static deflection u_1 (3 N,) per Omega^2 (module doc), Lame parameters lam, mu [Pa],
    on the vector DOFs 3 s + c of the scalar basis `sbasis`.

    Vectorised over elements, as `solid.assemble_elasticity` (scikit-fem's generic
    form loop makes one numpy call per local DOF pair, 2 x 3600 on a 20-node
    hexahedron: 11.3 s of CPU on the 7,878-DOF curved wheel blade, 2.2 s here).  The shape function phi_i along
    e_a has grad u = e_a g_i (g_i = grad phi_i), so sym(grad u) = sym(e_a g_i) and the
    strain of the deflection sym(H^T grad u) = sym(h_a g_i), h_a the row a of H_1;
    with sigma(A) : B = 2 mu A : B + lam tr A tr B on symmetric tensors,

        K_u1 = int sigma(N_u) : E_v + E_u : sigma(N_v) dV,   K_u2 = int sigma(N_u) : N_v dV,

    E = sym(e_a g_i) and N = sym(h_a g_i) per local vector DOF (i, a)."""
    vb = Basis(sbasis.mesh, ElementVector(sbasis.elem), quadrature=sbasis.quadrature)
    H = np.asarray(vb.interpolate(u1).grad)                               # (a, k, E, q)
    nb = len(sbasis.basis)
    G = np.stack([sbasis.basis[i][0].grad for i in range(nb)], axis=1)    # (k, nb, E, q)
    W = sbasis.dx                                                         # (E, q)
    ne, eye = W.shape[0], np.eye(3)
    K1 = np.empty((ne, 3 * nb, 3 * nb))
    K2 = np.empty((ne, 3 * nb, 3 * nb))
    for lo in range(0, ne, chunk):
        e = slice(lo, min(lo + chunk, ne))
        g = G[:, :, e].transpose(2, 1, 0, 3)                              # (e, i, k, q)
        h = H[:, :, e].transpose(2, 0, 1, 3)                              # (e, a, j, q)
        # (e, (i, a), j, k, q): the tensors p g_i with p = e_a (E) or h_a (N)
        pe = np.einsum("ab,eikq->eiabkq", eye, g)
        pn = np.einsum("eajq,eikq->eiajkq", h, g)
        shape = (g.shape[0], 3 * nb, 3, 3, g.shape[-1])
        Eu = 0.5 * (pe + pe.swapaxes(3, 4)).reshape(shape)
        Nu = 0.5 * (pn + pn.swapaxes(3, 4)).reshape(shape)
        w = W[e][:, None, None, None, :]

        def form(A, B):
            """int sigma(A) : B over each element, (e, m, n)."""
            flat = (g.shape[0], 3 * nb, -1)
            full = (2.0 * mu * A * w).reshape(flat) @ B.reshape(flat).transpose(0, 2, 1)
            ta, tb = np.einsum("emjjq->emq", A), np.einsum("emjjq->emq", B)
            return full + lam * (ta * W[e][:, None, :]) @ tb.transpose(0, 2, 1)

        K2[e] = form(Nu, Nu)
        K1[e] = form(Nu, Eu)
        K1[e] += K1[e].transpose(0, 2, 1)
    s = sbasis.element_dofs                                               # (nb, E)
    dofs = (3 * s.T[:, :, None] + np.arange(3)).reshape(ne, 3 * nb)
    rows = np.broadcast_to(dofs[:, :, None], K1.shape).ravel()
    cols = np.broadcast_to(dofs[:, None, :], K1.shape).ravel()
    n = 3 * sbasis.N
    return tuple(sp.coo_matrix((Kd.ravel(), (rows, cols)), shape=(n, n)).tocsr()
                 for Kd in (K1, K2))


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
