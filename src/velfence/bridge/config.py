"""The validated ``bridge:`` section of a bridge YAML file, checked against its ``shaper:``.

A bridge file holds two sections (``docs/bridge.md`` documents every field)::

    bridge:
      command_in: {topic: /cmd_vel_in, type: twist_stamped}
      command_out: {topic: /cmd_vel_out}            # type: same (default)
      state: {topic: /odom, type: odometry}
      command_frame: body                           # plane shapers: body or world
      incoming_command_timeout: 0.1                 # [s]
    shaper:
      kind: polygon
      corners: [[0, 0], [4, 0], [4, 3], [0, 3]]
      buffer: 0.5

Unknown keys are refused and every message names the field (``bridge.state.type: ...``); the
types of the topics are checked against what the shaper reads and writes (a joint shaper needs
joint states, a plane shaper a pose), before any DDS entity is created.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from velfence._extras import missing

try:
    from pydantic import Field, Strict, ValidationError, field_validator
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence._docs import document_inits
from velfence.errors import InvalidParameter
from velfence.io.config import StrictModel, describe_validation_error
from velfence.io.shaper_config import ConfiguredShaper, SensorTopic, load_yaml, parse_shaper
from velfence.io.yaml_reader import file_path

__all__ = [
    "COMMAND_TYPES",
    "OUTPUT_TYPES",
    "QOS_PROFILES",
    "STATE_TYPES",
    "BridgeConfig",
    "BridgeSettings",
    "dds_topic",
    "load_bridge_config",
    "parse_bridge_config",
]

#: Message types a command may arrive in (``bridge.command_in.type``).
COMMAND_TYPES: tuple[str, ...] = ("twist", "twist_stamped", "joint_jog", "float64_multi_array")
#: Message types the shaped command may leave in (``bridge.command_out.type``).
OUTPUT_TYPES: tuple[str, ...] = ("same", *COMMAND_TYPES, "joint_trajectory")
#: Message types of the state (``bridge.state.type``).
STATE_TYPES: tuple[str, ...] = ("joint_state", "pose_stamped", "odometry")
#: The ROS 2 QoS profiles a topic may use (``qos.profile``).
QOS_PROFILES: tuple[str, ...] = ("default", "sensor_data", "system_default")

#: Longest accepted topic name (ROS 2 caps a fully qualified name at 255 characters).
MAX_TOPIC_LENGTH = 255
#: Largest accepted history depth of a topic.
MAX_DEPTH = 100_000

Seconds = Annotated[float, Strict(), Field(gt=0.0, le=3600.0, allow_inf_nan=False)]
TopicName = Annotated[str, Strict(), Field(min_length=1, max_length=MAX_TOPIC_LENGTH)]
#: A ROS 2 node name: letters, digits and _, not starting with a digit (rmw_validate_node_name).
NodeName = Annotated[
    str, Strict(), Field(min_length=1, max_length=200, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")
]


def _check_topic(name: str) -> str:
    body = name.removeprefix("/")
    parts = body.split("/")
    ok = bool(body) and all(
        p and (p[0].isalpha() or p[0] == "_") and all(c.isalnum() or c == "_" for c in p)
        for p in parts
    )
    if not ok:
        raise ValueError(
            f"expected a ROS 2 topic name (letters, digits, _ and /, each part starting with a "
            f"letter or _), got {name!r}"
        )
    return name


class QosSettings(StrictModel):
    """A topic's QoS: a ROS 2 profile, optionally with its depth, reliability or durability."""

    profile: Literal["default", "sensor_data", "system_default"] = "default"
    depth: Annotated[int, Strict(), Field(ge=1, le=MAX_DEPTH)] | None = None
    reliability: Literal["reliable", "best_effort"] | None = None
    durability: Literal["volatile", "transient_local"] | None = None


class _Topic(StrictModel):
    @field_validator("topic", check_fields=False)
    @classmethod
    def _topic_name(cls, value: str) -> str:
        return _check_topic(value)

    @field_validator("qos", mode="before", check_fields=False)
    @classmethod
    def _qos_shorthand(cls, value: Any) -> Any:
        return {"profile": value} if isinstance(value, str) else value


