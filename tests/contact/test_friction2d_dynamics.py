"""The 2D friction law in a harmonic-balance study against brute-force time integration.

`tests/studies/inplane_oscillator_2d_friction.toml`: a mass in a plane with a 2D
friction contact to ground, forced along an oblique direction.  The reference is
written here: velocity-Verlet steps (4000 a period) with the return mapping of the
Coulomb disc at every step, run 150 periods from rest at frequencies around the
harmonic-balance peak, the amplitude (max - min) / 2 of the last period, the peak by a
parabola through the three largest.  Peaks of x and y within 0.5 %."""
from pathlib import Path

import numpy as np
from numba import njit

from pipeline.__main__ import main as cli
from pipeline.study.datasets.dataset import read_dataset

STUDY = Path(__file__).resolve().parents[1] / "studies" / "inplane_oscillator_2d_friction.toml"
KX, KY, C, KU, MU, N0 = 3.55e4, 4.0e4, 5.0, 1.0e4, 0.5, 5.0
FX, FY = 10.0, 7.0


@njit(cache=True)
def amplitudes(omegas, steps, periods):
    """(len(omegas), 2) half peak-to-peak of x, y over the last period."""
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
            tr = KU * (x - w)
            size = np.sqrt(tr[0] ** 2 + tr[1] ** 2)
            if size > MU * N0:
                tr = tr * (MU * N0 / size)
                w = x - tr / KU
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


def test_peaks_against_brute_force_time_integration(tmp_path):
    assert cli(["run", str(STUDY), "--out", str(tmp_path), "--no-figures"]) == 0
    ds = read_dataset(tmp_path / f"{STUDY.stem}.nc")
    for d, dof in enumerate(("x", "y")):
        hb = float(ds["peak_amplitude"].sel(dof=dof).values.ravel()[0])
        w_peak = float(ds["peak_frequency"].sel(dof=dof).values.ravel()[0])
        om = w_peak * np.linspace(0.99, 1.01, 11)
        ref = parabola_peak(om, amplitudes(om, 4000, 150)[:, d])
        assert abs(hb / ref - 1) < 5e-3, (dof, hb, ref)


def test_linear_limits_carry_the_2d_contact():
    """Stuck, the contact adds ku along both tangents: sqrt((k + ku) / m) in x and y;
    open, the bare springs (the dataset's natural_frequency_stuck / _free)."""
    from pipeline.model.system import natural_frequencies
    from pipeline.study.files.documents import load_study

    s = load_study(STUDY).system({})
    stuck = np.sort(natural_frequencies(s, "stuck"))[:2]
    np.testing.assert_allclose(stuck, np.sqrt([KX + KU, KY + KU]), rtol=1e-12)
    np.testing.assert_allclose(np.sort(natural_frequencies(s, "open"))[:2],
                               np.sqrt([KX, KY]), rtol=1e-12)
