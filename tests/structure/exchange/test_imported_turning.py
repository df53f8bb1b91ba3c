"""An imported blade that turns: the wheel blade written as a CalculiX deck, its
stiffness exported by ccx at rest and at 7,500 and 15,000 rpm (`*STATIC` with `CENTRIF`,
then `*FREQUENCY, PERTURBATION, SOLVER=MATRIXSTORAGE`), brought in through
`[scene.matrices]` with `[[scene.matrices.speed]]`: the Campbell study and the
interference (speed) study run on it and equal the package's own turning blade on the
same mesh (the same linearised tangent, `structure.rotation`): Campbell frequencies and
crossing speeds to 1e-7 (measured 3e-9 and 6e-9), the speed study's peaks to 1e-7
(measured 5e-9).  The same blade written in a model frame of its own (the engine axis
along Z through an offset point) and imported with that `axis` equals the disk-frame
import."""
import re

import numpy as np
import pytest

from pipeline.__main__ import main as cli
from pipeline.study.datasets.dataset import read_dataset
from helpers import STUDIES
from calculix import DISK, ccx, exported_blade, moved_deck, needs_ccx, turning_deck

SPEEDS = (7500.0, 15000.0)


def export_speeds(folder):
    for rpm in SPEEDS:
        turning_deck(folder, f"spin{int(rpm)}", rpm, DISK.hub_radius,
                     ("*FREQUENCY, SOLVER=MATRIXSTORAGE",))


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


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A folder with the deck `blade.inp` exported by ccx at rest and at SPEEDS, written
    once for the tests below (each writes its own studies and decks beside it)."""
    folder = tmp_path_factory.mktemp("turning")
    exported_blade(folder)
    export_speeds(folder)
    return folder


@needs_ccx
def test_campbell_and_speed_studies_run_on_an_imported_turning_blade(exported):
    tmp_path = exported
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


# The same blade in a model whose engine axis is its own: along Z through an offset
# point, the blade's radial line at 40 deg in the XY plane (x_model = Q x + b).
POINT, DIRECTION = np.array([0.03, -0.02, 0.05]), np.array([0.0, 0.0, 1.0])
RADIAL = np.array([np.cos(0.7), np.sin(0.7), 0.0])
Q = np.column_stack([DIRECTION, np.cross(RADIAL, DIRECTION), RADIAL])   # disk -> model
B = POINT - Q @ np.array([0.0, 0.0, -DISK.hub_radius])
AXIS = "axis = {{ point = [{}, {}, {}], direction = [{}, {}, {}] }}\n".format(
    *(float(v) for v in (*POINT, *DIRECTION)))


def export_moved(folder):
    """blade_z.inp, the deck `blade.inp` in the model frame, exported by ccx at rest and
    at SPEEDS turning about the model's axis."""
    moved_deck(folder, "blade", "blade_z", Q, B)
    ccx(folder, "blade_z")
    for rpm in SPEEDS:
        turning_deck(folder, f"spin_z{int(rpm)}", rpm, None, ("*FREQUENCY, SOLVER=MATRIXSTORAGE",),
                     deck="blade_z", axis=(POINT, DIRECTION))


def in_model_frame(text, axis=True):
    """A study on blade_z.inp: its matrices, with the model's engine axis or without."""
    text = text.replace('mesh = "blade.inp"', 'mesh = "blade_z.inp"')
    text = re.sub(r'job = "(blade|spin)', r'job = "\1_z', text)
    return text.replace('units = "SI"\n', 'units = "SI"\n' + AXIS) if axis else text


@needs_ccx
def test_a_blade_in_its_own_engine_frame_equals_the_disk_frame_import(exported, capsys):
    """Campbell frequencies and crossings, and the speed study's peaks, of the blade
    exported in the model frame and imported with its axis equal the disk-frame
    export's to 1e-7 (the same blade: only ccx's rounding of the exported matrices to 14
    digits differs; measured 7e-9 here, and rounding K's entries at the 14th digit alone
    moves the lowest frequency by 1e-9 to 2.5e-8, so another ccx build may reach that);
    without the axis the blade sits askew in the disk
    and its shroud faces do not pair: refused."""
    tmp_path = exported
    export_moved(tmp_path)
    campbell = lambda t: t.replace("count = 16", "count = 3").replace(
        "engine_orders = [1, 2, 3, 4, 5, 6]", "engine_orders = [3]\nnodal_diameters = [0, 3]")
    speed = lambda t: t.replace("speed = [6000.0, 7000.0, 7250.0, 8000.0]", "speed = [8000.0]")
    for kind, name, edit in (("campbell", "shrouded_disk_campbell.toml", campbell),
                             ("speed", "shrouded_disk_speed.toml", speed)):
        disk = on_mesh(name, True, edit)
        for frame, text in (("disk", disk), ("model", in_model_frame(disk))):
            (tmp_path / f"{kind}_{frame}.toml").write_text(text)
            assert cli(["run", str(tmp_path / f"{kind}_{frame}.toml"), "--out",
                        str(tmp_path / "out")]) == 0
    a, b = (read_dataset(tmp_path / "out" / f"campbell_{f}.nc") for f in ("disk", "model"))
    for name in ("frequency_open", "frequency_stuck", "crossing_speed"):
        x, y = a[name].values, b[name].values
        assert np.isfinite(x).all() and x.shape == y.shape and x.size > 0, name
        assert np.abs(y / x - 1).max() < 1e-7, name
    a, b = (read_dataset(tmp_path / "out" / f"speed_{f}.nc") for f in ("disk", "model"))
    for name in ("peak_amplitude", "peak_frequency"):
        x, y = a[name].values, b[name].values
        assert np.isfinite(x).all() and np.abs(y / x - 1).max() < 1e-7, name
    (tmp_path / "askew.toml").write_text(in_model_frame(on_mesh(
        "shrouded_disk_speed.toml", True, speed), axis=False))
    capsys.readouterr()
    assert cli(["check", str(tmp_path / "askew.toml")]) == 2
    err = capsys.readouterr().err
    assert "scene.mesh: shroud faces do not pair" in err and err.count("\n") == 1, err
