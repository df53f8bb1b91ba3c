"""Study files whose blade is imported from exported matrices (`[scene.matrices]`).

The files are written here without CalculiX: the package's wheel blade as a deck
(`calculix_deck.write_deck`, 20-node hexahedra) and its own K and M (ElementHexS2) in
CalculiX's `.sti` / `.mas` / `.dof` layout.  A study on them runs; every mistake in
the table or the files is one line naming the study file and the field, exit 2,
nothing written."""
import re

import numpy as np
import pytest
from skfem import Basis, ElementHexS2

from pipeline.__main__ import main as cli
from pipeline.errors import UsageError
from pipeline.structure.disk import wheel_params
from pipeline.structure.exchange.calculix_deck import write_deck
from pipeline.structure.fe_model import BladeParams, DiskPlacement
from pipeline.structure.solid import assemble_elasticity, solid_mesh
from pipeline.study.datasets.dataset import read_dataset
from pipeline.study.files.documents import load_study
from helpers import STUDIES

BLADE = BladeParams(n_chord=2, n_thick=1, n_span=4)
DISK = DiskPlacement(hub_radius=0.12, sectors=36)
MATRICES = 'matrices = { format = "calculix", job = "blade", units = "SI" }'


def write_export(folder, drop_root=True, sets_kept=None):
    """The wheel blade's deck and its K, M as CalculiX writes them (root DOFs absent
    when `drop_root`)."""
    mesh, sets = solid_mesh(BLADE, DISK)
    p = wheel_params(BLADE, DISK)
    if sets_kept is not None:
        sets = {k: v for k, v in sets.items() if k in sets_kept}
    write_deck(mesh, sets, p, folder / "blade.inp")
    basis = Basis(mesh, ElementHexS2(), intorder=4)
    K, M = assemble_elasticity(basis, p.E, p.nu, p.rho)
    root = np.nonzero(np.abs(basis.doflocs[2]) < 1e-12)[0]
    keep = np.setdiff1d(np.arange(K.shape[0]),
                        (3 * root[:, None] + np.arange(3)).ravel() if drop_root else [])
    for suffix, A in ((".sti", K), (".mas", M)):
        T = A[keep][:, keep].tocoo()
        up = T.row <= T.col
        (folder / f"blade{suffix}").write_text("".join(
            f"{i + 1} {j + 1} {v:.17e}\n" for i, j, v in zip(T.row[up], T.col[up], T.data[up])))
    (folder / "blade.dof").write_text("".join(f"{k // 3 + 1}.{k % 3 + 1}\n" for k in keep))


def study_text(scene_lines):
    text = (STUDIES / "shrouded_disk.toml").read_text().split("[quick.scene.blade]")[0]
    text = text.replace("craig_bampton_modes = 20", "craig_bampton_modes = 20\n" + scene_lines)
    text = re.sub(r"\noptimum_preload = .*", "", text)
    text = text.replace("preload = [0.3, 1.0, 3.0, 10.0, 30.0]", "preload = [3.0]")
    return text.replace("harmonics = 3", "harmonics = 1").replace(
        'figures = ["amplitude", "hysteresis"]', "figures = []")


def test_a_study_on_exported_matrices_runs_and_equals_the_packages_own(tmp_path):
    write_export(tmp_path)
    (tmp_path / "imported.toml").write_text(study_text('mesh = "blade.inp"\n' + MATRICES))
    (tmp_path / "own.toml").write_text(study_text('mesh = "blade.inp"'))
    assert load_study(tmp_path / "imported.toml").scene.structure.matrices.format == "calculix"
    for name in ("imported", "own"):
        assert cli(["run", str(tmp_path / f"{name}.toml"), "--out", str(tmp_path / "out")]) == 0
    a, b = (read_dataset(tmp_path / "out" / f"{n}.nc") for n in ("imported", "own"))
    for name in ("peak_amplitude", "peak_frequency", "natural_frequency_stuck"):
        assert np.abs(a[name].values - b[name].values).max() <= 1e-8 * np.abs(b[name].values).max()


def _dof_line_dropped(folder):
    lines = (folder / "blade.dof").read_text().splitlines()
    (folder / "blade.dof").write_text("\n".join(lines[:-1]) + "\n")


def _stiffness_negated(folder):
    rows = [line.split() for line in (folder / "blade.sti").read_text().splitlines()]
    (folder / "blade.sti").write_text("".join(f"{i} {j} {-float(v)!r}\n" for i, j, v in rows))


