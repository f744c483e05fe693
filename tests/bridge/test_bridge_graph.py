"""The bridge in the ROS 2 graph: discovery info, parameters, lifecycle, bonds, /rosout.

The peer (ros_graph_client.py, its own process, one per module, serving one spec per test)
encodes every request and decodes every reply, discovery, log, bond and parameter-event sample
with rosbags' typestore from the published definitions (ros_graph_defs.py), never with
velfence's message classes.
"""

from __future__ import annotations

import itertools
import json
import os
import queue
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from ros_graph_defs import typestore

from conftest import _SESSION, DOMAIN, LOOPBACK, SRC
from velfence.bridge import graph
from velfence.bridge import ros_interfaces as ri
from velfence.bridge.msgs import ros_name
from velfence.bridge.typehash import rihs01

CLIENT = Path(__file__).with_name("ros_graph_client.py")
SHAPER = {"kind": "polygon", "corners": [[0, 0], [4, 0], [4, 3], [0, 3]], "buffer": 0.5}
SECTION = {
    "command_in": {"topic": "cmd_in", "type": "twist"},
    "command_out": {"topic": "cmd_out"},
    "state": {"topic": "odom", "type": "odometry"},
    "command_frame": "world",
}
PARAM_TYPE_DOUBLE, PARAM_TYPE_STRING, PARAM_NOT_SET = 3, 4, 0


class GraphPeer:
    """ros_graph_client.py serving specs on stdin: one process (and participant) per module."""

    def __init__(self) -> None:
        env = {**os.environ, "PYTHONPATH": str(SRC), "CYCLONEDDS_URI": LOOPBACK}
        self._err = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 (closed in close())
        self.proc = subprocess.Popen(
            [sys.executable, str(CLIENT), "--serve", str(DOMAIN)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._err,
            text=True,
            env=env,
        )
        self._lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self._lines.put(line)

    def send(self, spec: dict[str, Any]) -> None:
        """Start a spec (its answers are read with :meth:`answer`)."""
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps({"domain": DOMAIN, **spec}) + "\n")
        self.proc.stdin.flush()

    def answer(self, timeout: float = 60.0) -> dict[str, Any]:
        try:
            msg: dict[str, Any] = json.loads(self._lines.get(timeout=timeout))
        except queue.Empty:
            self.proc.kill()
            self._err.seek(0)
            err = self._err.read()[-3000:]
            raise AssertionError(f"graph peer silent for {timeout} s: {err}") from None
        if "error" in msg:
            raise AssertionError(f"graph peer: {msg['error']}")
        return msg

    def __call__(self, spec: dict[str, Any], timeout: float = 60.0) -> dict[str, Any]:
        self.send(spec)
        result: dict[str, Any] = self.answer(timeout)["result"]
        return result

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            self.proc.wait(10.0)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self._err.close()


@pytest.fixture(scope="module")
def graph_peer() -> Iterator[GraphPeer]:
    p = GraphPeer()
    yield p
    p.close()


def fqn(b: Any) -> str:
    s = b.config.settings
    return f"/{s.namespace.strip('/')}/{s.node_name}"


def test_type_hashes_agree_with_rosbags() -> None:
    store: Any = typestore()
    for name in ri.__all__:
        cls = getattr(ri, name)
        if hasattr(cls, "__idl_typename__") and not name.endswith("24"):
            assert rihs01(cls) == store.hash_rihs01(ros_name(cls)), name
    humble: Any = typestore("humble")
    assert rihs01(ri.ParticipantEntitiesInfo24) == humble.hash_rihs01(
        "rmw_dds_common/msg/ParticipantEntitiesInfo"
    )


