"""velfence.apps.viewer.web: the viser web view, its checks in front of viser, and its scenes.

The refusals are tested with plain clients (http.client, a raw socket, the ``websockets``
client), as a hostile page or a rebinding DNS name would send them.
"""

from __future__ import annotations

import http.client
import json
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

pytest.importorskip("viser", reason="viser not installed (extra web)")

from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import connect

from velfence.apps.viewer.view import SCENES, scene_session, serve_scene
from velfence.apps.viewer.web import WebView
from velfence.errors import InvalidInput, InvalidParameter

VISER_PROTOCOL = "viser-v" + __import__("viser").__version__


@pytest.fixture(scope="module")
def view() -> Iterator[WebView]:
    with serve_scene("arm-box", realtime=False) as v:
        yield v


def _request(
    port: int, method: str, path: str, headers: dict[str, str], body: Any = None
) -> tuple[int, dict[str, str], bytes]:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        conn.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
        data = b"" if body is None else json.dumps(body).encode()
        for k, v in headers.items():
            conn.putheader(k, v)
        if body is not None:
            conn.putheader("Content-Type", "application/json")
            conn.putheader("Content-Length", str(len(data)))
        conn.endheaders(data if body is not None else None)
        r = conn.getresponse()
        return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read()
    finally:
        conn.close()


def _ws(view: WebView, *, port: int | None = None, **headers: str) -> Any:
    p = view.port if port is None else port
    return connect(
        f"ws://127.0.0.1:{p}",
        subprotocols=[VISER_PROTOCOL],  # type: ignore[list-item]
        additional_headers=headers,
        open_timeout=10,
    )


# ---------------------------------------------------------------------------------- HTTP
def test_page_is_viser_client_with_key_script_and_no_framing(view: WebView) -> None:
    host = f"127.0.0.1:{view.port}"
    status, headers, body = _request(view.port, "GET", "/", {"Host": host})
    assert status == 200
    assert b'id="velfence-status"' in body
    assert b'"/key"' in body
    assert b"<title>Viser</title>" in body  # viser's built client
    assert headers["x-frame-options"] == "DENY"
    assert "frame-ancestors 'none'" in headers["content-security-policy"]
    assert view.viser_port not in (0, view.port)


@pytest.mark.parametrize("host", ["evil.example:{port}", "127.0.0.1:1", "localhost.evil:{port}"])
def test_wrong_host_refused(view: WebView, host: str) -> None:
    status, headers, body = _request(view.port, "GET", "/", {"Host": host.format(port=view.port)})
    assert status == 403
    assert "Host" in json.loads(body)["error"]
    assert headers["x-frame-options"] == "DENY"


def test_foreign_origin_post_refused_and_own_origin_accepted(view: WebView) -> None:
    host = f"127.0.0.1:{view.port}"
    status, _, body = _request(
        view.port, "POST", "/key", {"Host": host, "Origin": "http://evil.example"}, {"key": "C"}
    )
    assert status == 403
    assert "Origin" in json.loads(body)["error"]
    before = view.state()["clutch"]
    status, _, _ = _request(
        view.port, "POST", "/key", {"Host": host, "Origin": f"http://{host}"}, {"key": "C"}
    )
    assert status == 200
    assert view.state()["clutch"] is (not before)
    view.press("C")  # back


# ---------------------------------------------------------------------------------- websocket
def test_websocket_through_the_front_port_reaches_viser(view: WebView) -> None:
    with _ws(view, Origin=f"http://127.0.0.1:{view.port}") as ws:
        assert ws.subprotocol == VISER_PROTOCOL
        first = ws.recv(timeout=10)  # the scene's persistent messages are replayed at once
        assert isinstance(first, bytes)
        assert len(first) > 0


@pytest.mark.parametrize("origin", ["http://evil.example", "null", "http://127.0.0.1:1"])
def test_websocket_with_foreign_origin_refused(view: WebView, origin: str) -> None:
    with pytest.raises(InvalidStatus) as info:
        _ws(view, Origin=origin)
    assert info.value.response.status_code == 403
    assert info.value.response.headers["X-Frame-Options"] == "DENY"


