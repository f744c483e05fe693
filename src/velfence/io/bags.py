"""Replay a recorded rosbag2 through a configured shaper (``velfence replay``; ``docs/replay.md``).

A bag (a rosbag2 directory with ``metadata.yaml`` and MCAP or sqlite3 storage, a folder holding
one ``.mcap`` or ``.db3`` file, or such a file, as Foxglove's and the ``mcap`` library's writers
leave them; read by ``rosbags``) holds a command topic and a state topic. Each recorded command,
in time order, is shaped with the latest state recorded at or before it (zero-order hold, by the
bag's receive time); the shaped command is written, as a message of the command's own type with
the command's timestamp, to a new bag beside a copy of every original topic. The replay is open
loop: the state is what was recorded, not what the shaped command would have produced.

The bag is read once; the command's and the state's fields are read from the CDR bytes
(:mod:`velfence.io._cdr`) and a shaped command is the command's bytes with the velocities
patched in. A bag with nothing to replay raises :class:`~velfence.errors.NothingToReplay`.

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
      sensors:                         # safety_filter only: range sensors -> obstacle rows
        - {topic: /camera/points, type: point_cloud2, base_frame: base_link, max_age: 0.2}

``rosbags`` (extra ``ros``) is imported inside the functions only.
"""

from __future__ import annotations

import os
import re
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
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
from velfence.errors import InvalidParameter, NothingToReplay, VelfenceError
from velfence.geometry.frames import body_to_world, world_to_body
from velfence.io._cdr import CdrError, CdrReader, patch_doubles
from velfence.io.config import Positive, StrictModel, describe_validation_error
from velfence.io.sensors import SENSOR_TYPES, accept_sensor_message
from velfence.io.shaper_config import (
    MAX_JOINTS,
    ConfiguredShaper,
    SensorTopic,
    load_yaml,
    parse_shaper,
)
from velfence.io.transforms import TransformStore
from velfence.io.yaml_reader import read_yaml

if TYPE_CHECKING:
    from numpy.typing import NDArray

