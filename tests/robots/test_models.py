"""velfence.robots: MuJoCo kinematics of the shipped arms against independent routes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.filter import SafetyFilter
from velfence.filter.kinematics import Kinematics
from velfence.filter.limits import JointLimits, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain
from velfence.robots import MujocoRobot, dh_mjcf, mdh_mjcf, panda, puma560, seven_dof, ur5e

PAIRS = [
    ("seven_dof", seven_dof, DHChain.seven_dof),
    ("ur5e", ur5e, DHChain.ur5e),
    ("puma560", puma560, DHChain.puma560),
]


def _random_q(limits: np.ndarray, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(limits[:, 0], limits[:, 1], size=(n, limits.shape[0]))


@pytest.mark.parametrize(("name", "make", "chain"), PAIRS, ids=[p[0] for p in PAIRS])
def test_dh_models_match_dhchain(name: str, make, chain) -> None:
    tool = np.array([0.01, -0.02, 0.05])
    robot, ref = make(tool=tool), chain(tool=tool)
    assert robot.dof == ref.dof
    np.testing.assert_allclose(robot.joint_limits, ref.joint_limits, atol=1e-12)
    for q in _random_q(ref.joint_limits, 50, seed=len(name)):
        for point in ("tcp", "flange", "elbow", "wrist", "joint1", f"joint{ref.dof - 1}"):
            np.testing.assert_allclose(robot.fk(q, point), ref.fk(q, point), rtol=0, atol=1e-9)
            np.testing.assert_allclose(
                robot.jacobian(q, point), ref.jacobian(q, point), rtol=0, atol=1e-9
            )
        np.testing.assert_allclose(
            robot.angular_jacobian(q), ref.angular_jacobian(q), rtol=0, atol=1e-9
        )


def test_ur5e_joint_names_are_the_drivers() -> None:
    assert ur5e().joint_names == DHChain.ur5e().joint_names


# ------------------------------------------------------------------------ the Panda
_H = math.pi / 2.0
_A = (0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088)
_D = (0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0)
_ALPHA = (0.0, -_H, _H, _H, -_H, _H, _H)


def _craig_fk(q: np.ndarray, tool: np.ndarray) -> np.ndarray:
    """Modified-DH forward kinematics, T_i = Rx(alpha) Tx(a) Rz(q) Tz(d), written out."""
    T = np.eye(4)
    for a, d, al, qi in zip(_A, _D, _ALPHA, q, strict=True):
        ca, sa, cq, sq = math.cos(al), math.sin(al), math.cos(qi), math.sin(qi)
        T = T @ np.array(
            [
                [cq, -sq, 0.0, a],
                [sq * ca, cq * ca, -sa, -sa * d],
                [sq * sa, cq * sa, ca, ca * d],
                [0.0, 0.0, 0.0, 1.0],
            ]
        )
    flange = T @ np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.107], [0, 0, 0, 1.0]])
    return (flange @ np.append(tool, 1.0))[:3]


def test_panda_matches_an_independent_modified_dh() -> None:
    tool = np.array([0.0, 0.0, 0.1034])
    robot = panda(tool=tool)
    # q = 0: the flange 0.926 m up, pointing down
    np.testing.assert_allclose(robot.fk(np.zeros(7)), [0.088, 0.0, 0.926 - 0.1034], atol=1e-12)
    for q in _random_q(robot.joint_limits, 50, seed=7):
        np.testing.assert_allclose(robot.fk(q), _craig_fk(q, tool), rtol=0, atol=1e-9)


def test_panda_jacobian_matches_finite_differences() -> None:
    robot = panda(tool=[0.0, 0.0, 0.1])
    h = 1e-6
    for q in _random_q(robot.joint_limits, 50, seed=8):
        for point in ("tcp", "elbow", "wrist"):
            fd = np.column_stack(
                [
                    (robot.fk(q + h * e, point) - robot.fk(q - h * e, point)) / (2 * h)
                    for e in np.eye(7)
                ]
            )
            np.testing.assert_allclose(robot.jacobian(q, point), fd, rtol=0, atol=1e-6)


def test_panda_angular_jacobian_matches_finite_rotations() -> None:
    robot = panda()
    mj = robot._mj  # the site frame, for an independent numerical derivative
    sid = robot._site["tcp"]
    h = 1e-6

    def rot(q: np.ndarray) -> np.ndarray:
        robot.fk(q)
        return np.array(robot._data.site_xmat[sid]).reshape(3, 3)

    assert mj is not None
    for q in _random_q(robot.joint_limits, 10, seed=9):
        cols = []
        for e in np.eye(7):
            dR = (rot(q + h * e) - rot(q - h * e)) / (2 * h) @ rot(q).T  # skew(omega)
            cols.append([dR[2, 1], dR[0, 2], dR[1, 0]])
        np.testing.assert_allclose(robot.angular_jacobian(q), np.array(cols).T, atol=1e-6)


def test_panda_names_and_limits() -> None:
    robot = panda()
    assert isinstance(robot, Kinematics)
    assert robot.dof == 7
    assert robot.joint_names == tuple(f"panda_joint{i}" for i in range(1, 8))
    assert robot.points[0] == "tcp"
    assert {"flange", "elbow", "wrist", "joint0", "joint6"} <= set(robot.points)
    np.testing.assert_allclose(robot.joint_limits[3], [-3.0718, -0.0698])
    np.testing.assert_allclose(robot.joint_limits[5], [-0.0175, 3.7525])
    assert not robot.joint_limits.flags.writeable


# ------------------------------------------------------------------------ loading and errors
def test_from_file_and_capsules(tmp_path: Path) -> None:
    xml = dh_mjcf(
        [[0.0, 0.0, 0.5, 0.0], [0.3, 0.0, 0.0, 0.0]], joint_limits=[[-1, 1], [-2, 2]], radius=0.05
    )
    assert xml.count('type="capsule"') == 2
    path = tmp_path / "arm.xml"
    path.write_text(xml, encoding="utf-8")
    robot = MujocoRobot.from_file(path)
    ref = DHChain([[0.0, 0.0, 0.5, 0.0], [0.3, 0.0, 0.0, 0.0]])
    q = np.array([0.4, -0.7])
    np.testing.assert_allclose(robot.fk(q), ref.fk(q), atol=1e-12)
    np.testing.assert_allclose(robot.joint_limits, [[-1, 1], [-2, 2]])


def test_theta_offsets_match_dhchain() -> None:
    rows = [[0.1, 0.3, 0.2, 0.5], [0.2, -0.4, 0.1, -1.0], [0.05, 1.0, 0.3, 2.0]]
    robot = MujocoRobot.from_xml(dh_mjcf(rows, joint_limits=[[-3, 3]] * 3))
    ref = DHChain(rows)
    for q in _random_q(np.array([[-3.0, 3.0]] * 3), 20, seed=3):
        np.testing.assert_allclose(robot.jacobian(q), ref.jacobian(q), atol=1e-9)


def test_mdh_theta_offsets_match_the_independent_route() -> None:
    rows = [[0.0, 0.0, 0.3, 0.4], [0.1, 0.7, 0.2, -0.3]]
    robot = MujocoRobot.from_xml(mdh_mjcf(rows, joint_limits=[[-3, 3]] * 2, flange_d=0.05))
    q = np.array([0.2, -0.5])
    T = np.eye(4)
    for (a, al, d, off), qi in zip(rows, q, strict=True):
        ca, sa, cq, sq = math.cos(al), math.sin(al), math.cos(qi + off), math.sin(qi + off)
        T = T @ np.array(
            [
                [cq, -sq, 0, a],
                [sq * ca, cq * ca, -sa, -sa * d],
                [sq * sa, cq * sa, ca, ca * d],
                [0, 0, 0, 1.0],
            ]
        )
    np.testing.assert_allclose(robot.fk(q), T[:3, 3] + 0.05 * T[:3, 2], atol=1e-12)


def test_validation_messages() -> None:
    robot = panda()
    with pytest.raises(InvalidInput, match=r"q: expected shape \(7,\)"):
        robot.fk(np.zeros(6))
    with pytest.raises(InvalidInput, match="q: expected finite"):
        robot.jacobian([0, 0, 0, np.nan, 0, 0, 0])
    with pytest.raises(InvalidInput, match="q: expected one joint vector"):
        robot.fk(np.zeros((2, 7)))
    with pytest.raises(InvalidInput, match="point: expected one of"):
        robot.fk(np.zeros(7), "knee")
    with pytest.raises(InvalidInput, match="point: expected a point name"):
        robot.jacobian(np.zeros(7), 3)  # type: ignore[arg-type]
    with pytest.raises(InvalidGeometry, match="text: expected an MJCF document"):
        MujocoRobot.from_xml("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(InvalidGeometry, match="xml: expected a site named 'tcp'"):
        MujocoRobot(xml=dh_mjcf([[0, 0, 1, 0]], joint_limits=[[-1, 1]]).replace('"tcp"', '"tip"'))
    with pytest.raises(InvalidGeometry, match=r"text: expected at least one joint.*hinge or slide"):
        MujocoRobot.from_xml(
            '<mujoco><worldbody><body><freejoint/><inertial pos="0 0 0" mass="1" '
            'diaginertia="1 1 1"/><site name="tcp"/></body></worldbody></mujoco>'
        )
    with pytest.raises(InvalidParameter, match="text: expected a string"):
        MujocoRobot.from_xml(b"<mujoco/>")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="path: expected a readable"):
        MujocoRobot.from_file("/nonexistent/arm.xml")
    with pytest.raises(
        InvalidGeometry, match=r"joint_limits: expected one .* row per row of dh_rows"
    ):
        dh_mjcf([[0, 0, 1, 0]], joint_limits=[[-1, 1], [-1, 1]])
    with pytest.raises(InvalidGeometry, match="joint_limits: expected lower < upper"):
        dh_mjcf([[0, 0, 1, 0]], joint_limits=[[1, -1]])
    with pytest.raises(InvalidGeometry, match="dh_rows"):
        dh_mjcf([[0, 0, 1]], joint_limits=[[-1, 1]])
    with pytest.raises(InvalidParameter, match="radius"):
        panda(radius=-0.1)


# ------------------------------------------------------------------------ the safety filter
@pytest.mark.parametrize(
    "steps", [pytest.param(60, id="short"), pytest.param(300, id="long", marks=pytest.mark.slow)]
)
def test_safety_filter_keeps_the_panda_tcp_in_a_box(steps: int) -> None:
    robot = panda(tool=[0.0, 0.0, 0.1])
    q = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
    lim = robot.joint_limits
    box = ConvexPolytope.box(robot.fk(q) - 0.1, robot.fk(q) + 0.1)
    dt = 0.002
    f = SafetyFilter(
        robot,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5)),
        workspace=WorkspaceLimit(box, buffer=0.05),
        dt=dt,
    )
    rng = np.random.default_rng(0)
    d_min = np.inf
    for k in range(steps):
        if k % (steps // 4) == 0:
            v = rng.normal(size=3)
            v = 0.8 * v / np.linalg.norm(v)
        q = q + f.filter_twist(q, v) * dt
        d_min = min(d_min, float(box.signed_distances(robot.fk(q)).min()))
        assert np.all((q >= lim[:, 0]) & (q <= lim[:, 1]))
    assert d_min >= -1e-9, d_min
    if steps > 100:
        assert d_min < 0.03  # the walk pressed on the walls
