"""Traded-control mode semantics of Khokar 2009 (ModeManager on an ideal pose follower)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.apps.teleop.laser import LaserRangeSensor
from velfence.apps.teleop.modes import ModeManager, aligned_rotation
from velfence.apps.teleop.resolved_rate import angle_axis, rotation_from_angle_axis
from velfence.errors import InvalidInput, InvalidParameter
from velfence.shaping.fixtures import LineFixture

RATE = 200.0
LASER = LaserRangeSensor()


def _pose(tilt=0.3, p=(0.1, 0.45, -0.05)):
    """Tool pointing down, tilted by ``tilt`` about a skew axis."""
    R = rotation_from_angle_axis([0.6, -0.8, 0.0], math.pi - tilt) @ np.diag([1.0, 1.0, 1.0])
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def _follow(m: ModeManager, T, *, t=0.0, limit=20000):
    """Run the manager's segment on an ideal arm that moves exactly by the twist."""
    h = 1.0 / m.rate
    T = np.array(T)
    for _ in range(limit):
        if not m.busy:
            return T, t
        t += h
        tw = m.control(t=t, pose=T, linear=np.zeros(3), angular=np.zeros(3))
        T[:3, 3] += h * tw[:3]
        w = tw[3:] * h
        if np.linalg.norm(w) > 0:
            T[:3, :3] = rotation_from_angle_axis(w, np.linalg.norm(w)) @ T[:3, :3]
    raise AssertionError("segment did not finish")


def _pointing_at(spot, distance=0.4):
    """A tool pose whose laser reads ``distance`` at ``spot`` (base frame) [m]."""
    T = _pose()
    T[:3, 3] = np.asarray(spot) - T[:3, :3] @ (LASER.offset + np.array([0.0, 0.0, distance]))
    return T


def _record_destination(m: ModeManager, spot) -> None:
    """Record ``spot`` as the destination the way an operator does: point the laser, press D."""
    m.press("D", t=0.0, pose=_pointing_at(spot), distance=0.4)
    np.testing.assert_allclose(m.destination, spot, atol=1e-12)


def test_startup_is_teleoperation_disengaged_and_nothing_is_sent():
    m = ModeManager(laser=LASER, rate=RATE)
    T = _pose()
    assert m.mode == "teleop"
    assert not m.clutch
    tw = m.control(t=0.0, pose=T, linear=[0.1, 0.0, 0.0], angular=[0.0, 0.2, 0.0])
    np.testing.assert_array_equal(tw, 0.0)
    m.press("C", t=0.0, pose=T, distance=None)
    assert m.clutch
    tw = m.control(t=0.0, pose=T, linear=[0.1, 0.0, 0.0], angular=[0.0, 0.2, 0.0])
    np.testing.assert_array_equal(tw, [0.1, 0.0, 0.0, 0.0, 0.2, 0.0])
    m.press("c", t=0.1, pose=T, distance=None)
    assert not m.clutch
    assert [e.kind for e in m.events] == ["clutch", "clutch"]


def test_unknown_key_and_bad_inputs_are_refused():
    m = ModeManager(laser=LASER)
    with pytest.raises(InvalidInput, match="expected one of"):
        m.press("X", t=0.0, pose=_pose(), distance=0.4)
    with pytest.raises(InvalidInput, match="distance"):
        m.press("D", t=0.0, pose=_pose(), distance=-1.0)
    with pytest.raises(InvalidParameter, match="presses_per_point"):
        ModeManager(laser=LASER, presses_per_point=0)
    with pytest.raises(InvalidParameter, match="fixture_options"):
        ModeManager(laser=LASER, fixture_options={"stiff": 1.0})


def test_a_needs_a_reading_and_a_spot_beyond_the_standoff():
    m = ModeManager(laser=LASER)
    m.press("A", t=0.0, pose=_pose(), distance=None)
    m.press("A", t=0.0, pose=_pose(), distance=0.15)
    assert [e.kind for e in m.events] == ["refused", "refused"]
    assert m.mode == "teleop"


def test_a_stops_20_cm_short_along_the_beam_then_hands_back():
    m = ModeManager(laser=LASER, rate=RATE)
    T0 = _pose()
    D = 0.43
    spot = LASER.target_transform(T0, D, with_offset=True)[:3, 3]
    m.press("C", t=0.0, pose=T0, distance=D)
    m.press("A", t=0.0, pose=T0, distance=D)
    assert m.mode == "autonomous"
    assert m.segment.kind == "approach"
    # Keys other than the clutch are ignored while the segment runs.
    m.press("S", t=0.0, pose=T0, distance=D)
    assert m.events[-1].kind == "ignored"
    T1, _ = _follow(m, T0)
    origin, direction = LASER.beam(T1)
    assert np.linalg.norm(spot - origin) == pytest.approx(0.20, abs=1e-6)
    np.testing.assert_allclose(direction, T0[:3, 2], atol=1e-9)  # orientation unchanged
    np.testing.assert_allclose(origin + 0.20 * direction, spot, atol=1e-6)  # beam still on spot
    assert m.mode == "teleop"
    assert m.clutch  # the operator's clutch state is untouched
    assert m.events[-1].kind == "segment-end"
    assert m.events[-1].key is None


