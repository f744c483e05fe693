"""Safety modes, mode zones, slowdown and time-to-collision zones (``velfence.filter.modes``).

Independent references: the covering angle of the cap directions from SciPy's convex hull (the
circumcentres of the hull's triangles) and the vertices of the cap polytope from SciPy's
half-space intersection; the closed-loop TCP speed from a central-difference Jacobian of the
arm's forward kinematics; distances to boxes by clipping (the closest point of an axis-aligned
box), not by the polytope projection the rows use.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy.spatial import ConvexHull, HalfspaceIntersection

from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter import (
    ApproachRows,
    ApproachZone,
    JointLimits,
    ModeLimits,
    ModeRows,
    ModeZone,
    RowContext,
    SafetyFilter,
    SafetyMode,
    SlowdownRows,
    SlowdownZone,
    speed_cap_directions,
)
from velfence.filter.kinematics import frame_of
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain

ARM = DHChain.seven_dof(link_radius=0.04)
LO = np.radians([-170.0, -120.0, -170.0, -120.0, -170.0, -120.0, -175.0])
Q0 = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
DT = 0.004


class PointRobot:
    """A free point in 3-D (or 2-D): joints are the coordinates, the Jacobian is the identity."""

    def __init__(self, dim: int = 3) -> None:
        self.dof = dim
        self.joint_names = tuple(f"x{i}" for i in range(dim))
        self.points = ("tcp",)

    def fk(self, q: Any, point: str = "tcp") -> np.ndarray:
        return np.asarray(q, dtype=float).copy()

    def jacobian(self, q: Any, point: str = "tcp") -> np.ndarray:
        return np.eye(self.dof)


BOX = ConvexPolytope.box([0.0, -1.0, -1.0], [1.0, 1.0, 1.0])  # the zone: x >= 0 (within 1 m)


def _at(x: float) -> np.ndarray:
    return np.array([x, 0.0, 0.0])


def _point_filter(*providers: Any, dim: int = 3, speed: float = 10.0) -> SafetyFilter:
    lim = JointLimits(np.full(dim, -50.0), np.full(dim, 50.0), max_speed=np.full(dim, speed))
    return SafetyFilter(PointRobot(dim), limits=lim, dt=DT, providers=list(providers))


# ------------------------------------------------------------------------- cap directions
def _covering_angle_hull(D: np.ndarray) -> float:
    """The covering angle: the largest angle from a hull triangle's circumcentre to its corners."""
    hull = ConvexHull(D)
    worst = 0.0
    for tri in hull.simplices:
        P = D[tri]
        c = np.cross(P[1] - P[0], P[2] - P[0])
        c /= np.linalg.norm(c)
        c = c if c @ P[0] > 0 else -c
        worst = max(worst, float(np.max(np.arccos(np.clip(P @ c, -1.0, 1.0)))))
    return worst


@pytest.mark.parametrize("dim", [2, 3])
def test_cap_directions_cover_the_sphere_with_their_stated_angle(dim: int) -> None:
    D, cosa = speed_cap_directions(dim)
    np.testing.assert_allclose(np.linalg.norm(D, axis=1), 1.0, atol=1e-15)
    if dim == 3:
        assert D.shape == (26, 3)
        alpha = _covering_angle_hull(D)
    else:
        assert D.shape == (8, 2)
        ang = np.sort(np.arctan2(D[:, 1], D[:, 0]))
        gaps = np.diff(np.concatenate([ang, ang[:1] + 2 * math.pi]))
        alpha = float(np.max(gaps)) / 2.0
    assert cosa == pytest.approx(math.cos(alpha), abs=1e-12)
    # the cap polytope {w : d_i·w <= v cos α} reaches exactly v at its farthest vertex
    v = 0.7
    hs = np.hstack([D, np.full((D.shape[0], 1), -v * cosa)])
    verts = HalfspaceIntersection(hs, np.zeros(dim)).intersections
    far = float(np.max(np.linalg.norm(verts, axis=1)))
    assert far <= v * (1 + 1e-12)
    assert far == pytest.approx(v, rel=1e-9)
    # and it holds the ball of radius v cos α (each row's distance from 0 is v cos α)
    assert float(np.min(-hs[:, -1])) == pytest.approx(v * cosa)


