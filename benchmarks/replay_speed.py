"""Time ``velfence.io.replay`` per 1000 input messages (docs/replay.md, "How it is checked").

Usage: ``python benchmarks/replay_speed.py [REPEATS]``. Each example bag's messages are repeated
REPEATS times (default 50) into a bigger bag of the same storage (MCAP for ``mobile_base``, sqlite3
for ``arm_jog``) in a temporary folder; after one warm-up replay (imports), the median of three
replays is printed. Needs the ``ros`` extra.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import StoragePlugin, Writer

from velfence.io import make_example_bag, replay
from velfence.io.bag_examples import _arm_jog_messages, _mobile_base_messages
from velfence.io.bags import _typestore


def _big(path: Path, base: list[tuple[str, str, int, Any]], repeats: int, plugin: Any) -> int:
    ts = _typestore(None)
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


def main(repeats: int = 50) -> None:
    ts = _typestore(None)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        cases = [
            ("mobile_base", _mobile_base_messages(ts), StoragePlugin.MCAP),
            ("arm_jog", _arm_jog_messages(ts), StoragePlugin.SQLITE3),
        ]
        for name, msgs, plugin in cases:
            ex = make_example_bag(name, root / name)
            replay(ex / "bag", ex / "replay.yaml", root / f"{name}_warm")
            n = _big(root / f"{name}_big", msgs, repeats, plugin)
            runs = []
            for k in range(3):
                t0 = time.perf_counter()
                s = replay(root / f"{name}_big", ex / "replay.yaml", root / f"{name}_out{k}")
                runs.append(time.perf_counter() - t0)
            med = statistics.median(runs)
            print(
                f"{name} ({s.storage}): {n} messages in, {s.commands} commands, {s.messages} "
                f"written: median {med:.3f} s = {1e3 * med / n * 1000:.1f} ms per 1000 input "
                "messages"
            )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 50)