class CommandIn(_Topic):
    """The incoming command topic."""

    topic: TopicName = "cmd_vel_in"
    type: Literal["twist", "twist_stamped", "joint_jog", "float64_multi_array"] = "twist_stamped"
    qos: QosSettings = QosSettings()


class CommandOut(_Topic):
    """The shaped command topic."""

    topic: TopicName = "cmd_vel_out"
    type: Literal[
        "same", "twist", "twist_stamped", "joint_jog", "float64_multi_array", "joint_trajectory"
    ] = "same"
    qos: QosSettings = QosSettings()


class StateIn(_Topic):
    """The state topic (joint positions, or a pose)."""

    topic: TopicName = "joint_states"
    type: Literal["joint_state", "pose_stamped", "odometry"] = "joint_state"
    qos: QosSettings = QosSettings(profile="sensor_data")
    joint_names: (
        Annotated[list[Annotated[str, Strict(), Field(min_length=1)]], Field(min_length=1)] | None
    ) = None


class SensorIn(SensorTopic, _Topic):
    """A range sensor's topic (``bridge.sensors``): a PointCloud2 or LaserScan feeding the filter.

    The fields of :class:`~velfence.io.shaper_config.SensorTopic`, and the topic's ``qos``
    (default ``sensor_data``, what camera and lidar drivers publish with).
    """

    qos: QosSettings = QosSettings(profile="sensor_data")


class DiagnosticsOut(_Topic):
    """The diagnostics topic (``diagnostic_msgs/DiagnosticArray``), rate-limited."""

    enabled: Annotated[bool, Strict()] = True
    topic: TopicName = "/diagnostics"
    period: Seconds = 1.0
    name: Annotated[str, Strict(), Field(min_length=1, max_length=200)] = "velfence_bridge"
    qos: QosSettings = QosSettings()


FrameId = Annotated[str, Strict(), Field(min_length=1, max_length=MAX_TOPIC_LENGTH)]


class TfIn(StrictModel):
    """The transform topics read when ``command_frame_id`` is set (``tf2_msgs/TFMessage``)."""

    topic: TopicName = "/tf"
    static_topic: TopicName = "/tf_static"
    qos: QosSettings = QosSettings(profile="default", depth=100)
    static_qos: QosSettings = QosSettings(
        profile="default", depth=100, durability="transient_local"
    )

    @field_validator("topic", "static_topic")
    @classmethod
    def _topic_name(cls, value: str) -> str:
        return _check_topic(value)

    @field_validator("qos", "static_qos", mode="before")
    @classmethod
    def _qos_shorthand(cls, value: Any) -> Any:
        return {"profile": value} if isinstance(value, str) else value


