"""A TCP front for foxglove-sdk's server that also accepts the legacy subprotocol name.

foxglove-sdk's WebSocket server accepts a client only if its ``Sec-WebSocket-Protocol`` header
offers ``foxglove.sdk.v1`` (the name is fixed in the SDK's handshake; no option changes it) and
answers HTTP 400 otherwise. Clients of the Foxglove WebSocket protocol before the SDK offer
``foxglove.websocket.v1``; the messages after the handshake are the same protocol (server info,
advertisements, subscriptions, binary message data).

:class:`SubprotocolFront` listens on the view's address and forwards every connection, byte for
byte, to the SDK's server on an ephemeral loopback port. It touches one thing: the upgrade
request of a client that offers ``foxglove.websocket.v1`` and not ``foxglove.sdk.v1`` goes on
with that header replaced by ``foxglove.sdk.v1``, and the server's ``101`` answer goes back with
the name the client offered. The ``Sec-WebSocket-Accept`` key does not depend on the
subprotocol, so both ends see a valid handshake. Everything else (a client offering the SDK's
name, a plain HTTP request, a client offering neither name, which the SDK refuses) passes
through unchanged. ``docs/foxglove.md`` ("Legacy clients") argues the choice.
"""

from __future__ import annotations

import contextlib
import selectors
import socket
import threading

__all__ = ["LEGACY", "SDK", "SubprotocolFront"]

#: The subprotocol foxglove-sdk speaks, and the legacy name of the same protocol.
SDK = "foxglove.sdk.v1"
LEGACY = "foxglove.websocket.v1"

_HEADER = b"sec-websocket-protocol"
_MAX_HEAD = 64 * 1024  # an upgrade request or answer is a few hundred bytes
_HANDSHAKE_TIMEOUT = 10.0  # [s]


def _read_head(sock: socket.socket) -> tuple[bytes, bytes] | None:
    """The HTTP head (through the blank line) and any bytes after it; None if it never ends."""
    buf = b""
    while b"\r\n\r\n" not in buf:
        if len(buf) > _MAX_HEAD:
            return None
        chunk = sock.recv(4096)
        if not chunk:
            return None
        buf += chunk
    end = buf.index(b"\r\n\r\n") + 4
    return buf[:end], buf[end:]


def _offered(head: bytes) -> list[str]:
    """The subprotocols a request offers (every ``Sec-WebSocket-Protocol`` line)."""
    names: list[str] = []
    for line in head.split(b"\r\n")[1:]:
        key, sep, value = line.partition(b":")
        if sep and key.strip().lower() == _HEADER:
            names += [v.strip() for v in value.decode("latin-1").split(",") if v.strip()]
    return names


def _set_protocol(head: bytes, name: str) -> bytes:
    """``head`` with its ``Sec-WebSocket-Protocol`` lines replaced by one naming ``name``."""
    lines = head[:-4].split(b"\r\n")
    kept = [ln for ln in lines if ln.partition(b":")[0].strip().lower() != _HEADER]
    kept.append(b"Sec-WebSocket-Protocol: " + name.encode("latin-1"))
    return b"\r\n".join(kept) + b"\r\n\r\n"


def rename_request(head: bytes) -> tuple[bytes, bool]:
    """An upgrade request as the SDK accepts it, and whether the legacy name was renamed.

    Args:
        head: The request's HTTP head, through the blank line.

    Returns:
        ``(head, legacy)``: unchanged with ``False`` unless the request offers
        ``foxglove.websocket.v1`` and not ``foxglove.sdk.v1``.
    """
    offered = _offered(head)
    if SDK in offered or LEGACY not in offered:
        return head, False
    return _set_protocol(head, SDK), True


def rename_response(head: bytes) -> bytes:
    """The SDK's ``101`` answer naming the legacy subprotocol (another answer unchanged)."""
    status = head.split(b"\r\n", 1)[0].split()
    if len(status) < 2 or status[1] != b"101" or _offered(head) != [SDK]:
        return head
    return _set_protocol(head, LEGACY)


class SubprotocolFront:
    """Forward connections from ``(host, port)`` to the SDK's server on ``127.0.0.1:upstream``.

    Args:
        host: The interface to listen on (the view's ``host``).
        port: The port (``0``: any free one; read :attr:`port`).
        upstream: The SDK server's port on the loopback interface.

    Raises:
        OSError: the address cannot be bound (the port in use, an unknown host name).
    """

    def __init__(self, host: str, port: int, upstream: int) -> None:
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._listener = socket.create_server((host, port), family=family)
        self._listener.setblocking(False)
        self.port: int = int(self._listener.getsockname()[1])
        self._upstream = upstream
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._open: set[socket.socket] = set()
        self._threads: list[threading.Thread] = []
        self._accepting = threading.Thread(
            target=self._accept, name="velfence-foxglove-front", daemon=True
        )
        self._accepting.start()

    def close(self) -> None:
        """Stop listening and close every forwarded connection (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._accepting.join(timeout=2.0)
        with contextlib.suppress(OSError):
            self._listener.close()
        with self._lock:
            socks = list(self._open)
        for s in socks:
            with contextlib.suppress(OSError):
                s.shutdown(socket.SHUT_RDWR)
            with contextlib.suppress(OSError):
                s.close()
        for t in self._threads:
            t.join(timeout=2.0)

    def _accept(self) -> None:
        with selectors.DefaultSelector() as sel:
            sel.register(self._listener, selectors.EVENT_READ)
            while not self._stop.is_set():
                if not sel.select(timeout=0.1):
                    continue
                try:
                    client, _ = self._listener.accept()
                except (BlockingIOError, InterruptedError):
                    continue
                except OSError:
                    return
                t = threading.Thread(
                    target=self._serve, args=(client,), name="velfence-foxglove-conn", daemon=True
                )
                self._threads = [x for x in self._threads if x.is_alive()] + [t]
                t.start()

    def _track(self, *socks: socket.socket) -> None:
        with self._lock:
            self._open.update(socks)

    def _forget(self, *socks: socket.socket) -> None:
        with self._lock:
            self._open.difference_update(socks)
        for s in socks:
            with contextlib.suppress(OSError):
                s.close()

    def _serve(self, client: socket.socket) -> None:
        client.setblocking(True)
        self._track(client)
        upstream = None
        try:
            upstream = socket.create_connection(
                ("127.0.0.1", self._upstream), timeout=_HANDSHAKE_TIMEOUT
            )
            self._track(upstream)
            client.settimeout(_HANDSHAKE_TIMEOUT)
            request = _read_head(client)
            if request is None:
                return
            head, legacy = rename_request(request[0])
            upstream.sendall(head + request[1])
            answer = _read_head(upstream)
            if answer is None:
                return
            client.sendall((rename_response(answer[0]) if legacy else answer[0]) + answer[1])
            client.settimeout(None)
            upstream.settimeout(None)
            self._pump(client, upstream)
        except OSError:
            pass  # a client or the server went away: the connection ends
        finally:
            self._forget(client, *([] if upstream is None else [upstream]))

    def _pump(self, a: socket.socket, b: socket.socket) -> None:
        other = {a: b, b: a}
        with selectors.DefaultSelector() as sel:
            sel.register(a, selectors.EVENT_READ)
            sel.register(b, selectors.EVENT_READ)
            while not self._stop.is_set():
                for key, _ in sel.select(timeout=0.2):
                    src: socket.socket = key.fileobj  # type: ignore[assignment]
                    data = src.recv(65536)
                    if not data:
                        return
                    other[src].sendall(data)