def test_cap_directions_refuse_other_dimensions() -> None:
    with pytest.raises(InvalidParameter, match="dim"):
        speed_cap_directions(4)


# ------------------------------------------------------------------------- the state machine
def test_safety_mode_values_order_and_refusal() -> None:
    assert [m.value for m in SafetyMode] == ["normal", "reduced", "stop"]
    assert SafetyMode("reduced") is SafetyMode.REDUCED
    assert SafetyMode.REDUCED == "reduced"
    assert SafetyMode.NORMAL.rank < SafetyMode.REDUCED.rank < SafetyMode.STOP.rank
    with pytest.raises(InvalidParameter, match="mode"):
        SafetyMode("slow")


def _oscillation() -> list[float]:
    """In from 0.2 m outside, 40 swings of ±15 mm about the boundary, then out to 0.2 m."""
    path = list(np.linspace(-0.2, 0.0, 21))
    for _ in range(40):
        path += [0.015, -0.015]
    return path + list(np.linspace(-0.015, -0.2, 20))


def test_hysteresis_band_stops_chatter() -> None:
    robot = PointRobot()
    rows = ModeRows(robot, zones=[ModeZone(BOX, name="cell")], exit_distance=0.02)
    modes = [rows.update(_at(x), time=0.01 * k) for k, x in enumerate(_oscillation())]
    assert rows.switches == 2  # into reduced on the boundary, back to normal 20 mm out
    ev = rows.history
    assert [(e.previous, e.mode, e.cause) for e in ev] == [
        ("normal", "reduced", "zone"),
        ("reduced", "normal", "release"),
    ]
    assert ev[0].zone == "cell"
    assert ev[0].point == "tcp"
    assert ev[0].time == pytest.approx(0.2)  # x = 0 exactly: on the boundary counts (UR)
    first_out = next(k for k, x in enumerate(_oscillation()) if k > 21 and x < -0.02)
    assert ev[1].time == pytest.approx(0.01 * first_out)
    assert modes[-1] is SafetyMode.NORMAL


def test_without_hysteresis_the_same_walk_chatters() -> None:
    rows = ModeRows(PointRobot(), zones=[ModeZone(BOX)], exit_distance=0.0)
    for k, x in enumerate(_oscillation()):
        rows.update(_at(x), time=0.01 * k)
    assert rows.switches == 2 * 40  # every swing in and out switches: what the band prevents


def test_enter_depth_switches_only_deep_enough() -> None:
    rows = ModeRows(PointRobot(), zones=[ModeZone(BOX)], enter_depth=0.05)
    assert rows.update(_at(0.04), time=0.0) is SafetyMode.NORMAL
    assert rows.update(_at(0.06), time=0.1) is SafetyMode.REDUCED


def test_stricter_wins_and_requests_combine() -> None:
    stop_box = ConvexPolytope.box([0.5, -1.0, -1.0], [1.0, 1.0, 1.0])
    rows = ModeRows(
        PointRobot(),
        zones=[ModeZone(BOX, name="near"), ModeZone(stop_box, mode="stop", name="danger")],
        exit_distance=0.0,
    )
    assert rows.update(_at(0.3), time=0.0) is SafetyMode.REDUCED
    assert rows.update(_at(0.7), time=0.1) is SafetyMode.STOP
    assert rows.cause == ("danger", "tcp")
    assert rows.request("reduced", source="curtain") is SafetyMode.STOP  # laxer: no effect
    assert rows.update(_at(0.3), time=0.2) is SafetyMode.REDUCED  # out of danger, still near
    assert rows.update(_at(-0.1), time=0.3) is SafetyMode.REDUCED  # the curtain still asks
    assert rows.cause == ("curtain", None)
    assert rows.request("stop", source="estop") is SafetyMode.STOP  # stricter: at once
    assert rows.history[-1].cause == "request"
    assert rows.history[-1].zone == "estop"
    rows.request("normal", source="estop")
    assert rows.mode is SafetyMode.STOP  # a release waits for the next update
    assert rows.update(_at(-0.1), time=0.4) is SafetyMode.REDUCED
    rows.request(SafetyMode.NORMAL, source="curtain")
    assert rows.update(_at(-0.1), time=0.5) is SafetyMode.NORMAL
    assert [e.mode for e in rows.history] == [
        "reduced", "stop", "reduced", "stop", "reduced", "normal"
    ]  # fmt: skip