@pytest.mark.parametrize("distro", ["jazzy", "humble"])
def test_discovery_info_lists_the_node_and_its_endpoints(
    bridge: Any, graph_peer: GraphPeer, distro: str
) -> None:
    b = bridge({**SECTION, "ros_distro": distro, "node_name": "fence"}, SHAPER)
    out = graph_peer({"node": fqn(b), "node_name": "fence", "discovery": True, "distro": distro})
    size = 16 if distro == "jazzy" else 24
    infos = [
        i
        for i in out["discovery"]
        if any(n["node_name"] == "fence" for n in i["node_entities_info_seq"])
    ]
    assert len(infos) >= 1
    info = infos[-1]
    (node,) = info["node_entities_info_seq"]
    assert node["node_namespace"] == "/" + b.config.settings.namespace.strip("/")
    pgid = bytes(info["gid"]["data"])
    assert len(pgid) == size
    assert pgid[16:] == bytes(size - 16)
    # The participant gid is the GUID DDS itself announces (builtin DCPSParticipant topic).
    keys = {bytes.fromhex(p["key"]) for p in out["entities"]["participants"]}
    assert pgid[:16] in keys
    writers = {bytes(g["data"])[:16] for g in node["writer_gid_seq"]}
    readers = {bytes(g["data"])[:16] for g in node["reader_gid_seq"]}
    by_topic: dict[str, set[bytes]] = {}
    for kind in ("publications", "subscriptions"):
        for e in out["entities"][kind]:
            if e["participant"] is not None and bytes.fromhex(e["participant"]) == pgid[:16]:
                by_topic.setdefault(f"{kind}:{e['topic']}", set()).add(bytes.fromhex(e["key"]))
    ns = b.config.settings.namespace.strip("/")
    assert by_topic[f"publications:rt/{ns}/cmd_out"] <= writers
    assert by_topic[f"subscriptions:rt/{ns}/cmd_in"] <= readers
    assert by_topic[f"subscriptions:rq/{ns}/fence/get_parametersRequest"] <= readers
    assert by_topic[f"publications:rr/{ns}/fence/get_parametersReply"] <= writers
    assert by_topic["publications:rt/rosout"] <= writers


def test_parameters_list_get_describe_set(bridge: Any, graph_peer: GraphPeer) -> None:
    b = bridge(SECTION, SHAPER)
    srv = "rcl_interfaces/srv/"
    param = "rcl_interfaces/msg/Parameter"
    value = "rcl_interfaces/msg/ParameterValue"

    def p(name: str, **v: Any) -> dict[str, Any]:
        return {"__type__": param, "name": name, "value": {"__type__": value, **v}}

    calls = [
        ["list_parameters", srv + "ListParameters", {"prefixes": [], "depth": 0}],
        ["get_parameters", srv + "GetParameters",
         {"names": ["incoming_command_timeout", "command_in.topic", "nope"]}],
        ["describe_parameters", srv + "DescribeParameters",
         {"names": ["incoming_command_timeout", "command_in.topic"]}],
        ["get_parameter_types", srv + "GetParameterTypes", {"names": ["state_timeout", "nope"]}],
        ["set_parameters", srv + "SetParameters", {"parameters": [
            p("incoming_command_timeout", type=PARAM_TYPE_DOUBLE, double_value=0.25),
            p("watchdog_period", type=PARAM_TYPE_DOUBLE, double_value=-1.0),
            p("command_in.topic", type=PARAM_TYPE_STRING, string_value="x"),
            p("state_timeout", type=PARAM_TYPE_STRING, string_value="1"),
        ]}],
        ["set_parameters_atomically", srv + "SetParametersAtomically", {"parameters": [
            p("state_timeout", type=PARAM_TYPE_DOUBLE, double_value=2.0),
            p("watchdog_period", type=PARAM_TYPE_DOUBLE, double_value=7200.0),
        ]}],
        ["get_parameters", srv + "GetParameters",
         {"names": ["incoming_command_timeout", "state_timeout", "watchdog_period"]}],
        ["list_parameters", srv + "ListParameters", {"prefixes": ["command_in"], "depth": 1}],
    ]  # fmt: skip
    out = graph_peer({"node": fqn(b), "calls": calls})
    listed, got, described, types, setr, atomic, after, sub = out["calls"]
    names = listed["result"]["names"]
    assert {"incoming_command_timeout", "command_in.topic", "node_name", "lifecycle"} <= set(names)
    assert "command_in" in listed["result"]["prefixes"]
    v0, v1, v2 = got["values"]
    assert (v0["type"], v0["double_value"]) == (PARAM_TYPE_DOUBLE, 0.1)
    assert (v1["type"], v1["string_value"]) == (PARAM_TYPE_STRING, "cmd_in")
    assert v2["type"] == PARAM_NOT_SET
    d0, d1 = described["descriptors"]
    assert d0["read_only"] is False
    assert d1["read_only"] is True
    assert d0["floating_point_range"][0]["to_value"] == 3600.0
    assert list(types["types"]) == [PARAM_TYPE_DOUBLE, PARAM_NOT_SET]
    r = setr["results"]
    assert [x["successful"] for x in r] == [True, False, False, False]
    assert "watchdog_period" in r[1]["reason"]
    assert "read-only" in r[2]["reason"]
    assert "double" in r[3]["reason"]
    assert atomic["result"]["successful"] is False
    assert "watchdog_period" in atomic["result"]["reason"]
    assert [v["double_value"] for v in after["values"]] == [0.25, 0.5, 0.05]
    assert b.node._cmd_timeout == 0.25  # applied to the running node
    assert set(sub["result"]["names"]) == {"command_in.topic", "command_in.type"}


