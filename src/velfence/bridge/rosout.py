"""The node's log lines on ``/rosout`` (``rcl_interfaces/msg/Log``), as ROS 2 nodes send them.

A :class:`RosoutHandler` is a ``logging.Handler``: it keeps each record (from any thread) until
the node's loop writes it. QoS as ``rcl_qos_profile_rosout_default``: reliable, transient local,
keep-last 1000, lifespan 10 s. The level maps from Python's (DEBUG 10 … CRITICAL 50) to ROS's
(DEBUG 10, INFO 20, WARN 30, ERROR 40, FATAL 50), a level between two taking the lower.
"""

from __future__ import annotations

import logging
import threading
from typing import Any

from velfence._docs import document_inits
from velfence.bridge import ros_interfaces as ri
from velfence.bridge.msgs import Time

__all__ = ["ROSOUT_DEPTH", "RosoutHandler", "ros_level"]

#: History depth of the /rosout writer (rcl's default).
ROSOUT_DEPTH = 1000
_LIFESPAN_S = 10
_MAX_QUEUED = 1000


def ros_level(levelno: int) -> int:
    """The ``rcl_interfaces/msg/Log`` level of a Python logging level (10, 20, 30, 40 or 50)."""
    for ros in (50, 40, 30, 20):
        if levelno >= ros:
            return ros
    return 10


def logger_name(namespace: str, node_name: str) -> str:
    """A node's logger name as rcl builds it: ``ns.sub.node`` (``node`` in the root namespace)."""
    parts = [p for p in namespace.strip("/").split("/") if p]
    return ".".join([*parts, node_name])


class RosoutHandler(logging.Handler):
    """Collects log records for ``/rosout``; :meth:`flush_to` writes them.

    Args:
        name: The ``Log.name`` (the node's logger name, :func:`logger_name`).
    """

    def __init__(self, name: str) -> None:
        super().__init__(logging.DEBUG)
        self.node_logger = name
        self._queue: list[ri.Log] = []
        self._qlock = threading.Lock()

    def emit(self, record: logging.LogRecord) -> None:  # noqa: D102 (logging.Handler)
        try:
            text = record.getMessage()
        except Exception:
            text = str(record.msg)
        ns = int(record.created * 1e9)
        log = ri.Log(
            stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000),
            level=ros_level(record.levelno),
            name=self.node_logger,
            msg=text,
            file=record.pathname,
            function=record.funcName or "",
            line=max(0, int(record.lineno or 0)),
        )
        with self._qlock:
            if len(self._queue) < _MAX_QUEUED:
                self._queue.append(log)

    def flush_to(self, writer: Any) -> int:
        """Write the waiting records with ``writer`` (a DataWriter); how many were written."""
        with self._qlock:
            logs, self._queue = self._queue, []
        for log in logs:
            writer.write(log)
        return len(logs)


def rosout_qos() -> Any:
    """The Cyclone DDS QoS of the ``/rosout`` writer (with the Log type hash in USER_DATA)."""
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    from velfence.bridge.typehash import user_data

    return Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
        Policy.History.KeepLast(ROSOUT_DEPTH),
        Policy.Durability.TransientLocal,
        Policy.DurabilityService(
            cleanup_delay=0,
            history=Policy.History.KeepLast(ROSOUT_DEPTH),
            max_samples=-1,
            max_instances=-1,
            max_samples_per_instance=-1,
        ),
        Policy.Lifespan(duration(seconds=_LIFESPAN_S)),
        Policy.Userdata(user_data(ri.Log)),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )


document_inits(globals())
