"""The N-sector assembly stored sparse (`cyclic.full_assembly(..., sparse=True)`):
its matrices against a dense reference built here with np.kron, their O(N)
storage, and every consumer of a mistuned disk's System (harmonic balance setup,
residual, Jacobian, recovery, continuation, natural frequencies, Hill stability,
time integration) giving the numbers of the same System stored dense."""
import copy
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from pipeline.contact import YangMenq
from pipeline.model import cyclic
from pipeline.model.build import engine_order, full_system, sector, stiffness_factors
from pipeline.model.system import natural_frequencies
from pipeline.solve.harmonic_balance import full_operators
from pipeline.solve.harmonic_balance import hbm
from pipeline.solve.response.response import frequency_response
from pipeline.solve.stability.hill import is_stable
from pipeline.solve.time_integration.timesim import simulate
from pipeline.study.files.documents import study_from_document

ROOT = Path(__file__).resolve().parents[3]
DOC = tomllib.loads((ROOT / "studies" / "disk_mistuned.toml").read_text())
MATRICES = ("M", "C", "K", "Bt", "Bn")


def random_sector(N, n=3, E=2, seed=0):
    """An n-DOF sector with E elements reaching into the next sector [kg, N/m, N s/m]."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    K = A @ A.T + n * np.eye(n)
    B = lambda: rng.standard_normal((E, n)) * (rng.random((E, n)) < 0.6)  # noqa: E731
    return cyclic.Sector(M=np.diag(1.0 + rng.random(n)), C=0.01 * K, K=K, Bt=B(), Bn=B(),
                         Bt_next=B(), Bn_next=B(),
                         contact=YangMenq(np.full(E, 2.0), np.full(E, 1.0), 0.3, 0.5),
                         forcing=rng.standard_normal((n, 2)) + 0j, sectors=N)


@pytest.mark.parametrize("N", [6, 12, 24])
def test_sparse_assembly_is_the_kron_reference_with_linear_storage(N):
    """Sparse CSR matrices equal (to 0) blockdiag / block-bidiagonal references
    assembled densely here; nonzeros N times the sector's, so storage grows like N."""
    sec = random_sector(N)
    f = 1.0 + 0.05 * np.random.default_rng(N).standard_normal(N)
    s = cyclic.full_assembly(sec, 1, f, sparse=True)
    ring = np.roll(np.eye(N), 1, axis=1)           # ring[j, j+1 mod N] = 1
    ref = {"M": np.kron(np.eye(N), sec.M), "C": np.kron(np.eye(N), sec.C),
           "K": np.kron(np.diag(f), sec.K),
           "Bt": np.kron(np.eye(N), sec.Bt) + np.kron(ring, sec.Bt_next),
           "Bn": np.kron(np.eye(N), sec.Bn) + np.kron(ring, sec.Bn_next)}
    for name in MATRICES:
        A = getattr(s, name)
        assert sp.issparse(A) and A.format == "csr", name
        np.testing.assert_array_equal(A.toarray(), ref[name], err_msg=name)
        assert A.nnz == np.count_nonzero(ref[name]), name
    per_sector = sum(np.count_nonzero(getattr(sec, k)) for k in ("M", "C", "K", "Bt", "Bn",
                                                                 "Bt_next", "Bn_next"))
    assert sum(getattr(s, k).nnz for k in MATRICES) == N * per_sector
    d = cyclic.full_assembly(sec, 1, f, sparse=False)
    for name in MATRICES:
        np.testing.assert_array_equal(getattr(d, name), ref[name])
    np.testing.assert_array_equal(s.forcing, d.forcing)


def test_default_storage_follows_the_size_threshold():
    small, big = random_sector(6, n=2), random_sector(cyclic.DENSE_MAX_DOF, n=2)
    assert isinstance(cyclic.full_assembly(small, 1).K, np.ndarray)
    s = cyclic.full_assembly(big, 1)
    assert all(sp.issparse(getattr(s, k)) for k in MATRICES)


def disk(N, H=3, seed=1):
    """studies/disk_mistuned.toml with N sectors, EO 3, one seed, H harmonics."""
    doc = copy.deepcopy(DOC)
    doc.pop("quick")
    doc["scene"]["disk"].update(sectors=N, engine_order=3)
    doc["scene"]["disk"]["mistuning"] = {"stiffness_std": 0.02, "seed": seed}
    doc["sweep"].pop("mistuning_seed")
    doc["solver"].update(harmonics=H, stability=False)
    return study_from_document(doc, file="sparse.toml").scene


def both(scene):
    """The mistuned disk's assembly stored sparse, and a copy of it densified."""
    s = cyclic.full_assembly(sector(scene, {}), engine_order(scene, {}),
                             stiffness_factors(scene, {}), sparse=True)
    return s, replace(s, **{k: getattr(s, k).toarray() for k in MATRICES})


def close(a, b, rel=1e-10):
    a, b = np.asarray(a), np.asarray(b)
    assert np.abs(a - b).max() <= rel * np.abs(b).max()


