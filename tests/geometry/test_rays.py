"""Ray helpers of velfence.geometry.primitives (shared with the laser's scene ray casts)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.errors import InvalidInput
from velfence.geometry.primitives import (
    RAY_PARALLEL_TOL,
    UNIT_TOL,
    as_vec3,
    dot3,
    norm3,
    ray_plane,
    ray_point,
    sub3,
    unit_ray,
)


def test_float_kernels_match_numpy():
    rng = np.random.default_rng(0)
    for _ in range(50):
        a, b = rng.normal(size=3), rng.normal(size=3)
        ta, tb = as_vec3("a", a), as_vec3("b", b)
        assert dot3(ta, tb) == pytest.approx(float(a @ b), abs=1e-15)
        np.testing.assert_allclose(sub3(ta, tb), a - b, atol=0)
        assert norm3(ta) == pytest.approx(float(np.linalg.norm(a)), rel=1e-15)
        t = float(rng.uniform(0.0, 3.0))
        np.testing.assert_allclose(ray_point(ta, tb, t), a + t * b, atol=1e-15)
    assert as_vec3("p", [1, 2, 3]) == (1.0, 2.0, 3.0)
    with pytest.raises(InvalidInput, match="p"):
        as_vec3("p", [1.0, math.nan, 0.0])
    with pytest.raises(InvalidInput, match="p"):
        as_vec3("p", [1.0, 2.0])


def test_unit_ray_renormalises_and_refuses_non_unit_directions():
    o, d = unit_ray([0.0, 0.0, 1.0], [0.0, 0.6, 0.8 * (1.0 + 0.5 * UNIT_TOL)])
    assert o == (0.0, 0.0, 1.0)
    assert norm3(d) == pytest.approx(1.0, abs=1e-15)
    with pytest.raises(InvalidInput, match="direction: expected a unit vector"):
        unit_ray([0.0, 0.0, 0.0], [0.0, 0.0, 2.0])
    with pytest.raises(InvalidInput, match="origin"):
        unit_ray([0.0, math.inf, 0.0], [0.0, 0.0, 1.0])


def test_ray_plane_hits_misses_and_parallel_rays():
    n, c = (0.0, 0.0, 2.0), (0.0, 0.0, -1.0)  # the plane z = -1 (normal length is irrelevant)
    down = (0.0, 0.0, -1.0)
    assert ray_plane(n, c, (0.3, 0.4, 1.0), down) == pytest.approx(2.0)
    assert ray_plane((0.0, 0.0, -1.0), c, (0.3, 0.4, 1.0), down) == pytest.approx(2.0)
    assert ray_plane(n, c, (0.0, 0.0, 1.0), (0.0, 0.0, 1.0)) == math.inf  # pointing away
    assert ray_plane(n, c, (0.0, 0.0, -1.0), down) == 0.0  # starts on the plane
    s = 0.4 * RAY_PARALLEL_TOL  # |n·d| = 0.8 RAY_PARALLEL_TOL with |n| = 2
    grazing = (math.sqrt(1.0 - s * s), 0.0, -s)
    assert ray_plane(n, c, (0.0, 0.0, 1.0), grazing) == math.inf  # parallel within the tolerance
    assert ray_plane(n, c, (0.0, 0.0, -1.0), (1.0, 0.0, 0.0)) == math.inf  # lies in the plane
