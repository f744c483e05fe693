"""Replay a recorded rosbag2 through a configured shaper (``velfence replay``; ``docs/replay.md``).

A bag (a rosbag2 directory with ``metadata.yaml``, MCAP or sqlite3 storage, read by ``rosbags``)
holds a command topic and a state topic. Each recorded command, in time order, is shaped with the
latest state recorded at or before it (zero-order hold, by the bag's receive time); the shaped
command is written, as a message of the command's own type with the command's timestamp, to a new
bag beside a copy of every original topic. The replay is open loop: the state is what was
recorded, not what the shaped command would have produced.

A command with no state before it, with a state older than ``max_state_age``, or with a non-finite
value is written as zero and counted in :class:`ReplaySummary`.

The configuration is one YAML file with a ``shaper:`` section
(:func:`~velfence.io.shaper_config.parse_shaper`) and a ``replay:`` section
(:class:`ReplaySettings`)::

    replay:
      command_topic: /cmd_vel
      state_topic: /odom
      output_topic: /cmd_vel_shaped    # default: <command_topic>_shaped
      joint_names: null                # bag names of the shaper's joints (JointState, JointJog)
      max_state_age: 0.5               # [s]; default: any age
      command_frame: world             # or body: a planar cmd_vel in the base frame (yaw applied)

``rosbags`` (extra ``ros``) is imported inside the functions only.
"""

from __future__ import annotations

import os
import re
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np

from velfence._extras import missing

try:
    from pydantic import Field, Strict, ValidationError, field_validator, model_validator
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence._deprecate import warn_renamed
from velfence._docs import document_inits
from velfence._validate import MAX_PATH_LENGTH, check_choice, show
from velfence.errors import InvalidParameter, VelfenceError
from velfence.geometry.frames import body_to_world, world_to_body
from velfence.io.config import Positive, StrictModel, describe_validation_error
from velfence.io.shaper_config import MAX_JOINTS, ConfiguredShaper, load_yaml, parse_shaper
from velfence.io.yaml_reader import read_yaml

if TYPE_CHECKING:
    from numpy.typing import NDArray

__all__ = [
    "CHANGE_TOL",
    "STORAGES",
    "ReplaySettings",
    "ReplaySummary",
    "replay",
]

#: Storage plugins a bag may use (rosbag2's ``storage_identifier``).
STORAGES: tuple[str, ...] = ("mcap", "sqlite3")
#: A shaped command counts as changed when a component differs from the command by more than
#: this, in the command's unit ([m/s] or [rad/s]).
CHANGE_TOL = 1e-9

TWIST = "geometry_msgs/msg/Twist"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
JOINT_JOG = "control_msgs/msg/JointJog"
FLOAT_ARRAY = "std_msgs/msg/Float64MultiArray"
JOINT_STATE = "sensor_msgs/msg/JointState"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
ODOMETRY = "nav_msgs/msg/Odometry"

_TWIST_TYPES = (TWIST, TWIST_STAMPED)
_JOINT_TYPES = (JOINT_JOG, FLOAT_ARRAY)
_POSE_TYPES = (POSE_STAMPED, ODOMETRY)

# control_msgs/msg/JointJog is not in rosbags' built-in stores: its definition (control_msgs,
# the field layout servo drivers publish), registered for bags that carry no definitions and for
# the example bags.
_JOINT_JOG_MSG = """std_msgs/Header header
string[] joint_names
float64[] displacements
float64[] velocities
float64 duration
"""

_TOPIC = re.compile(r"/[A-Za-z0-9_/~]{1,255}")
Topic = Annotated[str, Strict()]
JointName = Annotated[str, Strict(), Field(min_length=1, max_length=256)]


