"""A ROS 2 tool's view of the bridge, in its own process: ``python ros_graph_client.py SPEC``.

Every request is encoded and every reply, discovery and log sample decoded with rosbags'
typestore, from the published definitions in ros_graph_defs.py; velfence's message classes are
not used. Cyclone DDS only carries the bytes: the topic types are IDL structs built here from the
rosbags definitions (so the peers' XTypes descriptions agree), whose (de)serialisation is
replaced by rosbags'. A request is the 16-byte rmw_cyclonedds header (writer id, sequence
number) followed by the CDR body; a reply is kept only if it carries this client's id.

The spec's ``calls`` are run in order: ``[service suffix, srv type, request fields]``; the
result is one JSON object with the decoded replies, the discovery info and the /rosout lines.
"""

from __future__ import annotations

import json
import random
import struct
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsParticipant,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
)
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import make_idl_struct
from cyclonedds.idl import types as t
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

sys.path.insert(0, str(Path(__file__).parent))
from ros_graph_defs import typestore

TIMEOUT = 15.0
_BASE = {
    "bool": bool, "byte": t.byte, "char": t.uint8, "uint8": t.uint8, "int8": t.int8,
    "int32": t.int32, "uint32": t.uint32, "int64": t.int64, "uint64": t.uint64,
    "float64": t.float64, "string": str,
}  # fmt: skip


class Raw:
    """What the reader returns: the sample's bytes (decoded with rosbags afterwards)."""

    def __init__(self, data: bytes) -> None:
        self.data = data


class Peer:
    def __init__(self, store: Any, dp: DomainParticipant) -> None:
        self.store = store
        self.dp = dp
        self._structs: dict[str, Any] = {}

    def struct_of(self, name: str, header: bool = False) -> Any:
        """An IDL struct for the rosbags type ``name`` (DDS name ``pkg::kind::dds_::Type_``)."""
        key = name + ("+h" if header else "")
        if key in self._structs:
            return self._structs[key]
        pkg, kind, base = name.split("/")
        fields: dict[str, Any] = {}
        if header:
            fields = {"_rmw_guid": t.uint64, "_rmw_seq": t.int64}
        for fname, desc in self.store.fielddefs[name][1]:
            fields[fname] = self.annotation(desc)
        cls = make_idl_struct(
            f"P_{pkg}_{base}{'_h' if header else ''}", f"{pkg}::{kind}::dds_::{base}_", fields
        )
        cls.deserialize = classmethod(lambda c, data, **_kw: Raw(bytes(data)))
        self._structs[key] = cls
        return cls

    def annotation(self, desc: Any) -> Any:
        node, spec = desc
        node = int(node)
        if node == 1:  # BASE
            typ, bound = spec
            if typ == "string" and bound:
                return t.bounded_str[bound]
            return _BASE[typ]
        if node == 2:  # NAME
            return self.struct_of(spec)
        sub, n = spec
        if node == 3:  # ARRAY
            return t.array[self.annotation(sub), n]
        return t.sequence[self.annotation(sub), n] if n else t.sequence[self.annotation(sub)]

    def topic(self, topic: str, name: str, header: bool = False) -> Topic:
        return Topic(self.dp, topic, self.struct_of(name, header))

    def sample(self, cls: Any, data: bytes) -> Any:
        obj = cls.__new__(cls)
        obj.serialize = lambda **_kw: data
        return obj


def qos(*, transient: bool = False, depth: int = 10, userdata: bytes = b"") -> Qos:
    return Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(seconds=1)),
        Policy.Durability.TransientLocal if transient else Policy.Durability.Volatile,
        Policy.History.KeepLast(depth),
        Policy.Userdata(userdata),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )


def wait_for(cond: Any, what: str, timeout: float = TIMEOUT) -> None:
    end = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > end:
            raise SystemExit(f"timed out waiting for {what}")
        time.sleep(0.005)


def plain(msg: Any) -> Any:
    """A rosbags message as JSON-able data."""
    if hasattr(msg, "__msgtype__"):
        return {k: plain(getattr(msg, k)) for k in msg.__dataclass_fields__ if k != "__msgtype__"}
    if isinstance(msg, (list, tuple)):
        return [plain(x) for x in msg]
    if hasattr(msg, "tolist"):
        return msg.tolist()
    return msg


