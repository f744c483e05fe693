import dataclasses
import math

import numpy as np
import pytest

from velfence.apps.teleop.resolved_rate import ResolvedRate, angle_axis, rotation_from_angle_axis
from velfence.apps.teleop.servo import FirstOrderServo, PDGravityServo
from velfence.apps.teleop.trajectory import CartesianTrajectory, execute, straight_line
from velfence.errors import InvalidInput, InvalidParameter
from velfence.mechanisms.puma560 import Puma560

Q_START = np.array([-1.05628, -2.1085, 0.05893, 0.17227, -0.74605, 0.01345])  # §7.1 traj. 1


def _pose(R, p):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


@pytest.fixture(scope="module")
def puma():
    return Puma560()


@pytest.fixture
def line():
    T0 = _pose(rotation_from_angle_axis([0.3, -1.0, 0.2], 0.8), [0.2, 0.6, -0.3])
    R1 = rotation_from_angle_axis([1.0, 1.0, 0.0], 0.9) @ T0[:3, :3]
    T1 = _pose(R1, [0.2 + 0.06, 0.6 - 0.08, -0.3])  # D = 0.1 m exactly
    return T0, T1


# ------------------------------------------------------------------------------------------
# Generator
# ------------------------------------------------------------------------------------------


def test_endpoints_are_exact(line):
    T0, T1 = line
    tr = straight_line(T0, T1, spacing=0.003)
    assert np.array_equal(tr.poses[0], T0)
    assert np.array_equal(tr.poses[-1], T1)
    assert np.array_equal(tr.start, T0)
    assert np.array_equal(tr.end, T1)


def test_via_spacing_count_and_times(line):
    T0, T1 = line
    tr = straight_line(T0, T1, spacing=0.003, rate=250.0)
    assert tr.distance == pytest.approx(0.1)
    assert tr.n_steps == 34  # ceil(0.1 / 0.003) = ceil(33.33)
    steps = np.linalg.norm(np.diff(tr.positions, axis=0), axis=1)
    assert steps.max() <= 0.003
    np.testing.assert_allclose(tr.times, np.arange(35) / 250.0, atol=1e-15)
    assert tr.duration == pytest.approx(34 / 250.0)
    # an exact multiple does not get an extra via point from rounding
    assert straight_line(T0, T1, spacing=0.1 / 40).n_steps == 40


def test_positions_lie_on_the_straight_line_at_constant_speed(line):
    T0, T1 = line
    tr = straight_line(T0, T1, spacing=0.001)
    d = (T1[:3, 3] - T0[:3, 3]) / 0.1
    rel = tr.positions - T0[:3, 3]
    perp = rel - np.outer(rel @ d, d)
    assert np.max(np.linalg.norm(perp, axis=1)) < 1e-15
    steps = np.linalg.norm(np.diff(tr.positions, axis=0), axis=1)
    np.testing.assert_allclose(steps, 0.1 / tr.n_steps, rtol=1e-9)
    assert tr.speed == pytest.approx(0.1 / tr.duration)


def test_orientation_turns_about_one_fixed_axis_at_constant_rate(line):
    T0, T1 = line
    tr = straight_line(T0, T1, spacing=0.004)
    phi = angle_axis(T0[:3, :3].T @ T1[:3, :3])[1]
    assert tr.angle == pytest.approx(phi)
    assert tr.angle == pytest.approx(0.9)  # a rotation turned by 0.9 rad about a base axis
    np.testing.assert_allclose(tr.axis, np.array([1.0, 1.0, 0.0]) / math.sqrt(2), atol=1e-12)
    for a, b in zip(tr.poses[:-1], tr.poses[1:], strict=True):
        k, dphi = angle_axis(b[:3, :3] @ a[:3, :3].T)  # increment, in the base frame
        assert dphi == pytest.approx(tr.angle / tr.n_steps, abs=1e-12)
        np.testing.assert_allclose(k, tr.axis, atol=1e-6)


