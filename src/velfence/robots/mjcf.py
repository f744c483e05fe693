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

Physical parameters (all optional, keyword-only): ``masses`` [kg], ``centers_of_mass`` [m] and
``inertias`` [kg·m²] of the links, each in the *link frame* (standard DH: DH frame ``i``, at the
link's distal joint, as Universal Robots and Corke publish them; modified DH: frame ``i``, the
body itself, as Franka publishes them); without ``centers_of_mass`` a link's centre of mass is
the middle of its segment, without ``inertias`` the link is a solid cylinder of radius
``LINK_CYLINDER_RADIUS`` (0.05 m) along its segment (an approximation, say so where you use it).
Without ``masses`` every link is a unit point mass (a kinematic placeholder).
``effort_limits`` [N·m] become each joint's ``actuatorfrcrange`` (MuJoCo's
``jnt_actfrcrange``); ``velocity_limits`` [rad/s], ``acceleration_limits`` [rad/s²] and
``jerk_limits`` [rad/s³], which MJCF has no attribute for, ``<custom><numeric>`` elements of
those names; :class:`MujocoRobot` reads them back (``+inf`` where a model has none). No
``<option>`` is written: gravity and time step belong to whoever simulates the arm.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import positional_deprecated
from velfence._typing import FloatArray
from velfence._validate import check_positive, check_text, real_array
from velfence.errors import InvalidGeometry, InvalidParameter
from velfence.geometry.so3 import rotation_from_quaternion

__all__ = ["dh_mjcf", "mdh_mjcf"]

#: Radius [m] of the solid cylinder a link's inertia is approximated by when none is given.
LINK_CYLINDER_RADIUS = 0.05
#: Name of the ``<custom><numeric>`` element that holds the joint velocity limits [rad/s].
VELOCITY_LIMITS_NUMERIC = "velocity_limits"
#: Names of the ``<custom><numeric>`` elements of the joint acceleration [rad/s²] and jerk
#: [rad/s³] limits.
ACCELERATION_LIMITS_NUMERIC = "acceleration_limits"
JERK_LIMITS_NUMERIC = "jerk_limits"


def _mujoco() -> Any:
    """The mujoco module (imported on first use), for robots.model and robots.urdf."""
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - the physics extra is missing
        raise InvalidParameter(
            "xml: loading an MJCF model needs the 'mujoco' package, got ImportError; "
            "install velfence[physics]"
        ) from exc
    return mujoco


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


def _limit_vector(arg: str, value: ArrayLike | None, n: int, unit: str) -> FloatArray | None:
    """Per-joint limits, shape (n,), each finite and > 0 (``None``: none at all)."""
    if value is None:
        return None
    a = real_array(arg, value, (n,), error=InvalidParameter, what=f"limits {unit}")
    if np.any(a <= 0.0):
        raise InvalidParameter(f"{arg}: expected one limit > 0 {unit} per joint, got {a.tolist()}")
    return a


def _inertia_matrices(value: ArrayLike, n: int) -> FloatArray:
    """Link inertias (n, 3) principal or (n, 6) ``Ixx Iyy Izz Ixy Ixz Iyz`` as (n, 3, 3)."""
    a = real_array("inertias", value, None, error=InvalidParameter, what="inertias [kg·m²]")
    if a.ndim != 2 or a.shape[0] != n or a.shape[1] not in (3, 6):
        raise InvalidParameter(
            f"inertias: expected shape ({n}, 3) (principal moments) or ({n}, 6) "
            f"(Ixx, Iyy, Izz, Ixy, Ixz, Iyz) [kg·m²], got shape {a.shape}"
        )
    full = np.zeros((n, 6))
    full[:, : a.shape[1]] = a
    out = np.empty((n, 3, 3))
    for i, (xx, yy, zz, xy, xz, yz) in enumerate(full.tolist()):
        out[i] = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]
        ev = np.linalg.eigvalsh(out[i])
        tol = 1e-9 * max(float(ev.max()), 1e-12)
        if ev.min() < -tol or ev[0] + ev[1] < ev[2] - tol:
            raise InvalidParameter(
                f"inertias: expected physical inertia tensors (principal moments >= 0, "
                f"A + B >= C), got principal moments {ev.tolist()} on link {i}"
            )
    return out


def _cylinder(mass: float, segment: FloatArray) -> FloatArray:
    """Inertia [kg·m²] about the centre of a solid cylinder along ``segment`` (body frame)."""
    length = float(np.linalg.norm(segment))
    e = segment / length if length > 1e-9 else np.array([0.0, 0.0, 1.0])
    r2 = LINK_CYLINDER_RADIUS**2
    axial = mass * r2 / 2.0
    across = mass * (3.0 * r2 + length**2) / 12.0
    out: FloatArray = across * (np.eye(3) - np.outer(e, e)) + axial * np.outer(e, e)
    return out


