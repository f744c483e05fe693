r"""Benchmarks: per-call latency, a QP baseline, batch throughput, the other controllers.

Timing targets live here, not in unit tests. :func:`run_benchmarks` (the ``velfence bench``
command) measures

1. the latency of one :meth:`~velfence.PolygonShaper.shape` call (median, p99, max in µs; every
   call timed on its own with :func:`time.perf_counter_ns`, after a warm-up, with the garbage
   collector disabled) for regular 4-, 8- and 32-gons, both methods, the point in each zone;
2. the *same* constraint set as the exact law solved as a QP through :func:`qpsolvers.solve_qp`
   (``solver="daqp"``) and through ``daqp.solve`` directly, on the same states, with the ratios
   QP / velfence and the largest difference between the answers;
3. the throughput of :meth:`~velfence.PolygonShaper.shape_batch` with and without numba;
4. the joint-stop limiter, one obstacle-avoidance control cycle of redundant arms, one step of
   cobot path following and of resolved-rate teleoperation;
5. the n-D exact law (:class:`~velfence.PolytopeShaper`: per call on a 3-D box, an icosahedron
   and a 7-D joint box, beside qpsolvers/daqp on its own bound rows, and in batch) and one
   :class:`~velfence.SafetyFilter` cycle of a 7-DoF arm (joint and twist mode, beside daqp on
   the filter's own rows and mink's ``solve_ik`` when mink is installed);
6. the machine it ran on.

The result is a :class:`BenchReport` (``to_dict()`` for JSON, ``to_markdown()`` for
``docs/benchmarks.md``). The optional pieces (numba, qpsolvers, daqp) are skipped, with a note,
when they are not installed (mink too: the ``peers`` extra).

Modules: :mod:`~velfence.apps.bench.timing` (the measuring primitive),
:mod:`~velfence.apps.bench.rows`
(the table rows), :mod:`~velfence.apps.bench.cases` (one module per family of cases),
:mod:`~velfence.apps.bench.report` (the report and its Markdown), :mod:`~velfence.apps.bench.run`
(the
run), :mod:`~velfence.apps.bench.plan` (each step's expected seconds, which the progress
follows), :mod:`~velfence.apps.bench.settings` and :mod:`~velfence.apps.bench.machine`.
"""

from __future__ import annotations

from velfence.apps.bench.cases.peers import qp_bounds
from velfence.apps.bench.cases.shaping import regular_polygon
from velfence.apps.bench.machine import Machine, machine_info
from velfence.apps.bench.report import DEFAULT_PREAMBLE as DEFAULT_PREAMBLE
from velfence.apps.bench.report import GENERATED_MARKER, BenchReport, write_report
from velfence.apps.bench.rows import BatchRow, LatencyRow, QPRow, TargetCheck, WorstZone
from velfence.apps.bench.rows import ControlCycleRow as ControlCycleRow
from velfence.apps.bench.rows import StepRow as StepRow
from velfence.apps.bench.rows import StopLatencyRow as StopLatencyRow
from velfence.apps.bench.run import Progress as Progress
from velfence.apps.bench.run import run_benchmarks
from velfence.apps.bench.settings import AGREEMENT_TARGET as AGREEMENT_TARGET
from velfence.apps.bench.settings import BUFFER as BUFFER
from velfence.apps.bench.settings import LATENCY_TARGET_US as LATENCY_TARGET_US
from velfence.apps.bench.settings import MAX_EDGES as MAX_EDGES
from velfence.apps.bench.settings import SEED as SEED
from velfence.apps.bench.settings import SPRING_GAIN as SPRING_GAIN
from velfence.apps.bench.settings import THROUGHPUT_TARGET as THROUGHPUT_TARGET
from velfence.apps.bench.settings import ZONES as ZONES
from velfence.apps.bench.settings import BenchSettings

# The names above imported "as" themselves are importable from here too (as before the split)
# but, as before, not part of __all__.

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
