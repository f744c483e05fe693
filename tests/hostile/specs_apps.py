"""Specs of the applications velfence.apps.engine (the shard engine), velfence.apps.fleet (fleet
replay summaries) and velfence.apps.verify (verification campaigns), and of the closed-loop soak's
helpers in soak_filter."""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from harness import C, F, call

from velfence.apps.engine import Engine

_NOWHERE = "/nonexistent-velfence-hostile"
_CAMPAIGN = {"robot": "seven_dof", "families": [{"name": "box", "cases": 1, "steps": 5}]}


def _double(x: int) -> int:
    return 2 * x


@functools.cache
def _fleet() -> Path:
    from velfence.apps.fleet import make_demo_fleet

    return make_demo_fleet(Path(tempfile.mkdtemp()) / "fleet", bags=2, robots=1, cycles=10)


def _config() -> Path:
    return _fleet() / "replay.yaml"


def _bag() -> Path:
    from velfence.apps.fleet import find_bags

    return find_bags([_fleet()])[0][0]


@functools.cache
def _shaper() -> Any:
    from velfence.io.bags import load_replay_config

    return load_replay_config(_config())[0]


@functools.cache
def _replayed() -> Any:
    from velfence.io.bags import replay

    return replay(_bag(), _config(), Path(tempfile.mkdtemp()) / "shaped")


def _bag_report() -> Any:
    from velfence.apps.fleet import summarize_replay

    return summarize_replay(_replayed(), _shaper(), tol=1e-6)


def _summary() -> Any:
    from velfence.apps.fleet import FleetSummary

    return FleetSummary(config="replay.yaml", tol=1e-6, bags=(_bag_report(),))


@functools.cache
def _scenario_file() -> Path:
    from velfence.apps.verify.campaign import parse_campaign
    from velfence.apps.verify.cases import sample, write_scenario

    path = Path(tempfile.mkdtemp()) / "case.yaml"
    return write_scenario(sample(parse_campaign(_CAMPAIGN), 0, 0), path)


def _campaign_file() -> Path:
    path = Path(tempfile.mkdtemp()) / "campaign.yaml"
    path.write_text("robot: seven_dof\nfamilies: [{name: box, cases: 1, steps: 5}]\n")
    return path


def _campaign() -> Any:
    from velfence.apps.verify import parse_campaign

    return parse_campaign(_CAMPAIGN)


def _scenario() -> Any:
    from velfence.apps.verify import load_scenario

    return load_scenario(_scenario_file())


def _case() -> Any:
    from velfence.apps.verify import replay

    return replay(_scenario_file())


def _facets() -> dict[str, Any]:
    return {
        "N": np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]),
        "o": np.array([-1.0, -1.0]),
        "p": np.zeros(3),
        "vmax": np.ones(7),
        "rate": 500.0,
    }


_SEG = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 0.5]], [[0.0, 0.0, 0.5], [0.3, 0.0, 0.5]]])

#: The items of a map are the function's data, never read by the engine: any iterable is valid.
_ITEMS = {
    "progress": "a callback, called as shards finish: its own errors are the caller's",
    "items": "the function's data (any iterable of picklable values), never read by the engine",
}
#: A class is a callable (``engine.map(float, ["1", "2"])`` converts every item).
_CLASS_FN = {"fn": {"type_float": "a class is a function of one item"}}

#: No bags is a valid (empty) answer: the command line says "no bag" itself.
_NO_BAGS = {k: "documented: no paths, no bags" for k in ("empty_list", "empty_tuple")}

