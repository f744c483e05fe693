"""The safety filter's description as data for the C cycle (``velfence_core._filter``).

:func:`chain_data` turns a standard Denavit-Hartenberg table into the C API's chain (per joint a
fixed transform, an axis, a type and an offset, plus a tool transform; ``velfence_filter.h``),
:func:`mdh_chain_data` a modified (Craig) one, and :func:`filter_cycle` builds the C object of a
:class:`~velfence.filter.SafetyFilter` whose robot gives its chain as data (``chain_data()``;
identity or diagonal weights; twist mode passes its metric's factor to each cycle);
:func:`compose` and :func:`translation` are the transforms of that layout. Internal API (the
binding's description, for the C cycle's tests and benchmarks): users get the C cycle through
``SafetyFilter(backend="c")`` (:attr:`~velfence.filter.SafetyFilter.cycle_in_c`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence.errors import InvalidParameter
from velfence.shaping.backend import compiled_filter

__all__ = [
    "c_cycle_or_none",
    "c_options",
    "chain_data",
    "compose",
    "filter_cycle",
    "mdh_chain_data",
    "translation",
]

_REVOLUTE = 0.0


def _tzxrx(a: float, alpha: float, d: float) -> FloatArray:
    """``Tz(d) Tx(a) Rx(alpha)`` as a 3 x 4 ``[R | p]`` (row-major, 12 floats)."""
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([1.0, 0.0, 0.0, a, 0.0, c, -s, 0.0, 0.0, s, c, d])


def _rxtxtz(a: float, alpha: float, d: float) -> FloatArray:
    """``Rx(alpha) Tx(a) Tz(d)`` as a 3 x 4 ``[R | p]`` (row-major, 12 floats)."""
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([1.0, 0.0, 0.0, a, 0.0, c, -s, -s * d, 0.0, s, c, c * d])


def compose(A: FloatArray, B: FloatArray) -> FloatArray:
    """The product ``A B`` of two rigid transforms given as their top 3 x 4 rows (12,).

    The C API's transform layout (``[R | p]`` row-major); returns the same layout.
    """
    Am = np.vstack([A.reshape(3, 4), [0.0, 0.0, 0.0, 1.0]])
    Bm = np.vstack([B.reshape(3, 4), [0.0, 0.0, 0.0, 1.0]])
    return np.asarray((Am @ Bm)[:3].ravel(), dtype=np.float64)


def translation(p: Any) -> FloatArray:
    """The pure translation by ``p = (x, y, z)`` in the C API's transform layout (12,)."""
    x, y, z = (float(v) for v in p)
    return np.array([1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, y, 0.0, 0.0, 1.0, z])


def chain_data(dh: Any, tool: Any = (0.0, 0.0, 0.0)) -> tuple[FloatArray, FloatArray]:
    """A standard DH table ``(a, alpha, d, theta_offset)`` (n, 4) as chain data.

    Returns ``(joints (n * 17,), tool (12,))``.

    The motion ``Rz(q + theta_offset)`` comes first in a standard DH row and its fixed part
    ``Tz(d) Tx(a) Rx(alpha)`` becomes the next joint's transform (the tool's for the last joint).
    """
    rows = np.asarray(dh, dtype=np.float64).reshape(-1, 4)
    n = rows.shape[0]
    joints = np.zeros((n, 17))
    prev = translation((0.0, 0.0, 0.0))
    for j, (a, alpha, d, off) in enumerate(rows.tolist()):
        joints[j, :12] = prev
        joints[j, 12:15] = (0.0, 0.0, 1.0)
        joints[j, 15] = _REVOLUTE
        joints[j, 16] = off
        prev = _tzxrx(a, alpha, d)
    return joints.ravel(), compose(prev, translation(tool))


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
    return joints.ravel(), compose(translation((0.0, 0.0, flange_d)), translation(tool))


