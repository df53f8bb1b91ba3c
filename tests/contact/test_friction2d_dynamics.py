"""The 2D friction law in a harmonic-balance study against brute-force time integration.

`tests/studies/inplane_oscillator_2d_friction.toml`: a mass in a plane with a 2D
friction contact to ground, forced along an oblique direction.  The reference is
written here: velocity-Verlet steps (4000 a period) with the return mapping of the
Coulomb disc at every step, run 150 periods from rest at frequencies around the
harmonic-balance peak, the amplitude (max - min) / 2 of the last period, the peak by a
parabola through the three largest.  Peaks of x and y within 0.5 %, isotropic and with
the contact 2.5 times stiffer along y (ku2; there the step slides along the previous
force, an explicit scheme unlike the law's implicit closest point)."""
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from pipeline.__main__ import main as cli
from pipeline.study.datasets.dataset import read_dataset

STUDY = Path(__file__).resolve().parents[1] / "studies" / "inplane_oscillator_2d_friction.toml"
KX, KY, C, KU, MU, N0 = 3.55e4, 4.0e4, 5.0, 1.0e4, 0.5, 5.0
KU2 = 2.5e4      # [N/m] the anisotropic variant's stiffness along y
FX, FY = 10.0, 7.0


@njit(cache=True)
def amplitudes(omegas, steps, periods, ku2):
    """(len(omegas), 2) half peak-to-peak of x, y over the last period (contact
    stiffness KU along x, ku2 along y)."""
    out = np.zeros((omegas.size, 2))
    for j in range(omegas.size):
        om = omegas[j]
        dt = 2 * np.pi / om / steps
        x = np.zeros(2)
        v = np.zeros(2)
        w = np.zeros(2)
        f = np.zeros(2)
        lo = np.full(2, 1e9)
        hi = np.full(2, -1e9)
        k = np.array([KX, KY])
        F = np.array([FX, FY])
        a = -k * x - C * v - f
        for n in range(steps * periods):
            t = n * dt
            vh = v + 0.5 * dt * a
            x = x + dt * vh
            kc = np.array([KU, ku2])
            tr = kc * (x - w)
            size = np.sqrt(tr[0] ** 2 + tr[1] ** 2)
            if size > MU * N0 and ku2 == KU:
                tr = tr * (MU * N0 / size)
                w = x - tr / KU
            elif size > MU * N0:     # slide along the previous force onto the circle
                fs = np.sqrt(f[0] ** 2 + f[1] ** 2)
                e = f / fs if fs > 0 else tr / size
                ke = kc * e
                b, aa = tr[0] * ke[0] + tr[1] * ke[1], ke[0] ** 2 + ke[1] ** 2
                dl = (b - np.sqrt(max(b * b - aa * (size ** 2 - (MU * N0) ** 2), 0.0))) / aa
                w = w + dl * e
                tr = kc * (x - w)
            f = tr
            a = F * np.cos(om * (t + dt)) - k * x - C * vh - f
            v = vh + 0.5 * dt * a
            if n >= steps * (periods - 1):
                for d in range(2):
                    lo[d] = min(lo[d], x[d])
                    hi[d] = max(hi[d], x[d])
        out[j] = 0.5 * (hi - lo)
    return out


def parabola_peak(om, amp):
    i = int(np.clip(np.argmax(amp), 1, amp.size - 2))
    c = np.polyfit(om[i - 1:i + 2], amp[i - 1:i + 2], 2)
    return -c[1] ** 2 / (4 * c[0]) + c[2]


def with_ku2(tmp_path, ku2):
    """The study file, with `ku2` [N/m] on its contact unless ku2 is KU."""
    if ku2 == KU:
        return STUDY
    path = tmp_path / STUDY.name
    path.write_text(STUDY.read_text().replace("ku = 1.0e4\n", f"ku = 1.0e4\nku2 = {ku2}\n"))
    return path


@pytest.mark.parametrize("ku2", [KU, KU2])
def test_peaks_against_brute_force_time_integration(tmp_path, ku2):
    study = with_ku2(tmp_path, ku2)
    assert cli(["run", str(study), "--out", str(tmp_path), "--no-figures"]) == 0
    ds = read_dataset(tmp_path / f"{STUDY.stem}.nc")
    for d, dof in enumerate(("x", "y")):
        hb = float(ds["peak_amplitude"].sel(dof=dof).values.ravel()[0])
        w_peak = float(ds["peak_frequency"].sel(dof=dof).values.ravel()[0])
        om = w_peak * np.linspace(0.99, 1.01, 11)
        ref = parabola_peak(om, amplitudes(om, 4000, 150, ku2)[:, d])
        assert abs(hb / ref - 1) < 5e-3, (dof, hb, ref)


@pytest.mark.parametrize("ku2", [KU, KU2])
def test_linear_limits_carry_the_2d_contact(tmp_path, ku2):
    """Stuck, the contact adds ku along both tangents: sqrt((k + ku) / m) in x and y;
    open, the bare springs (the dataset's natural_frequency_stuck / _free)."""
    from pipeline.model.system import natural_frequencies
    from pipeline.study.files.documents import load_study

    s = load_study(with_ku2(tmp_path, ku2)).system({})
    stuck = np.sort(natural_frequencies(s, "stuck"))[:2]
    np.testing.assert_allclose(stuck, np.sort(np.sqrt([KX + KU, KY + ku2])), rtol=1e-12)
    np.testing.assert_allclose(np.sort(natural_frequencies(s, "open"))[:2],
                               np.sqrt([KX, KY]), rtol=1e-12)
