"""An imported blade that turns: the wheel blade written as a CalculiX deck, its
stiffness exported by ccx at rest and at 7,500 and 15,000 rpm (`*STATIC` with `CENTRIF`,
then `*FREQUENCY, PERTURBATION, SOLVER=MATRIXSTORAGE`), brought in through
`[scene.matrices]` with `[[scene.matrices.speed]]`: the Campbell study and the
interference (speed) study run on it and equal the package's own turning blade on the
same mesh (the same linearised tangent, `structure.rotation`): Campbell frequencies and
crossing speeds to 1e-7 (measured 3e-9 and 6e-9), the speed study's peaks to 1e-7
(measured 5e-9)."""
import re

import numpy as np
import pytest

from pipeline.__main__ import main as cli
from pipeline.study.datasets.dataset import read_dataset
from helpers import STUDIES
from structure.exchange.test_imported import DISK, ccx, exported_blade, needs_ccx

SPEEDS = (7500.0, 15000.0)


def export_speeds(folder):
    text = (folder / "blade.inp").read_text()
    for rpm in SPEEDS:
        w2 = (rpm * np.pi / 30) ** 2
        (folder / f"spin{int(rpm)}.inp").write_text(text[:text.index("*STEP")] + "\n".join([
            "*STEP", "*STATIC", "*DLOAD",
            f"EALL, CENTRIF, {w2:.17g}, 0., 0., {-DISK.hub_radius}, 1., 0., 0.", "*END STEP",
            "*STEP, PERTURBATION", "*FREQUENCY, SOLVER=MATRIXSTORAGE", "*END STEP", ""]))
        ccx(folder, f"spin{int(rpm)}")


MATRICES = """
[scene.matrices]
format = "calculix"
job = "blade"
units = "SI"
[[scene.matrices.speed]]
rpm = 7500.0
job = "spin7500"
[[scene.matrices.speed]]
rpm = 15000.0
job = "spin15000"
"""


def on_mesh(name, imported, edit=lambda t: t):
    """A shipped study on the deck `blade.inp`, its blade generated or imported."""
    text = (STUDIES / name).read_text().split("[quick")[0]
    text = re.sub(r"\[scene\.blade\]\n(n_\w+ = \d+\n)+", "[scene.blade]\nrho = 7850.0\n", text)
    text = text.replace("craig_bampton_modes = 20", 'craig_bampton_modes = 20\nmesh = "blade.inp"')
    return edit(text) + (MATRICES if imported else "")


@needs_ccx
def test_campbell_and_speed_studies_run_on_an_imported_turning_blade(tmp_path):
    exported_blade(tmp_path)
    export_speeds(tmp_path)
    campbell = lambda t: t.replace("count = 16", "count = 4")   # 0, 5000, 10000, 15000 rpm
    speed = lambda t: t.replace("speed = [6000.0, 7000.0, 7250.0, 8000.0]",
                                "speed = [6000.0, 8000.0]")
    for kind, name, edit in (("campbell", "shrouded_disk_campbell.toml", campbell),
                             ("speed", "shrouded_disk_speed.toml", speed)):
        for imported in (False, True):
            (tmp_path / f"{kind}_{imported}.toml").write_text(on_mesh(name, imported, edit))
            assert cli(["run", str(tmp_path / f"{kind}_{imported}.toml"), "--out",
                        str(tmp_path / "out")]) == 0
    a, b = (read_dataset(tmp_path / "out" / f"campbell_{i}.nc") for i in (False, True))
    for name in ("frequency_open", "frequency_stuck", "crossing_speed"):
        x, y = a[name].values, b[name].values
        assert np.isfinite(x).all() and np.isfinite(y).all() and x.shape == y.shape, name
        assert np.abs(y / x - 1).max() < 1e-7, name
    a, b = (read_dataset(tmp_path / "out" / f"speed_{i}.nc") for i in (False, True))
    for name in ("peak_amplitude", "peak_frequency"):
        x, y = a[name].values, b[name].values
        assert np.isfinite(x).all() and np.abs(y / x - 1).max() < 1e-7, name


def test_one_exported_speed_is_refused(tmp_path):
    (tmp_path / "blade.inp").write_text("")
    for ext in ("sti", "mas", "dof"):
        for job in ("blade", "spin7500"):
            (tmp_path / f"{job}.{ext}").write_text("")
    text = on_mesh("shrouded_disk_campbell.toml", False) + MATRICES.split(
        "[[scene.matrices.speed]]\nrpm = 15000.0")[0]
    (tmp_path / "one.toml").write_text(text)
    assert cli(["check", str(tmp_path / "one.toml")]) == 2
