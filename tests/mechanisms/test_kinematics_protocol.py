"""DHChain, PlanarArm and Puma560 satisfy the Kinematics protocol of the safety filter.

Every named point's Jacobian is checked against central finite differences of its ``fk``, and
the tool point against the existing ``end_effector`` / ``ee_jacobian`` / ``Puma560.position``.
"""

from __future__ import annotations

import numpy as np
import pytest

from velfence.errors import InvalidInput
from velfence.filter import Kinematics
from velfence.mechanisms.chain import DHChain, PlanarArm
from velfence.mechanisms.puma560 import Puma560

ROBOTS = {
    "seven_dof": DHChain.seven_dof(tool=(0.0, 0.02, 0.05)),
    "ur5e": DHChain.ur5e(),
    "puma560-chain": DHChain.puma560(tool=(0.01, 0.0, 0.1)),
    "puma560": Puma560(tool=(0.02, -0.01, 0.08)),
    "puma560-craig": Puma560(convention="craig"),
    "planar": PlanarArm((0.5, 0.8, 0.3, 0.6), base=(0.2, -0.1)),
}


def _configurations(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-2.0, 2.0, (5, n))


@pytest.mark.parametrize("name", list(ROBOTS))
def test_satisfies_the_protocol(name: str) -> None:
    robot = ROBOTS[name]
    assert isinstance(robot, Kinematics)
    assert "tcp" in robot.points
    assert len(robot.joint_names) == robot.dof
    assert len(set(robot.joint_names)) == robot.dof


@pytest.mark.parametrize("name", list(ROBOTS))
def test_every_point_jacobian_matches_finite_differences(name: str) -> None:
    robot = ROBOTS[name]
    h = 1e-6
    for q in _configurations(robot.dof):
        for point in robot.points:
            J = robot.jacobian(q, point)
            fd = np.column_stack(
                [
                    (robot.fk(q + h * e, point) - robot.fk(q - h * e, point)) / (2 * h)
                    for e in np.eye(robot.dof)
                ]
            )
            assert J.shape == fd.shape
            np.testing.assert_allclose(J, fd, atol=1e-8, err_msg=f"{name} {point}")


@pytest.mark.parametrize("name", ["seven_dof", "ur5e", "puma560-chain", "planar"])
def test_tcp_agrees_with_end_effector(name: str) -> None:
    robot = ROBOTS[name]
    for q in _configurations(robot.dof, seed=1):
        np.testing.assert_array_equal(robot.fk(q), robot.end_effector(q))
        np.testing.assert_array_equal(robot.jacobian(q), robot.ee_jacobian(q))


def test_puma560_keeps_its_pose_api_and_agrees_with_it() -> None:
    robot = ROBOTS["puma560"]
    for q in _configurations(6, seed=2):
        assert robot.fk(q).shape == (4, 4)
        np.testing.assert_allclose(robot.fk(q, "tcp"), robot.position(q), atol=1e-15)
        np.testing.assert_allclose(robot.jacobian(q, "tcp"), robot.jacobian(q)[:3], atol=1e-15)
        np.testing.assert_allclose(robot.angular_jacobian(q), robot.jacobian(q)[3:], atol=1e-15)


def test_named_points_are_the_argued_frames() -> None:
    arm = DHChain.seven_dof()
    q = _configurations(7, seed=3)[0]
    P = arm.joint_positions(q)
    np.testing.assert_array_equal(arm.fk(q, "elbow"), P[3])
    np.testing.assert_array_equal(arm.fk(q, "wrist"), P[5])
    np.testing.assert_allclose(arm.fk(q, "flange"), arm.frames(q)[7, :3, 3])
    # the wrist centre of the spherical wrists: the last three axes meet there
    for chain in (DHChain.seven_dof(), DHChain.puma560()):
        F = chain.frames(q[: chain.dof])
        w = chain.fk(q[: chain.dof], "wrist")
        for i in range(chain.dof - 3, chain.dof):
            z, o = F[i, :3, 2], F[i, :3, 3]
            assert np.linalg.norm(np.cross(z, w - o)) < 1e-12


def test_ur5e_matches_the_published_zero_pose() -> None:
    # At q = 0 the UR5e (published DH) stretches along -x: flange at x = a2 + a3,
    # y = -(d4 + d6), z = d1 - d5.
    arm = DHChain.ur5e()
    np.testing.assert_allclose(
        arm.fk(np.zeros(6)), [-0.425 - 0.3922, -(0.1333 + 0.0996), 0.1625 - 0.0997], atol=1e-12
    )
    assert arm.joint_names[0] == "shoulder_pan_joint"


def test_unknown_points_are_refused() -> None:
    arm = DHChain.seven_dof()
    with pytest.raises(InvalidInput, match="point"):
        arm.fk(np.zeros(7), "knee")
    with pytest.raises(InvalidInput, match="point"):
        arm.jacobian(np.zeros(7), 3)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="point"):
        arm.fk(np.zeros(7), "joint7")
