"""The fully stuck slider of the 2D friction law: the centre of the stick discs and
its derivative (`kernel.march` starts a stuck or slipping cycle there)."""
from __future__ import annotations

import numpy as np
from numba import njit


# -- the fully stuck slider: the centre of the stick discs ---------------------------
#
# A slider sticks at every sample iff it lies in every disc |u_i - w| <= r_i.  The
# stuck start is the point that is deepest inside them all, the minimiser of the
# convex f(w) = max_i (|u_i - w| - r_i): the 1D band middle when u moves along one
# tangent (`slider_rest`), a smooth function of the motion, and stuck iff f(w) <= 0.
# It is found by active sets: the minimiser over a few samples S (supported by one,
# two or three of them: a sample, the point between two on their segment, the
# Apollonius point of three) until no sample lies further out; each pass raises t.


@njit(cache=True, error_model="numpy")
def pair_point(u, r, a, b, out):
    """Minimiser of max(|u_a - w| - r_a, |u_b - w| - r_b) on the segment between the
    samples, written to out (w1, w2, t); False if it is not strictly inside."""
    d1, d2 = u[0, b] - u[0, a], u[1, b] - u[1, a]
    d = np.sqrt(d1 * d1 + d2 * d2)
    if d <= 0.0:
        return False
    al = 0.5 * (d + r[a] - r[b])
    if not 0.0 < al < d:
        return False
    out[0], out[1], out[2] = u[0, a] + al * d1 / d, u[1, a] + al * d2 / d, al - r[a]
    return True


@njit(cache=True, error_model="numpy")
def triple_point(u, r, a, b, c, out, k):
    """Root k (0, 1) of the point w at distance r_i + t from the samples a, b, c
    (Apollonius), written to out (w1, w2, t); False if there is none with every
    r_i + t > 0."""
    x = np.array([u[0, b] - u[0, a], u[0, c] - u[0, a]])   # origin at u_a
    y = np.array([u[1, b] - u[1, a], u[1, c] - u[1, a]])
    rr = np.array([r[b], r[c]])
    det = x[0] * y[1] - x[1] * y[0]
    if abs(det) <= 1e-14 * (x[0] * x[0] + y[0] * y[0] + x[1] * x[1] + y[1] * y[1]):
        return False
    # 2 u_i . w + 2 (r_i - r_a) t = |u_i|^2 - r_i^2 + r_a^2:  w = p + q t
    cc = 0.5 * (x * x + y * y - rr * rr + r[a] * r[a])
    mm = -(rr - r[a])
    p1, p2 = (y[1] * cc[0] - y[0] * cc[1]) / det, (-x[1] * cc[0] + x[0] * cc[1]) / det
    q1, q2 = (y[1] * mm[0] - y[0] * mm[1]) / det, (-x[1] * mm[0] + x[0] * mm[1]) / det
    # |w|^2 = (r_a + t)^2
    A = q1 * q1 + q2 * q2 - 1.0
    B = 2.0 * (p1 * q1 + p2 * q2) - 2.0 * r[a]
    C = p1 * p1 + p2 * p2 - r[a] * r[a]
    if abs(A) < 1e-14:
        if k == 1 or B == 0.0:
            return False
        t = -C / B
    else:
        disc = B * B - 4.0 * A * C
        if disc < 0.0:
            return False
        s = np.sqrt(disc)
        t = (-B - s) / (2.0 * A) if k == 0 else (-B + s) / (2.0 * A)
    if min(r[a], r[b], r[c]) + t <= 0.0:
        return False
    out[0], out[1], out[2] = u[0, a] + p1 + q1 * t, u[1, a] + p2 + q2 * t, t
    return True


@njit(cache=True, error_model="numpy")
def depth(u, r, i, w1, w2):
    """|u_i - w| - r_i: how far the sample's disc leaves w outside [m]."""
    return np.sqrt((u[0, i] - w1) ** 2 + (u[1, i] - w2) ** 2) - r[i]


@njit(cache=True, error_model="numpy")
def small_minimax(u, r, S, m, tol, best, support):
    """The minimiser of max over the m samples S[:m]: every candidate support (one, two
    or three samples) that keeps the others inside, the least t; best (w1, w2, t),
    support (3,) (-1 unused)."""
    best[2] = np.inf
    cand = np.empty(3)
    for i in range(m):
        for j in range(i, m):
            for k in range(j, m):
                for root in range(2 if k > j > i else 1):
                    a, b, c = S[i], S[j], S[k]
                    if i == j == k:
                        cand[0], cand[1], cand[2] = u[0, a], u[1, a], -r[a]
                    elif j == k:
                        if i == j or not pair_point(u, r, a, b, cand):
                            continue
                    elif i == j or not triple_point(u, r, a, b, c, cand, root):
                        continue
                    if cand[2] >= best[2]:
                        continue
                    ok = True
                    for o in range(m):    # the support lies on it by construction
                        if o == i or (o == j and j > i) or (o == k and k > j):
                            continue
                        if depth(u, r, S[o], cand[0], cand[1]) > cand[2] + tol:
                            ok = False
                            break
                    if ok:
                        best[0], best[1], best[2] = cand[0], cand[1], cand[2]  # no slice copy: it compiles a shape check
                        support[0] = a
                        support[1] = b if j > i else -1
                        support[2] = c if k > j else -1


