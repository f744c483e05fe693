"""The kinematics protocol's per-cycle frame equals the robots' per-call methods.

For every implementation (DHChain, PlanarArm, Puma560, MujocoRobot): ``robot.kinematics(q)``
answers ``point``, ``jacobian``, ``segments`` and ``point_jacobian`` exactly as ``fk``,
``jacobian``, ``link_segments`` and ``point_jacobian`` do for the same ``q``, also when frames
of different poses are interleaved (MuJoCo shares one ``MjData``); ``chain_data`` is the DH table
the chain computes with.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from velfence.filter import ChainData, KinematicsFrame
from velfence.mechanisms.chain import DHChain, PlanarArm
from velfence.mechanisms.puma560 import Puma560


def _robots() -> list[tuple[str, Any]]:
    out: list[tuple[str, Any]] = [
        ("dh7", DHChain.seven_dof(link_radius=0.05, tool=(0.0, 0.01, 0.1))),
        ("ur5e", DHChain.ur5e()),
        ("planar", PlanarArm.three_r()),
        ("puma", Puma560()),
    ]
    try:
        import mujoco  # noqa: F401

        from velfence.robots import panda, ur5e

        out += [("mj-ur5e", ur5e()), ("mj-panda", panda())]
    except ImportError:
        pass
    return out


ROBOTS = _robots()


@pytest.mark.parametrize(("name", "robot"), ROBOTS, ids=[n for n, _ in ROBOTS])
def test_the_frame_equals_the_per_call_methods(name: str, robot: Any) -> None:
    rng = np.random.default_rng(2)
    n = robot.dof
    lim = np.asarray(robot.joint_limits, dtype=float)
    for _ in range(5):
        qa = rng.uniform(np.maximum(lim[:, 0], -3.0), np.minimum(lim[:, 1], 3.0))
        qb = rng.uniform(np.maximum(lim[:, 0], -3.0), np.minimum(lim[:, 1], 3.0))
        fa = robot.kinematics(qa)
        fb = robot.kinematics(qb)  # interleaved: fa must still answer for qa
        assert isinstance(fa, KinematicsFrame)
        for f, q in ((fa, qa), (fb, qb), (fa, qa)):
            for pt in robot.points[:6]:
                np.testing.assert_allclose(f.point(pt), robot.fk(q, pt), atol=1e-14, rtol=0)
                np.testing.assert_allclose(f.jacobian(pt), robot.jacobian(q, pt), atol=1e-14)
            if hasattr(robot, "link_segments"):
                np.testing.assert_allclose(f.segments(), robot.link_segments(q), atol=1e-14)
                k = int(rng.integers(0, len(robot.link_segments(q))))
                np.testing.assert_allclose(
                    f.point_jacobian(k, 0.3), robot.point_jacobian(q, k, 0.3), atol=1e-14
                )
        assert fa.jacobian("tcp").shape[1] == n


@pytest.mark.parametrize("chain", [DHChain.seven_dof(tool=(0.0, 0.0, 0.1)), DHChain.ur5e()])
def test_chain_data_is_the_dh_table(chain: DHChain) -> None:
    cd = chain.chain_data()
    assert isinstance(cd, ChainData)
    np.testing.assert_array_equal(cd.dh[:, 0], chain.dh[:, 0])
    np.testing.assert_allclose(cd.dh[:, 1], np.cos(chain.dh[:, 1]), atol=0)
    np.testing.assert_allclose(cd.dh[:, 2], np.sin(chain.dh[:, 1]), atol=0)
    np.testing.assert_array_equal(cd.dh[:, 3:], chain.dh[:, 2:])
    np.testing.assert_array_equal(cd.tool, chain.tool)
    assert cd.point_index["tcp"] == chain.dof
    assert cd.point_index["flange"] == -1
    # the table reproduces the chain's tool point (an independent 4 x 4 product)
    q = np.linspace(-1.0, 1.0, chain.dof)
    T = np.eye(4)
    for (a, ca, sa, d, off), qi in zip(cd.dh.tolist(), q.tolist(), strict=True):
        ct, st = math.cos(qi + off), math.sin(qi + off)
        T = T @ np.array(
            [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
             [0.0, sa, ca, d], [0.0, 0.0, 0.0, 1.0]]
        )  # fmt: skip
    np.testing.assert_allclose((T @ np.append(cd.tool, 1.0))[:3], chain.fk(q), atol=1e-14)


def test_other_robots_have_no_chain_data() -> None:
    assert PlanarArm.three_r().chain_data() is None
    assert Puma560().chain_data() is not None  # its chain is a DH table


@pytest.mark.parametrize("chain", [DHChain.seven_dof(link_radius=0.05), PlanarArm.three_r()])
def test_batched_point_jacobians_equal_one_at_a_time(chain: Any) -> None:
    rng = np.random.default_rng(6)
    frame = chain.kinematics(rng.uniform(-2.0, 2.0, chain.dof))
    links = rng.integers(0, chain.dof, 12)
    ts = rng.uniform(0.0, 1.0, 12)
    batch = frame.point_jacobians(links, ts)
    for k, (link, t) in enumerate(zip(links.tolist(), ts.tolist(), strict=True)):
        np.testing.assert_allclose(batch[k], frame.point_jacobian(link, t), atol=1e-15, rtol=0)
