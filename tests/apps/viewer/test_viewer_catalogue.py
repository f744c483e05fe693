"""The viewers' HTTP catalogue: one table of requests, sent to the teleop viewer (the canvas
page, :func:`velfence.apps.viewer.server.serve`) and to the 3-D web view
(:func:`velfence.apps.viewer.web.serve_web`), each with the status and body it must get.

Unknown paths, every method the server does not serve, path traversal (plain, percent-encoded,
absolute-form), query strings, HEAD, malformed and hostile JSON (NaN, Infinity, 1e400, deep
nesting, not UTF-8), framing attacks (no, two or negative Content-Length, chunked bodies, a body
above the cap), huge request lines and headers, foreign Host and Origin, websocket upgrades, and
idle or stalled connections (slowloris). Every reply, error or not, is a complete HTTP response
with the security headers, and every error body is JSON ``{"error": ...}`` naming what was wrong.

Hermetic: both servers bind 127.0.0.1 on a free port, once for the module, with a short
per-connection timeout so that the idle cases end in a fraction of a second.
"""

from __future__ import annotations

import json
import socket
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import pytest

from velfence.apps.viewer.server import HOST, MAX_BODY, ViewerServer, serve

WAIT = 10.0  # [s] upper bound of every socket wait; never reached when the code is right
IDLE = 0.5  # [s] the servers' per-connection timeout here


@pytest.fixture(scope="module")
def servers() -> Iterator[dict[str, ViewerServer]]:
    """The teleop viewer on the real PUMA session, and (extra web) the web view's arm-box."""
    from velfence.apps.teleop import Session

    out: dict[str, ViewerServer] = {}
    out["teleop"] = serve(Session(), realtime=False, connection_timeout=IDLE)
    try:
        try:
            import viser  # noqa: F401

            from velfence.apps.viewer.view import scene_session
            from velfence.apps.viewer.web import WebView
        except ModuleNotFoundError:
            pass
        else:
            # serve_web's server, with the short idle timeout of this module
            out["web"] = WebView(scene_session("arm-box"), realtime=False, connection_timeout=IDLE)
        yield out
    finally:
        for srv in out.values():
            srv.stop()


class Reply:
    """A raw HTTP reply: status, headers (lower-case names) and body."""

    def __init__(self, raw: bytes) -> None:
        self.raw = raw
        head, _, self.body = raw.partition(b"\r\n\r\n")
        lines = head.decode("latin-1").split("\r\n")
        parts = lines[0].split()
        assert len(parts) >= 2, f"no status line: {raw[:200]!r}"
        assert parts[0].startswith("HTTP/1."), f"no status line: {raw[:200]!r}"
        self.status = int(parts[1])
        self.headers: dict[str, str] = {}
        for line in lines[1:]:
            name, _, value = line.partition(":")
            self.headers[name.strip().lower()] = value.strip()

    def json(self) -> Any:
        return json.loads(self.body)


def _exchange(port: int, request: bytes, half_close: bool = False) -> bytes:
    """Send ``request`` on a new connection (then end the sending side, with ``half_close``);
    read until the server closes it."""
    with socket.create_connection((HOST, port), timeout=WAIT) as conn:
        try:
            conn.sendall(request)
            if half_close:
                conn.shutdown(socket.SHUT_WR)
        except OSError:  # the server may close before reading all of a huge request
            pass
        reply = b""
        try:
            while chunk := conn.recv(65536):
                reply += chunk
        except ConnectionResetError:  # closed with unread input: what arrived before counts
            pass
    return reply


# --- request builders: each takes the port, returns the bytes to send ----------------------

Build = Callable[[int], bytes]


def req(
    method: str,
    path: str,
    body: bytes | None = None,
    *,
    headers: tuple[tuple[str, str], ...] = (),
    host: str | None = "",
    ctype: str | None = "application/json",
    length: bool = True,
    version: str = "HTTP/1.1",
) -> Build:
    def build(port: int) -> bytes:
        lines = [f"{method} {path} {version}"]
        if host is not None:
            lines.append(f"Host: {host or f'{HOST}:{port}'}")
        if body is not None:
            if ctype is not None:
                lines.append(f"Content-Type: {ctype}")
            if length:
                lines.append(f"Content-Length: {len(body)}")
        lines += [f"{k}: {v}" for k, v in headers]
        lines.append("Connection: close")
        return ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1") + (body or b"")

    return build