def test_lifecycle_nav2_manager_sequence(bridge: Any, graph_peer: GraphPeer) -> None:
    """Nav2's lifecycle_manager: per node change_state then get_state, configure then activate;
    on shutdown deactivate, cleanup, shutdown (each checked with get_state)."""
    b = bridge({**SECTION, "lifecycle": True}, SHAPER)
    assert b.node._active is False
    srv = "lifecycle_msgs/srv/"
    tr = "lifecycle_msgs/msg/Transition"

    def change(tid: int, label: str = "") -> list[Any]:
        return ["change_state", srv + "ChangeState",
                {"transition": {"__type__": tr, "id": tid, "label": label}}]  # fmt: skip

    get = ["get_state", srv + "GetState", {"structure_needs_at_least_one_member": 0}]
    empty = {"structure_needs_at_least_one_member": 0}
    calls = [
        get,
        ["get_available_transitions", srv + "GetAvailableTransitions", empty],
        change(1),
        get,  # configure -> inactive (2)
        change(3),
        get,  # activate -> active (3)
        change(1),  # configure is not available from active: refused
        change(0, "deactivate"),
        get,  # by label, as `ros2 lifecycle set` sends it
        change(2),
        get,  # cleanup -> unconfigured (1)
        change(5),
        get,  # shutdown -> finalized (4)
        ["get_available_states", srv + "GetAvailableStates", empty],
        ["get_transition_graph", srv + "GetAvailableTransitions", empty],
    ]
    out = graph_peer({"node": fqn(b), "calls": calls})
    c = out["calls"]
    assert c[0]["current_state"] == {"id": 1, "label": "unconfigured"}
    assert {t["transition"]["label"] for t in c[1]["available_transitions"]} == {
        "configure",
        "shutdown",
    }
    assert c[2]["success"]
    assert c[3]["current_state"]["id"] == 2
    assert c[4]["success"]
    assert c[5]["current_state"]["id"] == 3
    assert c[6]["success"] is False
    assert c[7]["success"]
    assert c[8]["current_state"]["id"] == 2
    assert c[9]["success"]
    assert c[10]["current_state"]["id"] == 1
    assert c[11]["success"]
    assert c[12]["current_state"] == {"id": 4, "label": "finalized"}
    assert len(c[13]["available_states"]) == 11
    assert len(c[14]["available_transitions"]) == 25
    assert b.node._active is False


def test_without_lifecycle_the_node_is_active(bridge: Any) -> None:
    b = bridge(SECTION, SHAPER)
    assert b.node._active is True
    assert not any(s.name.endswith("/change_state") for s in b.node._graph.services)


def test_rosout_carries_the_log_lines(bridge: Any, graph_peer: GraphPeer) -> None:
    b = bridge({**SECTION, "node_name": "loud"}, SHAPER)
    b.node._log.warning("graph test line %d", 42)
    out = graph_peer({"node": fqn(b), "rosout": "graph test line 42"})
    ns = b.config.settings.namespace.strip("/").replace("/", ".")
    (line,) = [x for x in out["rosout"] if x["msg"] == "graph test line 42"]
    assert line["level"] == 30
    assert line["name"] == f"{ns}.loud"
    assert line["function"] == "test_rosout_carries_the_log_lines"


# ---------------------------------------------------------------- /parameter_events
_SRV = "rcl_interfaces/srv/"
_SPACES = itertools.count()


def _param(name: str, x: float) -> dict[str, Any]:
    value = {"__type__": "rcl_interfaces/msg/ParameterValue", "type": PARAM_TYPE_DOUBLE,
             "double_value": x}  # fmt: skip
    return {"__type__": "rcl_interfaces/msg/Parameter", "name": name, "value": value}


