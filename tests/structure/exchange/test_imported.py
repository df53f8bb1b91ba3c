"""Blades imported from another FE code (`structure.exchange.imported`).

The package's own blade written as a CalculiX deck (`calculix_deck.write_deck`), run
through `ccx` (`*FREQUENCY, SOLVER=MATRIXSTORAGE`), read back and imported: on
20-node hexahedra (C3D20 = scikit-fem's ElementHexS2, the same 27-point rule) K and
M equal the package's on the same mesh to 1e-10 and the frequencies to 1e-8; on
10-node tetrahedra K equals to 1e-10 and M equals the package's mass integrated with
CalculiX's 4-point rule (ccx under-integrates the C3D10 mass; the package integrates
it exactly).  The shrouded-disk study of the imported blade equals that of the same
mesh assembled by the package to 1e-8 (peaks, linear frequencies, static normal
loads: measured 5e-10, 2e-12, 2e-11).  Without ccx the tests skip saying why."""
import re

import numpy as np
from skfem import Basis, ElementHexS2, ElementTetP2

from pipeline.__main__ import main as cli
from pipeline.structure.exchange.imported import MatrixFiles, import_blade
from pipeline.structure.solid import assemble_elasticity, solid_from_mesh
from pipeline.study.datasets.dataset import read_dataset
from helpers import STUDIES, frequencies
from calculix import exported_blade, needs_ccx

def relative(A, B):
    return abs(A - B).max() / abs(B).max()


@needs_ccx
def test_calculix_round_trip_of_the_package_blade_on_20_node_hexahedra(tmp_path):
    mesh, sets, p = exported_blade(tmp_path)
    ours = solid_from_mesh(mesh, sets, p, element=ElementHexS2())
    theirs = import_blade(tmp_path / "blade.inp", MatrixFiles("calculix", tmp_path / "blade"),
                          p, required=tuple(sets))
    assert theirs.n_dof == ours.n_dof == 399
    assert relative(theirs.K, ours.K) < 1e-10 and relative(theirs.M, ours.M) < 1e-10
    f_ours = frequencies(ours.K.toarray(), ours.M.toarray())
    f_theirs = frequencies(theirs.K.toarray(), theirs.M.toarray())
    assert np.abs(f_theirs / f_ours - 1).max() < 1e-8
    for name, d in ours.dof_sets.items():
        np.testing.assert_array_equal(theirs.dof_sets[name], d)
    for name, f in ours.frames.items():
        g = theirs.frames[name]
        assert np.allclose(g.normal, f.normal, atol=1e-14) and np.allclose(g.weights, f.weights,
                                                                          rtol=1e-12)


@needs_ccx
def test_calculix_round_trip_on_10_node_tetrahedra(tmp_path):
    mesh, sets, p = exported_blade(tmp_path, lambda m: m.to_meshtet())
    theirs = import_blade(tmp_path / "blade.inp", MatrixFiles("calculix", tmp_path / "blade"),
                          p, required=("root",))
    ours = solid_from_mesh(mesh, {"root": sets["root"]}, p, element=ElementTetP2())
    assert relative(theirs.K, ours.K) < 1e-10
    assert relative(theirs.M, ours.M) > 0.1        # ccx's C3D10 mass: a 4-point rule
    four_point = solid_from_mesh(mesh, {"root": sets["root"]}, p, element=ElementTetP2(),
                                 matrices=lambda basis, free: assemble_elasticity(
                                     Basis(mesh, ElementTetP2(), intorder=2), p.E, p.nu, p.rho))
    assert relative(theirs.M, four_point.M) < 1e-10


def disk_study(mesh_line):
    """The shrouded-disk study at one preload, H = 1, on a given mesh."""
    text = (STUDIES / "shrouded_disk.toml").read_text().split("[quick.scene.blade]")[0]
    text = text.replace("craig_bampton_modes = 20", "craig_bampton_modes = 20\n" + mesh_line)
    text = text.replace("preload = [0.3, 1.0, 3.0, 10.0, 30.0]", "preload = [3.0]")
    text = re.sub(r"\noptimum_preload = .*", "", text)
    return text.replace("harmonics = 3", "harmonics = 1").replace(
        'figures = ["amplitude", "hysteresis"]', "figures = []")


@needs_ccx
def test_imported_blade_study_equals_the_generated_blade_on_the_same_mesh(tmp_path):
    exported_blade(tmp_path)
    (tmp_path / "generated.toml").write_text(disk_study('mesh = "blade.inp"'))
    (tmp_path / "imported.toml").write_text(disk_study(
        'mesh = "blade.inp"\nmatrices = { format = "calculix", job = "blade", units = "SI" }'))
    for name in ("generated", "imported"):
        assert cli(["run", str(tmp_path / f"{name}.toml"), "--out", str(tmp_path / "out")]) == 0
    a, b = (read_dataset(tmp_path / "out" / f"{n}.nc") for n in ("generated", "imported"))
    # the same branches; continuation places its points by step control, which a
    # round-off difference in K may tip, so what is compared is what does not depend
    # on where the points fall: the peaks (located exactly), the linear frequencies,
    # the static normal loads
    for name in ("peak_amplitude", "peak_frequency", "natural_frequency_free",
                 "natural_frequency_stuck", "static_normal_load_pair"):
        x, y = a[name].values, b[name].values
        assert np.isfinite(x).all() and np.abs(x).max() > 0, name
        assert np.abs(x - y).max() <= 1e-8 * np.abs(x).max(), name
