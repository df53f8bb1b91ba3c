"""Stiffness mistuning of Craig-Bampton-reduced FE blades: scaling the reduced
stiffness by f (what `cyclic.full_assembly` does with `stiffness_factors`) is the
reduction of the blade with Young's modulus f E, to rounding.

Why: K(f E) = f K(E), M unchanged.  The constraint modes -K_ii^-1 K_ib do not change,
the fixed-interface modes keep their M_ii-normalised shapes with eigenvalues f w^2,
so the CB basis T is the same and T^T K(f E) T = f K_r, T^T M T = M_r.  Only the sign
of each fixed-interface mode is the eigen-solver's choice: the two reductions are
compared after aligning the signs (S = diag(1_b, s_k), s_k the sign of
Phi_k(E) . Phi_k(f E)), and by invariants that need no alignment (eigenvalues of the
reduced pencil, the boundary block K_bb + K_bi Psi).  Modal damping is defined by
ratios on the reduced modes, so the directly reduced blade has C_r(f E) = sqrt(f) C_r(E);
the mistuned assembly keeps C_r(E) (C is not scaled)."""
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as la

from pipeline.model.scene import Blade, CraigBampton, Cyclic, Mistuning, Scene
from pipeline.model.build import full_system, sector, stiffness_factors
from pipeline.model.system import natural_frequencies
from pipeline.structure.blades import build_blade
from pipeline.structure.fe_model import BladeParams
from pipeline.structure.reduction import reduce_blade

PARAMS = BladeParams(n_chord=2, n_thick=1, n_span=4)
MODES = 6


def reduced(f):
    """The blade reduced with Young's modulus f E (E = 210 GPa)."""
    return reduce_blade(build_blade(replace(PARAMS, E=f * PARAMS.E)), MODES)


def rel(a, b):
    return np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max()


@pytest.mark.parametrize("f", [0.95, 1.07])
def test_reduced_blade_with_scaled_modulus_is_the_scaled_reduction(f):
    """K_r(f E) = f K_r(E) and M_r(f E) = M_r(E) to 1e-10 after aligning the mode signs;
    the same basis (constraint modes equal, fixed-interface modes equal up to sign);
    invariants without alignment; C_r(f E) = sqrt(f) C_r(E) (modal damping ratios)."""
    a, b = reduced(1.0), reduced(f)
    nb = a.n_boundary
    assert (a.boundary == b.boundary).all() and a.n_modes == b.n_modes == MODES
    assert rel(b.Psi, a.Psi) < 1e-10
    s = np.sign(np.einsum("ik,ik->k", a.Phi, b.Phi))
    assert rel(b.Phi * s, a.Phi) < 1e-10
    S = np.concatenate([np.ones(nb), s])
    assert rel(S[:, None] * b.K * S, f * a.K) < 1e-10
    assert rel(S[:, None] * b.M * S, a.M) < 1e-10
    assert rel(S[:, None] * b.C * S, np.sqrt(f) * a.C) < 1e-10
    # no alignment needed: boundary stiffness block and the pencil's eigenvalues
    assert rel(b.K[:nb, :nb], f * a.K[:nb, :nb]) < 1e-10
    assert rel(la.eigh(b.K, b.M, eigvals_only=True), f * la.eigh(a.K, a.M, eigvals_only=True)) \
        < 1e-10
    np.testing.assert_allclose(b.fixed_frequencies, np.sqrt(f) * a.fixed_frequencies, rtol=1e-10)


def test_mistuned_reduced_sectors_have_the_directly_reduced_blades_frequencies():
    """Three uncoupled CB sectors with factors f_j: the assembly's open natural
    frequencies are those of the three blades reduced with f_j E, to 1e-10."""
    f = (0.95, 1.0, 1.07)
    scene = Scene(Blade(PARAMS), reduction=CraigBampton(MODES),
                  assembly=Cyclic(3, 1, Mistuning(factors=f)), model="solid_blade")
    np.testing.assert_array_equal(stiffness_factors(scene, {}), f)
    s = full_system(scene, {})
    assert s.n_dof == 3 * sector(scene, {}).n_dof
    ref = np.sort(np.concatenate([2 * np.pi * reduced(fj).frequencies for fj in f]))
    assert rel(natural_frequencies(s, "open"), ref) < 1e-10