def test_websocket_with_wrong_host_refused(view: WebView) -> None:
    # A raw handshake: a rebinding DNS name reaches loopback with its own Host.
    with socket.create_connection(("127.0.0.1", view.port), timeout=10) as s:
        s.sendall(
            b"GET / HTTP/1.1\r\nHost: attacker.example:%d\r\nUpgrade: websocket\r\n"
            b"Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
            b"Sec-WebSocket-Version: 13\r\n\r\n" % view.port
        )
        reply = b""
        while chunk := s.recv(4096):
            reply += chunk
    assert reply.startswith(b"HTTP/1.1 403") or reply.startswith(b"HTTP/1.0 403")


def test_websocket_straight_to_viser_port_is_closed(view: WebView) -> None:
    # The internal port accepts the handshake (viser has no hook there) but its connect
    # callback closes a connection without the front server's secret: policy violation.
    got: list[Any] = []

    def drain() -> None:
        with _ws(view, port=view.viser_port, **{"X-Velfence-Proxy": "guess"}) as ws:
            while True:
                got.append(ws.recv(timeout=10))

    with pytest.raises(ConnectionClosed) as info:
        drain()
    assert got == []  # closed before viser sent any of the scene
    assert info.value.rcvd is not None
    assert info.value.rcvd.code == 1008


# ---------------------------------------------------------------------------------- API + clock
def test_json_api_and_step(view: WebView) -> None:
    host = {"Host": f"localhost:{view.port}"}
    status, _, body = _request(view.port, "GET", "/scene", host)
    scene = json.loads(body)
    assert status == 200
    assert [p["type"] for p in scene] == ["box", "sphere"]
    t0 = view.state()["t"]
    status, _, body = _request(view.port, "POST", "/step", host, {"dt": 0.05})
    assert status == 200
    assert json.loads(body)["t"] == pytest.approx(t0 + 0.05, abs=1e-9)
    status, _, body = _request(view.port, "POST", "/key", host, {"key": "G"})
    assert status == 400
    assert "not used in the arm-box scene" in json.loads(body)["error"]


def test_clock_waits_for_a_client_then_runs() -> None:
    with serve_scene("arm-box") as v:
        deadline = time.monotonic() + 0.3
        while time.monotonic() < deadline:  # no client: the clock must stay at 0
            assert v.state()["t"] == 0.0
        assert not v.started
        status, _, _ = _request(v.port, "GET", "/", {"Host": f"127.0.0.1:{v.port}"})
        assert status == 200
        assert v.started
        deadline = time.monotonic() + 10.0
        while v.state()["t"] == 0.0:
            assert time.monotonic() < deadline, "the clock did not start after the page was fetched"
            time.sleep(0.01)


def test_start_true_runs_at_once() -> None:
    with serve_scene("arm-box", start=True) as v:
        deadline = time.monotonic() + 10.0
        while v.state()["t"] == 0.0:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        assert v.started


# ---------------------------------------------------------------------------------- scenes
def test_arm_box_jog_into_face_is_shaped_and_stays_inside() -> None:
    s = scene_session("arm-box")
    x0 = np.array(s.snapshot()["tcp"])
    s.jog([0.3, 0.0, 0.0], [0.0, 0.0, 0.0])  # toward x_max = 0.80, 0.14 m away
    s.advance(1.5)
    snap = s.snapshot()
    assert snap["commanded"] == [0.3, 0.0, 0.0]
    assert snap["min_margin"] >= -1e-9  # never outside the box
    assert snap["tcp"][0] == pytest.approx(0.80, abs=0.03)  # it went all the way to the face
    assert np.linalg.norm(snap["shaped"]) < 0.05  # and is held there: shaped << commanded
    assert snap["tcp"][0] > x0[0] + 0.1


