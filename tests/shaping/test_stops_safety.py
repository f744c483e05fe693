"""Joint stops crossed with a post-stage rate limiter, discrete time, and the invalid marker.

The closed-loop property: over random stop polygons, auxiliary transforms, start points, speeds
and directions, ``StopLimiter(method="exact", post=RateLimiter(...))`` integrated at its own
period never leaves the polygon beyond round-off, and every cycle in which the output leaves the
rate limiter's box is flagged (and counted).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import velfence as vf
from strategies import convex_corners, inward_normals
from velfence.mechanisms import PAPER_STOPS, Q_AUX
from velfence.shaping.stops import StopLimiter

DT = 1e-3


def paper_profile():
    return vf.ThreeZoneBraking.from_actuator_limits(gain=100, max_speed=2, max_acceleration=20)


def joints(dt=DT, max_speed=2.0, max_acceleration=20.0):
    return vf.RateLimiter(size=3, max_speed=max_speed, max_acceleration=max_acceleration, dt=dt)


def stops_of(poly):
    """Half-plane rows (a, b, c) of a polygon: n·q - o >= 0."""
    return np.column_stack([poly.normals, -poly.offsets])


def push(lim, theta, command, steps, dt=DT):
    """Integrate the limiter's output; per step: min signed distance, output, flag, box."""
    lim.reset()
    rows = []
    prev = np.zeros(lim.size)
    for _ in range(steps):
        lo, hi = lim.post.bounds() if lim.post is not None else (None, None)
        r = lim.explain(theta, command)
        theta = theta + dt * r.output
        q = lim.transform @ theta
        i, j = lim.limited
        d = float(lim.polygon.signed_distances(np.array([q[i], q[j]])).min())
        rows.append((d, r.output, r.rate_override, lo, hi, prev))
        prev = r.output
    return rows


def start_theta(poly, Q, frac, corner, q3=0.0):
    c = poly.centroid + frac * (poly.corners[corner] - poly.centroid)
    return Q.T @ np.array([c[0], c[1], q3])


def random_rotation(seed):
    A = np.random.default_rng(seed).normal(size=(3, 3))
    Q, R = np.linalg.qr(A)
    return Q * np.sign(np.diag(R))


# ---------------------------------------------------------------- the reproducer, before → after


@pytest.mark.parametrize(("speed", "before"), [(1.0, -3.65e-4), (2.0, -3.12e-3)])
def test_pushing_into_d1_with_a_post_stage_no_longer_crosses(speed, before):
    # Before the position-first composition this ended at min δ = `before` (3000 steps).
    lim = StopLimiter(
        PAPER_STOPS, profile=paper_profile(), transform=Q_AUX, method="exact", post=joints()
    )
    n0 = inward_normals(lim)[0]
    c = lim.polygon.centroid
    theta = Q_AUX.T @ np.array([c[0], c[1], 0.0])
    command = Q_AUX.T @ np.array([-speed * n0[0], -speed * n0[1], 0.0])
    rows = push(lim, theta, command, 3000)
    assert min(d for d, *_ in rows) >= -1e-12 > before
    assert lim.rate_overrides == 0  # the box could always brake in time toward d1
    np.testing.assert_allclose(rows[-1][1] @ Q_AUX[:2].T @ -n0, 0.0, atol=1e-9)


@settings(max_examples=40)
@given(
    corners=convex_corners(max_n=6),
    rot=st.integers(0, 2**31 - 1),
    frac=st.floats(0.0, 0.8),
    corner=st.integers(0, 5),
    angle=st.floats(0.0, 2 * math.pi),
    speed=st.floats(0.05, 3.0),
    bearing=st.floats(-1.0, 1.0),
    gain=st.floats(20.0, 900.0),
    accel=st.floats(2.0, 39.0),  # < gain·max_speed = 40 rad/s² (ThreeZoneBraking requires it)
)
def test_closed_loop_with_post_stage_never_crosses_and_flags_every_override(
    corners, rot, frac, corner, angle, speed, bearing, gain, accel
):
    poly = vf.ConvexPolygon(corners)
    Q = random_rotation(rot)
    prof = vf.ThreeZoneBraking(gain=gain, max_speed=2.0, max_acceleration=accel)
    lim = StopLimiter(stops_of(poly), profile=prof, transform=Q, method="exact", post=joints())
    theta = start_theta(poly, Q, frac, corner % len(corners))
    w = speed * np.array([math.cos(angle), math.sin(angle)])
    command = Q.T @ np.array([w[0], w[1], bearing])
    rows = push(lim, theta, command, 700)
    assert min(d for d, *_ in rows) >= -1e-12
    step = 20.0 * DT
    flagged = 0
    for _, out, flag, lo, hi, _ in rows:
        outside = bool(
            np.any(out < lo - 1e-9 * step - 1e-12) or np.any(out > hi + 1e-9 * step + 1e-12)
        )
        assert flag == outside
        flagged += flag
    assert lim.rate_overrides == flagged