__all__ = [
    "CHANGE_TOL",
    "STORAGES",
    "ReplaySettings",
    "ReplaySummary",
    "load_replay_config",
    "message_typestore",
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
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
#: The transform topics a replay with sensors reads (their TFMessage, in time order).
TF_TOPICS = ("/tf", "/tf_static")

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


class ReplaySensor(SensorTopic):
    """A range sensor's topic in a bag (``replay.sensors``; the fields of ``SensorTopic``)."""

    @field_validator("topic")
    @classmethod
    def _topic_name(cls, value: str) -> str:
        if not _TOPIC.fullmatch(value):
            raise ValueError(f"expected a ROS topic name (/name), got {show(value, 60)}")
        return value


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
        sensors: Range sensors (``sensor_msgs/msg/PointCloud2``, ``LaserScan``) whose points
            the safety filter keeps the arm out of (a ``safety_filter`` shaper only), through
            the bag's ``/tf`` and ``/tf_static`` (``docs/replay.md``, "Point clouds").
    """

    command_topic: Topic
    state_topic: Topic
    output_topic: Topic | None = None
    joint_names: Annotated[list[JointName], Field(min_length=1, max_length=MAX_JOINTS)] | None = (
        None
    )
    max_state_age: Positive | None = None
    command_frame: Literal["world", "body"] = "world"
    sensors: Annotated[list[ReplaySensor], Field(default_factory=list, max_length=16)]

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
        sensed = [x.topic for x in self.sensors]
        if len(set(sensed)) != len(sensed) or set(sensed) & {*topics, *TF_TOPICS}:
            raise ValueError(
                f"sensors: each sensor topic must be distinct and not a command, state, output "
                f"or transform topic, got {sensed}"
            )
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
        clouds_used: Sensor messages (``replay.sensors``) fed to the filter.
        clouds_dropped: Sensor messages dropped, by reason: ``"stale"`` (stamp older than
            ``max_age`` at the bag's receive time), ``"frame_unknown"`` (no transform from its
            frame to ``base_frame`` in the bag's ``/tf`` so far), ``"malformed"``, ``"invalid"``
            (a point beyond the finite range once transformed); and ``"bad_transform"`` counts
            the bag's transforms that could not be stored (a zero quaternion, NaN).
        cloud_readings_dropped: Readings of the used messages dropped (NaN, inf, out of
            range).
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
    clouds_used: int = 0
    clouds_dropped: Mapping[str, int] = field(default_factory=dict)
    cloud_readings_dropped: int = 0

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
    base: Path | None = None  # relative zone files: from the config file's folder
    if isinstance(config, Mapping):
        try:
            doc, name = dict(config), "config"
        except Exception:  # a hostile mapping is refused, not propagated
            raise InvalidParameter("config: expected a plain mapping of sections") from None
    elif isinstance(config, (str, os.PathLike)) and not isinstance(config, bytes):
        path = _fs_path("config", config)
        doc, name, base = load_yaml(path), f"{path}:", path.parent
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
    settings = _settings(doc["replay"], "replay")
    return parse_shaper(doc["shaper"], sensors=settings.sensors, base_dir=base), settings


def load_replay_config(
    config: str | Path | Mapping[str, Any],
) -> tuple[ConfiguredShaper, ReplaySettings]:
    """Read and check a replay configuration without a bag (what :func:`replay` reads first).

    ``velfence replay`` with several bags calls it once, so a bad file is one error, not one per
    bag.

    Args:
        config: A YAML file with ``shaper:`` and ``replay:`` sections, or that mapping.

    Returns:
        The configured shaper and the ``replay:`` section.

    Raises:
        InvalidParameter: a missing or unknown section, or a bad field (named).
    """
    return _config(config)


# --------------------------------------------------------------------------- messages
#
# The codecs read the few fields a replay needs from each message's CDR bytes and write a shaped
# command by patching its velocities into a copy of the command's bytes (velfence.io._cdr): no
# typestore decode or encode per message.


@dataclass(frozen=True)
class _Codec:
    """How a command is read from and written into its message's bytes.

    ``read(raw)`` gives the command's components and a token of where they are; ``write(raw,
    token, values, angular)`` gives the bytes of the shaped message (``values=None``: zeroed).
    """

    components: tuple[str, ...]
    unit: str
    read: Callable[[bytes], tuple[NDArray[np.float64], Any]]
    write: Callable[[bytes, Any, NDArray[np.float64] | None, NDArray[np.float64] | None], bytes]


def _twist_codec(cs: ConfiguredShaper, msgtype: str) -> _Codec:
    n = 3 if cs.command_space == "twist" else cs.command_dim
    names = ("vx", "vy", "vz")[:n]
    stamped = msgtype == TWIST_STAMPED

    def read(raw: bytes) -> tuple[NDArray[np.float64], Any]:
        r = CdrReader(raw)
        if stamped:
            r.header()
        lin_off, lin = r.vec3()
        ang_off, _ = r.vec3()
        return np.array(lin[:n], dtype=float), (lin_off, ang_off, lin)

    def write(raw: bytes, token: Any, linear: Any, angular: Any) -> bytes:
        lin_off, ang_off, lin = token
        if linear is None:  # zeroed: the whole twist stops
            return patch_doubles(raw, [(lin_off, np.zeros(3)), (ang_off, np.zeros(3))])
        xyz = np.array(lin, dtype=float)
        xyz[:n] = linear
        patches = [(lin_off, xyz)]
        if angular is not None:
            patches.append((ang_off, np.asarray(angular, dtype=float)))
        return patch_doubles(raw, patches)

    return _Codec(names, "m/s", read, write)


def _joint_codec(cs: ConfiguredShaper, msgtype: str, joints: tuple[str, ...], topic: str) -> _Codec:
    n = cs.command_dim

    if msgtype == FLOAT_ARRAY:

        def read_array(raw: bytes) -> tuple[NDArray[np.float64], Any]:
            r = CdrReader(raw)
            for _ in range(r.u32()):  # layout.dim: label, size, stride
                r.skip_string()
                r.skip_u32s(2)
            r.u32()  # layout.data_offset
            off, data = r.double_seq()
            if data.shape != (n,):
                raise InvalidParameter(
                    f"topic {topic}: expected {n} values in data (joints {list(joints)}), got "
                    f"{data.size}"
                )
            return data, off

        def write_array(raw: bytes, off: Any, v: Any, _: Any) -> bytes:
            return patch_doubles(raw, [(off, np.zeros(n) if v is None else v)])

        return _Codec(joints, "rad/s", read_array, write_array)

    orders: dict[bytes, tuple[tuple[str, ...], NDArray[np.intp] | None]] = {}

    def order(r: CdrReader, key: bytes, at: int) -> tuple[tuple[str, ...], NDArray[np.intp] | None]:
        known = orders.get(key)
        if known is None:
            end, r.pos = r.pos, at
            names = tuple(r.strings())
            r.pos = end
            idx = None
            if sorted(names) == sorted(joints):
                idx = np.array([names.index(j) for j in joints], dtype=np.intp)
            known = orders[key] = (names, idx)
        return known

    def read_jog(raw: bytes) -> tuple[NDArray[np.float64], Any]:
        r = CdrReader(raw)
        r.header()
        names, idx = order(r, *r.strings_key())
        displacements = r.u32()
        r.doubles_at(displacements)
        off, vel = r.double_seq()
        if idx is None or vel.size != len(names):
            raise InvalidParameter(
                f"topic {topic}: expected a JointJog with velocities for the joints "
                f"{list(joints)}, got joint_names {show(list(names), 120)} with "
                f"{vel.size} velocities"
            )
        if displacements:
            raise InvalidParameter(
                f"topic {topic}: a JointJog with displacements is a position command; only "
                "velocity jogs are replayed"
            )
        return vel[idx], (off, idx)

    def write_jog(raw: bytes, token: Any, v: Any, _: Any) -> bytes:
        off, idx = token
        vel = np.zeros(len(idx))
        if v is not None:
            vel[idx] = v
        return patch_doubles(raw, [(off, vel)])

    return _Codec(joints, "rad/s", read_jog, write_jog)


def _state_reader(
    cs: ConfiguredShaper, msgtype: str, joints: tuple[str, ...], topic: str, heading: bool
) -> Callable[[bytes], NDArray[np.float64]]:
    n = cs.state_dim
    if msgtype == JOINT_STATE:
        picks: dict[bytes, tuple[tuple[str, ...], NDArray[np.intp] | None]] = {}

        def read_joints(raw: bytes) -> NDArray[np.float64]:
            r = CdrReader(raw)
            r.header()
            key, at = r.strings_key()
            known = picks.get(key)
            if known is None:
                end, r.pos = r.pos, at
                names = tuple(r.strings())
                r.pos = end
                absent = [j for j in joints if j not in names]
                idx = None if absent else np.array([names.index(j) for j in joints], dtype=np.intp)
                known = picks[key] = (names, idx)
            names, idx = known
            _, pos = r.double_seq()
            if idx is None or pos.shape != (len(names),):
                raise InvalidParameter(
                    f"topic {topic}: expected a JointState with positions of the joints "
                    f"{list(joints)}, got names {show(list(names), 120)} with {pos.size} "
                    "positions"
                )
            return pos[idx]

        return read_joints
    odom = msgtype == ODOMETRY

    def read_pose(raw: bytes) -> NDArray[np.float64]:
        r = CdrReader(raw)
        r.header()
        if odom:
            r.skip_string()  # child_frame_id
        px, py, pz, ox, oy, oz, ow = r.pose()
        xyz = np.array((px, py, pz)[:n], dtype=float)
        if not heading:
            return xyz
        # yaw of the unit quaternion (x, y, z, w)
        yaw = np.arctan2(2.0 * (ow * oz + ox * oy), 1.0 - 2.0 * (oy * oy + oz * oz))
        return np.append(xyz, yaw)

    return read_pose


def _codecs(
    cs: ConfiguredShaper, settings: ReplaySettings, command_type: str, state_type: str
) -> tuple[_Codec, Callable[[bytes], NDArray[np.float64]]]:
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


def message_typestore(distro: str | None) -> Any:
    """The message definitions of ``distro`` (Humble if unknown), plus control_msgs/JointJog.

    Internal API (rosbags' typestore the replay reads and writes with; the example bags, the
    tests and ``benchmarks/replay_speed.py`` use the same one).

    Args:
        distro: A ROS 2 distribution name (``"humble"``, ``"jazzy"``, ...) or ``None``.

    Returns:
        A ``rosbags.typesys`` typestore.
    """
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = {s.value: s for s in Stores}.get(f"ros2_{distro}", Stores.ROS2_HUMBLE)
    ts = get_typestore(store)
    ts.register(get_types_from_msg(_JOINT_JOG_MSG, JOINT_JOG))
    return ts


#: File suffix -> storage, for a bag given as one storage file or a folder without metadata.
_SUFFIXES = {".mcap": "mcap", ".db3": "sqlite3"}


@dataclass(frozen=True)
class _Source:
    """Where a bag's messages are: what rosbags opens, the storage, and the metadata if any."""

    path: Path
    paths: list[Path]
    storage: str
    metadata: Mapping[str, Any] | None


