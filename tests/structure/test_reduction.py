"""Craig-Bampton reduction against the full model: Rayleigh-Ritz bounds, convergence
in the mode count, exact statics, FRF, projections, damping, errors."""
import meshio
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.linalg as la
import scipy.sparse.linalg as sla

from pipeline.structure.blades import build_blade
from pipeline.structure.fe_model import BladeParams, boundary_dofs
from pipeline.structure.mesh_io import write_fields
from pipeline.structure.reduction import (DEFAULT_MODES, eigenmodes, frf, modal_convergence,
                                          reconstruct, reduce, reduce_blade, reduce_map,
                                          reduced_modes)

SMALL = BladeParams(n_chord=6, n_thick=1, n_span=12)
TINY = BladeParams(n_chord=4, n_thick=1, n_span=8)   # 1782 DOFs: a dense solve in seconds


@pytest.fixture(scope="module")
def blade():
    return build_blade(BladeParams())  # the default blade, ~12k DOFs


@pytest.fixture(scope="module")
def full_freqs(blade):
    w2, _ = eigenmodes(blade.K, blade.M, 10)
    return np.sqrt(w2) / (2 * np.pi)


@pytest.fixture(scope="module")
def reduced(blade):
    return reduce_blade(blade)


@pytest.fixture(scope="module")
def small():
    return build_blade(SMALL)


def test_default_modes_within_0p1_percent_from_above(reduced, full_freqs):
    assert reduced.n_modes == DEFAULT_MODES
    err = reduced.frequencies[:10] / full_freqs - 1
    assert np.all(err > -1e-9), err  # Rayleigh-Ritz: upper bounds
    assert np.max(err) < 1e-3, err


def test_error_falls_monotonically_with_mode_count(small):
    res = modal_convergence(SMALL, [0, 5, 10, 20, 40], n_freqs=10)
    err = res["rel_error"]
    assert err.shape == (5, 10) and res["full_hz"].shape == (10,)
    assert np.all(err > -1e-9)
    worst = err.max(axis=1)
    assert np.all(np.diff(worst) < 0), worst
    assert np.all(np.diff(err, axis=0) <= 1e-9)  # per frequency too
    assert res["time_reduce_s"].shape == (5,)
    assert int(res["n_boundary"]) == boundary_dofs(small)[0].size


def test_projection_identities(small):
    red = reduce_blade(small, 8)
    T = red.T
    np.testing.assert_allclose(T.T @ (small.K @ T), red.K, atol=1e-10 * abs(red.K).max())
    np.testing.assert_allclose(T.T @ (small.M @ T), red.M, atol=1e-12 * abs(red.M).max())
    q = np.random.default_rng(0).standard_normal((red.M.shape[0], 2))
    np.testing.assert_allclose(reconstruct(red, q), T @ q, atol=1e-14 * abs(T @ q).max())
    assert red.labels[0] == "shroud_left:0:x" and red.labels[-1] == "mode:8"


def test_reduced_matrices_match_a_dense_reference():
    """Independent reference on a tiny blade (4 x 1 x 8 elements, 1782 DOFs: the dense
    solves cost O(n^3), and the identities below hold for any mesh; the small blade's
    3978 DOFs cost ten times more): Psi from a dense solve, Phi from a dense
    generalized eigen-solve (signs matched), then T^T K T and T^T M T of the full
    matrices.  The reduced matrices agree to 1e-10 of their largest entry."""
    m = 8
    small = build_blade(TINY)
    red = reduce_blade(small, m)
    b, i = red.boundary, red.interior
    K, M = small.K.toarray(), small.M.toarray()
    Psi = -la.solve(K[np.ix_(i, i)], K[np.ix_(i, b)], assume_a="pos")
    w2, Phi = la.eigh(K[np.ix_(i, i)], M[np.ix_(i, i)], subset_by_index=[0, m - 1])
    Phi *= np.sign(np.einsum("ij,ij->j", Phi, red.Phi))
    T = np.zeros((small.n_dof, b.size + m))
    T[b, np.arange(b.size)] = 1.0
    T[i, :b.size], T[i, b.size:] = Psi, Phi
    np.testing.assert_allclose(red.K, T.T @ K @ T, rtol=0, atol=1e-10 * abs(red.K).max())
    np.testing.assert_allclose(red.M, T.T @ M @ T, rtol=0, atol=1e-10 * abs(red.M).max())
    np.testing.assert_allclose(red.Psi, Psi, rtol=0, atol=1e-10 * abs(Psi).max())
    np.testing.assert_allclose(red.Phi, Phi, rtol=0, atol=1e-8 * abs(Phi).max())
    np.testing.assert_allclose(red.fixed_frequencies, np.sqrt(w2) / (2 * np.pi), rtol=1e-10)
    f = np.sqrt(la.eigh(T.T @ K @ T, T.T @ M @ T, eigvals_only=True)) / (2 * np.pi)
    # a dense eigen-solve of (K_r, M_r) itself loses ~eps * cond: 1e-9 at f1
    np.testing.assert_allclose(red.frequencies, f, rtol=1e-8)


def test_statics_at_boundary_dofs_are_exact(small):
    """Loads on boundary DOFs: the constraint modes span the static solution."""
    red = reduce_blade(small, 4)
    f = np.zeros(small.n_dof)
    b = red.boundary
    f[b] = np.random.default_rng(1).standard_normal(b.size)
    u = sla.spsolve(sp.csc_matrix(small.K), f)
    q = np.linalg.solve(red.K, f[b].tolist() + [0.0] * red.n_modes)
    np.testing.assert_allclose(reconstruct(red, q), u, atol=1e-9 * abs(u).max())