def test_an_unavoidable_override_is_flagged_and_position_still_wins():
    # Moving at 1.9 rad/s per joint straight at a stop 5 mrad away: no 20 rad/s² braking can stop
    # in time, so the acceleration limit must give way.
    prof = paper_profile()
    lim = StopLimiter(PAPER_STOPS, profile=prof, transform=Q_AUX, method="exact", post=joints())
    n0 = inward_normals(lim)[0]
    mid = 0.5 * (lim.polygon.corners[0] + lim.polygon.corners[1]) + 0.005 * n0
    theta = Q_AUX.T @ np.array([mid[0], mid[1], 0.0])
    v = Q_AUX.T @ np.array([-2.0 * n0[0], -2.0 * n0[1], 0.0])
    lim.reset()
    lim.post.reset(np.clip(v, -2, 2))
    r = lim.explain(theta, v)
    assert r.rate_override
    assert lim.rate_overrides == 1
    assert not np.allclose(r.output, r.rate_limited)
    # the stop bound holds on the output: approach speed within the profile's cap
    assert -n0 @ (Q_AUX[:2] @ r.output) <= prof.cap(r.delta) + 1e-12
    lim.reset()
    assert lim.rate_overrides == 0


def test_without_post_stage_rate_limited_is_the_output_and_no_flag():
    lim = StopLimiter(PAPER_STOPS, profile=paper_profile(), transform=Q_AUX, method="exact")
    r = lim.explain(np.full(3, np.pi / 2), np.array([0.3, -0.2, 0.1]))
    np.testing.assert_array_equal(r.rate_limited, r.output)
    assert not r.rate_override
    assert not r.invalid


def test_rate_limiter_docstring_says_it_does_not_keep_stops_alone():
    assert "does not guarantee joint stops" in vf.RateLimiter.__doc__


# ---------------------------------------------------------------- discrete time


