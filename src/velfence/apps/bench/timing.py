"""The measuring primitive of the benchmarks: time single calls, summarise them in µs.

Every call is timed on its own with :func:`time.perf_counter_ns`, after untimed warm-up passes
over the same arguments, with the garbage collector paused. The summary is the median, the 99th
percentile and the maximum, in µs; the cost of a bare timer pair (:func:`timer_overhead_ns`) is
included in every figure, not subtracted.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, TypedDict

import numpy as np

__all__ = [
    "Latency",
    "LatencyFields",
    "as_fields",
    "gc_paused",
    "latency_of",
    "time_calls",
    "timer_overhead_ns",
]


class LatencyFields(TypedDict):
    """The fields of :class:`Latency`, for ``Row(**as_fields(latency), ...)``."""

    calls: int
    median_us: float
    p99_us: float
    max_us: float


@dataclass(frozen=True)
class Latency:
    """Summary of single-call timings: the fields every per-call benchmark row shares.

    Attributes:
        calls: Timed calls.
        median_us: Median latency, µs.
        p99_us: 99th percentile, µs.
        max_us: Largest latency, µs.
    """

    calls: int
    median_us: float
    p99_us: float
    max_us: float


def as_fields(latency: Latency) -> LatencyFields:
    """The four fields of ``latency`` as keyword arguments of a row class built on it."""
    return {
        "calls": latency.calls,
        "median_us": latency.median_us,
        "p99_us": latency.p99_us,
        "max_us": latency.max_us,
    }


@contextmanager
def gc_paused() -> Iterator[None]:
    """Collect the young generations, then keep the garbage collector off until the block ends.

    Only generations 0 and 1: with the collector off nothing is collected during the timed
    calls anyway, and a full collection of a large heap (numba's compiled kernels loaded)
    cost 0.25 s per timed row — 47 s of a quick benchmark run's 110.
    """
    was_enabled = gc.isenabled()
    gc.collect(1)
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def latency_of(ns: Sequence[int]) -> Latency:
    """Median, p99 and max of per-call times given in ns, as a :class:`Latency` in µs."""
    a = np.asarray(ns, dtype=float) / 1e3
    med, p99 = np.percentile(a, [50.0, 99.0])
    return Latency(len(ns), float(med), float(p99), float(a.max()))


def time_calls(
    fn: Callable[..., Any], pool: Sequence[tuple[Any, ...]], *, calls: int, warmup: int
) -> Latency:
    """Time ``calls`` single calls ``fn(*args)``, cycling over the argument tuples of ``pool``.

    Args:
        fn: The callable timed.
        pool: Argument tuples (at least one), used in turn.
        calls: Timed calls.
        warmup: Untimed passes over the whole pool before timing.

    Returns:
        The :class:`Latency` of the timed calls.
    """
    for _ in range(warmup):
        for args in pool:
            fn(*args)
    k = len(pool)
    out = [0] * calls
    clock = time.perf_counter_ns
    with gc_paused():
        for i in range(calls):
            args = pool[i % k]
            t0 = clock()
            fn(*args)
            out[i] = clock() - t0
    return latency_of(out)


def timer_overhead_ns(samples: int = 20_000) -> float:
    """Median cost of an empty ``perf_counter_ns`` pair, ns."""
    clock = time.perf_counter_ns
    out = [0] * samples
    with gc_paused():
        for i in range(samples):
            t0 = clock()
            out[i] = clock() - t0
    return float(np.median(out))
