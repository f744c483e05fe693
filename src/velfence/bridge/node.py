"""The bridge node: a ROS 2 DDS participant that shapes every command it forwards.

One loop thread waits on the command and state readers (a Cyclone DDS wait set) and answers
each valid command sample with exactly one shaped command, in order; or, with
``publish_period``, publishes on its own timer the last command shaped against the newest state.
Fail-safes:

* a command older than ``incoming_command_timeout`` → a zero command, repeated every
  ``watchdog_period`` (every ``publish_period`` on the timer), ``halt_messages`` times, then
  silence until a fresh command arrives (``halt_messages`` None: zeros until then);
* no state yet, or state older than ``state_timeout`` → every command is answered with zero;
* a malformed message (wrong length, unknown, duplicate or missing joint names, non-finite
  numbers, an undecodable sample, a frame no transform reaches) is dropped alone and counted,
  never applied; the valid samples taken with it are answered;
* a range sensor's message (``sensors``: PointCloud2, LaserScan) that is malformed, stale
  (older than its ``max_age``) or in a frame no transform reaches is dropped and counted
  (``dropped:cloud_<reason>``, a warning at most every 10 s per reason); its points never
  reach the filter;
* nothing non-finite is ever written: every outgoing vector is checked before the write;
* on stop (SIGINT/SIGTERM in ``velfence bridge``) a last zero command is sent if any command
  was forwarded.

One log line per change of the node's state (``waiting_for_state`` → ``waiting_for_command`` →
``running`` → ``stale_command`` → ...), and per QoS mismatch (a reader or writer that cannot
match a peer because of incompatible QoS). A diagnostics topic reports the zone, the active
constraints, whether and how much the last command was changed, the counters and the watchdog.
"""

from __future__ import annotations

import contextlib
import logging
import math
import signal
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._validate import check_range
from velfence.bridge import msgs
from velfence.bridge.config import BridgeConfig, QosSettings, dds_topic
from velfence.bridge.transforms import TransformStore
from velfence.bridge.typehash import user_data
from velfence.errors import InvalidParameter, StartedInViolation, VelfenceError
from velfence.geometry.frames import body_to_world, world_to_body
from velfence.io.sensors import accept_sensor_message

__all__ = [
    "EXIT_CONFIG",
    "EXIT_DDS",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "NODE_STATES",
    "BridgeNode",
    "CycleInfo",
    "DDSFailure",
    "ros_qos",
    "serve",
]

#: Exit code of ``velfence bridge``: a clean stop (SIGINT, SIGTERM or ``--duration``).
EXIT_OK = 0
#: Exit code: the configuration file is missing or invalid (the message names the field).
EXIT_CONFIG = 2
#: Exit code: DDS could not be started (participant, topic, reader or writer creation failed).
EXIT_DDS = 3
#: Exit code: an unexpected internal error (a bug; the traceback is logged).
EXIT_INTERNAL = 4
#: Exit code: Ctrl-C (SIGINT) before the node was running, during start-up (128 + SIGINT, the
#: shell's convention); once the node runs, SIGINT is a clean stop (:data:`EXIT_OK`).
EXIT_INTERRUPTED = 130

#: The states of the node, in the order a normal start passes through them.
NODE_STATES: tuple[str, ...] = (
    "starting",
    "waiting_for_state",
    "waiting_for_command",
    "running",
    "stale_command",
    "stale_state",
    "stopped",
)

#: The QoS policy ids a mismatch report names: Cyclone DDS's ``dds_qos_policy_id_t``
#: (``dds/ddsc/dds_public_qosdefs.h``, the same in 0.10 and 11.0), which is what the status's
#: ``last_policy_id`` holds. They follow the DDS specification's ids up to 22 and differ from
#: 23 on (Cyclone puts its PROPERTY policy at 23), so a DATA_REPRESENTATION mismatch is 25 here
#: and 23 in the specification.
_POLICY_NAMES = {
    0: "INVALID",
    1: "USER_DATA",
    2: "DURABILITY",
    3: "PRESENTATION",
    4: "DEADLINE",
    5: "LATENCY_BUDGET",
    6: "OWNERSHIP",
    7: "OWNERSHIP_STRENGTH",
    8: "LIVELINESS",
    9: "TIME_BASED_FILTER",
    10: "PARTITION",
    11: "RELIABILITY",
    12: "DESTINATION_ORDER",
    13: "HISTORY",
    14: "RESOURCE_LIMITS",
    15: "ENTITY_FACTORY",
    16: "WRITER_DATA_LIFECYCLE",
    17: "READER_DATA_LIFECYCLE",
    18: "TOPIC_DATA",
    19: "GROUP_DATA",
    20: "TRANSPORT_PRIORITY",
    21: "LIFESPAN",
    22: "DURABILITY_SERVICE",
    23: "PROPERTY",
    24: "TYPE_CONSISTENCY_ENFORCEMENT",
    25: "DATA_REPRESENTATION",
}

_TYPES: dict[str, type[Any]] = {
    "twist": msgs.Twist,
    "twist_stamped": msgs.TwistStamped,
    "joint_jog": msgs.JointJog,
    "float64_multi_array": msgs.Float64MultiArray,
    "joint_trajectory": msgs.JointTrajectory,
    "joint_state": msgs.JointState,
    "pose_stamped": msgs.PoseStamped,
    "odometry": msgs.Odometry,
}
_TWISTS = ("twist", "twist_stamped")
#: Samples taken from a reader per call.
_TAKE = 256
#: Longest wait [s] of the loop before it looks at the clock again.
_MAX_WAIT = 0.1


class DDSFailure(VelfenceError, RuntimeError):
    """DDS could not be started or failed while running (``velfence bridge`` exits with 3)."""