class BridgeSettings(StrictModel):
    """The ``bridge:`` section (every field documented in ``docs/bridge.md``).

    Times are in seconds; ``domain_id`` null means ``ROS_DOMAIN_ID`` from the environment (or 0).
    """

    domain_id: Annotated[int, Strict(), Field(ge=0, le=232)] | None = None
    namespace: Annotated[str, Strict(), Field(max_length=MAX_TOPIC_LENGTH)] = ""
    command_in: CommandIn = CommandIn()
    command_out: CommandOut = CommandOut()
    state: StateIn = StateIn()
    diagnostics: DiagnosticsOut = DiagnosticsOut()
    #: Range sensors (point clouds, laser scans) whose points a safety filter keeps the arm
    #: out of: one PointCloudRows each (docs/point_clouds.md, "From ROS messages").
    sensors: Annotated[list[SensorIn], Field(default_factory=list, max_length=16)]
    command_frame: Literal["world", "body"] | None = None
    incoming_command_timeout: Seconds = 0.1
    state_timeout: Seconds = 0.5
    watchdog_period: Seconds = 0.05
    # ---- ROS conventions: output timing, halting, command frames (docs/bridge.md) ----
    #: Publish on the node's own timer with this period [s] (MoveIt Servo's and Nav2 velocity
    #: smoother's ``publish_period``): each period the last command is shaped against the
    #: newest state. None: one answer per command.
    publish_period: Seconds | None = None
    #: Zero commands published once commands go stale, then silence until they resume (MoveIt
    #: Servo's former ``num_outgoing_halt_msgs_to_publish``, default 4). None: zeros forever.
    halt_messages: Annotated[int, Strict(), Field(ge=1, le=1_000_000)] | None = 4
    #: The frame stamped commands are shaped in; a TwistStamped in another frame is rotated
    #: into it through /tf and /tf_static (refused if no transform is known). None: the
    #: header's frame is not looked at.
    command_frame_id: FrameId | None = None
    tf: TfIn = TfIn()
    # ---- end of ROS conventions ----
    # --- The node in the ROS 2 graph (velfence.bridge.graph): its name in `ros2 node list`,
    # the distro whose discovery layout it speaks, managed-node lifecycle, log lines on /rosout.
    node_name: NodeName = "velfence_bridge"
    ros_distro: Literal["jazzy", "humble"] = "jazzy"
    lifecycle: Annotated[bool, Strict()] = False
    rosout: Annotated[bool, Strict()] = True
    # Nav2 bond (velfence.bridge.bond): heartbeat period [s] of the node's side while active
    # (Nav2's node parameter of the same name and default); 0 disables the bond.
    bond_heartbeat_period: Annotated[
        float, Strict(), Field(ge=0.0, le=3600.0, allow_inf_nan=False)
    ] = 0.25

    @field_validator("namespace")
    @classmethod
    def _namespace(cls, value: str) -> str:
        return value if value in ("", "/") else _check_topic(value)


@dataclass(frozen=True, eq=False)
class BridgeConfig:
    """A validated bridge file: the ``bridge:`` settings and the configured shaper.

    Attributes:
        settings: The ``bridge:`` section.
        shaper: The ``shaper:`` section's shaper and what it reads and writes.
        output_type: ``command_out.type`` with ``same`` resolved to the input's type.
        joint_names: The names of the joints on the topics, in the shaper's order:
            ``state.joint_names`` when given (the robot's names, which may differ from the
            shaper's, e.g. ``fr3_joint1``), else the shaper's own; None for a point state.
        domain_id: The DDS domain the bridge joins.
        dds_topics: The DDS topic names (``rt/...``) of ``command_in``, ``command_out``,
            ``state`` and ``diagnostics``, and ``sensor<i>`` of each of ``sensors``.
        source: Where the configuration came from (file name, or ``"config"``).
    """

    settings: BridgeSettings
    shaper: ConfiguredShaper
    output_type: str
    joint_names: tuple[str, ...] | None
    domain_id: int
    dds_topics: dict[str, str]
    source: str = "config"


def dds_topic(settings: BridgeSettings, name: str) -> str:
    """The DDS topic of a ROS 2 topic name: ``rt/`` + namespace + name (absolute names keep theirs).

    Args:
        settings: The ``bridge:`` section (its ``namespace``).
        name: A ROS 2 topic name; absolute (``/cmd_vel``) or relative to the namespace.

    Returns:
        The DDS topic name (``"rt/ns/cmd_vel"``).
    """
    if name.startswith("/"):
        return "rt" + name
    ns = settings.namespace.strip("/")
    return f"rt/{ns}/{name}" if ns else f"rt/{name}"


def _domain_from_env() -> int:
    raw = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not raw:
        return 0
    if not raw.isdigit() or int(raw) > 232:
        raise InvalidParameter(f"ROS_DOMAIN_ID: expected an integer 0..232, got {raw[:20]!r}")
    return int(raw)


