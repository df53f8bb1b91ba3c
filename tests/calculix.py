"""CalculiX (ccx) for the tests that compare with it: running a deck, the package's
wheel blade written as a deck, and a turning deck (a linear `CENTRIF` static step, then
a `PERTURBATION` frequency step).  Without ccx those tests skip, saying why."""
import shutil
import subprocess

import numpy as np
import pytest

from pipeline.structure.disk import wheel_params
from pipeline.structure.exchange.calculix_deck import write_deck
from pipeline.structure.fe_model import BladeParams, DiskPlacement
from pipeline.structure.solid import solid_mesh

needs_ccx = pytest.mark.skipif(shutil.which("ccx") is None, reason=(
    "CalculiX (ccx) is not installed: apt-get install calculix-ccx"))
BLADE = BladeParams(n_chord=2, n_thick=1, n_span=4)
DISK = DiskPlacement(hub_radius=0.12, sectors=36)


def ccx(folder, job) -> str:
    """Run `ccx -i job` in `folder`; its .dat text ("" when it wrote none)."""
    run = subprocess.run(["ccx", "-i", job], cwd=folder, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stdout[-800:]
    dat = folder / f"{job}.dat"
    return dat.read_text() if dat.exists() else ""


def exported_blade(folder, mesh=None):
    """The wheel blade written as a deck, run through ccx: (mesh, sets, params)."""
    m, sets = solid_mesh(BLADE, DISK)
    mesh = m if mesh is None else mesh(m)
    p = wheel_params(BLADE, DISK)
    write_deck(mesh, sets, p, folder / "blade.inp")
    ccx(folder, "blade")
    return mesh, sets, p


def turning_deck(folder, job, rpm, hub, frequency, deck="blade", axis=None):
    """Write `job`.inp: the deck `deck`.inp turning at `rpm` about the axis parallel to
    X through (0, 0, -hub) [m] (or `axis` = (point [m], direction)) -- `*STATIC` with
    `CENTRIF`, then `*STEP, PERTURBATION` with the frequency step's line `frequency` --
    and run it; its .dat text."""
    text = (folder / f"{deck}.inp").read_text()
    w2 = (rpm * np.pi / 30) ** 2
    point, direction = axis if axis is not None else ((0.0, 0.0, -hub), (1.0, 0.0, 0.0))
    line = ", ".join(f"{v:.17g}" for v in (w2, *point, *direction))
    (folder / f"{job}.inp").write_text(text[:text.index("*STEP")] + "\n".join([
        "*STEP", "*STATIC", "*DLOAD", f"EALL, CENTRIF, {line}",
        "*END STEP", "*STEP, PERTURBATION", *frequency, "*END STEP", ""]))
    return ccx(folder, job)


def moved_deck(folder, deck, job, Q, b):
    """Write `job`.inp: the deck `deck`.inp with every node moved rigidly to Q x + b
    [m] (Q (3, 3) a rotation) -- the same blade in another frame."""
    lines, out, nodes = (folder / f"{deck}.inp").read_text().splitlines(), [], False
    for line in lines:
        if line.startswith("*"):
            nodes = line.upper().startswith("*NODE")
        elif nodes and line.strip():
            n, *x = line.split(",")
            line = f"{n}, " + ", ".join(f"{v:.17g}" for v in Q @ np.array(x, float) + b)
        out.append(line)
    (folder / f"{job}.inp").write_text("\n".join(out) + "\n")