class ReplaySettings(StrictModel):
    """The ``replay:`` section: which topics a replay reads and writes.

    Attributes:
        command_topic: The recorded command (``geometry_msgs/msg/Twist`` or ``TwistStamped`` for
            a polygon, polytope or twist-mode safety filter; ``control_msgs/msg/JointJog`` or
            ``std_msgs/msg/Float64MultiArray`` for joint commands).
        state_topic: The recorded state (``nav_msgs/msg/Odometry`` or
            ``geometry_msgs/msg/PoseStamped`` for a point; ``sensor_msgs/msg/JointState`` for
            joints).
        output_topic: Where the shaped command goes (default ``<command_topic>_shaped``); a
            topic the bag does not already have.
        joint_names: The bag's names of the shaper's joints, in the shaper's order (default:
            the shaper's own ``joint_names``); matched by name in ``JointState`` and ``JointJog``.
        max_state_age: Oldest state [s] a command is shaped with; an older one zeroes the
            command (default: any age).
        command_frame: ``"world"`` (default): a planar command is in the frame of the state's
            pose (odometry or map frame); ``"body"``: in the robot's body frame, turned by the
            pose's heading (yaw) into the pose's frame for shaping and back for writing (polygon
            shapers only; :func:`velfence.geometry.body_to_world`). The old value ``"state"``
            means ``"world"`` and warns until 0.3.
    """

    command_topic: Topic
    state_topic: Topic
    output_topic: Topic | None = None
    joint_names: Annotated[list[JointName], Field(min_length=1, max_length=MAX_JOINTS)] | None = (
        None
    )
    max_state_age: Positive | None = None
    command_frame: Literal["world", "body"] = "world"

    def __init__(self, **data: Any) -> None:
        """Build the section directly (the fields are documented in ``docs/replay.md``).

        Raises:
            InvalidParameter: a field is invalid; the message names it (``section replay.x``).
        """
        try:
            super().__init__(**data)
        except ValidationError as err:
            raise InvalidParameter(_section_error(err, "replay", ReplaySettings)) from None

    @field_validator("command_frame", mode="before")
    @classmethod
    def _old_frame(cls, value: Any) -> Any:
        if isinstance(value, str) and value == "state":
            warn_renamed("value of replay.command_frame", "state", "world", stacklevel=2)
            return "world"
        return value

    @field_validator("command_topic", "state_topic", "output_topic")
    @classmethod
    def _topic_name(cls, value: str | None) -> str | None:
        if value is not None and not _TOPIC.fullmatch(value):
            raise ValueError(
                f"expected a ROS topic name (/name, letters, digits, _ ~ /, at most 256 "
                f"characters), got {show(value, 60)}"
            )
        return value

    @model_validator(mode="after")
    def _distinct(self) -> ReplaySettings:
        topics = [self.command_topic, self.state_topic, self.output]
        if len(set(topics)) != 3:
            raise ValueError(f"command, state and output topics must differ, got {topics}")
        if self.joint_names is not None and len(set(self.joint_names)) != len(self.joint_names):
            raise ValueError(f"joint_names must be distinct, got {self.joint_names}")
        return self

    @property
    def output(self) -> str:
        """The output topic (``output_topic``, or ``<command_topic>_shaped``)."""
        return self.output_topic or f"{self.command_topic}_shaped"


@dataclass(frozen=True, eq=False)
class ReplaySummary:
    """What :func:`replay` read, shaped and wrote.

    Attributes:
        bag: The input bag.
        out: The bag written.
        storage: Its storage (``"mcap"`` or ``"sqlite3"``).
        kind: The shaper's kind (``"polygon"``, ...).
        command_space: The shaper's command space (``"plane"``, ``"workspace"``, ``"joint"``,
            ``"twist"``).
        command_topic: The command topic read.
        state_topic: The state topic read.
        output_topic: The topic of the shaped command.
        command_type: The command's message type.
        state_type: The state's message type.
        components: Names of the compared command components (``("vx", "vy")``, joint names).
        unit: Their unit (``"m/s"`` or ``"rad/s"``).
        commands: Commands shaped (one shaped message each).
        states: States read.
        messages: Messages written (every original one plus the shaped ones).
        changed: Commands whose shaped value differs by more than :data:`CHANGE_TOL`.
        changed_fraction: ``changed / commands`` (0 for no commands).
        max_abs_change: Largest ``|command − shaped|`` of any component, in ``unit``.
        zeroed_no_state: Commands written as zero because no state came before them.
        zeroed_stale: Commands written as zero because the state was older than
            ``max_state_age``.
        zeroed_invalid: Commands written as zero because the command or the state was not finite.
        times: Each command's time since the bag's first message [s], shape (N,).
        commanded: The commands, shape (N, k) (the compared components).
        shaped: The shaped commands in the same components, shape (N, k) (in twist mode, the
            TCP velocity the shaped joint velocities give).
        positions: The held state at each command, shape (N, state_dim) (zeros without one).
        has_state: Whether a usable state was held, shape (N,).
        fence: A polygon shaper's corners (CCW) [m], shape (m, 2); else None.
        buffer: A polygon shaper's buffer [m]; else None.
    """

    bag: Path
    out: Path
    storage: str
    kind: str
    command_space: str
    command_topic: str
    state_topic: str
    output_topic: str
    command_type: str
    state_type: str
    components: tuple[str, ...]
    unit: str
    commands: int
    states: int
    messages: int
    changed: int
    changed_fraction: float
    max_abs_change: float
    zeroed_no_state: int
    zeroed_stale: int
    zeroed_invalid: int
    times: NDArray[np.float64]
    commanded: NDArray[np.float64]
    shaped: NDArray[np.float64]
    positions: NDArray[np.float64]
    has_state: NDArray[np.bool_]
    fence: NDArray[np.float64] | None
    buffer: float | None

    @property
    def zeroed(self) -> int:
        """All commands written as zero (no state, stale state, non-finite values)."""
        return self.zeroed_no_state + self.zeroed_stale + self.zeroed_invalid


