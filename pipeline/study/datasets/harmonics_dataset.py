"""The Fourier coefficients of the reported response DOFs in a response dataset, so
that deflection shapes and time histories can be rebuilt from the file:

    x(t) = sum_h c_h cos(h W t) + s_h sin(h W t)      (h = 0 ... H, s_0 = 0),

`harmonic_coefficient` (sweeps..., [sector,] point, dof, harmonic, component) [m]
with component = ["cos", "sin"] holding (c_h, s_h); padding NaN, harmonics above a
case's own H zero (as `harmonic_amplitude`, which is hypot(c_h, s_h))."""
from __future__ import annotations

import numpy as np


def coefficient_array(curve, rows, H: int, P: int) -> np.ndarray:
    """(S, P, D, H+1, 2) coefficients of one curve's reported DOFs `rows` (S, D)."""
    S, D = rows.shape
    out = np.full((S, P, D, H + 1, 2), np.nan)
    Q = np.moveaxis(np.asarray(curve.Q, dtype=float)[:, rows, :], 0, 1)   # (S, p, D, nh)
    p, h = Q.shape[1], (Q.shape[-1] - 1) // 2
    out[:, :p, :, :, :] = 0.0
    out[:, :p, :, 0, 0] = Q[..., 0]
    out[:, :p, :, 1:h + 1, 0] = Q[..., 1::2]
    out[:, :p, :, 1:h + 1, 1] = Q[..., 2::2]
    return out


def add_harmonic_coefficients(data_vars, coords, study, cases, curves, lay):
    """Add `harmonic_coefficient` and the `component` coordinate in place."""
    S, D = lay.rows.shape
    v = np.full(lay.shape + (S, lay.P, D, lay.H + 1, 2), np.nan)
    for (idx, _), c in zip(cases, curves):
        if c is not None:
            v[idx] = coefficient_array(c, lay.rows, lay.H, lay.P)
    dims = ("sector", "point", "dof", "harmonic", "component")
    if lay.sectors is None:
        v, dims = v.take(0, axis=len(lay.shape)), dims[1:]
    data_vars["harmonic_coefficient"] = (tuple(study.sweep.axes) + dims, v, {
        "units": "m", "long_name": "Fourier coefficients (c_h, s_h) of the response, "
                                   "x(t) = sum_h c_h cos(h W t) + s_h sin(h W t), W the "
                                   "excitation frequency in rad/s"})
    coords["component"] = ("component", np.array(["cos", "sin"]),
                           {"long_name": "cos: c_h, sin: s_h of x(t) = sum_h c_h cos(h W t) "
                                         "+ s_h sin(h W t)"})
