r"""A position-target shield for LeRobot's SO-100/SO-101 arms, built on the SafetyFilter.

LeRobot robots take an action dictionary of position targets (``{"shoulder_pan.pos": value, ...,
"gripper.pos": value}``) and report the measured positions in the same form. A
:class:`LeRobotShield` takes both and returns a safe action dictionary: each arm joint's target
becomes the joint velocity :math:`u = (\text{target} - q)/dt` over the control period, the
:class:`~velfence.filter.SafetyFilter` makes it admissible (joint limits with a braking buffer,
speed limits, a table plane, a workspace box on the gripper, obstacle spheres against the
links), and the filtered velocity :math:`x` becomes the target :math:`q + x\,dt` again. The
gripper joint does not move the gripper frame; its target is checked against its range and
rate-limited on its own.

Units are LeRobot's (``units="degrees"`` or ``"range_m100_100"`` for the arm joints,
``range_0_100`` for the gripper) and are converted at the edge with LeRobot's own formulas (see
``docs/lerobot.md``). The arm's kinematics come from the SO-ARM URDF that the
``example-robot-data`` package ships (:func:`so_arm`), compiled by MuJoCo once; its five arm
joints are a serial chain (:meth:`velfence.robots.MujocoRobot.chain_frames`), so every cycle runs
the compiled filter cycle. This module imports neither lerobot nor torch; MuJoCo and the URDF are
needed only by :func:`so_arm`.
"""

from __future__ import annotations

