"""The local web viewer: HTTP API on 127.0.0.1, scripted driver, scene dicts, CLI command.

Hermetic: every server binds 127.0.0.1 on a free port and is stopped by its test; the session
advances on request (``realtime=False``) except in the tests of the real-time thread, which
synchronise on events set by the fake session instead of sleeping.
"""

from __future__ import annotations

import importlib.resources
import json
import math
import shutil
import socket
import subprocess
import sys
import threading
import types
import urllib.error
import urllib.request
from collections.abc import Iterator
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from velfence.apps.teleop.scene import pick_and_place_scene, scene_to_dicts
from velfence.apps.teleop.session import Session
from velfence.apps.viewer.server import (
    ALLOWED_KEYS,
    HOST,
    ScriptedDriver,
    ViewerServer,
    serve,
)
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError

EVENT_TIMEOUT = 10.0  # [s] upper bound when waiting on the real-time thread; never reached


class FakeSession:
    """Records keys, jogs and advances; the tool point integrates the jog while the clutch is on."""

    def __init__(self) -> None:
        self.t = 0.0
        self.mode = "teleop"
        self.clutch = False
        self.keys: list[str] = []
        self.jogs: list[tuple[list[float], list[float]]] = []
        self.advances: list[float] = []
        self.position = np.array([0.4, 0.15, 0.0])
        self.velocity = np.zeros(3)
        self.advanced = threading.Event()
        self.zero_jog_after_motion = threading.Event()
        self.fail_with: BaseException | None = None

    def press(self, key: str) -> None:
        if self.fail_with is not None:
            raise self.fail_with
        self.keys.append(key)
        if key == "C":
            self.clutch = not self.clutch
        else:
            self.mode = key

    def jog(self, linear: Any, angular: Any) -> None:
        lin = np.asarray(linear, dtype=float)
        if not np.any(lin) and np.any(self.velocity):
            self.zero_jog_after_motion.set()
        self.velocity = lin
        self.jogs.append((lin.tolist(), np.asarray(angular, dtype=float).tolist()))

    def advance(self, dt: float) -> None:
        self.advances.append(dt)
        self.t += dt
        if self.clutch:
            self.position = self.position + self.velocity * dt
        self.advanced.set()

    def snapshot(self) -> dict[str, Any]:
        tool = np.eye(4)
        tool[:3, 3] = self.position
        return {
            "t": self.t,
            "mode": self.mode,
            "clutch": self.clutch,
            "q": [0.0, 0.1, 0.2, 0.3, 0.4, 0.5],
            "joints": [[0.0, 0.0, 0.0], [0.2, 0.15, 0.0], self.position.tolist()],
            "tool": tool.tolist(),
            "laser": {"origin": self.position.tolist(), "point": None},
            "fixture": None,
            "status": f"{len(self.keys)} keys",
            "task": {"destination": None},
        }

    def scene_primitives(self) -> list[dict[str, Any]]:
        return scene_to_dicts(pick_and_place_scene())


@pytest.fixture
def fake() -> FakeSession:
    return FakeSession()


@pytest.fixture
def server(fake: FakeSession) -> Iterator[ViewerServer]:
    srv = serve(fake, realtime=False)
    try:
        yield srv
    finally:
        srv.stop()


def _call(
    server: ViewerServer,
    method: str,
    path: str,
    body: Any = None,
    *,
    raw: bytes | None = None,
    headers: dict[str, str] | None = None,
) -> tuple[int, Any]:
    data = raw if raw is not None else (None if body is None else json.dumps(body).encode())
    req = urllib.request.Request(server.url.rstrip("/") + path, data=data, method=method)
    if data is not None and not (headers and "Content-Type" in headers):
        req.add_header("Content-Type", "application/json")
    for k, v in (headers or {}).items():
        req.add_header(k, v)
    try:
        with urllib.request.urlopen(req, timeout=10) as resp:
            payload = resp.read()
            ctype = resp.headers.get("Content-Type", "")
            return resp.status, json.loads(payload) if "json" in ctype else payload.decode()
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


# ------------------------------------------------------------------------------ GET


