"""A 1D shroud pair whose faces move along the in-plane direction it leaves free
(b = n x t) is warned about (`datasets.free_direction`), its two amplitudes checked
against the unreduced blade's linear response projected by hand.

The quick solid blade of the shrouded disk at engine order 0: every blade flaps in
phase, so the neighbours' faces differ only by the pitch rotation and slide mostly
radially past each other, across the circumferential slip direction of a default 1D
pair.  The pair's springs are negligible (1e-3 N/m against the blade's ~1e5 N/m), so
the solution at the peak is the clamped blade's linear response there: solved on the
unreduced FE blade, the left face's partner of each right-face node found by the
rotation about the disk axis, its displacement turned by the pitch, and projected on
t (the circumferential direction at the face centre, projected into the face) and
b = n x t (n from the face's points)."""
import re

import numpy as np
import pytest
import scipy.sparse.linalg as spla
import xarray as xr

from pipeline.__main__ import main as cli
from pipeline.model.build import blade_forcing
from pipeline.model.blade_cache import blade_model
from pipeline.study.files.documents import load_study

R, N = 0.12, 36                # hub radius [m], sectors
STUDY = f"""
[study]
title = "1D shroud pair at engine order 0: the faces slide across the slip direction"

[scene]
model = "solid_blade"
effects = ["friction", "normal_load_variation", "cyclic_coupling"]
craig_bampton_modes = 8
rayleigh = [20.0, 4e-6]

[scene.blade]
n_chord = 2
n_thick = 1
n_span = 4

[scene.disk]
sectors = {N}
hub_radius = {R}
engine_order = 0

[[scene.contact]]
pair = "shroud"
ku = 1e-3
kv = 1e-3
mu = 0.3
stiffness = "per_face"
TANGENT

[[scene.excitation]]
set = "excitation"
direction = [0.0, 1.0, 0.0]
amplitude = 1.0

[sweep]
preload = [1.0]
frequency = {{ start = 190.0, stop = 240.0, unit = "Hz" }}

[solver]
harmonics = 1

[output]
dofs = ["response.y"]
figures = []
"""


def turn(angle):
    """Rotation about the disk axis (parallel to X) by `angle` [rad]."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def by_hand(f, freq_hz, tangent=None):
    """(A_t, A_b) [m]: the unreduced blade's response at freq_hz projected on t and
    b = n x t, root mean square of the first harmonic's amplitude over the node pairs."""
    scene = load_study(f).scene
    blade = blade_model(scene.structure)
    w = 2 * np.pi * freq_hz
    a, b = scene.structure.rayleigh
    x = spla.spsolve((blade.K - w ** 2 * blade.M + 1j * w * (a * blade.M + b * blade.K)).tocsc(),
                     blade_forcing(scene)[:, 1])
    xr_, xl = blade.set_points["shroud_right"], blade.set_points["shroud_left"]
    centre = np.array([0.0, 0.0, -R])
    # the neighbour sits one pitch on: the turn that lays its left face on our right face
    gaps = {}
    for sign in (1.0, -1.0):
        laid = (xl - centre) @ turn(sign * 2 * np.pi / N).T + centre
        dist = np.linalg.norm(laid[None] - xr_[:, None], axis=2)
        gaps[sign] = (dist.min(axis=1).max(), np.argmin(dist, axis=1))
    sign = min(gaps, key=lambda s: gaps[s][0])
    assert gaps[sign][0] < 1e-12
    Ra, partner = turn(sign * 2 * np.pi / N), gaps[sign][1]
    # engine order 0: the neighbour moves in phase, its vector turned into our frame
    d = x[blade.dof_sets["shroud_left"][partner]] @ Ra.T - x[blade.dof_sets["shroud_right"]]
    n = np.linalg.svd(xr_ - xr_.mean(axis=0))[2][-1]
    if tangent is None:
        c = xr_.mean(axis=0) - centre
        tangent = np.array([0.0, c[2], -c[1]])
    t = tangent - (tangent @ n) * n
    t /= np.linalg.norm(t)
    return tuple(np.sqrt(np.mean(np.abs(d @ e) ** 2)) for e in (t, np.cross(n, t)))


def run(tmp_path, capsys, name, tangent_line=""):
    f = tmp_path / f"{name}.toml"
    f.write_text(STUDY.replace("TANGENT", tangent_line))
    assert cli(["run", str(f), "--out", str(tmp_path), "--workers", "1", "--no-figures"]) == 0
    lines = [ln for ln in capsys.readouterr().err.splitlines()
             if ln.startswith(f"warning: {f}: scene.contact[0]:")]
    with xr.open_dataset(tmp_path / f"{name}.nc") as ds:
        ds.load()
    return f, ds, lines


def test_faces_sliding_across_the_slip_direction_are_warned_about(tmp_path, capsys):
    """Default slip direction (circumferential): at the peak the faces move 6.2 times as
    far along b as along t -- one warning line naming the pair, its amplitudes the
    hand projection's to 1e-4 of the larger (measured 7e-6: the 8 Craig-Bampton modes;
    5e-6 with 20), and the pair in the dataset's `free_direction_warned`."""
    f, ds, lines = run(tmp_path, capsys, "across")
    freq = float(ds["peak_frequency"].squeeze())
    At, Ab = by_hand(f, freq)
    got = {k: float(ds[v].sel(contact="shroud").squeeze()) for k, v in (
        ("t", "slip_direction_amplitude"), ("b", "free_direction_amplitude"),
        ("r", "free_direction_ratio"))}
    assert got["t"] == pytest.approx(At, abs=1e-4 * Ab)
    assert got["b"] == pytest.approx(Ab, abs=1e-4 * Ab)
    assert got["r"] == pytest.approx(Ab / At, rel=1e-3) and Ab / At > 5.0
    assert ds.attrs["free_direction_warned"] == "shroud"
    assert ds["free_direction_ratio"].attrs["warn_at"] == 0.5
    assert len(lines) == 1, lines
    line = lines[0]
    assert line.startswith(f"warning: {f}: scene.contact[0]: case preload = 1 N: shroud pair "
                           "'shroud' (friction = \"1d\"): at the peak its faces move ")
    assert line.endswith("friction = \"2d\" slides in the whole face plane")
    nums = [float(v) for v in re.findall(r"move (\S+) m along n x t.* and (\S+) m along its "
                                         r"slip direction t \(ratio (\S+) >=", line)[0]]
    assert nums == pytest.approx([Ab, At, Ab / At], rel=5e-3)     # printed to 3 digits


def test_faces_sliding_along_the_slip_direction_are_not(tmp_path, capsys):
    """The same motion with the slip direction laid radially (tangent = Z, in the
    face): now b is the circumferential one and the ratio 0.017, far below 0.5 (the
    amplitudes the hand projection's to 1e-4 of the larger, measured 7e-6) -- no
    warning, an empty `free_direction_warned`."""
    f, ds, lines = run(tmp_path, capsys, "along", "tangent = [0.0, 0.0, 1.0]")
    freq = float(ds["peak_frequency"].squeeze())
    At, Ab = by_hand(f, freq, tangent=np.array([0.0, 0.0, 1.0]))
    assert float(ds["slip_direction_amplitude"].squeeze()) == pytest.approx(At, abs=1e-4 * At)
    assert float(ds["free_direction_amplitude"].squeeze()) == pytest.approx(Ab, abs=1e-4 * At)
    assert float(ds["free_direction_ratio"].squeeze()) == pytest.approx(Ab / At, abs=1e-4)
    assert Ab / At < 0.05
    assert ds.attrs["free_direction_warned"] == ""
    assert lines == []