import importlib.metadata
import math
import operator
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._extras import message
from velfence._typing import FloatArray
from velfence._validate import (
    check_choice,
    check_positive,
    check_range,
    describe,
    finite_scalar,
    readonly,
    real_array,
    show,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter, MissingExtra
from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.filter.parts import obstacle_list
from velfence.filter.result import FilterResult
from velfence.geometry.polytope import ConvexPolytope
from velfence.robots import MujocoRobot

__all__ = [
    "ARM_JOINTS",
    "GRIPPER",
    "JOINTS",
    "LeRobotShield",
    "RateMode",
    "ShieldResult",
    "SoArm",
    "Units",
    "calibration_ranges",
    "so_arm",
]

#: The SO-100/SO-101 follower's arm joints, in LeRobot's (and the URDF's) order.
ARM_JOINTS: tuple[str, ...] = (
    "shoulder_pan",
    "shoulder_lift",
    "elbow_flex",
    "wrist_flex",
    "wrist_roll",
)
#: The gripper joint (LeRobot's ``range_0_100``: 0 one end of its range, 100 the other).
GRIPPER = "gripper"
#: Every joint of the action and observation dictionaries.
JOINTS: tuple[str, ...] = (*ARM_JOINTS, GRIPPER)

#: The arm joints' units: LeRobot's ``MotorNormMode.DEGREES`` or ``RANGE_M100_100``.
Units = Literal["degrees", "range_m100_100"]
_UNITS: tuple[Units, ...] = ("degrees", "range_m100_100")
#: What the rate limit does with a joint's target step (``docs/lerobot.md``).
RateMode = Literal["pass", "clamp", "reject"]
_RATE_MODES: tuple[RateMode, ...] = ("pass", "clamp", "reject")
GripperPolicy = Literal["refuse", "clamp"]
_GRIPPER_POLICIES: tuple[GripperPolicy, ...] = ("refuse", "clamp")

#: Encoder ticks of the STS3215 servo per turn (positions 0 … 4095).
TICKS_PER_TURN = 4096
#: LeRobot's degrees: ``(ticks - mid) * 360 / (resolution - 1)``, so one LeRobot degree is
#: ``4095 / 4096`` of a degree of the joint.
_DEG = math.pi / 180.0
_LEROBOT_DEG = _DEG * (TICKS_PER_TURN - 1) / TICKS_PER_TURN

#: The URDFs of example-robot-data the shield reads. Its so100.urdf has no gripper frame (no
#: ``gripper_frame_link``), so the SO-100 needs ``path=`` to a model with one.
_URDF = {"so101": "so_arm_description/urdf/so101.urdf"}
_TCP_LINK = "gripper_frame_link"
_FIT_TOLERANCE = 1e-4  # largest accepted |chain frames − MuJoCo| of the gripper point [m]


# ---------------------------------------------------------------------------------- the model
@dataclass(frozen=True)
class SoArm:
    """An SO-100/SO-101 arm as the shield needs it: its chain, its base frame and its ranges.

    Attributes:
        name: ``"so101"`` or the file's stem.
        source: Path of the URDF (or MJCF) the model was read from.
        chain: The five arm joints as a :class:`~velfence.robots.MujocoRobot` (the model with
            the gripper joint fixed: :meth:`~velfence.robots.MujocoRobot.arm`), in the robot's
            base frame; named points ``"tcp"`` (the gripper frame's origin), ``"elbow"`` and
            ``"wrist"`` (the elbow-flex and wrist-flex joints' origins, on their axes), capsule
            links of ``link_radius`` from joint to joint (the last to the ``"tcp"``).
        rotation: Rotation of the chain's frame in the robot's base frame, shape (3, 3) (the
            identity for :func:`so_arm`).
        origin: Origin of the chain's frame in the base frame [m], shape (3,) (zero for
            :func:`so_arm`).
        joint_limits: The model's limits of the arm joints [rad], shape (5, 2), read-only.
        gripper_range: The model's range of the gripper joint [rad] ``(lower, upper)``.
        fit_error: Largest distance between the gripper point of the chain's frames (what the
            compiled filter cycle computes, ``chain.chain_frames()``) and MuJoCo's on the
            model, over the poses checked when it was built [m].
    """

    name: str
    source: str
    chain: MujocoRobot
    rotation: FloatArray
    origin: FloatArray
    joint_limits: FloatArray
    gripper_range: tuple[float, float]
    fit_error: float

    def to_base(self, point: ArrayLike) -> FloatArray:
        """A point of the chain's frame in the robot's base frame [m], shape (3,)."""
        p = real_array("point", point, (3,), what="a point (x, y, z) [m]")
        return np.asarray(self.rotation @ p + self.origin, dtype=np.float64)

    def from_base(self, point: ArrayLike) -> FloatArray:
        """A point of the robot's base frame in the chain's frame [m], shape (3,)."""
        p = real_array("point", point, (3,), what="a point (x, y, z) [m]")
        return np.asarray(self.rotation.T @ (p - self.origin), dtype=np.float64)

    def gripper_position(self, q: ArrayLike) -> FloatArray:
        """The gripper frame's origin in the base frame at arm joint angles ``q`` [rad] [m]."""
        return self.to_base(self.chain.fk(q, "tcp"))


def _urdf_path(model: str) -> Path:
    """The SO-ARM URDF shipped by ``example-robot-data`` (a file of the distribution)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise MissingExtra(
            message("example_robot_data", f"velfence.integrations.lerobot.so_arm({model!r})"),
            name="example_robot_data",
        ) from None
    tail = _URDF[model]
    for f in dist.files or ():
        if str(f).endswith(tail):
            return Path(str(dist.locate_file(f)))
    raise InvalidParameter(  # pragma: no cover - a broken or unexpected install
        f"model: example-robot-data {dist.version} has no {tail}; reinstall it or pass path="
    )


def so_arm(
    model: str = "so101",
    *,
    path: str | Path | None = None,
    link_radius: float = 0.03,
) -> SoArm:
    """The SO-101 arm from the URDF that ``example-robot-data`` ships (or another SO-ARM model).

    MuJoCo compiles the URDF (:meth:`velfence.robots.MujocoRobot.from_urdf`, no meshes; the
    ``"tcp"`` is the origin of ``gripper_frame_link``), and the arm is that model with the
    gripper joint fixed (:meth:`velfence.robots.MujocoRobot.arm`: its five joints, the named
    points and the capsule links; :class:`SoArm`). Its chain frames (what the compiled filter
    cycle runs on) are checked against MuJoCo's forward kinematics of the whole model on 64
    seeded poses within the joint limits; the arm is refused beyond 0.1 mm.

    Args:
        model: ``"so101"`` (the one model shipped with a gripper frame); ignored with ``path``.
        path: A URDF (``.urdf``) or MJCF (``.xml``) of the arm instead: the joints
            ``shoulder_pan`` … ``wrist_roll`` and ``gripper`` (LeRobot's names), and a link or
            site ``gripper_frame_link`` (URDF) or a site ``"tcp"`` (MJCF).
        link_radius: Capsule radius of every link for obstacle rows [m], > 0 (the default,
            3 cm, covers the STS3215 servo's 24 × 35 mm cross-section and its bracket).

    Returns:
        The arm.

    Raises:
        MissingExtra: ``example-robot-data`` or MuJoCo is not installed (the ``lerobot`` extra).
        InvalidParameter: an unknown ``model``, a bad ``path`` or ``link_radius``.
        InvalidGeometry: the file lacks a joint or the gripper frame, a joint has no range, or
            the five arm joints are not a serial chain that reproduces the model.
    """
    radius = check_positive("link_radius", link_radius, unit="m")
    if path is None:
        name = check_choice("model", model, tuple(_URDF))
        src = _urdf_path(name)
        robot = MujocoRobot.from_urdf(src, tcp_link=_TCP_LINK)
    else:
        if not isinstance(path, (str, Path)):
            raise InvalidParameter(f"path: expected a str or Path, got {describe(path)}")
        src = Path(path)
        name = src.stem
        if src.suffix.lower() == ".urdf":
            robot = MujocoRobot.from_urdf(src, tcp_link=_TCP_LINK)
        else:
            robot = MujocoRobot.from_file(src)
    names = tuple(robot.joint_names)
    missing = [j for j in JOINTS if j not in names]
    if missing:
        raise InvalidGeometry(
            f"path: expected the joints {list(JOINTS)} (LeRobot's SO-ARM names), the model "
            f"{str(src)[:200]!r} lacks {missing} (it has {list(names)})"
        )
    m = robot.model
    for j in JOINTS:
        if not bool(m.jnt_limited[m.joint(j).id]):
            raise InvalidGeometry(
                f"path: joint {j!r} has no range in {str(src)[:200]!r}; the shield needs the "
                "model's limits (a range of the joint, not a default)"
            )
    arm = robot.arm(ARM_JOINTS, points={"elbow": 2, "wrist": 3}, link_radius=radius)
    frames = arm.chain_frames()
    if frames is None:
        raise InvalidGeometry(
            f"path: the arm of {str(src)[:200]!r} is not a serial chain of its five arm joints "
            "as expected: MujocoRobot.chain_frames() finds none (a branch, or two joints on one "
            "body)"
        )
    # The frames the C cycle runs on against MuJoCo's kinematics of the whole model.
    lim = np.array(arm.joint_limits, dtype=np.float64)
    cols = [names.index(j) for j in ARM_JOINTS]
    full = np.zeros(robot.dof)
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(64):
        q = rng.uniform(lim[:, 0], lim[:, 1])
        full[cols] = q
        worst = max(worst, float(np.linalg.norm(frames.fk(q) - robot.fk(full))))
    if not worst <= _FIT_TOLERANCE:
        raise InvalidGeometry(
            f"path: the arm of {str(src)[:200]!r} is not a serial chain of its five arm joints "
            f"as expected: the chain's gripper point is {worst:.3g} m from MuJoCo's"
        )
    g = m.jnt_range[m.joint(GRIPPER).id]
    return SoArm(
        name=name,
        source=str(src),
        chain=arm,
        rotation=readonly(np.eye(3)),
        origin=readonly(np.zeros(3)),
        joint_limits=readonly(lim),
        gripper_range=(float(g[0]), float(g[1])),
        fit_error=worst,
    )


# ---------------------------------------------------------------------------------- calibration
def calibration_ranges(calibration: Mapping[str, Any]) -> dict[str, tuple[int, int, int]]:
    """``(range_min, range_max, drive_mode)`` of each joint of a LeRobot calibration.

    Args:
        calibration: LeRobot's calibration file read as a mapping (``json.load`` of
            ``<id>.json``: ``{"shoulder_pan": {"id": 1, "drive_mode": 0, "homing_offset": …,
            "range_min": 758, "range_max": 3292}, …}``), or ``MotorCalibration``-like objects
            with those attributes.

    Returns:
        Joint name -> ``(range_min, range_max, drive_mode)`` for every joint of :data:`JOINTS`.

    Raises:
        InvalidParameter: not a mapping, a joint missing, a range not within 0 … 4095 or
            ``range_min >= range_max``.
    """
    if not isinstance(calibration, Mapping):
        raise InvalidParameter(
            f"calibration: expected a mapping joint -> {{range_min, range_max, drive_mode}} "
            f"(LeRobot's calibration file), got {describe(calibration)}"
        )
    out: dict[str, tuple[int, int, int]] = {}
    for j in JOINTS:
        if j not in calibration:
            raise InvalidParameter(
                f"calibration: joint {j!r} is missing (got {show(list(calibration))})"
            )
        entry = calibration[j]
        vals = []
        for key in ("range_min", "range_max", "drive_mode"):
            v = entry.get(key) if isinstance(entry, Mapping) else getattr(entry, key, None)
            if key == "drive_mode" and v is None:
                v = 0
            x = check_range(f"calibration[{j!r}].{key}", v, low=0, high=TICKS_PER_TURN - 1)
            if x != int(x):
                raise InvalidParameter(f"calibration[{j!r}].{key}: expected an integer, got {x}")
            vals.append(int(x))
        lo, hi, drive = vals
        if lo >= hi:
            raise InvalidParameter(
                f"calibration[{j!r}]: expected range_min < range_max, got {lo} and {hi}"
            )
        out[j] = (lo, hi, drive)
    return out


# ---------------------------------------------------------------------------------- results
class ShieldResult(NamedTuple):
    """What :meth:`LeRobotShield.shield` returns.

    Attributes:
        action: The safe action, ``{"<joint>.pos": value}`` for every joint of :data:`JOINTS`,
            in the shield's units; always finite.
        held: True when the input was refused (``on_invalid="stop"``) and ``action`` holds the
            measured positions (a joint without a finite measurement: its last sent target).
        reason: Why it was held (the error's message), else ``""``.
        rejected: Joints whose target the rate limit rejected (``"reject"`` mode): their last
            safe target was used instead.
        gripper_clamped: True when the gripper target was outside 0 … 100 and clamped
            (``gripper="clamp"``).
        filter_result: The SafetyFilter's report of the arm joints (:meth:`LeRobotShield.explain`
            only; ``None`` from :meth:`LeRobotShield.shield` and when held).
    """

    action: dict[str, float]
    held: bool = False
    reason: str = ""
    rejected: tuple[str, ...] = ()
    gripper_clamped: bool = False
    filter_result: FilterResult | None = None


# ---------------------------------------------------------------------------------- the shield
def _box(name: str, value: Any) -> tuple[FloatArray, FloatArray]:
    if value is None:
        raise InvalidParameter(
            f"{name}: unset; the shield does not start without a workspace box for the gripper "
            f"in the robot's base frame: pass {name}=((x_min, y_min, z_min), (x_max, y_max, "
            "z_max)) [m], e.g. ((0.1, -0.25, 0.0), (0.45, 0.25, 0.35))"
        )
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise InvalidParameter(
            f"{name}: expected ((x_min, y_min, z_min), (x_max, y_max, z_max)) [m], got "
            f"{show(value)}"
        )
    lo = real_array(f"{name}[0]", value[0], (3,), error=InvalidParameter, what="a corner [m]")
    hi = real_array(f"{name}[1]", value[1], (3,), error=InvalidParameter, what="a corner [m]")
    if not np.all(lo < hi):
        raise InvalidParameter(f"{name}: expected lower < upper on every axis, got {lo}, {hi}")
    return lo, hi


def _per_joint(
    name: str, value: Any, joints: Sequence[str], unit: str, example: str
) -> dict[str, float]:
    if value is None:
        raise InvalidParameter(
            f"{name}: unset; the shield does not start without it: pass {name}={example} "
            f"[{unit}], one value per joint of {list(joints)}"
        )
    if not isinstance(value, Mapping):
        raise InvalidParameter(
            f"{name}: expected a mapping joint -> value [{unit}], got {describe(value)}"
        )
    unknown = [k for k in value if k not in JOINTS]
    if unknown:
        raise InvalidParameter(f"{name}: unknown joint(s) {show(unknown)}; joints: {list(JOINTS)}")
    out = {}
    for j in joints:
        if j not in value:
            raise InvalidParameter(
                f"{name}: unset for joint {j!r}; pass {name}={{..., {j!r}: value}} [{unit}]"
            )
        out[j] = check_positive(f"{name}[{j!r}]", value[j], unit=unit)
    return out


class LeRobotShield:
    r"""Safe position targets for an SO-100/SO-101 follower arm (LeRobot's action dictionary).

    Each call of :meth:`shield` (or :meth:`explain`):

    1. reads the measured positions ``observation["<joint>.pos"]`` and the targets
       ``action["<joint>.pos"]`` of every joint of :data:`JOINTS` (anything else in the
       observation, such as camera images, is ignored; the action must hold exactly these six
       keys) and converts them to radians (``units``);
    2. applies the rate limit's ``reject`` mode: a joint in that mode whose target is more than
       ``max_speed · dt`` from its measured position gets its last safe target instead (the
       target this shield sent it last time; the measured position on the first call or after
       :meth:`reset`) and is named in ``rejected``;
    3. filters the arm: :math:`u = (\text{target} - q)/dt`, :math:`x` = the
       :class:`~velfence.filter.SafetyFilter`'s output, the safe target :math:`q + x\,dt`. The
       filter holds the joint limits (the model's, narrowed by the calibrated range when
       ``calibration`` is given) with a linear braking buffer of ``joint_buffer``, the speed
       limit ``max_speed`` of every joint in ``clamp`` or ``reject`` mode (``pass``: the speed
       limit is the joint's whole range per period, i.e. none), the workspace box and the table
       plane on a sphere of radius ``tool_radius`` around the gripper frame's origin, the table
       plane on the elbow and wrist axes (spheres of the link radius), and the obstacle spheres
       against the links' capsules;
    4. the gripper: a target outside 0 … 100 is refused (``gripper="refuse"``: an error, or the
       hold action with ``on_invalid="stop"``) or clamped (``"clamp"``, ``gripper_clamped``),
       then rate-limited as its mode says (``clamp``: moved at most ``max_speed · dt`` from the
       measured position; ``reject``: the last safe target beyond that; ``pass``: unchanged);
    5. returns the safe targets in the same units.

    The construction refuses to start while a bound is unset: ``max_speed`` of every joint not
    in ``pass`` mode, ``table_height``, ``workspace`` and ``tool_radius`` have no default, and a
    joint whose model has no range is refused by :func:`so_arm`.

    Args:
        arm: The arm (:func:`so_arm`).
        dt: Control period [s], > 0 (LeRobot's ``1 / fps``).
        max_speed: Largest speed of each joint [deg/s of the joint; the gripper in degrees of its
            joint too], a mapping joint -> value > 0 for every joint not in ``pass`` mode.
        table_height: Height of the table plane in the robot's base frame [m]; the gripper
            sphere and the elbow and wrist stay above it.
        workspace: The gripper's box ``((x_min, y_min, z_min), (x_max, y_max, z_max))`` in the
            base frame [m]; the gripper sphere stays inside it.
        tool_radius: Radius of the sphere around the gripper frame's origin that the box and
            the table keep inside [m], >= 0 (0: the point itself).
        obstacles: Spheres in the base frame (:class:`~velfence.filter.SphereObstacle`) that
            the links' capsules keep out of.
        rate_limit: Joint -> ``"pass"``, ``"clamp"`` or ``"reject"``; a joint not named is
            ``"clamp"``.
        units: ``"degrees"`` (LeRobot's default, ``use_degrees=True``) or ``"range_m100_100"``
            for the arm joints; the gripper is always ``range_0_100``.
        calibration: LeRobot's calibration of the arm (:func:`calibration_ranges`); required
            with ``"range_m100_100"``, optional with degrees (then it narrows the limits to the
            calibrated ranges).
        gripper: ``"refuse"`` (default) or ``"clamp"`` a gripper target outside 0 … 100.
        joint_buffer: Width of the braking buffer at the joint limits [deg], > 0.
        workspace_buffer: Width of the braking buffer inside the box and the table [m], > 0.
        obstacle_buffer: Width of the obstacles' braking buffer [m], > 0.
        on_invalid: ``"raise"`` (default): bad input raises
            :class:`~velfence.errors.InvalidInput`; ``"stop"``: the hold action and ``held``.
        backend: The filter's backend (``"auto"``, ``"python"``, ``"c"``).

    Raises:
        InvalidParameter: an unset or bad bound or option (the message says how to set it).
        InvalidGeometry: a box or table that leaves no room for the gripper sphere.
    """

    def __init__(
        self,
        arm: SoArm,
        *,
        dt: float,
        max_speed: Mapping[str, float] | None = None,
        table_height: float | None = None,
        workspace: tuple[ArrayLike, ArrayLike] | None = None,
        tool_radius: float | None = None,
        obstacles: Sequence[SphereObstacle] = (),
        rate_limit: Mapping[str, RateMode] | None = None,
        units: Units = "degrees",
        calibration: Mapping[str, Any] | None = None,
        gripper: GripperPolicy = "refuse",
        joint_buffer: float = 5.0,
        workspace_buffer: float = 0.02,
        obstacle_buffer: float = 0.03,
        on_invalid: Literal["raise", "stop"] = "raise",
        backend: Literal["auto", "python", "c"] = "auto",
    ) -> None:
        if not isinstance(arm, SoArm):
            raise InvalidParameter(f"arm: expected a SoArm (so_arm()), got {describe(arm)}")
        self.arm = arm
        self.dt = check_positive("dt", dt, unit="s")
        self.units: Units = check_choice("units", units, _UNITS)
        self.gripper: GripperPolicy = check_choice("gripper", gripper, _GRIPPER_POLICIES)
        self.on_invalid = check_choice("on_invalid", on_invalid, ("raise", "stop"))
        modes: dict[str, RateMode] = dict.fromkeys(JOINTS, "clamp")
        if rate_limit is not None:
            if not isinstance(rate_limit, Mapping):
                raise InvalidParameter(
                    f"rate_limit: expected a mapping joint -> mode, got {describe(rate_limit)}"
                )
            for k, v in rate_limit.items():
                if k not in JOINTS:
                    raise InvalidParameter(
                        f"rate_limit: unknown joint {show(k)}; joints: {list(JOINTS)}"
                    )
                modes[k] = check_choice(f"rate_limit[{k!r}]", v, _RATE_MODES)
        self.rate_limit = modes
        limited = [j for j in JOINTS if modes[j] != "pass"]
        speeds = _per_joint("max_speed", max_speed, limited, "deg/s", "{'shoulder_pan': 60.0, ...}")
        if max_speed is not None:
            unused = [k for k in max_speed if modes.get(k) == "pass"]
            if unused:
                raise InvalidParameter(
                    f"max_speed: joint(s) {unused} are in rate_limit 'pass' mode, which has no "
                    "speed limit; remove them from max_speed or choose 'clamp' or 'reject'"
                )
        self.max_speed = speeds
        if table_height is None:
            raise InvalidParameter(
                "table_height: unset; the shield does not start without the table plane: pass "
                "table_height=0.0 [m] (the plane z = table_height of the robot's base frame; "
                "the base of the SO-ARM model stands on z = 0)"
            )
        self.table_height = check_range("table_height", table_height, low=-10.0, high=10.0)
        lo, hi = _box("workspace", workspace)
        if tool_radius is None:
            raise InvalidParameter(
                "tool_radius: unset; the shield does not start without the gripper's size: pass "
                "tool_radius=0.02 [m] (a sphere around the gripper frame's origin; 0: the point)"
            )
        self.tool_radius = check_positive("tool_radius", tool_radius, allow_zero=True, unit="m")
        jb = check_positive("joint_buffer", joint_buffer, unit="deg") * _DEG
        wb = check_positive("workspace_buffer", workspace_buffer, unit="m")
        ob = check_positive("obstacle_buffer", obstacle_buffer, unit="m")
        self.workspace = (readonly(lo), readonly(hi))

        # Units: value * scale = radians (arm), per joint; the joint limits in radians.
        lim = np.array(arm.joint_limits, dtype=np.float64)
        scale = np.full(len(ARM_JOINTS), _LEROBOT_DEG)
        self.calibration = None
        if calibration is not None:
            cal = calibration_ranges(calibration)
            self.calibration = cal
            for i, j in enumerate(ARM_JOINTS):
                lo_t, hi_t, drive = cal[j]
                half = (hi_t - lo_t) / 2.0 * 2.0 * math.pi / TICKS_PER_TURN
                lim[i, 0] = max(lim[i, 0], -half)
                lim[i, 1] = min(lim[i, 1], half)
                if self.units == "range_m100_100":
                    # ticks - mid = v' (max - min) / 200, v' = -v with drive_mode.
                    scale[i] = (hi_t - lo_t) / 200.0 * 2.0 * math.pi / TICKS_PER_TURN
                    scale[i] *= -1.0 if drive else 1.0
        elif self.units == "range_m100_100":
            raise InvalidParameter(
                "calibration: unset; units='range_m100_100' maps -100 … 100 onto each joint's "
                "calibrated range: pass calibration= LeRobot's calibration file of the arm "
                "(json.load of ~/.cache/huggingface/lerobot/calibration/robots/so_follower/"
                "<id>.json)"
            )
        if not np.all(lim[:, 0] < lim[:, 1]):
            raise InvalidParameter(
                f"calibration: the calibrated ranges leave no range of motion within the "
                f"model's limits: {lim.tolist()} [rad]"
            )
        self.joint_limits = readonly(lim)
        self._scale = scale
        vmax = np.array(
            [
                speeds[j] * _DEG if modes[j] != "pass" else (lim[i, 1] - lim[i, 0]) / self.dt
                for i, j in enumerate(ARM_JOINTS)
            ]
        )
        # The gripper: 0 … 100 <-> the model's range (LeRobot's range_0_100).
        g_lo, g_hi = arm.gripper_range
        self._g_step = (
            math.inf
            if modes[GRIPPER] == "pass"
            else speeds[GRIPPER] * _DEG * self.dt * 100.0 / (g_hi - g_lo)
        )

        # Geometry: base frame -> the chain's frame (the same frame for so_arm()).
        R, o = arm.rotation, arm.origin

        def poly(normals: FloatArray, offsets: FloatArray, names: list[str]) -> ConvexPolytope:
            Nc = normals @ R  # (R^T n)^T
            return ConvexPolytope(Nc, offsets - normals @ o, facet_names=names, redundant="keep")

        r = self.tool_radius
        eye = np.eye(3)
        box_n = np.vstack([eye, -eye])
        box_o = np.concatenate([lo + r, -(hi - r)])
        box_names = ["box x_min", "box y_min", "box z_min", "box x_max", "box y_max", "box z_max"]
        if not np.all(lo + r < hi - r):
            raise InvalidGeometry(
                f"workspace, tool_radius: the box {lo.tolist()} … {hi.tolist()} leaves no room "
                f"for a gripper sphere of radius {r:g} m"
            )
        up = np.array([[0.0, 0.0, 1.0]])
        link_r = float(np.max(arm.chain.link_radius))
        limits_ws = [
            WorkspaceLimit(poly(box_n, box_o, box_names), point="tcp", buffer=wb),
            WorkspaceLimit(
                poly(up, np.array([self.table_height + r]), ["table (gripper)"]),
                point="tcp",
                buffer=wb,
            ),
            WorkspaceLimit(
                poly(up, np.array([self.table_height + link_r]), ["table (wrist)"]),
                point="wrist",
                buffer=wb,
            ),
            WorkspaceLimit(
                poly(up, np.array([self.table_height + link_r]), ["table (elbow)"]),
                point="elbow",
                buffer=wb,
            ),
        ]
        given = obstacle_list(obstacles)
        obs = [SphereObstacle(R.T @ (np.asarray(ob_k.center) - o), radius=ob_k.radius)
               for ob_k in given]  # fmt: skip
        self.obstacles = given
        self.filter = SafetyFilter(
            arm.chain,
            limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=vmax, names=ARM_JOINTS),
            workspace=limits_ws,
            obstacles=obs,
            dt=self.dt,
            joint_buffer=jb,
            obstacle_buffer=ob,
            backend=backend,
        )
        self._keys = tuple(f"{j}.pos" for j in JOINTS)
        self._arm_keys = self._keys[:5]
        self._get = operator.itemgetter(*self._keys)
        self._scale_list = scale.tolist()
        self._inv_dt = 1.0 / self.dt
        # (joint, largest target step [rad]) of the joints in reject mode.
        self._reject_steps = tuple(
            (i, float(vmax[i]) * self.dt) for i, j in enumerate(ARM_JOINTS) if modes[j] == "reject"
        )
        self._any_reject = bool(self._reject_steps)
        self._last: list[float] | None = None  # the last safe action (user units)

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Forget the last safe target (a fresh start: ``reject`` then holds the measured)."""
        self._last = None

    @property
    def keys(self) -> tuple[str, ...]:
        """The action's keys, ``"<joint>.pos"`` for every joint of :data:`JOINTS`."""
        return self._keys

    def to_radians(self, values: Mapping[str, float]) -> FloatArray:
        """The arm joints of an action or observation in radians (the model's angles), (5,)."""
        vals = self._read("values", values, exact=False)
        return np.asarray(np.array(vals[:5]) * self._scale, dtype=np.float64)

    def from_radians(self, q: ArrayLike) -> dict[str, float]:
        """Arm joint angles [rad], shape (5,), in the shield's units, keyed ``"<joint>.pos"``."""
        qa = real_array("q", q, (5,), what="5 joint angles [rad]")
        return dict(zip(self._arm_keys, (qa / self._scale).tolist(), strict=True))

    # ------------------------------------------------------------------ input
    def _read(self, name: str, d: Any, *, exact: bool) -> list[float]:
        """The six values of ``d`` as floats, or a clear :class:`InvalidInput`."""
        if not isinstance(d, Mapping):
            raise InvalidInput(
                f"{name}: expected a dict {{'<joint>.pos': value}} (LeRobot's), got {describe(d)}"
            )
        missing = [k for k in self._keys if k not in d]
        if missing:
            raise InvalidInput(f"{name}: joint(s) missing: {missing}; expected {list(self._keys)}")
        if exact and len(d) != len(self._keys):
            extra = [k for k in d if k not in self._keys]
            raise InvalidInput(
                f"{name}: unknown joint(s) {show(extra)}: the model has {list(self._keys)}"
            )
        out = []
        for k in self._keys:
            v = finite_scalar(f"{name}[{k!r}]", d[k], what="joint position")
            out.append(v)
        return out

    def _values(self, action: Any, observation: Any) -> tuple[list[float], list[float]]:
        try:  # the common case: dicts of six finite numbers (one C call per dict)
            if type(action) is dict and type(observation) is dict and len(action) == 6:
                get = self._get
                qm = list(map(float, get(observation)))
                tg = list(map(float, get(action)))
                if math.isfinite(sum(qm) + sum(tg)):
                    return qm, tg
        except (KeyError, TypeError, ValueError, OverflowError):
            pass
        return self._read("observation", observation, exact=False), self._read(
            "action", action, exact=True
        )

    # ------------------------------------------------------------------ the cycle
    def _hold(self, observation: Any, reason: str) -> ShieldResult:
        """The hold action: the measured positions (else the last target), never NaN."""
        last = self._last
        out: dict[str, float] = {}
        for i, k in enumerate(self._keys):
            v = observation.get(k) if isinstance(observation, Mapping) else None
            try:
                x = float(v)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                x = math.nan
            if not math.isfinite(x):
                if last is None:
                    raise InvalidInput(
                        f"{reason}; no hold action exists either: {k} has no finite measured "
                        "position and no target was sent before"
                    )
                x = last[i]
            out[k] = x
        return ShieldResult(action=out, held=True, reason=reason)

    def _cycle(self, action: Any, observation: Any, explain: bool) -> ShieldResult:
        try:
            qm, tg = self._values(action, observation)
            g = tg[5]
            clamped = False
            if not 0.0 <= g <= 100.0:
                if self.gripper == "refuse":
                    raise InvalidInput(
                        f"action['gripper.pos']: expected a target in 0 … 100 (range_0_100: "
                        f"the gripper's range in the model), got {g:g}; pass gripper='clamp' to "
                        "clamp it instead"
                    )
                g = min(100.0, max(0.0, g))
                clamped = True
        except InvalidInput as exc:
            if self.on_invalid == "raise":
                raise
            return self._hold(observation, str(exc))
        scale = self._scale_list
        q = [v * k for v, k in zip(qm, scale, strict=False)]  # radians: the 5 arm joints
        t = [v * k for v, k in zip(tg, scale, strict=False)]
        rejected: tuple[str, ...] = ()
        last = self._last
        if self._any_reject:
            hit = []
            for i, step in self._reject_steps:
                if abs(t[i] - q[i]) > step:
                    t[i] = q[i] if last is None else last[i] * scale[i]
                    hit.append(ARM_JOINTS[i])
            rejected = tuple(hit)
        inv = self._inv_dt
        qa = np.array(q)
        ua = np.array([(b - a) * inv for a, b in zip(q, t, strict=True)])
        fr = None
        if explain:
            fr = self.filter.explain(qa, ua)
            x = fr.output
        else:
            x = self.filter.filter(qa, ua)
        dt = self.dt
        safe_t = [(a + b * dt) / k for a, b, k in zip(q, x.tolist(), scale, strict=True)]
        # The gripper: rate limit around the measured position.
        gm = qm[5]
        mode = self.rate_limit[GRIPPER]
        step = self._g_step
        if mode == "clamp":
            g = min(gm + step, max(gm - step, g))
        elif mode == "reject" and abs(g - gm) > step:
            g = gm if last is None else last[5]
            rejected = (*rejected, GRIPPER)
        safe_t.append(g)
        self._last = safe_t
        return ShieldResult(
            action=dict(zip(self._keys, safe_t, strict=True)),
            rejected=rejected,
            gripper_clamped=clamped,
            filter_result=fr,
        )

    def _arguments(
        self, call: str, args: tuple[Any, ...], observation: Any, action: Any
    ) -> tuple[Any, Any]:
        """``(observation, action)`` of a call, in the order of 0.2 (state first, command second).

        Before 0.2 the action came first. Both are dictionaries, so a positional call is read by
        content: the action holds exactly the keys of :attr:`keys`, an observation may hold more
        (camera images, ...). Positional arguments in the old order (an action first, an
        observation with more keys second) warn and are swapped; two positional dictionaries of
        exactly the six keys cannot be told apart and are refused (a swap would move the arm from
        the target instead of from the measured position); keywords are always unambiguous.
        """
        named = [k for k, v in (("observation", observation), ("action", action)) if v is not None]
        if len(args) > 2 or (args and named):
            raise InvalidParameter(
                f"LeRobotShield.{call}() takes (observation, action): two positional arguments or "
                f"observation=..., action=... by keyword, got {len(args)} positional and {named} "
                "by keyword"
            )
        if not args:
            if observation is None or action is None:
                raise InvalidParameter(
                    f"LeRobotShield.{call}() needs observation=... and action=..., got "
                    f"observation={describe(observation)}, action={describe(action)}"
                )
            return observation, action
        if len(args) != 2:
            raise InvalidParameter(
                f"LeRobotShield.{call}() takes (observation, action), got 1 positional argument"
            )
        first, second = args
        six = set(self._keys)
        if not (isinstance(first, Mapping) and isinstance(second, Mapping)):
            return first, second  # _read names what is wrong with each
        first_more = not set(first) <= six
        second_more = not set(second) <= six
        if second_more and not first_more:  # the action first: the order before 0.2
            warnings.warn(
                f"LeRobotShield.{call}(action, observation) is now {call}(observation, action) "
                "(the state first, as everywhere in velfence); pass observation=..., action=... "
                "by keyword; the old order goes in 0.3",
                DeprecationWarning,
                stacklevel=3,
            )
            return second, first
        if not first_more and not second_more:
            raise InvalidParameter(
                f"LeRobotShield.{call}(): the order changed in 0.2 from (action, observation) to "
                "(observation, action), and two dictionaries of the same joint keys cannot be "
                "told apart; pass them by keyword: "
                f"{call}(observation=robot.get_observation(), action=action)"
            )
        return first, second

    def shield(
        self,
        *args: Mapping[str, Any],
        observation: Mapping[str, Any] | None = None,
        action: Mapping[str, Any] | None = None,
    ) -> ShieldResult:
        """The safe action for ``action`` at the measured ``observation``.

        Call it ``shield(observation=obs, action=act)``: the state first, the command second,
        as every velfence call (before 0.2 it was ``shield(action, observation)``; a positional
        call in that order still works until 0.3 with a warning when the observation holds more
        than the six joints, and a positional call with two dictionaries of only the six joint
        keys is refused, since the order cannot be told from them).

        Args:
            *args: ``(observation, action)`` positionally (see above).
            observation: LeRobot's observation (at least ``"<joint>.pos"`` of the six joints).
            action: LeRobot's action ``{"<joint>.pos": target}`` of the six joints (exactly).

        Returns:
            A :class:`ShieldResult` (``.action`` is the dictionary to send).

        Raises:
            InvalidInput: with ``on_invalid="raise"``: a missing or unknown joint, a value that
                is not a finite number, a gripper target outside 0 … 100 with
                ``gripper="refuse"``; with ``"stop"`` only when no hold action exists (a joint
                without a finite measurement on the first call).
            InvalidParameter: arguments that are not one observation and one action, or two
                positional dictionaries whose order cannot be told.
        """
        obs, act = self._arguments("shield", args, observation, action)
        return self._cycle(act, obs, False)

    def explain(
        self,
        *args: Mapping[str, Any],
        observation: Mapping[str, Any] | None = None,
        action: Mapping[str, Any] | None = None,
    ) -> ShieldResult:
        """:meth:`shield` with the SafetyFilter's report (``filter_result``: zone, active rows).

        Args:
            *args: ``(observation, action)`` positionally (as in :meth:`shield`).
            observation: As in :meth:`shield`.
            action: As in :meth:`shield`.

        Returns:
            A :class:`ShieldResult` whose ``filter_result`` is set (unless held).

        Raises:
            InvalidInput: as :meth:`shield`.
            InvalidParameter: as :meth:`shield`.
        """
        obs, act = self._arguments("explain", args, observation, action)
        return self._cycle(act, obs, True)


document_inits(globals())
