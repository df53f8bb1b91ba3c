"""Dual mortar pairing of two planar faces meshed independently (Wohlmuth, SIAM J. Numer.
Anal. 38, 2000; Popp et al., Int. J. Numer. Meth. Eng. 79, 2009).

A right-face point k (a node of the right face's facets, with the area it carries,
D_k = int N_k dA) takes the left face's displacement as the average

    d_L(k) = (1 / D_k) int_face Psi_k d_L dA = sum_l W_kl d_l,
    W_kl = (1 / D_k) int Psi_k N^L_l dA,

Psi_k the dual (biorthogonal) shape functions of the right facets, int_e Psi_k N_j dA =
delta_kj int_e N_k dA, built facet by facet: Psi = A N, A = D_e M_e^-1 (D_e, M_e the
facet's lumped and consistent mass of unit density).  What this gives (the tests):

- faces that match node for node: W is the node-to-node pairing (biorthogonality);
- a field linear over the faces: d_L(k) is its value at point k, exactly;
- a uniform traction t on the right face (nodal forces D_k t) passes to the left face as
  t int N^L_l dA, the consistent nodal forces of t there: the two-body patch test.

The products Psi_k N^L_l are integrated exactly on the intersections of right and left
facets (clipped polygons, fan triangles, a collapsed Gauss rule of degree 10), facets
with straight edges (parallelograms make the integrands polynomials).  Not applicable
(`dual_pairing` returns None; the caller pairs node to segment) unless both faces are of
9-node quadrilaterals (the faces of the package's Hex2 blades) with straight edges: the
corners of 8-node serendipity facets (C3D20) carry negative int N_k dA, those of 6-node
triangles none, so no dual basis exists there.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .facets import CORNERS, kind_of, shape

_G = np.polynomial.legendre.leggauss(6)


def cross2(a, b):
    """The z component of the cross product of in-plane vectors a, b (..., 2)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def square_rule() -> tuple:
    """(r, s, w) of the 6 x 6 Gauss rule on [-1, 1]^2."""
    x, w = _G
    r, s = np.meshgrid(x, x, indexing="ij")
    return r.ravel(), s.ravel(), np.outer(w, w).ravel()


def triangle_rule(P) -> tuple:
    """(points (q, 2), weights (q,)) of the collapsed 6 x 6 Gauss rule on the triangle
    P (3, 2) (exact for polynomials of degree 10)."""
    x, w = _G
    u, v = np.meshgrid((x + 1) / 2, (x + 1) / 2, indexing="ij")
    a, b = u.ravel(), (v * (1 - u)).ravel()        # Duffy: (u, v (1 - u))
    wt = (np.outer(w, w) / 4 * (1 - u)).ravel()
    area2 = abs(cross2(P[1] - P[0], P[2] - P[0]))
    return P[0] + np.outer(a, P[1] - P[0]) + np.outer(b, P[2] - P[0]), wt * area2


def ccw(P) -> np.ndarray:
    """The polygon P (m, 2) turned counter-clockwise (its signed area positive)."""
    P = np.asarray(P, float)
    x, y = P[:, 0], P[:, 1]
    return P if np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)) >= 0 else P[::-1]


def clip(subject, window) -> np.ndarray:
    """The intersection (m, 2) of two convex polygons (Sutherland-Hodgman; either
    orientation)."""
    out = ccw(subject)
    W = ccw(window)
    for i in range(len(W)):
        a, b = W[i], W[(i + 1) % len(W)]
        if not len(out):
            break
        side = cross2(b - a, out - a)              # >= 0: inside
        poly = []
        for j in range(len(out)):
            p, q, sp_, sq = out[j], out[(j + 1) % len(out)], side[j], side[(j + 1) % len(out)]
            if sp_ >= 0:
                poly.append(p)
            if sp_ * sq < 0:
                poly.append(p + sp_ / (sp_ - sq) * (q - p))
        out = np.asarray(poly)
    return out


