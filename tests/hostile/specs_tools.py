"""Specs of the public tool modules velfence.apps.bench, velfence.apps.demo, velfence.apps.soak and
soak_filter."""

from __future__ import annotations

import numpy as np
from common import square
from harness import C, F, call

from velfence.apps import bench as bm
from velfence.apps import soak, soak_filter

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


def _soak_case() -> soak.SoakCase:
    return soak.polygon_cases(episodes=2, polygons=1, seed=0)[0]


def _soak_result() -> soak.SoakResult:
    return soak.run_case(_soak_case(), episodes=2, steps_per_episode=5)


def _vertex_result() -> soak_filter.VertexResult:
    return soak_filter.run_vertex_campaign(states=20, filter_states=0, per_polytope=20)[0]


def _cfg():  # type: ignore[no-untyped-def]
    from velfence.apps.demo.config import load_config

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
    "progress.Tracker": C(
        new=F(
            lambda: call([("a", 1.0)], title="velfence x", quiet=True),
            types={"console": "object", "title": "text"},
        ),
        methods={
            "stage": F(lambda: call("a"), types={"name": "text"}),
            "update": F(lambda: call(1.0, 2.0, "x"), types={"what": "text"}),
            "note": F(lambda: call("x"), types={"text": "text"}),
        },
    ),
    "progress.current": F(lambda: call()),
    "labels.method_label": F(lambda: call("per-joint-clamp"), types={"method": "text"}),
    "progress.frames": F(lambda: call("demo.gif"), types={"name": "text"}),
    "progress.stage": F(lambda: call("a"), types={"name": "text"}),
    "progress.summary": F(
        lambda: call("/nonexistent-velfence-hostile", [], "ok"),
        types={"verdict": "text", "folder": "path"},
        skip={"files": "an empty list is valid (a command that wrote nothing)"},
    ),
    "progress.update": F(lambda: call(1.0, 2.0, "x"), types={"what": "text"}),
    "progress.note": F(lambda: call("x"), types={"text": "text"}),
    "demo.build_shapers": F(lambda: call(square(), _cfg())),
    "demo.run_demo": F(
        lambda: call(out_dir="/nonexistent-velfence-hostile/demo"),
        heavy="runs the demo scenario and writes plots; only refusals are tried",
        types={"config_path": "path", "out_dir": "path", "console": "object", "config": "object"},
    ),
    "demo.run_arm_demo": F(
        lambda: call(out_dir="/nonexistent-velfence-hostile/demo-arm"),
        heavy="runs the arm scenario (minutes) and writes plots; only refusals are tried",
        types={"out_dir": "path", "console": "object", "methods": "object"},
    ),
    "soak.SoakCase": C(
        record="a campaign configuration of callables (polygon_cases(), stop_cases()); "
        "run_case() calls what it holds"
    ),
    "soak.SoakResult": C(record="output record of run_case()"),
    "soak.render_markdown": F(
        lambda: call([_soak_result()], command="make soak"),
        types={"command": "text", "notes": "text"},
    ),
    "soak.run_case": F(lambda: call(_soak_case(), episodes=2, steps_per_episode=5)),
    "soak_filter.CartesianPoint": C(
        new=F(lambda: call(dim=3)),
        instance=lambda: soak_filter.CartesianPoint(dim=3),
        methods={
            "fk": lambda: call(np.zeros(3)),
            "jacobian": lambda: call(np.zeros(3)),
        },
    ),
    "soak_filter.VertexResult": C(record="output record of run_vertex_campaign()"),
    "soak_filter.LoopResult": C(record="output record of run_loop_campaign()"),
    "soak_filter.render_markdown": F(
        lambda: call([_vertex_result()], command="make soak-filter"),
        types={"command": "text", "notes": "text", "intro": "text"},
    ),
    "soak_filter.run_vertex_campaign": F(
        lambda: call(states=20, filter_states=0, per_polytope=20),
        heavy="builds random polytopes and runs the shaper (a campaign); only refusals are tried",
    ),
    "soak_filter.run_loop_campaign": F(
        lambda: call("ur5e", 100.0, steps=10, episode_steps=10),
        heavy="builds MuJoCo models and runs a closed loop (a campaign); only refusals are tried",
    ),
}