@dataclass(frozen=True, eq=False)
class CycleInfo:
    """What one published command was made of (passed to ``on_cycle``).

    Attributes:
        t: ``time.monotonic()`` at the write [s].
        state: The state the shaper read (a copy), or None when there was none (fail-safe).
        command: The command as received (a copy, in the shaper's order), or None for a
            watchdog zero.
        shaped: What was published (a copy): the shaped command, or zeros.
        zone: The shaper's zone (``"free"``, ``"buffer"``, ``"outside"`` ...) or ``"held"``
            when a fail-safe zero was sent.
        active: Names of the active constraints (facets, edges, joint limits).
        node_state: The node's state (one of :data:`NODE_STATES`).
        changed: Whether the published command differs from the received one.
    """

    t: float
    state: np.ndarray | None
    command: np.ndarray | None
    shaped: np.ndarray
    zone: str
    active: tuple[str, ...]
    node_state: str
    changed: bool


def ros_qos(settings: QosSettings, msg_type: type) -> Any:
    """The Cyclone DDS QoS of a ROS 2 reader or writer, with the type hash in its USER_DATA.

    Profiles as in ``rmw_qos_profiles.h``: ``default`` reliable, keep-last 10, volatile;
    ``sensor_data`` best effort, keep-last 5, volatile; ``system_default`` the DDS defaults. The
    data representation is XCDR1 (plain CDR), the one ROS 2 uses.

    Args:
        settings: The topic's ``qos`` settings (profile and overrides).
        msg_type: The message class (its RIHS01 hash goes into USER_DATA).

    Returns:
        A ``cyclonedds.core.Qos``.

    Raises:
        InvalidParameter: ``settings`` is no QosSettings or ``msg_type`` no message class.
    """
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    if not isinstance(settings, QosSettings):
        raise InvalidParameter(f"settings: expected QosSettings, got {type(settings).__name__}")
    policies: list[Any] = [
        Policy.Userdata(user_data(msg_type)),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    ]
    reliable = Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100))
    depth = settings.depth
    if settings.profile == "default":
        policies += [reliable, Policy.History.KeepLast(depth or 10), Policy.Durability.Volatile]
    elif settings.profile == "sensor_data":
        policies += [
            Policy.Reliability.BestEffort,
            Policy.History.KeepLast(depth or 5),
            Policy.Durability.Volatile,
        ]
    elif depth is not None:
        policies.append(Policy.History.KeepLast(depth))
    if settings.reliability == "reliable":
        policies.append(reliable)
    elif settings.reliability == "best_effort":
        policies.append(Policy.Reliability.BestEffort)
    if settings.durability == "volatile":
        policies.append(Policy.Durability.Volatile)
    elif settings.durability == "transient_local":
        policies.append(Policy.Durability.TransientLocal)
    by_scope = {p.__scope__: p for p in policies}  # a later override replaces the profile's
    return Qos(*by_scope.values())


def _history_depth(settings: QosSettings) -> int | None:
    """The KEEP_LAST depth :func:`ros_qos` gives a reader (None: the DDS default, keep-last 1)."""
    if settings.depth is not None:
        return settings.depth
    return {"default": 10, "sensor_data": 5}.get(settings.profile, 1)


def _take_serialized(reader: Any, n: int) -> list[tuple[bytes, Any]]:
    """Up to ``n`` samples of ``reader`` as (CDR bytes, SampleInfo) pairs, not decoded.

    The call ``DataReader.take`` makes before decoding (cyclonedds 0.10 and 11.0); a failed take
    raises.
    """
    from cyclonedds._clayer import ddspy_take  # type: ignore[import-not-found]
    from cyclonedds.core import InstanceState, SampleState, ViewState

    mask = SampleState.Any | ViewState.Any | InstanceState.Any
    ret = ddspy_take(reader._ref, mask, n)
    if isinstance(ret, int):
        raise RuntimeError(f"dds_take failed ({ret})")
    return list(ret)


def _finite(values: Any) -> bool:
    return all(math.isfinite(x) for x in values)


def _yaw(q: Any) -> float | None:
    x, y, z, w = float(q.x), float(q.y), float(q.z), float(q.w)
    n = x * x + y * y + z * z + w * w
    if not math.isfinite(n) or n < 1e-12:
        return None
    return math.atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)


