"""Where a 1D shroud pair leaves the motion free: the relative motion of its faces
along the slip direction t and along b = n x t, at each case's peak.

A shroud pair with friction = "1d" acts along t and n only (`model.pair_motion`); a
mode that moves the faces along b meets neither stiffness nor friction there, and
its peak is then that of a shroud that does not rub.  At each case's peak point (the
largest converged amplitude of the first output DOF inside the frequency range, the
point of `peak_amplitude`) the relative displacement of every node pair along t and
b is taken from the solution (the rows of `pair_motion.plane_rows` on the reduced
coordinates, the neighbour's shifted by the inter-sector phase), and per pair of
faces

    A_e = sqrt( mean over the node pairs k of  sum_{h >= 1} (a_h,k^2 + b_h,k^2) )  [m]

along e = t and e = b (the vibration's harmonic amplitudes, the static part left
out; at H = 1 the first harmonic's amplitude, root mean square over the face), and
their ratio A_b / A_t.

A ratio of at least `RATIO` = 0.5 is warned about.  At |b| = r |t| the in-plane
motion turns atan(r) from t: the 1D element stuck holds r^2 / (1 + r^2) less of the
in-plane elastic energy ku (|t|^2 + |b|^2) / 2 than a 2D one, and sliding, its slip
path is 1 - 1 / sqrt(1 + r^2) shorter than the in-plane path, and so its friction
work.  At r = 0.5 that is 20 % of the stuck stiffness energy and 11 % of the friction
work, at r = 1 already 50 % and 29 %: from 0.5 on, what the 1D pair leaves out is of
the order of what friction changes at the peak, and friction = "2d" (slip in the
face plane) is the model to run.  A mistuned disk's full assembly is not measured.
"""
from __future__ import annotations

import numpy as np

from ...fourier.harmonics import shift
from ...model.pair_motion import free_pairs, plane_rows

RATIO = 0.5          # [-] A_b / A_t from which a 1D shroud pair is warned about
WARNED = "free_direction_warned"


def peak_point(c, row: int) -> int | None:
    """The point of `peak_amplitude` of the DOF `row` on the curve `c`: its largest
    converged, finite amplitude inside the curve's frequency window (None: none)."""
    om = np.asarray(c.omega, float)
    a = np.asarray(c.amplitude, float)[:, row]
    lo, hi = c.info.get("window", (-np.inf, np.inf))
    ok = (np.asarray(c.converged, bool) & np.isfinite(a) & np.isfinite(om) & (om >= lo)
          & (om <= hi) & np.all(np.isfinite(np.asarray(c.Q, float)), axis=(1, 2)))
    return int(np.argmax(np.where(ok, a, -np.inf))) if ok.any() else None


def face_amplitudes(rows, system, Q) -> np.ndarray:
    """(A_t, A_b) [m] (module doc) of one pair's rows (own, next) at the coefficients
    Q (n, 2H+1) of one point of a case's `system`."""
    own, nxt = rows
    X = own @ Q                                        # (2, k, 2H+1)
    if system.cyclic is not None:
        X = X + nxt @ shift(Q, system.cyclic.phase)
    return np.sqrt(np.mean(np.sum(X[..., 1:] ** 2, axis=-1), axis=-1))


def free_direction_variables(study, cases, curves, systems, row: int) -> tuple:
    """({name: (dims, values, attrs)}, names of the contacts warned about) of a
    response dataset: `slip_direction_amplitude`, `free_direction_amplitude` and
    `free_direction_ratio` (sweeps..., contact), NaN for the contacts that are no 1D
    shroud pair and the cases without a converged point; row: the first output DOF's
    row of a case's system.  ({}, ()) without a 1D shroud pair."""
    scene = study.scene
    if not free_pairs(scene) or scene.mistuning is not None:
        return {}, ()
    A = np.full(study.sweep.shape + (len(scene.contacts), 2), np.nan)
    for (idx, case), c, system in zip(cases, curves, systems):
        i = None if c is None or system is None else peak_point(c, row)
        if i is None:
            continue
        Q = np.asarray(c.Q, float)[i]
        for k, rows in plane_rows(scene, case).items():
            A[idx][k] = face_amplitudes(rows, system, Q)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = A[..., 1] / A[..., 0]
    sw = tuple(study.sweep.axes) + ("contact",)
    where = ("at the case's peak point (the largest converged amplitude of the first output "
             "DOF in the frequency range): sqrt of the mean over the node pairs of "
             "sum_h>=1 (a_h^2 + b_h^2) of the relative displacement; NaN for a contact that "
             "is no 1D shroud pair")
    data = {
        "slip_direction_amplitude": (sw, A[..., 0], {
            "units": "m", "long_name": "vibration amplitude of the relative displacement of "
                                       "the faces along the slip direction t of the 1D shroud "
                                       "pair", "comment": where}),
        "free_direction_amplitude": (sw, A[..., 1], {
            "units": "m", "long_name": "vibration amplitude of the relative displacement of "
                                       "the faces along b = n x t, the in-plane direction the "
                                       "1D shroud pair leaves free (no force)", "comment": where}),
        "free_direction_ratio": (sw, ratio, {
            "units": "1", "long_name": "free_direction_amplitude / slip_direction_amplitude",
            "warn_at": RATIO,
            "comment": f"from {RATIO:g} on, python -m pipeline run warns: friction = \"2d\" "
                       "slides in the whole face plane"})}
    warned = tuple(str(scene.contacts[k].name) for k, _ in free_pairs(scene)
                   if np.any(ratio[..., k] >= RATIO))
    return data, warned


def free_direction_notes(study, ds) -> list:
    """[(field, case, what)] of each 1D shroud pair whose faces move along b at least
    `RATIO` times as much as along t at some case's peak: the case of the largest
    ratio, its two amplitudes [m], and how many cases reach `RATIO`."""
    if ds is None or "free_direction_ratio" not in ds or getattr(study, "sweep", None) is None:
        return []
    ratio = ds["free_direction_ratio"].values
    out = []
    for k, pair in free_pairs(study.scene):
        r = ratio[..., k]
        hit = np.nan_to_num(r, nan=-np.inf) >= RATIO
        if not hit.any():
            continue
        idx = tuple(int(j) for j in np.unravel_index(int(np.argmax(np.where(hit, r, -np.inf))),
                                                      r.shape))
        case = dict(study.sweep.cases())[idx]
        At = float(ds["slip_direction_amplitude"].values[idx + (k,)])
        Ab = float(ds["free_direction_amplitude"].values[idx + (k,)])
        many = f", {int(hit.sum())} of {hit.size} cases" if hit.size > 1 else ""
        out.append((f"scene.contact[{k}]", case,
                    f"shroud pair {pair.name!r} (friction = \"1d\"): at the peak its faces "
                    f"move {Ab:.3g} m along n x t, the in-plane direction the pair leaves free "
                    f"(no stiffness, no friction), and {At:.3g} m along its slip direction t "
                    f"(ratio {r[idx]:.3g} >= {RATIO:g}{many}): the result misses the rubbing "
                    "along n x t; friction = \"2d\" slides in the whole face plane"))
    return out