def test_parameter_events_at_start_and_on_every_set(
    bridge: Any, graph_peer: GraphPeer, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The peer subscribes to /parameter_events before the bridge starts: the start event lists
    every parameter as new; each accepted set_parameters entry is one changed event, a
    set_parameters_atomically one event for all; a refused set announces nothing.

    The bridge holds its start event until its writer has matched a first subscriber, for at
    most START_EVENT_WAIT (2 s); discovery on a loaded machine can take longer, so here the
    bound is lifted and the event waits for the match alone. The peer makes its calls only
    once the start event came: the writer has matched its reader, so no change event can be
    written before (to no one)."""
    monkeypatch.setattr(graph, "START_EVENT_WAIT", 600.0)
    ns = f"/{_SESSION}/pe{next(_SPACES)}"
    node = f"{ns}/velfence_bridge"
    calls = [
        ["set_parameters", _SRV + "SetParameters", {"parameters": [
            _param("incoming_command_timeout", 0.3), _param("watchdog_period", -1.0)]}],
        ["set_parameters_atomically", _SRV + "SetParametersAtomically", {"parameters": [
            _param("state_timeout", 1.5), _param("watchdog_period", 0.2)]}],
    ]  # fmt: skip
    spec = {"node": node, "ready": True, "events_before_calls": 1, "parameter_events": 3}
    graph_peer.send({**spec, "calls": calls})
    assert graph_peer.answer().get("ready") is True  # its reader exists: now start the bridge
    b = bridge({**SECTION, "namespace": ns}, SHAPER)
    out = graph_peer.answer()["result"]
    events = out["parameter_events"]
    assert [e["node"] for e in events] == [node] * 3
    start, one, both = events
    new = {p["name"]: p["value"] for p in start["new_parameters"]}
    assert set(new) == set(b.node._graph.parameters.names())
    ict = new["incoming_command_timeout"]
    assert (ict["type"], ict["double_value"]) == (PARAM_TYPE_DOUBLE, 0.1)
    assert new["command_in.topic"]["string_value"] == "cmd_in"
    assert start["changed_parameters"] == [] == start["deleted_parameters"]
    assert [(p["name"], p["value"]["double_value"]) for p in one["changed_parameters"]] == [
        ("incoming_command_timeout", 0.3)
    ]
    assert one["new_parameters"] == []
    assert [(p["name"], p["value"]["double_value"]) for p in both["changed_parameters"]] == [
        ("state_timeout", 1.5),
        ("watchdog_period", 0.2),
    ]
    stamps = [e["stamp"]["sec"] + e["stamp"]["nanosec"] * 1e-9 for e in events]
    assert stamps == sorted(stamps)
    assert stamps[0] > 1.6e9  # wall-clock time, as rclcpp stamps them


# ---------------------------------------------------------------- lifecycle over DDS, Nav2 bond
_LC = "lifecycle_msgs/srv/"


def _change(label: str) -> list[Any]:
    tid = {"configure": 1, "cleanup": 2, "activate": 3, "deactivate": 4}[label]
    tr = {"__type__": "lifecycle_msgs/msg/Transition", "id": tid, "label": ""}
    return ["call", label, "change_state", _LC + "ChangeState", {"transition": tr}]


_GET = ["call", "get_state", "get_state", _LC + "GetState",
        {"structure_needs_at_least_one_member": 0}]  # fmt: skip


def _at(events: list[dict[str, Any]], kind: str, label: str | None = None, n: int = 0) -> float:
    """The time of the n-th event of a kind (and label)."""
    ts = [e["t"] for e in events if e["kind"] == kind and (label is None or e["label"] == label)]
    return float(ts[n])


def _script(b: Any, script: list[Any]) -> dict[str, Any]:
    s = b.config.settings
    return {"node": fqn(b), "node_name": s.node_name, "namespace": s.namespace, "script": script}


def test_nav2_bond_formed_on_activate_broken_on_deactivate(
    bridge: Any, graph_peer: GraphPeer
) -> None:
    """The peer plays Nav2's lifecycle_manager with its defaults (bond_timeout 4 s, heartbeat
    0.25 s): configure, activate, get_state, then createBondConnection must form the bond
    within bond_timeout / 2; deactivate breaks it from the node's side. Then again, with the
    manager breaking first: the node acknowledges and stops."""
    b = bridge({**SECTION, "lifecycle": True}, SHAPER)
    script = [
        _change("configure"), _GET, _change("activate"), _GET,
        ["bond_start", 0.25, 4.0], ["bond_wait_formed", 2.0], ["pause", 1.0],
        _change("deactivate"), _GET, ["pause", 0.4],
        _change("activate"), ["bond_start", 0.25, 4.0], ["bond_wait_formed", 2.0],
        ["pause", 0.3], ["bond_break"], ["pause", 0.6],
    ]  # fmt: skip
    ev = graph_peer(_script(b, script), timeout=90.0)["script"]["events"]
    replies = [e["reply"] for e in ev if e["kind"] == "reply"]
    assert [r.get("success") for r in replies if "success" in r] == [True, True, True, True]
    assert [e["ok"] for e in ev if e["kind"] == "formed"] == [True, True]
    node = [e for e in ev if e["kind"] == "bond"]
    # Nothing before the first activation; the heartbeat fields as Nav2's node side sends them.
    assert min(e["t"] for e in node) >= _at(ev, "call", "activate")
    assert {(e["heartbeat_period"], e["heartbeat_timeout"]) for e in node} == {(0.25, 4.0)}
    first = [e for e in node if e["t"] < _at(ev, "call", "activate", 1)]
    second = [e for e in node if e["t"] >= _at(ev, "call", "activate", 1)]
    assert len({e["instance_id"] for e in first}) == 1
    assert len({e["instance_id"] for e in second}) == 1
    assert first[0]["instance_id"] != second[0]["instance_id"]
    # Alive: heartbeats all through the manager's second of watching, far inside its timeout.
    t_formed, t_deact = _at(ev, "bond_formed"), _at(ev, "call", "deactivate")
    alive = [e["t"] for e in first if e["active"] and t_formed <= e["t"] <= t_deact]
    assert len(alive) >= 3
    assert max(b - a for a, b in itertools.pairwise([t_formed, *alive, t_deact])) < 2.0
    # Deactivate: the node says active=false (the manager sees it broken) and then nothing more
    # that is active; its false statuses stop within bondcpp's destructor wait.
    assert _at(ev, "bond_broken_by_node") >= t_deact
    falses = [e for e in first if not e["active"]]
    assert 1 <= len(falses) <= 4
    assert all(e["active"] for e in first if e["t"] < falses[0]["t"])
    assert not [e for e in first if e["active"] and e["t"] > falses[0]["t"]]
    # The manager breaks first: one acknowledgement from the node, then silence.
    t_break = _at(ev, "bond_break")
    after = [e for e in second if e["t"] > t_break]
    assert [e["active"] for e in after] == [False]
    assert _at(ev, "bond_ack") > t_break
    assert b.node._active is True  # a broken bond does not deactivate the node (as in Nav2)


def test_bond_disabled_with_zero_heartbeat_period(bridge: Any) -> None:
    b = bridge({**SECTION, "lifecycle": True, "bond_heartbeat_period": 0.0}, SHAPER)
    assert b.node._graph._bond_writer is None
    assert b.node._graph.parameters.get("bond_heartbeat_period") == 0.0


def test_inactive_node_answers_nothing_over_dds(bridge: Any, graph_peer: GraphPeer) -> None:
    """Commands stream over DDS the whole time: unconfigured and inactive, nothing comes out;
    active, every command is answered; on deactivate exactly one last zero, then silence.
    (Generous timeouts: a stalled peer on a busy machine must not cause watchdog zeros.)"""
    timeouts = {"incoming_command_timeout": 0.5, "state_timeout": 2.0}
    b = bridge({**SECTION, "lifecycle": True, **timeouts}, SHAPER)
    script = [
        ["stream", 50, [0.2, 0.1]], ["wait_matched"], ["pause", 0.4],
        _change("configure"), ["pause", 0.4],
        _change("activate"), ["wait_outputs", 10, 10.0],
        _change("deactivate"), ["pause", 0.5], ["stream", 0, None],
    ]  # fmt: skip
    res = graph_peer(_script(b, script), timeout=90.0)["script"]
    ev = res["events"]
    replies = [e["reply"]["success"] for e in ev if e["kind"] == "reply"]
    assert replies == [True, True, True]
    outs = [e for e in ev if e["kind"] == "out"]
    t_act, t_deact = _at(ev, "call", "activate"), _at(ev, "call", "deactivate")
    t_deact_reply = _at(ev, "reply", "deactivate")
    # Unconfigured then inactive, commands flowing for 0.8 s: not one output.
    sent_inactive = [e for e in ev if e["kind"] == "cmd" and _at(ev, "matched") <= e["t"] < t_act]
    assert len(sent_inactive) >= 20
    assert not [e for e in outs if e["t"] < t_act]
    active = [e for e in outs if t_act <= e["t"] and e["linear"] != [0.0, 0.0, 0.0]]
    assert len(active) >= 10
    assert all(e["linear"][0] > 0.0 for e in active)
    # Deactivate: the outputs from then on end with exactly one zero, and nothing follows it.
    late = [e for e in outs if e["t"] >= t_deact]
    zeros = [e for e in late if e["linear"] == [0.0, 0.0, 0.0] and e["angular"] == [0.0] * 3]
    assert len(zeros) == 1
    assert late
    assert late[-1] == zeros[0]
    sent_after = [e for e in ev if e["kind"] == "cmd" and e["t"] > t_deact_reply]
    assert len(sent_after) >= 15  # the stream went on for 0.5 s after the deactivate reply
    assert not [e for e in outs if e["t"] > zeros[0]["t"]]