def test_twist_integrates_to_the_displacement(line):
    T0, T1 = line
    tr = straight_line(T0, T1, spacing=0.002, rate=200.0)
    dt = np.diff(tr.times)
    np.testing.assert_allclose((tr.twists[:-1, :3] * dt[:, None]).sum(0), T1[:3, 3] - T0[:3, 3])
    np.testing.assert_allclose((tr.twists[:-1, 3:] * dt[:, None]).sum(0), tr.angle * tr.axis)
    assert np.array_equal(tr.twists[-1], np.zeros(6))


def test_sample_matches_via_points_and_clamps(line):
    T0, T1 = line
    tr = straight_line(T0, T1, spacing=0.01)
    for i in (0, 3, tr.n_steps):
        np.testing.assert_allclose(tr.sample(tr.times[i]), tr.poses[i], atol=1e-14)
    np.testing.assert_allclose(tr.sample(-1.0), T0, atol=1e-15)
    np.testing.assert_allclose(tr.sample(1e9), T1, atol=1e-14)
    with pytest.raises(InvalidInput, match="t: expected a finite time"):
        tr.sample(math.nan)


def test_pure_rotation_duration_rule():
    T0 = _pose(np.eye(3), [0.1, 0.5, -0.2])
    T1 = _pose(rotation_from_angle_axis([0, 0, 1], 0.5), [0.1, 0.5, -0.2])
    tr = straight_line(T0, T1, angular_spacing=0.01, rate=200.0)
    assert tr.distance == 0.0
    assert tr.n_steps == 50  # 0.5 rad / 0.01 rad
    assert tr.duration == pytest.approx(0.25)
    assert tr.angular_speed == pytest.approx(2.0)
    assert np.all(tr.positions == T0[:3, 3])


def test_pure_rotation_default_rule_is_half_a_radian_per_second():
    # The 'T'+'A' alignment (§6.4): the thesis's N = D / (V_r dt) is 0 for D = 0; ours is
    # N = ceil(φ / angular_spacing) with the default 2.5 mrad at 200 Hz, i.e. ω_r = 0.5 rad/s.
    T0 = _pose(np.eye(3), [0.1, 0.5, -0.2])
    phi = math.radians(40.0)
    T1 = _pose(rotation_from_angle_axis([1.0, -1.0, 0.5], phi), [0.1, 0.5, -0.2])
    tr = straight_line(T0, T1)
    assert tr.n_steps == math.ceil(phi / 0.0025) == 280
    assert tr.duration == pytest.approx(1.4)
    assert abs(tr.duration - phi / 0.5) <= 1.0 / tr.rate  # φ / ω_r within one playback period
    assert tr.angular_speed <= 0.5


def test_identical_poses_give_one_step():
    T = _pose(np.eye(3), [0.1, 0.2, 0.3])
    tr = straight_line(T, T)
    assert tr.n_steps == 1
    assert tr.angle == 0.0


def test_timing_linear_vs_max():
    T0 = _pose(np.eye(3), [0.0, 0.0, 0.0])
    T1 = _pose(rotation_from_angle_axis([0, 1, 0], 1.0), [0.01, 0.0, 0.0])
    lin = straight_line(T0, T1, spacing=0.002, angular_spacing=0.0025)
    mx = straight_line(T0, T1, spacing=0.002, angular_spacing=0.0025, timing="max")
    assert lin.n_steps == 5  # thesis: the translation alone sets N
    assert mx.n_steps == 400  # 1 rad / 2.5 mrad


def test_trajectory_is_immutable(line):
    tr = straight_line(*line)
    for arr in (tr.poses, tr.times, tr.twists, tr.axis, tr.start, tr.end):
        assert not arr.flags.writeable
    with pytest.raises(dataclasses.FrozenInstanceError):
        tr.rate = 1.0  # type: ignore[misc]


