"""velfence.bridge.foxglove: the live view seen by a real WebSocket client, and the MCAP file.

The client is the ``websockets`` library speaking Foxglove's ``foxglove.sdk.v1`` subprotocol on
127.0.0.1 (port 0: a free port), or offering only the legacy name ``foxglove.websocket.v1``, which
the view's front admits. Protobuf messages are decoded with the schema the server
advertises (``_protowire``, independent of foxglove-sdk); MCAP files are read with the ``mcap``
package's reader.
"""

from __future__ import annotations

import base64
import contextlib
import json
import math
import struct
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

pytest.importorskip("foxglove", reason="velfence.bridge.foxglove needs the [ros] extra")
pytest.importorskip("websockets", reason="the WebSocket client of these tests (dev extra)")
pytest.importorskip("mcap", reason="the MCAP reader of these tests ([ros] extra)")

from _protowire import decode, descriptors
from mcap.reader import make_reader
from websockets.exceptions import InvalidStatus, WebSocketException
from websockets.sync.client import connect

from velfence.bridge.foxglove import (
    SCENE_TOPIC,
    STATUS_TOPIC,
    VELOCITY_TOPIC,
    FoxgloveView,
    _quaternion_x_to,
    record_trajectory,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry import ConvexPolygon, ConvexPolytope
from velfence.sim.runner import Trajectory

SQUARE = ConvexPolygon([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
PROTOCOL = "foxglove.sdk.v1"
LINE_LOOP, LINE_LIST = 1, 2  # foxglove.LinePrimitive.Type


def _rotate(q: tuple[float, float, float, float], v: np.ndarray) -> np.ndarray:
    """``v`` rotated by the unit quaternion ``q = (x, y, z, w)`` (the rotation-matrix route)."""
    x, y, z, w = q
    R = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    return R @ v


def _xyz(d: dict[str, Any]) -> np.ndarray:
    return np.array([d.get("x", 0.0), d.get("y", 0.0), d.get("z", 0.0)])


def _quat(d: dict[str, Any]) -> tuple[float, float, float, float]:
    return (d.get("x", 0.0), d.get("y", 0.0), d.get("z", 0.0), d.get("w", 0.0))


def _step(k: int) -> dict[str, Any]:
    """Step ``k`` of a made-up run: a point moving right, the shaper cutting the x speed."""
    return {
        "t": 0.01 * k,
        "state": [0.1 + 0.001 * k, -0.2],
        "command": [0.3, 0.4],
        "shaped": [0.1, 0.4],
        "zone": "edge",
        "active": ["edge 1", "edge 2"],
    }


# ------------------------------------------------------------------ the live view


def test_websocket_client_sees_channels_and_decodes_what_was_published(tmp_path: Path) -> None:
    record = tmp_path / "live.mcap"
    with FoxgloveView(port=0, fence=SQUARE, arrow_time=0.5, record=record) as view:
        assert view.port is not None
        assert view.port > 0
        assert view.url == f"ws://127.0.0.1:{view.port}"
        with connect(view.url, subprotocols=[PROTOCOL], open_timeout=5) as ws:
            assert ws.subprotocol == PROTOCOL
            info = json.loads(ws.recv(timeout=5))
            assert info["op"] == "serverInfo"
            assert info["name"] == "velfence"
            adv = json.loads(ws.recv(timeout=5))
            assert adv["op"] == "advertise"
            chans = {c["topic"]: c for c in adv["channels"]}
            assert set(chans) == {SCENE_TOPIC, STATUS_TOPIC, VELOCITY_TOPIC}
            scene = chans[SCENE_TOPIC]
            assert (scene["encoding"], scene["schemaEncoding"]) == ("protobuf", "protobuf")
            assert scene["schemaName"] == "foxglove.SceneUpdate"
            for topic, title in (
                (STATUS_TOPIC, "velfence.Status"),
                (VELOCITY_TOPIC, "velfence.Velocity"),
            ):
                c = chans[topic]
                assert (c["encoding"], c["schemaEncoding"]) == ("json", "jsonschema")
                assert json.loads(c["schema"])["title"] == title
            sub = {1: STATUS_TOPIC, 2: VELOCITY_TOPIC, 3: SCENE_TOPIC}
            ws.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "subscriptions": [
                            {"id": i, "channelId": chans[t]["id"]} for i, t in sub.items()
                        ],
                    }
                )
            )
            # The subscription reaches the server asynchronously: publish step k until one
            # step's three messages have all arrived (bounded: 200 steps).
            # Every message of one step has the same log time.
            got: dict[int, dict[str, bytes]] = {}
            done = None
            for k in range(200):
                view.publish(_step(k))
                try:
                    while True:
                        msg = ws.recv(timeout=0.05)
                        assert isinstance(msg, bytes)
                        assert msg[0] == 0x01
                        sid, log_time = struct.unpack_from("<IQ", msg, 1)
                        got.setdefault(log_time, {})[sub[sid]] = msg[13:]
                except TimeoutError:
                    pass
                done = next((lt for lt, m in got.items() if len(m) == 3), None)
                if done is not None:
                    break
            assert done is not None, "no step's three messages arrived after 200 steps"
    # The recording holds the same bytes the client received, and every published step.
    _, recorded = _read_mcap(record)
    assert len(recorded[STATUS_TOPIC]) == k + 1
    for topic in (STATUS_TOPIC, VELOCITY_TOPIC, SCENE_TOPIC):
        assert dict(recorded[topic])[done] == got[done][topic]
    status = json.loads(got[done][STATUS_TOPIC])
    step = _step(round(status["t"] / 0.01))
    assert status == {
        "t": step["t"],
        "zone": "edge",
        "active": ["edge 1", "edge 2"],
        "changed_by": pytest.approx(0.2, abs=1e-15),  # |(0.3, 0.4) - (0.1, 0.4)|
        "changed": True,
    }
    vel = json.loads(got[done][VELOCITY_TOPIC])
    assert vel["t"] == step["t"]
    assert vel["command"] == [0.3, 0.4]
    assert vel["shaped"] == [0.1, 0.4]
    assert vel["command_norm"] == pytest.approx(0.5)
    assert vel["shaped_norm"] == pytest.approx(math.hypot(0.1, 0.4))
    # The scene: decode the last SceneUpdate with the advertised schema.
    types = descriptors(base64.b64decode(scene["schema"]))
    update = decode(got[done][SCENE_TOPIC], "foxglove.SceneUpdate", types)
    ents = {e["id"]: e for e in update["entities"]}
    fence = ents["fence"]["lines"][0]
    assert fence.get("type", 0) == LINE_LOOP
    pts = np.array([_xyz(p) for p in fence["points"]])
    np.testing.assert_array_equal(pts[:, :2], SQUARE.corners)
    np.testing.assert_array_equal(pts[:, 2], 0.0)
    robot = ents["robot"]
    centre = _xyz(robot["spheres"][0]["pose"]["position"])
    np.testing.assert_allclose(centre, [*step["state"], 0.0], rtol=0, atol=1e-15)
    arrows = robot["arrows"]
    assert len(arrows) == 2
    for arrow, v in zip(arrows, ([0.3, 0.4, 0.0], [0.1, 0.4, 0.0]), strict=True):
        v = np.array(v)
        length = arrow["shaft_length"] + arrow["head_length"]
        assert length == pytest.approx(0.5 * np.linalg.norm(v))  # |v| · arrow_time
        tip = _rotate(_quat(arrow["pose"]["orientation"]), np.array([1.0, 0.0, 0.0]))
        np.testing.assert_allclose(tip, v / np.linalg.norm(v), atol=1e-12)