def _stamp_now() -> msgs.Time:
    ns = time.time_ns()
    return msgs.Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class BridgeNode:
    """A DDS participant that forwards shaped commands (``docs/bridge.md``).

    Create it with a validated configuration, then call :meth:`run` (it blocks; from another
    thread or a signal handler, :meth:`stop` ends it). Nothing touches DDS before :meth:`run`.

    Args:
        config: The validated configuration (:func:`velfence.bridge.load_bridge_config`).
        on_cycle: Called after every published command with a :class:`CycleInfo` (for a live
            view); an exception it raises is logged once and counted, never stops the node.
        logger: Where the state changes and mismatches are logged (default
            ``logging.getLogger("velfence.bridge")``).

    Raises:
        InvalidParameter: ``config`` is no BridgeConfig, ``on_cycle`` is not callable.
    """

    def __init__(
        self,
        config: BridgeConfig,
        *,
        on_cycle: Callable[[CycleInfo], None] | None = None,
        logger: logging.Logger | None = None,
    ) -> None:
        if not isinstance(config, BridgeConfig):
            raise InvalidParameter(
                f"config: expected a BridgeConfig (velfence.bridge.load_bridge_config), got "
                f"{type(config).__name__}"
            )
        _check_on_cycle(on_cycle)
        if logger is not None and not isinstance(logger, logging.Logger):
            raise InvalidParameter(
                f"logger: expected a logging.Logger or None, got {type(logger).__name__}"
            )
        self.config = config
        self._on_cycle = on_cycle
        self._log = logger or logging.getLogger("velfence.bridge")
        s = config.settings
        cs = config.shaper
        self._cs = cs
        self._in_type = s.command_in.type
        self._out_type = config.output_type
        self._state_type = s.state.type
        self._names = config.joint_names
        self._index = {n: i for i, n in enumerate(self._names)} if self._names else {}
        self._body = s.command_frame == "body"
        self._cmd_timeout = float(s.incoming_command_timeout)
        self._state_timeout = float(s.state_timeout)
        self._zero_period = float(s.watchdog_period)
        self._diag_period = float(s.diagnostics.period)
        self._stop = threading.Event()
        self._ready = threading.Event()
        self._lock = threading.Lock()
        self._events: list[str] = []
        self._qos_reports: list[str] = []
        self._counters: dict[str, int] = dict.fromkeys(
            (
                "commands_received",
                "commands_shaped",
                "commands_changed",
                "commands_held",
                "outputs_published",
                "watchdog_zeros",
                "states_received",
                "transforms_received",
                "dropped_transforms",
                "clouds_received",
                "clouds_used",
                "dropped_clouds",
                "cloud_readings_dropped",
                "dropped_commands",
                "dropped_states",
                "dropped_outputs",
                "qos_incompatible",
                "on_cycle_errors",
                "diagnostics_published",
                # Loss a reader can see (docs/bridge.md, "Lost samples"): Cyclone's SAMPLE_LOST
                # and SAMPLE_REJECTED statuses, and takes that found the history full (samples
                # may have been overwritten before them; how many, DDS does not say).
                "command_samples_lost",
                "command_samples_rejected",
                "command_history_full",
                "state_samples_lost",
                "state_samples_rejected",
                "state_history_full",
            ),
            0,
        )
        self._drops: dict[str, int] = {}
        self._depths = {
            "command": _history_depth(s.command_in.qos),
            "state": _history_depth(s.state.qos),
        }
        self._node_state = "starting"
        self._state: np.ndarray | None = None
        self._state_yaw = 0.0
        self._state_time: float | None = None
        self._cmd_time: float | None = None
        self._next_zero = 0.0
        self._published_any = False
        # ROS conventions (docs/bridge.md): the own timer, halting, the last command.
        self._period = None if s.publish_period is None else float(s.publish_period)
        self._halt_n = s.halt_messages
        self._halts_sent = 0
        self._next_pub = 0.0
        self._last_cmd: tuple[Any, np.ndarray] | None = None
        # Command frames through /tf (None: the header's frame is not looked at).
        self._frame_id = (
            None if s.command_frame_id is None else s.command_frame_id.removeprefix("/")
        )
        self._tf = TransformStore()
        self._tf_readers: dict[str, Any] = {}
        # Range sensors (docs/point_clouds.md): one reader and one PointCloudRows each.
        self._sensors = list(s.sensors)
        self._clouds = list(cs.clouds)
        self._sensor_readers: list[Any] = []
        self._cloud_warned: dict[str, float] = {}
        self._cmd_rotation: tuple[Any, np.ndarray] | None = None  # (message, R into the frame)
        self._reader_types: dict[str, type[Any]] = {
            "command": _TYPES[self._in_type],
            "state": _TYPES[self._state_type],
            "transform": msgs.TFMessage,
        }
        self._last: dict[str, Any] = {"zone": "none", "active": (), "changed": False, "delta": 0.0}
        self._guard: Any = None
        self._participant: Any = None
        # --- ROS 2 graph hook (velfence.bridge.graph): discovery, parameters, lifecycle, /rosout
        self._graph: Any = None
        self._active = not s.lifecycle  # a managed node publishes nothing until activated

    # ---------------------------------------------------------------- public, thread-safe
    @property
    def node_state(self) -> str:
        """The node's state (one of :data:`NODE_STATES`)."""
        return self._node_state

    @property
    def counters(self) -> dict[str, int]:
        """A copy of the counters, with the drops by reason as ``dropped:<reason>``."""
        with self._lock:
            out = dict(self._counters)
            out.update({f"dropped:{k}": v for k, v in self._drops.items()})
        return out

    def wait_ready(self, timeout: float) -> bool:
        """Block until the DDS entities exist (or ``timeout`` [s] passes).

        Args:
            timeout: Longest wait [s], ``0 <= timeout <= 3600``.

        Returns:
            Whether the node is ready (its readers and writers are created).

        Raises:
            InvalidParameter: ``timeout`` is not a finite number in range.
        """
        t = check_range("timeout", timeout, low=0.0, high=3600.0, unit="s")
        return self._ready.wait(t)

    def stop(self) -> None:
        """Ask :meth:`run` to return (safe from another thread or a signal handler)."""
        self._stop.set()
        guard = self._guard
        if guard is not None:
            with contextlib.suppress(Exception):
                guard.set(True)

    def run(self, *, duration: float | None = None) -> int:
        """Create the participant, readers and writers, and forward commands until stopped.

        Args:
            duration: Stop by itself after this many seconds (``0 < duration <= 10⁶``); None
                runs until :meth:`stop`.

        Returns:
            :data:`EXIT_OK` after a clean stop.

        Raises:
            InvalidParameter: a bad ``duration``, or a node that has already run.
            DDSFailure: a DDS entity could not be created (a bad domain, no network interface).
        """
        _check_duration(duration)
        if self._node_state != "starting":
            raise InvalidParameter("run: a BridgeNode runs once; create a new one")
        # The first call of a shaper may import or compile (numba) for seconds: do it now, before
        # the readers exist, never in the first control cycle with commands queueing behind it.
        self._warm_up()
        try:
            self._open()
        except VelfenceError:
            self._close()
            raise
        except Exception as exc:  # cyclonedds raises DDSException (and ctypes errors)
            self._close()
            raise DDSFailure(f"DDS could not be started: {exc}") from None
        end = None if duration is None else time.monotonic() + float(duration)  # checked above
        try:
            self._set_state("waiting_for_state")
            self._loop(end)
            if self._published_any and not self._halted():
                self._publish_zero(time.monotonic(), reason="stop")
        finally:
            self._set_state("stopped")
            self._close()
        return EXIT_OK

    def _warm_up(self) -> None:
        """One throw-away call of the shaper (then reset: a stateful shaper forgets it)."""
        cs = self._cs
        # A state the shaper refuses (VelfenceError) is fine: its code paths were still loaded.
        # The zero state is no robot's: a safety filter's start warning there would be false (a
        # joint range may exclude 0), and the reset below re-arms it for the first real state.
        with contextlib.suppress(VelfenceError), warnings.catch_warnings():
            warnings.simplefilter("ignore", StartedInViolation)
            cs.shaper.explain(np.zeros(cs.state_dim), np.zeros(cs.command_dim))
        reset = getattr(cs.shaper, "reset", None)
        if callable(reset):
            reset()

    # ---------------------------------------------------------------- DDS set-up
    def _open(self) -> None:
        from cyclonedds.core import (
            GuardCondition,
            InstanceState,
            Listener,
            ReadCondition,
            SampleState,
            ViewState,
            WaitSet,
        )
        from cyclonedds.domain import DomainParticipant
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        c = self.config
        s = c.settings
        from velfence.bridge.graph import participant_qos

        dp = DomainParticipant(c.domain_id, qos=participant_qos())
        self._participant = dp

        def reader(key: str, typ: type, qos: QosSettings, what: str) -> Any:
            name = c.dds_topics[key]
            lis = Listener(  # type: ignore[no-untyped-call]
                on_requested_incompatible_qos=lambda _r, st: self._qos_event(
                    name, "reader", typ, st
                ),
                on_sample_lost=lambda _r, st: self._loss_event(what, "samples_lost", st),
                on_sample_rejected=lambda _r, st: self._loss_event(what, "samples_rejected", st),
            )
            return DataReader(dp, Topic(dp, name, typ), qos=ros_qos(qos, typ), listener=lis)

        def writer(key: str, typ: type, qos: QosSettings) -> Any:
            name = c.dds_topics[key]
            lis = Listener(  # type: ignore[no-untyped-call]
                on_offered_incompatible_qos=lambda _w, st: self._qos_event(name, "writer", typ, st)
            )
            return DataWriter(dp, Topic(dp, name, typ), qos=ros_qos(qos, typ), listener=lis)

        self._cmd_reader = reader("command_in", _TYPES[self._in_type], s.command_in.qos, "command")
        self._state_reader = reader("state", _TYPES[self._state_type], s.state.qos, "state")
        self._out_writer = writer("command_out", _TYPES[self._out_type], s.command_out.qos)
        self._diag_writer = None
        if s.diagnostics.enabled:
            self._diag_writer = writer("diagnostics", msgs.DiagnosticArray, s.diagnostics.qos)
        mask = SampleState.Any | ViewState.Any | InstanceState.Any
        self._ws = WaitSet(dp)
        self._guard = GuardCondition(dp)
        self._ws.attach(ReadCondition(self._cmd_reader, mask))
        self._ws.attach(ReadCondition(self._state_reader, mask))
        self._ws.attach(self._guard)
        for i, x in enumerate(self._sensors):
            typ = msgs.PointCloud2 if x.type == "point_cloud2" else msgs.LaserScan
            rd = reader(f"sensor{i}", typ, x.qos, "cloud")
            self._sensor_readers.append(rd)
            self._ws.attach(ReadCondition(rd, mask))
        if self._frame_id is not None or self._sensors:  # frames through /tf and /tf_static
            for key, topic, qos in (
                ("tf", s.tf.topic, s.tf.qos),
                ("tf_static", s.tf.static_topic, s.tf.static_qos),
            ):
                name = dds_topic(s, topic)
                lis = Listener(  # type: ignore[no-untyped-call]
                    on_requested_incompatible_qos=lambda _r, st, name=name: self._qos_event(
                        name, "reader", msgs.TFMessage, st
                    )
                )
                rd = DataReader(
                    dp,
                    Topic(dp, name, msgs.TFMessage),
                    qos=ros_qos(qos, msgs.TFMessage),
                    listener=lis,
                )
                self._tf_readers[key] = rd
                self._ws.attach(ReadCondition(rd, mask))
        # --- ROS 2 graph hook: services, lifecycle, /rosout, then ros_discovery_info
        from velfence.bridge.graph import RosGraph

        self._graph = RosGraph(
            c,
            dp,
            self._log,
            apply_setting=self._apply_setting,
            lifecycle_callbacks=self._lifecycle_callbacks(),
            active=self._active,
        )
        for rd in self._graph.conditions():
            self._ws.attach(ReadCondition(rd, mask))
        self._graph.announce(
            [
                self._cmd_reader,
                self._state_reader,
                *self._tf_readers.values(),
                *self._sensor_readers,
            ],
            [self._out_writer, self._diag_writer],
        )
        self._ready.set()
        self._log.info(
            "bridge up on DDS domain %d: %s (%s) -> %s (%s), state %s (%s), shaper %s",
            c.domain_id,
            c.dds_topics["command_in"],
            self._in_type,
            c.dds_topics["command_out"],
            self._out_type,
            c.dds_topics["state"],
            self._state_type,
            self._cs.kind,
        )

    def _close(self) -> None:
        self._ready.clear()
        graph, self._graph = self._graph, None  # --- ROS 2 graph hook
        if graph is not None:
            graph.close()
        dp, self._participant = self._participant, None
        self._guard = None
        self._tf_readers = {}
        self._sensor_readers = []
        for attr in ("_cmd_reader", "_state_reader", "_out_writer", "_diag_writer", "_ws"):
            self.__dict__.pop(attr, None)
        if dp is not None:
            with contextlib.suppress(Exception):  # nothing more can be done at shutdown
                dp.__del__()  # deletes the participant and every entity under it, now

    def _qos_event(self, topic: str, side: str, typ: type, status: Any) -> None:
        # Called on a Cyclone DDS thread: only record; the loop logs and reports.
        policy = _POLICY_NAMES.get(int(status.last_policy_id), f"policy {status.last_policy_id}")
        what = "requested" if side == "reader" else "offered"
        msg = (
            f"QoS mismatch on {topic} ({msgs.ros_name(typ)}): this {side}'s {what} {policy} is "
            f"incompatible with a peer's (total {status.total_count}); no data flows between "
            "them; check both sides' QoS profiles"
        )
        with self._lock:
            self._events.append(msg)
            self._counters["qos_incompatible"] += 1
        guard = self._guard
        if guard is not None:
            guard.set(True)

    def _loss_event(self, what: str, kind: str, status: Any) -> None:
        # Called on a Cyclone DDS thread: only count (the change since the last report).
        key = f"{what}_{kind}"
        with self._lock:
            if key in self._counters:
                self._counters[key] += max(0, int(status.total_count_change))

    # ---------------------------------------------------------------- the loop
    def _loop(self, end: float | None) -> None:
        from cyclonedds.util import duration as dds_duration

        next_diag = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            if end is not None and now >= end:
                break
            waits = [_MAX_WAIT, next_diag - now]
            if self._cmd_time is not None:
                stale_at = self._cmd_time + self._cmd_timeout
                if self._period is None:
                    waits.append((stale_at if now < stale_at else self._next_zero) - now)
                else:  # the timer's next period (zeros too go on the timer)
                    waits.append(self._next_pub - now)
            if self._state_time is not None and now < self._state_time + self._state_timeout:
                waits.append(self._state_time + self._state_timeout - now)
            if end is not None:
                waits.append(end - now)
            due = None if self._graph is None else self._graph.due()  # --- ROS 2 graph hook
            if due is not None:
                waits.append(due - now)
            wait = max(0.0, min(waits))
            if wait > 0:
                self._ws.wait(dds_duration(seconds=wait))
            self._guard.set(False)
            urgent = self._drain_events()
            self._take_transforms()
            self._take_clouds()
            self._take_states()
            if self._active:  # --- ROS 2 graph hook: an inactive managed node answers nothing
                self._take_commands()
            else:
                self._take(self._cmd_reader, "command")
            now = time.monotonic()
            self._watchdog(now)
            if self._period is not None and self._active:
                self._tick(now)
            if self._graph is not None:  # --- ROS 2 graph hook: services and /rosout
                self._graph.service(now)
            if self._diag_writer is not None and (urgent or now >= next_diag):
                self._publish_diagnostics(now)
                next_diag = now + self._diag_period

    # ---------------------------------------------------------------- ROS 2 graph hooks
    def _apply_setting(self, name: str, value: float) -> None:
        """A live parameter set (``ros2 param set``), already validated; from the loop thread."""
        attr = {
            "incoming_command_timeout": "_cmd_timeout",
            "state_timeout": "_state_timeout",
            "watchdog_period": "_zero_period",
            "diagnostics.period": "_diag_period",
        }[name]
        setattr(self, attr, float(value))
        self._log.info("parameter %s set to %g s", name, value)

    def _lifecycle_callbacks(self) -> dict[str, Callable[[], str]]:
        def activate() -> str:
            self._active = True
            return "success"

        def deactivate() -> str:
            if self._active and self._published_any:
                self._publish_zero(time.monotonic(), reason="stop")  # a last zero, as on stop
            self._active = False
            self._cmd_time = None  # no watchdog zeros while inactive
            return "success"

        def shutdown() -> str:
            return deactivate()

        return {"activate": activate, "deactivate": deactivate, "shutdown": shutdown,
                "error": deactivate}  # fmt: skip

    def _drain_events(self) -> bool:
        with self._lock:
            events, self._events = self._events, []
        for e in events:
            self._log.warning("%s", e)
            self._qos_reports = [*self._qos_reports[-4:], e]
        return bool(events)

    def _take(self, reader: Any, what: str) -> list[Any]:
        """The valid samples waiting in ``reader``, each decoded on its own, in order.

        The binding's ``DataReader.take`` decodes a batch in one loop after taking it: one
        undecodable sample (a non-UTF-8 string) raises and loses the whole batch. Here the
        serialized samples are taken and decoded one by one, so a bad one is dropped alone.
        """
        typ = self._reader_types[what]
        try:
            raw = _take_serialized(reader, _TAKE)
        except Exception:  # the reader failed (a deleted entity): nothing to take
            self._drop(what, "take_failed")
            return []
        depth = self._depths.get(what)
        if depth is not None and len(raw) >= depth:
            with self._lock:
                self._counters[f"{what}_history_full"] += 1
        out = []
        for data, info in raw:
            if not info.valid_data:
                continue
            try:
                sm = typ.deserialize(data)
            except Exception:  # UnicodeDecodeError, struct.error, ...: a malformed sample
                with self._lock:
                    self._counters[f"{what}s_received"] += 1
                self._drop(what, "undecodable")
                continue
            out.append(sm)
        return out

    def _drop(self, what: str, reason: str) -> None:
        key = f"{what}_{reason}"
        with self._lock:
            self._counters[f"dropped_{what}s"] += 1
            first = key not in self._drops
            self._drops[key] = self._drops.get(key, 0) + 1
        if first:  # one line per reason; the diagnostics count every drop
            self._log.warning(
                "dropped a %s message: %s (not applied; further drops of this kind are only "
                "counted, as dropped:%s in the diagnostics)",
                what,
                reason.replace("_", " "),
                key,
            )

    def _classify(self, now: float) -> str:
        if self._state_time is None:
            return "waiting_for_state"
        if now - self._state_time > self._state_timeout:
            return "stale_state"
        if self._cmd_time is None:
            return "waiting_for_command"
        if now - self._cmd_time > self._cmd_timeout:
            return "stale_command"
        return "running"

    def _set_state(self, new: str) -> None:
        if new != self._node_state:
            self._log.info("state: %s -> %s", self._node_state, new)
            self._node_state = new

    def _watchdog(self, now: float) -> None:
        self._set_state(self._classify(now))
        if self._period is not None:  # on the timer, _tick publishes the zeros
            return
        if self._cmd_time is None or now - self._cmd_time <= self._cmd_timeout:
            return
        if now >= self._next_zero:
            self._halt(now)
            self._next_zero = max(self._next_zero + self._zero_period, now)

    def _halted(self) -> bool:
        """Whether the halt is over: ``halt_messages`` zeros sent since the last command."""
        return self._halt_n is not None and self._halts_sent >= self._halt_n

    def _halt(self, now: float) -> None:
        """One zero of a stale command's halt, unless all of them were sent (then silence)."""
        if self._halted():
            return
        self._publish_zero(now, reason="watchdog")
        self._halts_sent += 1

    def _tick(self, now: float) -> None:
        """On the timer: the last command shaped against the newest state, or the halt."""
        if self._period is None or now < self._next_pub:
            return
        self._next_pub += self._period
        if self._next_pub <= now:  # late (a stall): the next period starts now, none replayed
            self._next_pub = now + self._period
        if self._cmd_time is None or self._last_cmd is None:
            return  # before the first command nothing is published
        if now - self._cmd_time > self._cmd_timeout:
            self._halt(now)
            return
        msg, v = self._last_cmd
        self._answer(msg, v, now)

    # ---------------------------------------------------------------- state
    def _take_states(self) -> None:
        for msg in self._take(self._state_reader, "state"):
            with self._lock:
                self._counters["states_received"] += 1
            p, yaw, reason = self._state_vector(msg)
            if p is None:
                self._drop("state", reason)
                continue
            self._state, self._state_yaw = p, yaw
            self._state_time = time.monotonic()

    def _state_vector(self, msg: Any) -> tuple[np.ndarray | None, float, str]:
        n = self._cs.state_dim
        if self._state_type == "joint_state":
            names, pos = list(msg.name), list(msg.position)
            if len(pos) != len(names):
                return None, 0.0, "length_mismatch"
            where = {nm: i for i, nm in enumerate(names)}
            if len(where) != len(names):  # a joint named twice: which entry holds?
                return None, 0.0, "duplicate_joints"
            wanted = self._names or ()  # the config check gives joint_state its names
            missing = [j for j in wanted if j not in where]
            if missing:
                return None, 0.0, "missing_joints"
            p = np.array([float(pos[where[j]]) for j in wanted])
            if not np.all(np.isfinite(p)):
                return None, 0.0, "nonfinite"
            return p, 0.0, ""
        pose = msg.pose.pose if self._state_type == "odometry" else msg.pose
        xyz = (float(pose.position.x), float(pose.position.y), float(pose.position.z))
        if not _finite(xyz):
            return None, 0.0, "nonfinite"
        yaw = 0.0
        if self._body:
            y = _yaw(pose.orientation)
            if y is None:
                return None, 0.0, "bad_orientation"
            yaw = y
        return np.array(xyz[:n]), yaw, ""

    def _fresh_state(self, now: float) -> np.ndarray | None:
        if self._state is None or self._state_time is None:
            return None
        if now - self._state_time > self._state_timeout:
            return None
        return self._state

    # ---------------------------------------------------------------- range sensors
    def _take_clouds(self) -> None:
        """Every waiting sensor message into its PointCloudRows, or dropped and counted."""
        for x, rd, rows in zip(self._sensors, self._sensor_readers, self._clouds, strict=True):
            try:
                raw = _take_serialized(rd, _TAKE)
            except Exception:  # the reader failed (a deleted entity): nothing to take
                self._drop_cloud("take_failed")
                continue
            for data, info in raw:
                if not info.valid_data:
                    continue
                with self._lock:
                    self._counters["clouds_received"] += 1
                self._use_cloud(x, rows, data)

    def _use_cloud(self, x: Any, rows: Any, data: bytes) -> None:
        msg = accept_sensor_message(data, x, now=time.time(), transforms=self._tf)
        sp = msg.points
        if sp is None:
            self._drop_cloud(msg.reason)
            return
        try:
            rows.update(sp.points, stamp=sp.stamp, transform=msg.pose)
        except VelfenceError:
            self._drop_cloud("invalid")
            return
        with self._lock:
            self._counters["clouds_used"] += 1
            self._counters["cloud_readings_dropped"] += sp.dropped

    def _drop_cloud(self, reason: str) -> None:
        """A dropped sensor message: counted; a warning at most every 10 s per reason."""
        key = f"cloud_{reason}"
        with self._lock:
            self._counters["dropped_clouds"] += 1
            self._drops[key] = self._drops.get(key, 0) + 1
            count = self._drops[key]
        now = time.monotonic()
        last = self._cloud_warned.get(key)
        if last is None or now - last >= 10.0:
            self._cloud_warned[key] = now
            self._log.warning(
                "dropped a sensor message: %s (%d so far; its points are not used; counted as "
                "dropped:%s in the diagnostics)",
                reason.replace("_", " "),
                count,
                key,
            )

    def _age_clouds(self) -> None:
        """Age every grid to the present, so a silent sensor's voxels decay."""
        if not self._clouds:
            return
        now = time.time()
        empty = np.zeros((0, 3))
        for rows in self._clouds:
            if rows.stamp is not None:
                rows.update(empty, stamp=now)

    # ---------------------------------------------------------------- commands
    def _take_transforms(self) -> None:
        for rd in self._tf_readers.values():
            for msg in self._take(rd, "transform"):
                for ts in msg.transforms:
                    with self._lock:
                        self._counters["transforms_received"] += 1
                    tr = ts.transform
                    r, x = tr.rotation, tr.translation
                    try:
                        self._tf.set(
                            ts.header.frame_id,
                            ts.child_frame_id,
                            (r.x, r.y, r.z, r.w),
                            (x.x, x.y, x.z),
                        )
                    except VelfenceError:
                        self._drop("transform", "invalid")

    def _take_commands(self) -> None:
        for msg in self._take(self._cmd_reader, "command"):
            self._on_command(msg)

    def _command_vector(self, msg: Any) -> tuple[np.ndarray | None, str]:
        n = self._cs.command_dim
        t = self._in_type
        if t in _TWISTS:
            tw = msg.twist if t == "twist_stamped" else msg
            lin = (float(tw.linear.x), float(tw.linear.y), float(tw.linear.z))
            ang = (float(tw.angular.x), float(tw.angular.y), float(tw.angular.z))
            if not (_finite(lin) and _finite(ang)):
                return None, "nonfinite"
            v3 = np.array(lin)
            if self._frame_id is not None and t == "twist_stamped":
                frame = str(msg.header.frame_id).removeprefix("/")
                if frame and frame != self._frame_id:  # an empty frame means the shaper's
                    try:
                        rot = self._tf.rotation(self._frame_id, frame)
                    except VelfenceError:  # a frame id no transform could name
                        rot = None
                    if rot is None:
                        return None, "frame_unknown"
                    v3 = rot @ v3
                    self._cmd_rotation = (msg, rot)
            return v3[:n], ""
        if t == "float64_multi_array":
            data = list(msg.data)
            if len(data) != n:
                return None, "wrong_length"
            v = np.array(data, dtype=float)
            return (v, "") if np.all(np.isfinite(v)) else (None, "nonfinite")
        # joint_jog: any subset of the joints, in any order; the others are commanded zero.
        names, vel = list(msg.joint_names), list(msg.velocities)
        if len(vel) != len(names) or not names:
            return None, "wrong_length"
        if len(msg.displacements) != 0:
            return None, "displacements_unsupported"
        if len(set(names)) != len(names):
            return None, "duplicate_joints"
        if any(nm not in self._index for nm in names):
            return None, "unknown_joints"
        v = np.zeros(n)
        for nm, x in zip(names, vel, strict=True):
            v[self._index[nm]] = float(x)
        return (v, "") if np.all(np.isfinite(v)) else (None, "nonfinite")

    def _on_command(self, msg: Any) -> None:
        with self._lock:
            self._counters["commands_received"] += 1
        v, reason = self._command_vector(msg)
        if v is None:
            self._drop("command", reason)
            return
        now = time.monotonic()
        first = self._cmd_time is None
        self._cmd_time = now
        self._next_zero = now + self._cmd_timeout
        self._halts_sent = 0
        self._set_state(self._classify(now))
        if self._period is not None:
            # On the timer: keep it; _tick shapes it against the state of each period.
            self._last_cmd = (msg, v)
            if first:
                self._next_pub = now
            return
        self._answer(msg, v, now)

    def _answer(self, msg: Any, v: np.ndarray, now: float) -> None:
        """Shape command ``v`` (of message ``msg``) against the fresh state and publish it."""
        p = self._fresh_state(now)
        if p is None:
            self._publish(np.zeros(self._cs.output_dim), msg, now, None, v, "held", (), True)
            with self._lock:
                self._counters["commands_held"] += 1
            return
        self._age_clouds()
        if self._body:
            res = self._cs.shaper.explain(p, body_to_world(v, self._state_yaw))
            out = world_to_body(np.asarray(res.output, dtype=float), self._state_yaw)
        else:
            res = self._cs.shaper.explain(p, v)
            out = np.asarray(res.output, dtype=float)
        active = tuple(str(a) for a in getattr(res, "active_names", ()) or ()) or tuple(
            f"edge {int(i)}" for i in getattr(res, "active", ()) or ()
        )
        self._publish(out, msg, now, p, v, str(res.zone), active, False)

    # ---------------------------------------------------------------- output
    def _publish_zero(self, now: float, *, reason: str) -> None:
        self._publish(np.zeros(self._cs.output_dim), None, now, None, None, "held", (), True)
        if reason == "watchdog":
            with self._lock:
                self._counters["watchdog_zeros"] += 1

    def _publish(
        self,
        out: np.ndarray,
        msg_in: Any,
        now: float,
        state: np.ndarray | None,
        command: np.ndarray | None,
        zone: str,
        active: tuple[str, ...],
        zero: bool,
    ) -> None:
        if out.shape != (self._cs.output_dim,) or not np.all(np.isfinite(out)):
            # Never write a non-finite command: a shaper bug must not reach the robot.
            self._log.error("non-finite shaped command %s replaced by zero", out)
            self._drop("output", "nonfinite")
            out, zone, zero = np.zeros(self._cs.output_dim), "held", True
        measured = None
        if self._out_type == "joint_trajectory":
            # Positions are integrated from the measured joints: without a fresh state there is
            # no trajectory a controller accepts. Nothing is written; the controller's last
            # trajectory ends at rest within incoming_command_timeout by construction.
            measured = self._fresh_state(now)
            if measured is None or measured.shape != out.shape:
                self._drop("output", "no_state")
                return
        try:
            self._out_writer.write(self._message(out, msg_in, zero, measured))
        except Exception as exc:
            raise DDSFailure(f"writing the shaped command failed: {exc}") from None
        changed = command is None or command.shape != out.shape or not np.array_equal(command, out)
        delta = (
            float(np.linalg.norm(out - command))
            if command is not None and command.shape == out.shape
            else 0.0
        )
        with self._lock:
            self._counters["outputs_published"] += 1
            if not zero:
                self._counters["commands_shaped"] += 1
                if changed:
                    self._counters["commands_changed"] += 1
        self._published_any = True
        self._last = {"zone": zone, "active": active, "changed": changed, "delta": delta}
        if self._on_cycle is not None:
            info = CycleInfo(
                t=now,
                state=None if state is None else state.copy(),
                command=None if command is None else command.copy(),
                shaped=out.copy(),
                zone=zone,
                active=active,
                node_state=self._node_state,
                changed=changed,
            )
            try:
                self._on_cycle(info)
            except Exception:
                with self._lock:
                    self._counters["on_cycle_errors"] += 1
                    first = self._counters["on_cycle_errors"] == 1
                if first:
                    self._log.exception("on_cycle raised (logged once; the bridge goes on)")

    def _header(self, msg_in: Any) -> msgs.Header:
        h = getattr(msg_in, "header", None)
        if isinstance(h, msgs.Header):
            return msgs.Header(
                stamp=msgs.Time(sec=h.stamp.sec, nanosec=h.stamp.nanosec), frame_id=h.frame_id
            )
        return msgs.Header(stamp=_stamp_now())

    def _message(
        self, out: np.ndarray, msg_in: Any, zero: bool, measured: np.ndarray | None = None
    ) -> Any:
        values = [float(x) for x in out]
        t = self._out_type
        if t in _TWISTS:
            lin = [0.0, 0.0, 0.0]
            ang = msgs.Vector3()
            rot = None
            if not zero and self._in_type in _TWISTS and msg_in is not None:
                tw = msg_in.twist if self._in_type == "twist_stamped" else msg_in
                lin = [float(tw.linear.x), float(tw.linear.y), float(tw.linear.z)]
                ang = msgs.Vector3(x=tw.angular.x, y=tw.angular.y, z=tw.angular.z)
                if self._cmd_rotation is not None and self._cmd_rotation[0] is msg_in:
                    rot = self._cmd_rotation[1]  # shaped in command_frame_id: rotate back
                    lin = [float(x) for x in rot @ np.array(lin)]
            lin[: len(values)] = values
            if rot is not None:
                lin = [float(x) for x in rot.T @ np.array(lin)]
            twist = msgs.Twist(linear=msgs.Vector3(x=lin[0], y=lin[1], z=lin[2]), angular=ang)
            if t == "twist":
                return twist
            return msgs.TwistStamped(header=self._header(msg_in), twist=twist)
        if t == "float64_multi_array":
            return msgs.Float64MultiArray(data=values)
        names = list(self._names or ())
        if t == "joint_jog":
            return msgs.JointJog(header=self._header(msg_in), joint_names=names, velocities=values)
        # joint_trajectory, as joint_trajectory_controller accepts with its default parameters
        # (docs/bridge.md): every joint, one point reached after incoming_command_timeout at
        # the measured position plus velocity x time, at rest there; stamp 0 = "start now".
        horizon = self._cmd_timeout
        assert measured is not None  # _publish wrote nothing without a fresh state
        positions = [float(q + v * horizon) for q, v in zip(measured, out, strict=True)]
        ns = round(horizon * 1e9)
        point = msgs.JointTrajectoryPoint(
            positions=positions,
            velocities=[0.0] * len(positions),
            time_from_start=msgs.Duration(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000),
        )
        return msgs.JointTrajectory(
            header=msgs.Header(stamp=msgs.Time(sec=0, nanosec=0)), joint_names=names, points=[point]
        )

    def _watchdog_value(self, state: str) -> str:
        if state != "stale_command":
            return "ok"
        return "halted" if self._halted() else "zero"

    def _publish_diagnostics(self, now: float) -> None:
        counters = self.counters
        last = self._last
        state = self._node_state
        level = 0
        if state in ("stale_command", "waiting_for_state"):
            level = 1
        if state == "stale_state" or counters["qos_incompatible"]:
            level = 2
        values = [
            ("state", state),
            ("zone", str(last["zone"])),
            ("active", ", ".join(last["active"]) or "none"),
            ("command_changed", "true" if last["changed"] else "false"),
            ("change_norm", f"{last['delta']:.6g}"),
            ("watchdog", self._watchdog_value(state)),
            ("shaper", self._cs.kind),
            *((k, str(v)) for k, v in sorted(counters.items())),
            *((f"qos_mismatch_{i}", r) for i, r in enumerate(self._qos_reports)),
        ]
        status = msgs.DiagnosticStatus(
            level=level,
            name=self.config.settings.diagnostics.name,
            message=state,
            hardware_id="velfence",
            values=[msgs.KeyValue(key=k, value=v) for k, v in values],
        )
        arr = msgs.DiagnosticArray(header=msgs.Header(stamp=_stamp_now()), status=[status])
        writer = self._diag_writer
        if writer is None:
            return
        try:
            writer.write(arr)
        except Exception as exc:
            raise DDSFailure(f"writing diagnostics failed: {exc}") from None
        with self._lock:
            self._counters["diagnostics_published"] += 1


