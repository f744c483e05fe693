r"""Interactive local web viewer for a traded-control session (Khokar 2009, §3.5).

The thesis's operator looked at the remote scene directly and drove the PUMA with an Omni stylus
and an Omni-PC keyboard (the thesis, §3.5). Here a person drives the simulated
:class:`~velfence.apps.teleop.session.Session` from a browser instead:

* :func:`serve` starts a :class:`ViewerServer`: a stdlib ``ThreadingHTTPServer`` bound to
  **127.0.0.1 only**, serving one HTML page (package data,
  ``velfence/apps/viewer/static/viewer.html``,
  read with :mod:`importlib.resources`) whose inline script draws the arm, the scene, the
  laser beam and the fixture line on a ``<canvas>`` (a small perspective projection; drag to
  turn the view, wheel to zoom) from ``GET /state`` polled at about 20 Hz;
* the keyboard sends the thesis's mode keys ``A S F D G P T``, ``C`` (clutch) and ``H`` (hand)
  to ``POST /key``; held keys jog the master hand through ``POST /jog``, in the PUMA base
  frame (the session's jog convention): Left/Right along ∓x, Down/Up along ∓y, PgDn/PgUp
  along ∓z, and ``U O`` / ``I K`` / ``J L`` turn about ±x / ±y / ±z;
* a background thread advances the session in real time (``realtime=True``), or, for tests and
  recordings, the session only advances on ``POST /step`` (``realtime=False``, deterministic);
  with ``start=False`` the real-time clock holds until a client fetches the page or posts;
* :class:`ScriptedDriver` is the test double of the person: it plays a timed script of key
  presses and jogs by sending the same HTTP requests the page sends (or, with
  :meth:`ScriptedDriver.replay`, the same calls in-process) and records the snapshots.

HTTP API (JSON bodies, ``Content-Type: application/json``; errors are ``{"error": message}``
with status 400 for a bad request (malformed JSON, a field that is not real numbers, a missing or
repeated ``Host``), 403 a foreign ``Host`` or ``Origin``, 404 unknown path, 409 wrong mode,
411/413 missing or oversized body (``Content-Length`` required, at most :data:`MAX_BODY` bytes),
415 not JSON, 500 a session failure, 503 too many connections or a stopped session):

* ``GET /`` — the page; ``GET /scene`` — :meth:`SessionLike.scene_primitives`;
* ``GET /state`` — :meth:`SessionLike.snapshot` plus ``"viewer": {"realtime": bool,
  "jog": {"linear": [3], "angular": [3]}, "error": str | None}``;
* ``POST /key`` ``{"key": "A"}`` (one of :data:`ALLOWED_KEYS`, either case);
* ``POST /jog`` ``{"linear": [3] m/s, "angular": [3] rad/s}`` (``angular`` may be left out:
  zero); each component finite, ``|linear| <= MAX_JOG_LINEAR``, ``|angular| <= MAX_JOG_ANGULAR``;
* ``POST /step`` ``{"dt": s}`` with ``0 < dt <= MAX_STEP_REQUEST`` — only when not real time.

Jogs are *held*: the server re-sends the last jog to the session before every ``advance``, so a
session that forgets its jog after one advance and one that keeps it behave alike. In real time a
jog older than ``jog_timeout`` is zeroed (a dead-man: a browser that lost a key-up or the
connection must not leave the arm moving; cf. the thesis's stale-transform jerks, §8.1).

Only loopback is ever bound, and these checks keep other web pages from driving the arm:

* ``Host`` must be ``127.0.0.1:port`` or ``localhost:port`` (DNS rebinding); more than one
  ``Host`` header, or none on an HTTP/1.1 request, is a 400; an HTTP/1.0 ``POST`` without one
  is a 403 (it cannot show it was addressed here); an HTTP/1.0 ``GET`` may omit it;
* a ``POST`` whose ``Origin`` is present and not ``http://127.0.0.1:port`` or
  ``http://localhost:port`` (``null`` included) is a 403. A ``POST`` without ``Origin`` is
  allowed: browsers send ``Origin`` on every ``POST`` a page makes, so its absence means a
  non-browser client (curl, :class:`ScriptedDriver`), which can reach loopback only locally;
* every ``POST`` must be JSON (no cross-site "simple" form posts);
* every response carries ``X-Frame-Options: DENY`` and a ``Content-Security-Policy`` with
  ``frame-ancestors 'none'`` (no clickjacking of the keys), ``default-src 'none'`` and the
  hashes of the page's own inline script and style, plus ``X-Content-Type-Options: nosniff``.

Each connection has a socket timeout (``connection_timeout``) and at most ``max_connections``
are served at once, so idle or slow clients cannot pin threads; a connection that has sent
nothing yet waits outside those slots (at most :data:`MAX_IDLE` of them, the oldest dropped
first, each for at most ``connection_timeout``), so idle sockets never lock the page out; a
client that disconnects early is logged at debug level only. If the real-time stepping thread
fails, :attr:`ViewerServer.error` records why, ``GET /state`` reports it and every ``POST``
answers 503.
"""

from __future__ import annotations

import base64
import contextlib
import hashlib
import json
import logging
import math
import queue
import re
import selectors
import socket
import sys
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Callable, Mapping, Sequence
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib.resources import files
from types import TracebackType
from typing import Any, Protocol, cast
from urllib.parse import urlsplit

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import (
    check_flag,
    check_positive_int,
    check_range,
    finite_scalar,
    real_array,
    step_count,
)
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError

__all__ = [
    "ALLOWED_KEYS",
    "CLUTCH_KEY",
    "DEFAULT_CONNECTION_TIMEOUT",
    "DEFAULT_MAX_CONNECTIONS",
    "HAND_KEY",
    "HOST",
    "MAX_BODY",
    "MAX_CONNECTIONS",
    "MAX_CONNECTION_TIMEOUT",
    "MAX_IDLE",
    "MAX_JOG_ANGULAR",
    "MAX_JOG_LINEAR",
    "MAX_JOG_TIMEOUT",
    "MAX_SAMPLES",
    "MAX_STEP_REQUEST",
    "MAX_TICK",
    "MIN_TICK",
    "MODE_KEYS",
    "ScriptedDriver",
    "SessionLike",
    "ViewerServer",
    "serve",
]


_log = logging.getLogger(__name__)

