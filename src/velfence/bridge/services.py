"""ROS 2 services over DDS, as ``rmw_cyclonedds_cpp`` carries them.

A service ``/ns/node/get_parameters`` is two topics: requests on
``rq/ns/node/get_parametersRequest`` and replies on ``rr/ns/node/get_parametersReply``, both
reliable, keep-last 10, volatile (``rmw_qos_profile_services_default``). Each sample starts
with a header: the client's 64-bit request-writer id and a sequence number; the server answers
with the same two values, and a client keeps only the replies that carry its own id.

The USER_DATA of the server's reader and writer holds ``serviceid=<id>;`` (one id for the pair,
so that a client can tell which reply writer belongs to which request reader) and the type hash;
a client's pair holds ``clientid=<id>;``. Before replying, the server waits (briefly) until its
reply writer has matched the reader of the client that sent the request, as rmw_cyclonedds does:
a reply written before that match would be lost.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from velfence._docs import document_inits
from velfence.bridge.typehash import user_data

__all__ = [
    "REPLY_WAIT",
    "ServiceServer",
    "client_service_id",
    "reliable_qos",
    "user_data_value",
]

#: Longest time [s] a reply waits for the client's reply reader to match before it is dropped
#: (rmw_cyclonedds waits 100 ms in the call; here the loop retries without blocking).
REPLY_WAIT = 2.0


def client_service_id(participant_guid: bytes, counter: int) -> str:
    """The ``serviceid``/``clientid`` text rmw_cyclonedds builds for a service or client.

    The participant's GUID prefix (12 bytes) and a big-endian counter (4 bytes), written as hex
    bytes joined by ``.`` (the first padded to two digits, the others not, as ``std::hex`` does).

    Args:
        participant_guid: The participant's 16-byte DDS GUID.
        counter: This participant's running count of services and clients (from 1).

    Returns:
        ``"01.10.2a.…"``.
    """
    data = participant_guid[:12] + (counter & 0xFFFFFFFF).to_bytes(4, "big")
    return f"{data[0]:02x}" + "".join(f".{b:x}" for b in data[1:])


def user_data_value(userdata: Any, key: str) -> str | None:
    """The value of ``key`` in a ``k=v;k2=v2;`` USER_DATA (bytes), or None."""
    if not userdata:
        return None
    text = bytes(userdata).decode("ascii", errors="replace")
    for part in text.split(";"):
        k, sep, v = part.partition("=")
        if sep and k == key:
            return v
    return None


@dataclass
class _Pending:
    reply: Any
    writer_handle: int
    deadline: float


class ServiceServer:
    """One service: a request reader, a reply writer and the handler that answers.

    Args:
        participant: The ``cyclonedds.domain.DomainParticipant``.
        name: The fully qualified service name (``/ns/node/get_parameters``).
        request_type: The request class (its first fields ``_rmw_guid``, ``_rmw_seq``).
        response_type: The response class (likewise).
        handler: Called with each request; returns the response (its header is filled here).
        service_id: The ``serviceid`` text (:func:`client_service_id`).
    """

    def __init__(
        self,
        participant: Any,
        name: str,
        request_type: type,
        response_type: type,
        handler: Callable[[Any], Any],
        *,
        service_id: str,
    ) -> None:
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        self.name = name
        self._handler = handler
        self._response_type = response_type
        extra = f"serviceid={service_id};".encode("ascii")

        def qos(typ: type) -> Any:
            return reliable_qos(typ, extra)

        body = name.lstrip("/")
        self.reader: Any = DataReader(
            participant,
            Topic(participant, f"rq/{body}Request", request_type),
            qos=qos(request_type),
        )
        self.writer: Any = DataWriter(
            participant,
            Topic(participant, f"rr/{body}Reply", response_type),
            qos=qos(response_type),
        )
        self._pending: list[_Pending] = []
        self.answered = 0
        self.dropped = 0

    @property
    def entities(self) -> tuple[Any, Any]:
        """(request reader, reply writer)."""
        return self.reader, self.writer

    def poll(self, now: float) -> int:
        """Answer every waiting request (and retry replies whose client was not matched yet).

        Args:
            now: ``time.monotonic()`` [s].

        Returns:
            How many replies were written.
        """
        written = 0
        for sample in self.reader.take(N=64):
            info = getattr(sample, "sample_info", None)
            if info is not None and not info.valid_data:
                continue
            reply = self._handler(sample)
            reply._rmw_guid = sample._rmw_guid
            reply._rmw_seq = sample._rmw_seq
            handle = int(info.publication_handle) if info is not None else 0
            self._pending.append(_Pending(reply, handle, now + REPLY_WAIT))
        keep: list[_Pending] = []
        for p in self._pending:
            state = self._client_state(p.writer_handle)
            if state == "yes":
                self.writer.write(p.reply)
                written += 1
                self.answered += 1
            elif state == "maybe" and now < p.deadline:
                keep.append(p)
            else:
                self.dropped += 1
        self._pending = keep
        return written

    @property
    def waiting(self) -> bool:
        """Whether replies wait for their client's reader to match."""
        return bool(self._pending)

    def _client_state(self, writer_handle: int) -> str:
        """``yes`` (client's reply reader matched), ``maybe`` (not yet) or ``gone``."""
        if writer_handle == 0:
            return "yes"
        try:
            wr = self.reader.get_matched_publication_data(writer_handle)
        except Exception:
            return "gone"
        if wr is None:
            return "gone"
        clientid = user_data_value(_userdata(wr), "clientid")
        if clientid is None:  # a client without an id (older rmw, other vendors): assume matched
            return "yes"
        for handle in self.writer.get_matched_subscriptions():
            with contextlib.suppress(Exception):
                rd = self.writer.get_matched_subscription_data(handle)
                if rd is not None and user_data_value(_userdata(rd), "clientid") == clientid:
                    return "yes"
        return "maybe"


def _userdata(endpoint: Any) -> bytes | None:
    from cyclonedds.core import Policy

    qos = getattr(endpoint, "qos", None)
    if qos is None or Policy.Userdata not in qos:
        return None
    return bytes(qos[Policy.Userdata].data)


def reliable_qos(typ: type, extra: bytes = b"", *, depth: int = 10) -> Any:
    """Reliable, keep-last, volatile (ROS 2's default and services profile), typed USER_DATA.

    Args:
        typ: The message class (its type hash goes into USER_DATA).
        extra: USER_DATA before the hash (``b"serviceid=…;"``).
        depth: The history depth (10 as the default profile).

    Returns:
        A ``cyclonedds.core.Qos``.
    """
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    return Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
        Policy.History.KeepLast(depth),
        Policy.Durability.Volatile,
        Policy.Userdata(extra + user_data(typ)),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )


document_inits(globals())
