"""The elements of a contact face: the shape functions of its facets and the point of a
facet under a given location, so that a face's displacement can be interpolated anywhere
on it (the pairing of shroud faces whose meshes do not match, `disk.pairing`).

A facet is given by the indices of its points (rows of the face's `ContactFrame.points`)
in the local order of its kind, told apart by the number of points:

    tri3   corners 0 1 2                     tri6   + mid-edges 01 12 20
    quad4  corners 0 1 2 3 (in turn)         quad8  + mid-edges 01 12 23 30
                                             quad9  + the centre

On a quadratic facet the mid-edge points are the geometry's own (a curved element's
midside nodes, or the midpoints of a straight one), so the map x(xi) = sum_i N_i(xi) x_i
is the isoparametric one of the element, and the displacement of a point on the facet is
sum_i N_i(xi) d_i, as in the FE model.  Reference coordinates: triangles (r, s) with
r, s >= 0, r + s <= 1; quadrilaterals (r, s) in [-1, 1]^2.
"""
from __future__ import annotations

import numpy as np

KINDS = {3: "tri3", 6: "tri6", 4: "quad4", 8: "quad8", 9: "quad9"}
CORNERS = {"tri3": 3, "tri6": 3, "quad4": 4, "quad8": 4, "quad9": 4}


def kind_of(n_points: int) -> str:
    """The facet kind of a facet with `n_points` points (ValueError if none)."""
    try:
        return KINDS[n_points]
    except KeyError:
        raise ValueError(f"a contact-face facet of {n_points} points is none of "
                         f"{', '.join(f'{k} ({n})' for n, k in KINDS.items())}") from None


def shape(kind: str, r: float, s: float):
    """(N (n,), dN/dr (n,), dN/ds (n,)) of a facet of `kind` at (r, s)."""
    if kind in ("tri3", "tri6"):
        L = np.array([1.0 - r - s, r, s])
        dL = np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])
        if kind == "tri3":
            return L, dL[0], dL[1]
        pairs = ((0, 1), (1, 2), (2, 0))
        N = np.concatenate([L * (2 * L - 1), [4 * L[a] * L[b] for a, b in pairs]])
        dN = [np.concatenate([(4 * L - 1) * dL[k], [4 * (dL[k, a] * L[b] + L[a] * dL[k, b])
                                                    for a, b in pairs]]) for k in range(2)]
        return N, dN[0], dN[1]
    ri, si = np.array([-1.0, 1.0, 1.0, -1.0]), np.array([-1.0, -1.0, 1.0, 1.0])
    if kind == "quad4":
        return (0.25 * (1 + ri * r) * (1 + si * s), 0.25 * ri * (1 + si * s),
                0.25 * (1 + ri * r) * si)
    if kind == "quad9":
        # Lagrange: products of the 1D quadratics at -1, 0, 1
        def q(x):
            return np.array([0.5 * x * (x - 1), 1 - x * x, 0.5 * x * (x + 1)])

        def dq(x):
            return np.array([x - 0.5, -2 * x, x + 0.5])

        ia = [0, 2, 2, 0, 1, 2, 1, 0, 1]     # r position (-1, 0, 1 -> 0, 1, 2) of each point
        ib = [0, 0, 2, 2, 0, 1, 2, 1, 1]
        return (q(r)[ia] * q(s)[ib], dq(r)[ia] * q(s)[ib], q(r)[ia] * dq(s)[ib])
    # quad8, serendipity: corners, then mid-edges at (0, -1), (1, 0), (0, 1), (-1, 0)
    Nc = 0.25 * (1 + ri * r) * (1 + si * s) * (ri * r + si * s - 1)
    dNcr = 0.25 * ri * (1 + si * s) * (2 * ri * r + si * s)
    dNcs = 0.25 * si * (1 + ri * r) * (ri * r + 2 * si * s)
    rm, sm = np.array([0.0, 1.0, 0.0, -1.0]), np.array([-1.0, 0.0, 1.0, 0.0])
    on_r = rm == 0   # the mid-edges at r = 0 (bottom, top), else at s = 0 (right, left)
    Nm = np.where(on_r, 0.5 * (1 - r * r) * (1 + sm * s), 0.5 * (1 + rm * r) * (1 - s * s))
    dNmr = np.where(on_r, -r * (1 + sm * s), 0.5 * rm * (1 - s * s))
    dNms = np.where(on_r, 0.5 * sm * (1 - r * r), -s * (1 + rm * r))
    return (np.concatenate([Nc, Nm]), np.concatenate([dNcr, dNmr]),
            np.concatenate([dNcs, dNms]))


def inside(kind: str, r: float, s: float, tol: float) -> bool:
    """Whether (r, s) lies on the reference facet, within `tol` (reference units)."""
    if kind.startswith("tri"):
        return r >= -tol and s >= -tol and r + s <= 1 + tol
    return abs(r) <= 1 + tol and abs(s) <= 1 + tol


def locate(kind: str, X2, x2, iterations: int = 30):
    """Reference coordinates (r, s) of the in-plane location x2 (2,) on the facet whose
    points have in-plane coordinates X2 (n, 2): Newton on x(r, s) = x2 from the
    centre; None when it does not converge (far outside a distorted facet)."""
    r, s = (1 / 3, 1 / 3) if kind.startswith("tri") else (0.0, 0.0)
    size = np.ptp(X2, axis=0).max()
    for _ in range(iterations):
        N, dr, ds = shape(kind, r, s)
        res = N @ X2 - x2
        if np.linalg.norm(res) <= 1e-15 * size:
            return r, s
        Jm = np.column_stack([dr @ X2, ds @ X2])
        try:
            step = np.linalg.solve(Jm, res)
        except np.linalg.LinAlgError:
            return None
        r, s = r - step[0], s - step[1]
        if abs(r) > 10 or abs(s) > 10:
            return None
        if np.linalg.norm(step) <= 1e-15:
            return r, s
    return r, s


def order_facet(X2, corners, edge_points, centre=None) -> list:
    """A facet's points in the local order of its kind: `corners` (indices) turned
    counter-clockwise in the face's in-plane coordinates X2 (rows by index), then each
    edge's midside point (of `edge_points`, the one nearest the edge's chord midpoint),
    then the `centre` point, if any."""
    corners = np.asarray(corners)
    c = X2[corners]
    angle = np.arctan2(*(c - c.mean(axis=0)).T[::-1])
    corners = corners[np.argsort(angle)]
    out = list(corners)
    edge_points = list(edge_points)
    for i in range(len(corners)) if edge_points else ():
        mid = 0.5 * (X2[corners[i]] + X2[corners[(i + 1) % len(corners)]])
        j = int(np.argmin([np.linalg.norm(X2[p] - mid) for p in edge_points]))
        out.append(edge_points.pop(j))
    if centre is not None:
        out.append(centre)
    return out
