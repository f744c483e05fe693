"""The MuJoCo plant (velfence.sim.physics) and the look-ahead for its lag (shaping.lookahead)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from optional import requires
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.filter import SafetyFilter, TwistMode
from velfence.filter.limits import JointLimits, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.shaping.lookahead import LagCompensation
from velfence.sim import simulate

pytestmark = requires("mujoco")

Q0 = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
DT = 2e-3


class Hold:
    """A shaper that passes the command through (the reference is the command)."""

    method = "hold"

    def explain(self, q: np.ndarray, v: np.ndarray) -> object:
        class R:
            output = np.asarray(v, dtype=float)
            zone = "free"

        return R()

    def shape(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.asarray(v, dtype=float)

    def shape_batch(self, Q: np.ndarray, V: np.ndarray) -> np.ndarray:
        return np.asarray(V, dtype=float)


class TcpRate:
    """Unfiltered resolved rate: the TCP twist through the Jacobian's pseudo-inverse."""

    method = "no limit"

    def __init__(self, robot: object) -> None:
        self.robot = robot

    def shape(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.linalg.pinv(self.robot.jacobian(q)) @ np.asarray(v, dtype=float)

    def explain(self, q: np.ndarray, v: np.ndarray) -> object:
        out = self.shape(q, v)

        class R:
            output = out
            zone = "free"

        return R()

    def shape_batch(self, Q: np.ndarray, V: np.ndarray) -> np.ndarray:
        return np.array([self.shape(q, v) for q, v in zip(Q, V, strict=True)])


@pytest.fixture(scope="module")
def robot():
    from velfence.robots import panda

    return panda(radius=0.04)


def _plant(robot, **kw):
    from velfence.sim.physics import MujocoPlant

    return MujocoPlant(robot, **kw)


def test_computed_torque_servo_is_a_first_order_lag_with_gravity(robot) -> None:
    # A step of the joint-3 reference from rest: q̇ = v (1 - exp(-ω t)) in every pose.
    bw = 30.0
    plant = _plant(robot, bandwidth=bw, physics_dt=2.5e-4)
    step = np.zeros(7)
    step[3] = 0.4
    tr = simulate(Hold(), lambda t, q: step, Q0, duration=0.2, dt=DT, plant=plant)
    rec = plant.record
    expected = 0.4 * (1.0 - np.exp(-bw * rec.t))
    assert np.max(np.abs(rec.qvel[:, 3] - expected)) < 0.01 * 0.4
    others = np.delete(rec.qvel, 3, axis=1)
    assert np.max(np.abs(others)) < 1e-3  # M couples joints; the servo decouples them
    assert len(tr) == len(rec.t)
    np.testing.assert_allclose(tr.p, rec.qpos[:, :7], atol=0.0)


def test_zero_reference_holds_the_arm_against_gravity(robot) -> None:
    plant = _plant(robot)
    tr = simulate(Hold(), lambda t, q: np.zeros(7), Q0, duration=0.5, dt=DT, plant=plant)
    assert np.max(np.abs(tr.p - Q0)) < 1e-6
    # Without gravity compensation the same arm would fall: check gravity is really on.
    assert np.max(np.abs(plant.record.effort)) > 1.0


def test_a_fast_servo_approaches_the_ideal_plant(robot) -> None:
    v = np.array([0.2, -0.1, 0.1, 0.2, 0.0, -0.1, 0.3])
    ideal = simulate(Hold(), lambda t, q: v, Q0, duration=0.3, dt=DT)
    fast = simulate(
        Hold(),
        lambda t, q: v,
        Q0,
        duration=0.3,
        dt=DT,
        # The Panda's real effort limits (87/12 N·m) would clip this 2000 rad/s servo's start.
        plant=_plant(robot, bandwidth=2000.0, physics_dt=1e-4, max_effort=1e4),
    )
    # The lag shifts the path by about v / ω.
    assert np.max(np.abs(fast.p - ideal.p)) < 2.0 * np.max(np.abs(v)) / 2000.0


def test_a_push_makes_the_velocity_servo_drift_and_stops_with_it(robot) -> None:
    from velfence.sim.physics import BodyPush

    hand = robot.model.body(robot.model.nbody - 1).name
    push = BodyPush(body=hand, force=[0.0, 0.0, -40.0], start=0.1, duration=0.2)
    plant = _plant(robot, pushes=[push])
    tr = simulate(Hold(), lambda t, q: np.zeros(7), Q0, duration=0.5, dt=DT, plant=plant)
    z = np.array([robot.fk(q)[2] for q in tr.p])
    before = tr.t < 0.1
    assert np.max(np.abs(z[before] - z[0])) < 1e-6
    assert z[-1] < z[0] - 1e-3  # pushed down
    after = tr.t > 0.45  # six servo time constants after the push
    assert np.ptp(z[after]) < 1e-4  # a velocity servo keeps no position memory: stays there


def test_effort_limits_clip_and_are_reported(robot) -> None:
    plant = _plant(robot, max_effort=5.0)
    simulate(Hold(), lambda t, q: np.full(7, 1.0), Q0, duration=0.05, dt=DT, plant=plant)
    rec = plant.record
    assert rec.clipped.any()
    assert np.max(np.abs(rec.effort)) <= 5.0 + 1e-12


def _sphere_scene(robot):
    # A sphere 0.13 m below the TCP; the command drives the TCP straight at it.
    x0 = robot.fk(Q0)
    return SphereObstacle(x0 - np.array([0.0, 0.0, 0.13]), radius=0.05, name="ball")


def test_contacts_are_counted_by_the_simulator(robot) -> None:
    ball = _sphere_scene(robot)
    lim = robot.joint_limits
    limits = JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 2.0))
    down = np.array([0.0, 0.0, -0.3])
    free = _plant(robot, obstacles=[ball])
    simulate(
        TcpRate(robot),
        lambda t, q: down,
        Q0,
        duration=0.6,
        dt=DT,
        plant=free,
    )
    assert free.record.contact_steps > 0
    assert np.max(free.record.contact_depth) > 1e-3
    guarded = _plant(robot, obstacles=[ball])
    f = SafetyFilter(robot, limits=limits, obstacles=[ball], dt=DT, obstacle_buffer=0.05)
    shaper = LagCompensation(TwistMode(f), time_constant=guarded.time_constant, dt=DT, guard=f)
    simulate(shaper, lambda t, q: down, Q0, duration=0.6, dt=DT, plant=guarded)
    assert guarded.record.contact_steps == 0


