"""Compiled exact Yang-Menq forces against the numpy reference, finite differences
and the hard cases (grazing, exactly stuck, open, many harmonics)."""
import numpy as np
import pytest

from pipeline.bench import shroud_like_motions
from pipeline.contact import YangMenq, forces
from pipeline.contact import exact_reference
from pipeline.contact.exact import history
from pipeline.fourier.harmonics import basis

from helpers import one

TWO_PI = 2 * np.pi


def mixed_case(seed, E, H):
    """Shroud-like motions with per-element ku, kv (20 % Jenkins, kv = 0), mu and
    a static offset: separation, stick-slip and full stick all occur."""
    U, V, _ = shroud_like_motions(E, H, seed=seed)
    rng = np.random.default_rng(seed + 1000)
    U[:, 0] = rng.normal(size=E) * 0.3
    kv = rng.uniform(0.2, 3, E) * (rng.random(E) > 0.2)
    el = YangMenq(ku=10 ** rng.uniform(-1, 2, E), kv=kv, mu=rng.uniform(0.05, 0.8, E),
                  n0=rng.uniform(-0.5, 2.0, E))
    return U, V, el


def load_scale(V, el):
    """max over the period of |n| (>= 1e-9), per element, from a dense grid."""
    H = (V.shape[1] - 1) // 2
    tau = np.linspace(0, TWO_PI, 2001)
    n = el.n0[:, None] + el.kv[:, None] * (V @ basis(tau, H).T)
    return np.maximum(np.abs(n).max(1), 1e-9)


def worst_differences(f, g, U, V, el):
    """Largest difference of each quantity, per element relative to the larger of
    its scale, mu max|n| (Fu), max|n| (Fv), ku (dFu/dU), mu kv (dFu/dV), kv (dFv/dV),
    and the largest reference value."""
    n = load_scale(V, el)
    scales = {"Fu": el.mu * n, "Fv": n, "dFu_dU": el.ku, "dFu_dV": el.mu * el.kv,
              "dFv_dV": el.kv}
    out = {}
    for k, s in scales.items():
        a, b = getattr(f, k), getattr(g, k)
        diff = np.abs(a - b).reshape(len(a), -1).max(1)
        ref = np.abs(b).reshape(len(b), -1).max(1)
        out[k] = float(np.max(diff / np.maximum(s, np.maximum(ref, 1e-300))))
    return out


@pytest.mark.parametrize("H", [1, 3, 7, 21])
@pytest.mark.parametrize("factory", ["shroud", "mixed"])
def test_kernel_matches_numpy_reference(H, factory):
    E = 300
    if factory == "shroud":
        U, V, el = shroud_like_motions(E, H, seed=H)
    else:
        U, V, el = mixed_case(H, E, H)
    f = forces(U, V, el)
    g = exact_reference.exact_forces(U, V, el)
    assert f.regimes == g.regimes
    assert f.regimes["transitions"] > E // 2 and f.regimes["separated"] + f.regimes["stuck"] > 0
    worst = worst_differences(f, g, U, V, el)
    assert max(worst.values()) <= 1e-10, worst
    fn = forces(U, V, el, jacobian=False)
    np.testing.assert_array_equal(fn.Fu, f.Fu)
    np.testing.assert_array_equal(fn.Fv, f.Fv)


def central_differences(U, V, el, h=1e-6):
    """dFu/dU, dFu/dV, dFv/dV by central differences of the compiled forces."""
    E, nc = U.shape
    J = {k: np.empty((E, nc, nc)) for k in ("dFu_dU", "dFu_dV", "dFv_dV")}
    for c in range(nc):
        d = np.zeros_like(U)
        d[:, c] = h
        fp, fm = forces(U + d, V, el, jacobian=False), forces(U - d, V, el, jacobian=False)
        J["dFu_dU"][:, :, c] = (fp.Fu - fm.Fu) / (2 * h)
        fp, fm = forces(U, V + d, el, jacobian=False), forces(U, V - d, el, jacobian=False)
        J["dFu_dV"][:, :, c] = (fp.Fu - fm.Fu) / (2 * h)
        J["dFv_dV"][:, :, c] = (fp.Fv - fm.Fv) / (2 * h)
    return J


