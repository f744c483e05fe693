"""Specs of the public tool modules velfence.bench and velfence.demo."""

from __future__ import annotations

import numpy as np
from common import square
from harness import C, F, call

from velfence import bench as bm

_ROW = "output record of run_benchmarks() (one table row)"


def _report() -> bm.BenchReport:
    return bm.BenchReport(
        settings=bm.BenchSettings.make(quick=True),
        machine=bm.machine_info(),
        timer_overhead_ns=1.0,
        latency=(),
        worst=(),
        qp=(),
        batch=(),
        targets=(),
    )


def _cfg():  # type: ignore[no-untyped-def]
    from velfence.io import load_config

    return load_config(None)


SPECS: dict[str, F | C] = {
    "bench.BatchRow": C(record=_ROW),
    "bench.LatencyRow": C(record=_ROW),
    "bench.QPRow": C(record=_ROW),
    "bench.TargetCheck": C(record=_ROW),
    "bench.WorstZone": C(record=_ROW),
    "bench.Machine": C(record="output record of machine_info()"),
    "bench.BenchSettings": C(
        record="settings record built by BenchSettings.make()",
        instance=lambda: bm.BenchSettings.make(quick=True),
        methods={"make": lambda: call(quick=True)},
    ),
    "bench.BenchReport": C(
        record="output record of run_benchmarks()",
        instance=_report,
        methods={"to_dict": lambda: call(), "to_markdown": lambda: call()},
    ),
    "bench.machine_info": F(lambda: call()),
    "bench.qp_bounds": F(
        lambda: call(
            square(), np.array([0.5, 0.2]), np.array([1.0, 0.3]), buffer=0.2, spring_gain=2.0
        )
    ),
    "bench.regular_polygon": F(lambda: call(6)),
    "bench.run_benchmarks": F(
        lambda: call(quick=True), heavy="times every shaper (minutes); only refusals are tried"
    ),
    "bench.write_report": F(
        lambda: call(_report(), "/nonexistent-velfence-hostile/bench.md"),
        heavy="writes a report file; only refusals are tried",
    ),
    "demo.DemoResult": C(record="output record of run_demo()"),
    "demo.build_shapers": F(lambda: call(square(), _cfg())),
    "demo.run_demo": F(
        lambda: call(out_dir="/nonexistent-velfence-hostile/demo"),
        heavy="runs the demo scenario and writes plots; only refusals are tried",
        types={"config_path": "path", "out_dir": "path", "console": "object", "config": "object"},
    ),
}
