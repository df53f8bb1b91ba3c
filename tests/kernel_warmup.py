"""The package's compiled kernels, compiled (or loaded from their cache) before the test
processes start: `python kernel_warmup.py exact|others`, the two halves side by side
(conftest.py), so that each kernel is compiled once per run, not once per test process.
Each half calls the public entry points on small inputs of the types the package
passes, so that the signatures compiled are the ones the tests use."""
import sys

import numpy as np


def exact():
    """The exact Yang-Menq forces with their Jacobian and the periodic segments (time
    history), with the certified root search beneath them."""
    from pipeline.bench import shroud_like_motions
    from pipeline.contact import forces
    from pipeline.contact.exact import periodic_segments

    U, V, elem = shroud_like_motions(8, 3)
    forces(U, V, elem, jacobian=True)
    periodic_segments(U, V, elem)


def others():
    """The sampled (AFT) 1D and 2D friction march, the stuck slider's centre, the
    continuation's Hermite predictor and the sampled extrema."""
    from pipeline.bench import shroud_like_motions
    from pipeline.contact import forces
    from pipeline.contact.friction2d.kernel import march
    from pipeline.fourier.harmonics import amplitude_half_peak_to_peak
    from pipeline.solve.continuation.branch import hermite_on_plane

    U, V, elem = shroud_like_motions(8, 3)
    forces(U, V, elem, method="aft", n_samples=64, jacobian=True)
    rng = np.random.default_rng(0)
    E, nh = 4, 7
    X = rng.normal(size=(E, 3, nh)) * 0.1
    k = np.full((E, 2), 1.0)
    for n0 in (0.5, 50.0):                     # slipping, and stuck throughout
        march(k, np.ones(E), np.full(E, 0.3), np.full(E, n0), X, 64, True, True)
    Y = np.cumsum(rng.normal(size=(3, 5)), axis=0)
    T = np.diff(np.vstack([Y, Y[-1:] + 1.0]), axis=0)
    T /= np.linalg.norm(T, axis=1)[:, None]
    hermite_on_plane(Y, T, T[-1], 0.1)
    amplitude_half_peak_to_peak(rng.normal(size=(5, nh)))


if __name__ == "__main__":
    {"exact": exact, "others": others}[sys.argv[1]]()