def test_s_toggles_scaled_teleoperation_along_the_beam():
    m = ModeManager(laser=LASER, rate=RATE)
    T = _pose()
    m.press("C", t=0.0, pose=T, distance=None)
    m.press("S", t=0.0, pose=T, distance=None)
    assert m.mode == "teleop"  # refused without a reading
    m.press("S", t=0.0, pose=T, distance=0.4)
    assert m.mode == "scaled"
    K = T[:3, 2]
    tw = m.control(t=0.0, pose=T, linear=0.01 * K, angular=[0.0, 0.0, 0.1])
    np.testing.assert_allclose(tw[:3], 0.03 * K, atol=1e-12)
    np.testing.assert_array_equal(tw[3:], [0.0, 0.0, 0.1])  # orientation not scaled
    start, end = m.line
    np.testing.assert_allclose(end - start, 0.4 * K, atol=1e-12)
    m.press("S", t=0.0, pose=T, distance=0.4)
    assert m.mode == "teleop"
    assert m.line is None


def test_f_applies_the_line_fixture():
    m = ModeManager(laser=LASER, fixture_options={"stiffness": 300.0})
    T = _pose()
    m.press("C", t=0.0, pose=T, distance=None)
    m.press("F", t=0.0, pose=T, distance=0.4)
    assert m.mode == "fixture"
    assert isinstance(m.fixture, LineFixture)
    T2 = np.array(T)
    T2[:3, 3] += [0.005, 0.0, 0.0]
    v = np.array([0.0, 0.01, 0.0])
    tw = m.control(t=0.0, pose=T2, linear=v, angular=np.zeros(3))
    np.testing.assert_allclose(tw[:3], m.fixture.shape(T2[:3, 3], v))
    m.press("S", t=0.0, pose=T, distance=0.4)  # S replaces F
    assert m.mode == "scaled"
    assert m.fixture is None


def test_d_records_the_laser_spot_with_the_offset():
    m = ModeManager(laser=LASER)
    T = _pose()
    m.press("D", t=0.0, pose=T, distance=0.5)
    np.testing.assert_allclose(m.destination, LASER.laser_point(T, 0.5))


def _record_plane(m, points_T, distance=0.5):
    for T in points_T:
        m.press("P", t=0.0, pose=T, distance=distance)
        m.press("P", t=0.0, pose=T, distance=distance)


def test_p_twice_per_point_records_a_ccw_plane():
    m = ModeManager(laser=LASER)
    T = _pose(tilt=0.0)
    m.press("P", t=0.0, pose=T, distance=0.5)
    assert m.plane_points == ()
    m.press("P", t=0.0, pose=T, distance=0.5)
    assert len(m.plane_points) == 1
    shifts = [(0.1, 0.0, 0.0), (0.0, 0.1, 0.0)]  # with P1 at the origin: CCW seen from above
    poses = []
    for s in shifts:
        Ts = np.array(T)
        Ts[:3, 3] += s
        poses.append(Ts)
    _record_plane(m, poses)
    np.testing.assert_allclose(m.plane_normal, [0.0, 0.0, 1.0], atol=1e-12)
    assert m.events[-1].kind == "plane"


def test_collinear_plane_points_are_refused():
    m = ModeManager(laser=LASER)
    poses = []
    for x in (0.0, 0.05, 0.1):
        T = _pose(tilt=0.0)
        T[:3, 3] += (x, 0.0, 0.0)
        poses.append(T)
    _record_plane(m, poses)
    assert m.plane_normal is None
    assert m.events[-1].kind == "refused"
    assert m.plane_points == ()


def test_g_a_runs_three_legs_up_across_down_with_toggle_presses():
    m = ModeManager(laser=LASER, rate=RATE, speed=0.4)
    T = _pose()
    m.press("G", t=0.0, pose=T, distance=None)
    m.press("A", t=0.0, pose=T, distance=None)
    assert m.events[-1].kind == "refused"  # no destination yet
    dest = np.array([-0.18, 0.68, -0.6])
    T_d = np.array(T)
    _record_destination(m, dest)
    starts, ends = [], []
    for leg in (1, 2, 3):
        m.press("G", t=0.0, pose=T, distance=None)
        m.press("A", t=0.0, pose=T, distance=None)
        assert m.segment.kind == f"leg{leg}"
        starts.append(T[:3, 3].copy())
        T, _ = _follow(m, T)
        ends.append(T[:3, 3].copy())
        np.testing.assert_allclose(T[:3, :3], T_d[:3, :3], atol=1e-9)  # orientation constant
        assert m.legs_done == leg
        assert m.mode == "teleop"
        m.press("G", t=0.0, pose=T, distance=None)  # switches the path mode off
        m.press("A", t=0.0, pose=T, distance=None)
        assert not m.busy
    np.testing.assert_allclose(ends[0], starts[0] + [0.0, 0.0, 0.3], atol=1e-6)
    np.testing.assert_allclose(ends[1], [dest[0], dest[1], ends[0][2]], atol=1e-6)
    np.testing.assert_allclose(ends[2], [dest[0], dest[1], dest[2] + 0.35], atol=1e-6)
    assert m.legs_done == 0
    assert "path complete" in m.status


