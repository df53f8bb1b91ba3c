"""The hysteresis output of 2D friction: the in-plane orbit, never a 1D loop.

A lumped scene placing one 2D element (tests/studies/inplane_oscillator_2d_friction.toml:
mu n0 = 2.5 N, kv = 0) asked for the hysteresis figure: the dataset carries the second
tangent's motion, and the orbit drawn from it keeps the friction force on the Coulomb
circle while the element slides (its dissipated energy the harmonics' own)."""
from pathlib import Path

import numpy as np

from pipeline.contact.friction2d.law import Friction2D
from pipeline.study.datasets.dataset import read_dataset
from pipeline.study.execution.run import run_study
from pipeline.study.figures.contact_figures import element_orbit
from pipeline.study.files.documents import parse_study

STUDY = Path(__file__).resolve().parents[2] / "studies" / "inplane_oscillator_2d_friction.toml"


def test_a_2d_element_gets_its_in_plane_orbit(tmp_path):
    text = STUDY.read_text()
    assert "\nfigures = " not in text
    text = text.replace("[output]\n", '[output]\nfigures = ["amplitude", "hysteresis"]\n')
    st = parse_study(text, file=str(tmp_path / "orbit.toml"), name="orbit")
    res = run_study(st, tmp_path, workers=1, figures=True, progress=False)
    ds = read_dataset(res.path)
    assert np.all(np.isfinite(ds["hysteresis_u2"].values))
    assert (tmp_path / "orbit" / "hysteresis.png").is_file()
    orbit = element_orbit(ds, {}, st.solver.samples)
    force = np.hypot(*orbit["f"])
    assert force.max() <= 2.5 * (1 + 1e-12) and force.max() >= 2.5 * (1 - 1e-12)
    law = Friction2D(ku=1e4, kv=0.0, mu=0.5, n0=5.0)
    X = np.stack([ds[f"hysteresis_{d}"].values for d in ("u", "u2", "v")])[None]
    F = law.evaluate(X, n_samples=st.solver.samples, jacobian=False).F[0]
    h = np.arange(1, (X.shape[-1] - 1) // 2 + 1)
    loop = np.pi * sum(np.sum(h * (F[d, 1::2] * X[0, d, 2::2] - F[d, 2::2] * X[0, d, 1::2]))
                       for d in range(2))
    assert orbit["energy"] > 0 and abs(orbit["energy"] - loop) <= 1e-12 * abs(loop)
