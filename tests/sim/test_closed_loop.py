"""Shapers in closed loop: the properties the simulation is for."""

import numpy as np
import pytest

import velfence as vf
from velfence.sim import (
    AxisLimits,
    HardStop,
    NoLimit,
    chatter_rate,
    max_penetration,
    push,
    simulate,
    simulate_many,
    sliding_ratio,
    time_outside,
)

SQUARE = vf.ConvexPolygon([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
BUFFER = 0.1


def polygon_shaper(method, **kw):
    return vf.PolygonShaper(SQUARE, buffer=BUFFER, spring_gain=4.0, method=method, **kw)


@pytest.mark.parametrize("method", ["exact", "patent"])
@pytest.mark.parametrize("speed", [0.5, 5.0, 50.0])
def test_pure_push_into_an_edge_never_crosses(method, speed):
    dt = 1e-3
    assert dt * speed < BUFFER
    traj = simulate(
        polygon_shaper(method), lambda t, p: np.array([0.0, -speed]), [0.5, 0.5],
        duration=2.0, dt=dt,
    )  # fmt: skip
    assert max_penetration(traj, SQUARE) == 0.0
    assert traj.p[-1, 1] < 0.02  # it did reach the edge
    assert set(traj.zone) <= {"free", "buffer"}


@pytest.mark.parametrize("method", ["exact", "patent"])
def test_pure_push_near_the_step_limit_crosses_only_by_round_off(method):
    """dt·s = 0.09 of a 0.1 buffer: d_{k+1} = d_k (1 - dt s / d_max) >= 0 in exact arithmetic.

    In floating point the shaped normal speed is computed by cancellation (|v| - |v| d/d_max
    - |v|), with an absolute error ~ eps·|v| that exceeds the required speed once d ~ 1e-17;
    the point then crosses by ~1e-18 (reported to the core; both methods).
    """
    traj = simulate(
        polygon_shaper(method), lambda t, p: np.array([0.0, -90.0]), [0.5, 0.5], duration=0.1
    )
    assert max_penetration(traj, SQUARE) <= 1e-16


@pytest.mark.parametrize("method", ["exact", "patent"])
def test_diagonal_push_slides_along_the_edge(method):
    traj = simulate(
        polygon_shaper(method), lambda t, p: np.array([0.3, -0.3]), [0.2, 0.05], duration=2.0
    )
    assert sliding_ratio(traj, SQUARE, band=BUFFER) == pytest.approx(1.0, abs=1e-9)
    assert max_penetration(traj, SQUARE) == 0.0
    assert chatter_rate(traj, SQUARE, band=BUFFER) == 0.0


def test_hard_stop_sticks_where_the_exact_law_slides():
    out = simulate_many(
        {"exact": polygon_shaper("exact"), "hard": HardStop(SQUARE, dt=1e-3)},
        lambda t, p: np.array([0.3, -0.3]),
        [0.2, 0.05],
        duration=2.0,
    )
    assert sliding_ratio(out["hard"], SQUARE, band=BUFFER) < 0.1
    assert max_penetration(out["hard"], SQUARE) == 0.0
    assert out["exact"].p[-1, 0] == pytest.approx(0.8)


def test_push_outward_exact_recovers_hard_stop_deadlocks():
    """A 0.5 s outward push on a backdrivable mechanism: only the spring/recovery brings it back."""
    w = push(0.1, 0.6, [0.0, -0.4])
    shapers = {
        "exact": polygon_shaper("exact"),
        "patent": polygon_shaper("patent"),
        "hard": HardStop(SQUARE, dt=1e-3),
        "axis": AxisLimits(SQUARE.inscribed_rectangle(), buffer=BUFFER),
        "none": NoLimit(),
    }
    out = simulate_many(shapers, lambda t, p: np.zeros(2), [0.5, 0.05], duration=2.0, disturbance=w)
    for name in ("exact", "patent", "hard", "axis", "none"):
        assert max_penetration(out[name], SQUARE) > 0.05, name
    for name in ("exact", "patent"):
        assert out[name].p[-1, 1] > -1e-3, name  # recovered
        assert time_outside(out[name], SQUARE, tol=1e-3) < 1.5, name
    for name in ("hard", "axis", "none"):
        assert out[name].p[-1, 1] < -0.1, name  # no recovery for a zero command