class Client:
    """One service client: request writer + reply reader with a shared ``clientid``."""

    def __init__(self, peer: Peer, service: str, srv: str, cid: int) -> None:
        self.peer, self.srv = peer, srv
        body = service.lstrip("/")
        ud = f"clientid=ab.{cid:x};".encode()
        self.writer = DataWriter(
            peer.dp, peer.topic(f"rq/{body}Request", srv + "_Request", True), qos=qos(userdata=ud)
        )
        self.reader = DataReader(
            peer.dp, peer.topic(f"rr/{body}Reply", srv + "_Response", True), qos=qos(userdata=ud)
        )
        self.guid = random.SystemRandom().getrandbits(63)
        self.seq = 0

    def call(self, fields: dict[str, Any]) -> Any:
        wait_for(
            lambda: (
                self.writer.get_matched_subscriptions() and self.reader.get_matched_publications()
            ),
            f"the service {self.srv}",
        )
        store = self.peer.store
        req = make(store, self.srv + "_Request", fields)
        cdr = bytes(store.serialize_cdr(req, self.srv + "_Request"))
        self.seq += 1
        wire = cdr[:4] + struct.pack("<Qq", self.guid, self.seq) + cdr[4:]
        self.writer.write(self.peer.sample(self.writer.topic.data_type, wire))
        found: list[Any] = []

        def got() -> bool:
            for s in self.reader.take(N=10):
                if not isinstance(s, Raw):
                    continue
                guid, seq = struct.unpack_from("<Qq", s.data, 4)
                if guid == self.guid and seq == self.seq:
                    found.append(
                        store.deserialize_cdr(s.data[:4] + s.data[20:], self.srv + "_Response")
                    )
            return bool(found)

        wait_for(got, f"the reply of {self.srv}")
        return found[0]


_NP = {"uint8": "uint8", "byte": "uint8", "char": "uint8", "int64": "int64",
       "uint64": "uint64", "float64": "float64", "bool": "bool", "int32": "int32"}  # fmt: skip


def make(store: Any, name: str, fields: dict[str, Any]) -> Any:
    """A rosbags message of type ``name``: the given fields, every other one at its default."""
    values: dict[str, Any] = {}
    for fname, desc in store.fielddefs[name][1]:
        if fname in fields:
            values[fname] = convert(store, desc, fields[fname])
        else:
            values[fname] = convert(store, desc, None)
    return store.types[name](**values)


def convert(store: Any, desc: Any, value: Any) -> Any:
    node, spec = int(desc[0]), desc[1]
    if node == 1:
        typ = spec[0]
        if value is not None:
            return value
        return "" if typ == "string" else False if typ == "bool" else 0.0 if "float" in typ else 0
    if node == 2:
        value = dict(value or {})
        value.pop("__type__", None)
        return make(store, spec, value)
    sub, _n = spec
    items = list(value or [])
    if int(sub[0]) == 1 and sub[1][0] != "string":
        return np.array(items, dtype=_NP[sub[1][0]])
    return [convert(store, sub, v) for v in items]


def main() -> None:
    spec = json.loads(Path(sys.argv[1]).read_text(encoding="utf-8"))
    store = typestore(spec.get("distro", "jazzy"))
    dp = DomainParticipant(int(spec["domain"]))
    peer = Peer(store, dp)
    out: dict[str, Any] = {"calls": []}
    fqn = spec["node"]
    clients: dict[str, Client] = {}
    for i, (suffix, srv, fields) in enumerate(spec.get("calls", [])):
        if suffix not in clients:
            clients[suffix] = Client(peer, f"{fqn}/{suffix}", srv, i + 1)
        out["calls"].append(plain(clients[suffix].call(fields)))
    if spec.get("discovery"):
        info_name = "rmw_dds_common/msg/ParticipantEntitiesInfo"
        rd = DataReader(
            dp, peer.topic("ros_discovery_info", info_name), qos=qos(transient=True, depth=1)
        )
        parts = BuiltinDataReader(dp, BuiltinTopicDcpsParticipant)
        pubs = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
        subs = BuiltinDataReader(dp, BuiltinTopicDcpsSubscription)
        infos: list[Any] = []
        ents: dict[str, list[Any]] = {"participants": [], "publications": [], "subscriptions": []}

        def seen() -> bool:
            for s in rd.take(N=50):
                if isinstance(s, Raw):
                    infos.append(plain(store.deserialize_cdr(s.data, info_name)))
            for k, r in (("participants", parts), ("publications", pubs), ("subscriptions", subs)):
                for e in r.take(N=500):
                    ud = e.qos[Policy.Userdata].data.decode() if Policy.Userdata in e.qos else ""
                    ents[k].append({
                        "key": e.key.hex, "topic": getattr(e, "topic_name", None),
                        "type": getattr(e, "type_name", None), "user_data": ud,
                        "participant": getattr(getattr(e, "participant_key", None), "hex", None),
                    })  # fmt: skip
            return any(
                n["node_name"] == spec["node_name"]
                for i in infos
                for n in i["node_entities_info_seq"]
            ) and len(ents["publications"]) >= int(spec.get("min_publications", 1))

        wait_for(seen, "the bridge's ros_discovery_info")
        time.sleep(0.5)  # builtin topics: let the rest of this node's endpoints arrive
        seen()
        out["discovery"] = infos
        out["entities"] = ents
    if spec.get("rosout"):
        rd = DataReader(
            dp,
            peer.topic("rt/rosout", "rcl_interfaces/msg/Log"),
            qos=qos(transient=True, depth=1000),
        )
        logs: list[Any] = []

        def logged() -> bool:
            for s in rd.take(N=1000):
                if isinstance(s, Raw):
                    logs.append(plain(store.deserialize_cdr(s.data, "rcl_interfaces/msg/Log")))
            return any(spec["rosout"] in str(x["msg"]) for x in logs)

        wait_for(logged, "a /rosout line")
        out["rosout"] = logs
    sys.stdout.write(json.dumps(out))


if __name__ == "__main__":
    main()
