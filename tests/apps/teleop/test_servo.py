import math

import numpy as np
import pytest

from velfence.apps.teleop.servo import FirstOrderServo, JointServo, PDGravityServo
from velfence.errors import InvalidInput, InvalidParameter

Q0 = np.array([0.1, -0.2, 0.3])
CMD = np.array([0.4, 0.0, -0.1])


@pytest.mark.parametrize(
    "servo",
    [FirstOrderServo(time_constant=0.01), PDGravityServo(kp=100.0, inertia=1.0)],
    ids=["first-order", "pd-gravity"],
)
def test_servos_keep_the_joint_servo_contract(servo: JointServo) -> None:
    """JointServo's contract: reset() starts at rest where asked; holding the position keeps
    it; a step toward a command moves every joint toward it and reports the true position."""
    assert servo.command == "position"
    np.testing.assert_array_equal(servo.reset(Q0), Q0)  # no noise: measured = true
    np.testing.assert_array_equal(servo.q, Q0)
    np.testing.assert_allclose(servo.step(Q0, 0.01), Q0, atol=1e-15)  # at rest, held
    before = np.abs(CMD - servo.q)
    q = servo.step(CMD, 0.01)
    assert q.shape == (3,)
    np.testing.assert_array_equal(q, servo.q)
    assert np.all(np.abs(CMD - q) < before)
    with pytest.raises(ValueError, match="read-only"):
        servo.q[0] = 1.0  # the state is not writable through the property


# ------------------------------------------------------------------------------------------
# First-order lag
# ------------------------------------------------------------------------------------------


def test_position_lag_closed_form():
    tau, dt = 0.02, 0.005
    s = FirstOrderServo(time_constant=tau)
    s.reset(Q0)
    q = s.step(CMD, dt)
    np.testing.assert_allclose(q, CMD + (Q0 - CMD) * math.exp(-dt / tau), atol=1e-15)


def test_exact_discretisation_does_not_depend_on_the_step():
    a, b = FirstOrderServo(time_constant=0.02), FirstOrderServo(time_constant=0.02)
    a.reset(Q0)
    b.reset(Q0)
    for _ in range(10):
        qa = a.step(CMD, 0.001)
    qb = b.step(CMD, 0.010)
    np.testing.assert_allclose(qa, qb, atol=1e-14)


def test_zero_time_constant_tracks_perfectly():
    s = FirstOrderServo(time_constant=0.0)
    s.reset(Q0)
    assert np.array_equal(s.step(CMD, 0.005), CMD)


def test_per_joint_time_constants():
    s = FirstOrderServo(time_constant=[0.0, 0.01, 1.0])
    s.reset(Q0)
    q = s.step(CMD, 0.01)
    expected = CMD + (Q0 - CMD) * np.exp(-0.01 / np.array([1e-300, 0.01, 1.0]))
    np.testing.assert_allclose(q, expected, atol=1e-15)


def test_velocity_command_closed_form():
    # v(t) = c (1 - e^{-t/τ}) from rest, so q(t) = q0 + c t - c τ (1 - e^{-t/τ}).
    tau, c = 0.05, np.array([1.0, -2.0, 0.5])
    s = FirstOrderServo(time_constant=tau, command="velocity")
    s.reset(Q0)
    for _ in range(37):
        q = s.step(c, 0.003)
    t = 37 * 0.003
    np.testing.assert_allclose(q, Q0 + c * t - c * tau * (1 - math.exp(-t / tau)), atol=1e-12)
    np.testing.assert_allclose(s.qdot, c * (1 - math.exp(-t / tau)), atol=1e-12)


def test_noise_is_seeded_reported_only_and_reset_reseeds():
    s = FirstOrderServo(time_constant=0.0, noise_std=0.01, seed=7)
    m0 = s.reset(Q0)
    samples = np.array([s.step(Q0, 0.001) for _ in range(4000)])
    assert np.array_equal(s.q, Q0)  # the true state carries no noise
    assert samples.std(axis=0) == pytest.approx(np.full(3, 0.01), rel=0.05)
    assert abs(samples.mean() - Q0.mean()) < 1e-3
    assert np.array_equal(s.reset(Q0), m0)  # same seed, same first sample


def test_joint_limits_clip_and_stop():
    lim = [[-1.0, 1.0], [-1.0, 1.0], [-1.0, 0.5]]
    s = FirstOrderServo(time_constant=0.0, joint_limits=lim, command="velocity")
    s.reset([0.0, 0.0, 2.0])  # clipped into the limits
    assert s.q[2] == 0.5
    for _ in range(100):
        s.step([5.0, -5.0, 0.0], 0.01)
    np.testing.assert_array_equal(s.q, [1.0, -1.0, 0.5])
    np.testing.assert_array_equal(s.qdot, [0.0, 0.0, 0.0])


