"""The validated parts of a :class:`~velfence.filter.SafetyFilter`, checked once at construction.

The robot's kinematics and chain data against its ``dof``, the workspace limits against the
robot's points and task dimension, the obstacles against its capsule geometry, the user's row
providers, the joint profiles and the joint-mode metric. Each refusal is an
:class:`~velfence.errors.InvalidParameter` naming the public argument.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from velfence._validate import MAX_MAGNITUDE, describe, readonly, real_array
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.filter.attach import AttachmentTable
from velfence.filter.kinematics import checked, frame_of
from velfence.filter.limits import (
    Capsule,
    JointLimits,
    Profile,
    SelfCollision,
    Sphere,
    SphereObstacle,
    WorkspaceLimit,
)
from velfence.filter.rows import LEVEL_NAMES, ObstacleRows, SelfCollisionRows
from velfence.filter.solve import Metric, cholesky
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking

__all__ = [
    "check_robot",
    "custom_providers",
    "joint_profiles",
    "metric",
    "obstacle_list",
    "obstacle_rows",
    "robot_frame",
    "workspaces",
]

_PROTOCOL = ("dof", "joint_names", "points", "fk", "jacobian")


def check_robot(robot: Any) -> None:
    """The robot has the Kinematics protocol's names (never its type: structural)."""
    for attr in _PROTOCOL:
        if not hasattr(robot, attr):
            raise InvalidParameter(
                f"robot: expected the Kinematics protocol (dof, joint_names, points, fk, "
                f"jacobian), got {type(robot).__name__} without {attr!r}"
            )


def robot_frame(robot: Any, n: int) -> tuple[Any, int]:
    """``(frame at q = 0, task_dim)``: the robot's kinematics and chain data agree with ``n``."""
    q0 = np.zeros(n)
    try:
        frame = frame_of(robot, q0)
        p = np.asarray(frame.point("tcp"), dtype=float)
        dim = int(p.shape[0]) if p.ndim == 1 else -1
        if dim not in (2, 3):
            raise InvalidInput(
                f"robot: kinematics(q).point('tcp') expected shape (2,) or (3,), got {p.shape}"
            )
        checked("kinematics(q).point('tcp')", p, (dim,))
        checked("kinematics(q).jacobian('tcp')", frame.jacobian("tcp"), (dim, n))
    except VelfenceError as exc:
        raise InvalidParameter(f"robot: kinematics at q = 0: {exc}") from None
    data = getattr(robot, "chain_data", None)
    cd = data() if callable(data) else None
    if cd is not None:
        dh = np.asarray(getattr(cd, "dh", None), dtype=object)
        tool = np.asarray(getattr(cd, "tool", None), dtype=object)
        ok = dh.shape == (n, 5) and tool.shape == (3,)
        if ok:
            try:
                ok = bool(
                    np.isfinite(dh.astype(float)).all() and np.isfinite(tool.astype(float)).all()
                )
            except (TypeError, ValueError):
                ok = False
        if not ok:
            raise InvalidParameter(
                f"robot: inconsistent chain data: chain_data() expected dh of shape ({n}, 5) "
                f"and tool of shape (3,), finite, got dh {dh.shape}, tool {tool.shape}"
            )
    return frame, dim


def joint_profiles(
    limits: JointLimits,
    profile: Any,
    *,
    joint_buffer: float,
    spring_gain: float,
) -> tuple[Profile, ...]:
    """One approach profile per joint (``SafetyFilter``'s ``profile`` argument)."""
    if profile is not None and not isinstance(profile, (LinearBuffer, ThreeZoneBraking)):
        raise InvalidParameter(
            f"profile: expected None, a LinearBuffer or a ThreeZoneBraking, got {describe(profile)}"
        )
    acc = limits.max_acceleration
    profs: list[Profile] = []
    for j in range(limits.dof):
        v = float(limits.max_speed[j])
        if profile is not None:
            profs.append(profile)
        elif acc is not None and math.isfinite(acc[j]):
            a = float(acc[j])
            gain = 2.0 * a / v
            if not math.isfinite(gain) or gain > MAX_MAGNITUDE or gain <= 0.0:
                raise InvalidParameter(
                    f"limits: joint {j}'s max_acceleration {a:g} and max_speed {v:g} give no "
                    f"usable braking gain: expected 2 a / v in (0, {MAX_MAGNITUDE:g}] 1/s, got "
                    f"{gain:g}"
                )
            profs.append(ThreeZoneBraking(gain=gain, max_speed=v, max_acceleration=a))
        else:
            profs.append(
                LinearBuffer(buffer=joint_buffer, spring_gain=spring_gain, max_recovery_speed=v)
            )
    return tuple(profs)


