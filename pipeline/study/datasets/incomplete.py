"""Cases whose branch stopped short of the frequency interval: their largest
amplitude is the largest traced, not the peak of the interval (`peak_complete` = 0
in the dataset).  `incomplete_cases` words them for the end of `python -m pipeline run`,
`hidden_peaks` those with resonance steps not resolved, `edge_peaks` the complete cases whose largest amplitude lies at an end of the interval
(a resonance outside it, or none: not a peak), `window_edges` the same for the peak
windows, `absent_effects` declared contact
effects that no case shows.
"""
from __future__ import annotations

import numpy as np

from ..files.rules import contact_rules


def incomplete_cases(study, ds) -> list:
    """[({axis: value}, what)] of every case with points whose branch did not cover
    the study's frequency interval (failed cases, without points, are not listed)."""
    if ds is None or "peak_complete" not in ds or "n_points" not in ds:
        return []
    fr = study.sweep.frequency
    unit = ds["frequency"].attrs.get("units", "")
    lo_end, hi_end = sorted((fr.start, fr.stop))
    complete, n_points = ds["peak_complete"].values, ds["n_points"].values
    freq, conv = ds["frequency"].values, ds["converged"].values
    dofs = [str(d) for d in ds["dof"].values] if "dof" in ds.coords else []
    out = []
    for idx, case in study.sweep.cases():
        if bool(complete[idx]) or int(n_points[idx]) == 0:
            continue
        f = freq[idx][conv[idx].astype(bool)]
        covered = (f"{np.min(f):.6g}-{np.max(f):.6g} {unit}" if f.size
                   else "no converged point")
        peak = np.asarray(ds["peak_amplitude"].values[idx], float).ravel()
        top = (f"; peak_amplitude ({dofs[0]}) {peak[0]:.4g} m is the largest amplitude traced,"
               f" the peak may lie beyond" if dofs and peak.size and np.isfinite(peak[0])
               else "")
        why = str(ds["message"].values[idx]) if "message" in ds else ""
        out.append((case, f"the branch covers {covered} of {lo_end:g}-{hi_end:g} {unit} "
                          f"({why}){top}"))
    return out


def edge_peaks(study, ds) -> list:
    """[({axis: value}, what)] of every complete case with an output DOF whose largest
    amplitude lies at an end of the frequency interval (to 1e-9 of it): its value
    there, not a resonant peak (the amplitude still grows towards that end; a peak
    inside, if any, is lower)."""
    if ds is None or "peak_frequency" not in ds or "peak_complete" not in ds:
        return []
    fr = study.sweep.frequency
    unit = ds["frequency"].attrs.get("units", "")
    lo, hi = sorted((fr.start, fr.stop))
    tol = 1e-9 * max(abs(lo), abs(hi))
    dofs = [str(d) for d in ds["dof"].values]
    out = []
    for idx, case in study.sweep.cases():
        if not bool(ds["peak_complete"].values[idx]):
            continue
        f = np.asarray(ds["peak_frequency"].values[idx], float).reshape(-1, len(dofs))
        a = np.asarray(ds["peak_amplitude"].values[idx], float).reshape(-1, len(dofs))
        ends = []
        for end in (lo, hi):   # a DOF that never moves (amplitude 0) has no peak to miss
            names = [d for k, d in enumerate(dofs)
                     if ((np.abs(f[:, k] - end) <= tol) & (a[:, k] > 0)).any()]
            if names:
                ends.append(f"of {', '.join(names)} is its value at the range's end, "
                            f"{end:g} {unit}")
        if ends:
            out.append((case, f"the largest amplitude {'; '.join(ends)}: not a resonant peak "
                              f"(a peak inside {lo:g}-{hi:g} {unit}, if any, is lower; widen "
                              "[sweep] frequency if a resonance lies beyond)"))
    return out