# --------------------------------------------------------------------------------- config


def _settings(section: Any, where: str) -> ReplaySettings:
    if not isinstance(section, Mapping):
        raise InvalidParameter(
            f"section {where}: expected a mapping with command_topic and state_topic, got "
            f"{type(section).__name__}"
        )
    try:
        return ReplaySettings.model_validate(dict(section))
    except ValidationError as err:
        raise InvalidParameter(_section_error(err, where, ReplaySettings)) from None


def _section_error(err: ValidationError, where: str, model: type[StrictModel]) -> str:
    text = describe_validation_error(err, model)
    top = "(top level): "
    if text.startswith(top):
        return f"section {where}: {text.removeprefix(top)}"
    return f"section {where}.{text}"


def _fs_path(name: str, value: Any) -> Path:
    """A file-system path argument: str or PathLike, non-empty, no NUL, not absurdly long."""
    if isinstance(value, (bytes, bytearray)) or not isinstance(value, (str, os.PathLike)):
        raise InvalidParameter(f"{name}: expected a path (str or pathlib.Path), got {show(value)}")
    try:
        text = os.fspath(value)
    except Exception:  # a hostile __fspath__ is refused, not propagated
        raise InvalidParameter(f"{name}: expected a path, got {show(value)}") from None
    if not isinstance(text, str) or not text or "\x00" in text or len(text) > MAX_PATH_LENGTH:
        raise InvalidParameter(
            f"{name}: expected a non-empty path of at most {MAX_PATH_LENGTH} characters "
            f"without NUL, got {show(text)}"
        )
    return Path(text)


def _probe(path: Path, test: Callable[[Path], bool]) -> bool:
    try:
        return test(path)
    except (OSError, ValueError):  # a name too long for the file system, ...
        return False


def _config(config: Any) -> tuple[ConfiguredShaper, ReplaySettings]:
    if isinstance(config, Mapping):
        try:
            doc, name = dict(config), "config"
        except Exception:  # a hostile mapping is refused, not propagated
            raise InvalidParameter("config: expected a plain mapping of sections") from None
    elif isinstance(config, (str, os.PathLike)) and not isinstance(config, bytes):
        path = _fs_path("config", config)
        doc, name = load_yaml(path), f"{path}:"
    else:
        raise InvalidParameter(
            "config: expected a YAML file path or a mapping with 'shaper' and 'replay', got "
            f"{type(config).__name__}"
        )
    missing = [k for k in ("shaper", "replay") if k not in doc]
    if missing:
        raise InvalidParameter(
            f"config {name}: missing section(s) {missing}; a replay needs 'shaper:' and 'replay:'"
        )
    extra = sorted(str(k) for k in doc if k not in ("shaper", "replay"))
    if extra:
        raise InvalidParameter(f"config {name}: unknown section(s) {extra}")
    return parse_shaper(doc["shaper"]), _settings(doc["replay"], "replay")


# --------------------------------------------------------------------------- messages