class _Physics:
    """Validated physical parameters of an ``n``-link arm (module docs)."""

    def __init__(
        self,
        n: int,
        masses: ArrayLike | None,
        centers_of_mass: ArrayLike | None,
        inertias: ArrayLike | None,
        velocity_limits: ArrayLike | None,
        effort_limits: ArrayLike | None,
        acceleration_limits: ArrayLike | None = None,
        jerk_limits: ArrayLike | None = None,
    ) -> None:
        self.masses: FloatArray | None = None
        self.coms: FloatArray | None = None
        self.inertias: FloatArray | None = None
        if masses is None:
            for arg, val in (("centers_of_mass", centers_of_mass), ("inertias", inertias)):
                if val is not None:
                    raise InvalidParameter(
                        f"{arg}: expected None when masses is None (unit placeholder masses), "
                        f"got a value; give masses [kg] too"
                    )
        else:
            m = real_array("masses", masses, (n,), error=InvalidParameter, what="masses [kg]")
            if np.any(m <= 0.0):
                raise InvalidParameter(
                    f"masses: expected one mass > 0 [kg] per link (MuJoCo needs moving bodies "
                    f"to have mass), got {m.tolist()}"
                )
            self.masses = m
            if centers_of_mass is not None:
                self.coms = real_array(
                    "centers_of_mass",
                    centers_of_mass,
                    (n, 3),
                    error=InvalidParameter,
                    what="centres of mass [m]",
                )
            if inertias is not None:
                self.inertias = _inertia_matrices(inertias, n)
        self.velocity = _limit_vector("velocity_limits", velocity_limits, n, "[rad/s]")
        self.effort = _limit_vector("effort_limits", effort_limits, n, "[N·m]")
        self.acceleration = _limit_vector("acceleration_limits", acceleration_limits, n, "[rad/s²]")
        self.jerk = _limit_vector("jerk_limits", jerk_limits, n, "[rad/s³]")

    def inertial(self, i: int, link: tuple[FloatArray, FloatArray], segment: FloatArray) -> str:
        """The ``<inertial>`` element of body ``i``.

        ``link`` is (pos, quat) of the link frame in the body frame; ``segment`` the vector from
        the body origin to the next body (or flange), in the body frame.
        """
        if self.masses is None:
            return '<inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>'
        mass = float(self.masses[i])
        rot = rotation_from_quaternion(link[1])
        com = segment / 2.0 if self.coms is None else link[0] + rot @ self.coms[i]
        if self.inertias is None:
            inertia = _cylinder(mass, segment)
        else:
            inertia = rot @ self.inertias[i] @ rot.T
        full = [inertia[0, 0], inertia[1, 1], inertia[2, 2]]
        full += [inertia[0, 1], inertia[0, 2], inertia[1, 2]]
        return f'<inertial pos="{_fmt(com)}" mass="{mass!r}" fullinertia="{_fmt(full)}"/>'

    def joint_extra(self, i: int) -> str:
        """Attributes of joint ``i`` beyond name, type, axis and range."""
        if self.effort is None:
            return ""
        e = float(self.effort[i])
        return f' actuatorfrcrange="{_fmt([-e, e])}"'

    def custom(self) -> list[str]:
        """The ``<custom>`` lines (the velocity, acceleration and jerk limits), or none."""
        lines = []
        for name, values in (
            (VELOCITY_LIMITS_NUMERIC, self.velocity),
            (ACCELERATION_LIMITS_NUMERIC, self.acceleration),
            (JERK_LIMITS_NUMERIC, self.jerk),
        ):
            if values is not None:
                data = " ".join(repr(v) for v in values.tolist())
                lines.append(f'    <numeric name="{name}" data="{data}"/>')
        return ["  <custom>", *lines, "  </custom>"] if lines else []