@njit(cache=True, error_model="numpy")
def stick_centres(u, r, tol, w, t, support):
    """Per element: the centre of the stick discs w (E, 2), its value t (E,) [m] (<= 0:
    the slider sticks there at every sample) and its support samples (E, 3)."""
    E, _, N = u.shape
    S = np.empty(4, np.int64)
    best = np.empty(3)
    sup = np.empty(3, np.int64)
    for e in range(E):
        ue, re = u[e], r[e]
        c1, c2 = 0.0, 0.0
        for i in range(N):
            c1 += ue[0, i] / N
            c2 += ue[1, i] / N
        S[0] = 0
        for i in range(N):
            if depth(ue, re, i, c1, c2) > depth(ue, re, S[0], c1, c2):
                S[0] = i
        m = np.int64(1)  # typed, not a literal (a literal compiles small_minimax twice)
        for _ in range(4 * N):
            small_minimax(ue, re, S, m, tol[e], best, sup)
            far, worst = -1, best[2] + tol[e]
            for i in range(N):
                if i == sup[0] or i == sup[1] or i == sup[2]:
                    continue      # on it by construction (to round-off)
                d = depth(ue, re, i, best[0], best[1])
                if d > worst:
                    far, worst = i, d
            if far < 0:
                break
            m = 0
            for s in sup:
                if s >= 0:
                    S[m] = s
                    m += 1
            S[m] = far
            m += 1
        w[e, 0], w[e, 1], t[e] = best[0], best[1], best[2]
        for q in range(3):   # no slice copy: it compiles a shape check and its message
            support[e, q] = sup[q]


@njit(cache=True, error_model="numpy")
def centre_derivative(u, w, support, S, k, c, stuck, out):
    """In force units (u the points K u_i, w the centre K w, radii mu n_i): with
    du_i = K S_i dX_t and dr_i = c S_i dX_n (c = mu kv), the centre moves by
    dw = sum_i A_i du_i + b_i dr_i over its support: one sample, w = u_a (A = I); two,
    w = u_a + alpha e on their segment, alpha = (d + r_a - r_b) / 2; three, the
    implicit derivative of |u_i - w| - r_i = t (i = a, b, c).  Adds K^-1 dw/dX (the
    slider's, in metres) into out."""
    E, nh = u.shape[0], S.shape[1]
    A = np.zeros((3, 2, 2))
    b = np.zeros((3, 2))
    idx = np.empty(3, np.int64)
    G = np.empty((3, 3))
    nrm = np.empty((3, 2))
    for e in range(E):
        if not stuck[e]:
            continue
        m = 0
        for q in range(3):
            if support[e, q] >= 0:
                idx[m] = support[e, q]
                m += 1
        A[:] = 0.0
        b[:] = 0.0
        if m == 1:
            A[0, 0, 0] = A[0, 1, 1] = 1.0
        elif m == 2:
            ia, ib = idx[0], idx[1]
            d1, d2 = u[e, 0, ib] - u[e, 0, ia], u[e, 1, ib] - u[e, 1, ia]
            d = np.sqrt(d1 * d1 + d2 * d2)
            e1, e2 = d1 / d, d2 / d
            g = (e1 * (w[e, 0] - u[e, 0, ia]) + e2 * (w[e, 1] - u[e, 1, ia])) / d   # alpha / d
            ee = ((e1 * e1, e1 * e2), (e1 * e2, e2 * e2))
            for r in range(2):
                for s in range(2):
                    Ab = 0.5 * ee[r][s] + g * ((1.0 if r == s else 0.0) - ee[r][s])
                    A[1, r, s] = Ab
                    A[0, r, s] = (1.0 if r == s else 0.0) - Ab
            b[0, 0], b[0, 1], b[1, 0], b[1, 1] = 0.5 * e1, 0.5 * e2, -0.5 * e1, -0.5 * e2
        else:
            for q in range(3):
                x1, x2 = u[e, 0, idx[q]] - w[e, 0], u[e, 1, idx[q]] - w[e, 1]
                L = np.sqrt(x1 * x1 + x2 * x2)
                nrm[q, 0], nrm[q, 1] = x1 / L, x2 / L
                G[q, 0], G[q, 1], G[q, 2] = nrm[q, 0], nrm[q, 1], 1.0
            Gi = np.linalg.inv(G)
            for q in range(3):
                for r in range(2):
                    A[q, r, 0], A[q, r, 1] = Gi[r, q] * nrm[q, 0], Gi[r, q] * nrm[q, 1]
                    b[q, r] = -Gi[r, q]
        for q in range(m):
            i = idx[q]
            for j in range(nh):
                sij = S[i, j]
                for r in range(2):
                    out[e, r, j] += A[q, r, 0] * k[e, 0] * sij / k[e, r]
                    out[e, r, nh + j] += A[q, r, 1] * k[e, 1] * sij / k[e, r]
                    out[e, r, 2 * nh + j] += b[q, r] * c[e] * sij / k[e, r]
