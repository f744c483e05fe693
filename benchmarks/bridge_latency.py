"""Round-trip latency of ``velfence bridge`` on loopback DDS: command in -> shaped command out.

The bridge runs as its own process (``python -m velfence.apps.cli bridge --config ...``, a polygon
fence, TwistStamped in and out, ROS 2 default QoS: reliable, keep-last 10, or ``--depth``); this
script is the ROS 2 peer: it keeps a PoseStamped state fresh, sends TwistStamped commands at a
fixed rate
(each stamped with its index) and timestamps every answer. Latency = answer received - command
written, on one machine's monotonic clock. 0.5 s of commands before each measurement (warm-up)
are not counted.

Usage::

    python benchmarks/bridge_latency.py [--seconds 3] [--rates 100,1000] [--search] [--depth 10]

``--search`` then tries 2, 3, 4, 5, 7, 10 kHz and reports the highest rate *held*: every command
answered (nothing lost) and the sender within 5 % of the rate.
DDS is confined to loopback (CYCLONEDDS_URI) on a random domain.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LOOPBACK = (
    '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo" '
    'multicast="false"/></Interfaces><AllowMulticast>false</AllowMulticast></General>'
    '<Discovery><ParticipantIndex>auto</ParticipantIndex><Peers><Peer address="127.0.0.1"/>'
    "</Peers></Discovery></Domain></CycloneDDS>"
)
os.environ["CYCLONEDDS_URI"] = LOOPBACK

CONFIG = """\
bridge:
  domain_id: {domain}
  namespace: /bench
  command_in: {{topic: cmd_in, type: twist_stamped, qos: {{profile: default, depth: {depth}}}}}
  command_out: {{topic: cmd_out, qos: {{profile: default, depth: {depth}}}}}
  state: {{topic: pose, type: pose_stamped, qos: default}}
  command_frame: world
  diagnostics: {{enabled: false}}
shaper:
  kind: polygon
  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]
  buffer: 0.5