def test_generator_validates(line):
    T0, T1 = line
    with pytest.raises(InvalidParameter, match="spacing must be finite and > 0"):
        straight_line(T0, T1, spacing=0.0)
    with pytest.raises(InvalidParameter, match="rate must be finite and > 0"):
        straight_line(T0, T1, rate=-5)
    with pytest.raises(InvalidParameter, match="timing must be one of"):
        straight_line(T0, T1, timing="fast")
    skew = T1.copy()
    skew[:3, :3] *= 1.1
    with pytest.raises(InvalidInput, match="expected a rigid transform"):
        straight_line(T0, skew)
    with pytest.raises(InvalidInput, match=r"expected shape \(4, 4\)"):
        straight_line(T0, np.eye(3))


# ------------------------------------------------------------------------------------------
# Executor
# ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def short_line(puma):
    T0 = puma.fk(Q_START)
    T1 = _pose(rotation_from_angle_axis([0, 0, 1], 0.1) @ T0[:3, :3], T0[:3, 3] + [0.03, 0.02, 0])
    return straight_line(T0, T1, spacing=0.0005, rate=200.0)


def test_ideal_servo_follows_the_via_points(puma, short_line):
    ex = execute(short_line, puma, Q_START)
    assert ex.t.shape == (short_line.n_steps + 1,)
    # second-order (linearisation) error of one step: (0.5 mm)², (1.4 mrad)² in size
    assert ex.tracking_error.max() < 1e-6
    assert ex.orientation_error.max() < 1e-5
    assert ex.path_deviation.max() < 1e-6
    assert not ex.q.flags.writeable


def test_executor_converges_from_an_offset_start_under_servo_lag(puma, short_line):
    q_off = Q_START + np.array([0.004, -0.006, 0.006, 0.01, 0.0, 0.0])
    offset = np.linalg.norm(puma.position(q_off) - short_line.start[:3, 3])
    assert offset > 3e-3
    servo = FirstOrderServo(time_constant=0.01)
    ex = execute(short_line, puma, q_off, servo=servo, settle=40)
    assert ex.tracking_error[0] == pytest.approx(offset)
    assert ex.tracking_error[-1] < 1e-7
    assert ex.orientation_error[-1] < 1e-7
    # the offset is gone within the first 20 cycles (0.1 s), not just at the end
    assert ex.tracking_error[20:40].max() < 0.01 * offset


def test_self_correction_removes_servo_sag_that_commanded_feedback_keeps(puma, short_line):
    load = np.array([0.0, 40.0, 15.0, 0.0, 0.0, 0.0])

    def servo():
        return PDGravityServo(
            kp=2500.0, inertia=0.1, gravity=lambda q: load, compensation_error=0.25
        )

    measured = execute(short_line, puma, Q_START, servo=servo(), settle=100)
    commanded = execute(short_line, puma, Q_START, servo=servo(), feedback="commanded", settle=100)
    # the sag: 0.25 · load / Kp on joints 2 and 3, a few mrad, i.e. millimetres at the tool
    sagged = commanded.q_cmd[-1] - 0.25 * load / 2500.0
    expected_miss = np.linalg.norm(puma.position(sagged) - short_line.end[:3, 3])
    assert commanded.tracking_error[-1] == pytest.approx(expected_miss, rel=1e-3)
    assert commanded.tracking_error[-1] > 1e-3
    assert measured.tracking_error[-1] < 1e-6


def test_open_loop_via_to_via_drifts_with_sag(puma, short_line):
    load = np.array([0.0, 40.0, 15.0, 0.0, 0.0, 0.0])
    servo = PDGravityServo(kp=2500.0, inertia=0.1, gravity=lambda q: load, compensation_error=0.25)
    ex = execute(short_line, puma, Q_START, servo=servo, feedback="none", settle=100)
    assert ex.tracking_error[-1] > 1e-3


