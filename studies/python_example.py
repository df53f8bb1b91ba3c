"""The paper's Example 1 (Sec. 6.1, Fig. 2) written in Python instead of a study file.

A single-DOF oscillator with a Jenkins friction damper to ground (a Yang-Menq element
with kv = 0, so a constant normal load n0),

    m x'' + c x' + k x + f_u(x) = F0 cos(w t),

traced by frequency-response continuation (harmonic balance) for three normal loads,
returned as the dataset `python -m pipeline run` writes for the same study, written
to netCDF and plotted.

    python studies/python_example.py [OUT_DIR]        (default: results)
"""
import sys
from pathlib import Path

import numpy as np

import pipeline

# M, C, K over named DOFs [kg, N s/m, N/m]
structure = pipeline.Lumped(M=np.array([[1.0]]), C=np.array([[0.3]]), K=np.array([[3.55e4]]),
                            dofs=("x",))
# u = x slides against ground; no normal DOF (kv = 0): the normal load is n0, set per case
damper = pipeline.DofContact(name="damper", bt=np.array([1.0]), bn=np.array([0.0]),
                             ku=1.0e4, kv=0.0, mu=0.5, n0=None)
# F(t) = Re sum_h F_h exp(i h w t) [N]: F0 = 1 N at h = 1 on x (column 0: a static load)
forcing = pipeline.Forcing(np.array([[0.0, 1.0]], dtype=complex))
scene = pipeline.Scene(structure=structure, contacts=(damper,), loads=(forcing,),
                       effects=("friction",), model="lumped")

study = pipeline.Study(
    name="python_example",
    title="Example 1 in Python: single-DOF oscillator with a friction damper to ground",
    reference="Sec. 6.1, Eq. 12-13, Fig. 2",
    scene=scene,
    # n0 = 0 leaves the linear oscillator, 1000 N keeps the damper stuck [N]
    sweep=pipeline.Sweep(axes={"preload": (0.0, 2.0, 1000.0)},
                         frequency=pipeline.FrequencyRange(150.0, 250.0, "rad/s")),
    solver=pipeline.SolverSettings(harmonics=3),   # exact forces; stability: monodromy+check
    output=pipeline.OutputSettings(dofs=("x",), yscale="log"))

# one continuation per case, with the settings `run` passes
fr, H = study.sweep.frequency, study.solver.harmonics
curves = [pipeline.frequency_response(pipeline.build_system(scene, case), H, fr.omega_start,
                                      fr.omega_stop, **study.solver.kwargs(study.output.yscale))
          for _, case in study.sweep.cases()]
ds = pipeline.to_dataset(study, curves)

if __name__ == "__main__":
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "results")
    print("wrote", pipeline.write_netcdf(ds, out / f"{study.name}.nc"))
    lines = ds["amplitude"].sel(dof="x").plot.line(x="frequency", hue="preload", yscale="log")
    lines[0].figure.savefig(out / f"{study.name}.png")
