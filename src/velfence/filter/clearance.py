"""Link-obstacle clearances over a run: :func:`link_clearances`.

The signed surface clearance of every (sphere obstacle, capsule link) pair at one joint position
or at each row of a run, for plots and checks: the geometry of the filter's obstacle rows
(:class:`~velfence.filter.rows.ObstacleRows`, the arithmetic of
:func:`velfence.geometry.primitives.sphere_capsule_distance`) on the robot's own kinematics (the
frame the filter builds each cycle), so a clearance plotted here is the one the filter kept.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray, IntArray
from velfence._validate import readonly, real_array
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter import parts
from velfence.filter.kinematics import Kinematics, frame_of
from velfence.filter.limits import SphereObstacle, spatial_obstacles

__all__ = ["LinkClearances", "link_clearances"]


@dataclass(frozen=True, eq=False)
class LinkClearances:
    """The clearances of every (obstacle, link) pair, at one position or along a run.

    Indexed as the filter names its rows: entry ``[i, l]`` is ``"obstacle i on link l"``.

    Attributes:
        values: Signed surface clearance [m]: ``|x - c| - r_sphere - r_link`` (``x`` the point
            of the link's axis nearest the centre ``c``), negative when the link penetrates the
            sphere; shape (k, L) for one position, (T, k, L) for a run of T positions
            (read-only).
        minimum: The smallest clearance [m]: a float for one position, shape (T,) for a run.
        nearest: Where it is, ``(obstacle, link)``: a pair of ints for one position, shape
            (T, 2) for a run.
    """

    values: FloatArray
    minimum: float | FloatArray
    nearest: tuple[int, int] | IntArray


def link_clearances(
    robot: Kinematics, obstacles: Sequence[SphereObstacle], positions: ArrayLike
) -> LinkClearances:
    """The signed clearance of every (obstacle, link) pair at each joint position.

    For plots and checks of a run: ``link_clearances(robot, obstacles, qs).minimum`` is the
    closest any link came to any sphere at each step. The same geometry and kinematics as the
    safety filter's obstacle rows (``SafetyFilter(robot, obstacles=...)``:
    ``link_clearances(f.robot, f.obstacles, q)``).

    Args:
        robot: The kinematics, with capsule links (``link_radius`` and the frame's
            ``segments``: a ``DHChain``, ``PlanarArm``, a ``MujocoRobot`` with links).
        obstacles: The spheres (:class:`~velfence.filter.limits.SphereObstacle`), at least one.
        positions: Joint positions [rad], shape (dof,) or (T, dof).

    Returns:
        A :class:`LinkClearances`: values (k, L) or (T, k, L) [m], their minimum and where it
        is.

    Raises:
        InvalidParameter: a robot without the Kinematics protocol or without capsule links, no
            obstacles or not ``SphereObstacle`` entries, a planar centre for a spatial arm.
        InvalidInput: positions of the wrong shape or not finite; a kinematics answer of the
            wrong shape or not finite (naming ``robot``).
    """
    parts.check_robot(robot)
    n = int(robot.dof)
    obs = parts.obstacle_list(obstacles)
    if not obs:
        raise InvalidParameter("obstacles: expected at least one SphereObstacle, got none")
    frame0, dim = parts.robot_frame(robot, n)
    obs = spatial_obstacles(obs, dim)
    Q = real_array("positions", positions, None, what=f"joint positions [rad] of {n} joints")
    if Q.ndim not in (1, 2) or Q.shape[-1] != n:
        raise InvalidInput(
            f"positions: expected joint positions [rad] of shape ({n},) or (T, {n}), got shape "
            f"{Q.shape}"
        )
    one = Q.ndim == 1
    Q2 = Q.reshape(-1, n)
    rows = parts.obstacle_rows(
        robot, obs, frame0, n=n, buffer=1.0, spring_gain=0.0, max_speed=np.ones(n)
    )
    segs0 = rows.segments(frame0)
    out = np.empty((Q2.shape[0], len(obs), segs0.shape[0]))
    for t in range(Q2.shape[0]):
        c = rows.clearances(frame_of(robot, Q2[t]))
        if c.shape != out.shape[1:]:
            raise InvalidInput(
                f"robot: kinematics(q).segments() gave {c.shape[1]} links at positions row {t}, "
                f"{out.shape[2]} at q = 0"
            )
        out[t] = c
    L = out.shape[2]
    flat = out.reshape(Q2.shape[0], len(obs) * L)
    at = np.argmin(flat, axis=1) if Q2.shape[0] else np.zeros(0, dtype=np.int64)
    mins = flat[np.arange(Q2.shape[0]), at]
    pairs = np.stack(np.divmod(at, L), axis=1).astype(np.int64)
    if one:
        return LinkClearances(
            values=readonly(out[0]),
            minimum=float(mins[0]),
            nearest=(int(pairs[0, 0]), int(pairs[0, 1])),
        )
    return LinkClearances(values=readonly(out), minimum=readonly(mins), nearest=readonly(pairs))


document_inits(globals())
