"""The node side of a Nav2 bond (``bond/msg/Status`` on the ``bond`` topic).

Nav2's lifecycle manager, after it has activated a managed node, forms a *bond* with it: both
sides publish ``bond/msg/Status`` (``id`` = the node's name, each side its own random
``instance_id``) on ``bond`` (relative to the namespace), the manager waits up to half its
``bond_timeout`` (default 4 s) for the node's first heartbeat, and later declares the node dead
(and resets the whole stack) when no heartbeat came for ``bond_timeout``. A Nav2 node creates its
side when it activates and destroys it when it deactivates or shuts down
(``nav2::LifecycleNode::createBond`` / ``destroyBond``).

:class:`Bond` follows bondcpp's state machine (``BondSM``) as a Nav2 node runs it:

* waiting for the sister -> alive on her first ``active`` status; dead after the connect timeout
  (10 s) without one;
* alive: a status with ``active = true`` every heartbeat period (``bond_heartbeat_period``,
  0.25 s); the node side never times the sister out (Nav2 sets
  ``bond_disable_heartbeat_timeout``);
* broken by this side (deactivate, shutdown): ``active = false`` at once and every 0.05 s until
  the sister answers dead, for at most 0.1 s (the wait of bondcpp's destructor) — then the bond
  is gone;
* the sister's ``active = false``: dead, acknowledged with one ``active = false``.

The class holds no DDS entity: :meth:`Bond.receive` gets the sister's statuses and ``publish``
(given at construction) writes this side's.
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable
from typing import Any

from velfence._docs import document_inits
from velfence._validate import check_range, check_text
from velfence.bridge import ros_interfaces as ri
from velfence.bridge.msgs import Header, Time

__all__ = ["BOND_TOPIC", "Bond"]

#: The topic name Nav2 gives its bonds (relative: ``/<namespace>/bond``).
BOND_TOPIC = "bond"
#: bond/msg/Constants.
CONNECT_TIMEOUT = 10.0
HEARTBEAT_TIMEOUT = 4.0
DEAD_PUBLISH_PERIOD = 0.05
#: How long bondcpp's destructor waits for the sister's death ack before it drops the bond [s].
DESTROY_WAIT = 0.1


class Bond:
    """One bond, seen from the managed node.

    Args:
        bond_id: The bond's id (Nav2: the node's name, without namespace).
        publish: Writes one :class:`~velfence.bridge.ros_interfaces.BondStatus`.
        heartbeat_period: Seconds between two heartbeats (> 0).
        now: ``time.monotonic()`` at the start [s]; the first heartbeat goes out at once.

    Raises:
        InvalidParameter: An id that is not a string, or a period not in (0, 3600] s.
    """

    def __init__(
        self,
        bond_id: str,
        publish: Callable[[ri.BondStatus], None],
        *,
        heartbeat_period: float,
        now: float,
    ) -> None:
        self.id = check_text("bond_id", bond_id)
        self.instance_id = str(uuid.uuid4())
        self.state = "waiting"
        self.sister: str | None = None
        self.sent = 0
        self._publish = publish
        self._period = check_range(
            "heartbeat_period", heartbeat_period, low=0.0, high=3600.0, low_open=True, unit="s"
        )
        now = check_range("now", now, unit="s")
        self._connect_deadline = now + CONNECT_TIMEOUT
        self._next = now
        self._dying_until = 0.0
        self.poll(now)

    @property
    def gone(self) -> bool:
        """Whether nothing more will be published (dead, or broken and done waiting)."""
        return self.state == "dead"

    def _status(self, active: bool) -> None:
        ns = time.time_ns()
        self._publish(
            ri.BondStatus(
                header=Header(stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)),
                id=self.id,
                instance_id=self.instance_id,
                active=active,
                heartbeat_timeout=HEARTBEAT_TIMEOUT,
                heartbeat_period=self._period,
            )
        )
        self.sent += 1

    def receive(self, msg: Any) -> None:
        """A sample of the bond topic (another id's, or our own, is skipped)."""
        if str(msg.id) != self.id or str(msg.instance_id) == self.instance_id:
            return
        if self.sister is None:
            self.sister = str(msg.instance_id)
        if bool(msg.active):
            if self.state == "waiting":
                self.state = "alive"
            return
        if self.state in ("waiting", "alive"):  # the sister died first: acknowledge it
            self.state = "dead"
            self._status(False)
        elif self.state == "dying":
            self.state = "dead"

    def break_bond(self, now: float) -> None:
        """This side ends the bond (deactivate, shutdown)."""
        if self.state == "waiting":
            self.state = "dead"
            self._status(False)
        elif self.state == "alive":
            self.state = "dying"
            self._status(False)
            self._next = now + DEAD_PUBLISH_PERIOD
            self._dying_until = now + DESTROY_WAIT

    def poll(self, now: float) -> None:
        """Publish what is due at ``now`` and apply the timeouts."""
        if self.state == "waiting" and now >= self._connect_deadline:
            self.state = "dead"
            return
        if self.state == "dying" and now >= self._dying_until:
            self.state = "dead"
            return
        if self.state == "dead" or now < self._next:
            return
        self._status(self.state != "dying")
        step = DEAD_PUBLISH_PERIOD if self.state == "dying" else self._period
        self._next = max(self._next + step, now + 0.5 * step)

    def due(self) -> float | None:
        """When :meth:`poll` next has something to do (monotonic seconds), or None."""
        if self.state == "dead":
            return None
        if self.state == "dying":
            return min(self._next, self._dying_until)
        if self.state == "waiting":
            return min(self._next, self._connect_deadline)
        return self._next


document_inits(globals())
