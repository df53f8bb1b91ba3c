"""Study files whose blade is imported from exported matrices (`[scene.matrices]`).

The files are written here without CalculiX: the package's wheel blade as a deck
(`calculix_deck.write_deck`, 20-node hexahedra) and its own K and M (ElementHexS2) in
CalculiX's `.sti` / `.mas` / `.dof` layout.  A study on them runs; every mistake in
the table or the files is one line naming the study file and the field, exit 2,
nothing written: the files checked against each other and against the mesh (the
mass M weighs against the mesh's volume, a file cut short, lengths in millimetres),
set names ignoring case, decks with `*INCLUDE` files."""
import re

import numpy as np
import pytest
from skfem import Basis, ElementHexS2

from pipeline.__main__ import main as cli
from pipeline.errors import UsageError
from pipeline.model.blade_cache import blade_model
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


EXPORT_FILES = ("blade.inp", "blade.sti", "blade.mas", "blade.dof")
_default_export = {}     # the files and result of write_export(folder): made once


def write_export(folder, drop_root=True, sets_kept=None, mm=False, frame=None):
    """The wheel blade's deck and its K, M as CalculiX writes them (the upper triangle
    column by column; root DOFs absent when `drop_root`); `mm`: in N/mm, tonnes and mm;
    `frame` (Q, b): the blade moved to Q x + b [m], K and M assembled there.
    Returns the package's full K, M (root DOFs kept, SI units) and the DOFs written.
    The default export, which most tests write, is assembled once and its files copied."""
    default = drop_root and sets_kept is None and not mm and frame is None
    if default and _default_export:
        for name, text in _default_export["files"].items():
            (folder / name).write_text(text)
        return _default_export["result"]
    result = assembled_export(folder, drop_root, sets_kept, mm, frame)
    if default:
        _default_export["files"] = {name: (folder / name).read_text() for name in EXPORT_FILES}
        _default_export["result"] = result
    return result


def assembled_export(folder, drop_root, sets_kept, mm, frame):
    """`write_export`, assembled and written."""
    mesh, sets = solid_mesh(BLADE, DISK)
    root = np.nonzero(np.abs(Basis(mesh, ElementHexS2()).doflocs[2]) < 1e-12)[0]
    if frame is not None:
        mesh = type(mesh)(frame[0] @ mesh.p + frame[1][:, None], mesh.t)
    p = wheel_params(BLADE, DISK)
    if sets_kept is not None:
        sets = {k: v for k, v in sets.items() if k in sets_kept}
    write_deck(mesh.scaled(1e3) if mm else mesh, sets, p, folder / "blade.inp")
    basis = Basis(mesh, ElementHexS2(), intorder=4)
    K, M = assemble_elasticity(basis, p.E, p.nu, p.rho)
    keep = np.setdiff1d(np.arange(K.shape[0]),
                        (3 * root[:, None] + np.arange(3)).ravel() if drop_root else [])
    for suffix, A in ((".sti", K), (".mas", M)):
        T = (A[keep][:, keep] / (1e3 if mm else 1.0)).tocoo()
        up = np.nonzero(T.row <= T.col)[0]
        up = up[np.lexsort((T.row[up], T.col[up]))]     # ccx's order: column by column
        (folder / f"blade{suffix}").write_text("".join(
            f"{i + 1} {j + 1} {v:.17e}\n" for i, j, v in zip(T.row[up], T.col[up], T.data[up])))
    (folder / "blade.dof").write_text("".join(f"{k // 3 + 1}.{k % 3 + 1}\n" for k in keep))
    return K, M, keep


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
    assert refused(f, field, pattern, capsys)


