"""The face-total hysteresis loop at each case's peak (paper Fig. 5b, for a whole
contact): the friction force summed over the elements of the contact that
dissipates most there, against the mean tangential relative displacement of its
elements, drawn exactly from the dataset's per-element coefficients
(`contact_dataset.peak_motion_variables`, `contact.exact.history`).  The legend
gives the energy the contact dissipates per cycle [J] (`dissipated_energy`, the sum
of its elements' slider work).  With 2D friction the loop becomes an orbit in the
face plane: the mean relative motion and slider, and the total tangential force
(`draw_plane_orbits`)."""
from __future__ import annotations

import itertools

import numpy as np

from ...contact import YangMenq
from ...contact.exact import history
from ...contact.friction2d.law import Friction2D, cycle_results
from .plots import wrapped_title


def face_loop(ds, sel: dict, tau) -> dict | None:
    """(u [m], f [N], contact name, element count, energy [J]) of the contact that
    dissipates most at the peak of the case `sel` (isel of the sweep axes); None
    when the case has no converged peak."""
    peak = peak_contact(ds, sel)
    if peak is None:
        return None
    sub, pairs, head = peak
    el = YangMenq(*(sub[f"{k}_pair"].values[pairs] for k in ("ku", "kv", "mu")),
                  n0=sub["preload_pair"].values[pairs])
    h = history(sub["peak_contact_u"].values[pairs], sub["peak_contact_v"].values[pairs], el, tau)
    return dict(u=h["u"].mean(axis=0), f=h["fu"].sum(axis=0), **head)


def peak_contact(ds, sel: dict):
    """(the case `sel`'s dataset, the elements of the contact dissipating most at its
    peak, {name, elements, energy [J], frequency}); None without a converged peak."""
    sub = ds.isel(sel)
    p = int(sub["peak_contact_point"])
    if p < 0:
        return None
    energy = sub["dissipated_energy"].isel(point=p).values
    c = int(np.nanargmax(energy)) if np.isfinite(energy).any() else 0
    pairs = np.flatnonzero(ds["pair_contact"].values == c)
    return sub, pairs, dict(name=str(ds["contact"].values[c]), elements=pairs.size,
                            energy=float(energy[c]),
                            frequency=float(sub["frequency"].isel(point=p)))


def draw_face_loops(study, ds, ax) -> None:
    """One face-total loop per case on `ax` (module doc), labelled."""
    tau = np.linspace(0.0, 2 * np.pi, 1201)
    axes = list(study.sweep.axes)
    unit = ds["frequency"].attrs["units"]
    for idx in itertools.product(*(range(len(study.sweep.axes[a])) for a in axes)):
        sel = dict(zip(axes, idx))
        loop = face_loop(ds, sel, tau)
        if loop is None:
            continue
        case = ", ".join(f"{a} = {study.sweep.axes[a][i]:g} {ds[a].attrs.get('units', '')}"
                         for a, i in sel.items())
        ax.plot(loop["u"], loop["f"], lw=1.6,
                label=f"{case}: {loop['name']} ({elements(loop['elements'])}) at "
                      f"{loop['frequency']:.4g} {unit}, W = {loop['energy']:.3g} J/cycle")
    ax.set_xlabel("mean tangential relative displacement of its elements [m]")
    ax.set_ylabel("contact's total friction force [N]")
    total = "face total" if getattr(study.scene, "model", "") != "lumped" else "its total"
    wrapped_title(ax, f"{study.title}\nat the peak: the contact dissipating most, {total} "
                      "(W: energy dissipated per cycle)", fontsize=9)


def elements(n: int) -> str:
    """'1 element', 'n elements'."""
    return f"{n} element" + ("" if n == 1 else "s")


