"""A ROS 2 peer for the bridge tests, run in its own process: ``python ros_client.py SPEC.json``.

It joins the DDS domain with its own participant, publishes and subscribes with the ROS 2 type
names (``rt/<topic>``, ``pkg::msg::dds_::Type_``) and prints one JSON object with what it saw.
Scenarios (``spec["scenario"]``):

* ``stream``: keep a state fresh (optionally switching it to other values after a command:
  ``state_switch``), send ``commands`` at ``rate_hz`` (optionally pausing), collect
  every output with its receive time; a command item with ``raw_frame_id`` (hex) is a
  TwistStamped this peer encodes byte by byte (:func:`cdr_twist_stamped`), e.g. with a frame
  id that is not UTF-8;
* ``qos``: open a best-effort writer against the bridge's reliable command reader and a
  transient-local reader against its volatile writer (both mismatches), then read diagnostics;
* ``qos_one``: one command writer with one incompatible policy (``mismatch``:
  ``data_representation``, XCDR2 only, or ``reliability``), then read diagnostics;
* ``endpoints``: read the builtin DCPSPublication/DCPSSubscription topics and report the type
  name and USER_DATA of every endpoint on the given topics.

Sleeps here only pace the publishing; every wait for the bridge is a condition with a deadline.
"""

from __future__ import annotations

import json
import math
import struct
import sys
import time
from pathlib import Path
from typing import Any

from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
)
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from velfence.bridge import msgs
from velfence.bridge.typehash import user_data

TYPES = {
    "twist": msgs.Twist,
    "twist_stamped": msgs.TwistStamped,
    "joint_jog": msgs.JointJog,
    "float64_multi_array": msgs.Float64MultiArray,
    "joint_trajectory": msgs.JointTrajectory,
    "joint_state": msgs.JointState,
    "pose_stamped": msgs.PoseStamped,
    "odometry": msgs.Odometry,
}
DISCOVERY_S = 15.0
_STORE: Any = None


def qos(typ: type, *, reliable: bool = True, depth: int = 10, transient: bool = False) -> Qos:
    rel = (
        Policy.Reliability.Reliable(max_blocking_time=duration(seconds=1))
        if reliable
        else Policy.Reliability.BestEffort
    )
    dur = Policy.Durability.TransientLocal if transient else Policy.Durability.Volatile
    return Qos(
        rel,
        dur,
        Policy.History.KeepLast(depth),
        Policy.Userdata(user_data(typ)),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )


def wait_for(cond: Any, what: str, timeout: float = DISCOVERY_S) -> None:
    end = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > end:
            raise SystemExit(f"timed out waiting for {what}")
        time.sleep(0.005)


def cdr_twist_stamped(
    sec: int, frame_id: bytes, linear: list[float], angular: list[float]
) -> bytes:
    """A TwistStamped in plain little-endian CDR, encoded here byte by byte (not by the binding).

    The frame id is written as raw bytes (length with the NUL, the bytes, the NUL), so it can
    hold what no encoder would write: bytes that are not UTF-8.
    """
    body = struct.pack("<iI", sec, 0)  # header.stamp
    body += struct.pack("<I", len(frame_id) + 1) + frame_id + b"\0"
    body += b"\0" * (-len(body) % 8)  # the float64s align to 8 (from the body's start)
    body += struct.pack("<6d", *linear, *angular)
    return b"\x00\x01\x00\x00" + body  # encapsulation: CDR_LE, no options


class RawSample:
    """Makes ``DataWriter.write`` send given bytes: it writes what ``serialize`` returns."""

    @staticmethod
    def of(typ: type, data: bytes) -> Any:
        sample = typ()
        sample.serialize = lambda use_version_2=None: data  # the writer pads to 4 bytes
        return sample