def locate_all(kind: str, P, x, iterations: int = 30):
    """Reference coordinates (r, s) (m,) of the in-plane points x (m, 2) on the facet with
    points P (p, 2): Newton on x(r, s) = x for all points at once (`facets.locate`
    one by one); None when it does not converge."""
    r, s = np.zeros(len(x)), np.zeros(len(x))
    size = np.ptp(P, axis=0).max()
    for _ in range(iterations):
        N, dr, ds = shape(kind, r, s)                   # (p, m) each
        res = N.T @ P - x                               # (m, 2)
        if np.abs(res).max() <= 1e-14 * size:
            return r, s
        a, b = dr.T @ P, ds.T @ P                       # columns of the Jacobian (m, 2)
        det = cross2(a, b)
        if np.any(det == 0):
            return None
        r = r - cross2(res, b) / det                    # Cramer on [a b] (dr, ds) = res
        s = s - cross2(a, res) / det
    return None


def straight(kind: str, P) -> bool:
    """Whether the facet with in-plane points P has straight edges (its mid-edge points
    at the chord midpoints, its centre at the corners' mean, within 1e-9 of its size)."""
    n = CORNERS[kind]
    c, size = P[:n], np.ptp(P, axis=0).max()
    mids = 0.5 * (c + np.roll(c, -1, axis=0))
    ok = len(P) == n or np.abs(P[n:2 * n] - mids).max() <= 1e-9 * size
    return ok and (len(P) <= 2 * n or np.abs(P[2 * n] - c.mean(axis=0)).max() <= 1e-9 * size)


def dual_weights(kind: str, P) -> tuple | None:
    """(A (p, p), D_e (p,)) of a right facet with in-plane points P (p, 2): Psi = A N;
    None when some int N_k dA <= 0."""
    r, s, w = square_rule()
    N, dr, ds = (X.T for X in shape(kind, r, s))      # (q, p) each
    J = np.abs((dr @ P[:, 0]) * (ds @ P[:, 1]) - (dr @ P[:, 1]) * (ds @ P[:, 0]))
    Me = (N * (w * J)[:, None]).T @ N
    De = Me.sum(axis=1)
    if np.any(De <= 0):
        return None
    return De[:, None] * np.linalg.inv(Me), De


def dual_pairing(XR, facets_right, XL, facets_left) -> sp.csr_matrix | None:
    """W sparse (k_R, k_L) [-] (module doc) of right-face points XR (k_R, 2) on the left
    face's points XL (k_L, 2), both in the left face's in-plane coordinates [m], with
    their facets (local order of `structure.facets`); None where it does not apply
    (module doc) or the right facets are not covered by left ones (area to 1e-9)."""
    fr, fl = np.asarray(facets_right, int), np.asarray(facets_left, int)
    kr, kl = kind_of(fr.shape[1]), kind_of(fl.shape[1])
    if kr != "quad9" or kl != "quad9" or not all(straight(kr, XR[f]) for f in fr) \
            or not all(straight(kl, XL[f]) for f in fl):
        return None
    nr, nl = CORNERS[kr], CORNERS[kl]
    lo, hi = XL[fl[:, :nl]].min(axis=1), XL[fl[:, :nl]].max(axis=1)
    M = np.zeros((len(XR), len(XL)))
    D = np.zeros(len(XR))
    for ids in fr:
        P = XR[ids]
        dw = dual_weights(kr, P)
        if dw is None:
            return None
        A, De = dw
        D[ids] += De
        box_lo, box_hi = P[:nr].min(axis=0), P[:nr].max(axis=0)
        covered = 0.0
        for f in np.nonzero(np.all(lo <= box_hi, axis=1) & np.all(hi >= box_lo, axis=1))[0]:
            poly = clip(P[:nr], XL[fl[f, :nl]])
            for t in range(1, len(poly) - 1):
                x, wt = triangle_rule(poly[[0, t, t + 1]])
                covered += wt.sum()
                at_r, at_l = locate_all(kr, P, x), locate_all(kl, XL[fl[f]], x)
                if at_r is None or at_l is None:
                    return None
                psi = A @ shape(kr, *at_r)[0]           # (p, q)
                M[np.ix_(ids, fl[f])] += (psi * wt) @ shape(kl, *at_l)[0].T
        if abs(covered - De.sum()) > 1e-9 * De.sum():
            return None
    W = M / D[:, None]
    W[np.abs(W) < 1e-14] = 0.0
    return sp.csr_matrix(W)