@pytest.mark.parametrize(
    "offered",
    [["foxglove.websocket.v1"], ["other.v9", "foxglove.websocket.v1"], [PROTOCOL, "x"]],
)
def test_a_legacy_client_gets_server_info_advertisements_and_data(offered: list[str]) -> None:
    # A client of the Foxglove WebSocket protocol before the SDK offers only its legacy name:
    # it is admitted with that name and speaks the same protocol (the server's own name
    # when it is offered).
    with FoxgloveView(port=0, fence=SQUARE) as view:
        assert view.url is not None
        with connect(view.url, subprotocols=offered, open_timeout=5) as ws:
            assert ws.subprotocol == (PROTOCOL if PROTOCOL in offered else "foxglove.websocket.v1")
            info = json.loads(ws.recv(timeout=5))
            assert info["op"] == "serverInfo"
            assert info["name"] == "velfence"
            adv = json.loads(ws.recv(timeout=5))
            assert adv["op"] == "advertise"
            chans = {c["topic"]: c for c in adv["channels"]}
            assert set(chans) == {SCENE_TOPIC, STATUS_TOPIC, VELOCITY_TOPIC}
            assert chans[STATUS_TOPIC]["encoding"] == "json"
            ws.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "subscriptions": [{"id": 7, "channelId": chans[STATUS_TOPIC]["id"]}],
                    }
                )
            )
            status = None
            for k in range(200):  # the subscription reaches the server asynchronously
                view.publish(_step(k))
                with contextlib.suppress(TimeoutError):
                    msg = ws.recv(timeout=0.05)
                    assert isinstance(msg, bytes)
                    assert msg[0] == 0x01
                    assert struct.unpack_from("<I", msg, 1)[0] == 7
                    status = json.loads(msg[13:])
                    break
            assert status is not None, "no message data after 200 steps"
            assert status["zone"] == "edge"


