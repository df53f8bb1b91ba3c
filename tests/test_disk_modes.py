"""Modes of a tuned disk per nodal diameter (`[study] kind = "modes"` on a disk
scene): the Laxalde et al. (2007) lumped disk study against the closed form of its
cyclic eigenproblem, written out here from the study's numbers."""
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import UsageError
from pipeline.study.documents import load_study, parse_study
from pipeline.study.run import run_study
from pipeline.study.dataset_check import problems

from helpers import closed_form_hz

STUDY = Path(__file__).resolve().parents[1] / "studies" / "disk_laxalde.toml"
def test_laxalde_study_gives_the_closed_form_frequency_nodal_diameter_diagram(tmp_path):
    res = run_study(load_study(STUDY), tmp_path)
    ds = res.dataset
    assert list(ds.nodal_diameter.values) == list(range(13)) and ds.sizes["mode"] == 3
    for nd in range(13):
        np.testing.assert_allclose(ds.frequency_open.sel(nodal_diameter=nd),
                                   closed_form_hz(nd, False), rtol=1e-12)
        np.testing.assert_allclose(ds.frequency_stuck.sel(nodal_diameter=nd),
                                   closed_form_hz(nd, True), rtol=1e-12)
    assert ds.frequency_open.attrs["units"] == "Hz"
    # EO = 0: the neighbours move together, the tip contact carries nothing
    np.testing.assert_allclose(ds.frequency_open[0], ds.frequency_stuck[0], rtol=1e-12)
    assert (ds.frequency_stuck[1:] > ds.frequency_open[1:]).all()
    assert problems(res.path) == []
    fig = tmp_path / "disk_laxalde" / "nodal_diameter_diagram.png"
    assert res.figures == [fig] and fig.stat().st_size > 10_000


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
    from pipeline.study.check import check
    assert check(str(STUDY)) == 0
    out = capsys.readouterr().out
    assert "valid disk_modes study" in out and "24 sectors" in out and "26 sector eigen" in out
