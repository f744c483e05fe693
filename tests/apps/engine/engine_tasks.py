"""The shards of the engine tests, in a module the workers of a test's cluster import by name.

Dask sends a function by reference (module and name): the fixture puts this folder on the
``PYTHONPATH`` of the scheduler and workers it starts.
"""

from __future__ import annotations

import os
import time
from pathlib import Path


def square_sum(item: tuple[int, int]) -> tuple[int, int, float]:
    """A shard whose result depends on nothing but its item (not on the worker)."""
    a, b = item
    return a, a * a + b, sum(1.0 / (k + 1) for k in range(a + b))


def hold_once(item: tuple[int, str]) -> int:
    """Shard 5's first attempt writes its worker's pid and waits to be killed; others square."""
    k, folder = item
    flag = Path(folder) / "held"
    if k == 5 and not flag.exists():
        flag.write_text(str(os.getpid()))
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:  # the test kills this process
            time.sleep(0.05)
        return -1  # never killed: a wrong result fails the test
    return k * k
