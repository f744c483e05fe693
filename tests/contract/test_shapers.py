"""The shaper contract (velfence.shaping.base), run over every shaper.

Adding a shaper means adding one entry to ``FACTORIES``: ``(name, make)`` where
``make(**overrides)`` returns a shaper whose ``shape(p, v)`` takes a 2-D position and command.
``make`` must pass the overrides through to the constructor (the tests use ``on_invalid`` and,
for the parameter checks, each keyword-only parameter). States are drawn around ``POLYGON``.

Checks: finite float (2,) output; ``explain().output == shape()``; ``shape_batch`` equals a loop of
``shape`` exactly; ``explain`` satisfies the typed result contract (``ShapingResultProtocol``: a
``Zone`` name, the active constraints, the stage names); non-finite input raises ``InvalidInput``
naming "finite" or, with ``on_invalid="stop"``, gives zeros; wrong shapes raise ``InvalidInput``;
all tuning parameters are keyword-only; a bad parameter raises ``InvalidParameter`` naming it.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from bad_inputs import bad_tuning_values
from velfence import (
    ConvexPolygon,
    InvalidInput,
    InvalidParameter,
    LinearBuffer,
    PolygonShaper,
    Shaper,
    ShapingResult,
    ThreeZoneBraking,
)
from velfence.shaping import ZONE_NAMES
from velfence.shaping.base import ZONES, ShapingResultProtocol
from velfence.sim import AxisLimits, HardStop, NoLimit

POLYGON = ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])  # the README's pentagon

Factory = Callable[..., Any]


def _polygon_shaper(method: str) -> Factory:
    def make(**overrides: Any) -> PolygonShaper:
        kw: dict[str, Any] = {"buffer": 0.2, "spring_gain": 4.0, "method": method}
        kw.update(overrides)
        return PolygonShaper(POLYGON, **kw)

    return make


def _polygon_profile(kind: str) -> Factory:
    """The exact law with an approach profile instead of the built-in buffer."""

    def make(**overrides: Any) -> PolygonShaper:
        if kind == "linear":
            profile: Any = LinearBuffer(buffer=0.2, spring_gain=4.0)
        else:
            profile = ThreeZoneBraking(gain=20.0, max_speed=2.0, max_acceleration=10.0)
        return PolygonShaper(POLYGON, **{"profile": profile, **overrides})

    return make


def _baseline(kind: str) -> Factory:
    def make(**overrides: Any) -> Any:
        if kind == "none":
            return NoLimit(**overrides)
        if kind == "hard-stop":
            return HardStop(POLYGON, **{"dt": 1e-3, **overrides})
        return AxisLimits(POLYGON.inscribed_rectangle(), **{"buffer": 0.2, **overrides})

    return make


def _caster_wall(**overrides: Any) -> Any:
    from velfence.cobot import CasterWall

    return CasterWall(POLYGON, **{"buffer": 0.2, **overrides})


FACTORIES: list[tuple[str, Factory]] = [
    ("polygon-patent", _polygon_shaper("patent")),
    ("polygon-exact", _polygon_shaper("exact")),
    ("polygon-linear-profile", _polygon_profile("linear")),
    ("polygon-three-zone-profile", _polygon_profile("three-zone")),
    ("baseline-none", _baseline("none")),
    ("baseline-hard-stop", _baseline("hard-stop")),
    ("baseline-axis-limits", _baseline("axis-limits")),
    ("cobot-caster-wall", _caster_wall),
]

IDS = [name for name, _ in FACTORIES]
MAKERS = [make for _, make in FACTORIES]


def states(n: int = 300, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Positions in and around POLYGON (free zone, buffer, corners, outside) and commands."""
    rng = np.random.default_rng(seed)
    lo, hi = POLYGON.corners.min(axis=0), POLYGON.corners.max(axis=0)
    mid, half = 0.5 * (lo + hi), 0.8 * (hi - lo)
    P = mid + rng.uniform(-1.0, 1.0, size=(n, 2)) * half
    P[: len(POLYGON.corners)] = POLYGON.corners  # exactly on the corners
    P[len(POLYGON.corners)] = POLYGON.centroid
    V = rng.normal(size=(n, 2)) * rng.uniform(0.0, 4.0, size=(n, 1))
    V[::11] = 0.0
    return P, V


