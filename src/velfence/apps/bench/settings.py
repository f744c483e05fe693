"""How much work a benchmark run does, the benchmark geometry and the timing targets."""

from __future__ import annotations

from dataclasses import dataclass

from velfence._validate import (
    MAX_SEED,
    check_flag,
    check_positive,
    check_positive_int,
    describe,
)
from velfence.errors import InvalidParameter
from velfence.shaping import ZONE_NAMES

__all__ = [
    "AGREEMENT_TARGET",
    "BUFFER",
    "FILTER_MEDIAN_TARGET_US",
    "FILTER_P99_TARGET_US",
    "LATENCY_TARGET_US",
    "MAX_EDGES",
    "POLYTOPE_BOX_TARGET_US",
    "POLYTOPE_FACETS_TARGET_US",
    "SEED",
    "SPRING_GAIN",
    "THROUGHPUT_TARGET",
    "ZONES",
    "BenchSettings",
]

#: Zones timed per polygon, in the order of ``velfence.shaping.ZONE_NAMES``.
ZONES: tuple[str, ...] = ZONE_NAMES[:5]

# Timing targets of the project.
LATENCY_TARGET_US = 5.0  # 8-edge single-call median, µs
AGREEMENT_TARGET = 1e-9  # max |exact - QP|, workspace units per second
THROUGHPUT_TARGET = 10e6  # shape_batch with numba, states per second
POLYTOPE_BOX_TARGET_US = 10.0  # PolytopeShaper.shape, 3-D box, three facets violated, median µs
POLYTOPE_FACETS_TARGET_US = 20.0  # PolytopeShaper.shape, 3-D 20-facet polytope, worst zone, µs
FILTER_MEDIAN_TARGET_US = 80.0  # SafetyFilter.filter, 7-DoF arm, worst zone, median µs
FILTER_P99_TARGET_US = 200.0  # the same, 99th percentile µs

# The benchmark geometry: regular polygons of circumradius 1 (workspace units) about the origin.
BUFFER = 0.1  # workspace units
SPRING_GAIN = 4.0  # 1/s; max recovery speed = SPRING_GAIN * BUFFER = 0.4 units/s
SEED = 20240611

#: Most edges of a benchmark polygon (the benchmarks use at most 32).
MAX_EDGES = 100_000

# Bounds of a hand-built BenchSettings (a typo must not allocate gigabytes or run for days).
_MAX_CALLS = 10_000_000
_MAX_BATCH = 100_000_000


@dataclass(frozen=True)
class BenchSettings:
    """How much work a run does.

    Attributes:
        quick: Whether this is the small smoke-test configuration.
        calls: Timed single calls per (polygon, method, zone) and per QP route.
        warmup: Untimed calls per state before timing.
        states_per_zone: Distinct states per zone, cycled through during timing.
        latency_edges: Edge counts of the regular polygons timed per call.
        batch_edges: Edge counts of the regular polygons timed in batch.
        batch_n: Rows per ``shape_batch`` call with numba.
        batch_repeats: Timed ``shape_batch`` calls with numba.
        python_n: Rows of the pure-Python ``shape_batch`` run (extrapolated per state).
        buffer: Buffer width of every shaper, workspace units.
        spring_gain: Spring gain of every shaper, 1/s.
        seed: Seed of every random state.
        stop_candidates: Random states drawn to fill the joint-stop limiter's zones.
        nd_batch_n: Rows per :meth:`PolytopeShaper.shape_batch` call with numba, one row of the
            table per size.
        nd_python_n: Rows of the plain-Python :meth:`PolytopeShaper.shape_batch` run.
        filter_calls: Timed single calls per :class:`SafetyFilter` (and peer) row.
        filter_states: Distinct states per zone of the safety-filter rows.
    """

    quick: bool
    calls: int
    warmup: int
    states_per_zone: int
    latency_edges: tuple[int, ...]
    batch_edges: tuple[int, ...]
    batch_n: int
    batch_repeats: int
    python_n: int
    buffer: float = BUFFER
    spring_gain: float = SPRING_GAIN
    seed: int = SEED
    stop_candidates: int = 20_000
    nd_batch_n: tuple[int, ...] = (1_000, 10_000, 1_000_000)
    nd_python_n: int = 2_000
    filter_calls: int = 2_000
    filter_states: int = 16

    def __post_init__(self) -> None:
        """Check every field (a hand-built configuration is refused by field name).

        Raises:
            InvalidParameter: a field of the wrong type or out of range.
        """
        check_flag("quick", self.quick)
        for name, value, minimum, maximum in (
            ("calls", self.calls, 1, _MAX_CALLS),
            ("warmup", self.warmup, 0, _MAX_CALLS),
            ("states_per_zone", self.states_per_zone, 1, _MAX_CALLS),
            ("batch_n", self.batch_n, 16, _MAX_BATCH),
            ("batch_repeats", self.batch_repeats, 1, _MAX_CALLS),
            ("python_n", self.python_n, 16, _MAX_BATCH),
            ("stop_candidates", self.stop_candidates, 1, _MAX_BATCH),
            ("seed", self.seed, 0, MAX_SEED),
            ("nd_python_n", self.nd_python_n, 16, _MAX_BATCH),
            ("filter_calls", self.filter_calls, 1, _MAX_CALLS),
            ("filter_states", self.filter_states, 1, _MAX_CALLS),
        ):
            check_positive_int(name, value, minimum=minimum, maximum=maximum)
        for name, edges in (
            ("latency_edges", self.latency_edges),
            ("batch_edges", self.batch_edges),
        ):
            if not isinstance(edges, tuple) or not edges:
                raise InvalidParameter(
                    f"{name}: expected a non-empty tuple of edge counts, got {describe(edges)}"
                )
            for i, n in enumerate(edges):
                check_positive_int(f"{name}[{i}]", n, minimum=3, maximum=MAX_EDGES, example=8)
        if not isinstance(self.nd_batch_n, tuple) or not self.nd_batch_n:
            raise InvalidParameter(
                f"nd_batch_n: expected a non-empty tuple of row counts, got "
                f"{describe(self.nd_batch_n)}"
            )
        for i, n in enumerate(self.nd_batch_n):
            check_positive_int(f"nd_batch_n[{i}]", n, minimum=16, maximum=_MAX_BATCH, example=1000)
        check_positive("buffer", self.buffer)
        check_positive("spring_gain", self.spring_gain, allow_zero=True)

    @classmethod
    def make(cls, *, quick: bool) -> BenchSettings:
        """The full configuration, or the quick one (a few seconds, for the smoke test).

        Raises:
            InvalidParameter: ``quick`` is not a boolean.
        """
        if check_flag("quick", quick):
            return cls(
                quick=True,
                calls=200,
                warmup=3,
                states_per_zone=8,
                latency_edges=(4, 8, 32),
                batch_edges=(8, 32),
                batch_n=10_000,
                batch_repeats=2,
                python_n=400,
                nd_batch_n=(1_000, 10_000),
                nd_python_n=200,
                filter_calls=100,
                filter_states=4,
            )
        return cls(
            quick=False,
            calls=50_000,
            warmup=20,
            states_per_zone=64,
            latency_edges=(4, 8, 32),
            batch_edges=(8, 32),
            batch_n=1_000_000,
            batch_repeats=7,
            python_n=20_000,
            nd_batch_n=(1_000, 10_000, 1_000_000),
            nd_python_n=2_000,
            filter_calls=2_000,
            filter_states=16,
        )