def test_dwell_delays_only_the_laxer_switch() -> None:
    rows = ModeRows(PointRobot(), zones=[ModeZone(BOX)], dwell=0.5)
    assert rows.update(_at(0.1), time=1.0) is SafetyMode.REDUCED  # stricter: at once
    assert rows.update(_at(-0.5), time=1.1) is SafetyMode.REDUCED
    assert rows.update(_at(-0.5), time=1.49) is SafetyMode.REDUCED
    assert rows.update(_at(-0.5), time=1.5) is SafetyMode.NORMAL
    assert [e.time for e in rows.history] == [1.0, 1.5]


def test_update_is_once_per_cycle_and_time_moves_forward() -> None:
    rows = ModeRows(PointRobot(), zones=[ModeZone(BOX)])
    rows.update(_at(-0.5), time=2.0)
    assert rows.update(_at(0.5), time=2.0) is SafetyMode.NORMAL  # the same cycle: no change
    assert rows.switches == 0
    with pytest.raises(InvalidInput, match="time"):
        rows.update(_at(0.5), time=1.0)
    assert rows.update(_at(0.5), time=2.004) is SafetyMode.REDUCED
    assert rows.time == 2.004


def test_explain_and_batch_never_change_the_state() -> None:
    rows = ModeRows(
        PointRobot(), zones=[ModeZone(BOX)],
        modes={"reduced": ModeLimits(point_speeds={"tcp": 0.25})},
    )  # fmt: skip
    f = _point_filter(rows)
    rows.update(_at(-0.5), time=0.0)
    u = np.array([2.0, 1.0, 0.0])
    inside = _at(0.5)
    for _ in range(3):
        r = f.explain(inside, u)
        # the zone applies at once in the rows (before the next update) ...
        assert np.linalg.norm(r.output) <= 0.25 * (1 + 1e-9)
        assert any("zone 'zone' at tcp" in nm for nm in r.constraint_names)
    f.filter_batch(np.array([inside, _at(0.2), _at(-1.0)]), np.array([u, u, u]))
    f.shape_batch(np.array([inside, inside]), np.array([u, u]))
    # ... and the state did not move: no switch, no event
    assert rows.mode is SafetyMode.NORMAL
    assert rows.switches == 0
    assert rows.history == ()
    out = f.filter(_at(-0.5), u)
    np.testing.assert_allclose(out, u)  # outside: the normal mode caps nothing
    assert rows.update(inside, time=DT) is SafetyMode.REDUCED
    assert rows.switches == 1


# ------------------------------------------------------------------------- stop and caps
def _arm_limits(**kw: Any) -> JointLimits:
    return JointLimits(LO, -LO, max_speed=np.full(7, 1.5), **kw)


def test_stop_gives_zero_and_says_why() -> None:
    rows = ModeRows(ARM, max_speed=np.full(7, 1.5))
    f = SafetyFilter(ARM, limits=_arm_limits(), dt=DT, providers=[rows])
    rows.update(Q0, time=0.0)
    rows.request("stop", source="light curtain")
    r = f.explain(Q0, np.array([0.3, -0.2, 0.1, 0.0, 0.5, -0.4, 0.2]))
    assert np.all(r.output == 0.0)
    assert r.active_names
    assert all("request 'light curtain'" in nm for nm in r.active_names if nm.startswith("mode"))
    assert "mode stop (request 'light curtain'): joint 0 speed (lower)" in r.constraint_names


