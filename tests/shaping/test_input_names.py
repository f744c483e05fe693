"""Public argument names of the shapers and the checks behind them (hostile-input fixes)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import velfence as vf
from bad_inputs import HugeLen, RaisingArray
from velfence._validate import real_array
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry import ConvexPolygon, points_segments_distances
from velfence.sim import NoLimit

SQUARE = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]


def shaper() -> vf.PolygonShaper:
    return vf.PolygonShaper(ConvexPolygon(SQUARE), buffer=0.2, accelerate=False)


def test_shape_takes_position_and_command_by_keyword() -> None:
    s = shaper()
    by_kw = s.shape(position=[0.5, 0.2], command=[1.0, 0.3])
    assert np.array_equal(by_kw, s.shape(np.array([0.5, 0.2]), np.array([1.0, 0.3])))
    out = s.shape_batch(positions=[[0.5, 0.2]], commands=[[1.0, 0.3]])
    assert np.array_equal(out[0], by_kw)


def test_batch_message_names_the_argument_with_the_bad_row() -> None:
    with pytest.raises(InvalidInput, match=r"non-finite commands in row\(s\) \[1\]"):
        shaper().shape_batch([[0.0, 0.0], [0.1, 0.1]], [[1.0, 0.0], [math.nan, 0.0]])


def test_no_limit_explain_reports_finite_distances() -> None:
    r = NoLimit().explain([0.5, 0.2], [1.0, 0.3])
    assert r.primary == -1
    assert math.isfinite(r.d1)
    assert math.isfinite(r.d2)
    assert r.d1 >= 1e150


def test_real_array_refuses_lying_sequences_by_name() -> None:
    with pytest.raises(InvalidInput, match=r"position: expected .* list, tuple or array"):
        real_array("position", HugeLen(), (2,))

    class HugeList(list):  # type: ignore[type-arg]
        def __len__(self) -> int:
            return 10**12

    with pytest.raises(InvalidInput, match=r"position: expected .* at most 10000000 entries"):
        real_array("position", HugeList([1.0, 2.0]), (2,))
    with pytest.raises(InvalidInput, match="command: expected"):
        real_array("command", RaisingArray(), (2,))


def test_long_double_beyond_float64_is_too_large_not_inf() -> None:
    with pytest.raises(InvalidInput, match=r"positions: expected .* magnitude <= 1e\+150"):
        real_array("positions", np.array([np.longdouble("1e4000")]))


def test_profiles_check_delta_and_speed() -> None:
    p = vf.LinearBuffer(buffer=0.2, spring_gain=4.0)
    with pytest.raises(InvalidInput, match="delta: expected a signed distance"):
        p.cap("0.1", 1.0)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="speed: expected a speed >= 0"):
        p.cap(0.1, -1.0)
    assert p.cap(np.float32(0.1), np.int64(1)) == pytest.approx(0.5)
    t = vf.ThreeZoneBraking(gain=4.0, max_speed=1.0, max_acceleration=2.0)
    with pytest.raises(InvalidParameter, match="dt must be finite and > 0"):
        t.check_period(-1.0)


def test_rate_limiter_hold_checks_the_value() -> None:
    r = vf.RateLimiter(size=2, max_speed=1.0, max_acceleration=10.0, dt=0.001)
    with pytest.raises(InvalidInput, match="value: expected"):
        r.hold(["a", "b"])
    r.hold((0.1, 0.2))
    assert r.state.tolist() == [0.1, 0.2]


def test_points_segments_distances_names_radii_and_bounds_pairs() -> None:
    with pytest.raises(InvalidInput, match="radii: expected radii >= 0"):
        points_segments_distances(
            [[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [[2.0, 0.0, 0.0]], radii=-1.0
        )
    with pytest.raises(InvalidInput, match="radii: expected"):
        points_segments_distances(
            [[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [[2.0, 0.0, 0.0]], radii="1"
        )
    t, d = points_segments_distances(
        [[0.0, 1.0, 0.0]], [[-1.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], radii=np.float32(0.5)
    )
    assert t[0, 0] == pytest.approx(0.5)
    assert d[0, 0] == pytest.approx(0.5)


def test_inside_by_angle_sum_checks_tol() -> None:
    with pytest.raises(InvalidParameter, match="tol"):
        ConvexPolygon(SQUARE).inside_by_angle_sum([0.0, 0.0], tol="1e-9")  # type: ignore[arg-type]