# ---------------------------------------------------------------------------- outputs
@pytest.mark.parametrize("make", MAKERS, ids=IDS)
def test_is_a_shaper(make: Factory) -> None:
    assert isinstance(make(), Shaper)


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
def test_shape_returns_finite_float_pair(make: Factory) -> None:
    sh = make()
    P, V = states()
    for p, v in zip(P, V, strict=True):
        p0, v0 = p.copy(), v.copy()
        out = sh.shape(p, v)
        assert isinstance(out, np.ndarray)
        assert out.shape == (2,)
        assert out.dtype == np.float64
        assert np.all(np.isfinite(out))
        assert out is not v
        np.testing.assert_array_equal(p, p0)  # inputs untouched
        np.testing.assert_array_equal(v, v0)


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
def test_accepts_sequences(make: Factory) -> None:
    sh = make()
    np.testing.assert_array_equal(
        sh.shape([0.1, 0.05], (1.0, -1.0)), sh.shape(np.array([0.1, 0.05]), np.array([1.0, -1.0]))
    )


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
def test_explain_output_equals_shape(make: Factory) -> None:
    sh = make()
    P, V = states(seed=1)
    for p, v in zip(P, V, strict=True):
        r = sh.explain(p, v)
        assert isinstance(r, ShapingResult)
        np.testing.assert_array_equal(r.output, sh.shape(p, v))
        np.testing.assert_array_equal(r.position, p)
        np.testing.assert_array_equal(r.command, v)
        assert r.zone in {"free", "buffer", "corner", "outside", "outside-corner"}


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
def test_explain_satisfies_the_typed_result_contract(make: Factory) -> None:
    sh = make()
    P, V = states(seed=4)
    seen: set[str] = set()
    for p, v in zip(P, V, strict=True):
        r = sh.explain(p, v)
        assert isinstance(r, ShapingResultProtocol)
        assert r.zone in ZONES
        assert isinstance(r.stages, tuple)
        assert all(isinstance(x, str) for x in r.stages)
        assert isinstance(r.active, tuple)
        assert all(isinstance(e, int) and 0 <= e < POLYGON.n for e in r.active)
        # The active constraints are the ones the zone names: one edge, or two at a corner.
        expected = {"free": 0, "buffer": 1, "outside": 1, "corner": 2, "outside-corner": 2}
        assert len(r.active) == expected[r.zone]
        if r.active:
            assert r.active[0] == r.primary
        seen.add(r.zone)
    invalid = make(on_invalid="stop").explain([math.nan, 0.0], [0.0, 0.0])
    assert (invalid.zone, invalid.active, invalid.stages) == ("invalid", (), ("stop",))
    assert {"free", "buffer"} <= seen or sh.method == "no-limit"


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
def test_batch_equals_loop(make: Factory) -> None:
    sh = make()
    P, V = states(seed=2)
    out = sh.shape_batch(P, V)
    assert out.shape == P.shape
    assert out.dtype == np.float64
    loop = np.array([sh.shape(p, v) for p, v in zip(P, V, strict=True)])
    np.testing.assert_array_equal(out, loop)
    # lists are accepted, and an empty batch is an empty (0, 2) answer
    np.testing.assert_array_equal(sh.shape_batch(P[:5].tolist(), V[:5].tolist()), loop[:5])
    assert sh.shape_batch(np.zeros((0, 2)), np.zeros((0, 2))).shape == (0, 2)


@pytest.mark.parametrize("method", ["patent", "exact"])
@pytest.mark.parametrize("accelerate", [True, False])
def test_polygon_batch_equals_loop_with_and_without_numba(method: str, accelerate: bool) -> None:
    sh = _polygon_shaper(method)(accelerate=accelerate)
    P, V = states(n=2000, seed=3)
    out, zones = sh.zones_batch(P, V)
    loop = np.array([sh.shape(p, v) for p, v in zip(P, V, strict=True)])
    np.testing.assert_array_equal(out, loop)
    assert [ZONE_NAMES[z] for z in zones] == [
        sh.explain(p, v).zone for p, v in zip(P, V, strict=True)
    ]
    # an empty batch on either path (the plain-Python path once failed to broadcast it)
    empty, empty_zones = sh.zones_batch(np.zeros((0, 2)), np.zeros((0, 2)))
    assert empty.shape == (0, 2)
    assert empty_zones.shape == (0,)