def make_command(typ: str, item: dict[str, Any], index: int) -> Any:
    if "raw_frame_id" in item:  # a hostile TwistStamped: its frame id as hex bytes
        lin = ([*(float(x) for x in item.get("values", [])), 0.0, 0.0, 0.0])[:3]
        data = cdr_twist_stamped(index, bytes.fromhex(item["raw_frame_id"]), lin, [0.0] * 3)
        return RawSample.of(TYPES[typ], data)
    values = [float(x) for x in item["values"]]
    stamp = msgs.Time(sec=index, nanosec=0)
    if typ in ("twist", "twist_stamped"):
        lin = ([*values, 0.0, 0.0, 0.0])[:3]
        ang = [float(x) for x in item.get("angular", [0.0, 0.0, 0.0])]
        tw = msgs.Twist(
            linear=msgs.Vector3(x=lin[0], y=lin[1], z=lin[2]),
            angular=msgs.Vector3(x=ang[0], y=ang[1], z=ang[2]),
        )
        if typ == "twist":
            return tw
        frame = str(item.get("frame_id", "cmd"))
        return msgs.TwistStamped(header=msgs.Header(stamp=stamp, frame_id=frame), twist=tw)
    if typ == "float64_multi_array":
        return msgs.Float64MultiArray(data=values)
    return msgs.JointJog(
        header=msgs.Header(stamp=stamp), joint_names=list(item["names"]), velocities=values
    )


def make_state(spec: dict[str, Any]) -> Any:
    typ, values = spec["type"], [float(x) for x in spec["values"]]
    if typ == "joint_state":
        return msgs.JointState(name=list(spec["names"]), position=values)
    xyz = ([*values, 0.0, 0.0, 0.0])[:3]
    yaw = float(spec.get("yaw", 0.0))
    q = msgs.Quaternion(z=math.sin(yaw / 2), w=math.cos(yaw / 2))
    pose = msgs.Pose(position=msgs.Point(x=xyz[0], y=xyz[1], z=xyz[2]), orientation=q)
    if typ == "pose_stamped":
        return msgs.PoseStamped(pose=pose)
    return msgs.Odometry(pose=msgs.PoseWithCovariance(pose=pose))


def output_values(typ: str, m: Any) -> tuple[int | None, list[float]]:
    if typ in ("twist", "twist_stamped"):
        tw = m.twist if typ == "twist_stamped" else m
        idx = m.header.stamp.sec if typ == "twist_stamped" else None
        return idx, [
            tw.linear.x,
            tw.linear.y,
            tw.linear.z,
            tw.angular.x,
            tw.angular.y,
            tw.angular.z,
        ]
    if typ == "float64_multi_array":
        return None, list(m.data)
    if typ == "joint_jog":
        return m.header.stamp.sec, list(m.velocities)
    return m.header.stamp.sec, list(m.points[0].velocities)


def tf_message(transforms: list[dict[str, Any]]) -> Any:
    """A tf2_msgs/TFMessage encoded by rosbags' typestore, written as those bytes."""
    store = typestore()
    tm = store.types
    msg = tm["tf2_msgs/msg/TFMessage"](
        transforms=[
            tm["geometry_msgs/msg/TransformStamped"](
                header=tm["std_msgs/msg/Header"](
                    stamp=tm["builtin_interfaces/msg/Time"](sec=0, nanosec=0),
                    frame_id=t["parent"],
                ),
                child_frame_id=t["child"],
                transform=tm["geometry_msgs/msg/Transform"](
                    translation=tm["geometry_msgs/msg/Vector3"](*t.get("xyz", [0.0, 0.0, 0.0])),
                    rotation=tm["geometry_msgs/msg/Quaternion"](*t["xyzw"]),
                ),
            )
            for t in transforms
        ]
    )
    data = bytes(store.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))
    return RawSample.of(msgs.TFMessage, data)