def test_g_a_without_toggle_off_starts_the_next_leg_directly():
    m = ModeManager(laser=LASER, rate=RATE, speed=0.4, toggle_off=False)
    _record_destination(m, [-0.18, 0.68, -0.6])
    T = _pose()
    for leg in (1, 2):
        m.press("G", t=0.0, pose=T, distance=None)
        m.press("A", t=0.0, pose=T, distance=None)
        assert m.segment.kind == f"leg{leg}"
        T, _ = _follow(m, T)


def test_prefix_is_cancelled_by_another_key():
    m = ModeManager(laser=LASER)
    T = _pose()
    m.press("G", t=0.0, pose=T, distance=0.4)
    assert m.prefix == "G"
    m.press("D", t=0.0, pose=T, distance=0.4)
    assert m.prefix is None
    assert m.destination is not None
    assert "cancelled" in m.events[-2].message


def test_t_a_aligns_the_tool_axis_with_the_plane_normal():
    m = ModeManager(laser=LASER, rate=RATE)
    # counter-clockwise seen from above: the recorded normal is +z
    spots = [[0.0, 0.5, -0.6], [0.2, 0.5, -0.6], [0.0, 0.7, -0.6]]
    _record_plane(m, [_pointing_at(p, 0.5) for p in spots])
    np.testing.assert_allclose(m.plane_normal, [0.0, 0.0, 1.0], atol=1e-12)
    T0 = _pose(tilt=0.4)
    m.press("T", t=0.0, pose=T0, distance=None)
    m.press("A", t=0.0, pose=T0, distance=None)
    assert m.segment.kind == "align"
    assert m.segment.trajectory.distance == 0.0
    T1, t = _follow(m, T0)
    np.testing.assert_allclose(T1[:3, 2], [0.0, 0.0, -1.0], atol=1e-6)
    np.testing.assert_allclose(T1[:3, 3], T0[:3, 3], atol=1e-9)  # position unchanged
    assert t == pytest.approx(0.4 / 0.3, abs=0.05)  # pure rotation at the angular speed


def test_aligned_rotation_faithful_keeps_x_closest_and_geodesic_is_least_rotation():
    rng = np.random.default_rng(4)
    n = np.array([0.1, -0.2, 1.0])
    z = -n / np.linalg.norm(n)
    for _ in range(30):
        R = rotation_from_angle_axis(rng.normal(size=3), rng.uniform(0.0, 2.5))
        Rf = aligned_rotation(R, n)
        Rg = aligned_rotation(R, n, alignment="geodesic")
        for Ra in (Rf, Rg):
            np.testing.assert_allclose(Ra[:, 2], z, atol=1e-12)
            np.testing.assert_allclose(Ra.T @ Ra, np.eye(3), atol=1e-12)
            assert np.linalg.det(Ra) == pytest.approx(1.0)
        # Faithful (eqs. 55-56): x is the normalised projection of the current x.
        px = R[:, 0] - (R[:, 0] @ z) * z
        np.testing.assert_allclose(Rf[:, 0], px / np.linalg.norm(px), atol=1e-12)
        # Geodesic: no rotation about z gives a smaller total angle.
        best = angle_axis(R.T @ Rg)[1]
        for th in np.linspace(-math.pi, math.pi, 73):
            cand = rotation_from_angle_axis(z, th) @ Rg
            assert angle_axis(R.T @ cand)[1] >= best - 1e-9
        assert angle_axis(R.T @ Rf)[1] >= best - 1e-9
        # Both equal the angle between the tool axis and -n at best (no extra twist).
        assert best == pytest.approx(math.acos(np.clip(R[:, 2] @ z, -1, 1)), abs=1e-9)


def test_aligned_rotation_faithful_equals_geodesic_for_a_tilt_about_x():
    R = rotation_from_angle_axis([1.0, 0.0, 0.0], math.pi - 0.5)
    np.testing.assert_allclose(
        aligned_rotation(R, [0, 0, 1]), aligned_rotation(R, [0, 0, 1], alignment="geodesic"),
        atol=1e-12,
    )  # fmt: skip


def test_aligned_rotation_validates_the_normal():
    R = np.eye(3)
    with pytest.raises(InvalidInput, match=r"normal: expected shape \(3,\), got shape \(2,\)"):
        aligned_rotation(R, [0.0, 1.0])
    with pytest.raises(InvalidInput, match=r"normal: expected finite values, got \[0\.0, nan"):
        aligned_rotation(R, [0.0, math.nan, 1.0])
    with pytest.raises(InvalidInput, match="normal: expected a non-zero vector"):
        aligned_rotation(R, [0.0, 0.0, 0.0])
