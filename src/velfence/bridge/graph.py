"""The bridge as a node of the ROS 2 graph: discovery info, parameters, lifecycle, /rosout.

ROS 2 tools do not find nodes through DDS discovery alone: every participant publishes
``ros_discovery_info`` (``rmw_dds_common/msg/ParticipantEntitiesInfo``): its gid and, per node,
the namespace, name and the gids of the node's readers and writers. A gid is the entity's
16-byte DDS GUID (Jazzy's ``Gid`` is ``char[16]``; Humble's is ``char[24]``, the GUID and eight
zero bytes). The topic is reliable, transient local, keep-last 1 (a late tool gets the last
sample), without the ``rt/`` prefix. The participant's USER_DATA says ``enclave=/;``.

:class:`RosGraph` creates these entities next to the node's own, answers the parameter and
lifecycle services from the node's loop thread, writes the queued log lines to ``/rosout``,
announces parameters on ``/parameter_events`` and keeps the node's side of a Nav2 bond
(:mod:`velfence.bridge.bond`) while a managed node is active.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable
from typing import Any

from velfence._docs import document_inits
from velfence.bridge import ros_interfaces as ri
from velfence.bridge.bond import BOND_TOPIC, Bond
from velfence.bridge.config import BridgeConfig, dds_topic
from velfence.bridge.lifecycle import LifecycleMachine
from velfence.bridge.params import ParameterStore
from velfence.bridge.rosout import RosoutHandler, logger_name, rosout_qos
from velfence.bridge.services import ServiceServer, client_service_id, reliable_qos

__all__ = [
    "DISCOVERY_TOPIC",
    "PARAMETER_EVENTS_TOPIC",
    "RosGraph",
    "fully_qualified_name",
    "gid",
    "participant_qos",
]

#: The DDS topic of the graph information (no ``rt/`` prefix).
DISCOVERY_TOPIC = "ros_discovery_info"
#: The DDS topic of ``/parameter_events``.
PARAMETER_EVENTS_TOPIC = "rt/parameter_events"
#: History depth of the ``/parameter_events`` writer (rclcpp's ParameterEventsQoS).
PARAMETER_EVENTS_DEPTH = 1000
#: Longest time [s] the start event (every parameter, as new) waits for a first subscriber.
START_EVENT_WAIT = 2.0


def gid(entity: Any, size: int) -> list[int]:
    """An entity's gid: its 16-byte DDS GUID, zero-padded to ``size`` bytes (16 or 24)."""
    raw = bytes(entity.guid.bytes)
    return list(raw) + [0] * (size - len(raw))


def fully_qualified_name(namespace: str, node_name: str) -> str:
    """``/ns/node`` (``/node`` in the root namespace)."""
    ns = namespace.strip("/")
    return f"/{ns}/{node_name}" if ns else f"/{node_name}"


def participant_qos() -> Any:
    """The participant QoS a ROS 2 context uses: USER_DATA ``enclave=/;``."""
    from cyclonedds.core import Policy, Qos

    return Qos(Policy.Userdata(b"enclave=/;"))


def _discovery_qos(typ: type) -> Any:
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    from velfence.bridge.typehash import user_data

    return Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
        Policy.History.KeepLast(1),
        Policy.Durability.TransientLocal,
        Policy.DurabilityService(
            cleanup_delay=0,
            history=Policy.History.KeepLast(1),
            max_samples=-1,
            max_instances=-1,
            max_samples_per_instance=-1,
        ),
        Policy.Userdata(user_data(typ)),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )


