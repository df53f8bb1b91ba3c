"""Friction in the contact plane: a 2D Coulomb slider with variable normal load.

Element e has three local directions: two orthonormal tangents t1, t2 of the contact
plane and the normal n.  Its relative motion is u = (u1, u2) in the plane and v along
the normal; the normal load and the tangential force are (Yang & Menq's element with
the slip free to turn in the plane; Petrov & Ewins' 2D friction; tmdsimpy's
ElasticDryFriction2D)

    n = n0 + kv v,                               f_n = max(n, 0),
    f = K (u - w),   |f| <= mu n,                 w the slider (2-vector),

K = diag(ku, ku2) (ku2 = ku: isotropic; two values where the face is stiffer one way),

an elastic - perfectly plastic slider on the Coulomb disc: it sticks while the trial
force K (u - w) lies inside the disc of radius mu n, otherwise the slider moves so
that the force stays on the circle, the slider moving along the force (Coulomb: the
friction force opposes the slip).  The return mapping is the closest point of
the disc to the trial force t in the energy norm f K^-1 f: f_i = t_i / (1 + g k_i),
g >= 0 the root of |f| = mu n (`kernel.return_gamma`); isotropic, f = mu n e and
w = u - (mu n / ku) e, e the unit trial direction.  Separated (n <= 0) the
forces vanish and the slider follows, w = u (as the 1D element's touchdown rule).

Periodic steady state on N equispaced samples of one period (alternating
frequency-time, AFT: the law has no closed form once the slip direction turns):
- a separated sample erases memory: one pass from there is the periodic state;
- else, if the slider at the centre w* of the stick discs |K (u_i - w)| <= mu n_i
  (in force units K w* minimises max_i (|K (u_i - w)| - mu n_i), `friction2d.centre.
  stick_centres`: the 1D element's band middle `slider_rest` for motion along one
  tangent) sticks at every sample, the cycle is fully stuck there;
- else the march is repeated from w* period after period until the slider returns to
  its start (to `PERIOD_RTOL` of the motion), at most `MAX_PERIODS` periods (the
  count is reported); a macroslip phase contracts the memory geometrically.
For motion along one tangent each rule is the 1D AFT element's, so the law reduces to
the Yang-Menq element (`contact.aft`) sample for sample.

Jacobian: forward derivatives along the march (stick keeps dw, slip differentiates
the return mapping -- g implicitly, `kernel.slip_derivative` --, separation sets
dw = du), and at a periodic fixed point reached by iteration the start's sensitivity
dw0 = (I - A)^-1 B from one more period (A = dw_N/dw0, B = dw_N/dX); F = W f,
dF/dX = W df/dX.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...fourier.harmonics import harmonics_of
from .kernel import march
from ..laws import LawForces

@dataclass(frozen=True)
class Friction2D:
    """E 2D friction elements: ku [N/m] (tangential, along tangent 1 and, unless ku2
    is given, tangent 2), kv [N/m], mu [-], n0 [N], ku2 [N/m] (along tangent 2; None:
    ku) (arrays of length E)."""

    ku: np.ndarray
    kv: np.ndarray
    mu: np.ndarray
    n0: np.ndarray
    ku2: np.ndarray | None = None

    name = "friction_2d"
    directions = ("tangent_1", "tangent_2", "normal")
    pairs = ((0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (2, 2))
    supports = frozenset({"hbm", "hill"})
    methods = ("aft",)          # force evaluations it offers (no closed form)
    # lumped study file: [[scene.friction_2d]] tangent_1 = ["x"], tangent_2 = ["y"],
    # normal = ["z"] (signed DOF lists), ku, kv, mu, n0
    effect = "friction_2d"
    study_table = "friction_2d"
    study_rows = ("tangent_1", "tangent_2", "normal")
    study_keys = {"ku": ("N/m", None), "kv": ("N/m", 0.0), "mu": ("1", None),
                  "n0": ("N", None), "ku2": ("N/m", "ku")}
    study_help = {"ku": "tangential stiffness (along both tangents unless ku2 is given)",
                  "ku2": "tangential stiffness along tangent_2",
                  "kv": "normal stiffness: n = n0 + kv v", "mu": "friction coefficient",
                  "n0": "preload (negative: a gap)"}

    def __post_init__(self):
        if self.ku2 is None:
            object.__setattr__(self, "ku2", self.ku)
        names = ("ku", "kv", "mu", "n0", "ku2")
        arrays = [np.atleast_1d(np.asarray(getattr(self, k), float)) for k in names]
        E = max(a.size for a in arrays)
        for k, a in zip(names, arrays):
            if a.ndim != 1 or a.size not in (1, E) or not np.all(np.isfinite(a)):
                raise ValueError(f"{k} must be finite, of length 1 or {E}, got {a!r}")
            object.__setattr__(self, k, np.broadcast_to(a, (E,)).copy())
        if (np.any(self.ku <= 0) or np.any(self.ku2 <= 0) or np.any(self.kv < 0)
                or np.any(self.mu <= 0)):
            raise ValueError(f"ku, ku2 must be > 0 [N/m], kv >= 0 [N/m] and mu > 0, got ku = "
                             f"{self.ku.min():g}, ku2 = {self.ku2.min():g}, kv = "
                             f"{self.kv.min():g}, mu = {self.mu.min():g}")

    @classmethod
    def from_study(cls, values: dict) -> "Friction2D":
        """One element from the study-file values {"ku", "kv", "mu", "n0", "ku2"}."""
        return cls(**{k: [values[k]] for k in ("ku", "kv", "mu", "n0", "ku2")})

    @property
    def size(self) -> int:
        return self.ku.size

    def linear_limit(self, contacts: str) -> np.ndarray:
        """(E, 3) springs [N/m] of a linear limit (`model.system.linear_stiffness`): as
        the Yang-Menq element's -- "stuck" or "tied": ku, ku2 along the tangents and kv
        of every element (closed and stuck, a gap too); "small": the preloaded
        elements stuck, the others open; "open": none."""
        if contacts == "open":
            return np.zeros((self.size, 3))
        closed = np.ones(self.size, bool) if contacts in ("stuck", "tied") else self.n0 > 0
        k = np.stack([self.ku, self.ku2], axis=1)
        k = k * closed[:, None] if contacts == "small" else k
        return np.column_stack([k, self.kv * closed])

    def tile(self, reps: int) -> "Friction2D":
        """`reps` copies of the E elements one after the other (every sector's)."""
        return Friction2D(*(np.tile(getattr(self, k), int(reps))
                            for k in ("ku", "kv", "mu", "n0", "ku2")))

    def evaluate(self, X, method: str = "aft", n_samples: int = 256,
                 jacobian: bool = True) -> LawForces:
        """Fourier coefficients F (E, 3, 2H+1) of (f1, f2, f_n) for the motion X
        (E, 3, 2H+1) and J (E, 7, 2H+1, 2H+1) in the order of `pairs` (AFT with
        `n_samples` samples; "exact" is not available for this law)."""
        if method != "aft":
            raise ValueError("the 2D friction law is evaluated by AFT (force_evaluation "
                             f"= \"aft\"), got {method!r}")
        X = np.asarray(X, float)
        if X.ndim != 3 or X.shape[:2] != (self.size, 3) or X.shape[2] % 2 == 0:
            raise ValueError(f"X must have shape (E={self.size}, 3, 2H+1), got {X.shape}")
        cycle = march(np.stack([self.ku, self.ku2], axis=1), self.kv, self.mu, self.n0, X,
                      int(n_samples), jacobian)
        return LawForces(cycle.F, cycle.J, cycle.regimes, cycle)


def cycle_results(X, law: Friction2D, n_samples: int = 256) -> dict:
    """Per element (E,), as the 1D element's `period_results.cycle_results` but from the N
    samples of the AFT cycle: `stick`, `slip`, `separation` (fractions of the samples
    [-]), `energy` dissipated per cycle [J] (the work of the tangential force over the
    relative motion, pi sum_h h (F_ch U_sh - F_sh U_ch) over both tangents: the elastic
    part and the normal force return what they take), `normal_mean` and
    `normal_amplitude` (of f_n = max(n, 0) [N]).  X (E, 3, 2H+1) [m]."""
    c = law.evaluate(np.asarray(X, float), n_samples=n_samples, jacobian=False).detail
    H = harmonics_of(c.F.shape[-1])
    h = np.arange(1, H + 1)
    energy = np.pi * sum(np.sum(h * (c.F[:, d, 1::2] * X[:, d, 2::2]
                                     - c.F[:, d, 2::2] * X[:, d, 1::2]), axis=1)
                         for d in range(2))
    fn = c.f[:, 2]
    return {"stick": np.mean(c.state == 1, axis=1), "slip": np.mean(c.state == 2, axis=1),
            "separation": np.mean(c.state == 0, axis=1), "energy": energy,
            "normal_mean": fn.mean(axis=1),
            "normal_amplitude": 0.5 * (fn.max(axis=1) - fn.min(axis=1))}
