"""Limits a :class:`~velfence.filter.SafetyFilter` enforces: joints, workspace, obstacles.

Frozen, validated value objects (their units and shapes in each class); the filter turns them into
rows of its minimum-change problem every cycle.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import KW_ONLY, dataclass, field
from typing import Any

import numpy as np

from velfence._deprecate import positional_deprecated, renamed_args, renamed_attribute
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_positive,
    check_text,
    describe,
    finite_scalar,
    readonly,
    real_array,
    show,
)
from velfence.errors import InvalidParameter
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking

__all__ = [
    "Capsule",
    "JointLimits",
    "Profile",
    "SelfCollision",
    "Sphere",
    "SphereObstacle",
    "WorkspaceLimit",
]

#: The approach profiles the filter's rows understand (the exact law's kernel profiles).
Profile = LinearBuffer | ThreeZoneBraking


def _vector(
    name: str, x: Any, n: int | None, what: str, *, nonfinite: bool = False, scalar: bool = False
) -> FloatArray:
    """One value per joint: shape (n,) (``scalar``: a number is repeated); NaN refused."""
    a = real_array(
        name, x, None, error=InvalidParameter, what=what, allow_nonfinite=nonfinite, max_abs=None
    )
    if scalar and a.ndim == 0 and n is not None:
        a = np.full(n, float(a))
    if a.ndim != 1 or (n is not None and a.shape[0] != n):
        want = "(n,)" if n is None else f"({n},), one per joint of lower"
        raise InvalidParameter(f"{name}: expected shape {want}, got shape {a.shape}")
    if np.isnan(a).any():
        raise InvalidParameter(f"{name}: expected {what}, got NaN in {a.tolist()}")
    big = np.isfinite(a) & (np.abs(a) > MAX_MAGNITUDE)
    if big.any():
        raise InvalidParameter(f"{name}: expected magnitudes <= {MAX_MAGNITUDE:g}, got {a[big]}")
    return a


@dataclass(frozen=True)
class JointLimits:
    """Position, velocity and (optional) acceleration and jerk limits of every joint.

    The speed limit was called ``max_velocity`` before 0.2: that keyword and attribute warn until
    0.3.

    Attributes:
        lower: Lower position limit of each joint [rad], shape (n,); ``-inf``: none.
        upper: Upper position limit [rad], shape (n,), ``> lower``; ``+inf``: none.
        max_speed: Largest joint speed [rad/s], shape (n,), finite and > 0 (a scalar is
            repeated).
        max_acceleration: Largest joint acceleration [rad/s²], shape (n,), > 0, ``inf`` for a
            joint without one; ``None`` (the default): none on any joint.
        max_jerk: Largest joint jerk [rad/s³], shape (n,) (a scalar is repeated), > 0, ``inf``
            for a joint without one; ``None`` (the default): none on any joint. A
            :class:`SafetyFilter` with ``dt`` bounds the change of the acceleration per period
            by it (the jerk rows, ``docs/safety_filter.md``).
        names: One name per joint, or ``None``; when given, a :class:`SafetyFilter` checks it
            against the robot's ``joint_names``.

    Raises:
        InvalidParameter: wrong shapes, NaN, ``lower >= upper``, non-positive or infinite
            speeds, non-positive accelerations or jerks, or names of the wrong number.
    """

    lower: FloatArray
    upper: FloatArray
    _: KW_ONLY
    max_speed: FloatArray
    max_acceleration: FloatArray | None = None
    names: tuple[str, ...] | None = None
    max_jerk: FloatArray | None = None

    max_velocity = renamed_attribute("max_velocity", "max_speed")

    def __post_init__(self) -> None:
        lo = _vector("lower", self.lower, None, "lower limits [rad] of shape (n,)", nonfinite=True)
        n = lo.shape[0]
        if n < 1:
            raise InvalidParameter("lower: expected at least one joint, got shape (0,)")
        hi = _vector("upper", self.upper, n, f"upper limits [rad] of shape ({n},)", nonfinite=True)
        if lo.max() == math.inf or hi.min() == -math.inf:
            raise InvalidParameter(
                "lower, upper: expected lower < +inf and upper > -inf (infinite limits mean no "
                f"limit on that side), got lower={lo.tolist()}, upper={hi.tolist()}"
            )
        bad = np.flatnonzero(~(hi > lo))
        if bad.size:
            j = int(bad[0])
            raise InvalidParameter(
                f"upper: expected upper > lower on every joint, got upper[{j}]={show(hi[j])} <= "
                f"lower[{j}]={show(lo[j])}"
            )
        v = _vector(
            "max_speed", self.max_speed, n, f"joint speeds [rad/s] of shape ({n},)",
            scalar=True,
        )  # fmt: skip
        if not np.all(v > 0.0):
            raise InvalidParameter(f"max_speed: expected speeds > 0 [rad/s], got {v.tolist()}")
        acc: FloatArray | None = None
        if self.max_acceleration is not None:
            acc = _vector(
                "max_acceleration", self.max_acceleration, n,
                f"accelerations [rad/s²] of shape ({n},)", nonfinite=True, scalar=True,
            )  # fmt: skip
            if not np.all(acc > 0.0):
                raise InvalidParameter(
                    f"max_acceleration: expected accelerations > 0 [rad/s²] (inf: none), got "
                    f"{acc.tolist()}"
                )
            acc = readonly(acc)
        jerk: FloatArray | None = None
        if self.max_jerk is not None:
            jerk = _vector(
                "max_jerk", self.max_jerk, n, f"jerks [rad/s³] of shape ({n},)",
                nonfinite=True, scalar=True,
            )  # fmt: skip
            if not np.all(jerk > 0.0):
                raise InvalidParameter(
                    f"max_jerk: expected jerks > 0 [rad/s³] (inf: none), got {jerk.tolist()}"
                )
            jerk = readonly(jerk)
        names = None
        raw_names: Any = self.names
        if raw_names is not None:
            if isinstance(raw_names, (str, bytes)) or not isinstance(raw_names, (list, tuple)):
                raise InvalidParameter(
                    f"names: expected {n} joint names, got {describe(raw_names)}"
                )
            names = tuple(check_text("names", s, max_length=200) for s in raw_names)
            if len(names) != n or len(set(names)) != n:
                raise InvalidParameter(
                    f"names: expected {n} distinct joint names, got {len(names)}: {list(names)}"
                )
        object.__setattr__(self, "lower", readonly(lo))
        object.__setattr__(self, "upper", readonly(hi))
        object.__setattr__(self, "max_speed", readonly(v))
        object.__setattr__(self, "max_acceleration", acc)
        object.__setattr__(self, "max_jerk", jerk)
        object.__setattr__(self, "names", names)

    @property
    def dof(self) -> int:
        """Number of joints."""
        return int(self.lower.shape[0])

    @classmethod
    def from_ros2_control(
        cls, mapping: Mapping[str, Any], joint_names: Sequence[str]
    ) -> JointLimits:
        """Limits from a ros2_control ``joint_limits`` mapping, ordered as ``joint_names``.

        The mapping is ``{"joint_limits": {name: {...}}}`` (the YAML file's document) or the inner
        ``{name: {...}}``; each joint's entry has ``has_position_limits``, ``min_position``,
        ``max_position``, ``has_velocity_limits``, ``max_velocity``, ``has_acceleration_limits``,
        ``max_acceleration``, ``has_jerk_limits``, ``max_jerk`` (the other ros2_control fields are
        accepted and not used), or is franka_description's ``{limit: {lower, upper, velocity,
        effort}}``. A limit is used when its ``has_…`` flag is true (its values must then be given)
        or when the flag is absent and its values are given (MoveIt files write only some flags); a
        false flag ignores the values. ros2_control's own loader reads a value only under a true
        flag and otherwise keeps the URDF's limit; velfence has no URDF here, so a value given
        without a flag is that limit. The joints must be exactly ``joint_names``: a missing or an
        extra joint is refused (a 7-joint file on a 6-joint arm, say), and so is a joint without a
        usable velocity limit (the filter needs every joint's speed). A position bound, position
        span or speed over :data:`SANE_LIMIT` (100 rad, rad/s) is refused: it is degrees written
        without ``!degrees``.

        Args:
            mapping: The parsed document.
            joint_names: The robot's joint names, in order.

        Returns:
            The limits (``names`` = ``joint_names``).

        Raises:
            InvalidParameter: wrong structure, joint set or values (the message names the
                joint and the field).
        """
        try:
            return cls._from_ros2(mapping, joint_names)
        except InvalidParameter as exc:
            raise InvalidParameter(f"mapping: {exc}") from None

    @classmethod
    def _from_ros2(cls, mapping: Any, joint_names: Any) -> JointLimits:
        if isinstance(joint_names, (str, bytes)) or not isinstance(joint_names, (list, tuple)):
            raise InvalidParameter(
                f"joint_names: expected a list or tuple of joint names, got {describe(joint_names)}"
            )
        names = tuple(check_text("joint_names", s, max_length=200) for s in joint_names)
        if not names or len(set(names)) != len(names) or not all(names):
            raise InvalidParameter(
                f"joint_names: expected at least one distinct non-empty name, got {list(names)}"
            )
        if not isinstance(mapping, Mapping):
            raise InvalidParameter(
                f"joint_limits: expected a mapping of joint names, got {describe(mapping)}"
            )
        inner = mapping.get("joint_limits", mapping)
        if not isinstance(inner, Mapping):
            raise InvalidParameter(
                f"joint_limits: expected a mapping of joint names, got {describe(inner)}"
            )
        keys = [str(k) for k in inner]
        missing = [s for s in names if s not in inner]
        extra = [k for k in keys if k not in names]
        if missing or extra:
            raise InvalidParameter(
                f"joint_limits: expected the robot's {len(names)} joints {list(names)}, got "
                f"{len(keys)} joint(s) {keys} (missing {missing}, not on this robot {extra})"
            )
        n = len(names)
        lo, hi = np.full(n, -math.inf), np.full(n, math.inf)
        vel, acc, jerk = np.zeros(n), np.full(n, math.inf), np.full(n, math.inf)
        for j, s in enumerate(names):
            entry = _entry(inner[s], s)
            if _used(entry, s, "position", ("min_position", "max_position")):
                lo[j] = _number(entry, s, "min_position", "rad")
                hi[j] = _number(entry, s, "max_position", "rad")
                _sane(s, "min_position", abs(lo[j]), "rad")
                _sane(s, "max_position", abs(hi[j]), "rad")
                _sane(s, "max_position - min_position", hi[j] - lo[j], "rad")
                if not hi[j] > lo[j]:  # named by joint here; JointLimits would say "upper[j]"
                    raise InvalidParameter(
                        f"joint_limits.{s}: expected max_position > min_position [rad] (upper > "
                        f"lower), got max_position {hi[j]:g} <= min_position {lo[j]:g}"
                    )
            if not _used(entry, s, "velocity", ("max_velocity",)):
                raise InvalidParameter(
                    f"joint_limits.{s}: no usable velocity limit (has_velocity_limits "
                    f"{entry.get('has_velocity_limits', 'absent')}, max_velocity "
                    f"{'given' if 'max_velocity' in entry else 'absent'}); the safety filter "
                    "needs every joint's max_velocity"
                )
            vel[j] = _number(entry, s, "max_velocity", "rad/s")
            _sane(s, "max_velocity", vel[j], "rad/s")
            if _used(entry, s, "acceleration", ("max_acceleration",)):
                acc[j] = _number(entry, s, "max_acceleration", "rad/s²")
            if _used(entry, s, "jerk", ("max_jerk",)):
                jerk[j] = _number(entry, s, "max_jerk", "rad/s³")
        try:
            return cls(
                lo,
                hi,
                max_speed=vel,
                max_acceleration=acc if np.isfinite(acc).any() else None,
                names=names,
                max_jerk=jerk if np.isfinite(jerk).any() else None,
            )
        except InvalidParameter as exc:
            raise InvalidParameter(f"joint_limits: {exc}") from None


# The dataclass's own __init__, taking the old keyword max_velocity and the old positional
# max_speed with a warning until 0.3.
JointLimits.__init__ = positional_deprecated(  # type: ignore[method-assign]
    3, ("self", "lower", "upper", "max_speed")
)(renamed_args(max_velocity="max_speed")(JointLimits.__init__))


#: The fields of a ros2_control joint_limits entry (joint_limits/joint_limits_rosparam.hpp);
#: only the position, velocity, acceleration and jerk ones are read.
_ROS2_KEYS = (
    "has_position_limits",
    "min_position",
    "max_position",
    "has_velocity_limits",
    "max_velocity",
    "has_acceleration_limits",
    "max_acceleration",
    "has_deceleration_limits",
    "max_deceleration",
    "has_jerk_limits",
    "max_jerk",
    "has_effort_limits",
    "max_effort",
    "angle_wraparound",
    "has_soft_limits",
    "k_position",
    "k_velocity",
    "soft_lower_limit",
    "soft_upper_limit",
)


#: Largest accepted position span [rad] and speed [rad/s] of one joint in a limits file: a
#: rotary joint of a real arm turns at most a few turns and a few rad/s; beyond it the numbers are
#: almost surely degrees written without their ``!degrees`` tag (360 "rad"), and are refused.
SANE_LIMIT = 100.0


def _entry(entry: Any, joint: str) -> Mapping[str, Any]:
    """A joint's entry as ros2_control fields (franka_description's ``limit`` mapping too)."""
    if (
        isinstance(entry, Mapping)
        and set(entry) == {"limit"}
        and isinstance(entry["limit"], Mapping)
    ):
        inner = entry["limit"]
        unknown = [str(k) for k in inner if k not in _FRANKA_KEYS]
        if unknown:
            raise InvalidParameter(
                f"joint_limits.{joint}.limit: unknown field(s) {unknown}; expected "
                f"{list(_FRANKA_KEYS)}"
            )
        return {_FRANKA_KEYS[k]: v for k, v in inner.items()}
    if not isinstance(entry, Mapping):
        raise InvalidParameter(
            f"joint_limits.{joint}: expected a mapping of limit fields, got {describe(entry)}"
        )
    unknown = [str(k) for k in entry if k not in _ROS2_KEYS]
    if unknown:
        raise InvalidParameter(
            f"joint_limits.{joint}: unknown field(s) {unknown}; expected ros2_control "
            f"joint_limits fields {list(_ROS2_KEYS)}"
        )
    return entry


#: franka_description's ``limit`` keys -> the ros2_control fields they are.
_FRANKA_KEYS = {
    "lower": "min_position",
    "upper": "max_position",
    "velocity": "max_velocity",
    "effort": "max_effort",
}


def _used(entry: Mapping[str, Any], joint: str, kind: str, values: tuple[str, ...]) -> bool:
    """Whether the entry sets the ``kind`` limit (the rule in ``from_ros2_control``)."""
    flag = f"has_{kind}_limits"
    if flag in entry:
        if not _flag(entry, joint, flag):
            return False
        for key in values:  # _number names the missing one
            _number(entry, joint, key, "")
        return True
    given = [key for key in values if key in entry]
    if given and len(given) != len(values):
        absent = [key for key in values if key not in entry]
        raise InvalidParameter(
            f"joint_limits.{joint}.{absent[0]}: missing ({given[0]} is given; a {kind} limit "
            "needs both)"
        )
    return bool(given)


def _sane(joint: str, what: str, value: float, unit: str) -> None:
    if value > SANE_LIMIT:
        raise InvalidParameter(
            f"joint_limits.{joint}: |{what}| = {value:g} {unit} is beyond the sane {SANE_LIMIT:g} "
            f"{unit}; if the file writes degrees, tag them (max_position: !degrees 360.0)"
        )


def _flag(entry: Mapping[str, Any], joint: str, key: str) -> bool:
    v = entry[key]
    if not isinstance(v, bool):
        raise InvalidParameter(f"joint_limits.{joint}.{key}: expected true or false, got {v!r}")
    return v


def _number(entry: Mapping[str, Any], joint: str, key: str, unit: str) -> float:
    if key not in entry:
        flag = f"has_{key.split('_')[1]}_limits"
        raise InvalidParameter(
            f"joint_limits.{joint}.{key}: missing ({flag} is true; expected a number)"
        )
    return finite_scalar(
        f"joint_limits.{joint}.{key}", entry[key], unit=unit, error=InvalidParameter
    )


# ---------------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class WorkspaceLimit:
    """A convex polytope a named point of the robot must stay in.

    Attributes:
        polytope: The allowed region (a :class:`~velfence.geometry.polytope.ConvexPolytope` in
            the robot's task space: 3-D, or 2-D for a ``PlanarArm``) [m].
        point: The guarded point (a name of the robot's ``points``), default ``"tcp"``.
        buffer: Width of the linear buffer inside every facet [m], > 0: the point's approach
            speed toward a facet at distance ``d < buffer`` is at most ``s d / buffer``, ``s``
            the commanded speed of the point (the exact law's buffer).
        spring_gain: Recovery gain outside [1/s], >= 0.
        max_recovery_speed: Cap on the recovery speed [m/s]; default ``spring_gain * buffer``.
        profile: An approach profile instead of the linear buffer (``LinearBuffer`` or
            ``ThreeZoneBraking``, in metres).

    Raises:
        InvalidParameter: a non-polytope, a non-string point or a bad buffer/gain/profile.
    """

    polytope: Any
    _: KW_ONLY
    point: str = "tcp"
    buffer: float = 0.05
    spring_gain: float = 1.0
    max_recovery_speed: float | None = None
    profile: Profile | None = None

    def __post_init__(self) -> None:
        from velfence.geometry.polytope import ConvexPolytope

        if not isinstance(self.polytope, ConvexPolytope):
            raise InvalidParameter(
                f"polytope: expected a ConvexPolytope, got {describe(self.polytope)}"
            )
        object.__setattr__(self, "point", check_text("point", self.point, max_length=200))
        if self.profile is None:
            prof: Profile = LinearBuffer(
                buffer=self.buffer,
                spring_gain=self.spring_gain,
                max_recovery_speed=self.max_recovery_speed,
            )
        elif isinstance(self.profile, (LinearBuffer, ThreeZoneBraking)):
            prof = self.profile
        else:
            raise InvalidParameter(
                f"profile: expected a LinearBuffer or ThreeZoneBraking, got "
                f"{describe(self.profile)}"
            )
        object.__setattr__(self, "profile", prof)


@dataclass(frozen=True)
class SphereObstacle:
    r"""A spherical obstacle, optionally with its own sphere of influence.

    The one obstacle class of velfence, used by the safety filter
    (:class:`~velfence.filter.SafetyFilter`, :class:`~velfence.filter.ObstacleRows`) and by the
    obstacle-avoiding chain controllers of :mod:`velfence.redundancy`:

    * the **safety filter** keeps every capsule link out of ``radius``; its own
      ``obstacle_buffer`` sets the approach band for all obstacles, and ``influence`` is not used
      (an obstacle built for configuration control can be handed to the filter unchanged);
    * the **configuration controller** (:class:`~velfence.redundancy.ConfigurationController`)
      keeps the link surfaces outside the sphere of influence ``influence`` (the claim's
      "spheres of influence having fixed radii surrounding obstacles at known positions",
      US 5,150,026 claim 1) and refuses an obstacle without one;
    * the QP baseline (:class:`~velfence.redundancy.VelocityDamperQP`) reads ``radius`` only.

    It replaces ``velfence.redundancy.Obstacle`` (called ``InfluenceObstacle`` for a while
    before 0.2); both names construct this class, with a warning, until 0.3.

    Attributes:
        center: Centre [m], shape (3,), read-only (a (2,) centre of a planar scene gets z = 0;
            ``dimension`` says which was given, and the safety filter, which works in 3-D,
            refuses a planar one rather than guess its height).
        radius: Radius of the obstacle body [m], >= 0 (0: a point obstacle; the links' own
            capsule radius and the filter's ``obstacle_buffer`` still keep them away from it).
        influence: Radius :math:`\rho` of the sphere of influence [m], > ``radius``, or ``None``
            (the default: none; the configuration controller needs one).
        name: Optional label for reports.

    Raises:
        InvalidParameter: a bad centre, radius or influence (``influence <= radius``), or a
            non-string name.
    """

    center: FloatArray
    _: KW_ONLY
    radius: float
    influence: float | None = None
    name: str | None = None
    #: How many coordinates the centre was given with (2: a planar scene, z = 0 added).
    dimension: int = field(default=3, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        c = real_array("center", self.center, error=InvalidParameter, what="2 or 3 numbers [m]")
        if c.shape not in ((2,), (3,)):
            raise InvalidParameter(f"center: expected shape (2,) or (3,) [m], got shape {c.shape}")
        object.__setattr__(self, "dimension", int(c.size))
        if c.shape == (2,):
            c = np.append(c, 0.0)
        object.__setattr__(self, "center", readonly(c))
        r = check_positive("radius", self.radius, allow_zero=True, unit="m")
        object.__setattr__(self, "radius", r)
        if self.influence is not None:
            rho = check_positive("influence", self.influence, unit="m")
            if not rho > r:
                raise InvalidParameter(
                    "influence must exceed radius (the sphere of influence surrounds the "
                    f"obstacle), got influence={rho:g} m <= radius={r:g} m"
                )
            object.__setattr__(self, "influence", rho)
        if self.name is not None:
            object.__setattr__(self, "name", check_text("name", self.name, max_length=200))


def _link_index(name: str, v: Any, low: int) -> int:
    """A link index: a Python or NumPy int (not a bool, not a timedelta) >= ``low``."""
    if (
        isinstance(v, (bool, np.bool_, np.timedelta64))
        or not isinstance(v, (int, np.integer))
        or v < low
        or v > 1_000_000
    ):
        raise InvalidParameter(f"{name}: expected a link index (an int >= {low}), got {show(v)}")
    return int(v)


def _attach_link(link: Any) -> str | int:
    if isinstance(link, str) and link == "tcp":
        return "tcp"
    if (
        isinstance(link, (bool, np.bool_, np.timedelta64))
        or not isinstance(link, (int, np.integer))
        or link < -1
    ):
        raise InvalidParameter(
            f"link: expected 'tcp' or a link index (an int >= -1, -1 the base), got {show(link)}"
        )
    return int(link)


def _point3(name: str, x: Any) -> FloatArray:
    a = real_array(name, x, (3,), error=InvalidParameter, what="3 numbers [m]")
    return readonly(a)


@dataclass(frozen=True)
class Sphere:
    """A ball carried by a link (a tool, a gripper, a held object) for the safety filter.

    Attributes:
        link: The frame it rides on: ``"tcp"`` (the tool frame) or a link index ``l``
            (``-1`` the base, ``0 … n-1`` the frame after joint ``l``'s motion, ``n`` the tool
            frame; :meth:`velfence.mechanisms.chain.ChainFrame.link_frame`).
        center: Centre in that frame [m], shape (3,).
        radius: Radius [m], >= 0.

    Raises:
        InvalidParameter: a bad link, centre or radius (negative, say).
    """

    link: str | int
    center: FloatArray
    _: KW_ONLY
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "link", _attach_link(self.link))
        object.__setattr__(self, "center", _point3("center", self.center))
        r = check_positive("radius", self.radius, allow_zero=True, unit="m")
        object.__setattr__(self, "radius", r)

    @property
    def ends(self) -> tuple[FloatArray, FloatArray]:
        """The shape's axis in its frame [m]: ``(center, center)``."""
        return self.center, self.center


@dataclass(frozen=True)
class Capsule:
    """A capsule carried by a link: the segment ``a -> b`` swept by a ball of ``radius``.

    Attributes:
        link: The frame it rides on (as :class:`Sphere`).
        a: One end of the axis in that frame [m], shape (3,).
        b: The other end [m], shape (3,).
        radius: Radius [m], >= 0.

    Raises:
        InvalidParameter: a bad link, end or radius (negative, say).
    """

    link: str | int
    a: FloatArray
    b: FloatArray
    _: KW_ONLY
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "link", _attach_link(self.link))
        object.__setattr__(self, "a", _point3("a", self.a))
        object.__setattr__(self, "b", _point3("b", self.b))
        r = check_positive("radius", self.radius, allow_zero=True, unit="m")
        object.__setattr__(self, "radius", r)

    @property
    def ends(self) -> tuple[FloatArray, FloatArray]:
        """The shape's axis in its frame [m]: ``(a, b)``."""
        return self.a, self.b


@dataclass(frozen=True)
class SelfCollision:
    """Which capsule links of the robot the safety filter keeps apart (self-collision rows).

    Every pair of links ``(i, j)``, ``i < j``, is guarded except pairs closer in the chain than
    ``min_gap`` (``j - i < min_gap``: by default adjacent links, which share a joint point and
    always touch) and the pairs in ``exclude`` (links that cannot meet, or whose capsules overlap
    by design). Each guarded pair gets the obstacle rows' approach profile (the filter's
    ``obstacle_buffer`` and ``spring_gain``) on the clearance ``|p_i - p_j| - r_i - r_j`` of its
    closest axis points.

    Attributes:
        exclude: Link pairs left out, each two distinct link indices (0-based, in any order).
        min_gap: Pairs with ``j - i < min_gap`` are left out, an int >= 1 (1: adjacent links too
            are guarded; 2, the default: adjacent links are not).

    Raises:
        InvalidParameter: a pair that is not two distinct non-negative ints, or a bad
            ``min_gap``.
    """

    _: KW_ONLY
    exclude: tuple[tuple[int, int], ...] = ()
    min_gap: int = 2

    def __post_init__(self) -> None:
        ex: Any = self.exclude
        if (
            isinstance(ex, np.ndarray)
            and ex.ndim == 2
            and (
                ex.dtype.kind in "iu"
                or (
                    ex.dtype.kind == "f"
                    and bool(np.all(np.isfinite(ex) & (np.abs(ex) <= 1e6) & (ex == np.round(ex))))
                )
            )
        ):
            ex = ex.astype(np.int64).tolist()  # an array of pairs of whole numbers, shape (k, 2)
        if isinstance(ex, (str, bytes)) or not isinstance(ex, Sequence):
            raise InvalidParameter(
                f"self_collision.exclude: expected a sequence of link pairs, got {describe(ex)}"
            )
        pairs: list[tuple[int, int]] = []
        for k, pr in enumerate(ex):
            name = f"self_collision.exclude[{k}]"
            if isinstance(pr, (str, bytes)) or not isinstance(pr, Sequence) or len(pr) != 2:
                raise InvalidParameter(f"{name}: expected a pair of link indices, got {show(pr)}")
            i, j = (_link_index(name, v, 0) for v in pr)
            if int(i) == int(j):
                raise InvalidParameter(
                    f"{name}: names link {int(i)} twice; a pair is two different links"
                )
            pairs.append((min(int(i), int(j)), max(int(i), int(j))))
        object.__setattr__(self, "exclude", tuple(pairs))
        g: Any = self.min_gap
        if isinstance(g, np.ndarray) and g.ndim == 0:
            g = g.item()
        object.__setattr__(self, "min_gap", _link_index("self_collision.min_gap", g, 1))

    def pairs(
        self, lengths: Sequence[float], *, radii: Sequence[float]
    ) -> tuple[tuple[int, int], ...]:
        """The guarded pairs ``(i, j)``, ``i < j``, of links of ``lengths`` and ``radii`` [m].

        Left out: ``j - i < min_gap``, the excluded pairs, and pairs that touch in every pose:
        the links between them are at most ``r_i + r_j`` long in all (plus
        :data:`ZERO_LINK`). Link ``i``'s end and link ``j``'s start are joined by those links,
        so their distance never exceeds that sum and the capsules always overlap (a spherical
        wrist's links ``i`` and ``i + 2`` around a zero-length link, say): no motion can
        separate them, and a row could only stop the arm.

        Raises:
            InvalidParameter: an excluded pair names a link the robot does not have.
        """
        ln_a = real_array("lengths", lengths, (None,), error=InvalidParameter, what="lengths [m]")
        links = int(ln_a.shape[0])
        rd_a = real_array("radii", radii, (None,), error=InvalidParameter, what="radii [m]")
        if rd_a.shape[0] != links:
            raise InvalidParameter(
                f"lengths, radii: expected one radius per link length, got {links} lengths "
                f"and {rd_a.shape[0]} radii"
            )
        if np.any(ln_a < 0.0) or np.any(rd_a < 0.0):
            raise InvalidParameter("lengths, radii: expected values >= 0 [m]")
        for k, (_, j) in enumerate(self.exclude):
            if j >= links:
                raise InvalidParameter(
                    f"self_collision.exclude[{k}]: link {j} does not exist (the robot has "
                    f"{links} links, 0 … {links - 1})"
                )
        ex = set(self.exclude)
        ln = [float(v) for v in ln_a]
        rd = [float(v) for v in rd_a]
        return tuple(
            (i, j)
            for i in range(links)
            for j in range(i + self.min_gap, links)
            if (i, j) not in ex and sum(ln[i + 1 : j]) > rd[i] + rd[j] + ZERO_LINK
        )


#: Slack of :meth:`SelfCollision.pairs`' test [m]: a link at most this long is a point.
ZERO_LINK = 1e-9


document_inits(globals())


def spatial_obstacles(
    obstacles: tuple[SphereObstacle, ...], dim: int
) -> tuple[SphereObstacle, ...]:
    """The obstacles of a robot that moves in ``dim`` dimensions, refusing planar centres in 3-D.

    Internal API of :mod:`velfence.filter`: a (2,) centre would silently become (x, y, 0) for a
    spatial arm.

    Args:
        obstacles: The obstacles.
        dim: The robot's task dimension (2: planar, 3: spatial).

    Returns:
        ``obstacles``.

    Raises:
        InvalidParameter: a spatial robot and an obstacle whose centre has two coordinates.
    """
    for i, o in enumerate(obstacles):
        if dim == 3 and o.dimension != 3:
            raise InvalidParameter(
                f"obstacles[{i}]: center {o.center[:2].tolist()} has {o.dimension} coordinates; "
                "the arm moves in 3-D: give (x, y, z) [m]"
            )
    return obstacles
