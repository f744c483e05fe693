"""velfence.geometry.clearance: signed distance of points to a convex region's boundary."""

from __future__ import annotations

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry import ConvexPolygon, ConvexPolytope, clearance

SQUARE = ConvexPolygon([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
BOX = ConvexPolytope.box([0.0, 0.0, 0.0], [2.0, 2.0, 2.0])


@pytest.mark.parametrize("region", [SQUARE, ConvexPolytope.from_polygon(SQUARE)])
def test_square_by_hand(region: ConvexPolygon | ConvexPolytope) -> None:
    pts = np.array(
        [
            [1.0, 1.0],  # centre: 1 from every side
            [0.5, 1.0],  # 0.5 from the left side
            [2.0, 1.0],  # on the boundary
            [3.0, 1.0],  # 1 right of the square
            [3.0, 3.0],  # beyond a corner: sqrt(2), not the facet violation 1
        ]
    )
    got = clearance(region, pts)
    np.testing.assert_allclose(got, [1.0, 0.5, 0.0, -1.0, -np.sqrt(2.0)], atol=1e-12)
    assert isinstance(clearance(region, [1.0, 1.0]), float)


def test_box_agrees_with_sampled_boundary_distance() -> None:
    rng = np.random.default_rng(3)
    X = rng.uniform(-1.0, 3.0, size=(200, 3))
    got = clearance(BOX, X)
    # Independent reference for an axis-aligned box: per-axis overshoot outside, margin inside.
    lo, hi = np.zeros(3), np.full(3, 2.0)
    over = np.maximum(lo - X, 0.0) + np.maximum(X - hi, 0.0)
    outside = np.linalg.norm(over, axis=1)
    margin = np.min(np.minimum(X - lo, hi - X), axis=1)
    want = np.where(outside > 0.0, -outside, margin)
    np.testing.assert_allclose(got, want, atol=1e-9)


def test_bad_inputs_are_named() -> None:
    with pytest.raises(InvalidParameter, match=r"^region: "):
        clearance("square", [0.0, 0.0])  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"^points: expected shape \(3,\) or \(N, 3\)"):
        clearance(BOX, [0.0, 0.0])
    with pytest.raises(InvalidInput, match=r"^points"):
        clearance(SQUARE, [[0.0, np.nan]])