def _inputs(
    rows_name: str,
    rows: ArrayLike,
    joint_limits: ArrayLike,
    tool: ArrayLike | None,
    name: Any,
    radius: Any,
    named_points: Mapping[str, int] | None,
) -> tuple[FloatArray, FloatArray, FloatArray, str, FloatArray, dict[str, int]]:
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
    n_rows = r.shape[0]
    per_link = isinstance(radius, (list, tuple)) or (
        isinstance(radius, np.ndarray) and radius.ndim > 0
    )
    if not per_link:
        rad = np.full(n_rows, check_positive("radius", radius, allow_zero=True, unit="[m]"))
    else:
        rad = real_array("radius", radius, (n_rows,), error=InvalidParameter, what="radii [m]")
        if np.any(rad < 0.0):
            raise InvalidParameter(
                f"radius: expected radii >= 0 [m], one per link, got {rad.tolist()}"
            )
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
    radius: FloatArray,
    named: dict[str, int],
    physics: _Physics,
    links: list[tuple[FloatArray, FloatArray]],
) -> str:
    """Nest the bodies: ``frames[i]`` = (pos, quat) of body ``i`` in its parent.

    ``links[i]`` = (pos, quat) of link ``i``'s frame (where its physical parameters are given)
    in body ``i``.
    """
    n = len(frames)
    lines = [
        f"<mujoco model={quoteattr(name)}>",
        '  <compiler angle="radian" autolimits="true"/>',
        *physics.custom(),
        "  <worldbody>",
    ]
    children = [*frames[1:], flange]
    for i, (pos, quat) in enumerate(frames):
        ind = "  " * (i + 2)
        lines.append(f'{ind}<body name="link{i}" pos="{_fmt(pos)}" quat="{_fmt(quat)}">')
        lines.append(f"{ind}  {physics.inertial(i, links[i], children[i][0])}")
        lines.append(
            f'{ind}  <joint name="joint{i}" type="hinge" axis="0 0 1" range="{_fmt(lim[i])}"'
            f"{physics.joint_extra(i)}/>"
        )
        lines.append(f'{ind}  <site name="joint{i}" pos="0 0 0"/>')
        for key, idx in named.items():
            if idx == i:
                lines.append(f'{ind}  <site name={quoteattr(key)} pos="0 0 0"/>')
        end = children[i][0]
        ri = float(radius[i])
        if ri > 0.0 and float(np.linalg.norm(end)) > 1e-9:
            lines.append(
                f'{ind}  <geom type="capsule" size="{ri!r}" fromto="0 0 0 {_fmt(end)}" '
                'contype="2" conaffinity="0" mass="0"/>'
            )
        elif ri > 0.0 and radius.min() != radius.max():
            # A zero-length link with its own radius: a sphere (robots.capsules reads it back).
            lines.append(
                f'{ind}  <geom type="sphere" size="{ri!r}" pos="0 0 0" '
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


@positional_deprecated(1, ("dh_rows", "joint_limits", "tool", "name"))
def dh_mjcf(
    dh_rows: ArrayLike,
    *,
    joint_limits: ArrayLike,
    tool: ArrayLike | None = None,
    name: str = "arm",
    radius: float | ArrayLike = 0.0,
    named_points: Mapping[str, int] | None = None,
    masses: ArrayLike | None = None,
    centers_of_mass: ArrayLike | None = None,
    inertias: ArrayLike | None = None,
    velocity_limits: ArrayLike | None = None,
    effort_limits: ArrayLike | None = None,
    acceleration_limits: ArrayLike | None = None,
    jerk_limits: ArrayLike | None = None,
) -> str:
    """MJCF of a revolute arm from standard DH rows (module docs for the frames).

    Args:
        dh_rows: Standard DH rows ``(a [m], alpha [rad], d [m], theta_offset [rad])``,
            shape (n, 4); ``theta_offset`` is folded into the body placements, so MuJoCo's
            ``qpos`` is the DH joint variable minus the offset, as in ``DHChain``.
        joint_limits: Lower/upper limit of each joint [rad], shape (n, 2), lower < upper.
        tool: Tool point in the last DH frame [m], shape (3,); the flange when ``None``.
        name: Model name (any string; XML-escaped).
        radius: Capsule radius of the link geoms [m], ``>= 0``, one for all links or one per
            link, shape (n,); ``0``: no geom (such a link reads back the largest radius, see
            ``velfence.robots.capsules``). With radii per link, a zero-length link gets a
            sphere geom of its radius.
        named_points: Extra site names mapped to a joint index ``j`` (a site at joint ``j``'s
            body origin), e.g. ``{"elbow": 2}``.
        masses: Link masses [kg], shape (n,), each > 0; ``None``: unit placeholder masses.
        centers_of_mass: Link centres of mass in the link frame [m], shape (n, 3) (module
            docs; needs ``masses``); ``None``: the middle of each link's segment.
        inertias: Link inertias about the centre of mass in the link frame [kg·m²], shape
            (n, 3) principal moments or (n, 6) ``Ixx, Iyy, Izz, Ixy, Ixz, Iyz`` (needs
            ``masses``); ``None``: a solid cylinder along the link (module docs).
        velocity_limits: Joint speed limits [rad/s], shape (n,), finite, > 0; ``None``: none.
        effort_limits: Joint torque limits [N·m], shape (n,), finite, > 0; ``None``: none.
        acceleration_limits: Joint acceleration limits [rad/s²], shape (n,), finite, > 0;
            ``None``: none.
        jerk_limits: Joint jerk limits [rad/s³], shape (n,), finite, > 0; ``None``: none.

    Returns:
        The MJCF document (str), to pass to :meth:`MujocoRobot.from_xml`.

    Raises:
        InvalidGeometry: bad rows, limits, tool, name or named points.
        InvalidParameter: a negative radius, or bad physical parameters.
    """
    r, lim, t, nm, rad, pts = _inputs(
        "dh_rows", dh_rows, joint_limits, tool, name, radius, named_points
    )
    n = r.shape[0]
    frames: list[tuple[FloatArray, FloatArray]] = [(np.zeros(3), np.array([1.0, 0, 0, 0]))]
    statics: list[tuple[FloatArray, FloatArray]] = []
    for a, alpha, d, off in r.tolist():
        pos = np.array([a * math.cos(off), a * math.sin(off), d])
        statics.append((pos, _quat_mul(_qz(off), _qx(alpha))))
    frames += statics[:-1]
    phys = _Physics(
        n, masses, centers_of_mass, inertias, velocity_limits, effort_limits,
        acceleration_limits, jerk_limits,
    )  # fmt: skip
    return _document(nm, frames, statics[-1], lim, t, rad, pts, phys, statics)


@positional_deprecated(1, ("mdh_rows", "joint_limits", "tool", "name"))
def mdh_mjcf(
    mdh_rows: ArrayLike,
    *,
    joint_limits: ArrayLike,
    tool: ArrayLike | None = None,
    name: str = "arm",
    flange_d: float = 0.0,
    radius: float | ArrayLike = 0.0,
    named_points: Mapping[str, int] | None = None,
    masses: ArrayLike | None = None,
    centers_of_mass: ArrayLike | None = None,
    inertias: ArrayLike | None = None,
    velocity_limits: ArrayLike | None = None,
    effort_limits: ArrayLike | None = None,
    acceleration_limits: ArrayLike | None = None,
    jerk_limits: ArrayLike | None = None,
) -> str:
    """MJCF of a revolute arm from modified (Craig) DH rows (module docs for the frames).

    Args:
        mdh_rows: Rows ``(a_{i-1} [m], alpha_{i-1} [rad], d_i [m], theta_offset [rad])``,
            shape (n, 4).
        joint_limits: Lower/upper limit of each joint [rad], shape (n, 2), lower < upper.
        tool: Tool point in the flange frame [m], shape (3,); the flange when ``None``.
        name: Model name (any string; XML-escaped).
        flange_d: Distance of the flange along the last joint's ``z`` axis [m].
        radius: Capsule radius of the link geoms [m], ``>= 0``, a scalar or shape (n,) (see
            :func:`dh_mjcf`); ``0``: no geom.
        named_points: Extra site names mapped to a joint index (see :func:`dh_mjcf`).
        masses: Link masses [kg], shape (n,), each > 0; ``None``: unit placeholder masses.
        centers_of_mass: Link centres of mass in frame ``i`` (the body) [m], shape (n, 3)
            (needs ``masses``); ``None``: the middle of each link's segment.
        inertias: Link inertias about the centre of mass in frame ``i`` [kg·m²], shape (n, 3)
            or (n, 6), as in :func:`dh_mjcf` (needs ``masses``); ``None``: a solid cylinder.
        velocity_limits: Joint speed limits [rad/s], shape (n,), finite, > 0; ``None``: none.
        effort_limits: Joint torque limits [N·m], shape (n,), finite, > 0; ``None``: none.
        acceleration_limits: Joint acceleration limits [rad/s²], shape (n,), finite, > 0;
            ``None``: none.
        jerk_limits: Joint jerk limits [rad/s³], shape (n,), finite, > 0; ``None``: none.

    Returns:
        The MJCF document (str).

    Raises:
        InvalidGeometry: bad rows, limits, tool, name, flange_d or named points.
        InvalidParameter: a negative radius, or bad physical parameters.
    """
    r, lim, t, nm, rad, pts = _inputs(
        "mdh_rows", mdh_rows, joint_limits, tool, name, radius, named_points
    )
    n = r.shape[0]
    fd = real_array("flange_d", flange_d, (), error=InvalidGeometry, what="a distance [m]")
    frames: list[tuple[FloatArray, FloatArray]] = []
    for a, alpha, d, off in r.tolist():
        # R_x(α) T_x(a) R_z(θ0) T_z(d): the joint's R_z(q) follows at the body origin.
        pos = np.array([a, -d * math.sin(alpha), d * math.cos(alpha)])
        frames.append((pos, _quat_mul(_qx(alpha), _qz(off))))
    flange = (np.array([0.0, 0.0, float(fd)]), np.array([1.0, 0.0, 0.0, 0.0]))
    phys = _Physics(
        n, masses, centers_of_mass, inertias, velocity_limits, effort_limits,
        acceleration_limits, jerk_limits,
    )  # fmt: skip
    identity = [(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))] * n
    return _document(nm, frames, flange, lim, t, rad, pts, phys, identity)
