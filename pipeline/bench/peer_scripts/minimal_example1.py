"""Example 1 of the paper (Sec. 6.1) by a minimal harmonic-balance continuation in plain
numpy: the floor of what a Python loop costs, for `bench peers`.  Run as a program:

    python minimal_example1.py N [--repeat R]

    m x'' + c x' + k x + f_J(x) = F0 cos(Om t),  m = 1 kg, c = 0.3 N s/m,
    k = 3.55e4 N/m, F0 = 1 N, f_J the Jenkins element ku = 1e4 N/m, mu = 0.5, normal
    load n,  H = 7, 150 -> 250 rad/s.

Only what a curve with stability cannot do without: the pipeline's exact forces and
Jacobian (`contact.exact.stacked_forces`, its compiled kernel), pseudo-arclength
continuation (tangent predictor, Newton on the bordered system, the harmonics scaled
by their current largest magnitude as NLvib's `dynamicDscale`, the step grown or
shrunk by the Newton iterations), |R| <= 1e-10 F0, and Hill's eigenproblem
(`stability.hill.hill_eigenvalues`) at every point.  None of the pipeline's checks:
no resonance guard, no recomputed full residual, no round-off floor, no dense
output, the peak the largest point (no exact location), no fold handling.  Prints

    RESULT n points seconds peak_amplitude peak_omega residual_evaluations final_omega cpu=CPU

seconds (CPU: cpu=): the curve after a warm-up in the same process, the median of R
runs (default 1); amplitude: half peak-to-peak of x(t) at 512 samples a period.  A
curve that stops short of 250 rad/s prints no RESULT (exit 1).
"""
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")   # as the pipeline's own runs

import numpy as np  # noqa: E402

from pipeline.contact.exact import stacked_forces  # noqa: E402
from pipeline.fourier.harmonics import derivative_matrix  # noqa: E402
from pipeline.paper_systems import example1  # noqa: E402
from pipeline.solve.harmonic_balance.dynamic_stiffness import apply_full, full_operator  # noqa: E402
from pipeline.solve.stability.hill import hill_eigenvalues  # noqa: E402

H, OMEGA = 7, (150.0, 250.0)
F0 = 1.0                      # [N] example1's excitation
TOL = 1e-10 * F0              # [N]
DS, DS_MAX = 0.05, 0.1        # scaled arclength: harmonics / their largest, Omega / the band
MAX_POINTS, MAX_NEWTON = 2000, 8
NH = 2 * H + 1
D = derivative_matrix(H)
P = np.zeros(NH)
P[1] = F0
V0 = np.zeros((1, NH))        # no normal motion: a Jenkins element


def residual(x, system):
    """(R [N], [dR/dQ, dR/dOm]) at x = [Q (2H+1), Om]: the pipeline's linear kernel
    (`dynamic_stiffness`) and exact forces."""
    Q, om = x[:NH], x[NH]
    L = full_operator(system, om, H)
    F, J, _ = stacked_forces(Q[None, :], V0, system.contact)
    dR = np.empty((NH, NH + 1))
    dR[:, :NH] = L + J[0, 0]
    dR[:, NH] = apply_full(system.K, system.C, system.M, Q[None, :], om, D, rate=True)[0]
    return L @ Q + F[0, 0] - P, dR


def stable(dRdQ, om, system):
    lam = hill_eigenvalues(dRdQ, system.M, system.C, om, H)
    return bool(lam.real.max() <= 1e-9 * np.abs(lam).max())


def curve(n):
    """(points (P, 2H+2), stable flags, residual evaluations)."""
    system = example1(n)
    x = np.zeros(NH + 1)
    x[NH] = OMEGA[0]
    nfev = 0
    for _ in range(MAX_NEWTON * 4):                   # the first point, at fixed Omega, from rest
        R, dR = residual(x, system)
        nfev += 1
        if np.linalg.norm(R) <= TOL:
            break
        x[:NH] -= np.linalg.solve(dR[:, :NH], R)
    else:
        raise ArithmeticError("the first point did not converge")
    e = np.eye(NH + 1)[NH]
    scale = np.append(np.full(NH, np.abs(x[:NH]).max()), OMEGA[1] - OMEGA[0])
    t = np.linalg.solve(np.vstack([dR * scale, e]), e)
    t /= np.linalg.norm(t)
    points, flags, ds = [x.copy()], [stable(dR[:, :NH], x[NH], system)], DS
    while x[NH] < OMEGA[1] and len(points) < MAX_POINTS and ds > 1e-8:
        z0 = x / scale
        z = z0 + ds * t
        for it in range(MAX_NEWTON):
            R, dR = residual(z * scale, system)
            nfev += 1
            if it > 0 and np.linalg.norm(R) <= TOL:
                break
            A = np.vstack([dR * scale, t])
            z = z - np.linalg.solve(A, np.append(R, t @ (z - z0) - ds))
        else:
            ds /= 2
            continue
        tn = np.linalg.solve(np.vstack([dR * scale, t]), e)
        t = np.sign(tn @ t) * tn / np.linalg.norm(tn)
        x = z * scale
        points.append(x.copy())
        flags.append(stable(dR[:, :NH], x[NH], system))
        new = np.append(np.full(NH, np.abs(x[:NH]).max()), scale[NH])   # dynamic scaling
        t = t * scale / new
        t /= np.linalg.norm(t)
        scale = new
        ds = min(ds * (1.5 if it <= 2 else 0.7 if it >= 5 else 1.0), DS_MAX)
    return np.array(points), np.array(flags), nfev


def amplitude(points):
    tau = 2 * np.pi * np.arange(512) / 512
    E = np.column_stack([np.ones(512)] + [f(h * tau) for h in range(1, H + 1)
                                           for f in (np.cos, np.sin)])
    x = points[:, :NH] @ E.T
    return (x.max(1) - x.min(1)) / 2


def main(argv):
    from script_args import arguments   # beside this script

    parsed = arguments(argv, "N [--repeat R]", 1)
    if parsed is None:
        return 2
    repeat, (n,) = parsed
    curve(n)                                          # warm-up: kernels loaded
    times, cpus = [], []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        points, _, nfev = curve(n)
        times.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
    if points[-1, NH] < OMEGA[1]:   # a partial curve is no result to time
        print(f"minimal_example1.py: the curve stopped at {points[-1, NH]:.4f} rad/s, short "
              f"of {OMEGA[1]:g}", file=sys.stderr)
        return 1
    a = amplitude(points)
    i = int(np.argmax(a))
    print(f"RESULT {n:g} {len(points)} {np.median(times):.6f} {a[i]:.10g} "
          f"{points[i, NH]:.10g} {nfev} {points[-1, NH]:.4f} cpu={np.median(cpus):.6f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