def _bag_source(bag: Any) -> _Source:
    """Resolve a bag argument: a rosbag2 directory, a folder with one storage file, or the file.

    With a ``metadata.yaml`` and no compression, the storage files it lists are opened directly
    (their own channels and topics, not the metadata's copy of them: a channel without QoS
    metadata, as Foxglove's writers make, would otherwise match no topic of the metadata).
    """
    p = _fs_path("bag", bag)
    what = "a rosbag2 directory, a folder with one .mcap or .db3 file, or such a file"
    if _probe(p, Path.is_file):
        storage = _SUFFIXES.get(p.suffix)
        if storage is None:
            raise InvalidParameter(f"bag: expected {what}, got the file {show(str(p), 200)}")
        return _Source(p, [p], storage, None)
    if not _probe(p, Path.is_dir):
        raise InvalidParameter(f"bag: expected {what}, got {show(str(p), 200)} (not found)")
    if _probe(p / "metadata.yaml", Path.is_file):
        try:
            meta = read_yaml(p / "metadata.yaml", what="bag metadata file")
            info = meta["rosbag2_bagfile_information"]
            storage = info["storage_identifier"]
        except VelfenceError:
            raise
        except Exception as exc:  # a key missing, not a mapping: a malformed bag
            raise InvalidParameter(
                f"bag {p}: unreadable metadata.yaml ({type(exc).__name__}: {exc})"
            ) from None
        if storage not in STORAGES:
            raise InvalidParameter(f"bag {p}: storage {storage!r} is not one of {list(STORAGES)}")
        files = info.get("relative_file_paths") or []
        paths = [p / str(f) for f in files] if isinstance(files, list) else []
        compressed = bool(info.get("compression_mode")) and info.get("compression_mode") != "none"
        if compressed or not paths or not all(_probe(f, Path.is_file) for f in paths):
            paths = [p]  # rosbags' directory reader: decompression, and its own errors
        return _Source(p, paths, str(storage), info if isinstance(info, Mapping) else None)
    try:
        entries = list(p.iterdir())
    except OSError as exc:  # a folder we may not list
        raise InvalidParameter(f"bag: cannot list the folder {show(str(p), 200)} ({exc})") from None
    found = sorted(f for f in entries if f.suffix in _SUFFIXES and _probe(f, Path.is_file))
    if len(found) != 1:
        raise InvalidParameter(
            f"bag: expected {what}, got the folder {show(str(p), 200)} with no metadata.yaml "
            f"and {len(found)} .mcap/.db3 files"
            + (f" ({[f.name for f in found]}; give each as its own bag)" if found else "")
        )
    return _Source(p, found, _SUFFIXES[found[0].suffix], None)


