"""Smoke version of the containment soak (``make soak`` runs 10⁶ steps per case)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.apps.soak import (
    SoakCase,
    _PlanarSets,
    polygon_cases,
    render_markdown,
    run_case,
    stop_cases,
)
from velfence.errors import InvalidParameter
from velfence.geometry import ConvexPolygon
from velfence.shaping import PolygonShaper
from velfence.sim.baselines import NoLimit

#: Slow, left out of `make check` (`make test` runs them): 10^4-step closed-loop campaigns.
pytestmark = pytest.mark.slow

SMOKE = {"episodes": 10, "steps_per_episode": 1000}


@pytest.fixture(scope="module")
def polygon_results() -> dict[str, object]:
    cases = polygon_cases(episodes=SMOKE["episodes"], polygons=5, seed=1)
    return {c.name: run_case(c, **SMOKE, seed=1) for c in cases}


def test_exact_polygon_and_caster_wall_are_contained(polygon_results: dict[str, object]) -> None:
    for name in ("PolygonShaper exact, 1 kHz", "CasterWall, 1 kHz"):
        r = polygon_results[name]
        assert r.steps == 10_000
        assert r.escapes == 0, name
        assert r.max_penetration <= 1e-9, name
        assert r.nonfinite == 0, name


def test_exact_polygon_recovers_from_outside(polygon_results: dict[str, object]) -> None:
    r = polygon_results["PolygonShaper exact, 1 kHz"]
    assert r.outside_episodes > 0
    assert r.recovered == r.outside_episodes
    assert r.median_recovery_time is not None
    assert 0.0 < r.median_recovery_time < 1.0


def test_exact_polygon_with_the_control_period_is_contained_at_20_hz(
    polygon_results: dict[str, object],
) -> None:
    r = polygon_results["PolygonShaper exact, 20 Hz, 3 units/s, dt=0.05"]
    assert r.escapes == 0
    assert r.max_penetration <= 1e-9
    assert r.recovered == r.outside_episodes


def _square_case(name: str, shaper: object, dt: float, speed: float) -> SoakCase:
    square = ConvexPolygon([[0, 0], [2, 0], [2, 2], [0, 2]])
    # Deliberately internal: one custom campaign case built from the soak module's own safe-set
    # geometry (the public polygon_cases() only builds the fixed campaign).
    sets = _PlanarSets([square], 10, np.eye(2))
    return SoakCase(
        name, sets.sample, sets.margin, sets.outward,
        lambda X, V: shaper.shape_batch(X, V), dt, speed, 2,  # type: ignore[attr-defined]
    )  # fmt: skip


def test_continuous_law_at_20_hz_leaks() -> None:
    # Without a control period the exact law only guarantees containment in continuous time: at
    # 20 Hz and 3 m/s with a 5 cm buffer one Euler step overshoots. The campaign must see it.
    square = ConvexPolygon([[0, 0], [2, 0], [2, 2], [0, 2]])
    shaper = PolygonShaper(square, buffer=0.05, spring_gain=1.0, method="exact")
    r = run_case(_square_case("20 Hz", shaper, 0.05, 3.0), **SMOKE, seed=4)
    assert r.escapes > 0
    assert r.max_penetration > 0.01
    periodic = PolygonShaper(square, buffer=0.05, spring_gain=1.0, method="exact", dt=0.05)
    r = run_case(_square_case("20 Hz, dt", periodic, 0.05, 3.0), **SMOKE, seed=4)
    assert r.escapes == 0
    assert r.max_penetration <= 1e-9


def test_stop_limiter_is_contained_with_and_without_rate_limiter() -> None:
    alone, rated = stop_cases(episodes=10)
    for case in (alone, rated):
        r = run_case(case, **SMOKE, seed=2)
        assert r.escapes == 0, case.name
        assert r.max_penetration <= 1e-9, case.name
        assert r.recovered == r.outside_episodes, case.name
    assert run_case(alone, **SMOKE, seed=2).flagged == -1
    assert run_case(rated, **SMOKE, seed=2).flagged >= 0


def test_the_campaign_detects_a_shaper_that_does_not_limit() -> None:
    r = run_case(_square_case("no limit", NoLimit(), 1e-3, 1.0), **SMOKE, seed=3)
    assert r.escapes > 0
    assert r.max_penetration > 0.1
    assert not r.contained


def test_campaign_parameters_are_validated() -> None:
    case = stop_cases(episodes=2)[0]
    with pytest.raises(InvalidParameter, match="episodes"):
        run_case(case, episodes=0)
    with pytest.raises(InvalidParameter, match="push_fraction"):
        run_case(case, episodes=2, steps_per_episode=2, push_fraction=1.5)
    with pytest.raises(InvalidParameter, match="1e8"):
        run_case(case, episodes=10**5, steps_per_episode=10**4)


def test_markdown_table_lists_every_case(polygon_results: dict[str, object]) -> None:
    text = render_markdown(list(polygon_results.values()), command="cmd")
    assert text.startswith("Produced by `cmd`.")
    for name in polygon_results:
        assert f"| {name} |" in text
    assert not any(math.isnan(r.max_penetration) for r in polygon_results.values())
