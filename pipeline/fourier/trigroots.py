"""Sign changes of real trigonometric polynomials over one period, certified.

p(tau) = P0 + sum_j Pc_j cos(j tau) + Ps_j sin(j tau), many polynomials at once.

Why no sign change is missed: with the bound
    D3 = sum_j j^3 sqrt(Pc_j^2 + Ps_j^2) >= max |p'''|,
Taylor's theorem with remainder certifies that an interval of half-width d around c
  * has no root if |p(c)| > d |p'(c)| + d^2/2 |p''(c)| + d^3/6 D3, and
  * is monotone (at most one root, present iff the end values differ in sign) if
    |p'(c)| > d |p''(c)| + d^2/2 D3.
Intervals with neither certificate are split in four until d < `resolution`; there
a sign change of the end values is reported.  Hence every sign change is found
except pairs of crossings closer than 2*resolution (1e-12 rad by default), which
bound an excursion of height < resolution^2 max|p''| / 2: a tangency for every
purpose here.  Tangencies (touching zero without crossing) are deliberately not
reported: nothing switches there.  Each root is polished by safeguarded Newton
inside its bracket, to 1e-13 rad or the polynomial's own conditioning.
"""
from __future__ import annotations

import numpy as np

from .harmonics import basis, harmonics_of

TWO_PI = 2 * np.pi


def _eval(P, tau, order=0):
    """p^(order)(tau) for rows P (K, 2H+1) at tau (K,)."""
    H = harmonics_of(P.shape[-1])
    return np.einsum("kc,kc->k", basis(tau, H, order), P)


def _eval01(P, x):
    """p(x) and p'(x) for rows P (K, 2H+1) at x (K,), from one set of cos/sin."""
    H = harmonics_of(P.shape[-1])
    j = np.arange(1, H + 1, dtype=float)
    arg = x[:, None] * j
    c, s = np.cos(arg), np.sin(arg)
    a, b = P[:, 1::2], P[:, 2::2]
    return P[:, 0] + np.einsum("kj,kj->k", a, c) + np.einsum("kj,kj->k", b, s), \
        np.einsum("kj,kj->k", b * j, c) - np.einsum("kj,kj->k", a * j, s)


def polish_root(P, lo, hi, plo, flo=None, fhi=None):
    """Roots of the trigonometric polynomials P (K, 2H+1), one in each [lo, hi] (K,).

    Each p changes sign on its interval, p(lo) having the sign plo (K,); safeguarded
    Newton with bisection, to round-off.  Starts from the secant point when the end
    values flo, fhi are given.  lo and hi are overwritten (the final brackets).
    """
    if flo is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            x = lo - flo * (hi - lo) / (fhi - flo)
        x = np.where(np.isfinite(x) & (x > lo) & (x < hi), x, 0.5 * (lo + hi))
    else:
        x = 0.5 * (lo + hi)
    up = plo < 0  # p increases through the root
    act = np.arange(x.size)
    # evaluation round-off of p: cos(j x), sin(j x) carry ~ j x eps each
    H = harmonics_of(P.shape[-1])
    weight = np.concatenate([[1.0], np.repeat(1.0 + 2 * np.pi * np.arange(1, H + 1), 2)])
    noise = 8 * np.finfo(float).eps * (np.abs(P) * weight).sum(1)
    for _ in range(100):
        Pa, xa, loa, hia = P[act], x[act], lo[act], hi[act]
        f, fp = _eval01(Pa, xa)
        right = (f > 0) == up[act]  # root is left of x
        hia = np.where(right, xa, hia)
        loa = np.where(right, loa, xa)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = -f / fp
        # converged on the raw Newton step (x itself may have just become a bracket
        # end, which must not turn a converged iterate into a bisection); at noise
        # level a flat root keeps iterating, its bracket shrinking, until the step
        # is tiny too
        tiny = np.abs(newton) < 1e-14
        small = (np.abs(f) <= noise[act]) & (np.abs(newton) < 1e-11)
        xn = xa + newton
        bad = ~np.isfinite(xn) | (xn <= loa) | (xn >= hia)
        xn = np.where(bad, 0.5 * (loa + hia), xn)
        keep = tiny | small | (f == 0)
        done = keep | (hia - loa < 1e-13)
        x[act] = np.where(keep, xa, xn)
        lo[act], hi[act] = loa, hia
        act = act[~done]
        if act.size == 0:
            break
    return x


def _certify(p0, p1, p2, d, D3):
    """(no root, monotone) certificates on [c-d, c+d] from p, p', p'' at c and D3."""
    no_root = np.abs(p0) > d * np.abs(p1) + d * d / 2 * np.abs(p2) + d**3 / 6 * D3
    mono = np.abs(p1) > d * np.abs(p2) + d * d / 2 * D3
    return no_root, mono


