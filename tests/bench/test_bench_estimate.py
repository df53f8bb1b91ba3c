"""`bench estimate`: a study that does not exist is one line before anything is
printed or run (the table's calibration itself: tests/study/files/test_study_guards.py)."""
from pipeline.bench import estimate


def test_a_missing_study_is_one_line_before_the_table(capsys):
    assert estimate.run(studies=["paper_example1", "no_such_study"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.strip().endswith("no_such_study.toml: (file): no such file")
    assert err.strip().startswith("error: ") and len(err.strip().splitlines()) == 1