"""


def measure(rate: float, seconds: float, domain: int, depth: int) -> dict[str, float]:
    from cyclonedds.core import (
        InstanceState,
        Policy,
        Qos,
        ReadCondition,
        SampleState,
        ViewState,
        WaitSet,
    )
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    from cyclonedds.util import duration

    from velfence.bridge import msgs
    from velfence.bridge.typehash import user_data

    def qos(typ: type) -> Qos:
        return Qos(
            Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
            Policy.History.KeepLast(depth),
            Policy.Durability.Volatile,
            Policy.Userdata(user_data(typ)),
            Policy.DataRepresentation(use_cdrv0_representation=True),
        )

    dp = DomainParticipant(domain)
    tw, ps = msgs.TwistStamped, msgs.PoseStamped
    cmd = DataWriter(dp, Topic(dp, "rt/bench/cmd_in", tw), qos=qos(tw))
    state = DataWriter(dp, Topic(dp, "rt/bench/pose", ps), qos=qos(ps))
    out = DataReader(dp, Topic(dp, "rt/bench/cmd_out", tw), qos=qos(tw))
    end = time.monotonic() + 30
    while not (
        cmd.get_matched_subscriptions()
        and out.get_matched_publications()
        and state.get_matched_subscriptions()
    ):
        if time.monotonic() > end:
            raise SystemExit("the bridge did not show up within 30 s")
        time.sleep(0.01)
    ws = WaitSet(dp)
    ws.attach(ReadCondition(out, SampleState.Any | ViewState.Any | InstanceState.Any))
    pose = ps(pose=msgs.Pose(position=msgs.Point(x=0.3, y=1.5)))
    state.write(pose)
    state.wait_for_acks(duration(seconds=5))
    # Warm-up (0.5 s, not measured): the first samples after discovery can wait for a
    # retransmission (a reader matched on one side before the other) -- start-up, not steady state.
    warm_end = time.monotonic() + 0.5
    k = 0
    while time.monotonic() < warm_end:
        cmd.write(tw(header=msgs.Header(stamp=msgs.Time(sec=10_000_000 + k))))
        k += 1
        out.take(N=1000)
        time.sleep(1.0 / rate)
    n = max(1, round(rate * seconds))
    sent = [math.nan] * n
    got = [math.nan] * n
    period = 1.0 / rate
    t0 = time.monotonic()
    next_state = t0
    i = 0

    def drain() -> None:
        now = time.monotonic()
        for m in out.take(N=1000):
            k = m.header.stamp.sec
            if 0 <= k < n and math.isnan(got[k]):
                got[k] = now

    while i < n:
        now = time.monotonic()
        if now >= next_state:
            state.write(pose)
            next_state = now + 0.05
        due = t0 + i * period
        if now >= due:
            m = tw(header=msgs.Header(stamp=msgs.Time(sec=i)))
            m.twist.linear.x, m.twist.linear.y = -0.5, 0.2 * math.sin(i * 1e-2)
            sent[i] = time.monotonic()
            cmd.write(m)
            i += 1
            drain()
            continue
        ws.wait(duration(seconds=max(0.0, due - now)))
        drain()
    t_send = time.monotonic() - t0
    end = time.monotonic() + 2.0
    while any(math.isnan(g) for g in got) and time.monotonic() < end:
        ws.wait(duration(milliseconds=50))
        drain()
    lat = sorted((g - s) * 1e3 for s, g in zip(sent, got, strict=True) if not math.isnan(g))
    answered = len(lat)

    def q(p: float) -> float:
        return lat[min(len(lat) - 1, int(p * len(lat)))] if lat else math.nan

    return {
        "rate_hz": rate,
        "sent": n,
        "answered": answered,
        "lost": n - answered,
        "send_rate_hz": n / t_send,
        "p50_ms": q(0.50),
        "p99_ms": q(0.99),
        "max_ms": lat[-1] if lat else math.nan,
        "over_10ms": sum(1 for x in lat if x > 10.0),
    }


def held(r: dict[str, float]) -> bool:
    return r["lost"] == 0 and r["send_rate_hz"] >= 0.95 * r["rate_hz"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--rates", default="100,1000")
    ap.add_argument("--search", action="store_true")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument(
        "--depth", type=int, default=10, help="history depth of the command topics (ROS: 10)"
    )
    args = ap.parse_args()
    domain = random.SystemRandom().randint(1, 230)
    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "bridge.yaml"
        cfg.write_text(CONFIG.format(domain=domain, depth=args.depth), encoding="utf-8")
        bridge = subprocess.Popen(
            [sys.executable, "-m", "velfence.apps.cli", "bridge", "--config", str(cfg)],
            stderr=subprocess.DEVNULL,
        )
        try:
            rows = []
            rates = [float(x) for x in args.rates.split(",")]
            for rate in rates:
                rows.append(measure(rate, args.seconds, domain, args.depth))
            if args.search:
                for rate in (2000.0, 3000.0, 4000.0, 5000.0, 7000.0, 10000.0):
                    r = measure(rate, args.seconds, domain, args.depth)
                    rows.append(r)
                    if not held(r):
                        break
        finally:
            bridge.terminate()
            bridge.wait(30)
    best = max((r["rate_hz"] for r in rows if held(r)), default=math.nan)
    print("| rate [Hz] | sent | lost | send rate [Hz] | p50 [ms] | p99 [ms] | max [ms] | held |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | :---: |")
    for r in rows:
        print(
            f"| {r['rate_hz']:.0f} | {r['sent']} | {r['lost']} | {r['send_rate_hz']:.0f} | "
            f"{r['p50_ms']:.3f} | {r['p99_ms']:.3f} | {r['max_ms']:.3f} | "
            f"{'yes' if held(r) else 'no'} |"
        )
    print(f"highest rate held: {best:.0f} Hz (history depth {args.depth})")
    if args.json is not None:
        args.json.write_text(json.dumps({"rows": rows, "highest_held_hz": best}, indent=2))


if __name__ == "__main__":
    main()