class RosGraph:
    """The node's graph entities, services and /rosout (created inside ``BridgeNode._open``).

    Args:
        config: The bridge configuration (``node_name``, ``namespace``, ``ros_distro``,
            ``lifecycle``, ``rosout``).
        participant: The node's ``DomainParticipant`` (created with :func:`participant_qos`).
        logger: The node's logger (a /rosout handler is added to it, and removed on close).
        apply_setting: The node's setter of a live parameter (``(name, seconds)``).
        lifecycle_callbacks: ``{"activate": f, ...}`` for the managed-node transitions.
        active: Whether the node starts active (True without ``lifecycle``).
    """

    def __init__(
        self,
        config: BridgeConfig,
        participant: Any,
        logger: logging.Logger,
        *,
        apply_setting: Callable[[str, float], None],
        lifecycle_callbacks: dict[str, Callable[[], str]],
        active: bool,
    ) -> None:
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        s = config.settings
        self._dp = participant
        self._logger = logger
        self.fqn = fully_qualified_name(s.namespace, s.node_name)
        self._namespace = "/" + s.namespace.strip("/") if s.namespace.strip("/") else "/"
        self._node_name = s.node_name
        self._settings = s
        size, self._gid_t, self._node_t, self._info_t = ri.GRAPH_TYPES[s.ros_distro]
        self._gid_size = size
        self._readers: list[Any] = []
        self._writers: list[Any] = []
        self.services: list[ServiceServer] = []
        guid = bytes(participant.guid.bytes)
        self._ids = 0

        def serve(suffix: str, req: type, rsp: type, handler: Callable[[Any], Any]) -> None:
            self._ids += 1
            srv = ServiceServer(
                participant,
                f"{self.fqn}/{suffix}",
                req,
                rsp,
                handler,
                service_id=client_service_id(guid, self._ids),
            )
            self.services.append(srv)
            self._readers.append(srv.reader)
            self._writers.append(srv.writer)

        self._discovery: Any = DataWriter(
            participant,
            Topic(participant, DISCOVERY_TOPIC, self._info_t),
            qos=_discovery_qos(self._info_t),
        )
        self._param_events: Any = DataWriter(
            participant,
            Topic(participant, PARAMETER_EVENTS_TOPIC, ri.ParameterEvent),
            qos=reliable_qos(ri.ParameterEvent, depth=PARAMETER_EVENTS_DEPTH),
        )
        self._writers.append(self._param_events)
        self.parameters = ParameterStore(
            config, apply_setting, publish_event=self._param_events.write, node=self.fqn
        )
        for h in self.parameters.handlers():
            serve(*h)
        # rclcpp announces each parameter as it is declared; a subscriber not yet matched then
        # misses it. The bridge holds this one event until a first subscriber has matched.
        self._start_event: ri.ParameterEvent | None = self.parameters.event(
            new=self.parameters.names()
        )
        self._start_deadline = time.monotonic() + START_EVENT_WAIT
        self.bond: Bond | None = None
        self._bond_writer: Any = None
        self._bond_reader: Any = None
        if s.lifecycle and s.bond_heartbeat_period > 0:
            from cyclonedds.sub import DataReader

            bond_topic = Topic(participant, dds_topic(s, BOND_TOPIC), ri.BondStatus)
            self._bond_writer = DataWriter(
                participant, bond_topic, qos=reliable_qos(ri.BondStatus, depth=5)
            )
            self._bond_reader = DataReader(
                participant, bond_topic, qos=reliable_qos(ri.BondStatus, depth=100)
            )
            self._writers.append(self._bond_writer)
            self._readers.append(self._bond_reader)
        self.lifecycle: LifecycleMachine | None = None
        self._events: Any = None
        if s.lifecycle:
            self._events = DataWriter(
                participant,
                Topic(participant, f"rt{self.fqn}/transition_event", ri.TransitionEvent),
                qos=reliable_qos(ri.TransitionEvent),
            )
            self._writers.append(self._events)
            self.lifecycle = LifecycleMachine(
                self._with_bond(lifecycle_callbacks),
                self._events.write,
                initial=3 if active else 1,
            )
            for h in self.lifecycle.handlers():
                serve(*h)
        self._rosout: Any = None
        self._handler: RosoutHandler | None = None
        if s.rosout:
            self._rosout = DataWriter(
                participant, Topic(participant, "rt/rosout", ri.Log), qos=rosout_qos()
            )
            self._writers.append(self._rosout)
            self._handler = RosoutHandler(logger_name(s.namespace, s.node_name))
            logger.addHandler(self._handler)

    def _with_bond(self, callbacks: dict[str, Callable[[], str]]) -> dict[str, Callable[[], str]]:
        """The node's lifecycle callbacks, with the bond formed on activate, broken on leaving."""
        if self._bond_writer is None:
            return callbacks
        out = dict(callbacks)

        def activate() -> str:
            fn = callbacks.get("activate")
            result = "success" if fn is None else fn()
            if result == "success":
                self._break_bond()
                self.bond = Bond(
                    self._node_name,
                    self._bond_writer.write,
                    heartbeat_period=self._settings.bond_heartbeat_period,
                    now=time.monotonic(),
                )
                self._logger.info("bond %r to the lifecycle manager created", self._node_name)
            return result

        def leaving(name: str) -> Callable[[], str]:
            def run() -> str:
                fn = callbacks.get(name)
                try:
                    return "success" if fn is None else fn()
                finally:
                    self._break_bond()

            return run

        out["activate"] = activate
        for name in ("deactivate", "shutdown", "error"):
            out[name] = leaving(name)
        return out

    def _break_bond(self) -> None:
        if self.bond is not None and not self.bond.gone:
            self.bond.break_bond(time.monotonic())
            self._logger.info("bond %r to the lifecycle manager broken", self._node_name)

    def conditions(self) -> list[Any]:
        """The readers that wake the node's wait set: service requests, the bond's statuses."""
        extra = [] if self._bond_reader is None else [self._bond_reader]
        return [*(srv.reader for srv in self.services), *extra]

    def announce(self, readers: list[Any], writers: list[Any]) -> None:
        """Publish ``ros_discovery_info`` with the node's own readers and writers added.

        Args:
            readers: The node's topic readers (command, state).
            writers: The node's topic writers (command out, diagnostics).
        """
        n = self._gid_size

        def gids(entities: list[Any]) -> list[Any]:
            return [self._gid_t(data=gid(e, n)) for e in entities if e is not None]

        node = self._node_t(
            node_namespace=self._namespace,
            node_name=self._node_name,
            reader_gid_seq=gids([*readers, *self._readers]),
            writer_gid_seq=gids([*writers, *self._writers]),
        )
        info = self._info_t(gid=self._gid_t(data=gid(self._dp, n)), node_entities_info_seq=[node])
        self._discovery.write(info)

    def service(self, now: float) -> None:
        """Answer waiting requests and write queued log lines (from the node's loop thread)."""
        if self._start_event is not None and (
            self._param_events.get_matched_subscriptions() or now >= self._start_deadline
        ):
            event, self._start_event = self._start_event, None
            self._param_events.write(event)
        if self._bond_reader is not None:
            for sample in self._bond_reader.take(N=100):
                info = getattr(sample, "sample_info", None)
                if self.bond is not None and (info is None or info.valid_data):
                    self.bond.receive(sample)
        for srv in self.services:
            srv.poll(now)
        if self.bond is not None:
            self.bond.poll(time.monotonic())
        if self._handler is not None and self._rosout is not None:
            self._handler.flush_to(self._rosout)

    def due(self) -> float | None:
        """When :meth:`service` next has timed work (monotonic seconds), or None."""
        times = [] if self.bond is None else [self.bond.due()]
        if self._start_event is not None:
            times.append(self._start_deadline)
        known = [x for x in times if x is not None]
        return min(known) if known else None

    @property
    def waiting(self) -> bool:
        """Whether a reply waits for its client's reader to match (poll again soon)."""
        return any(srv.waiting for srv in self.services)

    def close(self) -> None:
        """Break the bond, write the last log lines and detach the /rosout handler."""
        with contextlib.suppress(Exception):
            self._break_bond()
        if self._handler is not None:
            self._logger.removeHandler(self._handler)
            if self._rosout is not None:
                with contextlib.suppress(Exception):
                    self._handler.flush_to(self._rosout)
            self._handler = None


document_inits(globals())