SPECS: dict[str, F | C] = {
    "engine.Engine": C(
        # An address is a structured string (either answer for a string, like a path); the
        # constructor starts nothing (the cluster starts on entry or on the first map).
        new=F(lambda: call(timeout=1.0), types={"cluster": "path"}),
        instance=lambda: Engine(workers=0),
        methods={
            "close": lambda: call(),
            "map": F(lambda: call(_double, [1, 2]), skip=_ITEMS, accepts=_CLASS_FN),
            "n_workers": lambda: call(),
            "run": F(lambda: call(_double, [1, 2]), skip=_ITEMS, accepts=_CLASS_FN),
            "start": lambda: call(),
        },
    ),
    "engine.default_workers": F(lambda: call()),
    "engine.progress_text": F(lambda: call(3, 10, 2.0), types={"elapsed": "nonneg"}),
    "fleet.BagReport": C(
        record="output record of summarize_bag() / summarize_replay()", instance=_bag_report
    ),
    "fleet.RobotReport": C(record="output record of FleetSummary.robots"),
    "fleet.FleetSummary": C(
        record="output record of fleet_replay()",
        instance=_summary,
        methods={
            "csv": lambda: call(),
            "markdown": lambda: call(),
            "robots": lambda: call(),
            "rows": lambda: call(),
        },
    ),
    "fleet.bounds_of": F(lambda: call(_shaper()), types={"cs": "object"}),
    "fleet.find_bags": F(
        lambda: call([_fleet()]), types={"paths": "object"}, accepts={"paths": _NO_BAGS}
    ),
    "fleet.fleet_replay": F(
        lambda: call([_bag()], _config(), tol=1e-6),
        heavy="replays every bag on the engine (seconds); only refusals are tried",
        types={"bags": "object", "config": "path", "engine": "object"},
    ),
    "fleet.make_demo_fleet": F(
        lambda: call(f"{_NOWHERE}/fleet", bags=2, robots=1),
        heavy="writes a folder of bags; only refusals are tried",
        types={"folder": "path"},
    ),
    "fleet.output_names": F(
        lambda: call([Path("a/run.mcap"), Path("b/run.mcap")]),
        types={"bags": "object"},
        accepts={"bags": _NO_BAGS},
    ),
    "fleet.summarize_bag": F(
        lambda: call(_bag(), _config(), tol=1e-6),
        heavy="replays a bag and writes the shaped bag; only refusals are tried",
        types={"bag": "path", "config": "path", "group": "text"},
    ),
    "fleet.summarize_replay": F(
        lambda: call(_replayed(), _shaper(), tol=1e-6),
        types={"s": "object", "cs": "object", "bag": "text", "group": "text"},
    ),
    "soak_filter.any_start": F(lambda: call()),
    "soak_filter.clearance": F(
        lambda: call(_SEG, np.array([0.05, 0.05]), np.array([[0.5, 0.0, 0.5]]), np.array([0.1])),
        nonfinite={"out": "documented: inf when there is no sphere (no link can touch one)"},
    ),
    "soak_filter.soak_command": F(
        lambda: call(np.random.default_rng(0), twist=True, **_facets()),
        skip={"rng": "a numpy Generator (its draws are the soak's)"},
    ),
    "verify.batch.run_batch": F(
        lambda: call([_scenario()], family="box", indices=[0]),
        types={"scenarios": "object", "family": "text", "indices": "object"},
        skip={"timings": "an output: any dict, the CPU seconds per part are added to it"},
    ),
    "verify.Campaign": C(
        record="a validated configuration built by parse_campaign() / load_campaign()",
        instance=_campaign,
        methods={"normalised": lambda: call()},
    ),
    "verify.Scenario": C(
        record="a validated case built by load_scenario() (and the campaign's sampler)",
        instance=_scenario,
    ),
    "verify.CaseResult": C(
        record="output record of replay() and the campaign's shards",
        instance=_case,
        methods={"to_json": lambda: call()},
    ),
    "verify.Outcome": C(record="output record of verify()"),
    "verify.load_campaign": F(lambda: call(_campaign_file()), types={"path": "path"}),
    "verify.load_scenario": F(lambda: call(_scenario_file()), types={"path": "path"}),
    "verify.parse_campaign": F(
        lambda: call(dict(_CAMPAIGN)), types={"data": "object", "where": "text"}
    ),
    "verify.replay": F(lambda: call(_scenario_file()), types={"path": "path"}),
    "verify.verify": F(
        lambda: call(dict(_CAMPAIGN), Path(tempfile.mkdtemp()) / "verify"),
        heavy="runs a campaign and writes its report; only refusals are tried",
        types={"campaign": "object", "out": "path", "mapper": "callable"},
    ),
}
