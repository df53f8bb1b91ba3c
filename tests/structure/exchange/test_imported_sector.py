"""A blade on its disk sector as a designer exports it: the shipped CalculiX deck
(meshes/bladed_disk_sector.inp: C3D20 cells, cyclic cut faces, shroud faces meshed
differently) read as a mesh and, through ccx's exported K and M, as matrices.  Without
ccx the matrices test skips saying why."""
import importlib.util
import shutil

import numpy as np

from pipeline.__main__ import main as cli
from pipeline.structure.disk import pairing
from pipeline.structure.blades import load_blade
from pipeline.structure.mesh_io import read_volume
from pipeline.study.datasets.dataset import read_dataset

from calculix import ccx, needs_ccx
from helpers import STUDIES

MESHES = STUDIES.parent / "meshes"


def generator():
    """meshes/bladed_disk_sector.py as a module."""
    spec = importlib.util.spec_from_file_location("bladed_disk_sector",
                                                  MESHES / "bladed_disk_sector.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_shipped_deck_is_its_script_and_its_shroud_faces_do_not_match(tmp_path):
    """The deck equals what its script writes (every node to 1e-15 m, the same cells and
    sets); read back, its cut faces and shroud faces are the sector's, and no right-face
    point turned back by the pitch lands on a left-face point: every pairing row but
    the face's outline interpolates on a left facet (8 nodes)."""
    mod = generator()
    ours = read_volume(mod.write(tmp_path), ("root", "cyclic_low", "cyclic_high"))
    shipped = read_volume(MESHES / "bladed_disk_sector.inp", ("root", "cyclic_low"))
    assert np.abs(ours.mesh.p - shipped.mesh.p).max() < 1e-15
    assert np.array_equal(ours.mesh.t, shipped.mesh.t)
    assert {k: v.tolist() for k, v in ours.node_sets.items()} == {
        k: v.tolist() for k, v in shipped.node_sets.items()}
    blade = load_blade(MESHES / "bladed_disk_sector.inp", mod.wheel_params(mod.BLADE, mod.DISK))
    R, L = blade.frames["shroud_right"], blade.frames["shroud_left"]
    W = pairing(R.points, L.points, mod.DISK, L.facets)
    interpolated = np.diff(W.indptr) > 1
    assert interpolated.sum() >= len(R.points) // 2 and W.indices.size > W.shape[0]
    np.testing.assert_allclose(np.asarray(W.sum(axis=1)).ravel(), 1.0, rtol=1e-12)
    assert {"cyclic_low", "cyclic_high"} <= set(blade.dof_sets)


@needs_ccx
def test_the_sector_through_exported_matrices_equals_the_mesh_route(tmp_path):
    """ccx's K and M of the shipped deck (`*FREQUENCY, SOLVER=MATRIXSTORAGE`, the bore
    clamped) through `[scene.matrices]`: the frequency - nodal diameter diagram of the
    flexible disk sector (open and stuck, 19 ND x 4 families) equals the package's own
    C3D20 assembly of the same deck to 1e-7 (measured 1.9e-8 on the first family, whose
    eigenvalue is the most sensitive to the matrices' last digits; 5e-10 on the others)."""
    shutil.copy(MESHES / "bladed_disk_sector.inp", tmp_path / "sector.inp")
    ccx(tmp_path, "sector")
    text = (STUDIES / "bladed_disk_sector_modes.toml").read_text().replace(
        'mesh = "../meshes/bladed_disk_sector.inp"', 'mesh = "sector.inp"')
    (tmp_path / "mesh.toml").write_text(text)
    (tmp_path / "matrices.toml").write_text(text.replace(
        'mesh = "sector.inp"',
        'mesh = "sector.inp"\nmatrices = { format = "calculix", job = "sector", units = "SI" }'))
    for name in ("mesh", "matrices"):
        assert cli(["run", str(tmp_path / f"{name}.toml"), "--out", str(tmp_path / "out"),
                    "--no-figures"]) == 0
    a, b = (read_dataset(tmp_path / "out" / f"{n}.nc") for n in ("mesh", "matrices"))
    for name in ("frequency_open", "frequency_stuck"):
        x, y = a[name].values, b[name].values
        assert x.shape == (19, 4) and np.abs(x / y - 1).max() < 1e-7, name