def serve(
    config_path: str | Path | BridgeConfig,
    *,
    duration: float | None = None,
    on_cycle: Callable[[CycleInfo], None] | None = None,
) -> int:
    """Load a bridge file and run the node until SIGINT/SIGTERM (``velfence bridge``).

    Logs to stderr (one line per state change) unless the ``velfence.bridge`` logger already
    has handlers. SIGINT and SIGTERM stop the node cleanly when called from the main thread.

    Args:
        config_path: The bridge YAML file (``docs/bridge.md``), or a configuration already
            loaded from one (:func:`~velfence.bridge.load_bridge_config`), so that a caller
            that needs it too reads the file once.
        duration: Stop by itself after this many seconds (``0 < duration <= 10⁶``); None runs
            until a signal.
        on_cycle: Passed to :class:`BridgeNode` (a live view).

    Returns:
        The exit code: :data:`EXIT_OK` (clean stop), :data:`EXIT_DDS` (DDS failed),
        :data:`EXIT_INTERRUPTED` (Ctrl-C during start-up, before the signal handlers are in
        place; one log line, no traceback) or :data:`EXIT_INTERNAL` (a bug; the traceback is
        logged).

    Raises:
        InvalidParameter: a bad argument, or a configuration file that is missing or invalid
            (the message names the file and the field; ``velfence bridge`` exits with
            :data:`EXIT_CONFIG`).
    """
    from velfence.bridge.config import load_bridge_config

    if not isinstance(config_path, (str, Path, BridgeConfig)):
        raise InvalidParameter(
            f"config_path: expected a file path or a BridgeConfig, got {type(config_path).__name__}"
        )
    _check_duration(duration)
    _check_on_cycle(on_cycle)
    log = logging.getLogger("velfence.bridge")
    if not log.handlers:
        handler = logging.StreamHandler()
        handler.setFormatter(logging.Formatter("%(asctime)s velfence bridge: %(message)s"))
        log.addHandler(handler)
        log.setLevel(logging.INFO)
        log.propagate = False
    previous: dict[signal.Signals, Any] = {}
    try:  # start-up: Ctrl-C here stops with one line, before the handlers below take over
        config = (
            config_path
            if isinstance(config_path, BridgeConfig)
            else load_bridge_config(config_path)
        )
        node = BridgeNode(config, on_cycle=on_cycle)
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                previous[sig] = signal.signal(sig, lambda _s, _f: node.stop())
    except KeyboardInterrupt:
        for signum, old in previous.items():
            signal.signal(signum, old)
        log.error("interrupted during start-up")
        return EXIT_INTERRUPTED
    try:
        return node.run(duration=duration)
    except DDSFailure as exc:
        log.error("%s", exc)
        return EXIT_DDS
    except Exception:
        log.exception("internal error (please report it)")
        return EXIT_INTERNAL
    finally:
        for signum, old in previous.items():
            signal.signal(signum, old)


def _check_on_cycle(on_cycle: Any) -> None:
    if on_cycle is not None and (not callable(on_cycle) or isinstance(on_cycle, type)):
        raise InvalidParameter(
            f"on_cycle: expected a function taking a CycleInfo, or None, got "
            f"{type(on_cycle).__name__}"
        )


def _check_duration(duration: Any) -> None:
    if duration is not None:
        check_range("duration", duration, low=0.0, high=1e6, low_open=True, unit="s")


document_inits(globals())
