"""The Hermite curves that start the continuation's and the dense output's correctors
(`branch.hermite_point`): their order of accuracy on a circle, against its exact
points, and the choice between the cubic and the quintic (`Tracer.quintic_fits`)."""
import numpy as np

from pipeline.solve.continuation.branch import hermite_on_plane, hermite_point
from pipeline.solve.continuation.tracer import Tracer


def circle_points(angles, radius=1.0):
    """Points of a circle (with a third, constant coordinate) and their unit tangents."""
    a = np.asarray(angles, float)
    Y = radius * np.column_stack([np.cos(a), np.sin(a), np.full(a.size, 0.3)])
    T = np.column_stack([-np.sin(a), np.cos(a), np.zeros(a.size)])
    return Y, T


def test_hermite_extrapolation_converges_with_its_order_on_a_circle():
    """A step ds beyond the last of m points, h apart on the unit circle: the point
    where the Hermite curve meets the predictor's hyperplane is the circle's own to
    O(h^(2m)) (cubic, quintic, septic: error ratios 16, 64, 256 when h halves);
    a straight line is reproduced exactly."""
    def error(m, h):
        Y, T = circle_points(h * np.arange(m))
        ds = 0.8 * h  # on the hyperplane t . (p - y) = ds through the last point
        p = hermite_on_plane(Y, T, T[-1], ds)
        a = (m - 1) * h + np.arcsin(ds)  # the circle's point on that hyperplane
        return np.linalg.norm(p - [np.cos(a), np.sin(a), 0.3])

    for m in (2, 3, 4):
        e1, e2 = error(m, 0.2), error(m, 0.1)
        assert 0.5 * 2 ** (2 * m) < e1 / e2 < 2.0 * 2 ** (2 * m), (m, e1, e2)
    assert error(3, 0.1) < 1e-2 * error(2, 0.1)
    Y = np.outer(np.arange(3.0), [0.6, 0.8]) + [1.0, -2.0]
    T = np.tile([0.6, 0.8], (3, 1))
    assert np.allclose(hermite_on_plane(Y, T, T[-1], 0.7), Y[-1] + 0.7 * T[-1], atol=1e-14)


def test_quintic_start_only_where_it_predicted_the_last_point_better():
    """On a circle the quintic through three points predicts the fourth better than
    the cubic; with a corner between the last two points (a change of the
    stick/slip pattern) it does not, and the cubic is kept."""
    Y, T = circle_points(0.1 * np.arange(4))
    assert Tracer.quintic_fits(Y, T)
    Yk, Tk = Y.copy(), T.copy()
    Tk[3] = np.array([-np.sin(0.5), np.cos(0.5), 0.0])  # the last tangent turned
    Yk[3] = Yk[2] + 0.1 * Tk[3]
    assert not Tracer.quintic_fits(Yk, Tk)


def test_hermite_interpolation_between_neighbours_on_a_circle():
    """The middle of a chord of the circle from the septic through the chord's ends
    and one neighbour on each side, on the hyperplane normal to the chord: within
    O(h^8) of the circle's point there, 1e4 times closer than the cubic through
    the chord's ends alone."""
    h = 0.2
    Y, T = circle_points(h * np.arange(4))
    d = (Y[2] - Y[1]) / np.linalg.norm(Y[2] - Y[1])
    m = 0.5 * (Y[1] + Y[2])
    exact = np.array([np.cos(1.5 * h), np.sin(1.5 * h), 0.3])
    ok4, p4 = hermite_point(Y, T, d, float(d @ m), -1.5)
    ok2, p2 = hermite_point(Y[1:3].copy(), T[1:3].copy(), d, float(d @ m), -0.5)
    assert ok4 and ok2
    assert np.linalg.norm(p4 - exact) < 1e-4 * np.linalg.norm(p2 - exact)
    assert np.linalg.norm(p4 - exact) < 1e-9
