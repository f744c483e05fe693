"""What decoding each sample on its own costs the bridge on the good path (docs/bridge.md).

The bridge takes a reader's samples serialized and decodes them one by one (so an undecodable
sample is dropped alone); the Cyclone DDS binding's ``DataReader.take`` decodes the batch in one
loop (and loses the batch to one bad sample). Both are timed here on the same batches: a writer
and a reader of ``TwistStamped`` in one participant on loopback, ``--batch`` samples written,
then taken, ``--rounds`` times per way, alternating. Prints µs per sample (median over rounds).

Usage::

    python benchmarks/bridge_take.py [--batch 256] [--rounds 200]
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import time

os.environ["CYCLONEDDS_URI"] = (
    '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo" '
    'multicast="false"/></Interfaces><AllowMulticast>false</AllowMulticast></General>'
    "</Domain></CycloneDDS>"
)

from cyclonedds._clayer import ddspy_take
from cyclonedds.core import InstanceState, Policy, Qos, SampleState, ViewState
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from velfence.bridge import msgs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=256)
    ap.add_argument("--rounds", type=int, default=200)
    a = ap.parse_args()
    dp = DomainParticipant(random.SystemRandom().randint(1, 230))
    topic = Topic(dp, "rt/bench_take", msgs.TwistStamped)
    q = Qos(
        Policy.Reliability.Reliable(max_blocking_time=0),
        Policy.History.KeepLast(a.batch),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )
    w, r = DataWriter(dp, topic, qos=q), DataReader(dp, topic, qos=q)
    sample = msgs.TwistStamped(
        header=msgs.Header(stamp=msgs.Time(sec=1, nanosec=2), frame_id="base_link"),
        twist=msgs.Twist(linear=msgs.Vector3(x=0.1, y=0.2), angular=msgs.Vector3(z=0.3)),
    )
    mask = SampleState.Any | ViewState.Any | InstanceState.Any

    def binding() -> int:
        return len(r.take(N=a.batch))

    def per_sample() -> int:
        n = 0
        for data, info in ddspy_take(r._ref, mask, a.batch):
            if info.valid_data:
                try:
                    msgs.TwistStamped.deserialize(data)
                except Exception:  # as the bridge: a bad sample is dropped alone
                    continue
                n += 1
        return n

    times: dict[str, list[float]] = {"binding take": [], "per-sample decode": []}
    for i in range(2 * a.rounds):
        name, fn = ("binding take", binding) if i % 2 == 0 else ("per-sample decode", per_sample)
        for _ in range(a.batch):
            w.write(sample)
        t0 = time.perf_counter()
        got = fn()
        dt = time.perf_counter() - t0
        assert got == a.batch, (name, got)
        times[name].append(dt / a.batch * 1e6)
    for name, ts in times.items():
        print(f"{name:>18}: {statistics.median(ts):6.2f} µs/sample (median of {len(ts)} batches)")


if __name__ == "__main__":
    main()
