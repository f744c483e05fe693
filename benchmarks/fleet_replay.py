"""Time a fleet replay (``velfence replay --summary``) serially and on 1 and 2 Dask workers.

Usage: ``python benchmarks/fleet_replay.py [BAGS] [CYCLES]``. Writes BAGS small bags (default
1,000; ``velfence.apps.fleet.make_demo_fleet``: mobile bases in a 4 m x 3 m room, CYCLES
commands each at 10 Hz, default 30, plus their odometry) into a temporary folder, then runs
``fleet_replay`` over all of them three ways, once each:

* **serial**: ``Engine(workers=0)``, in this process;
* **1 worker** and **2 workers**: an embedded ``LocalCluster`` (``Engine(workers=N)``), its start
  timed apart from the run.

Each bag's own time (replay + summary, inside the worker) gives the median and the 99th
percentile per bag; the run's wall time gives the total, the bags per second and the speed-up
over serial. The three summaries must be equal (the script stops otherwise). Prints one Markdown
table and the machine's load average before and after (the development machine is shared: the
numbers are only as quiet as the machine). Needs the ``ros`` and ``cluster`` extras.
"""

from __future__ import annotations

import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from velfence.apps.engine import Engine
from velfence.apps.fleet import BagReport, find_bags, make_demo_fleet, summarize_bag


def timed_bag(item: tuple[str, str, str]) -> tuple[BagReport, float]:
    """One shard: a bag's report and the seconds it took (measured where it ran)."""
    bag, group, config = item
    t0 = time.perf_counter()
    report = summarize_bag(bag, config, group=group)
    return report, time.perf_counter() - t0


def run(engine: Engine, items: list[tuple[str, str, str]]) -> tuple[list[Any], float, float]:
    """Start the engine, replay every bag, stop: (results, start seconds, run seconds)."""
    t0 = time.perf_counter()
    with engine:
        t1 = time.perf_counter()
        results = engine.run(timed_bag, items)
        t2 = time.perf_counter()
    return results, t1 - t0, t2 - t1


def main() -> None:
    bags = int(sys.argv[1]) if len(sys.argv) > 1 else 1000
    cycles = int(sys.argv[2]) if len(sys.argv) > 2 else 30
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="velfence-fleet-bench-") as tmp:
        t0 = time.perf_counter()
        root = make_demo_fleet(Path(tmp) / "fleet", bags=bags, cycles=cycles, robots=4)
        written = time.perf_counter() - t0
        config = str(root / "replay.yaml")
        items = [(str(b), g, config) for b, g in find_bags([root])]
        rows, reference, serial_total = [], None, None
        for label, workers in (("serial", 0), ("1 worker", 1), ("2 workers", 2)):
            results, start, total = run(Engine(workers=workers, timeout=120), items)
            reports = [r for r, _ in results]
            if reference is None:
                reference = reports
            elif reports != reference:
                sys.exit(f"{label}: the summary differs from the serial one")
            per_bag = sorted(s for _, s in results)
            p99 = per_bag[min(len(per_bag) - 1, int(0.99 * len(per_bag)))]
            serial_total = serial_total or total
            rows.append(
                f"| {label} | {start:.1f} | {1000 * statistics.median(per_bag):.0f} | "
                f"{1000 * p99:.0f} | {total:.1f} | {len(items) / total:.1f} | "
                f"{serial_total / total:.2f} |"
            )
    load1 = os.getloadavg()
    print(
        f"{bags} bags of {cycles} commands (+ as many odometry messages), written in "
        f"{written:.0f} s; summaries equal in all three runs\n"
    )
    print("| engine | start [s] | median per bag [ms] | p99 per bag [ms] | total [s] | bags/s | "
          "speed-up |")  # fmt: skip
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    print("\n".join(rows))
    print(
        f"\nPython {platform.python_version()}, {platform.machine()}, {os.cpu_count()} CPUs; "
        f"load average (1, 5, 15 min) {load0[0]:.1f}, {load0[1]:.1f}, {load0[2]:.1f} before, "
        f"{load1[0]:.1f}, {load1[1]:.1f}, {load1[2]:.1f} after"
    )


if __name__ == "__main__":  # the embedded cluster's workers import this module
    main()