def _box_run(robot, bandwidth: float, lookahead: bool) -> float:
    lim = robot.joint_limits
    x0 = robot.fk(Q0)
    box = ConvexPolytope.box(x0 - 0.15, x0 + 0.15)
    f = SafetyFilter(
        robot,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 2.0)),
        workspace=WorkspaceLimit(box, buffer=0.05),
        dt=DT,
    )
    plant = _plant(robot, bandwidth=bandwidth)
    shaper = TwistMode(f)
    if lookahead:
        shaper = LagCompensation(shaper, time_constant=plant.time_constant, dt=DT, guard=f)
    tr = simulate(
        shaper, lambda t, q: np.array([0.0, 0.0, -1.0]), Q0, duration=0.5, dt=DT, plant=plant
    )
    d = np.array([box.signed_distances(robot.fk(q)) for q in tr.p]).min(axis=1)
    return max(0.0, -float(d.min()))


def test_servo_lag_eats_the_buffer_and_the_look_ahead_gives_it_back(robot) -> None:
    # 1 m/s into a 0.05 m buffer behind a 1/15 s lag: u T / b = 1.3 > 1/4, an overshoot.
    assert _box_run(robot, 15.0, lookahead=False) > 0.01
    assert _box_run(robot, 15.0, lookahead=True) < 1e-3