@dataclass(frozen=True)
class _Codec:
    """How a command is read from and written into its message."""

    components: tuple[str, ...]
    unit: str
    read: Callable[[Any], NDArray[np.float64]]
    write: Callable[[Any, NDArray[np.float64] | None, NDArray[np.float64] | None], Any]


def _vec3(v: Any) -> NDArray[np.float64]:
    return np.array([v.x, v.y, v.z], dtype=float)


def _twist_codec(cs: ConfiguredShaper, msgtype: str) -> _Codec:
    n = 3 if cs.command_space == "twist" else cs.command_dim
    names = ("vx", "vy", "vz")[:n]
    stamped = msgtype == TWIST_STAMPED

    def inner(msg: Any) -> Any:
        return msg.twist if stamped else msg

    def read(msg: Any) -> NDArray[np.float64]:
        return _vec3(inner(msg).linear)[:n]

    def write(msg: Any, linear: NDArray[np.float64] | None, angular: Any) -> Any:
        tw = inner(msg)
        if linear is None:  # zeroed: the whole twist stops
            zero = replace(tw.linear, x=0.0, y=0.0, z=0.0)
            new = replace(tw, linear=zero, angular=replace(tw.angular, x=0.0, y=0.0, z=0.0))
        else:
            xyz = _vec3(tw.linear)
            xyz[:n] = linear
            lin = replace(tw.linear, x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2]))
            ang = tw.angular
            if angular is not None:
                ang = replace(ang, x=float(angular[0]), y=float(angular[1]), z=float(angular[2]))
            new = replace(tw, linear=lin, angular=ang)
        return replace(msg, twist=new) if stamped else new

    return _Codec(names, "m/s", read, write)


def _joint_codec(cs: ConfiguredShaper, msgtype: str, joints: tuple[str, ...], topic: str) -> _Codec:
    n = cs.command_dim

    if msgtype == FLOAT_ARRAY:

        def read_array(msg: Any) -> NDArray[np.float64]:
            data = np.asarray(msg.data, dtype=float)
            if data.shape != (n,):
                raise InvalidParameter(
                    f"topic {topic}: expected {n} values in data (joints {list(joints)}), got "
                    f"{data.size}"
                )
            return data

        def write_array(msg: Any, v: NDArray[np.float64] | None, _: Any) -> Any:
            out = np.zeros(n) if v is None else np.asarray(v, dtype=float)
            return replace(msg, data=out.astype(np.float64))

        return _Codec(joints, "rad/s", read_array, write_array)

    def order(msg: Any) -> list[int]:
        names = list(msg.joint_names)
        if sorted(names) != sorted(joints) or len(msg.velocities) != len(names):
            raise InvalidParameter(
                f"topic {topic}: expected a JointJog with velocities for the joints "
                f"{list(joints)}, got joint_names {show(names, 120)} with "
                f"{len(msg.velocities)} velocities"
            )
        if len(msg.displacements):
            raise InvalidParameter(
                f"topic {topic}: a JointJog with displacements is a position command; only "
                "velocity jogs are replayed"
            )
        return [names.index(j) for j in joints]

    def read_jog(msg: Any) -> NDArray[np.float64]:
        return np.asarray(msg.velocities, dtype=float)[order(msg)]

    def write_jog(msg: Any, v: NDArray[np.float64] | None, _: Any) -> Any:
        vel = np.zeros(len(joints))
        if v is not None:
            vel[order(msg)] = v
        return replace(msg, velocities=vel)

    return _Codec(joints, "rad/s", read_jog, write_jog)


def _state_reader(
    cs: ConfiguredShaper, msgtype: str, joints: tuple[str, ...], topic: str, heading: bool
) -> Callable[[Any], NDArray[np.float64]]:
    n = cs.state_dim
    if msgtype == JOINT_STATE:

        def read_joints(msg: Any) -> NDArray[np.float64]:
            names = list(msg.name)
            pos = np.asarray(msg.position, dtype=float)
            absent = [j for j in joints if j not in names]
            if absent or pos.shape != (len(names),):
                raise InvalidParameter(
                    f"topic {topic}: expected a JointState with positions of the joints "
                    f"{list(joints)}, got names {show(names, 120)} with {pos.size} positions"
                )
            return pos[[names.index(j) for j in joints]]

        return read_joints
    odom = msgtype == ODOMETRY

    def read_pose(msg: Any) -> NDArray[np.float64]:
        pose = msg.pose.pose if odom else msg.pose
        xyz = _vec3(pose.position)[:n]
        if not heading:
            return xyz
        o = pose.orientation  # yaw of the unit quaternion (x, y, z, w)
        yaw = np.arctan2(2.0 * (o.w * o.z + o.x * o.y), 1.0 - 2.0 * (o.y * o.y + o.z * o.z))
        return np.append(xyz, yaw)

    return read_pose


