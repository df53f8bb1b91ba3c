"""Example 1 of the paper (Sec. 6.1) with pyHarm: frequency response, H = 7,
150 -> 250 rad/s, for one normal load n [N].  Run with an interpreter that has
pyHarm (`pip install pyharm-os`), never with the pipeline's own:

    python pyharm_example1.py N [DS] [--repeat R]

    m x'' + c x' + k x + f_J(x) = F0 cos(Om t),
    m = 1 kg, c = 0.3 N s/m, k = 3.55e4 N/m, F0 = 1 N,
    f_J: pyHarm's `Jenkins` element to ground, k = ku = 1e4 N/m, mu = 0.5, N0 = n.

pyHarm's defaults otherwise: 128 time samples per period (AFT), arc-length corrector,
tangent predictor, step ds0 = ds_max = 1, scipy `root` (hybr).  Prints one line

    RESULT n points seconds peak_amplitude peak_omega final_omega cpu=CPU_SECONDS

seconds: building the system and the analysis and solving it, after a warm-up solve
over 150-151 rad/s in the same process (Numba's cached kernels loaded), the median of
R runs (default 1); the imports and interpreter start-up are excluded.  Amplitude: half
peak-to-peak of x(t).
"""
import logging
import sys
import time

import numpy as np


def example1(n, omega_end=250.0, ds=None):
    """The pyHarm input dictionary of Example 1 at normal load n [N]; `ds`: the
    arc-length step ds0 = ds_max (None: pyHarm's default, 1)."""
    step = {} if ds is None else {"ds0": ds, "ds_max": ds}
    ground = {"connect": {"mass": [0]}, "dirs": [0]}
    return {
        "system": {"type": "Base", "nh": 7, "nti": 128},
        "substructures": {"mass": {"type": "onlydofs", "nnodes": 1, "ndofs": 1}},
        "connectors": {
            "inertia": {"type": "GOElement", "dto": 2, "xo": 1, "k": 1.0, **ground},
            "spring": {"type": "LinearSpring", "k": 3.55e4, **ground},
            "damper": {"type": "LinearDamper", "k": 0.3, **ground},
            "jenkins": {"type": "Jenkins", "k": 1e4, "mu": 0.5, "N0": float(n), **ground},
            "forcing": {"type": "CosinusForcing", "amp": 1.0, **ground},
        },
        "analysis": {"frf": {"study": "frf", "puls_inf": 150.0, "puls_start": 150.0,
                             "puls_sup": omega_end, "verbose": False, **step}},
    }


def solve(n, omega_end=250.0, ds=None):
    import pyHarm
    from pyHarm.DynamicOperator import compute_DFT

    maestro = pyHarm.Maestro(example1(n, omega_end, ds))
    maestro.operate()
    sols = [s for s in maestro.nls["frf"].SolList if s.flag_accepted]
    X = np.array([s.x for s in sols])
    x = X[:, :-1] @ compute_DFT(512, 7)["ft"]    # x(t) at 512 samples per period
    return X[:, -1], (x.max(1) - x.min(1)) / 2


def main(argv):
    from script_args import arguments   # beside this script (no pipeline in pyHarm's venv)

    parsed = arguments(argv, "N [DS] [--repeat R]", 2)
    if parsed is None:
        return 2
    repeat, (n, *rest) = parsed
    ds = rest[0] if rest else None
    logging.disable(logging.INFO)    # pyHarm logs every step at INFO
    solve(n, omega_end=151.0, ds=ds)
    times, cpus = [], []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        om, a = solve(n, ds=ds)
        times.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
    seconds, cpu = float(np.median(times)), float(np.median(cpus))
    i = int(np.argmax(a))
    print(f"RESULT {n:g} {om.size} {seconds:.6f} {a[i]:.10g} {om[i]:.10g} {om[-1]:.4f} "
          f"cpu={cpu:.6f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
