"""A ROS 2 tool's view of the bridge, in its own process.

``python ros_graph_client.py SPEC`` runs one spec and prints its JSON result;
``python ros_graph_client.py --serve DOMAIN`` keeps one participant and runs every spec read as a
JSON line from stdin, answering each with a JSON line (``{"ready": true}`` first for a spec that
asks for it, once its readers exist; then ``{"result": …}`` or ``{"error": …}``).

Every request is encoded and every reply, discovery and log sample decoded with rosbags'
typestore, from the published definitions in ros_graph_defs.py; velfence's message classes are
not used. Cyclone DDS only carries the bytes: the topic types are IDL structs built here from the
rosbags definitions (so the peers' XTypes descriptions agree), whose (de)serialisation is
replaced by rosbags'. A request is the 16-byte rmw_cyclonedds header (writer id, sequence
number) followed by the CDR body; a reply is kept only if it carries this client's id.

The spec's ``calls`` are run in order: ``[service suffix, srv type, request fields]``; the
result is one JSON object with the decoded replies, the discovery info and the /rosout lines.
With ``events_before_calls: n`` the calls wait until n parameter events came (a first event
proves the bridge's writer has matched this reader, so none written later is lost).
A spec's ``script`` is a timeline instead: service calls, the manager's side of a Nav2 bond
(bondcpp's protocol on ``<ns>/bond``), a command stream with a fresh odometry, and pauses; every
step, bond status, output and parameter event is recorded with its time.
"""

from __future__ import annotations

import json
import random
import struct
import sys
import threading
import time
import uuid
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
    "float32": t.float32, "float64": t.float64, "string": str,
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


_CLIENT_IDS = iter(range(1, 1 << 30))


class Client:
    """One service client: request writer + reply reader with a shared ``clientid``."""

    def __init__(self, peer: Peer, service: str, srv: str) -> None:
        cid = next(_CLIENT_IDS)
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
       "uint64": "uint64", "float64": "float64", "float32": "float32", "bool": "bool",
       "int32": "int32"}  # fmt: skip


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
    sub, n = spec
    items = list(value or [])
    if node == 3 and not items:  # a fixed-size array: n default elements
        items = [convert(store, sub, None) for _ in range(n)]
    if int(sub[0]) == 1 and sub[1][0] != "string":
        return np.array(items, dtype=_NP[sub[1][0]])
    return [convert(store, sub, v) for v in items]