def test_dt_caps_each_period_to_the_remaining_distance():
    # A linear buffer caps the approach at speed·δ/buffer = 2 rad/s here: over a 20 ms period
    # that covers 0.04 rad, more than the 0.02 rad left. With dt the cap is δ/dt = 1 rad/s.
    stops = [[1.0, 0.0, 1.0], [-1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [0.0, -1.0, 1.0]]
    prof = vf.LinearBuffer(buffer=0.05)
    plain = StopLimiter(stops, profile=prof)
    safe = StopLimiter(stops, profile=prof, dt=0.02)
    q = np.array([-0.98, 0.0])
    v = np.array([-5.0, 0.0])
    assert q[0] + 0.02 * plain.shape(q, v)[0] < -1.0  # the continuous-time law overshoots
    out = safe.shape(q, v)
    assert out[0] == pytest.approx(-1.0)
    assert q[0] + 0.02 * out[0] >= -1.0 - 1e-15
    np.testing.assert_array_equal(safe.shape(q, -v), plain.shape(q, -v))  # moving away: no cap


@pytest.mark.slow
@settings(max_examples=60)
@given(
    corners=convex_corners(max_n=6),
    buffer=st.floats(0.001, 0.3),
    dt=st.floats(1e-3, 0.05),
    angle=st.floats(0.0, 2 * math.pi),
    speed=st.floats(0.1, 20.0),
    method=st.sampled_from(["exact", "nearest"]),
)
# An isosceles triangle whose centroid is equidistant from stops 0 and 2 (a tie for the nearest
# stop): the limiter guards stop 2 and the command heads into stop 0, which it may not guard.
@example(
    corners=[
        [2.464446697170099, 1.0],
        [0.26777665141495066, 1.3170620105593807],
        [0.26777665141494966, 0.6829379894406193],
    ],
    buffer=0.25,
    dt=0.03125,
    angle=1.0,
    speed=8.0,
    method="nearest",
)
def test_dt_keeps_any_profile_inside_in_discrete_time(corners, buffer, dt, angle, speed, method):
    poly = vf.ConvexPolygon(corners)
    lim = StopLimiter(stops_of(poly), profile=vf.LinearBuffer(buffer=buffer), dt=dt, method=method)
    q = poly.centroid.copy()
    v = speed * np.array([math.cos(angle), math.sin(angle)])
    for _ in range(200):
        out = lim.shape(q, v)
        r = lim.explain(q, v)
        np.testing.assert_array_equal(r.output, out)
        before = poly.signed_distances(q)
        q = q + dt * out
        after = poly.signed_distances(q)
        # the exact law guards every stop (never outside), the nearest law the nearest one (it
        # may cross another stop at a vertex: the paper's open problem, not a period effect). On a
        # tie several stops are nearest and the law guards the one it reports.
        if method == "exact":
            assert after.min() >= -1e-12
        else:
            k = r.stop
            assert abs(before[k] - before.min()) <= 1e-12  # the guarded stop is a nearest one
            if before[k] >= 0.0:
                assert after[k] >= -1e-12


def test_dt_is_validated_and_must_match_the_stages():
    with pytest.raises(vf.InvalidParameter, match="dt"):
        StopLimiter(PAPER_STOPS, profile=paper_profile(), transform=Q_AUX, dt=0.0)
    with pytest.raises(vf.InvalidParameter, match="dt"):
        StopLimiter(PAPER_STOPS, profile=paper_profile(), transform=Q_AUX, dt="0.001")
    with pytest.raises(vf.InvalidParameter, match=r"dt=0.002 s differs from post.dt=0.001 s"):
        StopLimiter(PAPER_STOPS, profile=paper_profile(), transform=Q_AUX, dt=2e-3, post=joints())
    with pytest.raises(vf.InvalidParameter, match="K·dt"):
        StopLimiter(PAPER_STOPS, profile=paper_profile(), transform=Q_AUX, dt=0.02)
    lim = StopLimiter(PAPER_STOPS, profile=paper_profile(), transform=Q_AUX, dt=DT, post=joints())
    assert lim.dt == DT


# ---------------------------------------------------------------- on_invalid="stop"


@pytest.mark.parametrize("post", [False, True])
def test_invalid_input_under_stop_reports_an_explicit_marker(post):
    lim = StopLimiter(
        PAPER_STOPS,
        profile=paper_profile(),
        transform=Q_AUX,
        on_invalid="stop",
        post=joints() if post else None,
    )
    for theta, theta_dot in (
        (np.full(3, np.nan), np.zeros(3)),
        (np.zeros(3), np.array([0.0, np.inf, 0.0])),
    ):
        r = lim.explain(theta, theta_dot)
        assert r.invalid
        assert r.zone == "invalid"
        assert r.stop == -1
        assert math.isnan(r.delta)
        np.testing.assert_array_equal(r.output, np.zeros(3))
        np.testing.assert_array_equal(lim.shape(theta, theta_dot), np.zeros(3))
    good = lim.explain(np.full(3, np.pi / 2), np.zeros(3))
    assert not good.invalid
    assert good.profile_zone in (1, 2, 3)
    assert good.zone == "free"  # a zero command: no cap is below its speed


def test_invalid_rows_of_a_batch_are_zero_under_stop():
    lim = StopLimiter(PAPER_STOPS, profile=paper_profile(), transform=Q_AUX, on_invalid="stop")
    X = np.full((3, 3), np.pi / 2)
    V = np.array([[0.1, 0.0, 0.0], [np.nan, 0.0, 0.0], [0.0, 0.2, 0.0]])
    out = lim.shape_batch(X, V)
    np.testing.assert_array_equal(out[1], 0.0)
    np.testing.assert_array_equal(out[0], lim.shape(X[0], V[0]))


# ---------------------------------------------------------------- inputs


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"stops": "abc"}, vf.InvalidGeometry, r"stops: expected half-plane rows"),
        ({"stops": [0.624, 1.0, 0.353]}, vf.InvalidGeometry, r"stops: expected shape \(N, 3\)"),
        ({"stops": [[0.624, 1.0, 0.353]]}, vf.InvalidGeometry, "stops: expected at least 3 rows"),
        ({"stops": [[1, 0, 1], [0, 1, 1], [1, 1, 1]]}, vf.InvalidGeometry, "stops: .*bound"),
        ({"transform": 1.0}, vf.InvalidParameter, r"transform: expected shape \(N, N\)"),
        ({"transform": [["a", "b"], ["c", "d"]]}, vf.InvalidParameter, "transform"),
        ({"transform": np.ones((2, 3))}, vf.InvalidParameter, "transform: expected a square"),
        ({"limited": (0,)}, vf.InvalidParameter, "limited: expected two distinct"),
        ({"limited": b"\x00\x01"}, vf.InvalidParameter, "limited: expected two distinct"),
        ({"limited": "01"}, vf.InvalidParameter, "limited"),
        ({"limited": (0, 0)}, vf.InvalidParameter, "limited: expected two distinct"),
        ({"limited": (0, 5)}, vf.InvalidParameter, "limited: expected an int <= 2"),
        ({"limited": (True, 1)}, vf.InvalidParameter, "limited"),
        ({"limited": (0.0, 1)}, vf.InvalidParameter, "limited"),
        ({"clamp_ratio": "no"}, vf.InvalidParameter, "clamp_ratio: expected True or False"),
        ({"clamp_ratio": 0}, vf.InvalidParameter, "clamp_ratio"),
        ({"post": "x"}, vf.InvalidParameter, "post must be a RateLimiter of size 3"),
        (
            {"post": vf.RateLimiter(size=2, max_speed=1, max_acceleration=1, dt=DT)},
            vf.InvalidParameter,
            "post must be a RateLimiter of size 3",
        ),
    ],
)
def test_constructor_refusals_name_the_argument(kwargs, error, match):
    base = {"stops": PAPER_STOPS, "profile": paper_profile(), "transform": Q_AUX}
    base.update(kwargs)
    stops = base.pop("stops")
    with pytest.raises(error, match=match):
        StopLimiter(stops, **base)


