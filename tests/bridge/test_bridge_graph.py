"""The bridge in the ROS 2 graph: discovery info, parameters, lifecycle and /rosout.

The peer (ros_graph_client.py, its own process) encodes every request and decodes every reply,
discovery and log sample with rosbags' typestore from the published definitions
(ros_graph_defs.py), never with velfence's message classes.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from ros_graph_defs import typestore

from conftest import DOMAIN, LOOPBACK, SRC
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


def peer(spec: dict[str, Any], tmp_path: Path, timeout: float = 60.0) -> dict[str, Any]:
    path = tmp_path / f"graph-{os.urandom(4).hex()}.json"
    path.write_text(json.dumps({"domain": DOMAIN, **spec}), encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(SRC), "CYCLONEDDS_URI": LOOPBACK}
    proc = subprocess.run(
        [sys.executable, str(CLIENT), str(path)],
        capture_output=True,
        text=True,
        env=env,
        timeout=timeout,
        check=False,
    )
    if proc.returncode != 0:
        raise AssertionError(f"graph client failed ({proc.returncode}): {proc.stderr[-3000:]}")
    out: dict[str, Any] = json.loads(proc.stdout)
    return out


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
    bridge: Any, tmp_path: Path, distro: str
) -> None:
    b = bridge({**SECTION, "ros_distro": distro, "node_name": "fence"}, SHAPER)
    out = peer(
        {"node": fqn(b), "node_name": "fence", "discovery": True, "distro": distro}, tmp_path
    )
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


def test_parameters_list_get_describe_set(bridge: Any, tmp_path: Path) -> None:
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
    out = peer({"node": fqn(b), "calls": calls}, tmp_path)
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


def test_lifecycle_nav2_manager_sequence(bridge: Any, tmp_path: Path) -> None:
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
    out = peer({"node": fqn(b), "calls": calls}, tmp_path)
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


def test_rosout_carries_the_log_lines(bridge: Any, tmp_path: Path) -> None:
    b = bridge({**SECTION, "node_name": "loud"}, SHAPER)
    b.node._log.warning("graph test line %d", 42)
    out = peer({"node": fqn(b), "rosout": "graph test line 42"}, tmp_path)
    ns = b.config.settings.namespace.strip("/").replace("/", ".")
    (line,) = [x for x in out["rosout"] if x["msg"] == "graph test line 42"]
    assert line["level"] == 30
    assert line["name"] == f"{ns}.loud"
    assert line["function"] == "test_rosout_carries_the_log_lines"