def test_arm_box_autopilot_and_clutch() -> None:
    s = scene_session("arm-box")
    s.press("C")
    s.jog([0.2, 0.0, 0.0], [0.0, 0.0, 0.0])
    q0 = np.array(s.snapshot()["q"])
    s.advance(0.2)
    assert np.array_equal(np.array(s.snapshot()["q"]), q0)  # clutch released: no motion
    s.press("A")
    s.advance(0.5)
    snap = s.snapshot()
    assert snap["mode"] == "autopilot"
    assert np.linalg.norm(snap["commanded"]) > 0.1
    with pytest.raises(InvalidInput, match="not used in the arm-box scene"):
        s.press("T")


def test_teleop_scene_adds_velocities() -> None:
    s = scene_session("teleop")
    snap = s.snapshot()
    assert {"tcp", "commanded", "shaped", "mode", "laser"} <= set(snap)
    assert snap["tcp"] == [row[3] for row in snap["tool"][:3]]


def test_scene_names() -> None:
    assert SCENES == ("teleop", "arm-box", "fence-box")
    with pytest.raises(InvalidParameter, match="scene must be one of"):
        scene_session("box")
    with pytest.raises(InvalidParameter, match="frame_rate"):
        WebView(scene_session("arm-box"), frame_rate=0.0)


def test_fence_box_scene_in_mujoco() -> None:
    pytest.importorskip("mujoco")
    s = scene_session("fence-box")
    s.press("A")
    s.advance(1.0)
    snap = s.snapshot()
    assert snap["min_margin"] >= -0.01
    assert len(snap["joints"]) == 8


def test_failed_start_stops_both_servers() -> None:
    import threading

    class Broken:
        def __getattr__(self, name: str) -> Any:
            return getattr(inner, name)

        def scene_primitives(self) -> list[dict[str, Any]]:
            raise RuntimeError("no scene")

    inner = scene_session("arm-box")
    before = {t.name for t in threading.enumerate()}
    with pytest.raises(RuntimeError, match="no scene"):
        WebView(Broken())  # type: ignore[arg-type]
    deadline = time.monotonic() + 10.0
    while {t.name for t in threading.enumerate() if t.is_alive()} - before:
        assert time.monotonic() < deadline, "a server thread outlived the failed start"
        time.sleep(0.01)


def test_cli_view(monkeypatch: pytest.MonkeyPatch) -> None:
    from typer.testing import CliRunner

    import velfence.apps.viewer.view
    from velfence.apps import cli

    bad = CliRunner().invoke(cli.app, ["view", "--scenario", "box", "--no-browser"])
    assert bad.exit_code != 0
    assert "scene must be one of" in bad.output

    calls: dict[str, Any] = {}

    class Server:
        url = "http://127.0.0.1:9/"
        stopped = False

        def wait(self, timeout: float) -> bool:
            raise KeyboardInterrupt

        def stop(self) -> None:
            Server.stopped = True

    def fake(scene: str, **kwargs: Any) -> Server:
        calls.update(kwargs, scene=scene)
        return Server()

    monkeypatch.setattr(velfence.apps.viewer.view, "serve_scene", fake)
    ok = CliRunner().invoke(
        cli.app, ["view", "--scenario", "fence-box", "--port", "0", "--start", "--no-browser"]
    )
    assert ok.exit_code == 0, ok.output
    assert calls == {"scene": "fence-box", "port": 0, "start": True}
    assert Server.stopped
    # The option's former name: the same values, a warning on stderr.
    calls.clear()
    old = CliRunner().invoke(cli.app, ["view", "--scene", "arm-box", "--port", "0", "--no-browser"])
    assert old.exit_code == 0, old.output
    assert calls == {"scene": "arm-box", "port": 0, "start": False}
    assert "--scene is now --scenario" in old.stderr
    assert "goes in 0.3" in old.stderr
    assert "http://127.0.0.1:9/" in ok.output


def test_import_velfence_does_not_import_viser() -> None:
    code = "import sys, velfence, velfence.apps.viz; print('viser' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
