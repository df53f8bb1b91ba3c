"""Euler-Bernoulli beam blade (scikit-fem) and its closed-form cantilever frequencies.

Bending in flap (eta, EI_flap = E c t^3/12) and edge (xi, EI_edge = E t c^3/12)
with ElementLineHermite, axial (EA) and St Venant torsion (GJ, rho I_p) with P1;
the four fields are uncoupled:

    K_b: int EI w'' v'' dz,  M_b: int rho A w v dz,
    K_a: int EA u' v' dz,    K_t: int GJ th' ph' dz,   M_t: int rho I_p th ph dz.

Frames and contact conventions: `fe_model`.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from skfem import Basis, BilinearForm, ElementLineHermite, ElementLineP1, MeshLine, asm
from skfem.helpers import dd, dot, grad

from .fe_model import BladeModel, BladeParams, rotation_z

log = logging.getLogger(__name__)


@BilinearForm
def _bending(u, v, w):
    return dd(u)[0, 0] * dd(v)[0, 0]


@BilinearForm
def _stretch(u, v, w):
    return dot(grad(u), grad(v))


@BilinearForm
def _mass_scalar(u, v, w):
    return u * v


def torsion_constant(a: float, b: float) -> float:
    """St Venant J of a rectangle a x b (a >= b): a b^3 [1/3 - 0.21 (b/a)(1 - (b/a)^4/12)]."""
    a, b = max(a, b), min(a, b)
    r = b / a
    return a * b**3 * (1 / 3 - 0.21 * r * (1 - r**4 / 12))


def beam_blade(p: BladeParams) -> BladeModel:
    """Euler-Bernoulli beam blade: free DOFs [flap (w, w'), edge (w, w'), axial, torsion].

    Uncoupled fields on one MeshLine of `n_span` elements, root node clamped.  DOF
    sets hold the local translations (edge xi, flap eta, axial z) of a node.
    """
    c, t, L = p.chord, p.thickness, p.length
    A = c * t
    EI_flap, EI_edge = p.E * c * t**3 / 12, p.E * t * c**3 / 12
    J, Ip = torsion_constant(c, t), (c * t**3 + t * c**3) / 12
    z = np.linspace(0.0, L, p.n_span + 1)
    mesh = MeshLine(z)
    bh = Basis(mesh, ElementLineHermite())
    b1 = Basis(mesh, ElementLineP1())
    Kb, Mb = asm(_bending, bh), asm(_mass_scalar, bh)
    Ks, Ms = asm(_stretch, b1), asm(_mass_scalar, b1)
    K = sp.block_diag([EI_flap * Kb, EI_edge * Kb, p.E * A * Ks, p.G * J * Ks]).tocsr()
    M = sp.block_diag([p.rho * A * Mb, p.rho * A * Mb, p.rho * A * Ms, p.rho * Ip * Ms]).tocsr()
    nh, n1 = bh.N, b1.N
    off = np.array([0, nh, 2 * nh, 2 * nh + n1])
    nv = z.size
    node = np.arange(nv)
    local = np.stack([off[1] + bh.nodal_dofs[0], off[0] + bh.nodal_dofs[0],
                      off[2] + b1.nodal_dofs[0]], axis=1)  # (nv, 3): xi, eta, z
    fixed = np.concatenate([off[0] + bh.nodal_dofs[:, 0], off[1] + bh.nodal_dofs[:, 0],
                            [off[2] + b1.nodal_dofs[0, 0], off[3] + b1.nodal_dofs[0, 0]]])
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    K, M = K[free][:, free].tocsr(), M[free][:, free].tocsr()
    renum = -np.ones(K.shape[0] + fixed.size, dtype=np.int64)
    renum[free] = np.arange(free.size)
    point_dofs = renum[local]
    R = rotation_z(p.stagger_angle)
    points = np.stack([0 * z, 0 * z, z], axis=1)
    exc = int(np.argmin(abs(z - L / 3)))
    node_sets = {"root": np.array([0]), "excitation": np.array([exc]),
                 "response": np.array([nv - 1])}
    dof_sets = {k: point_dofs[v] for k, v in node_sets.items() if k != "root"}
    set_points = {k: points[v] for k, v in node_sets.items()}
    log.info("beam blade: %d elements, %d free DOFs", p.n_span, K.shape[0])
    return BladeModel(p, K, M, points, (("line", np.stack([node[:-1], node[1:]], 1)),),
                      point_dofs, R, dof_sets, set_points, {}, node_sets)


def euler_bernoulli_frequencies(p: BladeParams, n: int = 3, plane: str = "flap") -> np.ndarray:
    """Cantilever bending frequencies [Hz]: f_k = (beta_k L)^2 sqrt(EI/(rho A L^4)) / (2 pi)."""
    roots = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349,
                      14.1371683910])
    if n > roots.size:
        raise ValueError(f"n must be <= {roots.size}, got {n}")
    c, t = p.chord, p.thickness
    I = c * t**3 / 12 if plane == "flap" else t * c**3 / 12
    if plane not in ("flap", "edge"):
        raise ValueError(f"plane must be 'flap' or 'edge', got {plane!r}")
    return roots[:n] ** 2 * np.sqrt(p.E * I / (p.rho * c * t * p.length**4)) / (2 * np.pi)
