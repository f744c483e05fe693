"""The node side of a Nav2 bond without DDS: bondcpp's state machine, step by step in time.

Each status the bond publishes is kept; the sister's statuses are plain objects with the
fields of bond/msg/Status. The DDS exchange with a manager is tested in test_bridge_graph.py.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from velfence.bridge.bond import CONNECT_TIMEOUT, DEAD_PUBLISH_PERIOD, DESTROY_WAIT, Bond
from velfence.errors import InvalidParameter


def _bond(now: float = 100.0) -> tuple[Bond, list[Any]]:
    sent: list[Any] = []
    return Bond("controller", sent.append, heartbeat_period=0.25, now=now), sent


def _sister(active: bool, bond_id: str = "controller", instance: str = "mgr") -> Any:
    return SimpleNamespace(id=bond_id, instance_id=instance, active=active)


def test_heartbeats_on_the_period_once_formed() -> None:
    b, sent = _bond()
    assert [m.active for m in sent] == [True]  # the first status goes out at once
    assert (sent[0].id, sent[0].heartbeat_period, sent[0].heartbeat_timeout) == (
        "controller", 0.25, 4.0)  # fmt: skip
    b.receive(_sister(True, bond_id="planner"))  # another bond's status: ignored
    b.receive(SimpleNamespace(id="controller", instance_id=b.instance_id, active=True))  # ours
    assert b.state == "waiting"
    b.receive(_sister(True))
    assert (b.state, b.sister) == ("alive", "mgr")
    for k in range(1, 9):
        b.poll(100.0 + 0.25 * k)
    assert len(sent) == 9
    assert all(m.active for m in sent)
    assert {m.instance_id for m in sent} == {b.instance_id}
    assert b.due() == 100.0 + 0.25 * 9


def test_broken_by_the_node_repeats_false_until_acknowledged_or_done() -> None:
    b, sent = _bond()
    b.receive(_sister(True))
    b.break_bond(100.1)
    assert (b.state, [m.active for m in sent]) == ("dying", [True, False])
    b.poll(100.1 + DEAD_PUBLISH_PERIOD)
    assert [m.active for m in sent] == [True, False, False]
    b.poll(100.1 + DESTROY_WAIT)
    assert b.gone
    b.poll(200.0)
    assert len(sent) == 3
    assert b.due() is None

    b2, sent2 = _bond()
    b2.receive(_sister(True))
    b2.break_bond(100.1)
    b2.receive(_sister(False))  # the manager's acknowledgement ends it at once
    assert b2.gone
    assert [m.active for m in sent2] == [True, False]


def test_sister_dies_first_one_acknowledgement() -> None:
    b, sent = _bond()
    b.receive(_sister(True))
    b.receive(_sister(False))
    assert b.gone
    assert [m.active for m in sent] == [True, False]
    b.break_bond(101.0)  # deactivate later: nothing more to say
    b.poll(101.0)
    assert len(sent) == 2


def test_no_sister_within_the_connect_timeout() -> None:
    b, sent = _bond()
    b.poll(100.0 + CONNECT_TIMEOUT - 0.01)
    n = len(sent)
    assert n > 1
    assert all(m.active for m in sent)
    b.poll(100.0 + CONNECT_TIMEOUT)
    assert b.gone
    b.poll(100.0 + CONNECT_TIMEOUT + 1.0)
    assert len(sent) == n


@pytest.mark.parametrize(
    "kwargs",
    [{"heartbeat_period": 0.0}, {"heartbeat_period": float("nan")}, {"heartbeat_period": "1"},
     {"bond_id": 3}, {"now": float("inf")}],
)  # fmt: skip
def test_bad_arguments_refused(kwargs: dict[str, Any]) -> None:
    args: dict[str, Any] = {"bond_id": "c", "heartbeat_period": 0.25, "now": 0.0, **kwargs}
    bond_id = args.pop("bond_id")
    with pytest.raises(InvalidParameter):
        Bond(bond_id, lambda m: None, **args)