def _codecs(
    cs: ConfiguredShaper, settings: ReplaySettings, command_type: str, state_type: str
) -> tuple[_Codec, Callable[[Any], NDArray[np.float64]]]:
    space = cs.command_space
    joints: tuple[str, ...] = ()
    if cs.joint_names is not None:
        joints = tuple(settings.joint_names or cs.joint_names)
        if len(joints) != len(cs.joint_names):
            raise InvalidParameter(
                f"section replay.joint_names: expected {len(cs.joint_names)} names (the "
                f"shaper's joints {list(cs.joint_names)}), got {len(joints)}"
            )
    elif settings.joint_names is not None:
        raise InvalidParameter(
            f"section replay.joint_names: a {cs.kind} shaper has no joints; leave it out"
        )
    if space in ("plane", "workspace") and cs.state_dim > 3:
        raise InvalidParameter(
            f"section shaper: a {cs.state_dim}-D {cs.kind} cannot be replayed from poses and "
            "twists (at most 3 dimensions)"
        )
    cmd_ok = _JOINT_TYPES if space == "joint" else _TWIST_TYPES
    state_ok = (JOINT_STATE,) if space in ("joint", "twist") else _POSE_TYPES
    if command_type not in cmd_ok:
        raise InvalidParameter(
            f"replay.command_topic {settings.command_topic}: has type {command_type}; a "
            f"{cs.kind} shaper ({space} commands) reads {' or '.join(cmd_ok)}"
        )
    if state_type not in state_ok:
        raise InvalidParameter(
            f"replay.state_topic {settings.state_topic}: has type {state_type}; a {cs.kind} "
            f"shaper reads {' or '.join(state_ok)}"
        )
    if space == "joint":
        codec = _joint_codec(cs, command_type, joints, settings.command_topic)
    else:
        codec = _twist_codec(cs, command_type)
    heading = settings.command_frame == "body"
    if heading and space != "plane":
        raise InvalidParameter(
            f"section replay.command_frame: 'body' applies to a polygon shaper (a planar base), "
            f"not to a {cs.kind} one; leave it out"
        )
    return codec, _state_reader(cs, state_type, joints, settings.state_topic, heading)


# ------------------------------------------------------------------------------ replay