def workspaces(robot: Any, workspace: Any, frame0: Any) -> tuple[WorkspaceLimit, ...]:
    """The workspace limits, each on one of the robot's points of its polytope's dimension."""
    ws: Any = (workspace,) if isinstance(workspace, WorkspaceLimit) else workspace
    if isinstance(ws, (str, bytes)) or not isinstance(ws, Sequence):
        raise InvalidParameter(
            f"workspace: expected a WorkspaceLimit or a sequence of them, got {describe(workspace)}"
        )
    for w in ws:
        if not isinstance(w, WorkspaceLimit):
            raise InvalidParameter(f"workspace: expected WorkspaceLimit entries, got {describe(w)}")
        if w.point not in robot.points:
            raise InvalidParameter(
                f"workspace: point {w.point!r} is not one of the robot's points "
                f"{list(robot.points)}"
            )
        dim = np.asarray(frame0.point(w.point)).shape[0]
        if w.polytope.dim != dim:
            raise InvalidParameter(
                f"workspace: the polytope on {w.point!r} is {w.polytope.dim}-D, the robot's "
                f"task space is {dim}-D"
            )
    return tuple(ws)


def obstacle_list(obstacles: Any) -> tuple[SphereObstacle, ...]:
    """The obstacles, each a :class:`SphereObstacle`."""
    if isinstance(obstacles, (str, bytes)) or not isinstance(obstacles, Sequence):
        raise InvalidParameter(
            f"obstacles: expected a sequence of SphereObstacle, got {describe(obstacles)}"
        )
    for o in obstacles:
        if not isinstance(o, SphereObstacle):
            raise InvalidParameter(f"obstacles: expected SphereObstacle entries, got {describe(o)}")
    return tuple(obstacles)


def obstacle_rows(
    robot: Any,
    obstacles: tuple[SphereObstacle, ...],
    frame0: Any,
    *,
    n: int,
    buffer: float,
    spring_gain: float,
    max_speed: Any,
) -> ObstacleRows:
    """The obstacle provider, after checking the robot's capsule geometry once."""
    if not hasattr(robot, "link_radius"):
        raise InvalidParameter(
            f"obstacles: the robot {type(robot).__name__} has no capsule geometry "
            "('link_radius'); use a DHChain, PlanarArm or MujocoRobot (Puma560.chain)"
        )
    radius = np.asarray(robot.link_radius, dtype=float).reshape(-1)
    prov = ObstacleRows(
        obstacles, radius, buffer=buffer, spring_gain=spring_gain, max_speed=max_speed
    )
    try:
        segs = prov.segments(frame0)
        checked("kinematics(q).point_jacobian(0, 0.5)", frame0.point_jacobian(0, 0.5), (3, n))
    except (InvalidInput, AttributeError, TypeError) as exc:
        raise InvalidParameter(
            f"obstacles: the robot's capsule geometry is unusable: {exc}"
        ) from None
    if segs.shape[0] == 0:
        raise InvalidParameter("obstacles: the robot has no capsule links")
    return prov


def custom_providers(providers: Any) -> list[Any]:
    """The user's row providers: each with ``rows`` and a level 0-4."""
    if isinstance(providers, (str, bytes)) or not isinstance(providers, Sequence):
        raise InvalidParameter(
            f"providers: expected a sequence of row providers, got {describe(providers)}"
        )
    out = []
    for i, p in enumerate(providers):
        level = getattr(p, "level", None)
        if not callable(getattr(p, "rows", None)):
            raise InvalidParameter(
                f"providers[{i}]: expected a RowProvider (level, label, rows(ctx)), got "
                f"{describe(p)} without rows()"
            )
        if isinstance(level, bool) or level not in range(len(LEVEL_NAMES)):
            raise InvalidParameter(
                f"providers[{i}]: expected level 0-{len(LEVEL_NAMES) - 1} "
                f"({', '.join(LEVEL_NAMES)}), got {level!r}"
            )
        out.append(p)
    return out


def metric(weights: Any, n: int) -> Metric:
    """The joint-mode metric's factor ``L`` (``W = L Lᵀ``) from ``weights``."""
    if weights is None:
        return None
    Wa = real_array("weights", weights, error=InvalidParameter, what="weights")
    if Wa.shape == (n,):
        if not np.all(Wa > 0.0):
            raise InvalidParameter(f"weights: expected weights > 0, got {Wa.tolist()}")
        _check_ratio(float(Wa.max() / Wa.min()))
        return readonly(np.sqrt(Wa))
    if Wa.shape == (n, n):
        if not np.allclose(Wa, Wa.T, rtol=1e-12, atol=0.0):
            asym = float(np.max(np.abs(Wa - Wa.T)))
            raise InvalidParameter(
                f"weights: expected a symmetric ({n}, {n}) matrix, got one whose largest "
                f"|W - Wᵀ| entry is {asym:g}"
            )
        L = cholesky("weights", Wa)
        ev = np.linalg.eigvalsh(Wa)
        _check_ratio(float(ev[-1] / ev[0]) if ev[0] > 0.0 else math.inf)
        return readonly(L)
    raise InvalidParameter(f"weights: expected shape ({n},) or ({n}, {n}), got shape {Wa.shape}")