def test_server_binds_loopback_only(server: ViewerServer) -> None:
    assert server.url == f"http://127.0.0.1:{server.port}/"
    assert server.port > 0
    assert not server.realtime
    assert "step-on-request" in repr(server)
    assert HOST == "127.0.0.1"


def test_state_round_trip(server: ViewerServer, fake: FakeSession) -> None:
    status, state = _call(server, "GET", "/state")
    assert status == 200
    viewer = state.pop("viewer")
    assert state == json.loads(json.dumps(fake.snapshot()))
    assert viewer == {
        "realtime": False,
        "jog": {"linear": [0.0, 0.0, 0.0], "angular": [0.0, 0.0, 0.0]},
        "error": None,
        "started": True,
    }


def test_state_makes_numpy_and_non_finite_values_json(
    server: ViewerServer, fake: FakeSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    snap = fake.snapshot()
    snap.update(q=np.arange(6.0), t=np.float64(1.5), task={"n": np.int64(3), "d": float("nan")})
    monkeypatch.setattr(fake, "snapshot", lambda: snap)
    status, state = _call(server, "GET", "/state")
    assert status == 200
    assert state["q"] == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    assert state["t"] == 1.5
    assert state["task"] == {"n": 3, "d": None}


def test_scene_endpoint(server: ViewerServer) -> None:
    status, scene = _call(server, "GET", "/scene")
    assert status == 200
    assert scene == scene_to_dicts(pick_and_place_scene())


def test_page_has_canvas_keys_and_endpoints(server: ViewerServer) -> None:
    status, page = _call(server, "GET", "/")
    assert status == 200
    assert "<canvas" in page
    for needle in ('fetch("/state"', '"/key"', '"/jog"', 'fetch("/scene")', "PageUp", "clutch"):
        assert needle in page
    for key in ALLOWED_KEYS:
        assert f'<td class="k">{key}</td>' in page


# ------------------------------------------------------------------------------ the page file
PAGE_FILE = "static/viewer.html"


class _PageParser(HTMLParser):
    """Collects the page's ``<script>`` and ``<style>`` elements: attributes and text."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.elements: list[tuple[str, dict[str, str | None], str]] = []
        self._open: tuple[str, dict[str, str | None]] | None = None
        self._text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag in ("script", "style"):
            self._open, self._text = (tag, dict(attrs)), []

    def handle_data(self, data: str) -> None:
        if self._open is not None:
            self._text.append(data)

    def handle_endtag(self, tag: str) -> None:
        if self._open is not None and tag == self._open[0]:
            self.elements.append((*self._open, "".join(self._text)))
            self._open = None


def _page_file_text() -> str:
    resource = importlib.resources.files("velfence.apps.viewer").joinpath(PAGE_FILE)
    assert resource.is_file(), f"velfence/apps/viewer/{PAGE_FILE} is not in the installed package"
    return resource.read_text(encoding="utf-8")


def _page_script() -> str:
    parser = _PageParser()
    parser.feed(_page_file_text())
    parser.close()
    scripts = [(attrs, text) for tag, attrs, text in parser.elements if tag == "script"]
    assert len(scripts) == 1, scripts
    attrs, text = scripts[0]
    assert attrs == {}  # inline, no src: the CSP allows it by hash
    return text


def test_page_is_package_data_and_is_what_the_server_sends(server: ViewerServer) -> None:
    status, page = _call(server, "GET", "/")
    assert status == 200
    assert page == _page_file_text()


def test_page_script_binds_the_documented_keys() -> None:
    script = _page_script()
    assert 'const MODE_KEYS = "ASFDGPTCH";' in script
    assert set("ASFDGPTCH") == set(ALLOWED_KEYS)
    # jog keys of the module docstring: Left/Right -x/+x, Down/Up -y/+y, PgDn/PgUp -z/+z
    for binding in (
        "ArrowRight: [0, 1]",
        "ArrowLeft: [0, -1]",
        "ArrowUp: [1, 1]",
        "ArrowDown: [1, -1]",
        "PageUp: [2, 1]",
        "PageDown: [2, -1]",
    ):
        assert binding in script, binding
    # U O / I K / J L turn about +-x / +-y / +-z
    for binding in (
        "KeyU: [0, 1]",
        "KeyO: [0, -1]",
        "KeyI: [1, 1]",
        "KeyK: [1, -1]",
        "KeyJ: [2, 1]",
        "KeyL: [2, -1]",
    ):
        assert binding in script, binding
    for call in ('post("/key", { key: ch })', '"/jog"', 'fetch("/state"', 'fetch("/scene")'):
        assert call in script, call
    for event in ('"keydown"', '"keyup"', '"blur"'):
        assert f"window.addEventListener({event}" in script, event


def test_page_script_is_valid_javascript(tmp_path: Path) -> None:
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed: the script's syntax is not checked")
    js = tmp_path / "viewer.js"
    js.write_text(_page_script(), encoding="utf-8")
    done = subprocess.run(
        [node, "--check", str(js)], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr


def test_node_check_catches_a_syntax_error(tmp_path: Path) -> None:
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed")
    js = tmp_path / "broken.js"
    js.write_text(
        _page_script().replace("function frame()", "function frame(", 1), encoding="utf-8"
    )
    done = subprocess.run([node, "--check", str(js)], capture_output=True, timeout=60, check=False)
    assert done.returncode != 0


def test_head_request(server: ViewerServer) -> None:
    req = urllib.request.Request(server.url + "state", method="HEAD")
    with urllib.request.urlopen(req, timeout=10) as resp:
        assert resp.status == 200
        assert resp.read() == b""


# ------------------------------------------------------------------------------ POST


def test_key_jog_step_delivery(server: ViewerServer, fake: FakeSession) -> None:
    assert _call(server, "POST", "/key", {"key": "c"}) == (200, {"ok": True, "key": "C"})
    assert _call(server, "POST", "/key", {"key": "H"}) == (200, {"ok": True, "key": "H"})
    status, body = _call(server, "POST", "/jog", {"linear": [0.1, 0, 0], "angular": [0, 0, 0.2]})
    assert status == 200
    assert body == {"ok": True, "linear": [0.1, 0.0, 0.0], "angular": [0.0, 0.0, 0.2]}
    assert fake.keys == ["C", "H"]
    assert fake.jogs[-1] == ([0.1, 0.0, 0.0], [0.0, 0.0, 0.2])
    assert _call(server, "POST", "/step", {"dt": 0.5}) == (200, {"ok": True, "t": 0.5})
    # the held jog is re-sent before the advance
    assert fake.jogs[-1] == ([0.1, 0.0, 0.0], [0.0, 0.0, 0.2])
    np.testing.assert_allclose(fake.position, [0.45, 0.15, 0.0])
    _, state = _call(server, "GET", "/state")
    assert state["clutch"] is True
    assert state["viewer"]["jog"]["linear"] == [0.1, 0.0, 0.0]
    # angular may be left out (zero)
    assert _call(server, "POST", "/jog", {"linear": [0, 0, 0]})[0] == 200
    assert fake.jogs[-1] == ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])


BAD_REQUESTS = [
    ("POST", "/key", {"key": "X"}, 400, "key: expected one of"),
    ("POST", "/key", {"key": 3}, 400, "key: expected one of"),
    ("POST", "/key", {"kee": "A"}, 400, "expected {'key': ...}"),
    ("POST", "/jog", {"linear": [1, 2]}, 400, "linear [m/s]: expected shape (3,), got shape (2,)"),
    ("POST", "/jog", {"linear": "abc"}, 400, "linear [m/s]: expected numbers of shape (3,)"),
    (
        "POST",
        "/jog",
        {"linear": [0, 0, 0], "angular": [0, 0, float("nan")]},
        400,
        "angular [rad/s]: expected finite values",
    ),
    ("POST", "/jog", {"linear": [2.0, 0, 0]}, 400, "at most 1 m/s"),
    ("POST", "/jog", {"angular": [0, 0, 0]}, 400, "expected {'linear'"),
    ("POST", "/step", {"dt": -1}, 400, "dt: expected a value in (0, 10] s, got -1"),
    ("POST", "/step", {"dt": "1"}, 400, "dt: expected a number"),
    ("POST", "/step", {"dt": 100.0}, 400, "dt: expected a value in (0, 10] s, got 100"),
    ("POST", "/step", {}, 400, "expected {'dt': seconds}"),
    ("POST", "/key", [1, 2], 400, "expected a JSON object"),
    ("POST", "/nope", {"key": "A"}, 404, "no such endpoint"),
    ("GET", "/nope", None, 404, "no such page"),
]


@pytest.mark.parametrize(("method", "path", "body", "code", "message"), BAD_REQUESTS)
def test_bad_requests_give_json_errors(
    server: ViewerServer,
    fake: FakeSession,
    method: str,
    path: str,
    body: Any,
    code: int,
    message: str,
) -> None:
    status, payload = _call(server, method, path, body)
    assert status == code
    assert message in payload["error"]
    assert fake.keys == []
    assert fake.advances == []


def test_malformed_bodies(server: ViewerServer) -> None:
    status, payload = _call(server, "POST", "/key", raw=b"{not json")
    assert (status, "expected JSON" in payload["error"]) == (400, True)
    status, payload = _call(
        server, "POST", "/key", raw=b'{"key": "A"}', headers={"Content-Type": "text/plain"}
    )
    assert status == 415
    assert "application/json" in payload["error"]
    status, payload = _call(server, "POST", "/key", raw=b"x" * 70000)
    assert status == 413


def test_foreign_host_header_is_refused(server: ViewerServer, fake: FakeSession) -> None:
    status, payload = _call(server, "POST", "/key", {"key": "A"}, headers={"Host": "evil.test"})
    assert status == 403
    assert "Host: expected 127.0.0.1:" in payload["error"]
    assert fake.keys == []
    status, _ = _call(server, "GET", "/state", headers={"Host": f"localhost:{server.port}"})
    assert status == 200


def _raw_http(server: ViewerServer, request: bytes) -> tuple[int, bytes]:
    """Send ``request`` as is on a new connection; the status code and the body."""
    with socket.create_connection((HOST, server.port), timeout=10) as conn:
        conn.sendall(request)
        reply = b""
        while chunk := conn.recv(65536):
            reply += chunk
    head, _, body = reply.partition(b"\r\n\r\n")
    return int(head.split()[1]), body


def test_post_without_host_header_is_refused(server: ViewerServer, fake: FakeSession) -> None:
    body = b'{"key": "A"}'
    request = (
        b"POST /key HTTP/1.0\r\nContent-Type: application/json\r\n"
        b"Content-Length: %d\r\n\r\n%s" % (len(body), body)
    )
    status, reply = _raw_http(server, request)
    assert status == 403
    assert json.loads(reply) == {
        "error": f"Host: expected 127.0.0.1:{server.port} or localhost:{server.port}, got None"
    }
    assert fake.keys == []
    # the same request naming this server is accepted; a read-only GET needs no Host
    named = request.replace(b"\r\n\r\n", f"\r\nHost: {HOST}:{server.port}\r\n\r\n".encode(), 1)
    assert _raw_http(server, named)[0] == 200
    assert fake.keys == ["A"]
    assert _raw_http(server, b"GET /state HTTP/1.0\r\n\r\n")[0] == 200


def test_session_errors_map_to_400_and_500(server: ViewerServer, fake: FakeSession) -> None:
    fake.fail_with = InvalidInput("key A: no laser reading")
    assert _call(server, "POST", "/key", {"key": "A"}) == (
        400,
        {"error": "key A: no laser reading"},
    )
    fake.fail_with = RuntimeError("boom")
    assert _call(server, "POST", "/key", {"key": "A"}) == (500, {"error": "RuntimeError: boom"})
    fake.fail_with = None
    assert _call(server, "POST", "/key", {"key": "A"})[0] == 200


# ------------------------------------------------------------------------------ lifecycle


def test_stop_closes_the_port(fake: FakeSession) -> None:
    srv = serve(fake, realtime=False)
    port = srv.port
    with srv:
        assert _call(srv, "GET", "/state")[0] == 200
        assert srv.running
    assert not srv.running
    assert srv.wait(0.0)
    srv.stop()  # idempotent
    with pytest.raises(urllib.error.URLError):
        urllib.request.urlopen(srv.url + "state", timeout=5)
    # the port is free again: a new viewer can listen on it
    with serve(fake, port=port, realtime=False) as again:
        assert again.port == port
        assert _call(again, "GET", "/state")[0] == 200


def test_serve_parameters_are_validated(fake: FakeSession) -> None:
    with pytest.raises(InvalidParameter, match="port: expected an int <= 65,535, got 70000"):
        serve(fake, port=70000)
    with pytest.raises(InvalidParameter, match=r"tick: expected a value in \[0.0001, 1\] s, got 0"):
        serve(fake, tick=0.0)
    with (
        serve(fake, realtime=True, tick=0.005) as srv,
        pytest.raises(InvalidParameter, match="step: expected a viewer started with"),
    ):
        srv.step(0.1)


def test_realtime_thread_advances_and_refuses_step(fake: FakeSession) -> None:
    with serve(fake, realtime=True, tick=0.005) as srv:
        assert srv.realtime
        assert fake.advanced.wait(EVENT_TIMEOUT)
        status, payload = _call(srv, "POST", "/step", {"dt": 0.1})
        assert status == 409
        assert "realtime=False" in payload["error"]
    assert all(0.0 < dt <= 0.1 for dt in fake.advances)


def test_realtime_dead_man_zeroes_a_stale_jog(fake: FakeSession) -> None:
    with serve(fake, realtime=True, tick=0.005, jog_timeout=1e-6) as srv:
        assert _call(srv, "POST", "/jog", {"linear": [0.1, 0.0, 0.0]})[0] == 200
        assert fake.zero_jog_after_motion.wait(EVENT_TIMEOUT)
        _, state = _call(srv, "GET", "/state")
        assert state["viewer"]["jog"]["linear"] == [0.0, 0.0, 0.0]


class ReentrancyGuardedSession(FakeSession):
    """A FakeSession whose every call fails if another call is still inside it."""

    def __init__(self) -> None:
        super().__init__()
        self._inside = threading.Lock()
        self.overlapped = threading.Event()

    def _guarded(self, call: Any, *args: Any) -> Any:
        if not self._inside.acquire(blocking=False):
            self.overlapped.set()
            raise RuntimeError("re-entrant call into the session")
        try:
            # some work inside, so that an unserialised caller would likely overlap it
            for _ in range(200):
                np.linalg.norm(self.position)
            return call(*args)
        finally:
            self._inside.release()

    def press(self, key: str) -> None:
        self._guarded(super().press, key)

    def jog(self, linear: Any, angular: Any) -> None:
        self._guarded(super().jog, linear, angular)

    def advance(self, dt: float) -> None:
        self._guarded(super().advance, dt)

    def snapshot(self) -> dict[str, Any]:
        out: dict[str, Any] = self._guarded(super().snapshot)
        return out


def test_concurrent_requests_and_realtime_stepping_never_overlap_in_the_session() -> None:
    session = ReentrancyGuardedSession()
    requests = (
        ("POST", "/jog", {"linear": [0.01, 0.0, 0.0], "angular": [0.0, 0.0, 0.1]}),
        ("POST", "/key", {"key": "A"}),
        ("GET", "/state", None),
    )
    statuses: list[int] = []
    record = threading.Lock()
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)  # interleave the threads finely
    try:
        with serve(session, realtime=True, tick=0.001, jog_timeout=math.inf) as srv:
            assert session.advanced.wait(EVENT_TIMEOUT)
            start = len(session.advances)

            def client(offset: int) -> None:
                # bounded: stop once the stepping thread has advanced a few times meanwhile
                for i in range(300):
                    method, path, body = requests[(i + offset) % len(requests)]
                    status, _ = _call(srv, method, path, body)
                    with record:
                        statuses.append(status)
                    if i >= 30 and len(session.advances) >= start + 5:
                        return

            threads = [threading.Thread(target=client, args=(k,)) for k in range(4)]
            for th in threads:
                th.start()
            for th in threads:
                th.join(EVENT_TIMEOUT)
            assert not any(th.is_alive() for th in threads)
            assert srv.error is None
    finally:
        sys.setswitchinterval(switch)
    assert len(session.advances) >= start + 5  # the real-time thread ran during the requests
    assert len(statuses) >= 4 * 31
    assert set(statuses) == {200}
    assert not session.overlapped.is_set()


def test_realtime_failure_is_reported_not_raised(fake: FakeSession) -> None:
    failed = threading.Event()

    def advance(dt: float) -> None:
        failed.set()
        raise InvalidInput("q: not finite")

    fake.advance = advance  # type: ignore[method-assign]
    with serve(fake, realtime=True, tick=0.005) as srv:
        assert failed.wait(EVENT_TIMEOUT)
        srv._step_thread.join(EVENT_TIMEOUT)  # type: ignore[union-attr]
        assert srv.error == "InvalidInput: q: not finite"
        _, state = _call(srv, "GET", "/state")
        assert state["viewer"]["error"] == "InvalidInput: q: not finite"


# ------------------------------------------------------------------------------ driver

SCRIPT = [
    (0.0, "key", "C"),
    (0.1, "jog", ([0.05, 0.0, 0.0], [0.0, 0.0, 0.0])),
    (0.3, "key", "s"),
    (0.5, "jog", ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])),
]


def test_scripted_driver_over_http(server: ViewerServer, fake: FakeSession) -> None:
    driver = ScriptedDriver(SCRIPT)
    assert driver.duration == 0.5
    snaps = driver.run(server.url, until=0.6, sample_dt=0.1)
    assert fake.keys == ["C", "S"]
    assert [s["t"] for s in snaps] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    assert sum(fake.advances) == pytest.approx(0.6)
    assert all("viewer" not in s for s in snaps)
    assert snaps[0]["clutch"] is False
    assert snaps[-1]["clutch"] is True
    assert snaps[-1]["mode"] == "S"
    # jogged at 0.05 m/s from t = 0.1 to 0.5
    np.testing.assert_allclose(snaps[-1]["tool"][0][3] - snaps[0]["tool"][0][3], 0.02, atol=1e-12)
    np.testing.assert_allclose(fake.position, [0.42, 0.15, 0.0], atol=1e-12)


def test_replay_matches_http_run(server: ViewerServer, fake: FakeSession) -> None:
    over_http = ScriptedDriver(SCRIPT).run(server.url, until=0.6, sample_dt=0.1)
    local = FakeSession()
    in_process = ScriptedDriver(SCRIPT).replay(local, until=0.6, sample_dt=0.1)
    assert json.loads(json.dumps(in_process)) == over_http
    assert local.keys == fake.keys


def test_script_times_between_samples_split_the_step(fake: FakeSession) -> None:
    snaps = ScriptedDriver([(0.05, "key", "C")]).replay(fake, until=0.2, sample_dt=0.1)
    assert [s["t"] for s in snaps] == pytest.approx([0.0, 0.05, 0.1, 0.2])
    assert fake.keys == ["C"]


@pytest.mark.parametrize(
    ("script", "message"),
    [
        ([(0.0, "key")], r"script\[0\]: expected \(t, action, args\)"),
        ([(0.2, "key", "A"), (0.1, "key", "S")], r"script\[1\]: expected a finite time >= 0.2"),
        ([(-1.0, "key", "A")], r"script\[0\]: expected a finite time >= 0"),
        ([("0", "key", "A")], r"script\[0\]: expected a time"),
        ([(0.0, "press", "A")], r"script\[0\]: action: expected one of \['key', 'jog'\]"),
        ([(0.0, "key", "Q")], r"script\[0\]: key: expected one of"),
        ([(0.0, "jog", [1, 2, 3])], r"script\[0\]: jog: expected \(linear, angular\)"),
        ([(0.0, "jog", ([5, 0, 0], [0, 0, 0]))], r"script\[0\]: linear: expected a speed"),
    ],
)
def test_script_validation(script: Any, message: str) -> None:
    with pytest.raises(InvalidParameter, match=message):
        ScriptedDriver(script)


def test_driver_reports_http_errors_and_unreachable_viewers(fake: FakeSession) -> None:
    with serve(fake, realtime=True, tick=0.005) as srv:
        with pytest.raises(InvalidInput, match="POST /step: the viewer answered 409"):
            ScriptedDriver([(0.1, "key", "C")]).run(srv.url, step=True)
        url = srv.url
    with pytest.raises(VelfenceError, match="could not reach the viewer"):
        ScriptedDriver([]).run(url, timeout=5)
    with pytest.raises(InvalidParameter, match="sample_dt"):
        ScriptedDriver([]).replay(fake, sample_dt=0.0)


# ------------------------------------------------------------------------------ CLI


class _FakeServer:
    url = "http://127.0.0.1:9/"

    def __init__(self) -> None:
        self.stopped = False

    def wait(self, timeout: float | None = None) -> bool:
        raise KeyboardInterrupt

    def stop(self) -> None:
        self.stopped = True


def test_cli_teleop_serves_until_interrupted(monkeypatch: pytest.MonkeyPatch) -> None:
    from typer.testing import CliRunner

    from velfence.apps import cli
    from velfence.apps.viewer import server as viewer

    module = types.ModuleType("velfence.apps.teleop.session")
    module.Session = FakeSession  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "velfence.apps.teleop.session", module)
    calls: dict[str, Any] = {}
    fake_server = _FakeServer()

    def fake_serve(session: Any, **kwargs: Any) -> _FakeServer:
        calls.update(kwargs, session=session)
        return fake_server

    monkeypatch.setattr(viewer, "serve", fake_serve)
    result = CliRunner().invoke(
        cli.app, ["teleop", "--port", "0", "--no-browser", "--canvas"], env={"NO_COLOR": "1"}
    )
    assert result.exit_code == 0, result.output
    assert "http://127.0.0.1:9/" in result.output
    assert calls["port"] == 0
    assert calls["start"] is False  # the clock waits for the page
    assert isinstance(calls["session"], FakeSession)
    assert fake_server.stopped


# ------------------------------------------------------------------------------ real Session


def test_real_session_moves_when_clutched_and_jogged() -> None:
    session = Session()
    with serve(session, realtime=False) as srv:
        _, before = _call(srv, "GET", "/state")
        snaps = ScriptedDriver(
            [(0.0, "key", "C"), (0.0, "jog", ([0.03, 0.0, 0.0], [0.0, 0.0, 0.0]))]
        ).run(srv.url, until=1.0, sample_dt=0.1)
    assert snaps[-1]["clutch"] is True
    p0 = np.asarray(before["tool"])[:3, 3]
    p1 = np.asarray(snaps[-1]["tool"])[:3, 3]
    assert np.linalg.norm(p1 - p0) > 5e-3
    assert p1[0] - p0[0] > 0.0


def test_cli_teleop_uses_the_3d_web_view_when_viser_is_installed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    pytest.importorskip("viser")
    from typer.testing import CliRunner

    from velfence.apps import cli
    from velfence.apps.viewer import server as viewer
    from velfence.apps.viewer import view

    calls: dict[str, Any] = {}
    fake_server = _FakeServer()

    def fake_scene(scene: str, **kwargs: Any) -> _FakeServer:
        calls.update(kwargs, scene=scene)
        return fake_server

    def no_canvas(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the canvas page was served although viser is installed")

    monkeypatch.setattr(view, "serve_scene", fake_scene)
    monkeypatch.setattr(viewer, "serve", no_canvas)
    result = CliRunner().invoke(
        cli.app, ["teleop", "--port", "0", "--no-browser", "--start"], env={"NO_COLOR": "1"}
    )
    assert result.exit_code == 0, result.output
    assert calls == {"scene": "teleop", "port": 0, "start": True}
    assert fake_server.stopped
