"""Physical parameters of the generated MJCF: masses, centres of mass, inertias, limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("mujoco")

from velfence.errors import InvalidParameter
from velfence.robots import MujocoRobot, dh_mjcf, mdh_mjcf, panda, puma560, seven_dof, ur5e

G = 9.81
_H = math.pi / 2.0


def _holding_torque(robot: MujocoRobot, q: np.ndarray) -> np.ndarray:
    """MuJoCo's bias force at rest: the joint torques that hold the arm against gravity."""
    mj = robot._mj
    data = mj.MjData(robot.model)
    data.qpos[:] = q
    mj.mj_forward(robot.model, data)
    return np.array(data.qfrc_bias)


def _craig(a: float, alpha: float, d: float, q: float) -> np.ndarray:
    ca, sa, cq, sq = math.cos(alpha), math.sin(alpha), math.cos(q), math.sin(q)
    return np.array(
        [
            [cq, -sq, 0.0, a],
            [sq * ca, cq * ca, -sa, -sa * d],
            [sq * sa, cq * sa, ca, ca * d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def _dh(a: float, alpha: float, d: float, q: float) -> np.ndarray:
    ca, sa, cq, sq = math.cos(alpha), math.sin(alpha), math.cos(q), math.sin(q)
    return np.array(
        [
            [cq, -sq * ca, sq * sa, a * cq],
            [sq, cq * ca, -cq * sa, a * sq],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def _hold(
    axes: list[tuple[np.ndarray, np.ndarray]], com_world: list[np.ndarray], masses
) -> np.ndarray:
    """Holding torques from joint axes (origin, unit z) and link centres of mass (world)."""
    tau = np.zeros(len(axes))
    for j, (o, z) in enumerate(axes):
        for i in range(j, len(masses)):
            tau[j] += masses[i] * G * np.cross(z, com_world[i] - o)[2]
    return tau


# Gaz et al. 2019 (as shipped by franka_description), typed again here from the paper's table.
PANDA_A = (0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088)
PANDA_D = (0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0)
PANDA_ALPHA = (0.0, -_H, _H, _H, -_H, _H, _H)
PANDA_M = (4.970684, 0.646926, 3.228604, 3.587895, 1.225946, 1.666555, 0.735522)
PANDA_C = (
    (0.003875, 0.002081, -0.04762),
    (-0.003141, -0.02872, 0.003495),
    (0.027518, 0.039252, -0.066502),
    (-0.05317, 0.104419, 0.027454),
    (-0.011953, 0.041065, -0.038437),
    (0.060149, -0.014117, -0.010517),
    (0.010517, -0.004252, 0.061597),
)


def test_panda_gravity_matches_the_published_centres_of_mass() -> None:
    robot = panda()
    rng = np.random.default_rng(11)
    for q in rng.uniform(robot.joint_limits[:, 0], robot.joint_limits[:, 1], size=(20, 7)):
        T = np.eye(4)
        axes, coms = [], []
        for i in range(7):
            T = T @ _craig(PANDA_A[i], PANDA_ALPHA[i], PANDA_D[i], q[i])
            axes.append((T[:3, 3].copy(), T[:3, 2].copy()))
            coms.append((T @ np.append(PANDA_C[i], 1.0))[:3])
        np.testing.assert_allclose(
            _holding_torque(robot, q), _hold(axes, coms, PANDA_M), rtol=0, atol=1e-9
        )


def test_panda_last_joint_inertia_is_the_published_one() -> None:
    # Joint 7 moves link 7 only: M77 = Izz7 + m7 (cx² + cy²) about the joint axis (parallel axes).
    robot = panda()
    mj = robot._mj
    data = mj.MjData(robot.model)
    M = np.zeros((7, 7))
    data.qpos[:] = [0.1, -0.4, 0.2, -2.0, 0.3, 1.5, 0.7]
    mj.mj_forward(robot.model, data)
    mj.mj_fullM(robot.model, data, M)
    expected = 4.815e-3 + 0.735522 * (0.010517**2 + 0.004252**2)
    assert M[6, 6] == pytest.approx(expected, rel=1e-12)


UR5E_DH = (
    (0.0, _H, 0.1625),
    (-0.425, 0.0, 0.0),
    (-0.3922, 0.0, 0.0),
    (0.0, _H, 0.1333),
    (0.0, -_H, 0.0997),
    (0.0, 0.0, 0.0996),
)
UR5E_M = (3.761, 8.058, 2.846, 1.37, 1.3, 0.365)
UR5E_C = (
    (0.0, -0.02561, 0.00193),
    (0.2125, 0.0, 0.11336),
    (0.15, 0.0, 0.0265),
    (0.0, -0.0018, 0.01634),
    (0.0, 0.0018, 0.01634),
    (0.0, 0.0, -0.001159),
)


def test_ur5e_gravity_matches_the_published_centres_of_mass() -> None:
    # Standard DH: link i's centre of mass is given in DH frame i; joint i turns about z_{i-1}.
    robot = ur5e()
    rng = np.random.default_rng(12)
    for q in rng.uniform(-3.0, 3.0, size=(20, 6)):
        T = np.eye(4)
        axes, coms = [], []
        for i in range(6):
            axes.append((T[:3, 3].copy(), T[:3, 2].copy()))
            T = T @ _dh(*UR5E_DH[i], q[i])
            coms.append((T @ np.append(UR5E_C[i], 1.0))[:3])
        np.testing.assert_allclose(
            _holding_torque(robot, q), _hold(axes, coms, UR5E_M), rtol=0, atol=1e-9
        )


@pytest.mark.parametrize(
    ("make", "masses", "velocity", "effort"),
    [
        (panda, PANDA_M, [2.175] * 4 + [2.61] * 3, [87.0] * 4 + [12.0] * 3),
        (ur5e, UR5E_M, [math.pi] * 6, [150.0] * 3 + [28.0] * 3),
        (
            seven_dof,
            (4.0, 4.0, 3.0, 2.7, 1.7, 1.8, 0.3),
            np.radians([85, 85, 100, 75, 130, 135, 135]),
            [320, 320, 176, 176, 110, 40, 40],
        ),
        (puma560, (0.001, 17.4, 4.8, 0.82, 0.34, 0.09), [np.inf] * 6, [np.inf] * 6),
    ],
    ids=["panda", "ur5e", "seven_dof", "puma560"],
)
def test_shipped_masses_and_limits(make, masses, velocity, effort) -> None:
    robot = make()
    n = robot.dof
    np.testing.assert_allclose(robot.model.body_mass[1 : n + 1], masses, rtol=1e-15)
    np.testing.assert_allclose(robot.velocity_limits, velocity, rtol=1e-15)
    np.testing.assert_allclose(robot.effort_limits, effort, rtol=1e-15)
    np.testing.assert_array_equal(robot.model.opt.gravity, [0.0, 0.0, -9.81])  # no <option>
    assert "<option" not in robot.xml
    again = MujocoRobot.from_xml(robot.xml)
    np.testing.assert_array_equal(again.velocity_limits, robot.velocity_limits)
    np.testing.assert_array_equal(again.effort_limits, robot.effort_limits)
    jid = [robot.model.joint(j).id for j in robot.joint_names]
    limited = np.isfinite(robot.effort_limits)
    np.testing.assert_array_equal(robot.model.jnt_actfrclimited[jid], limited)


def test_panda_ships_frankas_acceleration_and_jerk_limits() -> None:
    """Franka's FCI table "Limits for Panda" (the FER), read back by MuJoCo and into limits()."""
    acc = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]
    jerk = [7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0]
    robot = panda()
    np.testing.assert_array_equal(robot.acceleration_limits, acc)
    np.testing.assert_array_equal(robot.jerk_limits, jerk)
    model = robot.model  # MuJoCo's own reading of the custom numerics
    np.testing.assert_array_equal(model.numeric("jerk_limits").data, jerk)
    np.testing.assert_array_equal(model.numeric("acceleration_limits").data, acc)
    again = MujocoRobot.from_xml(robot.xml)
    np.testing.assert_array_equal(again.jerk_limits, jerk)
    lim = robot.limits()
    np.testing.assert_array_equal(lim.max_speed, [2.175] * 4 + [2.61] * 3)
    np.testing.assert_array_equal(lim.max_acceleration, acc)  # type: ignore[arg-type]
    np.testing.assert_array_equal(lim.max_jerk, jerk)  # type: ignore[arg-type]
    np.testing.assert_array_equal(lim.lower, robot.joint_limits[:, 0])
    assert lim.names == robot.joint_names
    # a model without them: +inf, and limits() leaves them out
    assert np.all(np.isinf(ur5e().jerk_limits))
    assert ur5e().limits().max_jerk is None
    with pytest.raises(InvalidParameter, match="velocity_limits: the model gives no speed"):
        puma560().limits()
    with pytest.raises(InvalidParameter, match="jerk_limits: expected one limit > 0"):
        mdh_mjcf([[0.0, 0.0, 0.3, 0.0]], joint_limits=[[-1.0, 1.0]], jerk_limits=[0.0])


def test_puma_link_two_centre_of_mass_and_inertia() -> None:
    # Armstrong et al.: link 2's centre of mass 0.068 m from the shoulder axis along the arm,
    # 0.2275 m along the shoulder axis from the arm's plane (0.0775 m past the 0.15 m offset).
    robot = puma560()
    m = robot.model
    b = m.body("link1").id  # body 1 carries joint 1 (the shoulder, DH link 2)
    c_world = np.asarray(m.body_ipos[b])
    # In the body frame (DH frame 1 rotated by q2), DH frame 2 sits at (a2, 0, d2).
    np.testing.assert_allclose(c_world, [0.4318 - 0.3638, 0.006, 0.15 + 0.0775], atol=1e-12)
    np.testing.assert_allclose(np.sort(m.body_inertia[b]), [0.13, 0.524, 0.539], atol=1e-12)


def test_generator_rotates_inertias_and_centres_into_the_body() -> None:
    # One standard-DH link with an offset and a twist: its inertia and centre of mass are
    # given in DH frame 1; about joint 1's axis (z_0) M11 = z_0ᵀ R I Rᵀ z_0 + m |z_0 × c|².
    a, alpha, d, off = 0.3, 0.7, 0.2, 0.4
    inertia = np.array([[0.05, 0.002, -0.003], [0.002, 0.04, 0.001], [-0.003, 0.001, 0.03]])
    com = np.array([-0.1, 0.02, 0.05])
    mass = 2.5
    xml = dh_mjcf(
        [[a, alpha, d, off]],
        joint_limits=[[-3.0, 3.0]],
        masses=[mass],
        centers_of_mass=[com],
        inertias=[[0.05, 0.04, 0.03, 0.002, -0.003, 0.001]],
    )
    robot = MujocoRobot.from_xml(xml)
    mj = robot._mj
    data = mj.MjData(robot.model)
    for q in (0.0, 0.9, -2.1):
        data.qpos[:] = [q]
        mj.mj_forward(robot.model, data)
        M = np.zeros((1, 1))
        mj.mj_fullM(robot.model, data, M)
        T = _dh(a, alpha, d, q + off)
        R = T[:3, :3]
        c = (T @ np.append(com, 1.0))[:3]
        expected = (R @ inertia @ R.T)[2, 2] + mass * (c[0] ** 2 + c[1] ** 2)
        assert M[0, 0] == pytest.approx(expected, rel=1e-12)
        assert data.qfrc_bias[0] == pytest.approx(0.0, abs=1e-12)  # a vertical axis


def test_generator_cylinder_approximation() -> None:
    # No centres or inertias: a solid cylinder (radius 0.05 m) along each link, centred on it.
    L, m, r = 0.4, 3.0, 0.05
    xml = mdh_mjcf([[0.0, _H, 0.0, 0.0]], joint_limits=[[-3.0, 3.0]], flange_d=L, masses=[m])
    robot = MujocoRobot.from_xml(xml)
    model = robot.model
    b = model.body("link0").id
    np.testing.assert_allclose(model.body_ipos[b], [0.0, 0.0, L / 2], atol=1e-15)
    np.testing.assert_allclose(
        np.sort(model.body_inertia[b]),
        np.sort([m * r**2 / 2, m * (3 * r**2 + L**2) / 12, m * (3 * r**2 + L**2) / 12]),
        rtol=1e-12,
    )


def test_generator_validation() -> None:
    rows, lim = [[0.0, 0.0, 0.3, 0.0]], [[-1.0, 1.0]]
    with pytest.raises(InvalidParameter, match=r"masses: expected one mass > 0"):
        dh_mjcf(rows, joint_limits=lim, masses=[0.0])
    with pytest.raises(InvalidParameter, match=r"masses: expected shape \(1,\)"):
        dh_mjcf(rows, joint_limits=lim, masses=[1.0, 2.0])
    with pytest.raises(InvalidParameter, match="centers_of_mass: expected None when masses"):
        dh_mjcf(rows, joint_limits=lim, centers_of_mass=[[0, 0, 0]])
    with pytest.raises(InvalidParameter, match=r"inertias: expected shape \(1, 3\)"):
        dh_mjcf(rows, joint_limits=lim, masses=[1.0], inertias=[[1.0, 1.0]])
    with pytest.raises(InvalidParameter, match="inertias: expected physical inertia tensors"):
        mdh_mjcf(rows, joint_limits=lim, masses=[1.0], inertias=[[0.01, 0.01, 0.05]])
    with pytest.raises(InvalidParameter, match="velocity_limits: expected one limit > 0"):
        dh_mjcf(rows, joint_limits=lim, velocity_limits=[-1.0])
    with pytest.raises(InvalidParameter, match="effort_limits: expected finite"):
        dh_mjcf(rows, joint_limits=lim, effort_limits=[np.inf])
    with pytest.raises(InvalidParameter, match=r"effort_limits: expected shape \(1,\)"):
        dh_mjcf(rows, joint_limits=lim, effort_limits=[1.0, 2.0])
    robot = MujocoRobot.from_xml(
        dh_mjcf(rows, joint_limits=lim, velocity_limits=[1.5], effort_limits=[7.0])
    )
    assert robot.velocity_limits.tolist() == [1.5]
    assert robot.effort_limits.tolist() == [7.0]
    np.testing.assert_array_equal(robot.model.jnt_actfrcrange[0], [-7.0, 7.0])


def test_models_without_the_numeric_have_no_limits() -> None:
    robot = MujocoRobot.from_xml(dh_mjcf([[0.0, 0.0, 0.3, 0.0]], joint_limits=[[-1.0, 1.0]]))
    assert robot.velocity_limits.tolist() == [np.inf]
    assert robot.effort_limits.tolist() == [np.inf]
    np.testing.assert_array_equal(robot.model.body_mass[1], 1.0)  # the unit placeholder