def plane_orbit(ds, sel: dict, samples: int) -> dict | None:
    """The 2D friction counterpart of `face_loop`: over the elements of the contact
    dissipating most at the peak of the case `sel`, the mean in-plane relative motion
    (u1, u2) [m] and slider (w1, w2) [m] and the total tangential force (f1, f2) [N]
    over one period, from the AFT cycle of `samples` samples (`contact.friction2d`)."""
    peak = peak_contact(ds, sel)
    if peak is None:
        return None
    sub, pairs, head = peak
    law = Friction2D(*(sub[f"{k}_pair"].values[pairs] for k in ("ku", "kv", "mu")),
                     n0=sub["preload_pair"].values[pairs],
                     ku2=sub["ku2_pair"].values[pairs] if "ku2_pair" in sub else None)
    X = np.stack([sub[f"peak_contact_{d}"].values[pairs] for d in ("u", "u2", "v")], axis=1)
    return orbit_of(law, X, samples, head)


def element_orbit(ds, sel: dict, samples: int) -> dict | None:
    """`plane_orbit` of the one element sliding most at the peak (`hysteresis_*`), where
    the dataset has no per-element peak motions (a scene placing the law's elements
    itself)."""
    sub = ds.isel(sel)
    e = int(sub["hysteresis_element"])
    if e < 0:
        return None
    law = Friction2D(*(np.atleast_1d(float(sub[f"hysteresis_{k}"])) for k in
                       ("ku", "kv", "mu", "n0", "ku2") if f"hysteresis_{k}" in sub))
    X = np.stack([sub[f"hysteresis_{d}"].values for d in ("u", "u2", "v")])[None]
    energy = float(cycle_results(X, law, samples)["energy"][0])
    return orbit_of(law, X, samples, dict(name=f"element {e}", elements=1, energy=energy,
                                          frequency=float(sub["hysteresis_frequency"])))


def orbit_of(law, X, samples: int, head: dict) -> dict:
    """The mean relative motion and slider, the total tangential force of the elements
    of `law` at the motion X over one closed period, with the labels `head`."""
    cyc = law.evaluate(X, n_samples=samples, jacobian=False).detail
    close = np.r_[np.arange(cyc.u.shape[-1]), 0]        # a closed orbit
    return dict(u=cyc.u.mean(axis=0)[:, close], w=cyc.w.mean(axis=0)[:, close],
                f=cyc.f[:, :2].sum(axis=0)[:, close], **head)


def draw_plane_orbits(study, ds, axes_pair) -> None:
    """Per case, on two axes: the face's mean in-plane relative motion (solid) and
    slider (dashed); its total tangential force (`plane_orbit`), labelled."""
    ax_u, ax_f = axes_pair
    unit = ds["frequency"].attrs["units"]
    names = list(study.sweep.axes)
    for idx in itertools.product(*(range(len(study.sweep.axes[a])) for a in names)):
        sel = dict(zip(names, idx))
        orbit = (plane_orbit if "peak_contact_u2" in ds else element_orbit)(
            ds, sel, study.solver.samples)
        if orbit is None:
            continue
        case = ", ".join(f"{a} = {study.sweep.axes[a][i]:g} {ds[a].attrs.get('units', '')}"
                         for a, i in sel.items())
        line, = ax_u.plot(*orbit["u"], lw=1.6, label=f"{case} at {orbit['frequency']:.4g} {unit}")
        ax_u.plot(*orbit["w"], lw=1.0, ls="--", color=line.get_color())
        ax_f.plot(*orbit["f"], lw=1.6, color=line.get_color(),
                  label=f"{orbit['name']} ({elements(orbit['elements'])}), "
                        f"W = {orbit['energy']:.3g} J/cycle")
    ax_u.set(xlabel="relative displacement along t1 [m]", ylabel="along t2 = n x t1 [m]",
             title="mean relative motion (solid) and slider (dashed)")
    ax_f.set(xlabel="total friction force along t1 [N]", ylabel="along t2 [N]",
             title="total tangential force")
    for ax in axes_pair:
        ax.title.set_fontsize(9)
        ax.set_aspect("equal", adjustable="datalim")
