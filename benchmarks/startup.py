"""Start-up cost: ``import velfence`` and ``velfence --help`` beside a bare interpreter.

Usage: ``python benchmarks/startup.py [RUNS]`` (default 30). Each command runs RUNS times as a
fresh process, interleaved (bare, import, import + first SafetyFilter, --help, bare, …) so that
the load of the machine falls on all of them alike; the table gives the median, p99 and max wall
time of each and its median minus the bare interpreter's. The targets and the last run are in
docs/benchmarks.md ("Start-up"): ``import velfence`` ≤ 150 ms and ``velfence --help`` ≤ 400 ms
on the development machine.
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

COMMANDS: dict[str, list[str]] = {
    "python -c pass": [sys.executable, "-c", "pass"],
    "import velfence": [sys.executable, "-c", "import velfence"],
    "import velfence; velfence.SafetyFilter": [
        sys.executable,
        "-c",
        "import velfence; velfence.SafetyFilter",
    ],
    "velfence --help": [
        shutil.which("velfence") or str(Path(sys.executable).with_name("velfence")),
        "--help",
    ],
}


def _once(argv: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def _p99(xs: list[float]) -> float:
    ys = sorted(xs)
    return ys[min(len(ys) - 1, round(0.99 * (len(ys) - 1)))]


def main(runs: int = 30) -> None:
    """Print the Markdown table of start-up times.

    Args:
        runs: Fresh processes per command.
    """
    times: dict[str, list[float]] = {name: [] for name in COMMANDS}
    for argv in COMMANDS.values():  # warm the file cache once
        _once(argv)
    for i in range(runs):
        for name, argv in COMMANDS.items():
            times[name].append(_once(argv))
        print(f"\rrun {i + 1}/{runs}", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    bare = statistics.median(times["python -c pass"])
    print(f"{runs} fresh processes per command, interleaved; wall time [ms]\n")
    print("| command | median | p99 | max | median − bare interpreter |")
    print("|---|---:|---:|---:|---:|")
    for name, xs in times.items():
        med = statistics.median(xs)
        print(
            f"| `{name}` | {med * 1e3:.1f} | {_p99(xs) * 1e3:.1f} | {max(xs) * 1e3:.1f} "
            f"| {(med - bare) * 1e3:+.1f} |"
        )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 30)
