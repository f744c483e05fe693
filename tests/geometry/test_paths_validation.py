"""Bad inputs to the paths raise library errors that name the public argument."""

import inspect
import math

import numpy as np
import pytest

from bad_inputs import BAD_VECTORS, LyingLen
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.paths import Circle, Line, Polyline, Spline

BAD = {
    **BAD_VECTORS,
    "nan": [math.nan, 0.0],
    "big": [1e308, 0.0],
}
PATHS = {
    "line": lambda: Line([0.0, 0.0], [1.0, 0.0]),
    "circle": lambda: Circle([0.0, 0.0], radius=1.0),
    "polyline": lambda: Polyline([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], corner_radius=0.2),
    "spline": lambda: Spline([[0.0, 0.0], [1.0, 0.5], [2.0, 0.0]]),
}


@pytest.mark.parametrize("kind", sorted(BAD))
def test_constructors_name_their_points(kind: str):
    bad = BAD[kind]
    with pytest.raises(InvalidGeometry, match=r"^start: "):
        Line(bad, [1.0, 0.0])
    with pytest.raises(InvalidGeometry, match=r"^center: "):
        Circle(bad, radius=1.0)
    if kind != "ragged":  # a ragged (N, n) list is 1-D: still named
        with pytest.raises(InvalidGeometry, match=r"^vertices: "):
            Polyline([bad, [1.0, 0.0], [1.0, 1.0]], corner_radius=0.1)
    with pytest.raises(InvalidGeometry, match=r"^points: "):
        Spline([bad, [1.0, 0.5], [2.0, 0.0]])


@pytest.mark.parametrize("value", ["1", True, 1j, math.nan, 10**400, None])
def test_circle_scalars(value: object):
    with pytest.raises(InvalidParameter, match=r"^radius"):
        Circle([0.0, 0.0], radius=value)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^start_angle: "):
        Circle([0.0, 0.0], radius=1.0, start_angle=value)  # type: ignore[arg-type]


def test_circle_radius_is_keyword_only():
    assert inspect.signature(Circle).parameters["radius"].kind is inspect.Parameter.KEYWORD_ONLY
    with pytest.raises(TypeError):
        Circle([0.0, 0.0], 1.0)  # type: ignore[misc]


@pytest.mark.parametrize("radius", [[[0.1], [0.2, 0.3]], ["a"], [1j], [math.nan]])
def test_polyline_corner_radii(radius: object):
    with pytest.raises(InvalidParameter, match=r"^corner_radius"):
        Polyline([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], corner_radius=radius)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", sorted(PATHS))
@pytest.mark.parametrize("kind", sorted(BAD))
def test_queries_name_their_argument(name: str, kind: str):
    path = PATHS[name]()
    bad = BAD[kind]
    with pytest.raises(InvalidInput, match=r"^p: "):
        path.closest(bad)
    with pytest.raises(InvalidInput, match=r"^S: "):
        path.points(bad if kind != "None" else None)
    scalar = bad[0] if isinstance(bad, list) and kind in ("huge-int", "nan", "big") else bad
    with pytest.raises(InvalidInput, match=r"^s: "):
        path.point(scalar)
    if kind != "None":  # s0=None is "no reference"
        with pytest.raises(InvalidInput, match=r"^s0: "):
            path.closest([0.0, 0.0], s0=scalar, window=0.5)


@pytest.mark.parametrize("method", ["points", "tangents", "curvatures"])
def test_batch_queries_refuse_empty_lying_and_oversized_batches(method: str):
    line = Line([0.0, 0.0], [1.0, 0.0])
    with pytest.raises(InvalidInput, match=r"S: expected at least one arc length"):
        getattr(line, method)([])
    with pytest.raises(
        InvalidInput, match=r"S: expected arc lengths .* as a number, list, tuple or array"
    ):
        getattr(line, method)(LyingLen())
    spline = Spline([[0.0, 0.0], [1.0, 0.2], [2.0, 0.0]])
    with pytest.raises(InvalidInput, match=r"S: expected at most 100000 arc lengths"):
        getattr(spline, method)(np.zeros(Spline.MAX_BATCH + 1))
    assert getattr(line, method)([0.5]).shape == (1, 2)