def test_errors():
    s = FirstOrderServo(time_constant=0.01)
    with pytest.raises(InvalidInput, match=r"call reset\(q0\) before step"):
        s.step(CMD, 0.001)
    s.reset(Q0)
    with pytest.raises(InvalidInput, match=r"command \[rad\]: expected shape \(3,\), got shape"):
        s.step([1.0, 2.0], 0.001)
    with pytest.raises(InvalidInput, match=r"command \[rad\]: expected finite values, got \[nan"):
        s.step([np.nan, 0, 0], 0.001)
    with pytest.raises(InvalidInput, match=r"q0 \[rad\]: expected shape \(n,\) with n >= 1, got"):
        s.reset([[0.0, 1.0]])
    with pytest.raises(InvalidInput, match=r"q0 \[rad\]: expected numbers, got str 'home'"):
        s.reset("home")
    with pytest.raises(InvalidInput, match=r"dt must be finite and > 0 \(s\)"):
        s.step(CMD, 0.0)
    with pytest.raises(InvalidParameter, match="time_constant must be finite and >= 0"):
        FirstOrderServo(time_constant=-1.0)
    with pytest.raises(InvalidParameter, match="noise_std must be finite and >= 0"):
        FirstOrderServo(time_constant=0.0, noise_std=-0.1)
    with pytest.raises(InvalidParameter, match=r"seed: expected an int in \[0, 2\*\*63 - 1\]"):
        FirstOrderServo(time_constant=0.0, seed=1.5)
    with pytest.raises(InvalidParameter, match="command must be one of"):
        FirstOrderServo(time_constant=0.0, command="torque")
    with pytest.raises(InvalidParameter, match="expected finite lower < upper"):
        FirstOrderServo(time_constant=0.0, joint_limits=[[1.0, -1.0]])
    with pytest.raises(InvalidInput, match="expected 2 joints to match joint_limits"):
        FirstOrderServo(time_constant=0.0, joint_limits=[[-1, 1], [-1, 1]]).reset(Q0)
    with pytest.raises(InvalidInput, match="time_constant: expected a scalar or 3 values"):
        FirstOrderServo(time_constant=[0.1, 0.2]).reset(Q0)


# ------------------------------------------------------------------------------------------
# PD + gravity compensation on one rigid body per joint
# ------------------------------------------------------------------------------------------


def _settle(s, cmd, seconds, dt=0.001):
    for _ in range(round(seconds / dt)):
        q = s.step(cmd, dt)
    return q


def test_pd_with_exact_compensation_reaches_the_command():
    g = lambda q: 20.0 * np.sin(q)  # noqa: E731 - a position-dependent load
    s = PDGravityServo(kp=400.0, inertia=0.5, gravity=g)
    s.reset(Q0)
    np.testing.assert_allclose(_settle(s, CMD, 3.0), CMD, atol=1e-8)


def test_pd_static_offset_from_a_compensation_error():
    # I q'' = Kp (c - q) - Kd q' + (1 - e) g - g  =>  q_ss = c - e g / Kp.
    load = np.array([30.0, -10.0, 5.0])
    kp, e = 600.0, 0.2
    s = PDGravityServo(kp=kp, inertia=0.3, gravity=lambda q: load, compensation_error=e)
    s.reset(Q0)
    np.testing.assert_allclose(_settle(s, CMD, 3.0), CMD - e * load / kp, atol=1e-8)


def test_default_derivative_gain_is_critical_no_overshoot():
    s = PDGravityServo(kp=900.0, inertia=1.0)
    assert s.kd[0] == pytest.approx(60.0)  # 2 √(Kp I)
    s.reset([0.0])
    traj = [s.step([1.0], 0.001)[0] for _ in range(2000)]
    assert max(traj) <= 1.0 + 1e-9
    assert traj[-1] == pytest.approx(1.0, abs=1e-6)


def test_pd_second_order_closed_form_without_damping():
    # kd = 0: q(t) = c + (q0 - c) cos(ω t); semi-implicit Euler with a tiny step.
    s = PDGravityServo(kp=100.0, inertia=1.0, kd=0.0, max_substep=1e-5)
    s.reset([0.0])
    q = s.step([1.0], 0.2)
    assert q[0] == pytest.approx(1.0 - math.cos(10.0 * 0.2), abs=1e-4)


def test_torque_saturation_limits_acceleration():
    s = PDGravityServo(kp=1e4, inertia=1.0, max_torque=10.0, max_substep=1e-4)
    s.reset([0.0])
    q = s.step([1.0], 0.1)
    # Saturated throughout: constant acceleration τ_max/I from rest, which semi-implicit Euler
    # with N sub-steps integrates to a T²/2 · (1 + 1/N).
    assert q[0] == pytest.approx(0.5 * 10.0 * 0.1**2 * (1 + 1e-3), rel=1e-12)


def test_pd_validates():
    with pytest.raises(
        InvalidParameter,
        match=r"max_substep \(with kp, kd, friction and inertia\): expected a sub-step short",
    ):
        PDGravityServo(kp=1e6, inertia=1e-3, max_substep=1e-3)
    with pytest.raises(InvalidParameter, match="kp must be finite and > 0"):
        PDGravityServo(kp=0.0, inertia=1.0)
    with pytest.raises(InvalidParameter, match="expected scalars or arrays of one common length"):
        PDGravityServo(kp=[1.0, 2.0], inertia=[1.0, 2.0, 3.0])
    with pytest.raises(InvalidParameter, match="gravity: expected a callable"):
        PDGravityServo(kp=1.0, inertia=1.0, gravity=3.0)
    s = PDGravityServo(kp=1.0, inertia=1.0, gravity=lambda q: np.array([np.nan]))
    s.reset([0.0])
    with pytest.raises(InvalidInput, match="gravity"):
        s.step([0.0], 0.001)
