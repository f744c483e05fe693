"""Approach profiles: keyword-only parameters, refusals naming the argument, C¹ continuity."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import velfence as vf
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking


def test_parameters_are_keyword_only():
    with pytest.raises(TypeError):
        ThreeZoneBraking(100, 20, 2)  # type: ignore[misc]
    with pytest.raises(TypeError):
        LinearBuffer(0.1)  # type: ignore[misc]
    with pytest.raises(TypeError):
        vf.RateLimiter(3, max_speed=1, max_acceleration=1, dt=1e-3)  # type: ignore[misc]
    assert ThreeZoneBraking(gain=100, max_speed=2, max_acceleration=20).delta_phi == pytest.approx(
        0.101
    )


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (
            {"gain": 1e-200},
            r"gain=1e-200 1/s with max_acceleration=20 .*δ_int = max_acceleration/gain²",
        ),
        ({"gain": 1e308}, r"gain must be <= 1e\+150"),
        ({"gain": 1e150, "max_acceleration": 1e-150}, r"gain=1e\+150 .*δ_int"),
        ({"max_speed": 1e150, "max_acceleration": 1e-150}, r"max_speed=1e\+150 .*braking distance"),
        ({"gain": "100"}, "gain must be a number"),
        ({"max_speed": True}, "max_speed must be a number"),
        ({"max_acceleration": math.nan}, "max_acceleration must be finite"),
        ({"max_acceleration": -1.0}, "max_acceleration must be finite and > 0"),
        (
            {"gain": 1.0, "max_speed": 1.0, "max_acceleration": 2.0},
            r"max_speed=1 units/s must exceed max_acceleration/gain",
        ),
    ],
)
def test_three_zone_refusals_name_the_argument(kwargs, match):
    base = {"gain": 100.0, "max_speed": 2.0, "max_acceleration": 20.0}
    base.update(kwargs)
    with pytest.raises(vf.InvalidParameter, match=match):
        ThreeZoneBraking(**base)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"buffer": "0.1"}, "buffer must be a number"),
        ({"buffer": True}, "buffer must be a number"),
        ({"buffer": 0.0}, "buffer must be finite and > 0"),
        ({"buffer": 0.1, "spring_gain": "2"}, "spring_gain must be a number"),
        ({"buffer": 0.1, "max_recovery_speed": b"1"}, "max_recovery_speed must be a number"),
    ],
)
def test_linear_buffer_refusals_name_the_argument(kwargs, match):
    with pytest.raises(vf.InvalidParameter, match=match):
        LinearBuffer(**kwargs)


def test_extreme_but_valid_parameters_give_finite_caps():
    for kw in (
        {"gain": 1e-100, "max_speed": 2.0, "max_acceleration": 1e-100},
        {"gain": 1e100, "max_speed": 1e100, "max_acceleration": 1e100},
    ):
        p = ThreeZoneBraking(**kw)
        for d in (0.0, 1e-300, p.delta_int, p.delta_phi, 1e150, -1e150):
            assert math.isfinite(p.cap(d))
    assert LinearBuffer(buffer=1e-150).cap(1e-151, speed=1e150) == pytest.approx(1e149)


profiles = st.builds(
    lambda g, v, r: ThreeZoneBraking(gain=g, max_speed=v, max_acceleration=r * v * g),
    st.floats(1.0, 1e4),
    st.floats(1e-2, 1e2),
    st.floats(1e-3, 0.99),  # max_acceleration/gain = r·max_speed < max_speed
)


@settings(max_examples=200)
@given(p=profiles, sign=st.sampled_from([1.0, -1.0]))
def test_three_zone_is_c1_at_delta_int_and_c0_at_delta_phi(p, sign):
    # Step h relative to the switch; one-sided difference quotients err by O(h·|cap''|) from the
    # curvature plus O(eps·|cap|/h) from round-off, so the tolerances are derived from both.
    eps = 2.2e-16
    for x0 in (p.delta_int, p.delta_phi):
        h = 1e-6 * x0
        c0 = p.cap(sign * x0)
        lo, hi = p.cap(sign * (x0 - h)), p.cap(sign * (x0 + h))
        # value: continuous up to the slope times the step
        slope_bound = p.gain  # |cap'| <= K everywhere (the parabola lies below its tangent)
        assert abs(hi - lo) <= 2.5 * slope_bound * h + 8 * eps * abs(c0)
    x0 = p.delta_int
    h = 1e-6 * x0
    curv = (
        p.max_acceleration**2 / (p.max_acceleration / p.gain) ** 3
    )  # |cap''| near δ_int: a²/(2a(δ-δf))^{3/2}
    tol = curv * h + 8 * eps * abs(p.cap(x0)) / h
    d_lo = (p.cap(x0) - p.cap(x0 - h)) / h
    d_hi = (p.cap(x0 + h) - p.cap(x0)) / h
    assert d_lo == pytest.approx(p.gain, abs=tol + 1e-9 * p.gain)
    assert d_hi == pytest.approx(p.gain, abs=tol + 1e-9 * p.gain)
    assert abs(d_hi - d_lo) <= 2 * tol + 1e-9 * p.gain


@settings(max_examples=200)
@given(p=profiles, t=st.floats(0.0, 3.0))
def test_three_zone_cap_never_exceeds_k_delta_nor_v_max(p, t):
    # cap(δ) <= K·δ is what makes the law discrete-time safe for K·Te < 1.
    d = t * p.delta_phi
    c = p.cap(d)
    assert 0.0 <= c <= p.gain * d * (1 + 1e-12) + 1e-300
    assert c <= p.max_speed * (1 + 1e-12)
    assert p.cap(-d) == -c