#: Largest ratio of the metric's weights (eigenvalues): the solve runs in the metric's space and
#: maps back by ``1/sqrt(w)``, so its round-off grows with the ratio; beyond about 1e20 the answer
#: is visibly not the nearest one (a joint weighted 1e-31 came out at -1.3 rad/s for a 1.5 rad/s
#: optimum), at 1e12 the error stays at the round-off of the unweighted solve.
MAX_WEIGHT_RATIO = 1e12


def _check_ratio(ratio: float) -> None:
    if not ratio <= MAX_WEIGHT_RATIO:
        raise InvalidParameter(
            f"weights: expected the largest weight at most {MAX_WEIGHT_RATIO:g} times the "
            f"smallest (for a matrix: its eigenvalues), got a ratio of {ratio:.3g}; scale the "
            "commands or drop the joint instead"
        )


def self_collision(value: Any) -> SelfCollision | None:
    """The ``self_collision`` option as a :class:`SelfCollision`, or ``None`` for none."""
    if value is None or value is False:
        return None
    if value is True:
        return SelfCollision()
    if isinstance(value, SelfCollision):
        return value
    raise InvalidParameter(
        f"self_collision: expected True, False, None or a SelfCollision, got {describe(value)}"
    )


def self_collision_rows(
    robot: Any,
    sc: SelfCollision,
    frame0: Any,
    *,
    n: int,
    buffer: float,
    spring_gain: float,
    max_speed: Any,
) -> SelfCollisionRows:
    """The self-collision provider, after checking the robot's capsule geometry once."""
    if not hasattr(robot, "link_radius"):
        raise InvalidParameter(
            f"self_collision: the robot {type(robot).__name__} has no capsule geometry "
            "('link_radius'); use a DHChain, PlanarArm or MujocoRobot"
        )
    radius = np.asarray(robot.link_radius, dtype=float).reshape(-1)
    try:
        segs = np.asarray(frame0.segments(), dtype=np.float64)
        nl = segs.shape[0] if segs.ndim == 3 else 0
        segs = checked("kinematics(q).segments()", segs, (nl, 2, 3))
        if radius.shape[0] not in (1, nl):
            raise InvalidInput(f"link_radius has {radius.shape[0]} radii for {nl} links")
        if segs.shape[0]:
            checked("kinematics(q).point_jacobian(0, 0.5)", frame0.point_jacobian(0, 0.5), (3, n))
    except (InvalidInput, AttributeError, TypeError) as exc:
        raise InvalidParameter(
            f"self_collision: the robot's capsule geometry is unusable: {exc}"
        ) from None
    rad = np.broadcast_to(radius if radius.shape[0] > 1 else radius[:1], (segs.shape[0],))
    pairs = sc.pairs(np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1).tolist(), radii=rad.tolist())
    return SelfCollisionRows(
        pairs, link_radius=radius, buffer=buffer, spring_gain=spring_gain, max_speed=max_speed
    )


def add_attachment(table: AttachmentTable, name: Any, shape: Any, what: str) -> None:
    """Check one attachment against the robot's links and add it to ``table``."""
    from velfence._validate import check_text

    nm = check_text("name", name, max_length=200)
    if not isinstance(shape, (Sphere, Capsule)):
        raise InvalidParameter(f"{what}: expected a Sphere or a Capsule, got {describe(shape)}")
    link = table.link_of(shape)
    if not -1 <= link <= table.n:
        raise InvalidParameter(
            f"{what}.link: link {link} does not exist (the robot has links -1 (base) … "
            f"{table.n - 1} and 'tcp' ({table.n}))"
        )
    table.add(nm, shape)


def attachment_table(robot: Any, attachments: Any, frame0: Any, n: int) -> AttachmentTable:
    """The filter's attachment table from ``attachments=`` (a mapping or a sequence)."""
    from collections.abc import Mapping

    try:
        checked("kinematics(q).link_frame(-1)", frame0.link_frame(-1), (3, 4))
        checked("kinematics(q).jacobian_at(0, p)", frame0.jacobian_at(0, np.zeros(3)), (3, n))
    except (InvalidInput, AttributeError, TypeError) as exc:
        raise InvalidParameter(
            f"attachments: the robot {type(robot).__name__} gives no link frames "
            f"(its kinematics frame needs link_frame and jacobian_at; a DHChain has them): {exc}"
        ) from None
    table = AttachmentTable(n=n)
    if isinstance(attachments, Mapping):
        items = [(k, v, f"attachments[{k!r}]") for k, v in attachments.items()]
    elif isinstance(attachments, (str, bytes)) or not isinstance(attachments, Sequence):
        raise InvalidParameter(
            f"attachments: expected a mapping name -> shape or a sequence of shapes, got "
            f"{describe(attachments)}"
        )
    else:
        items = [(f"attachment {k}", v, f"attachments[{k}]") for k, v in enumerate(attachments)]
    for name, shape, what in items:
        add_attachment(table, name, shape, what)
    return table