# ---------------------------------------------------------------------------- invalid input
BAD_VALUES = [math.nan, math.inf, -math.inf]


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
@pytest.mark.parametrize("bad", BAD_VALUES, ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("slot", range(4), ids=["px", "py", "vx", "vy"])
def test_non_finite_input(make: Factory, bad: float, slot: int) -> None:
    x = np.array([1.0, 0.1, 0.5, -0.5])
    x[slot] = bad
    p, v = x[:2], x[2:]
    raising = make()
    with pytest.raises(InvalidInput, match="finite"):
        raising.shape(p, v)
    with pytest.raises(InvalidInput, match="finite"):
        raising.explain(p, v)
    P, V = np.array([[1.0, 1.0], p, [0.5, 0.5]]), np.array([[0.1, 0.0], v, [0.0, 0.2]])
    with pytest.raises(InvalidInput, match="finite"):
        raising.shape_batch(P, V)

    stopping = make(on_invalid="stop")
    np.testing.assert_array_equal(stopping.shape(p, v), [0.0, 0.0])
    r = stopping.explain(p, v)
    assert r.zone == "invalid"
    np.testing.assert_array_equal(r.output, [0.0, 0.0])
    out = stopping.shape_batch(P, V)
    np.testing.assert_array_equal(out[1], [0.0, 0.0])
    np.testing.assert_array_equal(out[[0, 2]], stopping.shape_batch(P[[0, 2]], V[[0, 2]]))


WRONG_PAIRS = [
    np.zeros(3),
    np.zeros((1, 2)),
    np.zeros((2, 1)),
    [1.0, 2.0, 3.0],
    [1.0],
    "ab",
    None,
    1.0,
]


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
@pytest.mark.parametrize("bad", WRONG_PAIRS, ids=lambda b: repr(b)[:20])
def test_wrong_shapes_single(make: Factory, bad: Any) -> None:
    sh = make()
    good = np.array([1.0, 0.5])
    for args in ((bad, good), (good, bad)):
        with pytest.raises(InvalidInput):
            sh.shape(*args)
        with pytest.raises(InvalidInput):
            sh.explain(*args)


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
@pytest.mark.parametrize(
    ("P", "V"),
    [
        (np.zeros((4, 3)), np.zeros((4, 3))),
        (np.zeros(2), np.zeros(2)),
        (np.zeros((4, 2)), np.zeros((3, 2))),
        (np.zeros((2, 2, 2)), np.zeros((2, 2, 2))),
        ([["a", "b"]], [[0.0, 0.0]]),
    ],
    ids=["3-cols", "1-d", "mismatched-n", "3-d", "strings"],
)
def test_wrong_shapes_batch(make: Factory, P: Any, V: Any) -> None:
    with pytest.raises(InvalidInput, match=r"\(N, 2\)"):
        make().shape_batch(P, V)


# ---------------------------------------------------------------------------- parameters
def _constructor_params(make: Factory) -> tuple[type, list[inspect.Parameter]]:
    cls = type(make())
    params = list(inspect.signature(cls).parameters.values())
    return cls, params


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
def test_tuning_parameters_are_keyword_only(make: Factory) -> None:
    _, params = _constructor_params(make)
    positional = [p for p in params if p.kind is not inspect.Parameter.KEYWORD_ONLY]
    # at most the geometry / model may be positional; no *args
    assert len(positional) <= 1, [p.name for p in positional]
    assert all(p.kind is not inspect.Parameter.VAR_POSITIONAL for p in params)
    assert any(p.kind is inspect.Parameter.KEYWORD_ONLY for p in params)


def test_polygon_shaper_positional_call_raises() -> None:
    with pytest.raises(TypeError):
        PolygonShaper(POLYGON, 0.2)  # type: ignore[misc]
    with pytest.raises(TypeError):
        PolygonShaper(POLYGON, 0.2, 4.0, "exact")  # type: ignore[misc]


@pytest.mark.parametrize("make", MAKERS, ids=IDS)
def test_bad_parameters_are_named(make: Factory) -> None:
    cls, _ = _constructor_params(make)
    checked = 0
    choices = 0
    for name, bad in bad_tuning_values(cls):
        choices += bad == "no-such-choice"
        with pytest.raises(InvalidParameter, match=name) as info:
            make(**{name: bad})
        assert repr(bad) in str(info.value)  # the value got is in the message
        checked += 1
    assert checked > 0
    assert choices > 0  # every shaper has at least on_invalid


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("buffer", 0.0),
        ("buffer", -0.1),
        ("buffer", math.nan),
        ("buffer", None),
        ("spring_gain", -1.0),
        ("spring_gain", math.inf),
        ("method", "fast"),
        ("method", None),
        ("corner_blend_angle", 0.0),
        ("corner_blend_angle", math.pi),
        ("corner_blend_angle", 4.0),
        ("max_recovery_speed", 0.0),
        ("max_recovery_speed", -1.0),
        ("max_recovery_speed", math.nan),
        ("on_invalid", "ignore"),
    ],
)
def test_polygon_shaper_bad_parameters(name: str, value: Any) -> None:
    with pytest.raises(InvalidParameter, match=name) as info:
        _polygon_shaper("exact")(**{name: value})
    assert repr(value) in str(info.value)


def test_polygon_shaper_needs_a_polygon() -> None:
    with pytest.raises(InvalidParameter, match=r"polygon must be a velfence\.ConvexPolygon"):
        PolygonShaper(POLYGON.corners.tolist(), buffer=0.2)  # type: ignore[arg-type]