def _dh5_chain(dh5: FloatArray, tool: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`chain_data` from ``ChainData`` rows ``(a, cos alpha, sin alpha, d, offset)``."""
    n = dh5.shape[0]
    joints = np.zeros((n, 17))
    prev = translation((0.0, 0.0, 0.0))
    for j, (a, c, s, d, off) in enumerate(dh5.tolist()):
        joints[j, :12] = prev
        joints[j, 12:15] = (0.0, 0.0, 1.0)
        joints[j, 15] = _REVOLUTE
        joints[j, 16] = off
        prev = np.array([1.0, 0.0, 0.0, a, 0.0, c, -s, 0.0, 0.0, s, c, d])
    return joints.ravel(), compose(prev, translation(tool))


def _points(dh5: FloatArray, point_index: dict[str, int]) -> dict[str, tuple[float, ...]]:
    """Every named point as ``(link, x, y, z)`` in the C chain's frames."""
    n = dh5.shape[0]
    out: dict[str, tuple[float, ...]] = {}
    for name, idx in point_index.items():
        if idx == n:  # the tool point
            out[name] = (float(n), 0.0, 0.0, 0.0)
        elif idx < 0:  # the last DH frame's origin: the last row's fixed part
            out[name] = (float(n - 1), float(dh5[n - 1, 0]), 0.0, float(dh5[n - 1, 3]))
        elif idx == 0:
            out[name] = (-1.0, 0.0, 0.0, 0.0)
        else:  # joint point P_idx: the origin of DH frame idx
            out[name] = (float(idx - 1), float(dh5[idx - 1, 0]), 0.0, float(dh5[idx - 1, 3]))
    return out


def _joint_profiles(sf: Any) -> list[Any]:
    """Each joint's approach profile, read from the filter's joint position rows."""
    from velfence.filter.rows import JointPositionLimit
    from velfence.shaping.profiles import LinearBuffer

    n = int(sf.dof)
    out: list[Any] = [LinearBuffer(buffer=0.1)] * n  # (joints without a finite limit: unused)
    for p in sf._providers:
        if isinstance(p, JointPositionLimit):
            for prof, _, sides in p._groups:
                for side in sides.tolist():
                    out[side // 2] = prof
    return out


def filter_cycle(sf: Any, profiles: Any = None) -> Any:
    """The C cycle (``velfence_core._filter.FilterCycle``) of a ``SafetyFilter``.

    The robot must give its chain as data (``chain_data()``, a DH chain, or ``chain_frames()``,
    a :class:`~velfence.filter.kinematics.ChainFrames`), the filter must have
    no custom row providers and identity or diagonal weights.

    Raises:
        InvalidParameter: the robot has no chain data, a custom provider or full-matrix
            weights, or the compiled core is not installed.
    """
    _filter = compiled_filter()
    if _filter is None:  # pragma: no cover - the core is an optional distribution
        raise InvalidParameter("the C filter cycle needs the compiled core (velfence_core)")
    from velfence.filter.rows import WorkspaceRows

    robot = sf.robot
    data = robot.chain_data() if hasattr(robot, "chain_data") else None
    frames = robot.chain_frames() if data is None and hasattr(robot, "chain_frames") else None
    if data is None and frames is None:
        raise InvalidParameter(
            f"robot: the C cycle needs the chain as data (chain_data() or chain_frames()), "
            f"{type(robot).__name__} gives none"
        )
    if len(sf._providers) != sf._n_builtin:
        raise InvalidParameter("providers: the C cycle runs the built-in rows only")
    metric = sf._metric
    if metric is not None and metric.ndim != 1:
        raise InvalidParameter("weights: the C cycle takes diagonal weights only")
    n = int(robot.dof)
    if data is not None:
        dh5 = np.asarray(data.dh, dtype=np.float64).reshape(n, 5)
        joints, tool = _dh5_chain(dh5, np.asarray(data.tool, dtype=np.float64))
        pts = _points(dh5, dict(data.point_index))
    else:
        assert frames is not None  # (one of the two, checked above)
        joints = np.asarray(frames.joints, dtype=np.float64).reshape(n * 17)
        tool = np.asarray(frames.tool, dtype=np.float64).reshape(12)
        pts = {k: tuple(float(v) for v in p) for k, p in frames.points.items()}
    lim = sf.limits
    jkind: list[int] = []
    jprm: list[float] = []
    for prof in _joint_profiles(sf) if profiles is None else profiles:
        kind, params = prof.kernel_profile
        jkind.append(int(kind))
        jprm.extend(float(v) for v in params)
    names = list(pts)
    ws = []
    for p in sf._providers:
        if isinstance(p, WorkspaceRows):
            kind, params = p.profile.kernel_profile
            poly = p.limit.polytope
            ws.append(
                (
                    names.index(p.limit.point),
                    np.ascontiguousarray(poly.normals, dtype=np.float64).ravel(),
                    np.ascontiguousarray(poly.offsets, dtype=np.float64),
                    int(kind),
                    np.array(params, dtype=np.float64),
                )
            )
    obs = sf.obstacles
    centres = np.array([o.center for o in obs], dtype=np.float64).reshape(-1)
    radii = np.array([o.radius for o in obs], dtype=np.float64)
    lr = (
        np.asarray(getattr(robot, "link_radius", np.zeros(1)), dtype=np.float64).reshape(-1)
        if obs or sf.self_collision_pairs
        else np.zeros(1)
    )
    lrad = np.ascontiguousarray(np.broadcast_to(lr if lr.shape[0] > 1 else lr[:1], (n,)))
    acc = lim.max_acceleration
    return _filter.FilterCycle(
        joints, tool, np.asarray(lim.lower, dtype=np.float64),
        np.asarray(lim.upper, dtype=np.float64), np.asarray(lim.max_speed, dtype=np.float64),
        None if acc is None else np.asarray(acc, dtype=np.float64), jkind,
        np.array(jprm), np.array([v for nm in names for v in pts[nm]]), ws, centres, radii,
        lrad, float(sf.obstacle_buffer), float(sf.spring_gain), float(sf.dt or 0.0),
        None if metric is None else np.asarray(metric) ** 2,
        None if lim.max_jerk is None else np.asarray(lim.max_jerk, dtype=np.float64),
        self_pairs=[v for pr in sf.self_collision_pairs for v in pr] or None,
        attachments=None if sf._attach is None else sf._attach.flat(),
    )  # fmt: skip


def c_cycle_or_none(sf: Any, profiles: Any = None) -> Any:
    """:func:`filter_cycle` with the filter's options set, or ``None`` where C cannot run it.

    ``None`` without the compiled ``_filter`` module, for a robot without chain data, with
    custom row providers or a full weight matrix, or when the C check refuses the description
    (then the Python route runs, as before). No warm start: a cycle's output depends on its
    state only, so ``filter`` and ``explain`` of one state agree bit for bit.
    """
    try:
        fc = filter_cycle(sf, profiles)
    except (InvalidParameter, ValueError, TypeError):
        return None
    fc.set_options(**c_options(sf))
    return fc


def c_options(sf: Any) -> dict[str, Any]:
    """The filter's ``max_iterations`` (clamped to the C int32) and ``time_budget`` for C."""
    cap = min(int(sf.max_iterations or 0), 2**31 - 1)
    return {"max_iterations": cap, "time_budget": float(sf.time_budget or 0.0), "warm": False}