def test_joint_scale_and_per_joint_caps() -> None:
    caps = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7])
    rows = ModeRows(
        ARM, max_speed=np.full(7, 1.5),
        modes={"normal": ModeLimits(joint_scale=0.8), "reduced": ModeLimits(max_speed=caps)},
    )  # fmt: skip
    f = SafetyFilter(ARM, limits=_arm_limits(), dt=DT, providers=[rows])
    u = np.full(7, 5.0)
    np.testing.assert_allclose(f.filter(Q0, u), np.full(7, 1.2))  # 0.8 x 1.5
    rows.request("reduced")
    np.testing.assert_allclose(f.filter(Q0, u), caps)  # below the normal 1.2: the smaller


def _fd_jacobian(q: np.ndarray, point: str = "tcp", h: float = 1e-6) -> np.ndarray:
    """Central differences of the arm's forward kinematics (not the library's Jacobian)."""
    J = np.empty((3, q.shape[0]))
    for j in range(q.shape[0]):
        e = np.zeros_like(q)
        e[j] = h
        J[:, j] = (ARM.fk(q + e, point) - ARM.fk(q - e, point)) / (2 * h)
    return J


def test_tcp_cap_holds_in_closed_loop() -> None:
    cap = 0.25
    rows = ModeRows(
        ARM, points=["tcp", "elbow"],
        modes={"reduced": ModeLimits(point_speeds={"tcp": cap, "elbow": 0.3})},
    )  # fmt: skip
    f = SafetyFilter(ARM, limits=_arm_limits(), dt=DT, providers=[rows])
    rows.request("reduced", source="test")
    rng = np.random.default_rng(7)
    q = Q0.copy()
    speeds, elbow = [], []
    for k in range(150):
        u = rng.normal(scale=1.5, size=7)
        rows.update(q, time=k * DT)
        x = f.filter(q, u)
        speeds.append(float(np.linalg.norm(_fd_jacobian(q) @ x)))
        elbow.append(float(np.linalg.norm(_fd_jacobian(q, "elbow") @ x)))
        q = q + x * DT
    assert max(speeds) <= cap * (1 + 1e-6)
    assert max(elbow) <= 0.3 * (1 + 1e-6)
    # the cap binds: most cycles run at the cap's inner radius or above (the loss of the
    # inner approximation is at most 1 - cos α = 11.4 %)
    assert float(np.median(speeds)) >= 0.886 * cap * (1 - 1e-6)


def test_switch_to_stricter_caps_holds_at_once_and_drops_acceleration_rows() -> None:
    rows = ModeRows(ARM, modes={"reduced": ModeLimits(point_speeds={"tcp": 0.05})})
    lim = _arm_limits(max_acceleration=np.full(7, 2.0))
    f = SafetyFilter(ARM, limits=lim, dt=DT, providers=[rows])
    u = np.array([1.0, 0.5, 0.0, 0.5, 0.0, 0.5, 0.0])
    f.reset(velocity=u)  # moving steadily at u
    assert np.linalg.norm(_fd_jacobian(Q0) @ u) > 0.3
    rows.request("reduced")
    r = f.explain(Q0, u)
    assert np.linalg.norm(_fd_jacobian(Q0) @ r.output) <= 0.05 * (1 + 1e-6)
    assert r.rate_override
    assert "acceleration" in r.dropped


