"""Yang-Menq contact element as plain data (paper Sec. 2, 4, 5; Eq. 1, 9, 10, 11).

One contact point with relative tangential displacement u and normal displacement
v: a tangential spring ku in series with a Coulomb slider (coefficient mu), a normal
spring kv and a preload n0 (negative = initial gap).  Normal load n = n0 + kv v
(Eq. 1).  States: stick, positive slip, negative slip, separation.

Parameters are arrays over E elements; displacements are real Fourier coefficients
in the layout of `harmonics.py`, shape (E, 2H+1).

The leaf of the contact layer: the element, its states, the result type and the
closed form of a fully stuck cycle, shared by both force evaluations
(`contact.exact`, `contact.aft`); `contact.forces` chooses between them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fourier.harmonics import basis, harmonics_of
from ..fourier.trigroots import TWO_PI


def _as_param(name, value, E=None):
    a = np.atleast_1d(np.asarray(value, dtype=float))
    if a.ndim != 1:
        raise ValueError(f"{name} must be a scalar or a 1-D array, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if E is not None and a.size not in (1, E):
        raise ValueError(f"{name} has {a.size} values, expected 1 or {E}")
    return a


@dataclass(frozen=True)
class YangMenq:
    """E Yang-Menq elements: ku, kv [N/m], mu [-], n0 [N] (arrays of length E).

    slider_rest: where a fully stuck slider sits.  A fully stuck cycle is periodic
    for any slider position w in [max lo, min hi], lo = u - mu n/ku, hi = u + mu n/ku.
    None (default) takes the middle, w = (max lo + min hi)/2: for a constant normal
    load the tangential spring is unstrained at the middle of the displacement range,
    and the force is continuous where the cycle starts to slip (there max lo = min hi
    is the only admissible w), which Newton needs.  An array takes those absolute
    positions [m], clamped into the interval.  Cycles that slip or separate do not
    depend on it.
    """

    ku: np.ndarray
    kv: np.ndarray
    mu: np.ndarray
    n0: np.ndarray
    slider_rest: np.ndarray | None = None

    def __post_init__(self):
        arrays = {k: _as_param(k, getattr(self, k)) for k in ("ku", "kv", "mu", "n0")}
        sizes = {a.size for a in arrays.values()} - {1}
        if len(sizes) > 1:
            got = ", ".join(f"{k}: {a.size}" for k, a in arrays.items())
            raise ValueError(f"ku, kv, mu, n0 must have one common length (or 1); got {got}")
        E = sizes.pop() if sizes else 1
        for k, a in arrays.items():
            object.__setattr__(self, k, np.broadcast_to(a, (E,)).copy())
        for k, what in (("ku", " (stiffness)"), ("kv", " (stiffness)"), ("mu", "")):
            a = getattr(self, k)
            if np.any(a < 0):
                bad = np.flatnonzero(a < 0)
                where = "" if E == 1 else f" at element {bad[0]} ({bad.size} negative)"
                raise ValueError(f"{k} must be >= 0{what}, got {a[bad[0]]:g}{where}")
        if self.slider_rest is not None:
            w = _as_param("slider_rest", self.slider_rest, E)
            object.__setattr__(self, "slider_rest", np.broadcast_to(w, (E,)).copy())

    @property
    def size(self) -> int:
        return self.ku.size

    def take(self, index) -> "YangMenq":
        """The elements selected by `index` (integer or boolean array), same order."""
        w = self.slider_rest
        return YangMenq(self.ku[index], self.kv[index], self.mu[index], self.n0[index],
                        None if w is None else w[index])

    def tile(self, reps: int) -> "YangMenq":
        """`reps` copies of the E elements one after the other (reps E elements): the
        elements of every sector of a wheel."""
        t = lambda a: None if a is None else np.tile(a, int(reps))  # noqa: E731
        return YangMenq(t(self.ku), t(self.kv), t(self.mu), t(self.n0), t(self.slider_rest))


# ---------------------------------------------------------------------------
# States and results of an evaluation
# ---------------------------------------------------------------------------

SEP, STICK, PSLIP, NSLIP = 0, 1, 2, 3
STATE_NAMES = {SEP: "separation", STICK: "stick", PSLIP: "positive slip", NSLIP: "negative slip"}
# where a stick phase took its slider position w from (for dw/dQ): the lower band
# edge lo, the upper edge hi, or u at touchdown
SRC_LO, SRC_HI, SRC_TD = 0, 1, 2


@dataclass(frozen=True)
class ContactForces:
    """Fourier coefficients of the contact forces and their Jacobian.

    Fu, Fv: (E, 2H+1) [N]; dFu_dU, dFu_dV, dFv_dV: (E, 2H+1, 2H+1) [N/m]
    (dFv/dU = 0 identically).  `regimes` counts elements evaluated as fully
    separated, fully stuck (both linear over the cycle, no transition search) and
    with transitions; for the exact method also `normal_load_searched`, the
    elements whose normal load varies and was searched for zeros (separation).
    """

    Fu: np.ndarray
    Fv: np.ndarray
    dFu_dU: np.ndarray | None
    dFu_dV: np.ndarray | None
    dFv_dV: np.ndarray | None
    regimes: dict


def check_coefficients(name, X, E):
    """X as a float array of shape (E, 2H+1) with finite values; ValueError naming `name`."""
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[0] != E or X.shape[1] % 2 == 0:
        raise ValueError(f"{name} must have shape (E={E}, 2H+1), got {X.shape}")
    if not np.all(np.isfinite(X)):
        raise ValueError(f"{name} contains NaN or Inf")
    return X


def stuck_slider(elem: YangMenq, maxlo, minhi, s_lo, s_hi):
    """Slider position w of fully stuck elements and its derivatives (see YangMenq).

    maxlo, minhi: (E,) band extremes; s_lo, s_hi: (E, 2H+1) the basis where they
    occur (lo, hi are stationary there, so d(max lo)/dQ = basis there).
    Returns w (E,), dw/dU and dw/dV (E, 2H+1).
    """
    r = np.where(elem.ku > 0, elem.mu / np.where(elem.ku > 0, elem.ku, 1.0), 0.0)
    rk = (r * elem.kv)[:, None]
    if elem.slider_rest is None:
        return 0.5 * (maxlo + minhi), 0.5 * (s_lo + s_hi), 0.5 * rk * (s_hi - s_lo)
    ref = elem.slider_rest
    low, high = ref < maxlo, ref > minhi
    w = np.where(low, maxlo, np.where(high, minhi, ref))
    dU = np.where(low[:, None], s_lo, np.where(high[:, None], s_hi, 0.0))
    dV = np.where(low[:, None], -rk * s_lo, np.where(high[:, None], rk * s_hi, 0.0))
    return w, dU, dV


def stuck_forces(U, elem: YangMenq, w, dwdU, dwdV, rows):
    """Fu = ku (U - w e0) and its Jacobian for the fully stuck elements `rows`."""
    nc = U.shape[1]
    ku = elem.ku[rows][:, None]
    Fu = ku * U[rows]
    Fu[:, 0] -= ku[:, 0] * w[rows]
    e0 = np.zeros(nc)
    e0[0] = 1.0
    dU = ku[..., None] * (np.eye(nc) - e0[:, None] * dwdU[rows][:, None, :])
    dV = -ku[..., None] * e0[:, None] * dwdV[rows][:, None, :]
    return Fu, dU, dV


def history_from_segments(U, V, elem: YangMenq, tau, seg) -> dict:
    """Periodic time history of every element at the instants `tau` (K,), from the
    periodic segments `seg` of one period (a, b, state, w, regime, Nc: see
    `exact.periodic_segments`).

    Returns arrays (E, K): `state` (SEP, STICK, PSLIP, NSLIP), `fu`, `fv` [N], `u`,
    `v` [m], `n` [N]; and `transitions`: per element a list of (tau, from, to)
    with tau in [0, 2 pi).
    """
    E = elem.size
    tau = np.asarray(tau, dtype=float)
    H = harmonics_of(U.shape[1])
    S = basis(tau, H)
    u, v = U @ S.T, V @ S.T
    n = seg["Nc"] @ S.T
    a, b, st = seg["a"], seg["b"], seg["state"]
    t0 = a[:, :1]
    tq = t0 + np.mod(tau[None, :] - t0, TWO_PI)
    # the segment containing each instant: last used segment with a <= t
    inside = (a[:, None, :] <= tq[..., None]) & (st[:, None, :] >= 0) & (b[:, None, :] > a[:, None, :])
    idx = inside.shape[2] - 1 - np.argmax(inside[..., ::-1], axis=2)
    rows = np.arange(E)[:, None]
    state = st[rows, idx]
    w = seg["w"][rows, idx]
    mu = elem.mu[:, None]
    fu = np.select([state == STICK, state == PSLIP, state == NSLIP],
                   [elem.ku[:, None] * (u - w), mu * n, -mu * n], 0.0)
    # frictionless contact and separation need no segments
    frictionless = (seg["regime"] == 3)[:, None]
    ud = U @ basis(tau, H, 1).T
    state = np.where(frictionless, np.where(ud >= 0, PSLIP, NSLIP), state)
    state = np.where(n <= 0, SEP, state)
    fu = np.where((n <= 0) | frictionless, 0.0, fu)
    fv = np.where(n > 0, n, 0.0)
    transitions = []
    for e in range(E):
        used = (st[e] >= 0) & (b[e] > a[e])
        ta, ss = a[e][used], st[e][used]
        ch = np.flatnonzero(ss != np.roll(ss, 1))
        transitions.append([(float(np.mod(ta[i], TWO_PI)), int(ss[i - 1]), int(ss[i])) for i in ch]
                           if ss.size > 1 else [])
    return dict(state=state, fu=fu, fv=fv, u=u, v=v, n=n, transitions=transitions)