def test_transform_and_limited_accept_arrays():
    lim = StopLimiter(
        PAPER_STOPS, profile=paper_profile(), transform=Q_AUX.tolist(), limited=np.array([0, 1])
    )
    assert lim.limited == (0, 1)


BAD_VECTORS = [
    ("abc", "got str"),
    (b"\x00\x01\x02", "got bytes"),
    ({"a": 1}, "got dict"),
    ([1j, 0, 0], "complex"),
    ([True, False, True], "booleans"),
    (True, "got bool"),
    (None, "got NoneType"),
    (["1", "2", "3"], "strings"),
]


@pytest.mark.parametrize(("bad", "what"), BAD_VECTORS)
def test_joint_vectors_must_be_real_numbers(bad, what):
    lim = StopLimiter(PAPER_STOPS, profile=paper_profile(), transform=Q_AUX, on_invalid="stop")
    good = np.full(3, np.pi / 2)
    with pytest.raises(vf.InvalidInput, match=f"position: .*{what}"):
        lim.shape(bad, np.zeros(3))
    with pytest.raises(vf.InvalidInput, match=f"command: .*{what}"):
        lim.explain(good, bad)
    with pytest.raises(vf.InvalidInput, match="positions"):
        lim.shape_batch([bad], np.zeros((1, 3)))


def test_joint_vectors_of_the_wrong_length_are_refused():
    lim = StopLimiter(PAPER_STOPS, profile=paper_profile(), transform=Q_AUX)
    with pytest.raises(vf.InvalidInput, match=r"position: expected shape \(3,\), got shape \(2,\)"):
        lim.shape([0.0, 0.0], np.zeros(3))
    with pytest.raises(vf.InvalidInput, match=r"command: expected shape \(3,\)"):
        lim.explain(np.zeros(3), np.zeros(4))
    with pytest.raises(vf.InvalidInput, match=r"commands must have shape \(N, 3\)"):
        lim.shape_batch(np.zeros((2, 3)), np.zeros((2, 2)))
    # lists and integer arrays are real numbers
    np.testing.assert_array_equal(
        lim.shape([1, 1, 1], [0, 0, 0]), lim.shape(np.ones(3), np.zeros(3))
    )