def test_correction_gain_stabilises_a_slow_servo(puma, short_line):
    # PD joints at √(Kp/I) = 50 rad/s (8 Hz): several 5 ms cycles of lag in the integral loop.
    def servo():
        return PDGravityServo(kp=2500.0, inertia=1.0)

    full = execute(short_line, puma, Q_START, servo=servo(), settle=300)
    gentle = execute(short_line, puma, Q_START, servo=servo(), settle=300, correction_gain=0.2)
    assert full.tracking_error[-1] > 1e-2  # the thesis's gain-1 increment diverges here
    # bounded by the servo's own lag, speed x 2/ω = 0.1 m/s x 40 ms = 4 mm
    assert gentle.tracking_error.max() < 4e-3
    assert gentle.tracking_error[-1] < 1e-6


def test_velocity_commanded_servo(puma, short_line):
    servo = FirstOrderServo(time_constant=0.0, command="velocity")
    ex = execute(short_line, puma, Q_START, servo=servo)
    assert ex.tracking_error.max() < 1e-6


def test_executor_records_resolver_diagnostics(puma, short_line):
    ex = execute(short_line, puma, Q_START, resolver=ResolvedRate(puma, inverse="jinv"))
    np.testing.assert_allclose(ex.w[0], puma.manipulability(Q_START), rtol=1e-12)
    np.testing.assert_allclose(ex.det, np.abs(ex.det) * np.sign(ex.det))
    assert np.all(ex.k == 0.0)
    assert ex.max_speed == pytest.approx(float(np.max(np.abs(ex.qdot))))
    assert np.array_equal(ex.qdot[-1], np.zeros(6))


def test_manipulability_is_recorded_at_the_feedback_joints(puma, short_line):
    # With a sagging servo the measured and the commanded joints differ by a few mrad; w and
    # det J are those resolved rate used: at q for "measured", at q_cmd otherwise.
    load = np.array([0.0, 40.0, 15.0, 0.0, 0.0, 0.0])

    def servo():
        return PDGravityServo(
            kp=2500.0, inertia=0.1, gravity=lambda q: load, compensation_error=0.25
        )

    for feedback, joints in (("measured", "q"), ("commanded", "q_cmd"), ("none", "q_cmd")):
        ex = execute(short_line, puma, Q_START, servo=servo(), feedback=feedback, settle=20)
        Q = getattr(ex, joints)
        assert np.max(np.abs(ex.q - ex.q_cmd)) > 1e-3  # the two really differ
        for c in (0, len(ex.t) // 2, len(ex.t) - 1):
            J = puma.jacobian(Q[c])
            assert ex.w[c] == pytest.approx(puma.manipulability(Q[c]), rel=1e-12), feedback
            assert ex.det[c] == pytest.approx(np.linalg.det(J), rel=1e-9), feedback


def test_path_deviation_is_the_distance_to_the_segment(puma, short_line):
    servo = FirstOrderServo(time_constant=0.02)
    ex = execute(short_line, puma, Q_START, servo=servo, settle=40)
    a, b = short_line.start[:3, 3], short_line.end[:3, 3]
    for p, dev in zip(ex.position, ex.path_deviation, strict=True):
        s = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        assert dev == pytest.approx(np.linalg.norm(p - (a + s * (b - a))), abs=1e-15)
    assert ex.path_deviation.max() > 1e-6  # the lag makes it non-trivial


def test_executor_validates(puma, short_line):
    with pytest.raises(InvalidParameter, match="expected a CartesianTrajectory"):
        execute("line", puma, Q_START)
    with pytest.raises(InvalidParameter, match="feedback must be one of"):
        execute(short_line, puma, Q_START, feedback="none-at-all")
    with pytest.raises(InvalidParameter, match="substeps: expected an int >= 1"):
        execute(short_line, puma, Q_START, substeps=0)
    with pytest.raises(InvalidParameter, match=r"correction_gain: expected a value in \(0, 1\]"):
        execute(short_line, puma, Q_START, correction_gain=1.5)
    with pytest.raises(InvalidParameter, match=r"expected an arm with fk\(q\) and jacobian\(q\)"):
        execute(short_line, object(), Q_START)
    with pytest.raises(InvalidInput, match=r"q0 \[rad\]: expected finite values, got \[nan"):
        execute(short_line, puma, np.full(6, np.nan))
    assert isinstance(short_line, CartesianTrajectory)
