"""`bench interface` builds what it says: the full-size study's blade with n_chord
elements across the chord, (2 n_chord + 1) x 3 node pairs a shroud face, with the 1D
law (exact forces) or the study's own 2D law (AFT)."""
import pytest

from pipeline.bench.interface import blade_study


@pytest.mark.parametrize("law", ["1d", "2d"])
def test_the_bench_blade_has_the_pairs_and_law_it_prints(law):
    study = blade_study(1, law)
    system = study.system({"preload": 10.0})
    assert study.scene.structure.params.n_chord == 1
    assert study.solver.force_evaluation == ("exact" if law == "1d" else "aft")
    n = system.contact.size if law == "1d" else sum(le.maps[0].shape[0] for le in system.laws)
    assert n == (2 * 1 + 1) * 3
