"""The benchmarks' former single module, kept so that existing imports keep working.

Everything now lives in the :mod:`velfence.bench` package (timing, rows, one module per family
of cases, report); this module only re-exports its public names. New code imports
``velfence.bench``.
"""

from __future__ import annotations

from velfence.bench import AGREEMENT_TARGET as AGREEMENT_TARGET
from velfence.bench import BUFFER as BUFFER
from velfence.bench import DEFAULT_PREAMBLE as DEFAULT_PREAMBLE
from velfence.bench import (
    GENERATED_MARKER,
    BatchRow,
    BenchReport,
    BenchSettings,
    LatencyRow,
    Machine,
    QPRow,
    TargetCheck,
    WorstZone,
    machine_info,
    qp_bounds,
    regular_polygon,
    run_benchmarks,
    write_report,
)
from velfence.bench import LATENCY_TARGET_US as LATENCY_TARGET_US
from velfence.bench import MAX_EDGES as MAX_EDGES
from velfence.bench import SEED as SEED
from velfence.bench import SPRING_GAIN as SPRING_GAIN
from velfence.bench import THROUGHPUT_TARGET as THROUGHPUT_TARGET
from velfence.bench import ZONES as ZONES
from velfence.bench import ControlCycleRow as ControlCycleRow
from velfence.bench import Progress as Progress
from velfence.bench import StepRow as StepRow
from velfence.bench import StopLatencyRow as StopLatencyRow

# The names imported "as" themselves stay importable from here but, as before, not in __all__.
__all__ = [
    "GENERATED_MARKER",
    "BatchRow",
    "BenchReport",
    "BenchSettings",
    "LatencyRow",
    "Machine",
    "QPRow",
    "TargetCheck",
    "WorstZone",
    "machine_info",
    "qp_bounds",
    "regular_polygon",
    "run_benchmarks",
    "write_report",
]