@pytest.mark.parametrize("H", [1, 5])
def test_kernel_jacobian_matches_central_differences(H):
    U, V, el = mixed_case(7, 200, H)
    f = forces(U, V, el)
    J = central_differences(U, V, el)
    worst = np.zeros(len(U))
    for k, num in J.items():
        a = getattr(f, k)
        err = np.abs(num - a).reshape(len(a), -1).max(1)
        worst = np.maximum(worst, err / np.maximum(np.abs(a).reshape(len(a), -1).max(1), 1.0))
    # all but elements at a degenerate transition (a kink within h): FD noise ~1e-9
    assert np.mean(worst < 1e-6) >= 0.97, np.sort(worst)[-5:]
    assert np.median(worst) < 1e-8


def stacked(cases):
    """One batch of single-element cases (same H): U, V, YangMenq."""
    U = np.concatenate([c[0] for c in cases])
    V = np.concatenate([c[1] for c in cases])
    p = {k: np.concatenate([getattr(c[2], k) for c in cases]) for k in ("ku", "kv", "mu", "n0")}
    return U, V, YangMenq(**p)


HARD = {
    # n = 1 + eps - cos: touches zero at tau = 0 (grazing), just crosses, just misses
    "grazing": one(U1=(0.5, 0.3), V1=(-1.0,)) + (YangMenq(1.0, 1.0, 0.4, 1.0),),
    "grazing+": one(U1=(0.5, 0.3), V1=(-1.0,)) + (YangMenq(1.0, 1.0, 0.4, 1.0 + 1e-12),),
    "grazing-": one(U1=(0.5, 0.3), V1=(-1.0,)) + (YangMenq(1.0, 1.0, 0.4, 1.0 - 1e-12),),
    # u = A cos with A = mu n/ku: max lo = min hi, stuck exactly at the onset of slip
    "onset of slip": one(U1=(0.2,)) + (YangMenq(10.0, 0.0, 0.5, 4.0),),
    "stuck, varying n": one(U1=(0.01, 0.0, 0.0, 0.005), V1=(0.01,), U0=0.3)
    + (YangMenq(2.0, 1.0, 0.5, 10.0),),
    "open": one(U1=(1.0, 0.5), V1=(0.3, 0.2)) + (YangMenq(1.0, 1.0, 0.4, -5.0),),
    "gap closes": one(U1=(0.0, 1.0), V1=(1.0,)) + (YangMenq(1.0, 1.0, 0.4, -0.5),),
    "no motion": one(U0=0.2) + (YangMenq(1.0, 1.0, 0.4, 3.0),),
    "frictionless": one(U1=(1.0, 0.2), V1=(0.5,)) + (YangMenq(1.0, 1.0, 0.0, 1.0),),
    "Jenkins, v ignored": one(U1=(1.0, 0.4, 0.1), V1=(5.0, 3.0)) + (YangMenq(3.0, 0.0, 0.5, 1.0),),
    "seam roots": one(U1=(0.0, 1.0), V1=(0.0, 1.0)) + (YangMenq(1.0, 1.0, 0.3, 0.0),),
}


@pytest.mark.parametrize("name", sorted(HARD))
def test_hard_cases_match_reference(name):
    U, V, el = HARD[name]
    f = forces(U, V, el)
    g = exact_reference.exact_forces(U, V, el)
    assert f.regimes == g.regimes
    worst = worst_differences(f, g, U, V, el)
    assert max(worst.values()) <= 1e-10, worst
    assert all(np.all(np.isfinite(getattr(f, k))) for k in ("Fu", "Fv", "dFu_dU", "dFu_dV"))