def sign_changes(P: np.ndarray, resolution: float = 1e-12, n_initial: int = 0):
    """Sign-changing roots of each row of P (M, 2H+1) in [0, 2 pi).

    Returns (roots, slope): arrays (M, R) sorted along axis 1 and padded with NaN
    (roots) / 0 (slope = +1 for an upward crossing, -1 for a downward one).
    """
    P = np.asarray(P, dtype=float)
    M, nc = P.shape
    H = harmonics_of(nc)
    if H == 0 or M == 0:
        return np.full((M, 0), np.nan), np.zeros((M, 0), dtype=int)
    j = np.arange(1, H + 1, dtype=float)
    amp = np.hypot(P[:, 1::2], P[:, 2::2])
    D3 = amp @ j**3
    scale = np.abs(P[:, 0]) + amp.sum(1)
    live = np.flatnonzero(amp.max(1) > 1e-14 * scale)  # constant rows have no roots
    N = n_initial or max(16, 8 * H)
    d = np.pi / N

    # the grid is offset by an irrational fraction of a cell: symmetric motions put
    # roots exactly at 0, pi/2, pi..., where a node would see an ambiguous sign
    tau_nodes = TWO_PI * (np.arange(N + 1) + 0.3819660112501051) / N
    centers = tau_nodes[:-1] + d
    Pl = P[live]
    pn = Pl @ basis(tau_nodes, H).T
    pn[:, -1] = pn[:, 0]  # one point of the circle, one sign
    pc, pc1, pc2 = (Pl @ basis(centers, H, k).T for k in range(3))
    no_root, mono = _certify(pc, pc1, pc2, d, D3[live][:, None])
    sgn = np.where(pn >= 0, 1, -1)
    change = sgn[:, :-1] != sgn[:, 1:]

    rows, lo, hi, slo, flo, fhi = [], [], [], [], [], []
    r, k = np.nonzero(mono & ~no_root & change)
    rows.append(live[r]); lo.append(tau_nodes[k]); hi.append(tau_nodes[k + 1]); slo.append(sgn[r, k])
    flo.append(pn[r, k]); fhi.append(pn[r, k + 1])

    r, k = np.nonzero(~no_root & ~mono)  # uncertified: refine
    urow, uc = live[r], centers[k]
    while urow.size and d > resolution:
        d /= 4
        urow = np.repeat(urow, 4)
        uc = np.repeat(uc, 4) + np.tile(np.array([-3.0, -1.0, 1.0, 3.0]) * d, uc.size)
        Pu = P[urow]
        no_root, mono = _certify(*(_eval(Pu, uc, k) for k in range(3)), d, D3[urow])
        pl, ph = _eval(Pu, uc - d), _eval(Pu, uc + d)
        sl, sh = np.where(pl >= 0, 1, -1), np.where(ph >= 0, 1, -1)
        keep = mono & ~no_root & (sl != sh)
        rows.append(urow[keep]); lo.append(uc[keep] - d); hi.append(uc[keep] + d); slo.append(sl[keep])
        flo.append(pl[keep]); fhi.append(ph[keep])
        unc = ~no_root & ~mono
        urow, uc = urow[unc], uc[unc]
    if urow.size:  # at resolution: a crossing only where the end values differ in sign
        pl, ph = _eval(P[urow], uc - d), _eval(P[urow], uc + d)
        sl, sh = np.where(pl >= 0, 1, -1), np.where(ph >= 0, 1, -1)
        keep = sl != sh
        rows.append(urow[keep]); lo.append(uc[keep] - d); hi.append(uc[keep] + d); slo.append(sl[keep])
        flo.append(pl[keep]); fhi.append(ph[keep])

    rows = np.concatenate(rows).astype(int)
    lo, hi, slo = np.concatenate(lo), np.concatenate(hi), np.concatenate(slo)
    flo, fhi = np.concatenate(flo), np.concatenate(fhi)
    roots = polish_root(P[rows], lo.copy(), hi.copy(), slo, flo, fhi) if rows.size else lo
    roots = np.mod(roots, TWO_PI)
    counts = np.bincount(rows, minlength=M)
    R = int(counts.max()) if rows.size else 0
    out = np.full((M, R), np.nan)
    slope = np.zeros((M, R), dtype=int)
    order = np.lexsort((roots, rows))
    rows, roots, slo = rows[order], roots[order], slo[order]
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    pos = np.arange(rows.size) - start[rows]
    out[rows, pos] = roots
    slope[rows, pos] = -slo
    return out, slope
