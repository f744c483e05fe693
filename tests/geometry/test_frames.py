"""velfence.geometry.body_to_world / world_to_body: planar twists turned by the heading."""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.errors import InvalidInput
from velfence.geometry import body_to_world, world_to_body


def test_forward_motion_points_along_the_heading() -> None:
    # a base facing +y (yaw 90°) driving forward moves along +y of the world
    np.testing.assert_allclose(body_to_world([1.0, 0.0], math.pi / 2), [0.0, 1.0], atol=1e-15)
    # sideways to the left of a base facing +y is -x of the world
    np.testing.assert_allclose(body_to_world([0.0, 1.0], math.pi / 2), [-1.0, 0.0], atol=1e-15)
    # the yaw rate is the same in both frames
    out = body_to_world([1.0, 0.0, 0.7], math.pi)
    np.testing.assert_allclose(out, [-1.0, 0.0, 0.7], atol=1e-15)


@pytest.mark.parametrize("yaw", [-3.0, -0.4, 0.0, 1.1, 2.9, 40.0])
def test_the_two_are_inverse_and_keep_the_speed(yaw: float) -> None:
    v = np.array([0.3, -1.2, 0.5])
    w = body_to_world(v, yaw)
    assert np.hypot(*w[:2]) == pytest.approx(np.hypot(*v[:2]), rel=1e-14)
    np.testing.assert_allclose(world_to_body(w, yaw), v, atol=1e-14)
    assert v.tolist() == [0.3, -1.2, 0.5]  # the input is not changed


@pytest.mark.parametrize(
    ("twist", "yaw"),
    [([1.0], 0.0), ([1.0, 2.0, 3.0, 4.0], 0.0), ([1.0, math.nan], 0.0), ([1.0, 0.0], math.inf)],
)
def test_bad_input_is_refused(twist: list[float], yaw: float) -> None:
    with pytest.raises(InvalidInput):
        body_to_world(twist, yaw)
