"""The safety filter's description as data for the C cycle (``velfence_core._filter``).

:func:`chain_data` turns a standard Denavit-Hartenberg table into the C API's chain (per joint a
fixed transform, an axis, a type and an offset, plus a tool transform; ``velfence_filter.h``),
:func:`mdh_chain_data` a modified (Craig) one, and :func:`filter_cycle` builds the C object of a
:class:`~velfence.shaping.filter.SafetyFilter` on a ``DHChain`` (joint mode, identity or diagonal
weights). Private: the public route is ``SafetyFilter``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence.errors import InvalidParameter

__all__ = ["chain_data", "filter_cycle", "mdh_chain_data"]

_REVOLUTE = 0.0


def _tzxrx(a: float, alpha: float, d: float) -> FloatArray:
    """``Tz(d) Tx(a) Rx(alpha)`` as a 3 x 4 ``[R | p]`` (row-major, 12 floats)."""
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([1.0, 0.0, 0.0, a, 0.0, c, -s, 0.0, 0.0, s, c, d])


def _rxtxtz(a: float, alpha: float, d: float) -> FloatArray:
    """``Rx(alpha) Tx(a) Tz(d)`` as a 3 x 4 ``[R | p]`` (row-major, 12 floats)."""
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([1.0, 0.0, 0.0, a, 0.0, c, -s, -s * d, 0.0, s, c, c * d])


def _compose(A: FloatArray, B: FloatArray) -> FloatArray:
    Am = np.vstack([A.reshape(3, 4), [0.0, 0.0, 0.0, 1.0]])
    Bm = np.vstack([B.reshape(3, 4), [0.0, 0.0, 0.0, 1.0]])
    return np.asarray((Am @ Bm)[:3].ravel(), dtype=np.float64)


def _translation(p: Any) -> FloatArray:
    x, y, z = (float(v) for v in p)
    return np.array([1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, y, 0.0, 0.0, 1.0, z])


def chain_data(dh: Any, tool: Any = (0.0, 0.0, 0.0)) -> tuple[FloatArray, FloatArray]:
    """A standard DH table ``(a, alpha, d, theta_offset)`` (n, 4) as ``(joints (n*17,), tool (12,))``.

    The motion ``Rz(q + theta_offset)`` comes first in a standard DH row and its fixed part
    ``Tz(d) Tx(a) Rx(alpha)`` becomes the next joint's transform (the tool's for the last joint).
    """
    rows = np.asarray(dh, dtype=np.float64).reshape(-1, 4)
    n = rows.shape[0]
    joints = np.zeros((n, 17))
    prev = _translation((0.0, 0.0, 0.0))
    for j, (a, alpha, d, off) in enumerate(rows.tolist()):
        joints[j, :12] = prev
        joints[j, 12:15] = (0.0, 0.0, 1.0)
        joints[j, 15] = _REVOLUTE
        joints[j, 16] = off
        prev = _tzxrx(a, alpha, d)
    return joints.ravel(), _compose(prev, _translation(tool))


def mdh_chain_data(
    mdh: Any, flange_d: float = 0.0, tool: Any = (0.0, 0.0, 0.0)
) -> tuple[FloatArray, FloatArray]:
    """A modified DH (Craig) table ``(a_{i-1}, alpha_{i-1}, d_i, theta_offset)`` as chain data.

    Joint ``i``'s fixed transform is ``Rx(alpha_{i-1}) Tx(a_{i-1}) Tz(d_i)``, its motion
    ``Rz(q + theta_offset)``; the tool is ``Tz(flange_d)`` then ``tool``.
    """
    rows = np.asarray(mdh, dtype=np.float64).reshape(-1, 4)
    n = rows.shape[0]
    joints = np.zeros((n, 17))
    for j, (a, alpha, d, off) in enumerate(rows.tolist()):
        joints[j, :12] = _rxtxtz(a, alpha, d)
        joints[j, 12:15] = (0.0, 0.0, 1.0)
        joints[j, 15] = _REVOLUTE
        joints[j, 16] = off
    return joints.ravel(), _compose(_translation((0.0, 0.0, flange_d)), _translation(tool))


def _dh_points(robot: Any) -> dict[str, tuple[float, float, float, float]]:
    """Every named point of a ``DHChain`` as ``(link, x, y, z)`` in the C chain's frames."""
    n = int(robot.dof)
    dh = np.asarray(robot.dh, dtype=np.float64)
    out: dict[str, tuple[float, float, float, float]] = {}
    for name in robot.points:
        idx = robot._point_index(name)
        if idx == n:
            out[name] = (float(n), 0.0, 0.0, 0.0)
        elif idx < 0:
            a, _, d, _ = dh[n - 1].tolist()
            out[name] = (float(n - 1), a, 0.0, d)
        elif idx == 0:
            out[name] = (-1.0, 0.0, 0.0, 0.0)
        else:
            a, _, d, _ = dh[idx - 1].tolist()
            out[name] = (float(idx - 1), a, 0.0, d)
    return out


def filter_cycle(sf: Any) -> Any:
    """The C cycle (``velfence_core._filter.FilterCycle``) of a ``SafetyFilter`` on a ``DHChain``.

    Raises:
        InvalidParameter: the robot is not a DH chain, the weights are a full matrix, or the
            compiled core is not installed.
    """
    try:
        from velfence_core import _filter
    except ImportError:  # pragma: no cover - the core is an optional distribution
        raise InvalidParameter("the C filter cycle needs the compiled core (velfence_core)") from None
    robot = sf.robot
    if not (hasattr(robot, "dh") and hasattr(robot, "tool") and hasattr(robot, "_point_index")):
        raise InvalidParameter(
            f"robot: the C cycle takes a DHChain, got {type(robot).__name__}"
        )
    metric = sf._metric
    if metric is not None and metric.ndim != 1:
        raise InvalidParameter("weights: the C cycle takes diagonal weights only")
    n = int(robot.dof)
    joints, tool = chain_data(robot.dh, robot.tool)
    lim = sf.limits
    jkind: list[int] = []
    jprm: list[float] = []
    for prof in sf._joint_prof:
        kind, params = prof.kernel_profile
        jkind.append(int(kind))
        jprm.extend(float(v) for v in params)
    pts = _dh_points(robot)
    names = list(pts)
    ws = []
    for w_i, w in enumerate(sf.workspace):
        kind, params = sf._ws_prof[w_i].kernel_profile
        ws.append(
            (
                names.index(w.point),
                np.ascontiguousarray(w.polytope.normals, dtype=np.float64).ravel(),
                np.ascontiguousarray(w.polytope.offsets, dtype=np.float64),
                int(kind),
                np.array(params, dtype=np.float64),
            )
        )
    obs = sf.obstacles
    centres = np.array([o.center for o in obs], dtype=np.float64).reshape(-1)
    radii = np.array([o.radius for o in obs], dtype=np.float64)
    lrad = np.broadcast_to(np.asarray(robot.link_radius, dtype=np.float64).reshape(-1), (n,))
    acc = lim.max_acceleration
    return _filter.FilterCycle(
        joints, tool, np.asarray(lim.lower, dtype=np.float64),
        np.asarray(lim.upper, dtype=np.float64), np.asarray(lim.max_velocity, dtype=np.float64),
        None if acc is None else np.asarray(acc, dtype=np.float64), jkind,
        np.array(jprm), np.array([v for nm in names for v in pts[nm]]), ws, centres, radii,
        np.ascontiguousarray(lrad), float(sf.obstacle_buffer), float(sf.spring_gain),
        float(sf.dt or 0.0), None if metric is None else np.asarray(metric) ** 2,
    )  # fmt: skip