#: The thesis's mode keys (§1.1, §6.1-6.5; docs/telerobotics.md): trajectory, scaled, fixture,
#: destination, path, plane point, align.
MODE_KEYS: tuple[str, ...] = ("A", "S", "F", "D", "G", "P", "T")
#: Toggles the clutch (the Omni's engage button).
CLUTCH_KEY = "C"
#: Closes / opens the hand (the Barrett Hand; the session's own key, not the thesis's).
HAND_KEY = "H"
#: Every key ``POST /key`` accepts (a session may still refuse one: 400 with its message).
ALLOWED_KEYS: tuple[str, ...] = (*MODE_KEYS, CLUTCH_KEY, HAND_KEY)
#: The only interface the server binds.
HOST = "127.0.0.1"
#: Largest accepted master-hand speed [m/s] (the Omni moves a few cm/s; 1 m/s is a typo guard).
MAX_JOG_LINEAR = 1.0
#: Largest accepted master-hand angular speed [rad/s].
MAX_JOG_ANGULAR = 3.0
#: Largest ``dt`` [s] one ``POST /step`` may ask for.
MAX_STEP_REQUEST = 10.0
#: Largest request body [bytes] (a request states it in ``Content-Length``; more: 413).
MAX_BODY = 65536
_DRAIN_LIMIT = 16 * MAX_BODY
#: Shortest and longest real-time stepping period ``tick`` [s].
MIN_TICK = 1e-4
MAX_TICK = 1.0
#: Longest finite dead-man ``jog_timeout`` [s] (``math.inf`` disables the dead-man).
MAX_JOG_TIMEOUT = 3600.0
#: Default and longest per-connection socket timeout [s]: an idle or stalled client is dropped.
DEFAULT_CONNECTION_TIMEOUT = 10.0
MAX_CONNECTION_TIMEOUT = 3600.0
#: Default and largest number of connections served at once (one thread each).
DEFAULT_MAX_CONNECTIONS = 128
MAX_CONNECTIONS = 4096
#: Most connections that wait, silent, for their first byte (they hold no slot and no thread);
#: beyond it the oldest is closed, so a legitimate client always gets in.
MAX_IDLE = 512
_IDLE_POLL = 0.25
#: Most snapshots one :class:`ScriptedDriver` run may record (``until / sample_dt``).
MAX_SAMPLES = 1_000_000
_SESSION_METHODS = ("press", "jog", "advance", "snapshot", "scene_primitives")


# ---------------------------------------------------------------------------------- protocol
class SessionLike(Protocol):
    """What the viewer needs of a traded-control session (``velfence.apps.teleop.session.Session``).

    Calls come from several threads; the viewer serialises them with one lock, so the session
    itself need not be thread-safe.
    """

    def press(self, key: str) -> None:
        """A key of the Omni-PC keyboard: one of :data:`ALLOWED_KEYS`."""
        ...

    def jog(self, linear: ArrayLike, angular: ArrayLike) -> None:
        """The master hand's velocity for the next advance: [m/s] and [rad/s], shape (3,) each."""
        ...

    def advance(self, dt: float) -> None:
        """Step the simulated world by ``dt`` [s] > 0."""
        ...

    def snapshot(self) -> dict[str, Any]:
        """JSON-able state (keys listed in :mod:`velfence.apps.viz.telerobotics`).

        ``t`` [s], ``mode``, ``clutch``, ``q`` (6 angles [rad]), ``joints`` (points [m] base to
        tool), ``tool`` (4 x 4), ``laser``, ``fixture``, ``status``, ``task``.
        """
        ...

    def scene_primitives(self) -> list[dict[str, Any]]:
        """The scene as :func:`velfence.apps.teleop.scene.scene_to_dicts` writes it."""
        ...


def _jsonable(x: Any) -> Any:
    """``x`` with NumPy values turned into Python ones and non-finite floats into ``None``."""
    if isinstance(x, Mapping):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, bool | np.bool_):
        return bool(x)
    if isinstance(x, int | np.integer):
        return int(x)
    if isinstance(x, float | np.floating):
        v = float(x)
        return v if math.isfinite(v) else None
    return x


def _vector(name: str, value: Any, limit: float, unit: str) -> FloatArray:
    """A finite 3-vector [unit] with norm <= limit, else :class:`InvalidInput` naming ``name``."""
    v = real_array(f"{name} [{unit}]", value, (3,))
    if isinstance(value, list | tuple):
        # NumPy turns [true, 0, 0] into the integers [1, 0, 0]: a 1 m/s jog. Each component
        # must be a real number itself (booleans and strings refused).
        for i, component in enumerate(value):
            finite_scalar(f"{name}[{i}]", component, unit=unit, what="speed")
    norm = float(np.linalg.norm(v))
    if norm > limit:
        raise InvalidInput(
            f"{name}: expected a speed of at most {limit:g} {unit}, got {norm:.6g} {unit}"
        )
    return v


def _key(value: Any) -> str:
    if not isinstance(value, str) or value.upper() not in ALLOWED_KEYS:
        raise InvalidInput(f"key: expected one of {list(ALLOWED_KEYS)}, got {value!r:.80}")
    return value.upper()