def test_a_client_offering_neither_name_is_refused_by_the_sdk() -> None:
    with FoxgloveView(port=0) as view:
        assert view.url is not None
        with pytest.raises(InvalidStatus) as err:
            connect(view.url, subprotocols=["foxglove.websocket.v2"], open_timeout=5)
        assert err.value.response.status_code == 400


def test_the_front_renames_only_the_legacy_offer() -> None:
    from velfence.bridge._foxglove_front import rename_request, rename_response

    req = (
        b"GET / HTTP/1.1\r\nHost: x\r\nSec-WebSocket-Key: k\r\n"
        b"sec-websocket-protocol: a, foxglove.websocket.v1\r\n\r\n"
    )
    head, legacy = rename_request(req)
    assert legacy
    assert head.endswith(b"Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n")
    assert b"a, foxglove.websocket.v1" not in head
    assert b"Sec-WebSocket-Key: k" in head
    both = req.replace(b"a, ", b"foxglove.sdk.v1, ")
    assert rename_request(both) == (both, False)
    ok = b"HTTP/1.1 101 Switching Protocols\r\nSec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n"
    assert rename_response(ok).endswith(b"Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n")
    refused = b"HTTP/1.1 400 Bad Request\r\nContent-Length: 3\r\n\r\n"
    assert rename_response(refused) == refused


def test_closing_stops_the_server() -> None:
    view = FoxgloveView(port=0, host="localhost")
    url = view.url
    assert url is not None
    with connect(url, subprotocols=[PROTOCOL], open_timeout=5):
        pass
    view.close()
    view.close()  # idempotent
    assert view.closed
    assert view.port is None
    # No session can be opened any more: the port refuses, or (while the server's tasks wind
    # down) the connection is reset before the handshake completes.
    with pytest.raises((OSError, WebSocketException)):
        connect(url, subprotocols=[PROTOCOL], open_timeout=5)
    with pytest.raises(InvalidInput, match="closed"):
        view.publish(_step(0))


# ------------------------------------------------------------------ MCAP


def _read_mcap(path: Path) -> tuple[dict[str, Any], dict[str, list[tuple[int, bytes]]]]:
    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        channels = {c.topic: (c, summary.schemas[c.schema_id]) for c in summary.channels.values()}
        msgs: dict[str, list[tuple[int, bytes]]] = {}
        for _schema, channel, message in reader.iter_messages(log_time_order=True):
            msgs.setdefault(channel.topic, []).append((message.log_time, message.data))
    return channels, msgs