def test_mistuned_disk_harmonic_balance_is_the_same_sparse_or_dense():
    """N = 24, H = 3: setup identical; residual, Jacobian, dR/dOm, recovery and the full
    residual of a random state equal to 1e-10 relative."""
    s, d = both(disk(24))
    ps, pd = hbm.setup(s, 3), hbm.setup(d, 3)
    for name in ("c", "o", "idx", "bt", "bn", "P"):
        np.testing.assert_array_equal(getattr(ps, name), getattr(pd, name), err_msg=name)
    x = 1e-5 * np.random.default_rng(0).standard_normal(ps.size)
    for Om in (2 * np.pi * 400, 2 * np.pi * 450):
        for a, b in zip(hbm.residual(ps, x, Om), hbm.residual(pd, x, Om)):
            close(a, b)
        Qs, Qd = (hbm.recover(p, x.reshape(p.c.size, -1), Om) for p in (ps, pd))
        close(Qs, Qd)
        close(hbm.full_residual(ps, Qs, Om), hbm.full_residual(pd, Qd, Om))


def test_mistuned_disk_continuation_is_the_same_sparse_or_dense():
    """A short stretch of the slipping response (N = 12, H = 3): the same branch
    points, amplitudes and Newton counts from the sparse and the dense assembly to
    1e-10; the refined peaks (a bounded Brent search on a flat maximum, so their
    frequency is only defined to ~1e-8 relative) the same peak amplitudes."""
    s, d = both(disk(12))
    kw = dict(stability=False, tol_rel=1e-9, max_points=12, dense_output=False)
    a, b = (frequency_response(x, 3, 2 * np.pi * 430, 2 * np.pi * 450, peak_dofs=[], **kw)
            for x in (s, d))
    assert a.converged.all() and a.omega.size == b.omega.size >= 8
    close(a.omega, b.omega)
    close(a.amplitude, b.amplitude)
    np.testing.assert_array_equal(a.newton_iterations, b.newton_iterations)
    a, b = (frequency_response(x, 3, 2 * np.pi * 430, 2 * np.pi * 450, peak_dofs=[0, 2], **kw)
            for x in (s, d))
    for dof in (0, 2):
        close(a.peak(dof)[0], b.peak(dof)[0])
        assert a.peak(dof)[1] == pytest.approx(b.peak(dof)[1], rel=1e-6)


def test_other_consumers_are_the_same_sparse_or_dense():
    """Natural frequencies (open, stuck), the Hill verdict from the full Jacobian and
    a few periods of event-driven integration (N = 6, H = 1)."""
    s, d = both(disk(6, H=1))
    for contacts in ("open", "stuck"):
        close(natural_frequencies(s, contacts), natural_frequencies(d, contacts), 1e-12)
    ps, pd = hbm.setup(s, 1), hbm.setup(d, 1)
    Om = 2 * np.pi * 440
    Q = hbm.recover(pd, 1e-6 * np.ones((pd.c.size, 3)), Om)
    Js, Jd = full_operators.full_jacobian(ps, Q, Om), full_operators.full_jacobian(pd, Q, Om)
    close(Js, Jd, 1e-14)
    assert is_stable(Js, d.M, d.C, Om, 1)[1] == pytest.approx(is_stable(Jd, d.M, d.C, Om, 1)[1],
                                                              rel=1e-10)
    ts, td = (simulate(x, Om, 3 * 2 * np.pi / Om) for x in (s, d))
    close(ts.q_final, td.q_final)


def test_large_mistuned_disk_is_stored_sparse():
    """200 sectors through the scene: O(N) nonzeros, no (N n)^2 array."""
    s = full_system(disk(200, H=1), {})
    assert all(sp.issparse(getattr(s, k)) for k in MATRICES)
    assert s.K.nnz == 200 * 4 and s.Bt.nnz == 200 * 2
    assert hbm.setup(s, 1).c.size == 200


def test_condensation_blade_by_blade_equals_the_whole():
    """A full wheel on a rigid disk condenses blade by blade (`parts.condense_by_parts`,
    one small dense solve per blade): S~, dS~/dOm, P~, dP~/dOm equal the one-piece
    sparse condensation and the dense one to 1e-12."""
    from dataclasses import replace as repl

    import pipeline.solve.harmonic_balance.hbm as hbm_mod
    from pipeline.solve.harmonic_balance.dynamic_stiffness import prepare
    from pipeline.model.system import dense
    from pipeline.study.files.documents import load_study

    st = load_study(Path(__file__).resolve().parents[3] / "studies" / "shrouded_disk_mistuned.toml",
                    quick=True)
    s = st.system({"preload": 3.0, "mistuning_seed": 1})
    prob = hbm_mod.setup(s, 3)
    assert prob.parts is not None and prob.parts.o.shape[0] == 24
    by_parts = hbm_mod.linear_part(prob, 1700.0)
    dense_sys = repl(s, M=dense(s.M), C=dense(s.C), K=dense(s.K))
    whole = hbm_mod.linear_part(repl(prob, system=dense_sys, linear=prepare(
        dense_sys, prob.H, prob.c, prob.o, prob.P, strategy="dense")), 1700.0)
    for a, b in zip(by_parts, whole):
        a, b = np.asarray(a), np.asarray(b)
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
