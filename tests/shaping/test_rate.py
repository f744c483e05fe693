"""RateLimiter: keyword-only size, validated limits and commands, the box and hold()."""

from __future__ import annotations

import numpy as np
import pytest

import velfence as vf


def test_size_is_keyword_only_and_validated():
    with pytest.raises(TypeError):
        vf.RateLimiter(3, max_speed=1, max_acceleration=1, dt=1e-3)  # type: ignore[misc]
    for bad, match in (
        (0, "size: expected an int >= 1"),
        (True, "size"),
        ("3", "size"),
        (10**9, "size: expected an int <= 100,000"),
    ):
        with pytest.raises(vf.InvalidParameter, match=match):
            vf.RateLimiter(size=bad, max_speed=1, max_acceleration=1, dt=1e-3)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"max_speed": "2"}, "max_speed: expected limits"),
        ({"max_speed": [1, 2]}, r"max_speed: expected a scalar or shape \(3,\)"),
        ({"max_acceleration": np.nan}, "max_acceleration: expected finite values"),
        ({"max_acceleration": [1, 0, 1]}, "max_acceleration must be finite and > 0"),
        ({"dt": "1e-3"}, "dt must be a number"),
        ({"dt": 0.0}, "dt must be finite and > 0"),
        ({"mode": "fast"}, "mode must be one of"),
    ],
)
def test_limits_are_validated(kwargs, match):
    base = {"size": 3, "max_speed": 2.0, "max_acceleration": 20.0, "dt": 1e-3}
    base.update(kwargs)
    with pytest.raises(vf.InvalidParameter, match=match):
        vf.RateLimiter(**base)


def test_commands_must_be_real_numbers():
    r = vf.RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=1e-3)
    for bad in ("abc", [True, False, True], [1j, 0, 0], {"a": 1}):
        with pytest.raises(vf.InvalidInput, match="command"):
            r.step(bad)
    with pytest.raises(vf.InvalidInput, match="value"):
        r.reset([np.nan, 0.0, 0.0])


def test_bounds_contain_the_next_output_and_hold_sets_the_state():
    r = vf.RateLimiter(size=2, max_speed=1.0, max_acceleration=10.0, dt=0.1)
    lo, hi = r.bounds()
    np.testing.assert_allclose(lo, [-1.0, -1.0])
    np.testing.assert_allclose(hi, [1.0, 1.0])
    out = r.step([5.0, -0.3])
    assert np.all(out >= lo)
    assert np.all(out <= hi)
    r.hold(np.array([1.8, 0.0]))  # an override beyond max_speed
    lo, hi = r.bounds()
    np.testing.assert_allclose(lo, [0.8, -1.0])  # the reachable end, not an empty box
    np.testing.assert_allclose(hi, [1.0, 1.0])
    lit = vf.RateLimiter(size=1, max_speed=1.0, max_acceleration=1.0, dt=0.1, mode="literal")
    lit.step([0.5])
    lit.hold(np.array([0.0]))  # literal mode remembers commands, not outputs
    np.testing.assert_allclose(lit.state, [0.5])