def test_frf_at_contact_dofs_matches_full_model(small):
    """Receptance from the excitation point to all shroud DOFs, 0 .. 2 f3, default
    mode count, Rayleigh damping (projects exactly).  Error per frequency in the norm
    over the contact DOFs (single entries may pass through antiresonances)."""
    blade = small
    w2, _ = eigenmodes(blade.K, blade.M, 6)
    fn = np.sqrt(w2) / (2 * np.pi)
    f3 = fn[2]
    beta = 2 * 0.01 / (2 * np.pi * f3)  # zeta = 1 % at f3
    red = reduce_blade(blade, rayleigh=(0.0, beta))
    exc = blade.dof_sets["excitation"][0]
    contact = np.concatenate([blade.dof_sets[s].ravel() for s in ("shroud_left", "shroud_right")])
    f = np.linspace(0.0, 2.0, 41) * f3
    f = f[np.all(abs(f[:, None] / fn - 1) > 0.01, axis=1)]  # not on a resonance peak
    omegas = 2 * np.pi * f
    H = frf(blade.K, blade.M, beta * blade.K, exc, contact, omegas)
    pos = np.full(blade.n_dof, -1)
    pos[red.boundary] = np.arange(red.n_boundary)
    Hr = frf(red.K, red.M, red.C, pos[exc], pos[contact], omegas)
    err = np.linalg.norm(Hr - H, axis=(1, 2)) / np.linalg.norm(H, axis=(1, 2))
    assert np.max(err) < 5e-3, err
    np.testing.assert_allclose(red.C, beta * red.K)


def test_modal_damping_of_reduced_modes(reduced):
    f, _ = reduced_modes(reduced, 5)
    w2, X = la.eigh(reduced.K, reduced.M, subset_by_index=[0, 4])
    D = X.T @ reduced.C @ X
    zeta = np.diag(D) / (2 * np.sqrt(w2))
    np.testing.assert_allclose(zeta, BladeParams().damping_ratios[0], rtol=1e-8)
    assert np.max(abs(D - np.diag(np.diag(D)))) < 1e-8 * np.max(np.diag(D))
    np.testing.assert_allclose(f, np.sqrt(w2) / (2 * np.pi))


def test_contact_maps_over_reduced_coordinates(blade, reduced):
    f = blade.frames["shroud_right"]
    Bt, Bn, _ = f.maps(blade.n_dof)
    Btr = reduce_map(reduced, Bt)
    q = np.random.default_rng(2).standard_normal(reduced.M.shape[0])
    np.testing.assert_allclose(Btr @ q, Bt @ reconstruct(reduced, q), atol=1e-12)
    pos = reduced.sets["shroud_right"]
    np.testing.assert_allclose(Btr[:, pos[:, 0]].diagonal(), f.tangent[0])
    with pytest.raises(ValueError, match="interior"):
        reduce_map(reduced, sp.eye(1, blade.n_dof, k=int(reduced.interior[0])))


def test_mode_shapes_export_to_vtu(small, tmp_path):
    red = reduce_blade(small, 10)
    f, U = reduced_modes(red, 3)
    path = write_fields(small, tmp_path / "cb_modes.vtu",
                        {f"mode_{k + 1}": U[:, k] for k in range(3)})
    m = meshio.read(path)
    assert set(m.point_data) >= {"mode_1", "mode_2", "mode_3", "shroud_left"}
    # operating deflection shape (complex) at 0.9 f1 driven at the excitation point
    q = np.linalg.solve(red.K - (2 * np.pi * 0.9 * f[0]) ** 2 * red.M + 0j,
                        np.eye(red.M.shape[0])[:, red.sets["excitation"][0, 1]])
    write_fields(small, tmp_path / "ods.vtu", {"ods": reconstruct(red, q)})
    assert "ods_abs" in meshio.read(tmp_path / "ods.vtu").point_data


@pytest.mark.parametrize("kwargs, match", [
    ({"boundary": [0, 0]}, "duplicate"),
    ({"boundary": []}, "boundary"),
    ({"boundary": [10**9]}, "boundary"),
    ({"boundary": [0, 1], "n_modes": -1}, "n_modes"),
    ({"boundary": [0, 1], "labels": ["a"]}, "labels"),
    ({"boundary": [0, 1], "rayleigh": (1.0,)}, "rayleigh"),
])
def test_reduce_argument_errors(small, kwargs, match):
    with pytest.raises(ValueError, match=match):
        reduce(small.K, small.M, **kwargs)


def test_mode_counts_error():
    with pytest.raises(ValueError, match="mode_counts"):
        modal_convergence(SMALL, [])


def test_reduction_is_repeatable(small):
    """The same blade reduced twice gives the same reduced model to the last bit, mode
    signs included (a fixed ARPACK start vector, not a random one per call)."""
    a, b = reduce_blade(small, 8), reduce_blade(small, 8)
    for name in ("M", "K", "C", "Phi", "Psi"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    w1, X1 = eigenmodes(small.K, small.M, 6)
    w2, X2 = eigenmodes(small.K, small.M, 6)
    assert np.array_equal(w1, w2) and np.array_equal(X1, X2)
