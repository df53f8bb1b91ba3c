"""Modes of a tuned disk per nodal diameter (`[study] kind = "modes"` on a disk
scene): the study file's keys and their errors.  The Laxalde et al. (2007) lumped disk
study's run against the closed form of its cyclic eigenproblem is in
test_shipped_studies.py."""
from pathlib import Path

import pytest

from pipeline.errors import UsageError
from pipeline.study.files.documents import parse_study

STUDY = Path(__file__).resolve().parents[3] / "studies" / "disk_laxalde.toml"
def test_modes_subset_of_nodal_diameters_and_frequencies():
    text = STUDY.read_text().replace("n_frequencies = 3", "n_frequencies = 2\n"
                                     "nodal_diameters = [3, 12]")
    s = parse_study(text, file="lax.toml")
    assert s.nodal_diameters == (3, 12) and s.n_frequencies == 2


@pytest.mark.parametrize("edit,field", [
    (lambda t: t.split("[[scene.contact]]")[0] + "[modes]\n",
     "scene.contact"),
    (lambda t: t.replace('"disk_coupling"]', ']').replace(', ]', ']'), "scene.effects"),
    (lambda t: t.replace("n_frequencies = 3", "n_frequencies = 4"), "modes.n_frequencies"),
    (lambda t: t.replace("n_frequencies = 3", "nodal_diameters = [0, 13]"),
     "modes.nodal_diameters[1]"),
    (lambda t: t.replace('elongation = ["next.xd", "-xd"]', 'elongation = ["xd"]'),
     "scene.disk.spring[0].elongation"),
    (lambda t: t.replace("k = 5e7", "k = -5e7"), "scene.disk.spring[0].k"),
])
def test_bad_disk_modes_studies_name_the_field(edit, field):
    with pytest.raises(UsageError) as e:
        parse_study(edit(STUDY.read_text()), file="lax.toml")
    assert str(e.value).startswith(f"lax.toml: {field}: "), str(e.value)


def test_check_describes_a_disk_modes_study(capsys):
    from pipeline.study.files.check import check
    assert check(str(STUDY)) == 0
    out = capsys.readouterr().out
    assert "valid disk_modes study" in out and "24 sectors" in out and "26 sector eigen" in out


def test_mode_shapes_solve_the_assembled_wheel_and_are_written_on_the_blade(tmp_path):
    """The disk modes study's shapes on an FE wheel (6 sectors, contacts stuck): each
    sector shape x at nodal diameter ND, repeated around the wheel as x e^{i j psi}
    (psi = 2 pi ND / N), is an eigenvector of the explicitly assembled stuck wheel at the
    sector's frequency (residual below 1e-12 of |K| |q|, the eigen-solver's backward
    error; repeated with the phase of ND + 1 it is far from one); open shapes at ND 0
    are real; the
    dataset holds them at the physical DOFs, scaled to max |x| = 1; the VTU holds each
    shape on the blade mesh."""
    import meshio
    import numpy as np
    import scipy.linalg as la

    from helpers import stuck_stiffness
    from pipeline import run_study
    from pipeline.model.build import full_system
    from pipeline.model.contacts import ShroudPair
    from pipeline.model.scene import Blade, CraigBampton, Cyclic, Scene
    from pipeline.model.system import dense
    from pipeline.structure.fe_model import BladeParams, DiskPlacement
    from pipeline.study.execution.disk_modes_study import (DiskModesStudy,
                                                           nodal_diameter_frequencies)

    disk = DiskPlacement(hub_radius=0.05, sectors=6)
    scene = Scene(Blade(BladeParams(n_chord=2, n_thick=1, n_span=4), disk=disk),
                  contacts=(ShroudPair("shroud", ku=1e5, kv=1e5, mu=0.3, n0=None),),
                  assembly=Cyclic(6, 0), reduction=CraigBampton(4),
                  effects=("friction", "normal_load_variation", "separation", "cyclic_coupling"))
    nds = (0, 1, 2, 3)
    res = nodal_diameter_frequencies(scene, nds, 3)
    wheel = full_system(scene, {"preload": 10.0})             # every pair closed: stuck = tied
    K, M = stuck_stiffness(wheel), dense(wheel.M)
    scale = la.norm(K)
    for i, nd in enumerate(nds):
        for j in range(3):
            x = res["shape_stuck"][i][:, j]
            w = 2 * np.pi * res["stuck"][i, j]
            for k, small in ((nd, True), (nd + 1, False)):
                q = np.concatenate([x * np.exp(2j * np.pi * k * s / 6) for s in range(6)])
                r = la.norm(K @ q - w**2 * (M @ q)) / (scale * la.norm(q))
                assert (r < 1e-12) if small else (r > 1e-8), (nd, j, k, r)   # measured 7e-14, 1.6e-7
    assert np.abs(res["shape_open"][0].imag).max() == 0.0
    study = DiskModesStudy(file="wheel.toml", name="wheel", title="wheel", description="",
                           reference="", text="", scene=scene, nodal_diameters=nds,
                           n_frequencies=3)
    out = run_study(study, tmp_path, figures=False)
    ds = out.dataset
    shape = ds["mode_shape_stuck"].sel(component="real") + 1j * ds["mode_shape_stuck"].sel(
        component="imag")
    assert not any(str(d).startswith("mode.") for d in ds["dof"].values)
    np.testing.assert_allclose(np.abs(shape).max(dim="dof"), 1.0, rtol=1e-12)
    vtu = meshio.read(tmp_path / "wheel" / "mode_shapes.vtu")
    assert {f"{m}_nd{nd}_mode{j}_{part}" for m in ("open", "stuck") for nd in nds
            for j in (1, 2, 3) for part in ("re", "im", "abs")} <= set(vtu.point_data)
