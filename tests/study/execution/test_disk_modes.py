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
