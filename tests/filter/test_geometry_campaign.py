"""The closed loop of ``benchmarks/safety_filter_geometry_campaign.py``, a few thousand steps.

A 7-joint arm with a random tool in a box among sphere obstacles, self-collision on, random
joint commands and TCP twists, grasp / release events: no attached shape leaves the box, no
shape or link enters an obstacle and no guarded link pair meets beyond round-off (1e-9 m), and
every output is finite. The violations are measured with the geometry primitives and the
robot's own frames, not with the filter's rows.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("velfence_core._filter")

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "safety_filter_geometry_campaign.py"


def _campaign() -> Any:
    spec = importlib.util.spec_from_file_location("geometry_campaign", _PATH)
    assert spec is not None
    assert spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _assert_clean(c: dict[str, Any]) -> None:
    for key in ("non_finite", "workspace", "tool-obstacle", "link-obstacle", "link-link"):
        assert c[key] == 0, (key, c)


def test_closed_loop_keeps_tools_payloads_and_links_apart() -> None:
    c = _campaign().run(800, seed=1, episode=400)
    _assert_clean(c)
    assert c["grasps"] > 0
    assert c["releases"] > 0
    assert c["twist_steps"] > 0


@pytest.mark.slow
def test_closed_loop_several_thousand_steps() -> None:
    c = _campaign().run(5000, seed=2)
    _assert_clean(c)
