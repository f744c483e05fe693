"""Time ``velfence.io.replay`` beside a plain rosbags copy of the same bag (docs/replay.md).

Usage: ``python benchmarks/replay_speed.py [REPEATS]``. Each example bag's messages are repeated
REPEATS times (default 50) into a bigger bag of the same storage (MCAP for ``mobile_base``, sqlite3
for ``arm_jog``) in a temporary folder. Two jobs run on it, alternating, three times each after one
warm-up of each (imports, caches):

* **baseline**: rosbags reads every message, decodes it with the typestore, encodes it again and
  writes it with rosbags' ``Writer`` (same storage, default settings) to a new bag;
* **replay**: ``velfence.io.replay`` with the example's ``replay.yaml`` (reads, shapes, writes
  every original message plus the shaped commands).

The medians are printed as one Markdown table: messages, seconds, messages per second and the
ratio ``baseline seconds / replay seconds`` (>= 1: the replay is at least as fast as the plain
copy). Needs the ``ros`` extra.
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer

from velfence.io import make_example_bag, replay
from velfence.io.bag_examples import arm_jog_messages, mobile_base_messages
from velfence.io.bags import message_typestore


def _big(path: Path, base: list[tuple[str, str, int, Any]], repeats: int, plugin: Any) -> int:
    ts = message_typestore(None)
    times = [t for _, _, t, _ in base]
    span = max(times) - min(times) + 10**8
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conns: dict[str, Any] = {}
        for topic, msgtype, _, _ in base:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
        for r in range(repeats):
            for topic, msgtype, t, msg in base:
                writer.write(conns[topic], t + r * span, ts.serialize_cdr(msg, msgtype))
    return len(base) * repeats


def copy_with_rosbags(bag: Path, out: Path, plugin: Any) -> int:
    """The baseline: read, decode, re-encode and write every message with rosbags alone."""
    n = 0
    with AnyReader([bag], default_typestore=message_typestore(None)) as reader:
        ts = reader.typestore
        with Writer(out, version=9, storage_plugin=plugin) as writer:
            conns = {
                c.id: writer.add_connection(c.topic, c.msgtype, typestore=ts)
                for c in reader.connections
            }
            for conn, t, raw in reader.messages():
                msg = ts.deserialize_cdr(raw, conn.msgtype)
                writer.write(conns[conn.id], t, ts.serialize_cdr(msg, conn.msgtype))
                n += 1
    return n


def _seconds(job: Callable[..., Any], *args: Any) -> float:
    t0 = time.perf_counter()
    job(*args)
    return time.perf_counter() - t0


def main(repeats: int = 50) -> None:
    ts = message_typestore(None)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        cases = [
            ("mobile_base", mobile_base_messages(ts), StoragePlugin.MCAP),
            ("arm_jog", arm_jog_messages(ts), StoragePlugin.SQLITE3),
        ]
        for name, msgs, plugin in cases:
            ex = make_example_bag(name, root / name)
            big = root / f"{name}_big"
            n = _big(big, msgs, repeats, plugin)
            cfg = ex / "replay.yaml"
            copy_with_rosbags(big, root / f"{name}_base_warm", plugin)
            s = replay(big, cfg, root / f"{name}_replay_warm")
            base, rep = [], []
            for k in range(3):  # alternating, so a change of load hits both jobs
                out_b, out_r = root / f"{name}_base{k}", root / f"{name}_replay{k}"
                base.append(_seconds(copy_with_rosbags, big, out_b, plugin))
                rep.append(_seconds(replay, big, cfg, out_r))
            b, r = statistics.median(base), statistics.median(rep)
            rows.append((name, s.storage, n, s.commands, b, r))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{os.cpu_count()} CPUs, load average {load:.1f} (1 min) at the end\n")
    print("| bag | storage | messages in | commands | job | seconds | msgs/s | ratio |")
    print("|---|---|---:|---:|---|---:|---:|---:|")
    for name, storage, n, cmds, b, r in rows:
        print(f"| {name} | {storage} | {n} | {cmds} | rosbags copy | {b:.3f} | {n / b:,.0f} | |")
        print(
            f"| {name} | {storage} | {n} | {cmds} | velfence replay | {r:.3f} | {n / r:,.0f} "
            f"| {b / r:.2f} |"
        )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 50)