def _typestore(distro: str | None) -> Any:
    """The message definitions of ``distro`` (Humble if unknown), plus control_msgs/JointJog."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = {s.value: s for s in Stores}.get(f"ros2_{distro}", Stores.ROS2_HUMBLE)
    ts = get_typestore(store)
    ts.register(get_types_from_msg(_JOINT_JOG_MSG, JOINT_JOG))
    return ts


def _bag_path(bag: Any) -> Path:
    p = _fs_path("bag", bag)
    if not _probe(p, Path.is_dir) or not _probe(p / "metadata.yaml", Path.is_file):
        raise InvalidParameter(
            f"bag: expected a rosbag2 directory with a metadata.yaml, got {show(str(p), 200)}"
        )
    return p


def _metadata(p: Path) -> Any:
    return read_yaml(p / "metadata.yaml", what="bag metadata file")["rosbag2_bagfile_information"]


def _distro_of(p: Path) -> str | None:
    """The bag's ``ros_distro`` (rosbag2 format 8+), or None (then Humble's definitions)."""
    try:
        distro = _metadata(p).get("ros_distro")
    except Exception:  # rosbags judges the file next and names what is wrong with it
        return None
    return distro if isinstance(distro, str) else None


def _storage_of(p: Path) -> str:
    try:
        ident = _metadata(p)["storage_identifier"]
    except Exception as exc:  # rosbags read it already; anything odd is a malformed bag
        raise InvalidParameter(f"bag {p}: unreadable metadata.yaml ({exc})") from None
    if ident not in STORAGES:
        raise InvalidParameter(f"bag {p}: storage {ident!r} is not one of {list(STORAGES)}")
    return str(ident)


def _out_path(out: Any) -> Path:
    p = _fs_path("out", out)
    if _probe(p, lambda q: os.path.lexists(q)):
        raise InvalidParameter(
            f"out: {p} exists already; a replay writes a new bag directory (remove it first)"
        )
    if not _probe(p.parent, Path.is_dir):
        raise InvalidParameter(f"out: the folder {p.parent} does not exist")
    return p


def replay(
    bag: str | Path,
    config: str | Path | Mapping[str, Any],
    out: str | Path,
    *,
    storage: str | None = None,
    progress: Callable[[float], None] | None = None,
) -> ReplaySummary:
    """Shape a bag's recorded commands with a configured shaper and write a new bag.

    Every message of ``bag`` is copied to ``out``; each command of ``replay.command_topic`` is
    shaped with the latest ``replay.state_topic`` state at or before it and written to
    ``replay.output_topic`` as a message of the command's type at the command's time. In twist
    mode the shaped joint velocities are written as the TCP twist they give (``J q̇``, linear and
    angular). The module docstring lists the message types.

    Args:
        bag: A rosbag2 directory (``metadata.yaml`` plus MCAP or sqlite3 storage).
        config: A YAML file with ``shaper:`` and ``replay:`` sections, or that mapping.
        out: The bag directory to write; it must not exist (its parent must).
        storage: ``"mcap"`` or ``"sqlite3"`` for the written bag (default: the input's).
        progress: Called now and then with the fraction done, 0..1 (reading and shaping the
            commands, then writing every message); for a progress bar.

    Returns:
        Counts, changes and the time series (:class:`ReplaySummary`).

    Raises:
        InvalidParameter: a bad config, a missing or malformed bag, a missing topic or one of the
            wrong type, a message with the wrong joints (the topic is named), an existing
            ``out``, the ``ros`` extra not installed.
    """
    # Every argument's form first, then the file system (a message names the bad argument).
    _fs_path("bag", bag)
    _fs_path("out", out)
    chosen = None if storage is None else check_choice("storage", storage, STORAGES)
    if progress is not None and not callable(progress):
        raise InvalidParameter(f"progress: expected a callable, got {type(progress).__name__}")
    report = _Progress(progress)
    cs, settings = _config(config)
    p = _bag_path(bag)
    target = _out_path(out)
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.rosbag2 import StoragePlugin, Writer
    except ImportError:
        raise InvalidParameter("replay needs rosbags: pip install 'velfence[ros]'") from None
    if hasattr(cs.shaper, "reset"):
        cs.shaper.reset()
    try:
        reader = AnyReader([p], default_typestore=_typestore(_distro_of(p)))
        reader.open()
    except Exception as exc:  # rosbags' errors, OSError, sqlite3/mcap errors: a malformed bag
        raise InvalidParameter(f"bag {p}: cannot read it ({type(exc).__name__}: {exc})") from None
    try:
        fmt = chosen or _storage_of(p)
        conns = {c.topic: c for c in reader.connections}
        for name, topic in (
            ("command_topic", settings.command_topic),
            ("state_topic", settings.state_topic),
        ):
            if topic not in conns:
                raise InvalidParameter(
                    f"replay.{name} {topic}: not in bag {p} (its topics: {sorted(conns)})"
                )
        if settings.output in conns:
            raise InvalidParameter(
                f"replay.output_topic {settings.output}: bag {p} has that topic already; choose "
                "another output_topic"
            )
        cmd_conn, state_conn = conns[settings.command_topic], conns[settings.state_topic]
        codec, read_state = _codecs(cs, settings, cmd_conn.msgtype, state_conn.msgtype)
        total = int(getattr(reader, "message_count", 0) or 0)
        result = _shape_all(
            reader, cs, settings, codec, read_state, cmd_conn, state_conn, report.part(0.0, 0.5)
        )
        messages = _write(
            reader, target, fmt, settings, cmd_conn, result, Writer, StoragePlugin,
            report.part(0.5, 1.0), total,
        )  # fmt: skip
        report(1.0)
    except VelfenceError:
        raise
    except Exception as exc:
        raise InvalidParameter(
            f"bag {p}: cannot replay it ({type(exc).__name__}: {show(str(exc), 200)})"
        ) from None
    finally:
        reader.close()
    return _summary(p, target, fmt, cs, settings, cmd_conn, state_conn, codec, result, messages)


class _Progress:
    """Forwards a phase's fraction to the caller's callback, at most every 1 % (cheap in loops)."""

    def __init__(self, fn: Callable[[float], None] | None, lo: float = 0.0, hi: float = 1.0):
        self.fn, self.lo, self.hi, self.last = fn, lo, hi, -1.0

    def __call__(self, f: float) -> None:
        if self.fn is not None and (f >= 1.0 or f - self.last >= 0.01):
            self.last = f
            self.fn(self.lo + (self.hi - self.lo) * min(max(f, 0.0), 1.0))

    def part(self, lo: float, hi: float) -> _Progress:
        span = self.hi - self.lo
        return _Progress(self.fn, self.lo + span * lo, self.lo + span * hi)


@dataclass
class _Result:
    times_ns: NDArray[np.int64]
    start_ns: int
    commanded: NDArray[np.float64]
    shaped: NDArray[np.float64]
    positions: NDArray[np.float64]
    has_state: NDArray[np.bool_]
    zeroed: dict[str, int]
    states: int
    raw: list[bytes]


def _shape_all(
    reader: Any,
    cs: ConfiguredShaper,
    settings: ReplaySettings,
    codec: _Codec,
    read_state: Callable[[Any], NDArray[np.float64]],
    cmd_conn: Any,
    state_conn: Any,
    report: _Progress,
) -> _Result:
    ts = reader.typestore
    s_times: list[int] = []
    s_vals: list[NDArray[np.float64]] = []
    cmds: list[tuple[int, Any]] = []
    for conn, t, raw in reader.messages(connections=[cmd_conn, state_conn]):
        msg = ts.deserialize_cdr(raw, conn.msgtype)
        if conn.topic == state_conn.topic:
            s_times.append(int(t))
            s_vals.append(read_state(msg))
        else:
            cmds.append((int(t), msg))
    order = np.argsort(np.array(s_times, dtype=np.int64), kind="stable")
    st = np.array(s_times, dtype=np.int64)[order]
    sv = [s_vals[i] for i in order]
    cmds.sort(key=lambda c: c[0])
    k, n = len(codec.components), cs.state_dim
    N = len(cmds)
    commanded = np.zeros((N, k))
    shaped = np.zeros((N, k))
    positions = np.zeros((N, n))
    has_state = np.zeros(N, dtype=bool)
    zeroed = {"no_state": 0, "stale": 0, "invalid": 0}
    raw_out: list[bytes] = []
    max_age_ns = None if settings.max_state_age is None else settings.max_state_age * 1e9
    twist_mode = cs.command_space == "twist"
    heading = settings.command_frame == "body"
    for i, (t, msg) in enumerate(cmds):
        report(i / max(N, 1))
        v = codec.read(msg)
        commanded[i] = np.where(np.isfinite(v), v, 0.0)
        j = int(np.searchsorted(st, t, side="right")) - 1
        reason = None
        if j < 0:
            reason = "no_state"
        elif max_age_ns is not None and t - int(st[j]) > max_age_ns:
            reason = "stale"
        elif not (np.all(np.isfinite(v)) and np.all(np.isfinite(sv[j]))):
            reason = "invalid"
        if j >= 0 and np.all(np.isfinite(sv[j])):
            positions[i] = sv[j][:n]
        if reason is not None:
            zeroed[reason] += 1
            out_msg = codec.write(msg, None, None)
        else:
            has_state[i] = True
            q = sv[j][:n]
            try:
                if heading:  # body frame -> the pose's frame: turn by the heading
                    v = body_to_world(v, sv[j][n])
                y = np.asarray(cs.shaper.shape(q, v), dtype=float)
                if heading:  # and back
                    y = world_to_body(y, sv[j][n])
            except VelfenceError:
                zeroed["invalid"] += 1
                has_state[i] = False
                out_msg = codec.write(msg, None, None)
            else:
                angular = None
                if twist_mode:  # the TCP twist the shaped joint velocities give
                    robot = cs.shaper.filter.robot
                    y, angular = robot.jacobian(q) @ y, robot.angular_jacobian(q) @ y
                shaped[i] = y
                out_msg = codec.write(msg, y, angular)
        raw_out.append(bytes(ts.serialize_cdr(out_msg, cmd_conn.msgtype)))
    return _Result(
        times_ns=np.array([c[0] for c in cmds], dtype=np.int64),
        start_ns=int(reader.start_time),
        commanded=commanded,
        shaped=shaped,
        positions=positions,
        has_state=has_state,
        zeroed=zeroed,
        states=len(s_times),
        raw=raw_out,
    )


def _add(writer: Any, ts: Any, topic: str, conn: Any) -> Any:
    from rosbags.interfaces import MessageDefinitionFormat

    qos = list(getattr(conn.ext, "offered_qos_profiles", []))
    if conn.msgdef.format != MessageDefinitionFormat.NONE and conn.digest:
        return writer.add_connection(
            topic,
            conn.msgtype,
            msgdef=conn.msgdef.data,
            rihs01=conn.digest,
            offered_qos_profiles=qos,
        )
    return writer.add_connection(topic, conn.msgtype, typestore=ts, offered_qos_profiles=qos)


def _write(
    reader: Any,
    target: Path,
    fmt: str,
    settings: ReplaySettings,
    cmd_conn: Any,
    result: _Result,
    Writer: Any,
    StoragePlugin: Any,
    report: _Progress,
    total: int,
) -> int:
    plugin = StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3
    ts = reader.typestore
    written = 0
    try:
        with Writer(target, version=9, storage_plugin=plugin) as writer:
            out_conns = {c.id: _add(writer, ts, c.topic, c) for c in reader.connections}
            shaped_conn = _add(writer, ts, settings.output, cmd_conn)
            pending = list(zip(result.times_ns.tolist(), result.raw, strict=True))
            i = 0
            for conn, t, raw in reader.messages():
                # Each shaped command goes in right after its command (same timestamp).
                while i < len(pending) and pending[i][0] < t:
                    writer.write(shaped_conn, pending[i][0], pending[i][1])
                    i, written = i + 1, written + 1
                writer.write(out_conns[conn.id], t, raw)
                written += 1
                if total:
                    report(written / (total + len(pending)))
            for t_cmd, raw in pending[i:]:
                writer.write(shaped_conn, t_cmd, raw)
                written += 1
    except BaseException:
        if target.is_dir():  # the directory this call created: no half-written bag left behind
            shutil.rmtree(target, ignore_errors=True)
        raise
    return written


def _summary(
    p: Path,
    target: Path,
    fmt: str,
    cs: ConfiguredShaper,
    settings: ReplaySettings,
    cmd_conn: Any,
    state_conn: Any,
    codec: _Codec,
    r: _Result,
    messages: int,
) -> ReplaySummary:
    N = len(r.times_ns)
    diff = np.abs(r.commanded - r.shaped)
    changed = int(np.count_nonzero(np.any(diff > CHANGE_TOL, axis=1))) if N else 0
    fence = buffer = None
    if cs.kind == "polygon":
        fence = np.array(cs.shaper.polygon.corners, dtype=float)
        buffer = float(cs.shaper.buffer)
    return ReplaySummary(
        bag=p,
        out=target,
        storage=fmt,
        kind=cs.kind,
        command_space=cs.command_space,
        command_topic=settings.command_topic,
        state_topic=settings.state_topic,
        output_topic=settings.output,
        command_type=cmd_conn.msgtype,
        state_type=state_conn.msgtype,
        components=codec.components,
        unit=codec.unit,
        commands=N,
        states=r.states,
        messages=messages,
        changed=changed,
        changed_fraction=changed / N if N else 0.0,
        max_abs_change=float(diff.max()) if diff.size else 0.0,
        zeroed_no_state=r.zeroed["no_state"],
        zeroed_stale=r.zeroed["stale"],
        zeroed_invalid=r.zeroed["invalid"],
        times=(r.times_ns - r.start_ns).astype(float) * 1e-9,
        commanded=r.commanded,
        shaped=r.shaped,
        positions=r.positions,
        has_state=r.has_state,
        fence=fence,
        buffer=buffer,
    )


document_inits(globals())