# ------------------------------------------------------------------------- slowdown
def _box_distance(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    return float(np.linalg.norm(p - np.clip(p, lo, hi)))


def test_slowdown_ramp_values() -> None:
    z = SlowdownZone(BOX, far_speed=1.0, near_speed=0.2, distance=0.5)
    assert z.speed_cap(0.0) == 0.2
    assert z.speed_cap(-0.3) == 0.2  # inside
    assert z.speed_cap(0.25) == pytest.approx(0.6)  # halfway: (0.2 + 1.0) / 2
    assert z.speed_cap(0.5) == math.inf  # beyond the band: no cap
    with pytest.raises(InvalidParameter, match="far_speed"):
        SlowdownZone(BOX, far_speed=0.1, near_speed=0.2, distance=0.5)


@pytest.mark.parametrize(
    ("p", "d"),
    [
        ([-0.25, 0.0, 0.0], 0.25),  # in front of a face
        ([-0.3, -1.45, 0.0], math.hypot(0.3, 0.45)),  # facet gap 0.45, distance 0.54: no cap
        ([-0.1, -1.2, 0.0], math.hypot(0.1, 0.2)),  # off an edge, in the band
        ([0.5, 0.0, 0.0], 0.0),  # inside
        ([-0.8, 0.0, 0.0], 0.8),  # far
    ],
)
def test_slowdown_rows_cap_the_point_by_its_distance(p: list[float], d: float) -> None:
    pa = np.array(p)
    assert _box_distance(pa, np.array([0.0, -1.0, -1.0]), np.ones(3)) == pytest.approx(d)
    z = SlowdownZone(BOX, far_speed=1.0, near_speed=0.2, distance=0.5)
    f = _point_filter(SlowdownRows(PointRobot(), [z]))
    u = np.array([3.0, 1.0, -0.5])
    x = f.filter(pa, u)
    if d >= 0.5:
        np.testing.assert_allclose(x, u)  # beyond the band: untouched
        return
    expect = 0.2 + 0.8 * d / 0.5  # the ramp, by hand
    _D, cosa = speed_cap_directions(3)
    assert np.linalg.norm(x) <= expect * (1 + 1e-9)
    assert np.linalg.norm(x) >= expect * cosa * (1 - 1e-9)


# ------------------------------------------------------------------------- time to collision
def test_ttc_row_keeps_time_to_collision_in_closed_loop() -> None:
    T = 0.5
    lo, hi = np.array([0.0, -0.2, -0.2]), np.array([0.4, 0.2, 0.2])
    zone = ConvexPolytope.box(lo, hi)
    rows = ApproachRows(PointRobot(), [ApproachZone(zone, time_to_collision=T)])
    f = _point_filter(rows)
    p = np.array([-0.6, 0.15, 0.05])
    u = np.array([1.0, 0.0, 0.0])  # straight at the zone, 1 m/s
    ratios = []
    for _ in range(400):
        x = f.filter(p, u)
        d0 = _box_distance(p, lo, hi)
        p = p + x * DT
        d1 = _box_distance(p, lo, hi)
        closing = (d0 - d1) / DT
        if closing > 1e-9:
            ratios.append(d0 / closing)
        assert d1 > 0.0
    assert min(ratios) >= T * (1 - 1e-6)
    assert min(ratios) <= T * 1.05  # it binds: the point approaches as fast as allowed
    assert _box_distance(p, lo, hi) < 0.05  # and gets close


def test_ttc_row_inside_allows_no_deeper() -> None:
    zone = ConvexPolytope.box([0.0, -0.2, -0.2], [0.4, 0.2, 0.2])
    rows = ApproachRows(PointRobot(), [ApproachZone(zone, time_to_collision=0.5, name="table")])
    f = _point_filter(rows)
    r = f.explain(np.array([0.05, 0.0, 0.0]), np.array([1.0, 0.3, 0.0]))  # 5 cm in, via x = 0
    assert r.output[0] <= 1e-12
    assert "approach 'table' on tcp (-0.050 m, T 0.5 s)" in r.active_names


# ------------------------------------------------------------------------- UR planes and errors
def test_a_ur_trigger_reduced_plane_becomes_a_mode_zone() -> None:
    from velfence.io.zones import ur_safety_planes

    planes = ur_safety_planes(
        [
            {"name": "floor", "normal": [0, 0, 1], "offset": 0.0, "mode": "both"},
            {"name": "door", "normal": [-1, 0, 0], "offset": -0.5, "mode": "trigger_reduced"},
        ],
        bounds={"lower": [-2, -2, -1], "upper": [2, 2, 2]},
    )
    door = next(pl for pl in planes.planes if pl.mode == "trigger_reduced")
    assert "door" in planes.ignored
    # UR: reduced on the side opposite to the plane's arrow: normal · p <= offset, in the bounds
    cell = ConvexPolytope.box([-2, -2, -1], [2, 2, 2])
    zone = ConvexPolytope(
        np.vstack([-door.normal, cell.normals]), np.concatenate([[-door.offset], cell.offsets])
    )
    rows = ModeRows(PointRobot(), zones=[ModeZone(zone, name=door.name)])
    assert rows.update(_at(0.3), time=0.0) is SafetyMode.NORMAL
    assert rows.update(_at(0.5), time=0.1) is SafetyMode.REDUCED  # on the plane
    assert rows.update(_at(0.49), time=0.2) is SafetyMode.REDUCED  # within 20 mm
    assert rows.update(_at(0.47), time=0.3) is SafetyMode.NORMAL


def test_bad_configurations_are_refused() -> None:
    robot = PointRobot()
    with pytest.raises(InvalidParameter, match="stop"):
        ModeRows(robot, modes={"stop": ModeLimits()})
    with pytest.raises(InvalidParameter, match="joint_scale"):
        ModeRows(robot, modes={"reduced": ModeLimits(joint_scale=0.5)})
    with pytest.raises(InvalidParameter, match="elbow"):
        ModeRows(robot, modes={"reduced": ModeLimits(point_speeds={"elbow": 0.1})})
    with pytest.raises(InvalidParameter, match="2-D"):
        ModeRows(robot, zones=[ModeZone(ConvexPolytope.box([0, 0], [1, 1]))])
    with pytest.raises(InvalidParameter, match="joint_scale"):
        ModeLimits(joint_scale=1.5)
    with pytest.raises(InvalidParameter, match="mode"):
        ModeZone(BOX, mode="slow")
    with pytest.raises(InvalidParameter, match="polytope"):
        ApproachZone("box", time_to_collision=1.0)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="time_to_collision"):
        ApproachZone(BOX, time_to_collision=0.0)
    rows = ModeRows(robot)
    with pytest.raises(InvalidInput, match="position"):
        rows.update([0.0, np.nan, 0.0], time=0.0)
    with pytest.raises(InvalidParameter, match="mode"):
        rows.request("fast")