class Script:
    """A timeline of steps against one bridge, with a background thread for the periodic work."""

    def __init__(self, peer: Peer, spec: dict[str, Any], clients: dict[str, Client]) -> None:
        self.peer, self.spec, self.clients = peer, spec, clients
        self.t0 = time.monotonic()
        self.events: list[dict[str, Any]] = []
        self.lock = threading.Lock()
        self.done = threading.Event()
        ns = spec["namespace"].strip("/")
        st = peer.store
        self.bond_name = "bond/msg/Status"
        bond_topic = peer.topic(f"rt/{ns}/bond", self.bond_name)
        self.bond_w = DataWriter(peer.dp, bond_topic, qos=qos(depth=5))
        self.bond_r = DataReader(peer.dp, bond_topic, qos=qos(depth=100))
        self.bond: dict[str, Any] | None = None  # the manager's side
        self.own: set[str] = set()  # the manager's instance ids (its own statuses come back)
        twist, odom = "geometry_msgs/msg/Twist", "nav_msgs/msg/Odometry"
        self.cmd_w = DataWriter(peer.dp, peer.topic(f"rt/{ns}/cmd_in", twist), qos=qos())
        self.odom_w = DataWriter(peer.dp, peer.topic(f"rt/{ns}/odom", odom), qos=qos())
        self.out_r = DataReader(peer.dp, peer.topic(f"rt/{ns}/cmd_out", twist), qos=qos(depth=100))
        self.stream: dict[str, Any] | None = None
        self.sent = 0
        self.odom = bytes(
            st.serialize_cdr(
                make(st, odom, {"pose": {"pose": {"position": {"x": 2.0, "y": 1.5},
                                                  "orientation": {"w": 1.0}}}}),
                odom,
            )
        )  # fmt: skip
        self.thread = threading.Thread(target=self._tick, daemon=True)
        self.thread.start()

    def now(self) -> float:
        return time.monotonic() - self.t0

    def record(self, kind: str, **data: Any) -> None:
        with self.lock:
            self.events.append({"t": self.now(), "kind": kind, **data})

    # ---------------------------------------------------------------- periodic work
    def _tick(self) -> None:
        st = self.peer.store
        while not self.done.is_set():
            for s in self.bond_r.take(N=100):
                if isinstance(s, Raw):
                    m = st.deserialize_cdr(s.data, self.bond_name)
                    self._on_status(m)
            for s in self.out_r.take(N=100):
                if isinstance(s, Raw):
                    m = st.deserialize_cdr(s.data, "geometry_msgs/msg/Twist")
                    self.record(
                        "out",
                        linear=[m.linear.x, m.linear.y, m.linear.z],
                        angular=[m.angular.x, m.angular.y, m.angular.z],
                    )
            t = time.monotonic()
            b = self.bond
            if b is not None and b["state"] in ("waiting", "alive") and t >= b["next"]:
                self._status(True)
                b["next"] = t + b["period"]
            sm = self.stream
            if sm is not None and t >= sm["next"]:
                self.odom_w.write(self.peer.sample(self.odom_w.topic.data_type, self.odom))
                self.cmd_w.write(self.peer.sample(self.cmd_w.topic.data_type, sm["cmd"]))
                self.sent += 1
                self.record("cmd")
                sm["next"] = t + 1.0 / sm["rate"]
            time.sleep(0.002)

    def _on_status(self, m: Any) -> None:
        b = self.bond
        if m.id != self.spec["node_name"] or m.instance_id in self.own:
            return
        self.record(
            "bond",
            instance_id=m.instance_id,
            active=bool(m.active),
            heartbeat_period=float(m.heartbeat_period),
            heartbeat_timeout=float(m.heartbeat_timeout),
        )
        if b is None:
            return
        if m.active and b["state"] == "waiting":
            b["state"] = "alive"
            self.record("bond_formed")
        elif not m.active and b["state"] == "dying":
            b["state"] = "dead"
            self.record("bond_ack")
        elif not m.active and b["state"] in ("waiting", "alive"):
            b["state"] = "dead"  # the sister died first: acknowledge it, as bondcpp does
            self._status(False)
            self.record("bond_broken_by_node")

    def _status(self, active: bool) -> None:
        b = self.bond
        assert b is not None
        st = self.peer.store
        ns = time.time_ns()
        msg = make(st, self.bond_name, {
            "header": {"stamp": {"sec": ns // 10**9, "nanosec": ns % 10**9}},
            "id": self.spec["node_name"], "instance_id": b["instance"], "active": active,
            "heartbeat_timeout": b["timeout"], "heartbeat_period": b["period"],
        })  # fmt: skip
        self.bond_w.write(
            self.peer.sample(
                self.bond_w.topic.data_type, bytes(st.serialize_cdr(msg, self.bond_name))
            )
        )

    # ---------------------------------------------------------------- steps
    def run(self) -> dict[str, Any]:
        try:
            for step in self.spec["script"]:
                self.step(step)
        finally:
            self.done.set()
            self.thread.join(5.0)
        return {"events": self.events, "sent": self.sent}

    def step(self, step: list[Any]) -> None:
        kind = step[0]
        if kind == "call":
            _, label, suffix, srv, fields = step
            if suffix not in self.clients:
                self.clients[suffix] = Client(self.peer, f"{self.spec['node']}/{suffix}", srv)
            self.record("call", label=label)
            reply = plain(self.clients[suffix].call(fields))
            self.record("reply", label=label, reply=reply)
        elif kind == "bond_start":  # the manager's createBondConnection
            _, period, timeout = step
            with self.lock:
                self.own.add(instance := str(uuid.uuid4()))
                self.bond = {"instance": instance, "state": "waiting", "next": 0.0,
                             "period": float(period), "timeout": float(timeout)}  # fmt: skip
            self.record("bond_start")
        elif kind == "bond_break":  # the manager ends the bond first (breakBond)
            with self.lock:
                assert self.bond is not None
                self.bond["state"] = "dying"
            self._status(False)
            self.record("bond_break")
        elif kind == "wait_matched":  # the stream's writers and the output reader found the bridge
            wait_for(
                lambda: (
                    self.cmd_w.get_matched_subscriptions()
                    and self.odom_w.get_matched_subscriptions()
                    and self.out_r.get_matched_publications()
                ),
                "the bridge's command, state and output topics",
            )
            self.record("matched")
        elif kind == "bond_wait_formed":  # waitUntilFormed(bond_timeout / 2)
            end = time.monotonic() + float(step[1])
            while time.monotonic() < end and self.bond is not None:
                if self.bond["state"] != "waiting":
                    break
                time.sleep(0.005)
            self.record("formed", ok=self.bond is not None and self.bond["state"] == "alive")
        elif kind == "stream":
            _, rate, linear = step
            if rate:
                st = self.peer.store
                twist = "geometry_msgs/msg/Twist"
                cmd = make(st, twist, {"linear": {"x": linear[0], "y": linear[1], "z": 0.0}})
                self.stream = {"rate": float(rate), "next": 0.0,
                               "cmd": bytes(st.serialize_cdr(cmd, twist))}  # fmt: skip
            else:
                self.stream = None
            self.record("stream", rate=rate)
        elif kind == "wait_outputs":  # until n outputs came after the last mark
            _, n, timeout = step
            start = self.now()
            end = time.monotonic() + float(timeout)

            def count() -> int:
                with self.lock:
                    return sum(1 for e in self.events if e["kind"] == "out" and e["t"] >= start)

            while count() < int(n) and time.monotonic() < end:
                time.sleep(0.005)
            self.record("outputs", n=count())
        elif kind == "pause":  # an observation window: what arrives (or not) meanwhile
            time.sleep(float(step[1]))
            self.record("pause_end")
        else:
            raise SystemExit(f"unknown step {kind!r}")


class Context:
    """What one peer process keeps between specs: participant, peers per distro, shared readers."""

    def __init__(self, domain: int) -> None:
        self.dp = DomainParticipant(domain)
        self.peers: dict[str, Peer] = {}
        self.readers: dict[str, Any] = {}

    def peer(self, distro: str) -> Peer:
        if distro not in self.peers:
            self.peers[distro] = Peer(typestore(distro), self.dp)
        return self.peers[distro]

    def reader(self, key: str, make_reader: Any) -> Any:
        if key not in self.readers:
            self.readers[key] = make_reader()
        return self.readers[key]


def run(spec: dict[str, Any], ctx: Context, ready: Any) -> dict[str, Any]:
    distro = spec.get("distro", "jazzy")
    peer = ctx.peer(distro)
    store, dp = peer.store, ctx.dp
    out: dict[str, Any] = {"calls": []}
    fqn = spec["node"]
    events: list[Any] = []
    ev_reader = None
    if spec.get("parameter_events") or spec.get("script") is not None:
        ev_name = "rcl_interfaces/msg/ParameterEvent"
        ev_reader = ctx.reader(
            "parameter_events",
            lambda: DataReader(dp, peer.topic("rt/parameter_events", ev_name), qos=qos(depth=1000)),
        )

        def take_events() -> None:
            for s in ev_reader.take(N=1000):
                if isinstance(s, Raw):
                    e = plain(store.deserialize_cdr(s.data, ev_name))
                    if e["node"] == fqn:
                        events.append(e)

    if spec.get("ready"):
        ready()
    if spec.get("events_before_calls"):  # e.g. the start event: then the writer has matched us
        first = int(spec["events_before_calls"])
        wait_for(lambda: take_events() or len(events) >= first, "the first parameter events")
    clients: dict[str, Client] = {}
    for suffix, srv, fields in spec.get("calls", []):
        if suffix not in clients:
            clients[suffix] = Client(peer, f"{fqn}/{suffix}", srv)
        out["calls"].append(plain(clients[suffix].call(fields)))
    if spec.get("script") is not None:
        out["script"] = Script(peer, spec, clients).run()
    if spec.get("parameter_events"):
        want = int(spec["parameter_events"])
        wait_for(lambda: take_events() or len(events) >= want, "parameter events")
    if ev_reader is not None:
        take_events()
        out["parameter_events"] = events
    if spec.get("discovery"):
        info_name = "rmw_dds_common/msg/ParticipantEntitiesInfo"
        rd = ctx.reader(
            f"discovery-{distro}",
            lambda: DataReader(
                dp, peer.topic("ros_discovery_info", info_name), qos=qos(transient=True, depth=1)
            ),
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
        log_name = "rcl_interfaces/msg/Log"
        rd = ctx.reader(
            "rosout",
            lambda: DataReader(
                dp, peer.topic("rt/rosout", log_name), qos=qos(transient=True, depth=1000)
            ),
        )
        logs: list[Any] = []

        def logged() -> bool:
            for s in rd.take(N=1000):
                if isinstance(s, Raw):
                    logs.append(plain(store.deserialize_cdr(s.data, log_name)))
            return any(spec["rosout"] in str(x["msg"]) for x in logs)

        wait_for(logged, "a /rosout line")
        out["rosout"] = logs
    return out


def _line(obj: Any) -> None:
    sys.stdout.write(json.dumps(obj) + "\n")
    sys.stdout.flush()


def main() -> None:
    if sys.argv[1] == "--serve":
        ctx = Context(int(sys.argv[2]))
        for raw in sys.stdin:
            if not raw.strip():
                continue
            try:
                _line({"result": run(json.loads(raw), ctx, lambda: _line({"ready": True}))})
            except (Exception, SystemExit) as exc:
                _line({"error": f"{type(exc).__name__}: {exc}"})
        return
    spec = json.loads(Path(sys.argv[1]).read_text(encoding="utf-8"))
    ctx = Context(int(spec["domain"]))
    sys.stdout.write(json.dumps(run(spec, ctx, lambda: None)))


if __name__ == "__main__":
    main()