def test_hard_cases_in_one_batch_as_alone():
    # elements do not see each other: a batch gives each element's own result
    names = sorted(HARD)
    f = forces(*stacked([HARD[k] for k in names]))
    for i, k in enumerate(names):
        fi = forces(*HARD[k])
        np.testing.assert_array_equal(f.Fu[i], fi.Fu[0])
        np.testing.assert_array_equal(f.dFu_dV[i], fi.dFu_dV[0])


def test_open_and_stuck_are_closed_form():
    U, V, el = HARD["open"]
    f = forces(U, V, el)
    assert f.regimes["separated"] == 1
    assert not f.Fu.any() and not f.Fv.any() and not f.dFu_dU.any() and not f.dFv_dV.any()
    U, V, el = HARD["stuck, varying n"]
    f = forces(U, V, el)
    assert f.regimes["stuck"] == 1
    np.testing.assert_array_equal(f.Fu[0, 1:], 2.0 * U[0, 1:])
    np.testing.assert_array_equal(f.Fv[0], el.n0[0] * np.eye(7)[0] + V[0])


def test_slider_rest_matches_reference():
    U, V, el = mixed_case(3, 200, 3)
    el = YangMenq(el.ku, el.kv, el.mu, el.n0, slider_rest=np.linspace(-0.5, 0.5, 200))
    f, g = forces(U, V, el), exact_reference.exact_forces(U, V, el)
    assert f.regimes["stuck"] > 5
    assert max(worst_differences(f, g, U, V, el).values()) <= 1e-10


def test_many_harmonics():
    U, V, el = mixed_case(11, 60, 50)
    f, g = forces(U, V, el), exact_reference.exact_forces(U, V, el)
    assert f.Fu.shape == (60, 101) and f.dFu_dU.shape == (60, 101, 101)
    assert max(worst_differences(f, g, U, V, el).values()) <= 1e-10


def test_history_matches_reference():
    U, V, el = mixed_case(5, 200, 5)
    tau = np.linspace(0, TWO_PI, 301)
    h, r = history(U, V, el, tau), exact_reference.history(U, V, el, tau)
    # the same state at every instant not within 1e-9 of a transition
    near = np.zeros(h["state"].shape, bool)
    for e, tr in enumerate(r["transitions"]):
        for t, _, _ in tr:
            near[e] |= np.abs(np.mod(tau - t + np.pi, TWO_PI) - np.pi) < 1e-9
    assert np.all((h["state"] == r["state"]) | near)
    np.testing.assert_allclose(h["fu"], r["fu"], rtol=0, atol=1e-12)
    for a, b in zip(h["transitions"], r["transitions"]):
        assert [s for _, _, s in a] == [s for _, _, s in b]
        np.testing.assert_allclose([t for t, _, _ in a], [t for t, _, _ in b], atol=1e-12)


def test_one_compiled_variant_for_any_input_layout():
    from pipeline.contact.exact_integrals import forces_all
    U, V, el = mixed_case(2, 20, 3)
    f = forces(U, V, el)
    ro = U.copy()
    ro.setflags(write=False)
    for args in ((ro, V), (np.asfortranarray(U), V[:, :]), (U.astype(np.float32), V)):
        g = forces(*args, el, jacobian=False)
        np.testing.assert_allclose(g.Fu, f.Fu, rtol=0, atol=1e-6 if args[0].dtype == np.float32 else 0)
    assert len(forces_all.signatures) == 1


def test_a_second_process_loads_the_compiled_kernels():
    # cache=True: the compiled code is stored on the first compilation (about 11 s
    # here) and a new process only loads it (about 0.2 s): Numba's own count of cache
    # hits and misses says which, whatever the machine's speed
    import subprocess
    import sys
    forces(*mixed_case(0, 2, 1))  # compiled, and cached, by now
    code = ("from pipeline.bench import shroud_like_motions\n"
            "from pipeline.contact import forces\n"
            "from pipeline.contact.exact_integrals import forces_all\n"
            "forces(*shroud_like_motions(3, 2))\n"
            "s = forces_all.stats\n"
            "print(sum(s.cache_hits.values()), sum(s.cache_misses.values()))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["1", "0"], out.stdout    # loaded from the cache, not compiled