def raw(data: bytes) -> Build:
    return lambda _port: data


@dataclass(frozen=True)
class Case:
    """One request and what must come back.

    Attributes:
        id: The case's name.
        build: The request bytes.
        status: The expected status code (``None``: the server closes without a reply).
        words: Every one of them in the body (the JSON error, or the page).
        servers: Which servers the case runs on.
        absent: Text that must not be in the reply (a served file's content).
        half_close: End the client's sending side after the request (the server reads EOF).
    """

    id: str
    build: Build
    status: int | None
    words: tuple[str, ...] = ()
    servers: tuple[str, ...] = ("teleop", "web")
    absent: tuple[str, ...] = ()
    half_close: bool = False


J = b'{"key": "A"}'
DEEP = b'{"key": ' + b"[" * 30000 + b"]" * 30000 + b"}"
PASSWD = ("root:", "/bin/")

CASES: list[Case] = [
    # pages and their queries
    Case("get-page", req("GET", "/"), 200, ("<",)),
    Case("get-index-html", req("GET", "/index.html"), 200, ("<",)),
    Case("head-page", req("HEAD", "/"), 200),
    Case("get-state", req("GET", "/state"), 200, ('"t"',)),
    Case("get-scene", req("GET", "/scene"), 200),
    Case("state-with-query", req("GET", "/state?x=1&y=%00&z=%ff"), 200, ('"t"',)),
    Case("state-with-long-query", req("GET", "/state?q=" + "a" * 20000), 200, ('"t"',)),
    Case("state-with-fragment", req("GET", "/state#frag"), 200, ('"t"',)),
    Case("head-state", req("HEAD", "/state"), 200),
    Case("absolute-form", lambda p: req("GET", f"http://{HOST}:{p}/state")(p), 200, ('"t"',)),
    # unknown paths and traversal
    Case("unknown-path", req("GET", "/nope"), 404, ("no such page",)),
    Case("head-unknown", req("HEAD", "/nope"), 404),
    Case("traversal", req("GET", "/../../etc/passwd"), 404, ("no such page",), absent=PASSWD),
    Case("traversal-encoded", req("GET", "/%2e%2e/%2e%2e/etc/passwd"), 404, absent=PASSWD),
    Case("traversal-encoded-slash", req("GET", "/..%2f..%2fetc%2fpasswd"), 404, absent=PASSWD),
    Case("traversal-double-encoded", req("GET", "/%252e%252e/etc/passwd"), 404, absent=PASSWD),
    Case("traversal-backslash", req("GET", "/..\\..\\etc\\passwd"), 404, absent=PASSWD),
    Case("traversal-double-slash", req("GET", "//etc/passwd"), 404, absent=PASSWD),
    Case("traversal-under-page", req("GET", "/index.html/../../../etc/passwd"), 404,
         absent=PASSWD),
    Case("asterisk-target", req("GET", "*"), 404),
    # methods
    Case("options", req("OPTIONS", "/"), 501, ("error",)),
    Case("options-asterisk", req("OPTIONS", "*"), 501, ("error",)),
    Case("put", req("PUT", "/key", J), 501, ("error",)),
    Case("delete", req("DELETE", "/state"), 501, ("error",)),
    Case("patch", req("PATCH", "/jog", J), 501, ("error",)),
    Case("trace", req("TRACE", "/"), 501, ("error",)),
    Case("connect", req("CONNECT", f"{HOST}:22"), 501, ("error",)),
    Case("made-up-method", req("BREW", "/"), 501, ("error",)),
    Case("lower-case-method", req("get", "/state"), 501, ("error",)),
    # POST routes, good and bad bodies
    Case("post-key", req("POST", "/key", J), 200, ('"ok": true',)),
    Case("post-key-lower-case", req("POST", "/key", b'{"key": "a"}'), 200, ('"ok": true',)),
    Case("post-key-unknown", req("POST", "/key", b'{"key": "Z"}'), 400, ("key: expected one of",)),
    Case("post-key-number", req("POST", "/key", b'{"key": 1}'), 400, ("key",)),
    Case("post-key-missing", req("POST", "/key", b"{}"), 400, ("body: expected", "key")),
    Case("post-malformed-json", req("POST", "/key", b'{"key": '), 400, ("expected JSON",)),
    Case("post-json-array", req("POST", "/key", b"[1, 2]"), 400, ("JSON object", "list")),
    Case("post-json-string", req("POST", "/key", b'"A"'), 400, ("JSON object", "str")),
    Case("post-empty-body", req("POST", "/key", b""), 400, ("expected JSON",)),
    Case("post-not-utf8", req("POST", "/key", b'{"key": "\xff"}'), 400, ("expected JSON",)),
    Case("post-deep-json", req("POST", "/key", DEEP), 400, ("body",)),
    Case("post-jog", req("POST", "/jog", b'{"linear": [0.01, 0, 0], "angular": [0, 0, 0]}'), 200,
         ('"ok": true',)),
    Case("post-jog-nan", req("POST", "/jog", b'{"linear": [NaN, 0, 0]}'), 400, ("linear",)),
    Case("post-jog-infinity", req("POST", "/jog", b'{"linear": [Infinity, 0, 0]}'), 400,
         ("linear",)),
    Case("post-jog-1e400", req("POST", "/jog", b'{"linear": [1e400, 0, 0]}'), 400, ("linear",)),
    Case("post-jog-long-int", req("POST", "/jog", b'{"linear": [' + b"9" * 400 + b", 0, 0]}"),
         400, ("linear",)),
    Case("post-jog-angular-nan", req("POST", "/jog", b'{"linear": [0, 0, 0], "angular": '
         b'[0, -Infinity, 0]}'), 400, ("angular",)),
    Case("post-jog-text", req("POST", "/jog", b'{"linear": "fast"}'), 400, ("linear",)),
    Case("post-jog-two", req("POST", "/jog", b'{"linear": [0, 0]}'), 400, ("linear",)),
    Case("post-jog-missing", req("POST", "/jog", b'{"angular": [0, 0, 0]}'), 400, ("linear",)),
    Case("post-step", req("POST", "/step", b'{"dt": 0.01}'), 200, ('"t"',)),
    Case("post-step-nan", req("POST", "/step", b'{"dt": NaN}'), 400, ("dt",)),
    Case("post-step-negative", req("POST", "/step", b'{"dt": -1}'), 400, ("dt",)),
    Case("post-step-huge", req("POST", "/step", b'{"dt": 1e308}'), 400, ("dt",)),
    Case("post-step-bool", req("POST", "/step", b'{"dt": true}'), 400, ("dt",)),
    Case("post-unknown-endpoint", req("POST", "/nope", J), 404, ("no such endpoint",)),
    Case("post-page", req("POST", "/", J), 404, ("no such endpoint",)),
    Case("post-traversal", req("POST", "/../key", J), 404, ("no such endpoint",)),
    Case("post-key-with-query", req("POST", "/key?x=1", J), 200, ('"ok": true',)),
    # framing
    Case("post-no-length", req("POST", "/key", J, length=False), 411, ("Content-Length",)),
    Case("post-two-lengths", req("POST", "/key", J, headers=(("Content-Length", "12"),)), 400,
         ("Content-Length",)),
    Case("post-negative-length", req("POST", "/key", J, length=False,
         headers=(("Content-Length", "-1"),)), 400, ("Content-Length",)),
    Case("post-chunked", req("POST", "/key", b"c\r\n" + J + b"\r\n0\r\n\r\n", length=False,
         headers=(("Transfer-Encoding", "chunked"),)), 411, ("Content-Length",)),
    Case("post-chunked-and-length", req("POST", "/key", J,
         headers=(("Transfer-Encoding", "chunked"),)), 400, ("Transfer-Encoding",)),
    Case("post-huge-body", req("POST", "/key", b" " * (MAX_BODY + 1)), 413, ("at most",)),
    Case("post-huge-declared-length", req("POST", "/key", J, length=False,
         headers=(("Content-Length", str(10**15)),)), 413, ("at most",)),
    Case("post-short-body", req("POST", "/key", J, length=False,
         headers=(("Content-Length", "40"),)), 400, ("expected 40 bytes",), half_close=True),
    Case("post-text-plain", req("POST", "/key", J, ctype="text/plain"), 415, ("Content-Type",)),
    Case("post-no-content-type", req("POST", "/key", J, ctype=None), 415, ("Content-Type",)),
    # huge and malformed heads
    Case("huge-request-line", req("GET", "/" + "a" * 70000), 414, ("error",)),
    Case("huge-header", req("GET", "/state", headers=(("X-Big", "b" * 70000),)), 431,
         ("error",)),
    Case("many-headers", req("GET", "/state", headers=tuple((f"X-{i}", "1") for i in range(200))),
         431, ("error",)),
    Case("garbage-request-line", raw(b"HELLO\r\n\r\n"), 400, ("error",)),
    Case("binary-request", raw(b"\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03" + b"\0" * 40
         + b"\r\n\r\n"), 400, ("error",)),
    Case("bad-version", req("GET", "/state", version="HTTP/9.9"), 505, ("error",)),
    Case("http09", raw(b"GET /state\r\n"), 400, ("HTTP/0.9",), half_close=True),
    Case("nul-in-path", req("GET", "/st\x00ate"), 404, ("no such page",)),
    Case("control-chars-in-path", req("GET", "/state\x1b[2J"), 404, ("no such page",)),
    # Host and Origin
    Case("foreign-host", req("GET", "/state", host="evil.example:80"), 403, ("Host",)),
    Case("no-host-http11", req("GET", "/state", host=None), 400, ("Host",)),
    Case("two-hosts", req("GET", "/state", headers=(("Host", "evil.example"),)), 400, ("Host",)),
    Case("foreign-origin-post", req("POST", "/key", J,
         headers=(("Origin", "http://evil.example"),)), 403, ("Origin",)),
    Case("null-origin-post", req("POST", "/key", J, headers=(("Origin", "null"),)), 403,
         ("Origin",)),
    # websocket upgrades
    Case("websocket-teleop", req("GET", "/", headers=(("Upgrade", "websocket"),
         ("Connection", "Upgrade"), ("Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="),
         ("Sec-WebSocket-Version", "13"))), 404, ("no websocket",), servers=("teleop",)),
    Case("websocket-foreign-origin", req("GET", "/", headers=(("Upgrade", "websocket"),
         ("Origin", "http://evil.example"), ("Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="),
         ("Sec-WebSocket-Version", "13"))), 403, ("Origin",)),
    # idle and stalled connections (slowloris): closed without a reply after IDLE seconds
    Case("idle-connection", raw(b""), None),
    Case("stalled-request-line", raw(b"GET /state HT"), None),
    Case("stalled-headers", raw(b"GET /state HTTP/1.1\r\nHost: x\r\n"), None),
    Case("stalled-body", lambda p: req("POST", "/key", J, length=False,
         headers=(("Content-Length", "100"),))(p)[:-len(J)], None),
]  # fmt: skip