def test_mcap_record_holds_the_same_channels_and_messages(tmp_path: Path) -> None:
    box = ConvexPolytope.box([0.0, 0.0, 0.0], [0.4, 0.3, 0.2])
    path = tmp_path / "run.mcap"
    with FoxgloveView(port=None, record=path, fence=box) as view:
        assert view.port is None
        assert view.url is None
        for k in range(5):
            view.publish(
                {
                    "t": 0.01 * k,
                    "state": [0.1, 0.1, 0.1],
                    "command": [0.0, 0.0, 0.2],
                    "shaped": [0.0, 0.0, 0.2],
                    "zone": "inside",
                }
            )
    channels, msgs = _read_mcap(path)
    assert {t: (c.message_encoding, s.name, s.encoding) for t, (c, s) in channels.items()} == {
        SCENE_TOPIC: ("protobuf", "foxglove.SceneUpdate", "protobuf"),
        STATUS_TOPIC: ("json", "velfence.Status", "jsonschema"),
        VELOCITY_TOPIC: ("json", "velfence.Velocity", "jsonschema"),
    }
    assert len(msgs[STATUS_TOPIC]) == 5
    assert len(msgs[VELOCITY_TOPIC]) == 5
    assert len(msgs[SCENE_TOPIC]) == 6  # the fence alone at the start, then one per step
    times = np.array([t for t, _ in msgs[STATUS_TOPIC]])
    np.testing.assert_array_equal(np.diff(times), 10_000_000)  # 0.01 s apart [ns]
    status = [json.loads(d) for _, d in msgs[STATUS_TOPIC]]
    assert [s["changed"] for s in status] == [False] * 5
    assert [s["changed_by"] for s in status] == [0.0] * 5
    assert status[0]["active"] == []
    assert status[0]["zone"] == "inside"
    # The fence: the box's 12 edges as a line list, each edge a box edge.
    types = descriptors(channels[SCENE_TOPIC][1].data)
    first = decode(msgs[SCENE_TOPIC][0][1], "foxglove.SceneUpdate", types)
    (fence,) = first["entities"]
    line = fence["lines"][0]
    assert line["type"] == LINE_LIST
    pts = np.array([_xyz(p) for p in line["points"]]).reshape(-1, 2, 3)
    assert pts.shape == (12, 2, 3)
    corners = {(x, y, z) for x in (0.0, 0.4) for y in (0.0, 0.3) for z in (0.0, 0.2)}
    for a, b in pts:
        assert tuple(np.round(a, 12)) in corners
        assert tuple(np.round(b, 12)) in corners
        assert np.count_nonzero(np.abs(a - b) > 1e-12) == 1  # parallel to one axis
    lengths = sorted(float(np.linalg.norm(a - b)) for a, b in pts)
    np.testing.assert_allclose(lengths, [0.2] * 4 + [0.3] * 4 + [0.4] * 4, atol=1e-12)
    last = decode(msgs[SCENE_TOPIC][-1][1], "foxglove.SceneUpdate", types)
    robot = {e["id"]: e for e in last["entities"]}["robot"]
    np.testing.assert_allclose(_xyz(robot["spheres"][0]["pose"]["position"]), [0.1, 0.1, 0.1])
    (up, _) = robot["arrows"]
    tip = _rotate(_quat(up["pose"]["orientation"]), np.array([1.0, 0.0, 0.0]))
    np.testing.assert_allclose(tip, [0.0, 0.0, 1.0], atol=1e-12)


def test_record_trajectory_replays_a_run(tmp_path: Path) -> None:
    n = 11
    t = 0.1 * np.arange(n)
    p = np.column_stack([0.05 * np.arange(n), np.zeros(n)])
    v_cmd = np.tile([0.5, 0.0], (n, 1))
    v_out = np.column_stack([np.linspace(0.5, 0.0, n), np.zeros(n)])
    zone = np.array(["inside"] * 6 + ["buffer"] * 5)
    traj = Trajectory(t, p, v_cmd, v_out, zone=zone, name="run")
    out = record_trajectory(traj, tmp_path / "traj.mcap", fence=SQUARE, every=4)
    assert out == tmp_path / "traj.mcap"
    _, msgs = _read_mcap(out)
    vel = [json.loads(d) for _, d in msgs[VELOCITY_TOPIC]]
    assert [round(v["t"], 12) for v in vel] == [0.0, 0.4, 0.8, 1.0]  # rows 0, 4, 8 and the last
    assert [v["shaped"] for v in vel] == [v_out[k].tolist() for k in (0, 4, 8, 10)]
    zones = [json.loads(d)["zone"] for _, d in msgs[STATUS_TOPIC]]
    assert zones == ["inside", "inside", "buffer", "buffer"]


# ------------------------------------------------------------------ refusals


