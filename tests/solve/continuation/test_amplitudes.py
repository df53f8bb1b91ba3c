"""The amplitudes the branch refinement reads, recovered once per point for all DOFs."""
import numpy as np

import pipeline.solve.continuation.amplitudes as amplitudes
from pipeline.paper_systems import example3
from pipeline.solve.continuation.amplitudes import AmplitudeCache, amplitudes_at
from pipeline.solve.harmonic_balance import hbm


def test_the_cache_reads_each_point_once_for_every_dof(monkeypatch):
    """Example 3's two DOFs at three states: the cache's values equal amplitudes_at's
    bit for bit, and each point is recovered once however many DOFs ask."""
    prob = hbm.setup(example3(10.0), 3, "exact", 256)
    rng = np.random.default_rng(1)
    Z = np.column_stack([rng.normal(size=(3, prob.size)), [1.0, 1.1, 1.2]])
    ref = amplitudes_at(prob, Z[:, :-1], Z[:, -1], [0, 1])
    calls = []
    real = hbm.recover
    monkeypatch.setattr(amplitudes.hbm, "recover", lambda *a: calls.append(1) or real(*a))
    cache = AmplitudeCache(prob, [0, 1])
    for _ in range(2):
        for i, z in enumerate(Z):
            assert [cache(z, 0), cache(z, 1)] == list(ref[i])
    assert len(calls) == 3