PARAMS = [(c, s) for c in CASES for s in c.servers]


def test_at_least_60_cases() -> None:
    assert len(PARAMS) >= 60
    assert len({c.id for c in CASES}) == len(CASES)


@pytest.mark.parametrize(("case", "name"), PARAMS, ids=[f"{s}-{c.id}" for c, s in PARAMS])
def test_viewer_request(case: Case, name: str, servers: dict[str, ViewerServer]) -> None:
    if name not in servers:
        pytest.skip("the web view needs viser (extra web)")
    srv = servers[name]
    data = _exchange(srv.port, case.build(srv.port), case.half_close)
    if case.status is None:
        assert data == b"", f"expected the server to close without a reply, got {data[:300]!r}"
        return
    reply = Reply(data)
    assert reply.status == case.status, data[:600]
    assert reply.headers.get("x-content-type-options") == "nosniff", reply.headers
    text = reply.body.decode("utf-8", "replace")
    if case.id.startswith("head-") or case.id == "head-page":
        assert reply.body == b""
    elif reply.status >= 400:
        assert reply.headers.get("content-type") == "application/json", reply.headers
        assert set(reply.json()) == {"error"}, text
    for w in case.words:
        assert w in text, (w, text[:400])
    for w in case.absent:
        assert w not in text, (w, text[:400])
    assert srv.error is None, srv.error