def cloud_message(cloud: dict[str, Any]) -> Any:
    """A sensor_msgs/PointCloud2 (x, y, z FLOAT32 and a padding float: point_step 16) stamped
    now, encoded by rosbags' typestore and written as those bytes."""
    store = typestore()
    tm = store.types
    pts = [[float(x) for x in p] for p in cloud["points"]]
    data = b"".join(struct.pack("<4f", *p, 0.0) for p in pts)
    ns = time.time_ns()
    fields = [
        tm["sensor_msgs/msg/PointField"](name=n, offset=o, datatype=7, count=1)
        for n, o in (("x", 0), ("y", 4), ("z", 8))
    ]
    import numpy as np

    msg = tm["sensor_msgs/msg/PointCloud2"](
        header=tm["std_msgs/msg/Header"](
            stamp=tm["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
            frame_id=cloud["frame"],
        ),
        height=1,
        width=len(pts),
        fields=fields,
        is_bigendian=False,
        point_step=16,
        row_step=16 * len(pts),
        data=np.frombuffer(data, dtype=np.uint8),
        is_dense=True,
    )
    raw = bytes(store.serialize_cdr(msg, "sensor_msgs/msg/PointCloud2"))
    return RawSample.of(msgs.PointCloud2, raw)


def typestore() -> Any:
    global _STORE  # built once: a typestore takes a while
    if _STORE is None:
        from rosbags.typesys import Stores, get_typestore

        _STORE = get_typestore(Stores.ROS2_JAZZY)
    return _STORE


def take_serialized(reader: DataReader, n: int) -> list[tuple[bytes, Any]]:
    """The samples of ``reader`` as CDR bytes (what ``DataReader.take`` decodes), with info."""
    from cyclonedds._clayer import ddspy_take
    from cyclonedds.core import InstanceState, SampleState, ViewState

    ret = ddspy_take(reader._ref, SampleState.Any | ViewState.Any | InstanceState.Any, n)
    if isinstance(ret, int):
        raise SystemExit(f"take failed: {ret}")
    return list(ret)


def trajectory_from_cdr(data: bytes) -> dict[str, Any]:
    """A trajectory_msgs/JointTrajectory decoded by rosbags' typestore (ROS 2 Jazzy)."""
    m = typestore().deserialize_cdr(data, "trajectory_msgs/msg/JointTrajectory")
    return {
        "stamp": [int(m.header.stamp.sec), int(m.header.stamp.nanosec)],
        "frame_id": m.header.frame_id,
        "joint_names": list(m.joint_names),
        "points": [
            {
                "positions": [float(x) for x in p.positions],
                "velocities": [float(x) for x in p.velocities],
                "accelerations": [float(x) for x in p.accelerations],
                "effort": [float(x) for x in p.effort],
                "time_from_start": [int(p.time_from_start.sec), int(p.time_from_start.nanosec)],
            }
            for p in m.points
        ],
    }


def stream(spec: dict[str, Any], dp: DomainParticipant) -> dict[str, Any]:
    t = spec["topics"]
    depth = int(spec.get("depth", 10))
    in_t, out_t = spec["cmd_type"], spec["out_type"]
    st = spec["state"]
    state_w = DataWriter(dp, Topic(dp, t["state"], TYPES[st["type"]]), qos=qos(TYPES[st["type"]]))
    cmd_w = DataWriter(dp, Topic(dp, t["cmd_in"], TYPES[in_t]), qos=qos(TYPES[in_t], depth=depth))
    out_r = DataReader(
        dp, Topic(dp, t["cmd_out"], TYPES[out_t]), qos=qos(TYPES[out_t], depth=depth)
    )
    # Transforms: /tf_static as ROS publishes it (reliable, transient-local, keep-last 1), once;
    # /tf volatile, with every state.
    tf_static_w = tf_w = None
    if "tf_static" in spec:
        tf_static_w = DataWriter(
            dp,
            Topic(dp, t["tf_static"], msgs.TFMessage),
            qos=qos(msgs.TFMessage, depth=1, transient=True),
        )
        tf_static_w.write(tf_message(spec["tf_static"]))
    if "tf" in spec:
        tf_w = DataWriter(dp, Topic(dp, t["tf"], msgs.TFMessage), qos=qos(msgs.TFMessage))
        wait_for(lambda: len(tf_w.get_matched_subscriptions()) > 0, "the tf reader")
    cloud_w = None
    if "cloud" in spec:  # a PointCloud2 written with every state, stamped at the write
        cloud_w = DataWriter(
            dp, Topic(dp, t["cloud"], msgs.PointCloud2), qos=qos(msgs.PointCloud2, depth=5)
        )
        wait_for(lambda: len(cloud_w.get_matched_subscriptions()) > 0, "the cloud reader")
    wait_for(lambda: len(cmd_w.get_matched_subscriptions()) > 0, "the command reader")
    wait_for(lambda: len(state_w.get_matched_subscriptions()) > 0, "the state reader")
    wait_for(lambda: len(out_r.get_matched_publications()) > 0, "the output writer")
    # The matches above are this side's: this peer's writers have matched the bridge's readers
    # (what a sample sent from here needs), but the bridge's output writer finds this peer's
    # reader on its own schedule, and a writer sends a volatile sample only to the readers it
    # has matched when it writes it. With a "sync" file, this peer names its endpoints (GUIDs)
    # in "<sync>.ready" and sends nothing until the test process, which runs the bridge, has
    # seen the bridge's side match every one of them ("<sync>.go").
    sync = spec.get("sync")
    if sync is not None:
        writers = [w for w in (state_w, cmd_w, tf_w, cloud_w) if w is not None]
        ends = {"writers": [str(w.guid) for w in writers], "readers": [str(out_r.guid)]}
        Path(sync + ".tmp").write_text(json.dumps(ends), encoding="utf-8")
        Path(sync + ".tmp").replace(sync + ".ready")  # the test never reads half a file
        wait_for(lambda: Path(sync + ".go").exists(), "the test's go-ahead (bridge side matched)")
    state = make_state(st)
    commands = spec["commands"]
    prepared = [make_command(in_t, c, i) for i, c in enumerate(commands)]  # fast sending
    rate = float(spec["rate_hz"])
    pause_after = spec.get("pause_after")  # [index, seconds]
    switch = spec.get("state_switch")  # {"after": index, "values": [...]}
    state_period = float(spec.get("state_period", 0.05))
    outputs: list[dict[str, Any]] = []
    sent: list[float] = []
    t0 = time.monotonic()

    def collect() -> None:
        if out_t == "joint_trajectory":  # decoded by rosbags from the bytes on the wire
            for data, info in take_serialized(out_r, 1000):
                if info.valid_data:
                    traj = trajectory_from_cdr(data)
                    outputs.append({"t": time.monotonic() - t0, "i": None, "traj": traj})
            return
        for m in out_r.take(N=1000):
            if getattr(m, "sample_info", None) is not None and not m.sample_info.valid_data:
                continue
            idx, vals = output_values(out_t, m)
            outputs.append({"t": time.monotonic() - t0, "i": idx, "v": vals})

    tf_msg = None if tf_w is None else tf_message(spec["tf"])

    def write_state() -> None:  # the current state (and the transforms on /tf, the cloud)
        state_w.write(state)
        if tf_w is not None:
            tf_w.write(tf_msg)
        if cloud_w is not None:
            cloud_w.write(cloud_message(spec["cloud"]))

    write_state()
    next_state = time.monotonic() + state_period
    # A first state must be there before the first command is shaped: the bridge's diagnostics
    # are not needed for that; the state writer is reliable and matched, so one short settle of
    # the state (acknowledged by the reader) suffices.
    state_w.wait_for_acks(duration(seconds=5))
    next_cmd = time.monotonic()
    i = 0
    end_pause = None
    while i < len(commands):
        now = time.monotonic()
        if now >= next_state:
            write_state()
            next_state = now + state_period
        if end_pause is not None and now < end_pause:
            collect()
            time.sleep(0.0005)
            continue
        if now >= next_cmd:
            cmd_w.write(prepared[i])
            sent.append(now - t0)
            i += 1
            next_cmd += 1.0 / rate
            if switch is not None and i == int(switch["after"]):  # a new state from now on
                state = make_state({**st, "values": switch["values"]})
                write_state()
                next_state = time.monotonic() + state_period
            if pause_after is not None and i == int(pause_after[0]):
                end_pause = time.monotonic() + float(pause_after[1])
                next_cmd = end_pause
            continue
        collect()
        time.sleep(min(0.0005, max(0.0, next_cmd - time.monotonic())))
    expected = int(spec.get("expect", len(commands)))
    tail = float(spec.get("tail", 0.0))
    end = time.monotonic() + 10.0
    tail_end = time.monotonic() + tail
    # With "expect_nonzero", only non-zero answers count (a watchdog's zeros do not).
    nonzero = bool(spec.get("expect_nonzero", False))

    # With "give_up_after", the wait also ends once no answer came for that long (a flood the
    # bridge could not take in full is never answered in full).
    give_up = spec.get("give_up_after")

    # A trajectory "moves" if its point leaves ``rest_positions`` (the state, in the output's
    # joint order); any other output if it is not all zeros.
    rest = spec.get("rest_positions")

    def moving(o: dict[str, Any]) -> bool:
        if "traj" in o:
            pos = o["traj"]["points"][0]["positions"]
            return rest is None or any(a != b for a, b in zip(pos, rest, strict=True))
        return any(o["v"])

    def answered() -> int:
        return sum(1 for o in outputs if moving(o)) if nonzero else len(outputs)

    last_count, last_change = -1, time.monotonic()
    while (answered() < expected and time.monotonic() < end) or time.monotonic() < tail_end:
        if time.monotonic() >= next_state:
            write_state()
            next_state = time.monotonic() + state_period
        collect()
        if len(outputs) != last_count:
            last_count, last_change = len(outputs), time.monotonic()
        elif (
            give_up is not None
            and time.monotonic() - last_change > float(give_up)
            and time.monotonic() >= tail_end
        ):
            break
        time.sleep(0.001)
    collect()
    return {"sent": sent, "outputs": outputs}


def qos_scenario(spec: dict[str, Any], dp: DomainParticipant) -> dict[str, Any]:
    t = spec["topics"]
    in_t, out_t = spec["cmd_type"], spec["out_type"]
    # Best effort offered to a reliable request: the bridge's reader reports the mismatch.
    w = DataWriter(dp, Topic(dp, t["cmd_in"], TYPES[in_t]), qos=qos(TYPES[in_t], reliable=False))
    # Transient-local requested from a volatile writer: the bridge's writer reports it.
    r = DataReader(dp, Topic(dp, t["cmd_out"], TYPES[out_t]), qos=qos(TYPES[out_t], transient=True))
    diag = DataReader(dp, Topic(dp, t["diag"], msgs.DiagnosticArray), qos=qos(msgs.DiagnosticArray))
    found: list[dict[str, str]] = []

    def mismatch_reported() -> bool:
        for m in diag.take(N=100):
            for s in m.status:
                kv = {v.key: v.value for v in s.values}
                found.append(kv)
        return any(int(kv.get("qos_incompatible", "0")) >= 2 for kv in found)

    wait_for(mismatch_reported, "a diagnostics message reporting two QoS mismatches")
    del w, r
    return {"diagnostics": found[-1]}


def qos_one(spec: dict[str, Any], dp: DomainParticipant) -> dict[str, Any]:
    """One writer against the bridge's command reader with one incompatible policy."""
    t = spec["topics"]
    typ = TYPES[spec["cmd_type"]]
    if spec["mismatch"] == "data_representation":  # XCDR2 only; the bridge reads XCDR1
        q = Qos(
            Policy.Reliability.Reliable(max_blocking_time=duration(seconds=1)),
            Policy.Userdata(user_data(typ)),
            Policy.DataRepresentation(use_xcdrv2_representation=True),
        )
    else:  # best effort offered, reliable requested
        q = qos(typ, reliable=False)
    w = DataWriter(dp, Topic(dp, t["cmd_in"], typ), qos=q)
    diag = DataReader(dp, Topic(dp, t["diag"], msgs.DiagnosticArray), qos=qos(msgs.DiagnosticArray))
    found: list[dict[str, str]] = []

    def reported() -> bool:
        for m in diag.take(N=100):
            for s in m.status:
                found.append({v.key: v.value for v in s.values})
        return any(int(kv.get("qos_incompatible", "0")) >= 1 for kv in found)

    wait_for(reported, "a diagnostics message reporting the QoS mismatch")
    del w
    return {"diagnostics": found[-1]}


def endpoints(spec: dict[str, Any], dp: DomainParticipant) -> dict[str, Any]:
    wanted = set(spec["topics"])
    pubs = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    subs = BuiltinDataReader(dp, BuiltinTopicDcpsSubscription)
    seen: dict[str, dict[str, Any]] = {}

    def read() -> bool:
        for kind, rd in (("publication", pubs), ("subscription", subs)):
            for e in rd.take(N=200):
                if e.topic_name in wanted:
                    ud = e.qos[Policy.Userdata] if Policy.Userdata in e.qos else None  # noqa: SIM401
                    seen[f"{kind}:{e.topic_name}"] = {
                        "type": e.type_name,
                        "user_data": None if ud is None else ud.data.decode("ascii"),
                    }
        return len(seen) >= int(spec["expect"])

    wait_for(read, f"{spec['expect']} endpoints on {sorted(wanted)}")
    return {"endpoints": seen}


def main() -> None:
    with open(sys.argv[1], encoding="utf-8") as fh:
        spec = json.load(fh)
    dp = DomainParticipant(int(spec["domain"]))
    fn = {"stream": stream, "qos": qos_scenario, "qos_one": qos_one, "endpoints": endpoints}[
        spec["scenario"]
    ]
    result = fn(spec, dp)
    sys.stdout.write(json.dumps(result))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
