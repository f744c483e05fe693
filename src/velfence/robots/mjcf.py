r"""MJCF text of serial arms built from Denavit-Hartenberg tables.

Two conventions, both with revolute joints about the local ``z`` axis of a body whose frame is
the joint's DH frame:

* standard DH (:func:`dh_mjcf`), rows ``(a [m], alpha [rad], d [m], theta_offset [rad])``, link
  transform :math:`A_i = R_z(q_i + θ^0_i)\,T_z(d_i)\,T_x(a_i)\,R_x(α_i)`: body ``i`` carries
  joint ``i`` at the origin of DH frame ``i - 1``; the static part of :math:`A_i` places the next
  body (or the flange) in it;
* modified DH of Craig (:func:`mdh_mjcf`), rows ``(a_{i-1} [m], alpha_{i-1} [rad], d_i [m],
  theta_offset [rad])``, :math:`T_i = R_x(α_{i-1})\,T_x(a_{i-1})\,R_z(q_i + θ^0_i)\,T_z(d_i)`:
  body ``i`` is DH frame ``i``; the flange sits ``flange_d`` along the last ``z``.

Sites: ``"tcp"`` (the flange plus ``tool`` in the flange frame), ``"flange"``, ``"joint0"`` …
``"joint{n-1}"`` (each joint's body origin, on its axis) and the ``named_points``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import check_positive, check_text, real_array
from velfence.errors import InvalidGeometry

__all__ = ["dh_mjcf", "mdh_mjcf"]


def _quat_mul(p: FloatArray, q: FloatArray) -> FloatArray:
    """Hamilton product of two quaternions ``(w, x, y, z)``."""
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def _qx(a: float) -> FloatArray:
    return np.array([math.cos(a / 2.0), math.sin(a / 2.0), 0.0, 0.0])


def _qz(a: float) -> FloatArray:
    return np.array([math.cos(a / 2.0), 0.0, 0.0, math.sin(a / 2.0)])


def _fmt(v: Any) -> str:
    return " ".join(repr(float(x)) for x in np.asarray(v, dtype=float).ravel())


def _inputs(
    rows_name: str,
    rows: ArrayLike,
    joint_limits: ArrayLike,
    tool: ArrayLike | None,
    name: Any,
    radius: Any,
    named_points: Mapping[str, int] | None,
) -> tuple[FloatArray, FloatArray, FloatArray, str, float, dict[str, int]]:
    r = real_array(rows_name, rows, (None, 4), error=InvalidGeometry, what="DH rows")
    n = r.shape[0]
    if n < 1:
        raise InvalidGeometry(f"{rows_name}: expected at least one row of shape (4,), got 0 rows")
    lim = real_array(
        "joint_limits", joint_limits, (None, 2), error=InvalidGeometry, what="limits [rad]"
    )
    if lim.shape[0] != n:
        raise InvalidGeometry(
            f"joint_limits: expected one (lower, upper) row per row of {rows_name} ({n}), got "
            f"{lim.shape[0]} rows; or {rows_name}: expected {lim.shape[0]} rows, got {n}"
        )
    if not np.all(lim[:, 0] < lim[:, 1]):
        bad = np.flatnonzero(lim[:, 0] >= lim[:, 1]).tolist()
        raise InvalidGeometry(
            f"joint_limits: expected lower < upper on every joint, got lower >= upper on "
            f"joint(s) {bad}"
        )
    t = np.zeros(3) if tool is None else real_array("tool", tool, (3,), error=InvalidGeometry)
    nm = check_text("name", name, error=InvalidGeometry)
    rad = check_positive("radius", radius, allow_zero=True, unit="[m]")
    pts: dict[str, int] = {}
    if named_points is not None and not isinstance(named_points, Mapping):
        raise InvalidGeometry(
            f"named_points: expected a mapping of site names to joint indices, got "
            f"{type(named_points).__name__}"
        )
    for key, idx in dict(named_points or {}).items():
        if not isinstance(key, str) or not key:
            raise InvalidGeometry(
                f"named_points: expected non-empty str site names, got {type(key).__name__}"
            )
        if isinstance(idx, bool) or not isinstance(idx, (int, np.integer)) or not 0 <= idx < n:
            raise InvalidGeometry(
                f"named_points: expected a joint index (int) in [0, {n - 1}] for {key[:40]!r}, "
                f"got {type(idx).__name__}"
            )
        if key in ("tcp", "flange") or (key.startswith("joint") and key[5:].isdigit()):
            raise InvalidGeometry(
                f"named_points: expected a name other than tcp, flange, joint<j>, got {key!r}"
            )
        pts[key] = int(idx)
    return r, lim, t, nm, rad, pts


def _document(
    name: str,
    frames: list[tuple[FloatArray, FloatArray]],
    flange: tuple[FloatArray, FloatArray],
    lim: FloatArray,
    tool: FloatArray,
    radius: float,
    named: dict[str, int],
) -> str:
    """Nest the bodies: ``frames[i]`` = (pos, quat) of body ``i`` in its parent."""
    n = len(frames)
    lines = [
        f"<mujoco model={quoteattr(name)}>",
        '  <compiler angle="radian" autolimits="true"/>',
        '  <option gravity="0 0 0"/>',
        "  <worldbody>",
    ]
    children = [*frames[1:], flange]
    for i, (pos, quat) in enumerate(frames):
        ind = "  " * (i + 2)
        lines.append(f'{ind}<body name="link{i}" pos="{_fmt(pos)}" quat="{_fmt(quat)}">')
        lines.append(f'{ind}  <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>')
        lines.append(
            f'{ind}  <joint name="joint{i}" type="hinge" axis="0 0 1" range="{_fmt(lim[i])}"/>'
        )
        lines.append(f'{ind}  <site name="joint{i}" pos="0 0 0"/>')
        for key, idx in named.items():
            if idx == i:
                lines.append(f'{ind}  <site name={quoteattr(key)} pos="0 0 0"/>')
        end = children[i][0]
        if radius > 0.0 and float(np.linalg.norm(end)) > 1e-9:
            lines.append(
                f'{ind}  <geom type="capsule" size="{radius!r}" fromto="0 0 0 {_fmt(end)}" '
                'contype="2" conaffinity="0" mass="0"/>'
            )
    ind = "  " * (n + 2)
    lines.append(f'{ind}<body name="flange" pos="{_fmt(flange[0])}" quat="{_fmt(flange[1])}">')
    lines.append(f'{ind}  <site name="flange" pos="0 0 0"/>')
    lines.append(f'{ind}  <site name="tcp" pos="{_fmt(tool)}"/>')
    lines.append(f"{ind}</body>")
    for i in reversed(range(n)):
        lines.append("  " * (i + 2) + "</body>")
    lines += ["  </worldbody>", "</mujoco>", ""]
    return "\n".join(lines)


def dh_mjcf(
    dh_rows: ArrayLike,
    joint_limits: ArrayLike,
    tool: ArrayLike | None = None,
    name: str = "arm",
    *,
    radius: float = 0.0,
    named_points: Mapping[str, int] | None = None,
) -> str:
    """MJCF of a revolute arm from standard DH rows (module docs for the frames).

    Args:
        dh_rows: Standard DH rows ``(a [m], alpha [rad], d [m], theta_offset [rad])``,
            shape (n, 4); ``theta_offset`` is folded into the body placements, so MuJoCo's
            ``qpos`` is the DH joint variable minus the offset, as in ``DHChain``.
        joint_limits: Lower/upper limit of each joint [rad], shape (n, 2), lower < upper.
        tool: Tool point in the last DH frame [m], shape (3,); the flange when ``None``.
        name: Model name (any string; XML-escaped).
        radius: Capsule radius of the link geoms [m], ``>= 0``; ``0``: no geoms.
        named_points: Extra site names mapped to a joint index ``j`` (a site at joint ``j``'s
            body origin), e.g. ``{"elbow": 2}``.

    Returns:
        The MJCF document (str), to pass to :meth:`MujocoRobot.from_xml`.

    Raises:
        InvalidGeometry: bad rows, limits, tool, name or named points.
        InvalidParameter: a negative radius.
    """
    r, lim, t, nm, rad, pts = _inputs(
        "dh_rows", dh_rows, joint_limits, tool, name, radius, named_points
    )
    frames: list[tuple[FloatArray, FloatArray]] = [(np.zeros(3), np.array([1.0, 0, 0, 0]))]
    statics: list[tuple[FloatArray, FloatArray]] = []
    for a, alpha, d, off in r.tolist():
        pos = np.array([a * math.cos(off), a * math.sin(off), d])
        statics.append((pos, _quat_mul(_qz(off), _qx(alpha))))
    frames += statics[:-1]
    return _document(nm, frames, statics[-1], lim, t, rad, pts)


def mdh_mjcf(
    mdh_rows: ArrayLike,
    joint_limits: ArrayLike,
    tool: ArrayLike | None = None,
    name: str = "arm",
    *,
    flange_d: float = 0.0,
    radius: float = 0.0,
    named_points: Mapping[str, int] | None = None,
) -> str:
    """MJCF of a revolute arm from modified (Craig) DH rows (module docs for the frames).

    Args:
        mdh_rows: Rows ``(a_{i-1} [m], alpha_{i-1} [rad], d_i [m], theta_offset [rad])``,
            shape (n, 4).
        joint_limits: Lower/upper limit of each joint [rad], shape (n, 2), lower < upper.
        tool: Tool point in the flange frame [m], shape (3,); the flange when ``None``.
        name: Model name (any string; XML-escaped).
        flange_d: Distance of the flange along the last joint's ``z`` axis [m].
        radius: Capsule radius of the link geoms [m], ``>= 0``; ``0``: no geoms.
        named_points: Extra site names mapped to a joint index (see :func:`dh_mjcf`).

    Returns:
        The MJCF document (str).

    Raises:
        InvalidGeometry: bad rows, limits, tool, name, flange_d or named points.
        InvalidParameter: a negative radius.
    """
    r, lim, t, nm, rad, pts = _inputs(
        "mdh_rows", mdh_rows, joint_limits, tool, name, radius, named_points
    )
    fd = real_array("flange_d", flange_d, (), error=InvalidGeometry, what="a distance [m]")
    frames: list[tuple[FloatArray, FloatArray]] = []
    for a, alpha, d, off in r.tolist():
        # R_x(α) T_x(a) R_z(θ0) T_z(d): the joint's R_z(q) follows at the body origin.
        pos = np.array([a, -d * math.sin(alpha), d * math.cos(alpha)])
        frames.append((pos, _quat_mul(_qx(alpha), _qz(off))))
    flange = (np.array([0.0, 0.0, float(fd)]), np.array([1.0, 0.0, 0.0, 0.0]))
    return _document(nm, frames, flange, lim, t, rad, pts)