def _distro_of(source: _Source) -> str | None:
    """The bag's ``ros_distro`` (rosbag2 format 8+), or None (then Humble's definitions)."""
    distro = (source.metadata or {}).get("ros_distro")
    return distro if isinstance(distro, str) else None


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
    ``replay.output_topic`` as a message of the command's type at the command's time, right
    after the command. In twist mode the shaped joint velocities are written as the TCP twist
    they give (``J q̇``, linear and angular). The module docstring lists the message types.

    Args:
        bag: A rosbag2 directory (``metadata.yaml`` plus MCAP or sqlite3 storage), a folder
            holding one ``.mcap`` or ``.db3`` file and no ``metadata.yaml`` (as Foxglove's and
            the ``mcap`` library's writers leave them), or such a file.
        config: A YAML file with ``shaper:`` and ``replay:`` sections, or that mapping.
        out: The bag directory to write; it must not exist (its parent must).
        storage: ``"mcap"`` or ``"sqlite3"`` for the written bag (default: the input's).
        progress: Called now and then with the fraction of the bag's messages done, 0..1; for a
            progress bar.

    Returns:
        Counts, changes and the time series (:class:`ReplaySummary`).

    Raises:
        NothingToReplay: the bag has no message, lacks the command or the state topic (or has
            no message on it), or no command has a usable state (all before the first state, or
            every held state older than ``max_state_age``); the message names the bag's topics
            with their types and counts and what was looked for. No output is left behind.
        InvalidParameter: a bad config, a missing or malformed bag, a topic of the wrong type,
            a message with the wrong joints (the topic is named), an existing ``out``, the
            ``ros`` extra not installed.
    """
    # Every argument's form first, then the file system (a message names the bad argument).
    _fs_path("bag", bag)
    _fs_path("out", out)
    chosen = None if storage is None else check_choice("storage", storage, STORAGES)
    if progress is not None and not callable(progress):
        raise InvalidParameter(f"progress: expected a callable, got {type(progress).__name__}")
    report = _Progress(progress)
    cs, settings = _config(config)
    source = _bag_source(bag)
    p = source.path
    target = _out_path(out)
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.rosbag2 import StoragePlugin, Writer
    except ImportError:
        raise InvalidParameter("replay needs rosbags: pip install 'velfence[ros]'") from None
    if hasattr(cs.shaper, "reset"):
        cs.shaper.reset()
    try:
        reader = AnyReader(source.paths, default_typestore=message_typestore(_distro_of(source)))
        reader.open()
    except Exception as exc:  # rosbags' errors, OSError, sqlite3/mcap errors: a malformed bag
        raise InvalidParameter(f"bag {p}: cannot read it ({type(exc).__name__}: {exc})") from None
    try:
        fmt = chosen or source.storage
        job = _Job.plan(reader, source, cs, settings)
        plugin = StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3
        result = job.run(reader, target, Writer(target, version=9, storage_plugin=plugin), report)
        report(1.0)
    except VelfenceError:
        raise
    except Exception as exc:
        raise InvalidParameter(
            f"bag {p}: cannot replay it ({type(exc).__name__}: {show(str(exc), 200)})"
        ) from None
    finally:
        reader.close()
    return _summary(p, target, fmt, cs, settings, job, result)


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
    messages: int
    clouds: tuple[int, dict[str, int], int] = (0, {}, 0)


#: Messages held before the shaped commands of a window are computed (one batch call) and the
#: window is written: bounds the memory by count and by bytes, whatever the bag's size.
_WINDOW_MESSAGES = 4096
_WINDOW_BYTES = 32 * 2**20


def _holdings(reader: Any, counts: Mapping[str, int] | None = None) -> str:
    """What a bag holds: its topics with type and message count (read, or its index's)."""
    topics: dict[str, list[Any]] = {}
    for c in reader.connections:
        topics.setdefault(c.topic, []).append(c)
    if not topics:
        return "the bag holds no topic"
    parts = []
    for topic in sorted(topics):
        conns = topics[topic]
        n = counts[topic] if counts is not None else sum(int(c.msgcount or 0) for c in conns)
        types = "/".join(sorted({c.msgtype for c in conns}))
        parts.append(f"{topic} ({types}, {n} messages)")
    shown = parts[:20] + ([f"... {len(parts) - 20} more"] if len(parts) > 20 else [])
    return f"the bag holds {len(topics)} topic(s): " + ", ".join(shown)


@dataclass
class _Job:
    """One replay: the topics' connections, the codecs, and the shaping of a window."""

    cs: ConfiguredShaper
    settings: ReplaySettings
    codec: _Codec
    read_state: Callable[[bytes], NDArray[np.float64]]
    command_type: str
    state_type: str
    cmd_ids: frozenset[int]
    state_ids: frozenset[int]
    wanted: str
    listed: int | None
    path: Path
    sensor_ids: Mapping[int, int] = field(default_factory=dict)
    tf_ids: frozenset[int] = frozenset()

    @classmethod
    def plan(cls, reader: Any, source: _Source, cs: ConfiguredShaper, s: ReplaySettings) -> _Job:
        by_topic: dict[str, list[Any]] = {}
        for c in reader.connections:
            by_topic.setdefault(c.topic, []).append(c)
        space = cs.command_space
        cmd_ok = _JOINT_TYPES if space == "joint" else _TWIST_TYPES
        state_ok = (JOINT_STATE,) if space in ("joint", "twist") else _POSE_TYPES
        wanted = (
            f"looked for commands on {s.command_topic} ({' or '.join(cmd_ok)}) and states on "
            f"{s.state_topic} ({' or '.join(state_ok)})"
        )
        listed = None
        if source.metadata is not None and isinstance(source.metadata.get("message_count"), int):
            listed = int(source.metadata["message_count"])
        for name, topic in (("command_topic", s.command_topic), ("state_topic", s.state_topic)):
            if topic not in by_topic:
                raise NothingToReplay(
                    f"replay.{name} {topic}: not in bag {source.path}; {wanted}; "
                    f"{_holdings(reader)}{_listed(listed)}"
                )
        if s.output in by_topic:
            raise InvalidParameter(
                f"replay.output_topic {s.output}: bag {source.path} has that topic already; "
                "choose another output_topic"
            )
        types = {}
        for topic in (s.command_topic, s.state_topic):
            found = {c.msgtype for c in by_topic[topic]}
            if len(found) != 1:
                raise InvalidParameter(
                    f"topic {topic}: bag {source.path} has it with several types {sorted(found)}"
                )
            types[topic] = found.pop()
        codec, read_state = _codecs(cs, s, types[s.command_topic], types[s.state_topic])
        sensor_ids: dict[int, int] = {}
        for i, x in enumerate(s.sensors):
            want = SENSOR_TYPES[x.type]
            if x.topic not in by_topic:
                raise InvalidParameter(
                    f"replay.sensors[{i}].topic {x.topic}: not in bag {source.path} ({want} "
                    f"expected); {_holdings(reader)}"
                )
            found = {c.msgtype for c in by_topic[x.topic]}
            if found != {want}:
                raise InvalidParameter(
                    f"replay.sensors[{i}].topic {x.topic}: bag {source.path} has it as "
                    f"{sorted(found)}, expected {want} (type: {x.type})"
                )
            sensor_ids.update(dict.fromkeys((c.id for c in by_topic[x.topic]), i))
        tf_ids = frozenset(
            c.id
            for c in reader.connections
            if s.sensors and c.topic in TF_TOPICS and c.msgtype == TF_MESSAGE
        )
        return cls(
            cs=cs,
            settings=s,
            codec=codec,
            read_state=read_state,
            command_type=types[s.command_topic],
            state_type=types[s.state_topic],
            cmd_ids=frozenset(c.id for c in by_topic[s.command_topic]),
            state_ids=frozenset(c.id for c in by_topic[s.state_topic]),
            wanted=wanted,
            listed=listed,
            path=source.path,
            sensor_ids=sensor_ids,
            tf_ids=tf_ids,
        )

    def run(self, reader: Any, target: Path, writer: Any, report: _Progress) -> _Result:
        """Read every message once, in time order; shape and write window by window."""
        total = int(getattr(reader, "message_count", 0) or 0)
        cmd_ids, state_ids = self.cmd_ids, self.state_ids
        sensor_ids, tf_ids = self.sensor_ids, self.tf_ids
        read_cmd, read_state = self.codec.read, self.read_state
        max_age = None if self.settings.max_state_age is None else self.settings.max_state_age
        acc = _Accumulator(self, max_age)
        step = max(total // 100, 1) if total else 2**62  # about every 1 %
        per_conn: dict[int, int] = dict.fromkeys((c.id for c in reader.connections), 0)
        topic = ""
        try:
            with writer:
                ts = reader.typestore
                out = {c.id: _add(writer, ts, c.topic, c) for c in reader.connections}
                cmd_conn = next(c for c in reader.connections if c.id in cmd_ids)
                shaped_conn = _add(writer, ts, self.settings.output, cmd_conn)
                window: list[tuple[Any, int, Any, int]] = []
                nbytes, last_t = 0, -(2**63)
                group: list[int] = []
                held: tuple[int, NDArray[np.float64]] | None = None
                read = 0
                try:
                    for conn, t, raw in reader.messages():
                        if t != last_t:
                            if t < last_t:
                                raise InvalidParameter(
                                    f"bag: messages not in time order ({conn.topic} at {t} ns "
                                    f"after {last_t} ns)"
                                )
                            if group:  # the commands of the last timestamp get their state
                                acc.hold(group, held)
                                group = []
                            if len(window) >= _WINDOW_MESSAGES or nbytes >= _WINDOW_BYTES:
                                acc.flush(window, writer, shaped_conn)
                                window, nbytes = [], 0
                            last_t = t
                        cid = conn.id
                        k = -1
                        if cid in state_ids:
                            topic = conn.topic
                            held = (t, read_state(raw))
                        elif cid in cmd_ids:
                            topic = conn.topic
                            v, token = read_cmd(raw)
                            k = acc.add(t, v, token)
                            group.append(k)
                        elif cid in sensor_ids:
                            acc.cloud(sensor_ids[cid], t, raw)
                        elif cid in tf_ids:
                            topic = conn.topic
                            acc.transforms(reader.deserialize(raw, conn.msgtype))
                        window.append((out[cid], t, raw, k))
                        nbytes += len(raw)
                        per_conn[cid] += 1
                        read += 1
                        if read % step == 0:
                            report(read / total)
                except CdrError as exc:
                    raise InvalidParameter(f"topic {topic}: malformed message ({exc})") from None
                acc.hold(group, held)
                counts: dict[str, int] = {}
                for c in reader.connections:
                    counts[c.topic] = counts.get(c.topic, 0) + per_conn[c.id]
                acc.states = sum(per_conn[i] for i in state_ids)
                acc.start_ns = int(reader.start_time) if read else 0
                self._check(reader, acc, counts)
                acc.flush(window, writer, shaped_conn)
        except BaseException:
            if target.is_dir():  # the directory this call created: no half-written bag left
                shutil.rmtree(target, ignore_errors=True)
            raise
        return acc.result()

    def _check(self, reader: Any, acc: _Accumulator, counts: Mapping[str, int]) -> None:
        s = self.settings
        why = None
        if not any(counts.values()):
            why = "no messages"
        elif not counts.get(s.command_topic):
            why = f"no message on {s.command_topic}"
        elif not counts.get(s.state_topic):
            why = f"no message on {s.state_topic}"
        elif acc.paired == 0:
            before = sum(1 for h in acc.held if h is None)
            why = (
                f"no command paired with a state: of {acc.count} commands, {before} came "
                "before the first state"
            )
            if s.max_state_age is not None:
                why += (
                    f" and {acc.count - before} had a state older than "
                    f"max_state_age={s.max_state_age} s"
                )
        if why is not None:
            raise NothingToReplay(
                f"nothing to replay in bag {self.path}: "
                f"{why}; {self.wanted}; {_holdings(reader, counts)}{_listed(self.listed)}"
            )


def _listed(listed: int | None) -> str:
    return "" if listed is None else f"; its metadata.yaml lists {listed} messages"


class _Accumulator:
    """The commands read so far, their held states, and the shaping of a window of them."""

    def __init__(self, job: _Job, max_age: float | None) -> None:
        cs = job.cs
        self.job = job
        self.max_age_ns = None if max_age is None else max_age * 1e9
        self.k = len(job.codec.components)
        self.n = cs.state_dim
        self.twist = cs.command_space == "twist"
        self.heading = job.settings.command_frame == "body"
        # A stateless shaper's batch call equals looping its shape (the Shaper contract); a
        # shaper with memory (rate limits, a filter's warm start) is called command by command.
        self.batch = not (hasattr(cs.shaper, "reset") or self.twist or self.heading)
        self.start_ns = 0
        self.states = 0
        self.messages = 0
        self.count = 0
        self.paired = 0
        self.zeroed = {"no_state": 0, "stale": 0, "invalid": 0}
        self.t: list[int] = []
        self.v: list[NDArray[np.float64]] = []
        self.tokens: list[Any] = []
        self.held: list[tuple[int, NDArray[np.float64]] | None] = []
        self.done = 0  # commands shaped and written
        self.parts: list[tuple[NDArray[Any], ...]] = []
        # range sensors: the bag's transforms so far, and the clouds (in the base frame's
        # terms) waiting to be fed to their PointCloudRows before the command they precede
        self.sensors = job.settings.sensors
        self.clouds = job.cs.clouds
        self.tf = TransformStore()
        self.events: list[tuple[int, int, Any, float, Any]] = []
        self.clouds_used = 0
        self.clouds_dropped: dict[str, int] = {}
        self.readings_dropped = 0

    def add(self, t: int, v: NDArray[np.float64], token: Any) -> int:
        self.t.append(t)
        self.v.append(v)
        self.tokens.append(token)
        self.held.append(None)
        self.count += 1
        return self.count - 1

    def transforms(self, msg: Any) -> None:
        """A ``/tf`` or ``/tf_static`` message: its transforms into the store (bad ones skipped)."""
        for ts in msg.transforms:
            tr = ts.transform
            r, x = tr.rotation, tr.translation
            try:
                self.tf.set(
                    ts.header.frame_id, ts.child_frame_id, (r.x, r.y, r.z, r.w), (x.x, x.y, x.z)
                )
            except VelfenceError:
                self._drop_cloud("bad_transform")

    def _drop_cloud(self, reason: str) -> None:
        self.clouds_dropped[reason] = self.clouds_dropped.get(reason, 0) + 1

    def cloud(self, i: int, t: int, raw: bytes) -> None:
        """A sensor message received at ``t`` [ns]: kept for the next command, or dropped."""
        msg = accept_sensor_message(raw, self.sensors[i], now=t * 1e-9, transforms=self.tf)
        sp = msg.points
        if sp is None:
            self._drop_cloud(msg.reason)
            return
        self.clouds_used += 1
        self.readings_dropped += sp.dropped
        self.events.append((self.count, i, sp.points, sp.stamp, msg.pose))

    def _feed(self, upto: int, now: float) -> None:
        """The clouds received before command ``upto``, then every grid aged to ``now`` [s]."""
        ev = self.events
        e = 0
        while e < len(ev) and ev[e][0] <= upto:
            _, i, pts, stamp, pose = ev[e]
            try:
                self.clouds[i].update(pts, stamp=stamp, transform=pose)
            except VelfenceError:  # a point beyond the finite range once transformed
                self.clouds_used -= 1
                self._drop_cloud("invalid")
            e += 1
        if e:
            del ev[:e]
        empty = np.zeros((0, 3))
        for rows in self.clouds:
            if rows.stamp is not None and now > rows.stamp:
                rows.update(empty, stamp=now)

    def hold(self, group: list[int], held: tuple[int, NDArray[np.float64]] | None) -> None:
        """The commands of one timestamp get the latest state at or before it."""
        for k in group:
            self.held[k] = held
            if held is not None and (
                self.max_age_ns is None or self.t[k] - held[0] <= self.max_age_ns
            ):
                self.paired += 1

    def flush(self, window: list[tuple[Any, int, Any, int]], writer: Any, shaped_conn: Any) -> None:
        """Shape the window's commands and write the window, each shaped command after its own."""
        lo, hi = self.done, self.count
        out = self._shape(lo, hi)
        codec = self.job.codec
        for conn, t, raw, k in window:
            writer.write(conn, t, raw)
            self.messages += 1
            if k >= 0:
                y, ang = out[k - lo]
                writer.write(shaped_conn, t, codec.write(raw, self.tokens[k], y, ang))
                self.messages += 1
        for k in range(lo, hi):  # done with their bytes
            self.tokens[k] = None
        self.done = hi

    def _shape(self, lo: int, hi: int) -> list[tuple[Any, Any]]:
        m, k, n = hi - lo, self.k, self.n
        V = np.array(self.v[lo:hi], dtype=float).reshape(m, k)
        width = n + 1 if self.heading else n
        P = np.zeros((m, width))
        has = np.zeros(m, dtype=bool)
        age_ok = np.ones(m, dtype=bool)
        times = np.array(self.t[lo:hi], dtype=np.int64)
        for i, h in enumerate(self.held[lo:hi]):
            if h is not None:
                has[i] = True
                P[i] = h[1]
                if self.max_age_ns is not None and times[i] - h[0] > self.max_age_ns:
                    age_ok[i] = False
        finite_v = np.asarray(np.isfinite(V).all(axis=1), dtype=bool)
        finite_p = np.asarray(np.isfinite(P).all(axis=1), dtype=bool)
        no_state = ~has
        stale = has & ~age_ok
        invalid = has & age_ok & ~(finite_v & finite_p)
        ok = has & age_ok & finite_v & finite_p
        self.zeroed["no_state"] += int(no_state.sum())
        self.zeroed["stale"] += int(stale.sum())
        self.zeroed["invalid"] += int(invalid.sum())
        commanded = np.where(np.isfinite(V), V, 0.0)
        positions = np.where(has[:, None] & finite_p[:, None], P[:, :n], 0.0)
        shaped = np.zeros((m, k))
        out: list[tuple[Any, Any]] = [(None, None)] * m
        rows = np.flatnonzero(ok)
        shaper = self.job.cs.shaper
        done = False
        if self.batch and rows.size:
            try:
                Y = np.asarray(shaper.shape_batch(P[rows, :n], V[rows]), dtype=float)
            except VelfenceError:
                pass  # row by row below: the rows the shaper refuses are zeroed
            else:
                shaped[rows] = Y
                for j, i in enumerate(rows.tolist()):
                    out[i] = (Y[j], None)
                done = True
        if not done:
            for i in range(m) if self.clouds else rows.tolist():
                if self.clouds:  # the clouds before this command, the grids aged to it
                    self._feed(lo + i, float(times[i]) * 1e-9)
                    if not ok[i]:
                        continue
                q, v = P[i, :n], V[i]
                try:
                    if self.heading:  # body frame -> the pose's frame: turn by the heading
                        v = body_to_world(v, P[i, n])
                    y = np.asarray(shaper.shape(q, v), dtype=float)
                    if self.heading:  # and back
                        y = world_to_body(y, P[i, n])
                except VelfenceError:
                    ok[i] = False
                    self.zeroed["invalid"] += 1
                    continue
                angular = None
                if self.twist:  # the TCP twist the shaped joint velocities give
                    robot = shaper.filter.robot
                    y, angular = robot.jacobian(q) @ y, robot.angular_jacobian(q) @ y
                shaped[i] = y
                out[i] = (y, angular)
        self.parts.append((times, commanded, shaped, positions, ok))
        return out

    def result(self) -> _Result:
        if self.parts:
            times, commanded, shaped, positions, ok = (
                np.concatenate(col) for col in zip(*self.parts, strict=True)
            )
        else:
            times = np.zeros(0, dtype=np.int64)
            commanded = shaped = np.zeros((0, self.k))
            positions = np.zeros((0, self.n))
            ok = np.zeros(0, dtype=bool)
        return _Result(
            times_ns=times,
            start_ns=self.start_ns,
            commanded=commanded,
            shaped=shaped,
            positions=positions,
            has_state=ok,
            zeroed=self.zeroed,
            states=self.states,
            messages=self.messages,
            clouds=(self.clouds_used, dict(self.clouds_dropped), self.readings_dropped),
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


def _summary(
    p: Path,
    target: Path,
    fmt: str,
    cs: ConfiguredShaper,
    settings: ReplaySettings,
    job: _Job,
    r: _Result,
) -> ReplaySummary:
    N = len(r.times_ns)
    diff = np.abs(r.commanded - r.shaped)
    changed = int(np.count_nonzero(np.any(diff > CHANGE_TOL, axis=1))) if N else 0
    fence = buffer = None
    acc_clouds = r.clouds
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
        command_type=job.command_type,
        state_type=job.state_type,
        components=job.codec.components,
        unit=job.codec.unit,
        commands=N,
        states=r.states,
        messages=r.messages,
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
        clouds_used=acc_clouds[0],
        clouds_dropped=acc_clouds[1],
        cloud_readings_dropped=acc_clouds[2],
    )


document_inits(globals())
