"""Capsule links of MJCF arms (velfence.robots.capsules) against DHChain and finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from optional import requires
from velfence.errors import InvalidGeometry, InvalidInput
from velfence.mechanisms import DHChain

pytestmark = requires("mujoco")


def test_seven_dof_capsules_equal_the_dh_chain() -> None:
    from velfence.robots import seven_dof

    robot, chain = seven_dof(radius=0.05), DHChain.seven_dof(link_radius=0.05)
    rng = np.random.default_rng(1)
    np.testing.assert_allclose(robot.link_radius, chain.link_radius)
    for _ in range(20):
        q = rng.uniform(-2.0, 2.0, 7)
        np.testing.assert_allclose(robot.joint_positions(q), chain.joint_positions(q), atol=1e-12)
        np.testing.assert_allclose(robot.link_segments(q), chain.link_segments(q), atol=1e-12)
        for link in range(7):
            t = float(rng.uniform())
            np.testing.assert_allclose(
                robot.point_jacobian(q, link, t), chain.point_jacobian(q, link, t), atol=1e-12
            )


def test_panda_point_jacobians_match_finite_differences() -> None:
    from velfence.robots import panda

    robot = panda(radius=0.04)
    rng = np.random.default_rng(2)
    lim = robot.joint_limits
    h = 1e-6
    for _ in range(5):
        q = rng.uniform(lim[:, 0] + 0.1, lim[:, 1] - 0.1)
        for link in range(7):
            t = float(rng.uniform())

            def point(qq: np.ndarray, link: int = link, t: float = t) -> np.ndarray:
                a, b = robot.link_segments(qq)[link]
                return (1.0 - t) * a + t * b

            fd = np.column_stack(
                [(point(q + h * e) - point(q - h * e)) / (2 * h) for e in np.eye(7)]
            )
            np.testing.assert_allclose(robot.point_jacobian(q, link, t), fd, atol=1e-6)


def test_bad_link_arguments_and_missing_sites() -> None:
    from velfence.robots import MujocoRobot, panda

    robot = panda(radius=0.04)
    q = np.zeros(7) + 0.1
    with pytest.raises(InvalidInput, match="link"):
        robot.point_jacobian(q, 7, 0.5)
    with pytest.raises(InvalidInput, match="t: expected a fraction"):
        robot.point_jacobian(q, 0, 1.5)
    bare = MujocoRobot.from_xml(
        '<mujoco><worldbody><body><joint name="j" type="hinge"/><geom size="0.1"/>'
        '<site name="tcp" pos="0 0 1"/></body></worldbody></mujoco>'
    )
    with pytest.raises(InvalidGeometry, match="joint0"):
        bare.link_segments([0.0])


def test_the_serial_chain_interface_runs_the_arm_baselines_and_configuration_control() -> None:
    from velfence.filter import SphereObstacle
    from velfence.filter.limits import JointLimits
    from velfence.redundancy import ConfigurationController
    from velfence.robots import seven_dof
    from velfence.sim.arm_baselines import JointClamp

    robot, chain = seven_dof(radius=0.05), DHChain.seven_dof(link_radius=0.05)
    q = np.array([0.0, 0.4, 0.0, 1.8, 0.0, 0.5, 0.0])
    assert robot.n_links == chain.n_links
    assert robot.task_dim == 3
    np.testing.assert_allclose(robot.end_effector(q), chain.end_effector(q), atol=1e-12)
    np.testing.assert_allclose(robot.ee_jacobian(q), chain.ee_jacobian(q), atol=1e-12)
    ob = [SphereObstacle(center=[0.3, 0.1, 0.6], radius=0.03, influence=0.1)]
    v = np.array([0.0, 0.2, 0.0])
    np.testing.assert_allclose(
        ConfigurationController(robot, ob).shape(q, v),
        ConfigurationController(chain, ob).shape(q, v),
        atol=1e-9,
    )
    hi = np.full(7, 2.9)
    lim = JointLimits(-hi, hi, max_speed=np.full(7, 1.5))
    np.testing.assert_allclose(
        JointClamp(robot, limits=lim).shape(q, v),
        JointClamp(chain, limits=lim).shape(q, v),
        atol=1e-9,
    )