def window_edges(study, ds) -> list:
    """[({axis: value}, what)] of every case and `[output] peak_windows` entry whose
    largest amplitude inside the window is no local maximum of the branch: a converged
    neighbour along the branch, outside the window, is higher, so the value is the
    curve's flank at the window's edge (a resonance beyond it), not a resonant peak."""
    if ds is None or "window_peak_frequency" not in ds or "peak_window_low" not in ds:
        return []
    unit = ds["frequency"].attrs.get("units", "")
    lows, highs = ds["peak_window_low"].values, ds["peak_window_high"].values
    dofs = [str(d) for d in ds["dof"].values]
    out = []
    for idx, case in study.sweep.cases():
        sub = ds.isel(dict(zip(study.sweep.axes, idx)))
        f, conv = sub["frequency"].values, sub["converged"].values.astype(bool)
        A = sub["amplitude"].transpose(..., "point", "dof").values.reshape(
            -1, f.size, len(dofs))                       # (sectors, points, dofs)
        at = np.flatnonzero(conv)                        # converged points, branch order
        for w, (lo, hi) in enumerate(zip(lows, highs)):
            inside = conv[at] & (f[at] >= lo) & (f[at] <= hi)
            if not inside.any():
                continue
            names = []
            for k, d in enumerate(dofs):
                a = A[:, at, k]                          # (sectors, converged points)
                j = np.argmax(np.where(inside, a, -np.inf), axis=1)
                rows = np.arange(a.shape[0])
                top = a[rows, j] * (1 + 1e-9)            # above round-off
                prev, nxt = a[rows, np.maximum(j - 1, 0)], a[rows, np.minimum(j + 1, at.size - 1)]
                flank = np.flatnonzero((prev > top) | (nxt > top))
                if flank.size:
                    s0 = flank[0]
                    where = f" (sector {s0})" if a.shape[0] > 1 else ""
                    names.append(f"{d}{where} at {f[at][j[s0]]:.6g} {unit}")
            if names:
                out.append((case, f"the largest amplitude in peak window {w} ({lo:g}-{hi:g} "
                                  f"{unit}) of {', '.join(names)} lies on the curve's flank "
                                  "at the window's edge, not at a resonant peak (the "
                                  "amplitude rises beyond the window; move or widen [output] "
                                  "peak_windows)"))
    return out


# the ends of a curve's notes on steps across a resonance not resolved (`response`) and
# on a largest amplitude traced outside the range (`window`)
NOTES = ("a peak may hide there", "lies outside the range: not its peak")


def hidden_peaks(study, ds, named=()) -> list:
    """[({axis: value}, what)] of every case whose message notes steps across a
    resonance that could not be shortened to its half-power band (a peak may hide
    between two points), or a largest amplitude traced outside the range (the branch
    followed beyond it; not for the cases in `named`, whose largest amplitude at the
    range's end is said already: `edge_peaks`), in the study's words."""
    if ds is None or "message" not in ds or getattr(study, "sweep", None) is None:
        return []           # a response study's only (a Campbell study's messages are per speed)
    out = []
    for idx, case in study.sweep.cases():
        words = NOTES[:1] if case in named else NOTES
        out += [(case, n.strip()) for n in str(ds["message"].values[idx]).split(";")
                if any(w in n for w in words)]
    return out


def absent_effects(study, ds) -> list:
    """[text] of the declared contact effects that no converged point of any case shows
    (the contact-state fractions of the dataset): "separation" where no element ever
    separates, "friction" where none ever slips or none ever closes.  A sweep may
    well have such cases; a whole study without the effect likely misstates the scene.
    Not for a quick variant (it runs some of the cases the declaration is made for), nor
    where a case failed or stopped short (its missing points may show the effect)."""
    if ds is None or any(v not in ds for v in ("slip_fraction", "converged", "peak_complete")) \
            or study.quick or not bool(ds["peak_complete"].all()):   # a response dataset only
        return []
    conv = ds["converged"] == 1

    def largest(var):   # NaN: no such variable, or no converged point has a number
        return float(ds[var].where(conv).max()) if var in ds else np.nan

    effects, out = set(study.scene.effects), []
    sep, slip, stick = (largest(v) for v in ("separation_fraction", "slip_fraction",
                                             "stick_fraction"))
    # the fractions are those of the scene's own contacts: the elements of a further law
    # with a normal load ([[scene.friction_2d]]) may separate unrecorded
    unrecorded = any(c.normal and not c.swept for c in contact_rules(study.scene))
    if "separation" in effects and sep == 0.0 and not unrecorded:
        out.append("\"separation\" is declared but no contact separates at any point of any "
                   "case (separation_fraction 0 everywhere)")
    if "friction" in effects and slip == 0.0 and stick == 0.0:
        out.append("\"friction\" is declared but no contact ever closes (separation_fraction "
                   "1 everywhere): no contact force acts")
    elif "friction" in effects and slip == 0.0:
        out.append("\"friction\" is declared but no contact slips at any point of any case "
                   "(slip_fraction 0 everywhere): the friction limit is never reached")
    return out