BAD = {   # case: (scene lines, how the files are spoiled, field, message pattern)
    "no_mesh": (MATRICES, None, "scene.matrices", "need the mesh they belong to"),
    "unknown_format": ('mesh = "blade.inp"\nmatrices = { format = "nastran", job = "blade", '
                       'units = "SI" }', None, "scene.matrices.format", "must be one of"),
    "no_units": ('mesh = "blade.inp"\nmatrices = { format = "calculix", job = "blade" }', None,
                 "scene.matrices.units", "missing"),
    "bad_units": ('mesh = "blade.inp"\nmatrices = { format = "calculix", job = "blade", '
                  'units = "inch" }', None, "scene.matrices.units", "must be one of"),
    "missing_job": ('mesh = "blade.inp"\nmatrices = { format = "calculix", job = "other", '
                    'units = "SI" }', None, "scene.matrices.job", "not found"),
    "dof_map_size": ('mesh = "blade.inp"\n' + MATRICES, _dof_line_dropped, "scene.matrices",
                     r"blade\.(sti|dof).*"),
    "root_rows_kept": ('mesh = "blade.inp"\n' + MATRICES, "keep_root", "scene.matrices",
                       r"DOF map .* does not match the free DOFs.*rows of clamped DOFs"),
    "indefinite": ('mesh = "blade.inp"\n' + MATRICES, _stiffness_negated, "scene.matrices",
                   r"K is not positive definite"),
    "missing_node_set": ('mesh = "blade.inp"\n' + MATRICES, "no_excitation", "scene.mesh",
                         r"no node set 'excitation'"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_imported_blade_is_one_line_exit_2(tmp_path, case, capsys):
    lines, spoil, field, pattern = BAD[case]
    if spoil == "keep_root":
        write_export(tmp_path, drop_root=False)
    elif spoil == "no_excitation":
        write_export(tmp_path, sets_kept=("root", "shroud_left", "shroud_right", "response"))
    else:
        write_export(tmp_path)
        if spoil:
            spoil(tmp_path)
    f = tmp_path / "bad.toml"
    f.write_text(study_text(lines))
    with pytest.raises(UsageError, match=f"{re.escape(field)}: .*({pattern})"):
        load_study(f)
    assert cli(["run", str(f), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {f}: {field}: "), err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


# --------------------------------------------------------------------------- lumped scenes
EXAMPLE2 = (STUDIES / "paper_example2.toml").read_text()


def write_chain(folder, order=(0, 1)):
    """Example 2's M, C, K as Matrix Market files with a "node direction" table (DOF k
    of the study is node 10 + k, direction 2, i.e. `n1<k>.y`), rows in `order`."""
    import scipy.io
    import scipy.sparse as sp
    import tomllib

    m = tomllib.loads(EXAMPLE2)["scene"]["matrices"]
    for name, key in (("M", "M"), ("K", "K"), ("C", "C")):
        A = np.asarray(m[key], float)[np.ix_(order, order)]
        scipy.io.mmwrite(folder / f"{name}.mtx", sp.coo_matrix(A), symmetry="symmetric")
    (folder / "dofs.txt").write_text("".join(f"{10 + k} 2\n" for k in order))


def _example2_from_files(dofs_line):
    import tomllib
    doc = tomllib.loads(EXAMPLE2)
    old = doc["scene"]["dofs"]
    text = re.sub(r"(?m)^\[scene\.matrices\]\n(?:#.*\n)?(?:[A-Z] = .*\n)+", "", EXAMPLE2)
    assert "[scene.matrices]" not in text
    text = text.replace("[scene]\n", '[scene]\nmatrices = { format = "matrix_market", '
                        'stiffness = "K.mtx", mass = "M.mtx", dofs = "dofs.txt", '
                        'damping = "C.mtx", units = "SI" }\n', 1)
    text = re.sub(r'(?m)^dofs = \[.*\]\n', dofs_line, text)
    for k, name in enumerate(old):          # the study's DOF names become the file's
        text = re.sub(rf'"{name}"', f'"n1{k}.y"', text)
    return text


def test_a_lumped_scene_reads_its_matrices_from_files(tmp_path):
    """Example 2 typed and Example 2 from Matrix Market files (rows stored in the other
    order, the scene's `dofs` reorder them): the same system, bit for bit."""
    write_chain(tmp_path, order=(1, 0))
    typed = load_study(STUDIES / "paper_example2.toml")
    (tmp_path / "files.toml").write_text(_example2_from_files('dofs = ["n10.y", "n11.y"]\n'))
    files = load_study(tmp_path / "files.toml")
    a, b = typed.system({"preload": 100.0}), files.system({"preload": 100.0})
    for name in ("M", "C", "K"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert files.scene.structure.dofs == ("n10.y", "n11.y")
    # without `dofs`, the file's order and names
    (tmp_path / "auto.toml").write_text(_example2_from_files(""))
    auto = load_study(tmp_path / "auto.toml")
    assert auto.scene.structure.dofs == ("n11.y", "n10.y")


def test_a_lumped_scene_whose_dofs_miss_the_files_is_one_line(tmp_path):
    write_chain(tmp_path)
    (tmp_path / "bad.toml").write_text(_example2_from_files('dofs = ["n10.y", "n12.y"]\n'))
    with pytest.raises(UsageError, match=r"bad\.toml: scene\.dofs: must name exactly the "
                                         r"exported DOFs \(2: n10\.y, n11\.y\); unknown: n12\.y"):
        load_study(tmp_path / "bad.toml")
