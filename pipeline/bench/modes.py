"""What nonlinear modes cost and save: `python -m pipeline bench modes`.

1. One backbone of the tuned FE sector of `studies/shrouded_disk.toml` (solid blade,
   36 sectors, EO = ND 3, H = 3, 3 N per face), from 0.01 to 1000 slip onsets,
   condensed onto the contact DOFs and on all DOFs, against one forced-response curve of the same scene over the study's range
   (stability off, the study's tolerance): wall times and their ratio.
2. Forced responses synthesised from stored backbones: 100 force levels x 5 preloads
   of the lumped disk of `studies/disk_nonlinear_modes.toml` (ND 3), the peak
   interpolated along the backbone, against the full harmonic balance of the same
   cases at force scale 1 (the time of the 5 curves, scaled to 500), with the peak
   errors of both synthesis variants (interpolated, located exactly) against the full
   harmonic balance's peak.
3. The synthesised peak of `studies/shrouded_disk.toml` (EO = ND 3, its five preloads)
   against the full harmonic balance's: the error of one mode, and the time of each
   (the synthesis includes its backbone).
With `--quick` the FE sector is the study's quick mesh.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from ..fourier.harmonics import amplitude_half_peak_to_peak
from ..solve.nonlinear_modes.backbone import continue_mode, point_at
from ..solve.nonlinear_modes.epmc import mode_problem
from ..solve.nonlinear_modes.synthesis import refiner, synthesise
from ..solve.nonlinear_modes.synthesis import synthesised_curve
from ..solve.response.response import frequency_response
from ..study.files.documents import load_study
from ..solve.nonlinear_modes.epmc import onset_amplitude

PRELOADS = (0.5, 1.0, 2.0, 4.0, 8.0)      # N, the lumped disk's synthesis table
FORCES = np.geomspace(0.25, 4.0, 100)     # factors on the 1 N engine-order load


def backbone_table(quick: bool):
    root = Path(__file__).resolve().parents[2] / "studies"
    study = load_study(root / "shrouded_disk.toml", quick=quick)
    system = study.system({"preload": 3.0})
    sv, fr = study.solver, study.sweep.frequency
    rows = []
    for condense in (True, False):
        t0 = time.perf_counter()
        mp = mode_problem(system, sv.harmonics, 0, sv.force_evaluation, sv.samples,
                          condense=condense)
        a = onset_amplitude(mp)
        bb = continue_mode(mp, np.log10(0.01 * a), np.log10(1000 * a), tol_rel=sv.tolerance)
        rows.append((mp, bb, time.perf_counter() - t0))
    t0 = time.perf_counter()
    cur = frequency_response(system, sv.harmonics, fr.omega_start, fr.omega_stop,
                             stability=False, tol_rel=sv.tolerance, method=sv.force_evaluation)
    t_fr = time.perf_counter() - t0
    print(f"\nFE sector of shrouded_disk.toml ({'quick' if quick else 'full'} mesh, "
          f"{system.n_dof} DOFs, {rows[0][0].kept.size} contact DOFs, {system.contact.size} "
          f"elements, H = {sv.harmonics}, 3 N)")
    print(f"{'computation':<46} {'points':>7} {'wall s':>8} {'/ forced':>9}")
    for (mp, bb, t), what in zip(rows, ("condensed", "all DOFs")):
        print(f"{'backbone ND 3, 0.01-1000 slip onsets, ' + what:<46} {bb.s.size:>7} "
              f"{t:>8.2f} {t / t_fr:>9.3f}")
    print(f"{'forced response, %g-%g Hz' % (fr.start, fr.stop):<46} {cur.omega.size:>7} "
          f"{t_fr:>8.2f} {1:>9.3f}")
    (mp, bb, _), (_, ref, _) = rows
    print(f"backbone {bb.omega[0] / (2 * np.pi):.1f} -> {bb.omega[-1] / (2 * np.pi):.1f} Hz, "
          f"zeta up to {bb.zeta.max():.4f}; at 1000 slip onsets the condensed omega is the "
          f"one on all DOFs to {abs(bb.omega[-1] / ref.omega[-1] - 1):.1e}")


def synthesis_table():
    study = load_study(Path(__file__).resolve().parents[2] / "studies" /
                       "disk_nonlinear_modes.toml").response
    sv, fr = study.solver, study.sweep.frequency
    stored, t_bb = [], 0.0
    for n0 in PRELOADS:
        system = study.system({"preload": n0, "eo": 3})
        t0 = time.perf_counter()
        mp = mode_problem(system, sv.harmonics)
        a = onset_amplitude(mp)
        stored.append((system, mp, continue_mode(mp, np.log10(0.01 * a), np.log10(1000 * a))))
        t_bb += time.perf_counter() - t0
    t0 = time.perf_counter()
    peaks = [[synthesise(bb, mp.M, mp.C, f * s.forcing[:, 1]) for f in FORCES]
             for s, mp, bb in stored]
    t_syn = time.perf_counter() - t0
    errs, errs_exact, t_hbm = [], [], 0.0
    for (system, mp, bb), row in zip(stored, peaks):
        t0 = time.perf_counter()
        cur = frequency_response(system, sv.harmonics, fr.omega_start, fr.omega_stop,
                                 stability=False, tol_rel=sv.tolerance, peak_dofs=[0])
        t_hbm += time.perf_counter() - t0
        k = int(np.argmax(cur.amplitude[:, 0]))
        ref = cur.amplitude[k, 0]
        F1 = system.forcing[:, 1]
        for syn, out in ((synthesise(bb, mp.M, mp.C, F1), errs),
                         (synthesise(bb, mp.M, mp.C, F1, refine=refiner(mp, bb)), errs_exact)):
            _, _, Q = point_at(mp, bb, syn.peak_s, segment=syn.peak_index)
            out.append(amplitude_half_peak_to_peak(Q)[0] / ref - 1.0)
    n = len(PRELOADS) * FORCES.size
    print(f"\nSynthesis from stored backbones: lumped disk (disk_nonlinear_modes.toml), ND 3, "
          f"H = {sv.harmonics}; {len(PRELOADS)} preloads x {FORCES.size} force levels")
    print(f"{'computation':<52} {'wall s':>8}")
    print(f"{'5 backbones (stored once)':<52} {t_bb:>8.3f}")
    print(f"{'%d synthesised responses (peak interpolated)' % n:<52} {t_syn:>8.3f}")
    print(f"{'full harmonic balance, 5 curves (force x 1)':<52} {t_hbm:>8.3f}")
    print(f"{'full harmonic balance, %d curves (scaled)' % n:<52} {t_hbm * FORCES.size:>8.1f}")
    print(f"speed-up of the synthesis: {t_hbm * FORCES.size / t_syn:.0f}x (backbones included: "
          f"{t_hbm * FORCES.size / (t_syn + t_bb):.0f}x)")
    print("peak amplitude error against the full harmonic balance at force x 1, per preload: "
          "interpolated " + ", ".join(f"{e:+.2%}" for e in errs) + "; located exactly "
          + ", ".join(f"{e:+.2%}" for e in errs_exact))


def preload_table(quick: bool):
    """The synthesised peak of shrouded_disk.toml (EO = ND 3) at its five preloads against
    the full harmonic balance's, with the time of each."""
    study = load_study(Path(__file__).resolve().parents[2] / "studies" / "shrouded_disk.toml",
                       quick=quick)
    sv, fr = study.solver, study.sweep.frequency
    dof = study.scene.dof_index("response.y")
    print(f"\nshrouded_disk.toml, EO = ND 3, H = {sv.harmonics} ({'quick' if quick else 'full'} "
          "mesh): synthesised peak against the full harmonic balance's")
    print(f"{'preload N':>9} {'synth m':>11} {'HBM m':>11} {'amp err':>8} {'freq err':>9} "
          f"{'synth s':>8} {'HBM s':>7}")
    for n0 in (0.3, 1.0, 3.0, 10.0, 30.0):
        system = study.system({"preload": n0})
        t0 = time.perf_counter()
        c = synthesised_curve(system, sv.harmonics, dof, tol_rel=sv.tolerance)
        t_syn = time.perf_counter() - t0
        t0 = time.perf_counter()
        cur = frequency_response(system, sv.harmonics, fr.omega_start, fr.omega_stop,
                                 stability=False, tol_rel=sv.tolerance, peak_dofs=[dof])
        t_hbm = time.perf_counter() - t0
        i = int(np.argmax(np.where(cur.converged, cur.amplitude[:, dof], -1.0)))
        ref, w = cur.amplitude[i, dof], cur.omega[i]
        print(f"{n0:>9g} {c['peak_amplitude']:>11.4e} {ref:>11.4e} "
              f"{c['peak_amplitude'] / ref - 1:>+8.2%} {c['peak_omega'] / w - 1:>+9.3%} "
              f"{t_syn:>8.1f} {t_hbm:>7.1f}")


def run(quick=False):
    print(f"Nonlinear modes (load average {os.getloadavg()[0]:.1f}, "
          f"{os.cpu_count()} cores)")
    backbone_table(quick)
    synthesis_table()
    preload_table(quick)
    return 0
