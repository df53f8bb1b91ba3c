"""`bench montecarlo` prints one row per mode with the peaks' differences against the
full curves (the case itself is the Monte-Carlo study's: measured by the bench, the
equality of its peaks checked in tests/solve/response/test_largest_peaks.py)."""
import numpy as np

import pipeline.bench.montecarlo as mc


def test_bench_montecarlo_prints_both_modes_and_their_differences(monkeypatch, capsys):
    full = ("full curves", 10.0, 20.0, 900, 350, 5000, np.array([1.0, 2.0]), np.array([5.0, 6.0]))
    peaks = ("largest peaks", 4.0, 5.0, 2, 350, 1600, np.array([1.0, 2.0 * (1 + 3e-9)]),
             np.array([5.0, 6.0 * (1 + 2e-7)]))
    monkeypatch.setattr(mc, "case_rows", lambda quick=False: ("2 blades", [full, peaks]))
    assert mc.run() == 0
    out = capsys.readouterr().out
    assert "2 blades" in out and "load average" in out
    row = next(line for line in out.splitlines() if line.startswith("largest peaks"))
    assert "3.0e-09" in row and "2.0e-07" in row
    assert "wall 2.50, CPU 4.00" in out