@pytest.mark.parametrize("host", ["0.0.0.0", "192.168.1.20", "example.org", "::"])
def test_non_loopback_hosts_are_refused_without_allow_remote(host: str) -> None:
    with pytest.raises(InvalidParameter, match="allow_remote=True"):
        FoxgloveView(host=host, port=0)


def test_bad_arguments_are_refused(tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match="port"):
        FoxgloveView(port=70000)
    with pytest.raises(InvalidParameter, match="port"):
        FoxgloveView(port=True)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="record"):
        FoxgloveView(port=None)
    existing = tmp_path / "x.mcap"
    existing.write_bytes(b"")
    with pytest.raises(InvalidParameter, match="exists"):
        FoxgloveView(port=None, record=existing)
    with pytest.raises(InvalidGeometry, match="unbounded"):
        FoxgloveView(
            port=None, record=tmp_path / "a.mcap", fence=ConvexPolytope([[0.0, 0.0, 1.0]], [0.0])
        )
    with pytest.raises(InvalidGeometry, match="4 dimensions"):
        FoxgloveView(
            port=None, record=tmp_path / "b.mcap", fence=ConvexPolytope.box(np.zeros(4), np.ones(4))
        )
    with pytest.raises(InvalidGeometry, match="ConvexPolygon"):
        FoxgloveView(port=None, record=tmp_path / "c.mcap", fence=[[0, 0], [1, 0], [0, 1]])  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="arrow_time"):
        FoxgloveView(port=None, record=tmp_path / "d.mcap", arrow_time=0.0)


def test_a_port_in_use_is_refused_naming_the_port() -> None:
    with (
        FoxgloveView(port=0) as first,
        pytest.raises(
            InvalidParameter, match=f"port: cannot start the server on 127.0.0.1:{first.port}"
        ),
    ):
        FoxgloveView(port=first.port)


def test_publish_refuses_malformed_steps(tmp_path: Path) -> None:
    with FoxgloveView(port=None, record=tmp_path / "x.mcap") as view:
        good = _step(1)
        for key, bad, match in [
            ("t", math.nan, "info.t"),
            ("t", -1.0, "info.t"),
            ("state", "abc", "info.state"),
            ("command", [1.0, math.inf], "info.command"),
            ("shaped", [1.0, 2.0, 3.0], "info.shaped"),
            ("zone", 3, "info.zone"),
            ("active", "edge 1", "info.active"),
            ("active", [1], r"info.active\[0\]"),
        ]:
            with pytest.raises(InvalidInput, match=match):
                view.publish({**good, key: bad})
        missing = dict(good)
        del missing["shaped"]
        with pytest.raises(InvalidInput, match=r"info\.shaped: missing"):
            view.publish(missing)
        view.publish(good)  # still usable after the refusals


def test_joint_vectors_go_to_the_json_channels_only(tmp_path: Path) -> None:
    path = tmp_path / "joints.mcap"
    with FoxgloveView(port=None, record=path, fence=SQUARE) as view:
        # an object with attributes works as well as a mapping
        step = SimpleNamespace(t=0.0, state=np.zeros(6), command=np.ones(6), shaped=np.ones(6))
        view.publish(step)
    channels, msgs = _read_mcap(path)
    types = descriptors(channels[SCENE_TOPIC][1].data)
    last = decode(msgs[SCENE_TOPIC][-1][1], "foxglove.SceneUpdate", types)
    assert [e["id"] for e in last["entities"]] == ["fence"]  # no robot point for 6 joints
    assert json.loads(msgs[VELOCITY_TOPIC][0][1])["command"] == [1.0] * 6


@pytest.mark.parametrize(
    "v", [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -2.0, 0.0], [0.3, -0.2, 0.9], [-1.0, 1e-12, 0.0]]
)
def test_arrow_orientation_turns_x_onto_the_velocity(v: list[float]) -> None:
    q = _quaternion_x_to(np.array(v))
    assert math.isclose(float(np.linalg.norm(q)), 1.0, rel_tol=1e-12)
    v = np.array(v)
    np.testing.assert_allclose(
        _rotate(q, np.array([1.0, 0.0, 0.0])), v / np.linalg.norm(v), atol=1e-9
    )