def _check_fit(
    s: BridgeSettings, cs: ConfiguredShaper, where: str
) -> tuple[str, tuple[str, ...] | None]:
    """Whether the topics' types fit the shaper; the resolved output type and joint names."""
    space, cin, st = cs.command_space, s.command_in.type, s.state.type
    twists = ("twist", "twist_stamped")
    out = cin if s.command_out.type == "same" else s.command_out.type
    names = cs.joint_names
    if names is None and s.state.joint_names is not None:
        names = tuple(s.state.joint_names)
        if len(names) != cs.state_dim:
            raise InvalidParameter(
                f"{where}bridge.state.joint_names: the shaper reads {cs.state_dim} values, got "
                f"{len(names)} names"
            )
    elif cs.joint_names is not None and s.state.joint_names is not None:
        # The robot's names of the shaper's joints, in the shaper's order (an FR3's fr3_joint1…,
        # a prefixed UR's left_shoulder_pan_joint…): the topics use these names.
        names = tuple(s.state.joint_names)
        if len(names) != len(cs.joint_names):
            raise InvalidParameter(
                f"{where}bridge.state.joint_names: the robot's names of the shaper's joints "
                f"{list(cs.joint_names)}, in that order: expected {len(cs.joint_names)} names, "
                f"got {len(names)}"
            )
    if names is not None and len(set(names)) != len(names):
        repeated = sorted({n for n in names if names.count(n) > 1})
        raise InvalidParameter(
            f"{where}bridge.state.joint_names: expected distinct names, {repeated} repeated"
        )

    def bad(field: str, msg: str) -> InvalidParameter:
        return InvalidParameter(f"{where}bridge.{field}: {msg} (shaper kind {cs.kind!r})")

    # The command.
    if cin in twists and not (
        space in ("plane", "twist") or (space == "workspace" and cs.command_dim <= 3)
    ):
        raise bad(
            "command_in.type",
            f"a {cin} carries a 3-D linear velocity, the shaper reads "
            f"{cs.command_dim} {space} velocities; use joint_jog or float64_multi_array",
        )
    if cin == "joint_jog" and names is None:
        raise bad("command_in.type", "joint_jog needs joint names; give state.joint_names")
    if cin == "joint_jog" and space not in ("joint", "workspace"):
        raise bad("command_in.type", f"joint_jog does not fit a {space} command")
    # The state.
    if st == "joint_state" and names is None:
        raise bad("state.type", "joint_state needs joint names; give state.joint_names")
    if st in ("pose_stamped", "odometry") and (space in ("joint", "twist") or cs.state_dim > 3):
        raise bad(
            "state.type",
            f"a pose gives x, y, z; the shaper reads {cs.state_dim} "
            f"{'joint positions' if space in ('joint', 'twist') else 'values'}; use joint_state",
        )
    # The output.
    if out in twists and not (space == "plane" or (space == "workspace" and cs.output_dim <= 3)):
        raise bad(
            "command_out.type",
            f"the shaped command is {cs.output_dim} "
            f"{'joint velocities' if space in ('joint', 'twist') else 'values'}, no twist; "
            "use float64_multi_array, joint_trajectory or joint_jog",
        )
    if out in ("joint_jog", "joint_trajectory") and names is None:
        raise bad("command_out.type", f"{out} needs joint names; give state.joint_names")
    if out == "joint_trajectory" and (st != "joint_state" or cs.state_dim != cs.output_dim):
        raise bad(
            "command_out.type",
            "joint_trajectory integrates positions from the measured joints: it needs a "
            "joint_state state with one position per output velocity",
        )
    if s.command_frame_id is not None and cin != "twist_stamped":
        raise bad(
            "command_frame_id",
            f"only a twist_stamped command carries a frame to resolve, not a {cin}; leave it out",
        )
    # The frame of a twist.
    frame = s.command_frame
    if space == "plane" and cin in twists and frame is None:
        raise bad(
            "command_frame",
            "required for a plane shaper fed twists: body (a mobile "
            "base's cmd_vel, rotated by the pose's yaw) or world (already in the pose's frame)",
        )
    if frame == "body" and not (space == "plane" and st in ("pose_stamped", "odometry")):
        raise bad(
            "command_frame",
            "body needs a plane shaper and a pose state (pose_stamped or "
            "odometry); use world or leave it out",
        )
    return out, names


