"""`bench evaluations` counts what it says: every call of the residual a curve makes
(the first point's guesses, Newton iterates, corners, folds, dense output and peaks),
split into parts that add up, per point of the returned curve.  Plumbing and
counting, never a timing."""
import pytest

from pipeline.__main__ import main
from pipeline.bench import evaluations
from pipeline.solve.harmonic_balance import hbm


@pytest.mark.parametrize("which", evaluations.QUICK)
def test_every_residual_call_is_counted(which, monkeypatch):
    calls = []
    residual = hbm.residual

    def counted(*args, **kwargs):
        calls.append(kwargs.get("jacobian", True))
        return residual(*args, **kwargs)

    monkeypatch.setattr(hbm, "residual", counted)
    r = evaluations.curve_cost(*evaluations.CURVES[which])
    assert r.nfev == len(calls)
    assert calls.count(False) == 2            # the first point's two linear guesses
    assert r.continuation + r.dense + r.peaks == r.nfev
    assert r.continuation >= r.branch_points and r.dense >= r.dense_points
    assert r.points >= r.branch_points + r.dense_points + 1   # at least one peak inserted
    assert r.per_point == pytest.approx(r.nfev / r.points)


def test_bench_evaluations_prints_one_row_per_curve(capsys):
    assert main(["bench", "evaluations", "--quick"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith("Example ")]
    assert [(int(r[1]), float(r[2])) for r in rows] == [
        (evaluations.CURVES[i][0], evaluations.CURVES[i][1]) for i in evaluations.QUICK]
    for r in rows:
        points, evals, per_point = int(r[5]), int(r[8]), float(r[9])
        assert per_point == pytest.approx(evals / points, abs=0.005)
        assert int(r[10]) + int(r[11]) + int(r[12]) == evals
    assert "load average" in out and "all curves:" in out
