"""The simulated traded-control world (Session) and its viewer protocol."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from velfence.apps.teleop.laser import LaserRangeSensor
from velfence.apps.teleop.modes import ModeManager
from velfence.apps.teleop.scene import Plane, Scene, scene_to_dicts
from velfence.apps.teleop.servo import FirstOrderServo
from velfence.apps.teleop.session import (
    GRIPPER_LENGTH,
    OMNI_TO_PUMA,
    Session,
    default_robot,
    omni_to_puma,
    ready_pose,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.mechanisms.puma560 import Puma560

RATE = 100.0  # a coarser control rate keeps these tests quick


def _session(**kw):
    return Session(rate=RATE, modes=ModeManager(rate=RATE, **kw.pop("modes", {})), **kw)


def test_snapshot_and_scene_are_json_and_complete():
    s = _session()
    s.advance(0.3)
    snap = s.snapshot()
    json.dumps(snap)
    for key in ("t", "mode", "clutch", "q", "joints", "tool", "laser", "fixture", "status", "task"):
        assert key in snap
    assert snap["t"] == pytest.approx(0.3)
    assert snap["mode"] == "teleop"
    assert snap["clutch"] is False
    assert len(snap["q"]) == 6
    assert np.shape(snap["joints"]) == (7, 3)
    assert np.shape(snap["tool"]) == (4, 4)
    np.testing.assert_allclose(snap["joints"][-1], np.array(snap["tool"])[:3, 3], atol=1e-12)
    assert snap["laser"]["point"] is not None
    assert snap["fixture"] is None
    assert snap["task"] == {
        "holding": False,
        "done": False,
        "hand": "open",
        "collisions": 0,
        "cup": [0.2, 0.58, -0.6],
    }
    prims = s.scene_primitives()
    json.dumps(prims)
    assert {p["name"]: p["type"] for p in prims} == {
        "table": "plane",
        "cup": "cylinder",
        "folder": "box",
        "destination": "disk",
    }
    assert next(p for p in prims if p["name"] == "cup")["dynamic"] is True
    # one scene format: the session's export is scene_to_dicts with the cup marked dynamic
    assert prims == scene_to_dicts(s.scene, dynamic=("cup",))
    assert [p["dynamic"] for p in prims] == [False, True, False, False]


def test_protocol_input_validation():
    s = _session()
    with pytest.raises(InvalidInput, match="expected one of"):
        s.press("Q")
    with pytest.raises(InvalidInput, match=r"linear \[m/s\]: expected shape \(3,\), got shape"):
        s.jog([0.0, 0.0], [0.0, 0.0, 0.0])
    with pytest.raises(InvalidInput, match=r"linear \[m/s\]: expected finite values"):
        s.jog([0.0, math.nan, 0.0], [0.0, 0.0, 0.0])
    with pytest.raises(InvalidInput, match=r"angular \[rad/s\]: expected numbers of shape"):
        s.jog([0.0, 0.0, 0.0], "fast")
    with pytest.raises(InvalidParameter, match=r"q0 \[rad\]: expected shape \(6,\), got shape"):
        _session(q0=np.zeros(5))
    with pytest.raises(InvalidInput, match="dt"):
        s.advance(-0.1)
    with pytest.raises(InvalidParameter, match="rate"):
        Session(rate=200.0, modes=ModeManager(rate=100.0))


def test_the_laser_is_cast_from_the_true_pose_not_the_noisy_measured_one():
    # A resting arm whose encoders report 5 mrad of noise: the beam stays where the true joints
    # put it, so a noise-free laser reads the true distance to the table exactly. Casting from
    # the measured pose moved the spot by millimetres every cycle.
    table = Scene({"table": Plane((0.0, 0.0, -0.6), (0.0, 0.0, 1.0))})
    servo = FirstOrderServo(
        time_constant=0.01, noise_std=5e-3, seed=3, joint_limits=default_robot().joint_limits
    )
    laser = LaserRangeSensor(noise_v=0.0, quantum_v=0.0)
    s = Session(
        scene=table, servo=servo, laser=laser, rate=RATE, modes=ModeManager(laser=laser, rate=RATE)
    )
    s.advance(1.0)  # more than the 50-sample window at 90 Hz
    hit = laser.true_hit(s.true_pose, table)
    assert hit is not None
    reading = s.observe().distance
    assert reading is not None
    assert reading == pytest.approx(hit.distance, abs=1e-9)
    # the noise is really there: the measured pose the control layer sees is off the true one
    assert np.linalg.norm(s.pose[:3, 3] - s.true_pose[:3, 3]) > 1e-4
    measured_hit = laser.true_hit(s.pose, table)
    assert measured_hit is not None
    assert abs(measured_hit.distance - hit.distance) > 1e-4
    np.testing.assert_allclose(s.observe().pose, s.true_pose, atol=0.0)


def test_advance_accumulates_partial_cycles():
    s = _session()
    for _ in range(25):
        s.advance(0.004)  # 0.4 cycles each at 100 Hz
    assert s.t == pytest.approx(0.1)


def test_nothing_is_sent_while_disengaged_and_nothing_is_buffered():
    s = _session()
    q0 = s.q
    s.jog([0.05, 0.0, 0.0], [0.0, 0.0, 0.3])
    s.advance(1.0)
    np.testing.assert_array_equal(s.q, q0)  # start-up: disengaged
    s.press("C")
    s.advance(0.5)
    moved = s.pose[:3, 3] - ready_pose()[1][:3, 3]
    assert moved[0] == pytest.approx(0.025, abs=2e-3)
    s.press("C")  # disengage (index) while the hand keeps moving
    s.advance(0.3)  # the servo settles on the last command
    q1 = s.q
    s.advance(1.0)
    np.testing.assert_allclose(s.q, q1, atol=1e-9)
    s.jog(np.zeros(3), np.zeros(3))
    s.press("C")  # re-engage: no jump from motion made while disengaged
    s.advance(0.5)
    np.testing.assert_allclose(s.q, q1, atol=1e-9)


def test_a_on_the_session_stops_20_cm_short_with_the_spot_fixed():
    s = _session()
    s.advance(1.0)  # let the 50-sample filter settle
    spot = s.observe().spot
    D = s.observe().distance
    s.press("A")
    assert s.snapshot()["segment"] == "approach"
    while s.modes.busy:
        s.advance(0.1)
    origin, direction = s.laser.beam(s.pose)
    # 20 cm from the laser head to the spot, along the beam (the laser's ~mm noise aside).
    assert np.linalg.norm(spot - origin) == pytest.approx(0.20, abs=3e-3)
    np.testing.assert_allclose(np.cross(spot - origin, direction), 0.0, atol=1e-3)
    assert D > 0.3
    assert s.snapshot()["mode"] == "teleop"
    assert s.events[-1].kind == "segment-end"


def test_s_scaling_factors_measured_on_the_robot_motion():
    s = _session()
    s.advance(1.0)
    s.press("C")
    s.press("S")
    K = s.pose[:3, 2].copy()
    L = np.cross(K, [1.0, 0.0, 0.0])
    L /= np.linalg.norm(L)
    for direction, gain in ((K, 3.0), (-K, 3.0), (L, 0.2)):
        p0 = s.pose[:3, 3].copy()
        hand = 0.01 * direction
        s.jog(hand, np.zeros(3))
        s.advance(1.0)
        s.jog(np.zeros(3), np.zeros(3))
        s.advance(0.2)  # servo settles
        moved = s.pose[:3, 3] - p0
        assert moved @ direction / 0.01 == pytest.approx(gain, rel=0.02)
        assert np.linalg.norm(moved - (moved @ direction) * direction) < 1e-3


def test_d_then_g_a_path_legs_on_the_session():
    s = _session(modes={"speed": 0.2})
    s.advance(1.0)
    s.press("D")
    dest = s.modes.destination
    ends = []
    for _leg in range(3):
        s.press("G")
        s.press("A")
        while s.modes.busy:
            s.advance(0.1)
        ends.append(s.pose[:3, 3].copy())
        s.press("G")
        s.press("A")
    p0 = ready_pose()[1][:3, 3]
    np.testing.assert_allclose(ends[0], p0 + np.array([0.0, 0.0, 0.3]), atol=2e-3)
    np.testing.assert_allclose(ends[1][:2], dest[:2], atol=2e-3)
    assert ends[2][2] == pytest.approx(dest[2] + 0.35, abs=2e-3)
    # The wrist-centre path (trace) rose 0.3 m before moving across.
    tr = s.trace
    assert tr[:, 3].max() == pytest.approx(p0[2] + 0.3, abs=3e-3)


def _grasp_pose(cup_top=-0.5, depth=0.03):
    robot = Puma560()
    q, T = ready_pose(robot)
    T = np.array(T)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])  # tool z straight down
    T[:3, 3] = [0.2, 0.58, cup_top - depth + GRIPPER_LENGTH]
    return robot.ik_nearest(T, q)


def test_grasp_carry_and_place_on_the_destination():
    s = _session(q0=_grasp_pose())
    s.press("H")
    s.advance(1.1)
    assert s.holding
    assert s.snapshot()["task"]["hand"] == "closed"
    s.press("C")
    dest = np.array([-0.18, 0.68])
    for v, dur in (((0, 0, 0.1), 3.0), ((-0.19, 0.05, 0.0), 2.0), ((0, 0, -0.1), 2.95)):
        s.jog(v, np.zeros(3))
        s.advance(dur)
    s.jog(np.zeros(3), np.zeros(3))
    s.advance(0.3)
    cup = s.cup
    assert np.linalg.norm(cup[:2] - dest) < 0.02
    assert -0.6 < cup[2] < -0.6 + 0.03
    assert s.collisions == 0  # the cup bottom cleared the folder top by 6 cm
    s.press("H")
    s.advance(1.1)
    assert s.done
    assert not s.holding
    assert s.snapshot()["task"]["done"] is True


def test_missed_grasp_and_collision_count():
    s = _session(q0=_grasp_pose(depth=0.1))  # fingertips too deep: no grasp
    s.press("H")
    s.advance(1.1)
    assert not s.holding
    assert s.missed_grasps == 1
    s.press("C")
    s.jog([0.0, 0.0, -0.1], np.zeros(3))  # push the fingertips into the table
    s.advance(0.5)
    assert s.collisions == 1
    assert s.collision_log[0][1] == "table"


def test_omni_map_is_self_inverse():
    v = np.array([0.01, 0.02, 0.03])
    np.testing.assert_array_equal(omni_to_puma(v), [-0.01, 0.03, 0.02])
    np.testing.assert_array_equal(omni_to_puma(omni_to_puma(v)), v)
    assert np.linalg.det(OMNI_TO_PUMA) == pytest.approx(1.0)


def test_a_scene_without_a_cup_has_no_task_object():
    from velfence.apps.teleop.scene import door_scene

    s = Session(scene=door_scene(), rate=RATE, modes=ModeManager(rate=RATE))
    s.advance(0.5)
    snap = s.snapshot()
    json.dumps(snap)
    assert snap["task"]["cup"] is None
    assert s.cup is None
    assert {p["type"] for p in s.scene_primitives()} == {"plane"}
    s.press("H")
    s.advance(1.1)
    assert not s.holding