def parse_bridge_config(
    document: Any, *, source: str = "config", base_dir: str | Path | None = None
) -> BridgeConfig:
    """Validate a bridge document (the mapping of a bridge YAML file).

    Args:
        document: A mapping with a ``bridge:`` and a ``shaper:`` section.
        source: How the document is named in messages (the file name).
        base_dir: The folder a relative ``shaper.zone`` file path is read from (the config
            file's folder; :func:`load_bridge_config` passes it); ``None`` (default): the
            current directory.

    Returns:
        The validated configuration, with the shaper built.

    Raises:
        InvalidParameter: a missing or unknown section or key, a bad value (named
            ``bridge.<field>`` or ``shaper.<field>``), or topics whose types do not fit the
            shaper (a joint shaper fed twists).
    """
    if not isinstance(source, str) or not source or len(source) > 500 or "\n" in source:
        raise InvalidParameter("source: expected a short one-line name")
    where = f"{source}: "
    if not isinstance(document, dict):
        raise InvalidParameter(
            f"document: {where}expected a mapping with 'bridge' and 'shaper' sections, got "
            f"{type(document).__name__}"
        )
    extra = sorted(str(k) for k in document if k not in ("bridge", "shaper"))
    if extra:
        raise InvalidParameter(
            f"{where}unknown section(s) {extra} in the document; a bridge file holds 'bridge' "
            "and 'shaper'"
        )
    if "shaper" not in document:
        raise InvalidParameter(f"{where}the 'shaper' section is missing from the document")
    bridge = document.get("bridge")
    if bridge is None:
        bridge = {}
    if not isinstance(bridge, dict):
        raise InvalidParameter(
            f"{where}bridge: expected a mapping of fields, got {type(bridge).__name__}"
        )
    odd = [k for k in bridge if not isinstance(k, str)]
    if odd:
        raise InvalidParameter(f"{where}bridge: expected string keys, got {odd[0]!r}")
    try:
        settings = BridgeSettings.model_validate(bridge)
    except ValidationError as err:
        text = describe_validation_error(err, BridgeSettings)
        raise InvalidParameter(f"{where}bridge.{text}") from None
    if settings.sensors and document["shaper"] is not None:
        kind = document["shaper"].get("kind") if isinstance(document["shaper"], dict) else None
        if kind != "safety_filter":
            raise InvalidParameter(
                f"{where}bridge.sensors: range sensors feed a safety filter's obstacle rows; "
                f"the shaper is {str(kind)[:40]!r} (use kind: safety_filter, or no sensors)"
            )
    cs = parse_shaper(
        document["shaper"],
        where=f"{source}: shaper",
        sensors=settings.sensors,
        base_dir=base_dir,
    )
    out, names = _check_fit(settings, cs, where)
    domain = settings.domain_id if settings.domain_id is not None else _domain_from_env()
    topics = {
        key: dds_topic(settings, getattr(settings, key).topic)
        for key in ("command_in", "command_out", "state", "diagnostics")
    }
    topics.update(
        {f"sensor{i}": dds_topic(settings, x.topic) for i, x in enumerate(settings.sensors)}
    )
    return BridgeConfig(settings, cs, out, names, domain, topics, source)


def load_bridge_config(path: str | Path) -> BridgeConfig:
    """Load and validate a bridge YAML file (``bridge:`` + ``shaper:``; ``docs/bridge.md``).

    Args:
        path: The YAML file (read by the narrow reader of :func:`velfence.io.load_yaml`).

    Returns:
        The validated configuration, with the shaper built.

    Raises:
        InvalidParameter: the file cannot be read or is not plain YAML, or a field is invalid
            (the message names the file and the field).
    """
    doc = load_yaml(path)
    return parse_bridge_config(doc, source=f"config file {path}", base_dir=file_path(path).parent)


document_inits(globals())
