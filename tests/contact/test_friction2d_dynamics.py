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
    stiffness KU along x, ku2 along y).  Written per component (no array temporaries
    in the step loop: the same operations in the same order as the vector form)."""
    out = np.zeros((omegas.size, 2))
    slip = MU * N0
    for j in range(omegas.size):
        om = omegas[j]
        dt = 2 * np.pi / om / steps
        x0 = x1 = v0 = v1 = w0 = w1 = f0 = f1 = 0.0
        lo0 = lo1 = 1e9
        hi0 = hi1 = -1e9
        a0 = -KX * x0 - C * v0 - f0
        a1 = -KY * x1 - C * v1 - f1
        for n in range(steps * periods):
            t = n * dt
            vh0 = v0 + 0.5 * dt * a0
            vh1 = v1 + 0.5 * dt * a1
            x0 = x0 + dt * vh0
            x1 = x1 + dt * vh1
            tr0 = KU * (x0 - w0)
            tr1 = ku2 * (x1 - w1)
            size = np.sqrt(tr0 ** 2 + tr1 ** 2)
            if size > slip and ku2 == KU:
                tr0 = tr0 * (slip / size)
                tr1 = tr1 * (slip / size)
                w0 = x0 - tr0 / KU
                w1 = x1 - tr1 / KU
            elif size > slip:     # slide along the previous force onto the circle
                fs = np.sqrt(f0 ** 2 + f1 ** 2)
                if fs > 0:
                    e0, e1 = f0 / fs, f1 / fs
                else:
                    e0, e1 = tr0 / size, tr1 / size
                ke0, ke1 = KU * e0, ku2 * e1
                b, aa = tr0 * ke0 + tr1 * ke1, ke0 ** 2 + ke1 ** 2
                dl = (b - np.sqrt(max(b * b - aa * (size ** 2 - slip ** 2), 0.0))) / aa
                w0 = w0 + dl * e0
                w1 = w1 + dl * e1
                tr0 = KU * (x0 - w0)
                tr1 = ku2 * (x1 - w1)
            f0, f1 = tr0, tr1
            cs = np.cos(om * (t + dt))
            a0 = FX * cs - KX * x0 - C * vh0 - f0
            a1 = FY * cs - KY * x1 - C * vh1 - f1
            v0 = vh0 + 0.5 * dt * a0
            v1 = vh1 + 0.5 * dt * a1
            if n >= steps * (periods - 1):
                lo0, hi0 = min(lo0, x0), max(hi0, x0)
                lo1, hi1 = min(lo1, x1), max(hi1, x1)
        out[j, 0] = 0.5 * (hi0 - lo0)
        out[j, 1] = 0.5 * (hi1 - lo1)
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
