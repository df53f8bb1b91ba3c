"""Restarted continuations on closed forms: joined Branches, both-ways and backwards
tracing, restarts past a corner."""
import numpy as np
import pytest

from pipeline.solve.continuation.branch import Branch
from pipeline.solve.continuation.pseudo_arclength import continue_branch
from pipeline.solve.continuation.newton import newton
from pipeline.solve.continuation.restarts import continue_past_corners, cover_range, join, piece, trace_range

from helpers import scurve


def middle_root(lam):
    r = np.roots([1, 0, -3, -lam])
    return np.array([r[(np.abs(r.imag) < 1e-9) & (np.abs(r.real) < 1)].real[0]])


def vee(x, lam):
    """x = 10 |lam - 0.5|: a symmetric corner the step control cannot cross."""
    d = lam - 0.5
    return np.array([x[0] - 10 * abs(d)]), np.eye(1), np.array([-10 * np.sign(d)])


def on_scurve(b, tol=1e-12):
    return all(np.linalg.norm(scurve(x, lam)[0]) <= tol for x, lam in zip(b.x, b.lam))


def folds_consistent(b):
    """Each fold lies between its two points: the tangent's lam-component changes sign."""
    return all(b.tangent[i, -1] * b.tangent[i + 1, -1] < 0 for i in b.fold_index)


def tangents_along_the_points(b):
    chords = np.diff(np.column_stack([b.x, b.lam]), axis=0)
    return np.all(np.einsum("ij,ij->i", chords, b.tangent[:-1]) > 0)


@pytest.fixture(scope="module")
def two_ways():
    """The S-curve from its middle branch at lam = -1.5: up to the fold (-1, 2) and back
    to lam = -2.4; the other way through the fold (1, -2) up to lam = 3."""
    x0 = middle_root(-1.5)
    a = continue_branch(scurve, x0, -1.5, 3.0, tol=1e-12, lam_back=-2.4)
    b = continue_branch(scurve, x0, -1.5, 3.0, tol=1e-12, lam_back=-2.4, direction=-1)
    assert (a.status, b.status) == (1, 0)
    return a, b


def test_piece_reverses_points_tangents_and_folds(two_ways):
    a, _ = two_ways
    r = piece(a, reverse=True)
    assert isinstance(r, Branch) and len(r) == len(a)
    np.testing.assert_array_equal(r.lam, a.lam[::-1])
    np.testing.assert_array_equal(r.tangent, -a.tangent[::-1])
    np.testing.assert_array_equal(r.fold_lam, a.fold_lam[::-1])
    assert folds_consistent(r) and tangents_along_the_points(r)
    np.testing.assert_array_equal(r.fold_index, len(a) - 2 - a.fold_index[::-1])
    d = piece(a, drop_first=True)
    np.testing.assert_array_equal(d.x, a.x[1:])
    np.testing.assert_array_equal(d.fold_index, a.fold_index - 1)
    assert (d.nfev, d.message, d.status) == (a.nfev, a.message, a.status)
    assert not d.x.flags.writeable and not r.tangent.flags.writeable


def test_join_two_branches_at_their_first_point(two_ways):
    a, b = two_ways
    j = join([piece(a, reverse=True), piece(b, drop_first=True)], "joined", True, 0,
             discarded=[a])
    assert isinstance(j, Branch) and len(j) == len(a) + len(b) - 1
    assert j.lam[len(a) - 1] == -1.5 and j.lam[0] == -2.4 and j.lam[-1] == 3.0
    np.testing.assert_allclose(j.fold_lam, [2.0, -2.0], atol=1e-9)
    np.testing.assert_allclose(j.fold_x[:, 0], [-1.0, 1.0], atol=1e-6)
    assert folds_consistent(j) and tangents_along_the_points(j) and on_scurve(j)
    np.testing.assert_allclose(np.linalg.norm(j.tangent / j.scale, axis=1), 1.0)
    np.testing.assert_array_equal(j.scale, np.maximum(a.scale, b.scale))
    assert j.nfev == 2 * a.nfev + b.nfev and j.njev == 2 * a.njev + b.njev  # discarded too
    assert j.n_rejected == 2 * a.n_rejected + b.n_rejected
    assert j.min_step == min(a.min_step, b.min_step)
    assert j.point_nfev.sum() <= a.nfev + b.nfev and j.converged.all()
    assert (j.success, j.status, j.message) == (True, 0, "joined")


def test_trace_range_both_ways_from_the_middle_branch():
    b = trace_range(scurve, middle_root(-1.5), -1.5, 3.0, 1e-12, None)
    assert b.success and b.status == 0 and "both ways" in b.message
    assert b.lam[0] == -1.5 - 0.2 * 4.5 and b.lam[-1] == 3.0
    np.testing.assert_allclose(b.fold_lam, [2.0, -2.0], atol=1e-9)
    assert folds_consistent(b) and tangents_along_the_points(b) and on_scurve(b)


def test_cover_range_traces_backwards_from_the_far_end():
    """From lam0 = 1.5 on the middle branch the S-curve leaves the range on the lam0
    side (through the fold (-1, 2)); from lam_end = 3 the upper branch covers it."""
    def first_point(lam, guess=None):
        nr = newton(lambda x: scurve(x, lam)[:2], np.array([0.0 if lam == 1.5 else 2.5]), 1e-12)
        return nr, 7
    b, spent = cover_range(scurve, first_point, 1.5, 3.0, 1e-12, None)
    assert b.success and b.status == 0 and "traced backwards" in b.message, b.message
    assert spent == 14 and b.lam[0] == 1.5 and b.lam[-1] == 3.0
    assert np.all(np.diff(b.lam) > 0) and np.all(b.x[:, 0] > 1) and on_scurve(b)
    assert tangents_along_the_points(b) and b.fold_lam.size == 0


def test_cover_range_of_an_arc_that_misses_the_far_end_is_no_success():
    def circle(x, lam):
        return np.array([x[0] ** 2 + lam**2 - 1]), np.array([[2 * x[0]]]), np.array([2 * lam])

    def first_point(lam, guess=None):
        return newton(lambda x: circle(x, lam)[:2], np.array([0.5]), 1e-12), 0
    b, _ = cover_range(circle, first_point, -0.5, 1.5, 1e-12, None)
    assert not b.success and b.status == 1 and b.message.startswith("1.5 not reached")
    np.testing.assert_allclose(b.fold_lam, [1.0], atol=1e-9)


def test_continue_past_corners_restarts_beyond_a_stall():
    alone = continue_branch(vee, [5.0], 0.0, 1.0, tol=1e-12, ds_min=1e-4)
    assert alone.status == -1  # the step collapses at the corner
    b = continue_past_corners(vee, np.array([5.0]), 0.0, 1.0, 1e-12, None, ds_min=1e-4)
    assert b.success and b.status == 0 and "1 restart(s)" in b.message
    assert b.lam[-1] == 1.0 and np.all(np.diff(b.lam) > 0)
    np.testing.assert_allclose(b.x[:, 0], 10 * np.abs(b.lam - 0.5), atol=1e-11)
    assert b.nfev > alone.nfev and len(b) > len(alone)