def test_rows_of_a_planar_robot() -> None:
    robot = PointRobot(2)
    zone = ConvexPolytope.box([0.0, -1.0], [1.0, 1.0])
    rows = ModeRows(
        robot, zones=[ModeZone(zone)], modes={"reduced": ModeLimits(point_speeds={"tcp": 0.1})}
    )
    ctx = RowContext(np.array([0.2, 0.0]), np.zeros(2), None, DT, frame_of(robot, [0.2, 0.0]))
    blk = rows.rows(ctx)
    assert blk is not None
    assert blk.G.shape == (8, 2)
    np.testing.assert_allclose(blk.b, -0.1 * math.cos(math.pi / 8))


def test_a_zone_watches_only_its_points() -> None:
    tcp, elbow = ARM.fk(Q0), ARM.fk(Q0, "elbow")
    around_tcp = ConvexPolytope.box(tcp - 0.1, tcp + 0.1)
    around_elbow = ConvexPolytope.box(elbow - 0.1, elbow + 0.1)
    assert not around_tcp.contains(elbow)
    rows = ModeRows(
        ARM, points=["tcp", "elbow"],
        zones=[ModeZone(around_tcp, name="tool only", points=("elbow",))],
    )  # fmt: skip
    assert rows.update(Q0, time=0.0) is SafetyMode.NORMAL  # the TCP is in, but not watched
    rows = ModeRows(ARM, zones=[ModeZone(around_elbow, name="elbow", points=("elbow",))])
    assert rows.update(Q0, time=0.0) is SafetyMode.REDUCED
    assert (rows.history[0].zone, rows.history[0].point) == ("elbow", "elbow")


def test_history_keeps_the_last_events_and_counts_all() -> None:
    rows = ModeRows(PointRobot(), zones=[ModeZone(BOX)], exit_distance=0.0, history=3)
    for k, x in enumerate([0.5, -0.5] * 4):
        rows.update(_at(x), time=float(k))
    assert rows.switches == 8
    assert [e.time for e in rows.history] == [5.0, 6.0, 7.0]
    assert rows.history[-1].previous is SafetyMode.REDUCED
    assert rows.history[-1].mode is SafetyMode.NORMAL