# ---------------------------------------------------------------------------------- server
class _HTTPError(Exception):
    def __init__(self, status: HTTPStatus, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


#: Errors of a client that went away (closed, reset, stalled): nothing to answer, nothing to print.
_GONE = (ConnectionError, TimeoutError)


def _refusal(status: HTTPStatus, message: str) -> bytes:
    """A complete HTTP/1.0 error response, for the accept thread (no handler runs)."""
    body = json.dumps({"error": message}).encode()
    head = [f"HTTP/1.0 {status.value} {status.phrase}", "Content-Type: application/json"]
    head += [f"Content-Length: {len(body)}", "Connection: close"]
    head += [f"{k}: {v}" for k, v in _SECURITY_HEADERS]
    return ("\r\n".join(head) + "\r\n\r\n").encode() + body


class _HTTPServer(ThreadingHTTPServer):
    """The threaded server, with a waiting room in front of the ``max_connections`` slots.

    A new connection first waits, without a thread and without a slot, until its first byte
    arrives; only then does it take a slot (or get 503). So idle connections (a browser's
    speculative pre-connects, or a client that opens sockets and sends nothing) never lock the
    page out. The waiting room holds at most :data:`MAX_IDLE` connections (the oldest is closed
    to make room for a new one) and closes a connection still silent after
    ``connection_timeout``.
    """

    daemon_threads = True
    # The stdlib's backlog of 5 overflows under a few dozen concurrent clients: refused SYNs are
    # retried after 1 s, 2 s, ... (measured p99 above 1 s with 50 clients; 80 ms with 128).
    request_queue_size = 128

    def __init__(self, viewer: ViewerServer, port: int, max_connections: int) -> None:
        self.viewer = viewer
        self._slots = threading.BoundedSemaphore(max_connections)
        self._max_connections = max_connections
        super().__init__((HOST, port), _Handler)
        self._arrivals: queue.SimpleQueue[tuple[Any, Any]] = queue.SimpleQueue()
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._closing = threading.Event()
        self._waiter = threading.Thread(
            target=self._wait_for_first_bytes, name="velfence-viewer-idle", daemon=True
        )
        self._waiter.start()

    def process_request(self, request: Any, client_address: Any) -> None:
        """Hand a new connection to the waiting room (it takes a slot once it sends)."""
        self._arrivals.put((request, client_address))
        self._wake()

    def _wake(self) -> None:
        # OSError: the buffer is full (the waiter is awake anyway) or the socket closed
        with contextlib.suppress(OSError):
            self._wake_w.send(b"\0")

    def _wait_for_first_bytes(self) -> None:
        """The waiting-room thread: dispatch connections that sent, close the silent ones."""
        waiting: dict[Any, tuple[float, Any]] = {}  # insertion order = age
        with selectors.DefaultSelector() as sel:
            sel.register(self._wake_r, selectors.EVENT_READ)
            try:
                while not self._closing.is_set():
                    now = time.monotonic()
                    timeout = _IDLE_POLL
                    if waiting:
                        first = next(iter(waiting.values()))[0]
                        timeout = max(
                            0.0, min(timeout, first + self.viewer.connection_timeout - now)
                        )
                    for key, _ in sel.select(timeout):
                        if key.fileobj is self._wake_r:
                            try:
                                while self._wake_r.recv(4096):
                                    pass
                            except OSError:
                                pass
                            continue
                        request = key.fileobj
                        sel.unregister(request)
                        _, address = waiting.pop(request)
                        self._dispatch(request, address)
                    while True:
                        try:
                            request, address = self._arrivals.get_nowait()
                        except queue.Empty:
                            break
                        if len(waiting) >= MAX_IDLE:  # make room: the oldest silent one goes
                            oldest = next(iter(waiting))
                            sel.unregister(oldest)
                            del waiting[oldest]
                            self.shutdown_request(oldest)
                        waiting[request] = (time.monotonic(), address)
                        sel.register(request, selectors.EVENT_READ)
                    deadline = time.monotonic() - self.viewer.connection_timeout
                    for request, (since, _) in list(waiting.items()):
                        if since > deadline:
                            break  # the rest are younger
                        sel.unregister(request)
                        del waiting[request]
                        self.shutdown_request(request)
            finally:
                for request in waiting:
                    self.shutdown_request(request)
                while True:
                    try:
                        self.shutdown_request(self._arrivals.get_nowait()[0])
                    except queue.Empty:
                        break

    def _dispatch(self, request: Any, client_address: Any) -> None:
        """Serve in a new thread, or refuse with 503 when ``max_connections`` are busy."""
        if not self._slots.acquire(blocking=False):
            # Answered from the waiting-room thread, so it must never block: a non-blocking
            # send of a few hundred bytes to a fresh socket fits its buffer; if not, just close.
            try:
                request.setblocking(False)
                request.send(
                    _refusal(
                        HTTPStatus.SERVICE_UNAVAILABLE,
                        f"too many open connections (max_connections={self._max_connections});"
                        " retry",
                    )
                )
            except OSError:
                pass
            self.shutdown_request(request)
            return
        try:
            super().process_request(request, client_address)
        except BaseException:  # the thread did not start: give the slot back
            self._slots.release()
            self.shutdown_request(request)

    def server_close(self) -> None:
        """Stop the waiting room (closing its connections), then the listening socket."""
        self._closing.set()
        self._wake()
        self._waiter.join()
        self._wake_r.close()
        self._wake_w.close()
        super().server_close()

    def process_request_thread(self, request: Any, client_address: Any) -> None:
        """The handler thread; frees its connection slot when done."""
        try:
            super().process_request_thread(request, client_address)
        finally:
            self._slots.release()

    def handle_error(self, request: Any, client_address: Any) -> None:
        """Log instead of printing a traceback; a client that went away is only a debug note."""
        exc = sys.exc_info()[1]
        if isinstance(exc, _GONE):
            _log.debug("client %s went away: %s", client_address, type(exc).__name__)
        else:
            _log.error("request from %s failed", client_address, exc_info=True)


class _Handler(BaseHTTPRequestHandler):
    server_version = "velfence-viewer"
    _raw: bytes | None = None
    _body_error: _HTTPError | None = None

    def setup(self) -> None:
        """Apply the per-connection socket timeout (it also governs the file streams)."""
        super().setup()
        # An idle or stalled client then costs its thread at most this long, not forever.
        self.connection.settimeout(self._viewer.connection_timeout)

    def log_message(self, format: str, *args: Any) -> None:
        """Per-request log at debug level only (the CLI prints the URL, nothing per request)."""
        _log.debug("%s " + format, self.address_string(), *args)

    # -------------------------------------------------------------------------- plumbing
    @property
    def _viewer(self) -> ViewerServer:
        return cast(_HTTPServer, self.server).viewer

    def end_headers(self) -> None:
        """Every response, error replies of the stdlib included, carries the security headers."""
        for name, value in self._viewer._security_headers:
            self.send_header(name, value)
        super().end_headers()

    def _send(self, status: HTTPStatus, body: bytes, content_type: str) -> None:
        # The stdlib answers an unparsable request line as HTTP/0.9, i.e. without status line
        # and headers; every reply here has both (the security headers above all).
        if self.request_version == "HTTP/0.9":
            self.request_version = "HTTP/1.0"
        try:
            self.send_response(status)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            if status >= 400:
                self.send_header("Connection", "close")
                self.close_connection = True
            self.end_headers()
            if self.command != "HEAD":
                self.wfile.write(body)
        except _GONE as exc:  # the client closed early: nobody left to tell
            self.close_connection = True
            _log.debug(
                "client %s went away mid-response: %s", self.client_address, type(exc).__name__
            )

    def _json(self, status: HTTPStatus, payload: Any) -> None:
        body = json.dumps(_jsonable(payload), allow_nan=False).encode()
        self._send(status, body, "application/json")

    def send_error(self, code: int, message: str | None = None, explain: str | None = None) -> None:
        """The stdlib's own errors (bad request line, unknown method, ...) as JSON too."""
        try:
            status = HTTPStatus(code)
        except ValueError:
            status = HTTPStatus.BAD_REQUEST
        self.log_error("code %d, message %s", code, message)
        self.close_connection = True
        self._json(status, {"error": message or status.phrase})

    def _check_request(self) -> None:
        """Refuse requests not addressed to this server, or (POST) sent by another web page."""
        if self.request_version == "HTTP/0.9":  # no headers at all: nothing to check
            raise _HTTPError(HTTPStatus.BAD_REQUEST, "HTTP/0.9: expected HTTP/1.0 or HTTP/1.1")
        port = self._viewer.port
        expected = (f"{HOST}:{port}", f"localhost:{port}")
        hosts = self.headers.get_all("Host") or []
        # Duplicates are refused outright: servers and proxies disagree about which one counts.
        if len(hosts) > 1:
            raise _HTTPError(
                HTTPStatus.BAD_REQUEST, f"Host: expected one Host header, got {len(hosts)}"
            )
        if not hosts and self.request_version != "HTTP/1.0":
            raise _HTTPError(
                HTTPStatus.BAD_REQUEST,
                f"Host: an {self.request_version} request must send a Host header; expected "
                f"{expected[0]} or {expected[1]}",
            )
        host = hosts[0] if hosts else None
        # Fail closed: the Host check is the DNS-rebinding guard, and a POST without Host (raw
        # HTTP/1.0; browsers always send one) cannot show it was addressed to this server.
        if (host is None and self.command == "POST") or (host is not None and host not in expected):
            raise _HTTPError(
                HTTPStatus.FORBIDDEN,
                f"Host: expected {expected[0]} or {expected[1]}, got {host!r:.80}",
            )
        if self.command == "POST":
            self._check_origin()

    def _check_origin(self) -> None:
        port = self._viewer.port
        expected = (f"{HOST}:{port}", f"localhost:{port}")
        # A browser sends Origin on every POST a page makes; another site's page (or a sandboxed
        # frame, "null") must not drive the arm. No Origin at all is a non-browser client (curl,
        # ScriptedDriver), already bound to loopback and to this Host: allowed.
        origins = self.headers.get_all("Origin") or []
        if len(origins) > 1:
            raise _HTTPError(
                HTTPStatus.BAD_REQUEST, f"Origin: expected at most one, got {len(origins)}"
            )
        allowed = tuple(f"http://{h}" for h in expected)
        if origins and origins[0] not in allowed:
            raise _HTTPError(
                HTTPStatus.FORBIDDEN,
                f"Origin: expected {allowed[0]} or {allowed[1]} (this viewer's own page), "
                f"got {origins[0]!r:.80}",
            )

    def _read_body(self) -> None:
        """Read the body first: an early error reply must not leave unread bytes behind."""
        # Closing a socket with unread input sends a reset, which can eat the error reply.
        self._raw = None
        self._body_error = None
        lengths = self.headers.get_all("Content-Length") or []
        if not lengths:
            self._body_error = _HTTPError(
                HTTPStatus.LENGTH_REQUIRED, "Content-Length: expected a length"
            )
            return
        length = lengths[0].strip()
        if len(lengths) > 1 or self.headers.get("Transfer-Encoding") is not None:
            # Two framings of one body (request smuggling): refuse, and read nothing.
            self._body_error = _HTTPError(
                HTTPStatus.BAD_REQUEST,
                "Content-Length: expected exactly one and no Transfer-Encoding, got "
                f"{len(lengths)} Content-Length and Transfer-Encoding "
                f"{self.headers.get('Transfer-Encoding')!r:.40}",
            )
            return
        # Digits only: int() would also take "+5", " 5", "5_0" and thousands of digits.
        if not (length.isascii() and length.isdigit()) or len(length) > 20:
            self._body_error = _HTTPError(
                HTTPStatus.BAD_REQUEST,
                f"Content-Length: expected a number of bytes, got {length!r:.40}",
            )
            return
        n = int(length)
        if n > MAX_BODY:
            self._body_error = _HTTPError(
                HTTPStatus.REQUEST_ENTITY_TOO_LARGE,
                f"body: expected at most {MAX_BODY} bytes, got {n}",
            )
            if n <= _DRAIN_LIMIT:  # drain a moderately large body so the reply arrives
                self.rfile.read(n)
            return
        self._raw = self.rfile.read(n)
        if len(self._raw) < n:
            self._body_error = _HTTPError(
                HTTPStatus.BAD_REQUEST,
                f"body: expected {n} bytes (Content-Length), got {len(self._raw)}",
            )

    def _body(self) -> dict[str, Any]:
        if self._body_error is not None:
            raise self._body_error
        ctype = self.headers.get("Content-Type", "")
        if ctype.split(";")[0].strip().lower() != "application/json":
            raise _HTTPError(
                HTTPStatus.UNSUPPORTED_MEDIA_TYPE,
                f"Content-Type: expected application/json, got {ctype!r:.80}",
            )
        try:
            # Long integers become floats (inf beyond the float range): the field's validator
            # then refuses them by name, instead of an OverflowError deep in NumPy.
            data = json.loads((self._raw or b"").decode("utf-8"), parse_int=_parse_int)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise _HTTPError(HTTPStatus.BAD_REQUEST, f"body: expected JSON, got {exc}") from None
        except RecursionError:
            raise _HTTPError(
                HTTPStatus.BAD_REQUEST, "body: expected JSON nested at most a few levels deep"
            ) from None
        except ValueError as exc:  # what else the decoder may refuse
            raise _HTTPError(HTTPStatus.BAD_REQUEST, f"body: expected JSON, got {exc}") from None
        if not isinstance(data, dict):
            raise _HTTPError(
                HTTPStatus.BAD_REQUEST, f"body: expected a JSON object, got {type(data).__name__}"
            )
        return data

    def _dispatch(self, action: Callable[[], None]) -> None:
        try:
            self._check_request()
            action()
        except _HTTPError as exc:
            self._json(exc.status, {"error": exc.message})
        except VelfenceError as exc:
            self._json(HTTPStatus.BAD_REQUEST, {"error": str(exc)})
        except _GONE:  # the client went away while we read or computed: nobody to answer
            self.close_connection = True
        except Exception as exc:  # a session bug must answer 500, not drop the connection
            self._json(HTTPStatus.INTERNAL_SERVER_ERROR, {"error": f"{type(exc).__name__}: {exc}"})

    # -------------------------------------------------------------------------- routes
    def do_GET(self) -> None:
        """``/``, ``/state``, ``/scene`` (and a websocket upgrade where the server has one)."""
        if self.headers.get("Upgrade", "").lower() == "websocket":
            self._dispatch(self._upgrade)
            return
        self._dispatch(self._get)

    def _upgrade(self) -> None:
        # A refusal is an HTTP/1.1 reply (websocket clients reject HTTP/1.0 status lines); it
        # always closes the connection.
        self.protocol_version = "HTTP/1.1"
        # A browser sends Origin on every websocket handshake: the POST rule applies.
        self._check_origin()
        if not self._viewer._upgrade(self):
            raise _HTTPError(HTTPStatus.NOT_FOUND, "no websocket endpoint here")

    def do_HEAD(self) -> None:
        """Headers of a ``GET``."""
        self._dispatch(self._get)

    def do_POST(self) -> None:
        """``/key``, ``/jog``, ``/step``."""
        self._read_body()
        self._dispatch(self._post)

    def _get(self) -> None:
        path = urlsplit(self.path).path
        viewer = self._viewer
        if path in ("/", "/index.html"):
            viewer._client_seen()
            self._send(HTTPStatus.OK, viewer._page_bytes, "text/html; charset=utf-8")
        elif path == "/state":
            self._json(HTTPStatus.OK, viewer.state())
        elif path == "/scene":
            self._json(HTTPStatus.OK, viewer.scene())
        else:
            raise _HTTPError(HTTPStatus.NOT_FOUND, f"no such page {path!r:.80}; try / or /state")

    def _post(self) -> None:
        path = urlsplit(self.path).path
        viewer = self._viewer
        if viewer.error is not None:
            raise _HTTPError(
                HTTPStatus.SERVICE_UNAVAILABLE,
                f"session stopped: {viewer.error}; restart the viewer",
            )
        if path not in ("/key", "/jog", "/step"):
            raise _HTTPError(
                HTTPStatus.NOT_FOUND,
                f"no such endpoint {path!r:.80}; expected /key, /jog or /step",
            )
        body = self._body()
        viewer._client_seen()
        if path == "/key":
            if "key" not in body:
                raise InvalidInput(f"body: expected {{'key': ...}}, got keys {_keys(body)}")
            key = viewer.press(body["key"])
            self._json(HTTPStatus.OK, {"ok": True, "key": key})
        elif path == "/jog":
            if "linear" not in body:
                raise InvalidInput(
                    f"body: expected {{'linear': [3], 'angular': [3]}}, got keys {_keys(body)}"
                )
            lin, ang = viewer.jog(body["linear"], body.get("angular", (0.0, 0.0, 0.0)))
            self._json(HTTPStatus.OK, {"ok": True, "linear": lin, "angular": ang})
        else:
            if viewer.realtime:
                raise _HTTPError(
                    HTTPStatus.CONFLICT,
                    "step: the session advances in real time; start the viewer with "
                    "realtime=False to step it on request",
                )
            if "dt" not in body:
                raise InvalidInput(f"body: expected {{'dt': seconds}}, got keys {_keys(body)}")
            t = viewer.step(body["dt"])
            self._json(HTTPStatus.OK, {"ok": True, "t": t})


def _keys(body: Mapping[str, Any]) -> list[str]:
    """The first few keys of a body, for messages (a 64 kB body must not echo 64 kB)."""
    return [k[:40] for k in sorted(body)[:10]]


def _parse_int(text: str) -> int | float:
    """JSON integers: exact up to 18 digits, else a float (``inf`` beyond the float range)."""
    # int() of thousands of digits is slow (and refused past sys.get_int_max_str_digits()),
    # and such an int overflows when converted to float later on.
    return int(text) if len(text) <= 18 else float(text)


class ViewerServer:
    """A running viewer: HTTP on ``127.0.0.1:port`` plus, in real time, a stepping thread.

    Create it with :func:`serve`. Use it as a context manager, or call :meth:`stop`.

    Args:
        session: The session to show and drive.
        port: TCP port; 0 (default) picks a free one (read it back from :attr:`port`).
        realtime: Advance the session with wall-clock time in a background thread (default);
            ``False`` advances only on :meth:`step` / ``POST /step`` (deterministic).
        tick: Period of the real-time stepping thread [s], in [``MIN_TICK``, ``MAX_TICK``].
        max_step: Longest ``dt`` [s] one real-time advance may take, in (0,
            ``MAX_STEP_REQUEST``]; a stalled thread resumes with this step instead of catching
            up, so simulated time then lags wall time.
        jog_timeout: In real time, a jog not renewed for this long [s] is zeroed (dead-man), in
            (0, ``MAX_JOG_TIMEOUT``]; ``math.inf`` disables it.
        connection_timeout: Socket timeout of each connection [s], in (0,
            ``MAX_CONNECTION_TIMEOUT``]: a client idle or stalled this long is disconnected.
        max_connections: Connections served at once (one thread each), in [1,
            ``MAX_CONNECTIONS``]; more are answered 503 at once.
        start: In real time, start the clock at once (default); ``False`` holds the session at
            its start until a client shows up (the page is fetched, or a ``POST`` arrives), so
            the person opening the page does not find it already minutes into the run.

    Raises:
        InvalidParameter: a ``session`` without the :class:`SessionLike` methods, a
            ``realtime`` that is not a bool, a port outside [0, 65535], or a time or count that
            is not a finite number in its range (the message names the argument).
        OSError: the port is in use.
    """

    def __init__(
        self,
        session: SessionLike,
        *,
        port: int = 0,
        realtime: bool = True,
        tick: float = 0.02,
        max_step: float = 0.1,
        jog_timeout: float = 0.5,
        connection_timeout: float = DEFAULT_CONNECTION_TIMEOUT,
        max_connections: int = DEFAULT_MAX_CONNECTIONS,
        start: bool = True,
    ) -> None:
        missing = [m for m in _SESSION_METHODS if not callable(getattr(session, m, None))]
        if missing:
            raise InvalidParameter(
                f"session: expected a SessionLike with methods {list(_SESSION_METHODS)}, got "
                f"{type(session).__name__} without {missing}"
            )
        self._port = check_positive_int("port", port, minimum=0, maximum=65535, example=8765)
        self._realtime = check_flag("realtime", realtime)
        self._tick = check_range("tick", tick, low=MIN_TICK, high=MAX_TICK, unit="s")
        self._max_step = check_range(
            "max_step", max_step, low=0.0, low_open=True, high=MAX_STEP_REQUEST, unit="s"
        )
        if isinstance(jog_timeout, float) and jog_timeout == math.inf:
            self._jog_timeout = math.inf  # documented: no dead-man
        else:
            self._jog_timeout = check_range(
                "jog_timeout", jog_timeout, low=0.0, low_open=True, high=MAX_JOG_TIMEOUT, unit="s"
            )
        self._connection_timeout = check_range(
            "connection_timeout",
            connection_timeout,
            low=0.0,
            low_open=True,
            high=MAX_CONNECTION_TIMEOUT,
            unit="s",
        )
        n_connections = check_positive_int(
            "max_connections", max_connections, maximum=MAX_CONNECTIONS, example=128
        )
        self._started = threading.Event()
        if check_flag("start", start):
            self._started.set()
        self._session = session
        self._lock = threading.RLock()
        self._jog_linear = np.zeros(3)
        self._jog_angular = np.zeros(3)
        self._jog_time = time.monotonic()
        self._error: str | None = None
        self._stopping = threading.Event()
        self._stopped = False
        self._httpd = _HTTPServer(self, self._port, n_connections)
        self._port = int(self._httpd.server_address[1])
        self._http_thread = threading.Thread(
            target=self._httpd.serve_forever,
            kwargs={"poll_interval": 0.05},
            name="velfence-viewer-http",
            daemon=True,
        )
        self._step_thread: threading.Thread | None = None
        self._http_thread.start()
        if self._realtime:
            self._step_thread = threading.Thread(
                target=self._run_realtime, name="velfence-viewer-step", daemon=True
            )
            self._step_thread.start()

    # -------------------------------------------------------------------------- properties
    @property
    def port(self) -> int:
        """The bound TCP port."""
        return self._port

    @property
    def url(self) -> str:
        """``http://127.0.0.1:<port>/``: open it in a browser."""
        return f"http://{HOST}:{self._port}/"

    @property
    def realtime(self) -> bool:
        """Whether a background thread advances the session with wall-clock time."""
        return self._realtime

    @property
    def error(self) -> str | None:
        """The failure that stopped real-time stepping (``"Type: message"``), else ``None``."""
        return self._error

    @property
    def connection_timeout(self) -> float:
        """Socket timeout of each connection [s]."""
        return self._connection_timeout

    @property
    def started(self) -> bool:
        """Whether the real-time clock runs (``start=True``, or a client has shown up)."""
        return self._started.is_set()

    @property
    def running(self) -> bool:
        """Whether the server still answers (False after :meth:`stop`)."""
        return not self._stopped

    # -------------------------------------------------------------------------- actions
    def state(self) -> dict[str, Any]:
        """The session's snapshot plus ``"viewer"``: ``realtime``, held ``jog``, ``error``."""
        with self._lock:
            snap = dict(self._session.snapshot())
            snap["viewer"] = {
                "realtime": self._realtime,
                "jog": {
                    "linear": self._jog_linear.tolist(),
                    "angular": self._jog_angular.tolist(),
                },
                "error": self._error,
                "started": self._started.is_set(),
            }
        return snap

    def scene(self) -> list[dict[str, Any]]:
        """The session's scene primitives (:func:`velfence.apps.teleop.scene.scene_to_dicts`)."""
        with self._lock:
            return list(self._session.scene_primitives())

    def press(self, key: Any) -> str:
        """Forward a key to the session.

        Args:
            key: One of :data:`ALLOWED_KEYS`, either case.

        Returns:
            The key sent (upper case).

        Raises:
            InvalidInput: any other key.
        """
        k = _key(key)
        with self._lock:
            self._session.press(k)
        return k

    def jog(self, linear: Any, angular: Any = (0.0, 0.0, 0.0)) -> tuple[list[float], list[float]]:
        """Set the held master-hand velocity and forward it to the session.

        Args:
            linear: Velocity [m/s], shape (3,), norm <= :data:`MAX_JOG_LINEAR`.
            angular: Angular velocity [rad/s], shape (3,), norm <= :data:`MAX_JOG_ANGULAR`.

        Returns:
            The accepted ``(linear, angular)`` as lists.

        Raises:
            InvalidInput: a wrong shape, non-finite components or too high a speed.
        """
        lin = _vector("linear", linear, MAX_JOG_LINEAR, "m/s")
        ang = _vector("angular", angular, MAX_JOG_ANGULAR, "rad/s")
        with self._lock:
            self._jog_linear, self._jog_angular = lin, ang
            self._jog_time = time.monotonic()
            self._session.jog(lin.copy(), ang.copy())
        return lin.tolist(), ang.tolist()

    def step(self, dt: Any) -> float | None:
        """Advance the session by ``dt`` (only when not in real time).

        Args:
            dt: Time step [s], ``0 < dt <= MAX_STEP_REQUEST``.

        Returns:
            The session's time ``t`` [s] after the step (``None`` if its snapshot has none).

        Raises:
            InvalidInput: a ``dt`` out of range.
            InvalidParameter: the server runs in real time.
        """
        if self._realtime:
            raise InvalidParameter(
                "step: expected a viewer started with realtime=False, got a real-time one"
            )
        value = check_range(
            "dt", dt, low=0.0, low_open=True, high=MAX_STEP_REQUEST, unit="s", error=InvalidInput
        )
        with self._lock:
            self._session.jog(self._jog_linear.copy(), self._jog_angular.copy())
            self._session.advance(value)
            t = self._session.snapshot().get("t")
        return None if t is None else float(t)

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the server stops or ``timeout`` [s] passes.

        Returns:
            Whether the server has stopped.
        """
        self._http_thread.join(timeout)
        return not self._http_thread.is_alive()

    def stop(self) -> None:
        """Stop stepping and serving, close the socket and join the threads (idempotent)."""
        if self._stopped:
            return
        self._stopped = True
        self._stopping.set()
        if self._step_thread is not None:
            self._step_thread.join()
        self._httpd.shutdown()
        self._httpd.server_close()
        self._http_thread.join()

    def __enter__(self) -> ViewerServer:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()

    def __repr__(self) -> str:
        mode = "realtime" if self._realtime else "step-on-request"
        state = "running" if self.running else "stopped"
        return f"ViewerServer({self.url}, {mode}, {state})"

    # -------------------------------------------------------------------------- front-end hooks
    # A subclass (velfence.apps.viewer.web.WebView) serves another page with its own headers and
    # forwards websocket upgrades; the checks of _Handler stay in front of all of it.
    _page_bytes: bytes = b""
    _security_headers: tuple[tuple[str, str], ...] = ()

    def _upgrade(self, handler: BaseHTTPRequestHandler) -> bool:
        """Take over a checked websocket handshake; ``False``: none served here (404)."""
        return False

    def _client_seen(self) -> None:
        """A client fetched the page or posted: the real-time clock may start."""
        self._started.set()

    # -------------------------------------------------------------------------- real time
    def _run_realtime(self) -> None:
        # Whatever stops this thread is recorded: a stepping thread that dies silently would
        # leave the page showing a frozen arm as if all were well.
        try:
            while not self._started.is_set():  # start=False: hold until a client shows up
                if self._stopping.wait(self._tick):
                    return
            last = time.monotonic()
            while not self._stopping.wait(self._tick):
                now = time.monotonic()
                dt = min(now - last, self._max_step)
                last = now
                if dt <= 0.0:
                    continue
                with self._lock:
                    if now - self._jog_time > self._jog_timeout:
                        self._jog_linear = np.zeros(3)
                        self._jog_angular = np.zeros(3)
                    self._session.jog(self._jog_linear.copy(), self._jog_angular.copy())
                    self._session.advance(dt)
        except Exception as exc:  # keep serving so the page can show what went wrong
            self._error = f"{type(exc).__name__}: {exc}"
            _log.debug("real-time stepping stopped", exc_info=True)


def serve(
    session: SessionLike,
    *,
    port: int = 0,
    realtime: bool = True,
    tick: float = 0.02,
    max_step: float = 0.1,
    jog_timeout: float = 0.5,
    connection_timeout: float = DEFAULT_CONNECTION_TIMEOUT,
    max_connections: int = DEFAULT_MAX_CONNECTIONS,
    start: bool = True,
) -> ViewerServer:
    """Serve ``session`` on ``http://127.0.0.1:port/`` and return the running server.

    Args:
        session: The session to show and drive (:class:`SessionLike`).
        port: TCP port; 0 (default) picks a free one.
        realtime: Advance with wall-clock time in a background thread (default); ``False``
            steps only on ``POST /step`` (tests, recordings).
        tick: Real-time stepping period [s], in [``MIN_TICK``, ``MAX_TICK``].
        max_step: Longest real-time advance [s], in (0, ``MAX_STEP_REQUEST``].
        jog_timeout: Real-time dead-man: a jog not renewed within this time [s] is zeroed;
            ``math.inf`` disables it.
        connection_timeout: Per-connection socket timeout [s].
        max_connections: Connections served at once; more are answered 503.
        start: Start the real-time clock at once (default); ``False`` waits for a client.

    Returns:
        The running :class:`ViewerServer`; call :meth:`ViewerServer.stop` (or use ``with``).

    Raises:
        InvalidParameter: a bad session, flag, port, time or count (see :class:`ViewerServer`).
        OSError: the port is in use.
    """
    return ViewerServer(
        session,
        port=port,
        realtime=realtime,
        tick=tick,
        max_step=max_step,
        jog_timeout=jog_timeout,
        connection_timeout=connection_timeout,
        max_connections=max_connections,
        start=start,
    )


# ---------------------------------------------------------------------------------- driver
_ACTIONS = ("key", "jog")


class _Backend(Protocol):
    def press(self, key: str) -> None: ...

    def jog(self, linear: FloatArray, angular: FloatArray) -> None: ...

    def advance_to(self, tau: float, dt: float) -> None: ...

    def state(self) -> dict[str, Any]: ...


class _LocalBackend:
    """Calls the session directly, re-sending the held jog before each advance like the server."""

    def __init__(self, session: SessionLike) -> None:
        self._session = session
        self._lin = np.zeros(3)
        self._ang = np.zeros(3)

    def press(self, key: str) -> None:
        self._session.press(key)

    def jog(self, linear: FloatArray, angular: FloatArray) -> None:
        self._lin, self._ang = linear, angular
        self._session.jog(linear.copy(), angular.copy())

    def advance_to(self, tau: float, dt: float) -> None:
        self._session.jog(self._lin.copy(), self._ang.copy())
        self._session.advance(dt)

    def state(self) -> dict[str, Any]:
        return dict(self._session.snapshot())


class _HTTPBackend:
    """Sends what the page sends; ``step`` posts ``/step``, otherwise waits on the wall clock."""

    def __init__(self, url: str, *, step: bool, timeout: float) -> None:
        self._base = url.rstrip("/")
        self._step = step
        self._timeout = timeout
        self._start = time.monotonic()
        self._wake = threading.Event()  # never set: its wait() paces the real-time mode

    def request(self, method: str, path: str, payload: Any = None) -> Any:
        data = None if payload is None else json.dumps(payload).encode()
        req = urllib.request.Request(self._base + path, data=data, method=method)
        if data is not None:
            req.add_header("Content-Type", "application/json")
        try:
            with urllib.request.urlopen(req, timeout=self._timeout) as resp:
                return json.loads(resp.read().decode())
        except urllib.error.HTTPError as exc:
            try:
                message = json.loads(exc.read().decode()).get("error", "")
            except (ValueError, AttributeError):
                message = ""
            raise InvalidInput(
                f"{method} {path}: the viewer answered {exc.code}: {message or exc.reason}"
            ) from None
        except urllib.error.URLError as exc:
            raise VelfenceError(
                f"{method} {path}: could not reach the viewer at {self._base} ({exc.reason}); "
                f"is it running?"
            ) from None

    def press(self, key: str) -> None:
        self.request("POST", "/key", {"key": key})

    def jog(self, linear: FloatArray, angular: FloatArray) -> None:
        self.request("POST", "/jog", {"linear": linear.tolist(), "angular": angular.tolist()})

    def advance_to(self, tau: float, dt: float) -> None:
        if self._step:
            self.request("POST", "/step", {"dt": dt})
        else:
            remaining = self._start + tau - time.monotonic()
            if remaining > 0.0:
                self._wake.wait(remaining)

    def state(self) -> dict[str, Any]:
        snap = self.request("GET", "/state")
        if not isinstance(snap, dict):
            raise InvalidInput(f"GET /state: expected a JSON object, got {type(snap).__name__}")
        snap.pop("viewer", None)
        return snap


class ScriptedDriver:
    """A scripted operator at the keyboard: the test double of a person using the viewer.

    The script is a list of ``(t, action, args)``, ``t`` [s] counted from the start of the run,
    non-decreasing; entries with equal ``t`` run in order. Actions:

    * ``("key", "A")`` — press a key (one of :data:`ALLOWED_KEYS`);
    * ``("jog", (linear, angular))`` — set the held master-hand velocity, [m/s] and [rad/s],
      shape (3,) each, until the next ``jog`` (``jog`` with zeros to stop).

    Between actions time advances in samples of ``sample_dt``; a snapshot is recorded at the
    start and after every advance, so the result can be fed to
    :func:`velfence.apps.viz.telerobotics.animate_session`.

    Args:
        script: The timed actions.

    Raises:
        InvalidParameter: a malformed entry (message names its index).
    """

    def __init__(self, script: Sequence[tuple[float, str, Any]]) -> None:
        entries: list[tuple[float, str, Any]] = []
        last = 0.0
        for i, entry in enumerate(script):
            try:
                t_raw, action, args = entry
            except (TypeError, ValueError):
                raise InvalidParameter(
                    f"script[{i}]: expected (t, action, args), got {entry!r}"
                ) from None
            if isinstance(t_raw, bool) or not isinstance(t_raw, int | float):
                raise InvalidParameter(f"script[{i}]: expected a time t [s], got {t_raw!r}")
            t = float(t_raw)
            if not (math.isfinite(t) and t >= last):
                raise InvalidParameter(
                    f"script[{i}]: expected a finite time >= {last:g} s (non-decreasing, from 0), "
                    f"got {t_raw!r}"
                )
            last = t
            try:
                if action == "key":
                    parsed: Any = _key(args)
                elif action == "jog":
                    try:
                        lin, ang = args
                    except (TypeError, ValueError):
                        raise InvalidInput(
                            f"jog: expected (linear, angular), got {args!r}"
                        ) from None
                    parsed = (
                        _vector("linear", lin, MAX_JOG_LINEAR, "m/s"),
                        _vector("angular", ang, MAX_JOG_ANGULAR, "rad/s"),
                    )
                else:
                    raise InvalidInput(f"action: expected one of {list(_ACTIONS)}, got {action!r}")
            except InvalidInput as exc:
                raise InvalidParameter(f"script[{i}]: {exc}") from None
            entries.append((t, str(action), parsed))
        self._script: tuple[tuple[float, str, Any], ...] = tuple(entries)

    @property
    def duration(self) -> float:
        """Time of the last action [s] (0 for an empty script)."""
        return self._script[-1][0] if self._script else 0.0

    @property
    def script(self) -> tuple[tuple[float, str, Any], ...]:
        """The validated script: keys upper case, jogs as arrays."""
        return self._script

    def run(
        self,
        url: str,
        *,
        until: float | None = None,
        sample_dt: float = 0.05,
        step: bool = True,
        timeout: float = 10.0,
    ) -> list[dict[str, Any]]:
        """Play the script against a running viewer over HTTP, as a browser would.

        Args:
            url: The viewer's URL (:attr:`ViewerServer.url`).
            until: Run until this time [s] (default: the last action's time).
            sample_dt: Spacing of recorded snapshots [s], > 0.
            step: Advance the server with ``POST /step`` (a ``realtime=False`` viewer; the
                default, deterministic); ``False`` waits on the wall clock instead, for a
                real-time viewer.
            timeout: Per-request timeout [s].

        Returns:
            The snapshots (``GET /state`` without its ``"viewer"`` entry), in time order.

        Raises:
            InvalidInput: the viewer rejected a request (status and message included).
            VelfenceError: the viewer could not be reached.
            InvalidParameter: bad ``until`` or ``sample_dt``.
        """
        wait = check_range(
            "timeout", timeout, low=0.0, low_open=True, high=MAX_CONNECTION_TIMEOUT, unit="s"
        )
        backend = _HTTPBackend(url, step=check_flag("step", step), timeout=wait)
        return self._play(backend, until, sample_dt)

    def replay(
        self, session: SessionLike, *, until: float | None = None, sample_dt: float = 0.05
    ) -> list[dict[str, Any]]:
        """Play the script in-process on ``session`` (same semantics as :meth:`run`, no HTTP).

        Args:
            session: The session to drive.
            until: Run until this time [s] (default: the last action's time).
            sample_dt: Spacing of recorded snapshots [s], > 0.

        Returns:
            The snapshots, in time order.
        """
        return self._play(_LocalBackend(session), until, sample_dt)

    def _play(
        self, backend: _Backend, until: float | None, sample_dt: float
    ) -> list[dict[str, Any]]:
        h = check_range("sample_dt", sample_dt, low=0.0, low_open=True, unit="s")
        if until is None:
            end, end_name = self.duration, "until (default: the script's last time)"
        else:
            end, end_name = check_range("until", until, low=0.0, unit="s"), "until"
        if end > 0.0:  # bounded before the first request: no endless loop, no huge list
            step_count(end_name, end, "sample_dt", h, max_steps=MAX_SAMPLES)
        sample_dt = h
        snapshots = [backend.state()]
        tau = 0.0
        i = 0
        n = len(self._script)
        eps = 1e-9
        while True:
            while i < n and self._script[i][0] <= tau + eps:
                _, action, args = self._script[i]
                if action == "key":
                    backend.press(args)
                else:
                    backend.jog(args[0], args[1])
                i += 1
            if tau >= end - eps:
                break
            next_sample = (math.floor(tau / sample_dt + eps) + 1) * sample_dt
            next_event = self._script[i][0] if i < n else math.inf
            target = min(next_sample, next_event, float(end))
            backend.advance_to(target, target - tau)
            tau = target
            snapshots.append(backend.state())
        return snapshots


# ---------------------------------------------------------------------------------- page
#: The page, shipped as package data next to this module: ``static/viewer.html`` (one inline
#: ``<script>`` and one inline ``<style>``, allowed by hash in the CSP below).
_PAGE_RESOURCE = "static/viewer.html"


def _load_page() -> str:
    """The viewer page's text, read from the installed package with :mod:`importlib.resources`."""
    try:
        return files("velfence.apps.viewer").joinpath(_PAGE_RESOURCE).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:  # a broken install: say which file is missing
        raise RuntimeError(
            f"viewer page: cannot read velfence.apps.viewer/{_PAGE_RESOURCE} from the installed "
            f"package ({exc}); reinstall velfence"
        ) from None


_PAGE = _load_page()


def _csp_hash(tag: str) -> str:
    """``'sha256-…'`` of the one inline ``<tag>`` element of the page, for the CSP."""
    found = re.findall(rf"<{tag}>(.*?)</{tag}>", _PAGE, flags=re.DOTALL)
    if len(found) != 1:  # a page edit that adds a second element must also extend the CSP
        raise RuntimeError(f"viewer page: expected one inline <{tag}>, found {len(found)}")
    digest = hashlib.sha256(found[0].encode()).digest()
    return f"'sha256-{base64.b64encode(digest).decode()}'"


_PAGE_BYTES = _PAGE.encode()
#: Sent on every response. The page runs only its own inline script and style (by hash), talks
#: only to this server, and may not be framed (no clickjacking of the arm's keys).
_CSP = (
    f"default-src 'none'; script-src {_csp_hash('script')}; style-src {_csp_hash('style')}; "
    "connect-src 'self'; img-src 'self'; base-uri 'none'; form-action 'none'; "
    "frame-ancestors 'none'"
)
_SECURITY_HEADERS: tuple[tuple[str, str], ...] = (
    ("X-Frame-Options", "DENY"),
    ("Content-Security-Policy", _CSP),
    ("X-Content-Type-Options", "nosniff"),
    ("Referrer-Policy", "same-origin"),
)
ViewerServer._page_bytes = _PAGE_BYTES
ViewerServer._security_headers = _SECURITY_HEADERS
