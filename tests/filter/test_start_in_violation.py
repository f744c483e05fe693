"""A filter whose state already violates a constraint says so: ``FilterResult.violations`` on every
route and cycle, and one :class:`StartedInViolation` warning per start.

The scene: a 7-joint arm with a sphere placed 25 cm below the middle of its fifth link, so that the
third link already passes through it. The depth is checked against a brute-force distance (the
link's axis sampled at 20,001 points), not against the filter's own geometry.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pytest

from velfence.errors import StartedInViolation
from velfence.filter import (
    LEVEL_OBSTACLE,
    JointLimits,
    RowBlock,
    RowContext,
    SafetyFilter,
    SphereObstacle,
)
from velfence.mechanisms.chain import DHChain

ARM = DHChain.seven_dof(link_radius=0.05)
LIM = ARM.joint_limits
Q = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
CENTRE = ARM.link_segments(Q)[4].mean(axis=0) - np.array([0.0, 0.0, 0.25])
RADIUS = 0.08


def _sampled_clearance(q: np.ndarray, link: int) -> float:
    """The sphere-capsule clearance by sampling the link's axis (independent of the filter)."""
    a, b = ARM.link_segments(q)[link]
    pts = a + np.linspace(0.0, 1.0, 20_001)[:, None] * (b - a)
    return float(np.linalg.norm(pts - CENTRE, axis=1).min()) - RADIUS - 0.05


def _filter(route: str, **kw: Any) -> SafetyFilter:
    """The scene's filter on one route: the C cycle, the compiled rows or plain Python."""
    extra: dict[str, Any] = {}
    if route == "compiled":  # a full weight matrix keeps the cycle out of C, on compiled rows
        extra["weights"] = np.eye(7) + 0.1 * np.ones((7, 7))
    f = SafetyFilter(
        ARM,
        limits=JointLimits(LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1.5)),
        obstacles=[SphereObstacle(CENTRE, radius=RADIUS)],
        dt=0.002,
        backend="python" if route == "python" else "c",
        **extra,
        **kw,
    )
    return f


ROUTES = ["python", "c", "compiled"]


def test_the_scene_starts_inside() -> None:
    depths = [_sampled_clearance(Q, k) for k in range(7)]
    assert min(depths) < -0.05  # the third link (index 2) is 8 cm deep in the sphere
    assert int(np.argmin(depths)) == 2
    pytest.importorskip("velfence_core._filter")
    assert _filter("c").cycle_in_c
    assert not _filter("compiled").cycle_in_c


@pytest.mark.parametrize("route", ROUTES)
def test_the_result_names_the_violated_pair_and_its_depth(route: str) -> None:
    if route != "python":
        pytest.importorskip("velfence_core._filter")
    f = _filter(route)
    with pytest.warns(StartedInViolation) as seen:
        r = f.explain(Q, np.zeros(7))
    assert len(seen) == 1
    assert r.zone.startswith("outside")
    assert "recovery" in r.stages
    assert [nm for nm, _ in r.violations] == ["obstacle 0 on link 2"]
    depth = r.violations[0][1]
    assert depth == pytest.approx(-_sampled_clearance(Q, 2), abs=1e-9)
    assert isinstance(depth, float)
    assert type(depth) is float
    assert "obstacle 0 on link 2" in r.active_names
    # the message names the pair and the depth; it points at this file, the caller
    msg = str(seen[0].message)
    assert f"obstacle 0 on link 2 ({depth:.4g} m deep)" in msg
    assert "recovery" in msg
    assert seen[0].filename == __file__
    # in recovery: a zero command moves the link out of the sphere
    assert np.abs(r.output).max() > 0.0
    assert _sampled_clearance(Q + 0.002 * r.output, 2) > _sampled_clearance(Q, 2)


@pytest.mark.parametrize("route", ROUTES)
def test_the_warning_comes_once_per_start(route: str) -> None:
    if route != "python":
        pytest.importorskip("velfence_core._filter")
    f = _filter(route)
    with pytest.warns(StartedInViolation):
        x0 = f.filter(Q, np.zeros(7))  # the fast path of the C cycle warns too
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = f.explain(Q, np.zeros(7))  # still inside: reported, not warned again
        f.filter_twist(Q, np.zeros(6))
    assert r.violations
    assert r.violations[0][0] == "obstacle 0 on link 2"
    np.testing.assert_allclose(r.output, x0, rtol=1e-9, atol=1e-12)
    f.reset()
    with pytest.warns(StartedInViolation):
        f.filter_twist(Q, np.zeros(6))  # a new start


def test_a_start_outside_every_constraint_warns_nothing_and_reports_nothing() -> None:
    f = _filter("python")
    q = Q.copy()
    q[1] += 0.6  # the arm leans away from the sphere
    assert min(_sampled_clearance(q, k) for k in range(7)) > 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = f.explain(q, np.zeros(7))
    assert r.violations == ()
    assert not r.zone.startswith("outside")


def test_independent_states_are_not_a_start() -> None:
    pytest.importorskip("velfence_core._filter")
    f = _filter("c")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f.shape_batch(Q[None], np.zeros((1, 7)))
        out = f.filter_batch(Q[None], np.zeros((1, 7)))
    assert out.stage_names(0).count("recovery") == 1
    with pytest.warns(StartedInViolation):  # the batches did not count as the start
        f.filter(Q, np.zeros(7))


def test_a_joint_past_its_limit_is_reported_in_radians() -> None:
    f = SafetyFilter(ARM, limits=JointLimits(LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1.5)))
    q = Q.copy()
    q[3] = LIM[3, 0] - 0.2
    with pytest.warns(StartedInViolation, match=r"joint 3 position \(lower\) \(0\.2 rad deep\)"):
        r = f.explain(q, np.zeros(7))
    assert [nm for nm, _ in r.violations] == ["joint 3 position (lower)"]
    assert r.violations[0][1] == pytest.approx(0.2, rel=1e-12)


class _Wall:
    """A user's row, violated now; with or without a distance."""

    level = LEVEL_OBSTACLE
    label = "wall"

    def __init__(self, distance: bool) -> None:
        self.distance = distance

    def rows(self, ctx: RowContext) -> RowBlock:
        d = np.array([-0.03]) if self.distance else None
        return RowBlock(np.eye(7)[:1], np.array([0.01]), np.array([True]), np.array([0]),
                        ["wall"], distance=d)  # fmt: skip


@pytest.mark.parametrize("distance", [True, False])
def test_a_providers_rows_are_reported_but_not_warned(distance: bool) -> None:
    """A provider's rows (people, zones, point clouds, the user's own) change at run time: a
    violated one is in ``violations`` (depth ``None`` without a distance) but gives no warning."""
    f = SafetyFilter(
        ARM,
        limits=JointLimits(LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1.5)),
        providers=[_Wall(distance)],
    )
    q = Q.copy()
    q[1] += 0.6
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = f.explain(q, np.zeros(7))
    assert r.violations == (("wall", 0.03 if distance else None),)
    assert r.zone == "outside"