def test_lag_compensation_predicts_a_first_order_lag() -> None:
    from velfence import ConvexPolygon, PolygonShaper

    poly = ConvexPolygon([[-10, -10], [10, -10], [10, 10], [-10, 10]])
    lag = LagCompensation(PolygonShaper(poly, buffer=0.1), time_constant=0.05, dt=0.01)
    for _ in range(3):
        lag.shape(np.zeros(2), np.array([1.0, 0.0]))
    v_hat = lag.predicted_velocity
    assert v_hat is not None
    np.testing.assert_allclose(v_hat[0], 1.0 - math.exp(-3 * 0.01 / 0.05), rtol=1e-12)
    # Shaped at p + T v_hat first, then guarded at the measured position p.
    inner = PolygonShaper(poly, buffer=0.1)
    p = np.array([9.895, 0.0])  # 0.105 from the wall, outside the buffer; p + T v_hat is inside
    cmd = np.array([1.0, 0.0])
    ahead = inner.shape(p + 0.05 * v_hat, cmd)
    assert ahead[0] < inner.shape(p, cmd)[0] - 0.05  # the look-ahead brakes
    r = lag.explain(p, cmd)
    np.testing.assert_allclose(r.output, inner.shape(p, ahead), rtol=0, atol=1e-15)
    np.testing.assert_allclose(r.position, p, rtol=0, atol=0)
    lag.reset()
    assert lag.predicted_velocity is None


def test_bad_plant_arguments_name_the_argument(robot) -> None:
    from velfence.sim.physics import BodyPush, MujocoPlant

    with pytest.raises(InvalidParameter, match="joints"):
        MujocoPlant(robot, joints=["nope"])
    with pytest.raises(InvalidParameter, match="transmission"):
        MujocoPlant(robot, actuated=["panda_joint1"])
    with pytest.raises(InvalidParameter, match="pushes: unknown body"):
        MujocoPlant(robot, pushes=[BodyPush(body="nobody", force=[1.0, 0.0, 0.0])])
    with pytest.raises(InvalidParameter, match="obstacles"):
        MujocoPlant(robot, obstacles=[(0.0, 0.0, 0.0)])
    with pytest.raises(InvalidGeometry, match="robot"):
        MujocoPlant("<mujoco><worldbody><body/></mujoco>")
    plant = MujocoPlant(robot, physics_dt=1e-3)
    with pytest.raises(InvalidParameter, match="dt: expected a whole multiple"):
        simulate(Hold(), lambda t, q: np.zeros(7), Q0, duration=0.01, dt=1.5e-3, plant=plant)
    with pytest.raises(InvalidParameter, match="disturbance"):
        simulate(
            Hold(),
            lambda t, q: np.zeros(7),
            Q0,
            duration=0.01,
            dt=1e-3,
            plant=plant,
            disturbance=lambda t, q: np.zeros(7),
        )
    fresh = MujocoPlant(robot)
    with pytest.raises(InvalidInput, match="record"):
        _ = fresh.record
    with pytest.raises(InvalidInput, match="reset"):
        fresh.advance(np.zeros(7), 0.0)


def test_velocity_actuators_track_on_a_two_link_arm() -> None:
    from velfence.robots import dh_mjcf
    from velfence.sim.physics import MujocoPlant

    xml = dh_mjcf(
        [[0.3, 0.0, 0.0, 0.0], [0.25, 0.0, 0.0, 0.0]], joint_limits=[[-3.0, 3.0], [-3.0, 3.0]]
    )
    plant = MujocoPlant(xml, servo="velocity", kv=20.0, gravity=False, physics_dt=5e-4)
    v = np.array([0.5, -0.3])
    tr = simulate(Hold(), lambda t, q: v, np.zeros(2), duration=0.4, dt=1e-3, plant=plant)
    np.testing.assert_allclose(plant.record.qvel[-1], v, rtol=1e-3)
    assert tr.p[-1] @ v > 0.0


def test_measurement_noise_reaches_the_shaper_not_the_physics(robot) -> None:
    from velfence.sim.runner import simulate

    def zero(t: float, q: np.ndarray) -> np.ndarray:
        return np.zeros(7)

    runs = []
    for noise in (0.0, 1e-3):
        plant = _plant(robot, bandwidth=40.0)
        runs.append(simulate(Hold(), zero, Q0, duration=0.2, dt=DT, plant=plant, noise_std=noise))
    quiet, noisy = runs
    # The physics is the same run (a zero command holds the arm: gravity is compensated) ...
    np.testing.assert_allclose(noisy.p, quiet.p, rtol=0, atol=1e-12)
    np.testing.assert_allclose(quiet.p, np.tile(Q0, (len(quiet.p), 1)), rtol=0, atol=1e-6)
    # ... and the shaper saw the noise: per-axis standard deviation about 1 mrad.
    err = noisy.p_measured - noisy.p
    assert 0.8e-3 < float(err.std()) < 1.2e-3
