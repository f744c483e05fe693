"""velfence.sim.scenarios: the waypoint operator, the default demo script, constant()."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from velfence.apps.demo.script import default_script
from velfence.errors import InvalidParameter
from velfence.geometry.polygon import ConvexPolygon
from velfence.mechanisms.wrist import Wrist, WristGeometry
from velfence.sim.scenarios import (
    Script,
    Waypoint,
    WaypointOperator,
    constant,
    operator_from,
)

TOL = 1e-12
WPS = (
    Waypoint(t=0.0, target=(1.0, 0.0), speed=0.5),
    Waypoint(t=2.0, target=(0.0, 1.0), speed=1.0),
    Waypoint(t=3.5, target=(-1.0, -1.0), speed=0.25),
)

finite = st.floats(-10.0, 10.0, allow_nan=False)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


# ------------------------------------------------------------------------------ WaypointOperator


@pytest.mark.parametrize(
    ("t", "index"),
    [(0.0, 0), (1.999, 0), (2.0, 1), (3.0, 1), (3.5, 2), (100.0, 2), (-1.0, 0)],
)
def test_active_waypoint_switches_at_waypoint_times(t: float, index: int) -> None:
    assert WaypointOperator(WPS).active(t) is WPS[index]


def test_command_heads_for_the_active_target() -> None:
    op = WaypointOperator(WPS)
    p = np.array([0.2, -0.3])
    for t, w in ((1.0, WPS[0]), (2.5, WPS[1]), (4.0, WPS[2])):
        v = op(t, p)
        assert v.shape == (2,)
        np.testing.assert_allclose(_unit(v), _unit(np.asarray(w.target) - p), atol=TOL)
    # Just before and at a switch the direction changes.
    before, after = op(2.0 - 1e-9, p), op(2.0, p)
    assert float(_unit(before) @ _unit(after)) < 0.5


def test_speed_is_the_waypoint_speed_far_from_the_target() -> None:
    op = WaypointOperator(WPS, gain=6.0)
    for t, w in ((0.5, WPS[0]), (2.5, WPS[1]), (4.0, WPS[2])):
        p = np.asarray(w.target) + np.array([3.0, 4.0])  # 5 away, well beyond speed / gain
        assert math.isclose(float(np.linalg.norm(op(t, p))), w.speed, rel_tol=1e-12)


def test_speed_slows_linearly_near_the_target() -> None:
    gain = 4.0
    op = WaypointOperator(WPS, gain=gain)
    w = WPS[1]
    for d in (1e-6, 0.01, 0.1, 0.2499):  # speed / gain = 0.25
        p = np.asarray(w.target) + d * _unit(np.array([1.0, 2.0]))
        assert math.isclose(float(np.linalg.norm(op(2.5, p))), gain * d, rel_tol=1e-9)


def test_zero_at_the_target() -> None:
    op = WaypointOperator(WPS)
    for t, w in ((0.0, WPS[0]), (2.0, WPS[1]), (9.0, WPS[2])):
        v = op(t, np.asarray(w.target, dtype=float))
        assert v.shape == (2,)
        assert np.array_equal(v, np.zeros(2))


@given(t=st.floats(0.0, 10.0), x=finite, y=finite, gain=st.floats(0.1, 100.0))
def test_never_exceeds_the_waypoint_speed(t: float, x: float, y: float, gain: float) -> None:
    op = WaypointOperator(WPS, gain=gain)
    v = op(t, np.array([x, y]))
    assert np.all(np.isfinite(v))
    assert float(np.linalg.norm(v)) <= op.active(t).speed * (1 + 1e-12)


@given(x=finite, y=finite)
def test_moves_toward_the_target(x: float, y: float) -> None:
    op = WaypointOperator(WPS)
    p = np.array([x, y])
    e = np.asarray(WPS[0].target) - p
    v = op(0.0, p)
    assert float(v @ e) >= 0.0
    assert abs(float(v[0] * e[1] - v[1] * e[0])) <= 1e-9 * (1 + float(np.linalg.norm(e)))


def test_operator_rejects_bad_arguments() -> None:
    with pytest.raises(InvalidParameter, match="at least one waypoint"):
        WaypointOperator(())
    for gain in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(InvalidParameter, match=r"gain must be finite and > 0 \(1/s\)"):
            WaypointOperator(WPS, gain=gain)


def test_waypoint_and_script_are_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        WPS[0].speed = 2.0  # type: ignore[misc]
    script = Script(start=(0.0, 0.0), waypoints=WPS, pushes=(), duration=1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        script.duration = 2.0  # type: ignore[misc]
    assert script.labels == ()


def test_operator_from_script() -> None:
    script = Script(start=(0.0, 0.0), waypoints=WPS, pushes=(), duration=5.0)
    op = operator_from(script)
    assert isinstance(op, WaypointOperator)
    assert op.waypoints == WPS
    p = np.array([0.3, 0.3])
    np.testing.assert_array_equal(op(2.5, p), WaypointOperator(WPS)(2.5, p))


# ---------------------------------------------------------------------------------- default_script

SQUARE = ConvexPolygon([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])


def _polygons() -> list[tuple[str, ConvexPolygon, float]]:
    return [
        ("square", SQUARE, 0.2),
        ("wrist", Wrist(geometry=WristGeometry()).default_polygon(), 0.08),
        ("pentagon", ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]]), 0.2),
    ]


@pytest.fixture(params=_polygons(), ids=lambda x: x[0])
def case(request: pytest.FixtureRequest) -> tuple[ConvexPolygon, float, Script]:
    _, poly, buffer = request.param
    return poly, buffer, default_script(poly, buffer=buffer)


def test_script_has_seven_labelled_phases_in_time_order(
    case: tuple[ConvexPolygon, float, Script],
) -> None:
    _, _, s = case
    assert len(s.waypoints) == 7
    assert len(s.labels) == len(s.waypoints)
    assert s.labels[0] == "start outside, come in"
    ts = [w.t for w in s.waypoints]
    assert ts[0] == 0.0
    assert all(b > a for a, b in itertools.pairwise(ts))
    # Every phase lasts at least its dwell (>= 0.2 s).
    assert min(np.diff(ts)) >= 0.2
    assert all(w.speed > 0 for w in s.waypoints)
    assert all(np.all(np.isfinite(w.target)) for w in s.waypoints)


def test_script_starts_just_outside_the_longest_edge(
    case: tuple[ConvexPolygon, float, Script],
) -> None:
    poly, buffer, s = case
    start = np.asarray(s.start)
    assert not poly.contains(start)
    lengths = np.linalg.norm(np.roll(poly.corners, -1, axis=0) - poly.corners, axis=1)
    e = int(np.argmax(lengths))
    d = poly.signed_distances(start)
    assert math.isclose(float(d[e]), -0.6 * buffer, rel_tol=1e-9)
    # First phase comes in, toward the centroid (inside).
    np.testing.assert_allclose(s.waypoints[0].target, poly.centroid, atol=TOL)
    assert poly.contains(np.asarray(s.waypoints[0].target))


def test_script_presses_beyond_the_boundary(case: tuple[ConvexPolygon, float, Script]) -> None:
    poly, _, s = case
    outside = [not poly.contains(np.asarray(w.target)) for w in s.waypoints]
    # Phases 2-6 (edge press, sweep, acute corner, obtuse corner, far side) aim beyond the edge.
    assert outside[1:6] == [True] * 5
    # The last phase holds inside the polygon, within the buffer of the long edge.
    assert not outside[6]


def test_script_push_follows_the_last_waypoint(case: tuple[ConvexPolygon, float, Script]) -> None:
    poly, _, s = case
    assert len(s.pushes) == 1
    t0, t1, vel = s.pushes[0]
    assert t0 > s.waypoints[-1].t
    assert t1 > t0
    assert s.duration >= t1
    assert s.duration > s.waypoints[-1].t
    # The push drives outward through the long edge.
    lengths = np.linalg.norm(np.roll(poly.corners, -1, axis=0) - poly.corners, axis=1)
    e = int(np.argmax(lengths))
    assert float(poly.normals[e] @ np.asarray(vel)) < 0.0


def test_script_is_deterministic() -> None:
    assert default_script(SQUARE, buffer=0.2) == default_script(SQUARE, buffer=0.2)


def test_script_depends_on_buffer() -> None:
    a = default_script(SQUARE, buffer=0.1)
    b = default_script(SQUARE, buffer=0.3)
    assert a.start != b.start


# ----------------------------------------------------------------------------------------- constant


def test_constant_returns_the_velocity() -> None:
    op = constant((0.3, -1.25))
    for t, p in ((0.0, np.zeros(2)), (7.5, np.array([10.0, -3.0]))):
        v = op(t, p)
        assert v.shape == (2,)
        assert v.dtype == np.float64
        np.testing.assert_array_equal(v, [0.3, -1.25])


def test_constant_copies_and_is_read_only() -> None:
    src = np.array([1.0, 2.0])
    op = constant(src)
    src[0] = 99.0  # the operator keeps its own copy
    v = op(0.0, np.zeros(2))
    np.testing.assert_array_equal(v, [1.0, 2.0])
    with pytest.raises(ValueError, match="read-only"):
        v[0] = 5.0