def refused(f, field, pattern, capsys) -> str:
    """The one error line of study `f` (load and `run`: exit 2, nothing written), which
    must name `field` and match `pattern`."""
    out = f.parent / "out"
    with pytest.raises(UsageError, match=f"{re.escape(field)}: .*({pattern})"):
        load_study(f)
    assert cli(["run", str(f), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {f}: {field}: "), err
    assert not out.exists() or not any(out.iterdir())
    return err[0]


# ------------------------------------------------------- the files against the mesh
SCENE = 'mesh = "blade.inp"\n' + MATRICES
DENSITY = r"density (\S+) kg/m\^3"


def blade_of(folder, scene_lines=SCENE, name="s"):
    """The blade of a study on the files in `folder`."""
    (folder / f"{name}.toml").write_text(study_text(scene_lines))
    return blade_model(load_study(folder / f"{name}.toml").scene.structure)


def same_blade(a, b):
    assert (a.K != b.K).nnz == 0 and (a.M != b.M).nnz == 0
    assert a.dof_sets.keys() == b.dof_sets.keys() and a.frames.keys() == b.frames.keys()
    for name, d in a.dof_sets.items():
        np.testing.assert_array_equal(b.dof_sets[name], d)
    for name, f in a.frames.items():
        np.testing.assert_array_equal(b.frames[name].weights, f.weights)


def test_swapped_stiffness_and_mass_files_are_refused_by_their_mass(tmp_path, capsys):
    """.sti and .mas exchanged load without complaint otherwise (both are positive
    definite; the frequencies come out 1e-5 Hz).  The "mass" the message names is the
    hand sum of the .mas file over its x rows (both triangles), the volume the
    package's full M summed over the x DOFs over rho: they agree to the 3 digits
    printed."""
    _, M, keep = write_export(tmp_path)
    sti, mas = tmp_path / "blade.sti", tmp_path / "blade.mas"
    text = sti.read_text()
    sti.write_text(mas.read_text())
    mas.write_text(text)
    (tmp_path / "swapped.toml").write_text(study_text(SCENE))
    line = refused(tmp_path / "swapped.toml", "scene.matrices",
                   r"blade\.mas: mass .* kg \(translation along x\) .*: likely K and M "
                   r"swapped", capsys)
    i, j, v = np.loadtxt(mas, unpack=True)
    x = (keep[i.astype(int) - 1] % 3 == 0) & (keep[j.astype(int) - 1] % 3 == 0)
    m = v[x].sum() + v[x & (i != j)].sum()
    r = np.zeros(M.shape[0])
    r[0::3] = 1.0
    volume = r @ M @ r / wheel_params(BLADE, DISK).rho
    got = re.search(r"mass (\S+) kg .* volume of (\S+) m\^3 .*" + DENSITY, line)
    assert m > 1e8 and volume == pytest.approx(1.623e-5, rel=1e-3)
    for value, want in zip(got.groups(), (m, volume, m / volume)):
        assert float(value) == pytest.approx(want, rel=5e-3)


def test_the_blades_rho_is_what_the_imported_mass_must_weigh(tmp_path, capsys):
    """The steel blade's matrices (7850 kg/m^3) with [scene.blade] rho = 4430 kg/m^3
    (titanium): refused, naming the density the free DOFs' translation mass implies
    (by hand: r^T M r over the written rows / the volume, 7560 kg/m^3: the clamped
    root's share is missing); rho = 7850 kg/m^3 loads, and M is the file's."""
    _, M, keep = write_export(tmp_path)
    r = np.zeros(M.shape[0])
    r[0::3] = 1.0
    free = r[keep] @ M[keep][:, keep] @ r[keep]
    implied = free / (r @ M @ r / wheel_params(BLADE, DISK).rho)
    assert implied == pytest.approx(7560, rel=1e-3)
    (tmp_path / "ti.toml").write_text(study_text(SCENE).replace(
        "n_span = 8\n", "n_span = 8\nrho = 4430.0\n", 1))
    line = refused(tmp_path / "ti.toml", "scene.matrices",
                   "where the blade's density is 4430 kg/m\\^3: likely a stale file", capsys)
    assert float(re.search(DENSITY, line).group(1)) == pytest.approx(implied, rel=5e-3)
    steel = blade_of(tmp_path, SCENE, "steel")
    assert abs(steel.M - M[keep][:, keep]).max() <= 1e-14 * abs(M).max()


@pytest.mark.parametrize("key, value", [("E", "2.1e11"), ("nu", "0.3")])
def test_stiffness_material_given_with_matrices_is_refused(tmp_path, capsys, key, value):
    write_export(tmp_path)
    (tmp_path / "bad.toml").write_text(study_text(SCENE).replace(
        "n_span = 8\n", f"n_span = 8\n{key} = {value}\n", 1))
    refused(tmp_path / "bad.toml", f"scene.blade.{key}",
            r"unused with scene\.matrices \(the exported K holds the stiffness\)", capsys)


def test_a_truncated_stiffness_file_is_named_so(tmp_path, capsys):
    """The first 3/5 of the .sti lines (CalculiX writes the upper triangle column by
    column, so the last columns are missing): named at its last line and its last
    row, not as a K that is not positive definite."""
    write_export(tmp_path)
    sti = tmp_path / "blade.sti"
    lines = sti.read_text().splitlines(keepends=True)
    kept = lines[:len(lines) * 3 // 5]
    sti.write_text("".join(kept))
    last = max(max(int(a), int(b)) for a, b, _ in (x.split() for x in kept))
    assert last < 399
    (tmp_path / "cut.toml").write_text(study_text(SCENE))
    refused(tmp_path / "cut.toml", "scene.matrices",
            rf"blade\.sti: ends at line {len(kept)}: its last row is {last}, but "
            rf"\S*blade\.dof maps 399 rows: truncated\?", capsys)


def test_a_deck_in_millimetres_read_as_si_is_named_a_unit_mistake(tmp_path, capsys):
    """The deck in mm (and K, M in N/mm and tonnes) without units = "mm": refused,
    naming the span (the package mesh's largest extent x 1000) and the cure, on the
    matrices' route and on the mesh's; with units = "mm" the blade equals the SI
    export's to 1e-12, on the matrices' route ([scene.matrices] units) and on the
    mesh's ([scene] units; with matrices that key is refused: theirs says it)."""
    write_export(tmp_path, mm=True)
    mesh, _ = solid_mesh(BLADE, DISK)
    span = 1e3 * np.ptp(mesh.p, axis=1).max()
    (tmp_path / "mm.toml").write_text(study_text(SCENE))
    refused(tmp_path / "mm.toml", "scene.matrices",
            rf'coordinates span {span:.3g} m.*a mesh in millimetres\? set \[scene\.matrices\] '
            r'units = "mm"', capsys)
    (tmp_path / "mesh.toml").write_text(study_text('mesh = "blade.inp"'))
    refused(tmp_path / "mesh.toml", "scene.mesh",
            rf"coordinates span {span:.3g} m.*a mesh in millimetres\?", capsys)
    mm = blade_of(tmp_path, SCENE.replace('"SI"', '"mm"'))
    (tmp_path / "si").mkdir()
    write_export(tmp_path / "si")
    si = blade_of(tmp_path / "si")
    assert abs(mm.K - si.K).max() <= 1e-12 * abs(si.K).max()
    assert abs(mm.M - si.M).max() <= 1e-12 * abs(si.M).max()
    # the mesh route reads it with [scene] units = "mm": the SI mesh's blade, its own
    # K and M, faces and frames (coordinates 1e-3 x the file's)
    on_mm = blade_of(tmp_path, 'mesh = "blade.inp"\nunits = "mm"', name="mesh_mm")
    on_si = blade_of(tmp_path / "si", 'mesh = "blade.inp"', name="mesh_si")
    assert abs(on_mm.K - on_si.K).max() <= 1e-12 * abs(on_si.K).max()
    assert abs(on_mm.M - on_si.M).max() <= 1e-12 * abs(on_si.M).max()
    for name, f in on_si.frames.items():
        np.testing.assert_allclose(on_mm.frames[name].points, f.points, rtol=0, atol=1e-15)
    (tmp_path / "both_units.toml").write_text(study_text(SCENE + '\nunits = "mm"'))
    refused(tmp_path / "both_units.toml", "scene.units", "with scene.matrices", capsys)


def test_a_deck_in_its_own_engine_frame_imports_as_the_disk_frames(tmp_path, capsys):
    """The blade written with its engine axis along Z through (30, -20, 50) mm, its
    radial line at 0.7 rad in XY, in mm, K and M assembled there: with that `axis` (in
    mm) its blade equals the disk-frame export's -- K and M to 1e-12 of their largest
    entry (measured 3e-15, 4e-15), the face points to 1e-15 m (6e-17 m), normals and
    tangents to 1e-14 (7e-16); with the direction reversed the right face faces the
    blade before, refused saying so."""
    axis, radial = np.array([0.0, 0.0, 1.0]), np.array([np.cos(0.7), np.sin(0.7), 0.0])
    Q = np.column_stack([axis, np.cross(radial, axis), radial])     # disk -> model
    point = np.array([0.03, -0.02, 0.05])
    write_export(tmp_path, mm=True, frame=(Q, point - Q @ DISK.centre))
    axis_of = ('units = "mm", axis = {{ point = [30.0, -20.0, 50.0], '
               'direction = [0.0, 0.0, {}] }}').format
    model = blade_of(tmp_path, SCENE.replace('units = "SI"', axis_of("1.0")))
    (tmp_path / "si").mkdir()
    write_export(tmp_path / "si")
    disk = blade_of(tmp_path / "si")
    assert abs(model.K - disk.K).max() <= 1e-12 * abs(disk.K).max()
    assert abs(model.M - disk.M).max() <= 1e-12 * abs(disk.M).max()
    for name, f in disk.frames.items():
        g = model.frames[name]
        np.testing.assert_allclose(g.points, f.points, rtol=0, atol=1e-15)
        for v in ("normal", "tangent", "tangent2"):
            np.testing.assert_allclose(getattr(g, v), getattr(f, v), rtol=0, atol=1e-14)
    for name, d in disk.dof_sets.items():
        np.testing.assert_array_equal(model.dof_sets[name], d)
    (tmp_path / "reversed.toml").write_text(study_text(
        SCENE.replace('units = "SI"', axis_of("-1.0"))))
    refused(tmp_path / "reversed.toml", "scene.matrices",
            "faces the blade before.*reverse the axis direction", capsys)


SET_NAMES = ("root", "shroud_left", "shroud_right", "excitation", "response")


def test_upper_case_set_names_are_the_required_sets(tmp_path, capsys):
    """ROOT, SHROUD_LEFT, ... (as pre-processors write them): the same blade as the
    lower-case deck; two sets whose names differ only in case: refused, naming both."""
    write_export(tmp_path)
    lower = blade_of(tmp_path)
    deck = tmp_path / "blade.inp"
    text = deck.read_text()
    for name in SET_NAMES:
        text = text.replace(f"NSET={name}\n", f"NSET={name.upper()}\n")
    assert "NSET=root" not in text and "NSET=SHROUD_LEFT" in text
    (tmp_path / "upper").mkdir()
    (tmp_path / "upper" / "blade.inp").write_text(text)
    for suffix in (".sti", ".mas", ".dof"):
        (tmp_path / "upper" / f"blade{suffix}").write_text(
            (tmp_path / f"blade{suffix}").read_text())
    same_blade(lower, blade_of(tmp_path / "upper"))
    deck.write_text(text.replace("*MATERIAL", "*NSET, NSET=Root\n1\n*MATERIAL"))
    (tmp_path / "both.toml").write_text(study_text(SCENE))
    refused(tmp_path / "both.toml", "scene.mesh",
            r"node sets 'ROOT' and 'Root' differ only in case", capsys)


def test_a_deck_with_include_files_reads_as_the_flat_deck(tmp_path, capsys):
    """The deck's nodes and node sets moved to included files (parts/nodes.inp;
    parts/sets.inp, which includes response.inp beside it): the blade of the flat
    deck, node numbers and all; a missing include: one line naming it and the file
    that includes it."""
    write_export(tmp_path)
    flat = blade_of(tmp_path)
    text = (tmp_path / "blade.inp").read_text()
    head, rest = text.split("*NODE", 1)
    nodes, rest = rest.split("*ELEMENT", 1)
    elements, rest = rest.split("*NSET", 1)
    sets, rest = rest.split("*MATERIAL", 1)
    sets, response = sets.split("*NSET, NSET=response")
    parts = tmp_path / "parts"
    parts.mkdir()
    (parts / "nodes.inp").write_text("*NODE" + nodes)
    (parts / "sets.inp").write_text("*NSET" + sets + "*Include, input = response.inp\n")
    (parts / "response.inp").write_text("*NSET, NSET=response" + response)
    (tmp_path / "blade.inp").write_text(head + "*INCLUDE, INPUT=parts/nodes.inp\n*ELEMENT"
                                        + elements + "*INCLUDE, INPUT=parts/sets.inp\n"
                                        "*MATERIAL" + rest)
    same_blade(flat, blade_of(tmp_path, name="included"))
    (parts / "response.inp").unlink()
    (tmp_path / "missing.toml").write_text(study_text(SCENE))
    refused(tmp_path / "missing.toml", "scene.mesh",
            r"parts/sets\.inp: \*INCLUDE, INPUT=response\.inp: no such file \S*parts/"
            r"response\.inp", capsys)


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
