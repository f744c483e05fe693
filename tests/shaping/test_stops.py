import math

import numpy as np
import pytest

import velfence as vf
from strategies import inward_normals
from velfence.geometry.polygon import polygon_from_halfplanes
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking
from velfence.shaping.rate import RateLimiter
from velfence.shaping.stops import StopLimiter

R2, R3, R6 = math.sqrt(2), math.sqrt(3), math.sqrt(6)
Q = np.array([[2 / R6, -1 / R6, -1 / R6], [0, 1 / R2, -1 / R2], [1 / R3, 1 / R3, 1 / R3]])
STOPS = np.array([[0.624, 1, 0.353], [-1.72, 1, 3.05], [-0.528, -1, 0.346], [1.72, -1, 1.54]])


def paper_profile():
    return ThreeZoneBraking.from_actuator_limits(gain=100, max_speed=2, max_acceleration=20)


# ---------------------------------------------------------------- half-planes -> polygon


def test_polygon_from_halfplanes_matches_the_notes_vertices_and_distances():
    poly, order = polygon_from_halfplanes(STOPS[:, :2], STOPS[:, 2])
    assert order.tolist() == [0, 1, 2, 3]
    expected = [(-0.80759, 0.15094), (1.15060, -1.07097), (1.51068, -0.45164), (-0.53114, 0.62644)]
    np.testing.assert_allclose(poly.corners, expected, atol=1e-5)
    home = poly.signed_distances([0.0, 0.0])
    np.testing.assert_allclose(home, STOPS[:, 2] / np.hypot(STOPS[:, 0], STOPS[:, 1]), rtol=1e-12)


def test_polygon_from_halfplanes_any_order_and_mapping():
    perm = [2, 0, 3, 1]
    poly, order = polygon_from_halfplanes(STOPS[perm, :2], STOPS[perm, 2])
    P = np.random.default_rng(0).uniform(-1, 1, (50, 2))
    d_poly = poly.signed_distances(P)
    S = STOPS[perm]
    d_direct = (P @ S[:, :2].T + S[:, 2]) / np.hypot(S[:, 0], S[:, 1])
    np.testing.assert_allclose(d_poly, d_direct[:, order], atol=1e-12)


def test_polygon_from_halfplanes_rejects_unbounded_and_redundant():
    with pytest.raises(vf.InvalidGeometry, match="do not bound"):
        polygon_from_halfplanes([[1, 0], [0, 1], [1, 1]], [1, 1, 1])
    with pytest.raises(vf.InvalidGeometry, match=r"half-plane\(s\) \[4\] contribute no edge"):
        polygon_from_halfplanes([[1, 0], [0, 1], [-1, 0], [0, -1], [1, 1]], [1, 1, 1, 1, 10])
    with pytest.raises(vf.InvalidGeometry, match="zero normal"):
        polygon_from_halfplanes([[1, 0], [0, 0], [-1, 0], [0, -1]], [1, 1, 1, 1])


# ---------------------------------------------------------------- profiles


def test_three_zone_constants_are_the_papers():
    p = paper_profile()
    assert p.delta_f == pytest.approx(0.00141421, abs=1e-8)
    assert p.delta_int == pytest.approx(0.00282843, abs=1e-8)
    assert p.delta_phi == pytest.approx(0.14283557, abs=1e-8)
    assert p.max_speed == pytest.approx(2.82842712, abs=1e-8)
    assert p.max_acceleration == pytest.approx(28.28427125, abs=1e-7)


def test_three_zone_is_c0_at_both_joins_and_c1_at_delta_int():
    p = paper_profile()
    h = 1e-9
    for d in (p.delta_int, p.delta_phi):
        assert p.cap(d - h) == pytest.approx(p.cap(d + h), abs=1e-6)
    slope_lo = (p.cap(p.delta_int) - p.cap(p.delta_int - 1e-7)) / 1e-7
    slope_hi = (p.cap(p.delta_int + 1e-7) - p.cap(p.delta_int)) / 1e-7
    assert slope_lo == pytest.approx(p.gain, rel=1e-3)
    assert slope_hi == pytest.approx(p.gain, rel=1e-3)
    assert [p.zone(x) for x in (0.2, 0.1, 0.001, -0.001, -0.1, -0.2)] == [3, 2, 1, 1, 2, 3]


def test_three_zone_outside_forces_return_with_the_signed_profile():
    p = paper_profile()
    assert p.cap(-0.2) == -p.max_speed
    assert p.cap(-0.001) == pytest.approx(-0.1)
    assert p.cap(-0.05) == pytest.approx(-math.sqrt(2 * p.max_acceleration * (0.05 - p.delta_f)))


def test_riding_the_braking_curve_decelerates_at_a_max():
    p = paper_profile()
    d, v, dt = 0.1, p.cap(0.1), 1e-6
    v2 = p.cap(d - v * dt)
    assert (v - v2) / dt == pytest.approx(p.max_acceleration, rel=1e-4)


def test_check_period_guards_k_dt():
    p = paper_profile()
    p.check_period(1e-3)
    with pytest.raises(vf.InvalidParameter, match="K·dt"):
        p.check_period(0.02)


def test_linear_buffer_profile_matches_the_patent_scaling():
    lb = LinearBuffer(buffer=0.2, spring_gain=4.0)
    assert lb.cap(0.05, speed=2.0) == pytest.approx(0.5)
    assert lb.cap(0.3, speed=2.0) == math.inf
    assert lb.cap(-0.1) == pytest.approx(-0.4)
    assert lb.cap(-1.0) == pytest.approx(-0.8)  # capped at k·d_max by default
    assert [lb.zone(x) for x in (0.3, 0.1, -0.1)] == [0, 1, 2]


# ---------------------------------------------------------------- rate limiter


def test_rate_limiter_output_mode_ramps_at_a_max():
    r = RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=1e-3)
    out = np.array([r.step([-0.5, 0.5, 0.0]) for _ in range(30)])
    np.testing.assert_allclose(np.diff(out[:25, 1]), 0.02)
    assert out[24, 1] == pytest.approx(0.5)
    assert out[-1].tolist() == pytest.approx([-0.5, 0.5, 0.0])


def test_rate_limiter_literal_mode_cannot_ramp():
    r = RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=1e-3, mode="literal")
    out = [r.step([0.0, 0.5, 0.0])[1] for _ in range(3)]
    assert out == pytest.approx([0.02, 0.5, 0.5])  # one limited sample, then the full step


def test_rate_limiter_clamps_speed_and_validates():
    r = RateLimiter(size=2, max_speed=1.0, max_acceleration=1e6, dt=1e-3)
    assert r.step([5.0, -5.0]).tolist() == [1.0, -1.0]
    with pytest.raises(vf.InvalidInput, match="shape"):
        r.step([1.0])
    with pytest.raises(vf.InvalidInput, match="finite"):
        r.step([math.nan, 0.0])
    with pytest.raises(vf.InvalidParameter, match="max_acceleration"):
        RateLimiter(size=2, max_speed=1.0, max_acceleration=0.0, dt=1e-3)


# ---------------------------------------------------------------- the limiter


def make(method="nearest", tangential="scale_with_normal", pre=True, post=False):
    return StopLimiter(
        STOPS,
        profile=paper_profile(),
        transform=Q,
        method=method,
        tangential=tangential,
        pre=RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=1e-3) if pre else None,
        post=RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=1e-3) if post else None,
    )


def test_frame_matches_the_papers_zeta_formulas():
    a, _b = STOPS[:, 0], STOPS[:, 1]
    zeta = np.array(
        [
            -np.pi / 2 - abs(np.arctan(a[0])),
            -np.pi / 2 + abs(np.arctan(a[1])),
            np.pi / 2 - abs(np.arctan(a[2])),
            np.pi / 2 + abs(np.arctan(a[3])),
        ]
    )
    lim = make(pre=False)
    for k in range(4):
        e_perp = -inward_normals(lim)[k]
        np.testing.assert_allclose(e_perp, [np.cos(zeta[k]), np.sin(zeta[k])], atol=1e-12)


def test_bearing_passes_untouched_and_far_from_stops_nothing_changes():
    lim = make(pre=False)
    home = np.full(3, np.pi / 2)
    v = np.array([0.3, -0.2, 0.5])
    np.testing.assert_allclose(lim.shape(home, v), v, atol=1e-15)
    r = lim.explain(home + 0.3 * Q[1], np.array([0.0, 1.0, -1.0]))
    assert r.q_dot_lim[2] == pytest.approx(r.q_dot[2])


def run_paper(lim, seconds=4.5, dt=1e-3):
    th = np.full(3, np.pi / 2)
    rows = []
    for k in range(round(seconds / dt)):
        t = k * dt
        c1 = -0.5 if 0 < t <= 2.5 else (0.5 if t > 2.5 else 0.0)
        r = lim.explain(th, np.array([c1, -c1, 0.5 if t > 3 else 0.0]))
        rows.append((t, r))
        th = th + dt * r.output
    return rows


def test_paper_scenario_phase_one_event_times():
    rows = run_paper(make(), seconds=1.3)
    t2 = next(t for t, r in rows if r.stop == 3 and r.profile_zone == 2)
    t_lim = next(t for t, r in rows if r.v_perp_lim < r.v_perp - 1e-12)
    t1 = next(t for t, r in rows if r.stop == 3 and r.profile_zone == 1)
    # Zone names: entering the braking zone the cap is still above the speed (free); in the
    # linear zone stop d4 (index 3) caps the command (buffer, the stop active, the cap applied).
    r2 = next(r for t, r in rows if t == t2)
    r1 = next(r for t, r in rows if t == t1)
    assert (r2.zone, r2.active) == ("free", ())
    assert (r1.zone, r1.active) == ("buffer", (3,))
    assert "stop-cap" in r1.stages
    t_stop = next(t for t, r in rows if t > 1.0 and np.hypot(*r.q_dot_lim[:2]) < 1e-2)
    assert t2 == pytest.approx(0.9, abs=0.02)
    assert t_lim == pytest.approx(1.09, abs=0.02)
    assert t1 == pytest.approx(1.1, abs=0.02)
    assert t_stop == pytest.approx(1.15, abs=0.02)


def test_paper_scenario_never_crosses_and_ends_with_pure_bearing():
    rows = run_paper(make())
    assert min(r.deltas.min() for _, r in rows) >= -1e-9
    last = rows[-1][1]
    np.testing.assert_allclose(last.q_dot_lim[:2], 0.0, atol=1e-9)
    np.testing.assert_allclose(last.output, np.full(3, 0.5 / 3), atol=1e-9)
    # the faithful tangential scaling exceeds the joints' acceleration limit (derivations §4: 51.5)
    outs = np.array([r.output for _, r in rows])
    assert np.abs(np.diff(outs, axis=0)).max() / 1e-3 == pytest.approx(51.5, abs=0.5)


def _post_run(lim):
    rows = run_paper(lim)
    outs = np.array([r.output for _, r in rows])
    acc = np.abs(np.diff(outs, axis=0)).max(axis=1) / 1e-3
    flags = np.array([r.rate_override for _, r in rows])
    return rows, outs, acc, flags


@pytest.mark.parametrize("method", ["exact", "nearest"])
def test_post_stage_never_crosses_and_flags_every_cycle_the_acceleration_limit_gives_way(method):
    # The paper's profile brakes at √2·20 rad/s² along the stop normal; toward d4 the joints'
    # box delivers 28.33 rad/s², and the discrete ride down the parabola needs a few % more:
    # position wins on a few cycles, each flagged.
    lim = make(method=method, tangential="preserve", post=True)
    rows, outs, acc, flags = _post_run(lim)
    assert min(r.deltas.min() for _, r in rows) >= -1e-12
    over = acc > 20.0 + 1e-9
    assert over.any()
    assert np.array_equal(flags[1:], over)  # flagged exactly when the limit gave way
    assert not flags[0]
    assert lim.rate_overrides == int(flags.sum()) == 14
    assert acc.max() < 20.0 * 1.05  # gave way by less than the discrete-ride factor 1 + K·Te/2
    assert np.abs(outs).max() <= 2.0 + 1e-12
    lim.reset()
    assert lim.rate_overrides == 0


def test_faithful_law_with_post_stage_no_longer_crosses():
    # Before the position-first composition, the post-stage delayed the faithful law's braking
    # and the robot crossed d1 by 1.0e-3 rad in the paper's scenario.
    rows, _, _, flags = _post_run(make(post=True))
    assert min(r.deltas.min() for _, r in rows) >= -1e-12
    assert flags.sum() == 14


@pytest.mark.parametrize("method", ["exact", "nearest"])
def test_a_profile_within_the_braking_capacity_never_needs_an_override(method):
    post = RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=1e-3)
    probe = StopLimiter(STOPS, profile=paper_profile(), transform=Q, post=post)
    assert probe.braking_capacity == pytest.approx(28.3336, abs=1e-4)
    assert make().braking_capacity is None
    prof = ThreeZoneBraking(
        gain=100.0, max_speed=2 * R2, max_acceleration=probe.braking_capacity / (1 + 100 * 1e-3 / 2)
    )
    lim = StopLimiter(
        STOPS,
        profile=prof,
        transform=Q,
        method=method,
        tangential="preserve",
        pre=RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=1e-3),
        post=RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=1e-3),
    )
    rows, _, acc, flags = _post_run(lim)
    assert not flags.any()
    assert lim.rate_overrides == 0
    assert acc.max() <= 20.0 + 1e-9
    assert min(r.deltas.min() for _, r in rows) >= -1e-12


def test_exact_respects_every_stop_at_a_vertex():
    lim = make(method="exact", pre=False)
    poly = lim.polygon
    rng = np.random.default_rng(3)
    for _ in range(300):
        v12 = poly.corners[rng.integers(4)] + rng.uniform(-0.05, 0.05, 2)
        q = np.array([v12[0], v12[1], rng.uniform(-1, 1)])
        th = Q.T @ q
        w = rng.normal(size=3)
        r = lim.explain(th, w)
        speed = float(np.hypot(*r.q_dot[:2]))
        for k, d in enumerate(r.deltas):
            cap = lim.profile.cap(float(d), speed)
            assert inward_normals(lim)[k] @ r.q_dot_lim[:2] >= -cap - 1e-9


def test_stateless_batch_equals_loop_and_stateful_batch_is_refused():
    lim = make(pre=False)
    rng = np.random.default_rng(1)
    X = np.pi / 2 + rng.uniform(-0.6, 0.6, (20, 3))
    V = rng.normal(size=(20, 3))
    np.testing.assert_array_equal(
        lim.shape_batch(X, V), [lim.shape(x, v) for x, v in zip(X, V, strict=False)]
    )
    with pytest.raises(vf.InvalidParameter, match="stateless"):
        make(pre=True).shape_batch(X, V)


def test_limiter_validates_inputs():
    with pytest.raises(vf.InvalidParameter, match="orthonormal"):
        StopLimiter(STOPS, profile=paper_profile(), transform=np.ones((3, 3)))
    with pytest.raises(vf.InvalidParameter, match="ApproachProfile"):
        StopLimiter(STOPS, profile=object(), transform=Q)
    with pytest.raises(vf.InvalidParameter, match="method"):
        StopLimiter(STOPS, profile=paper_profile(), transform=Q, method="magic")
    lim = make(pre=False)
    with pytest.raises(vf.InvalidInput, match="finite"):
        lim.shape(np.full(3, np.nan), np.zeros(3))
    with pytest.raises(vf.InvalidInput, match="shape"):
        lim.shape(np.zeros(2), np.zeros(3))


# ---------------------------------------------------------------- profiles in the polygon shaper


def test_polygon_shaper_with_linear_buffer_profile_equals_the_builtin_exact_law_inside():
    poly = vf.ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])
    builtin = vf.PolygonShaper(poly, buffer=0.2, spring_gain=4.0, method="exact")
    with_profile = vf.PolygonShaper(poly, profile=LinearBuffer(buffer=0.2, spring_gain=4.0))
    rng = np.random.default_rng(5)
    P = rng.uniform(-0.5, 2.5, (400, 2))
    P = P[poly.contains(P)]
    V = rng.normal(size=P.shape)
    np.testing.assert_allclose(
        with_profile.shape_batch(P, V), builtin.shape_batch(P, V), atol=1e-12
    )


def test_polygon_shaper_with_three_zone_profile_respects_every_cap():
    poly = vf.ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])
    prof = ThreeZoneBraking(gain=50.0, max_speed=1.0, max_acceleration=5.0)
    s = vf.PolygonShaper(poly, method="exact", profile=prof)
    rng = np.random.default_rng(6)
    relaxed = 0
    for _ in range(300):
        p = rng.uniform(-0.3, 2.6, 2)
        v = rng.normal(size=2) * 2
        r = s.explain(p, v)
        d = poly.signed_distances(p)
        slack = poly.normals @ r.output + np.array([prof.cap(float(x)) for x in d])
        # every cap of an edge the point is inside always holds
        assert np.all(slack[d >= 0] >= -1e-9)
        if "relaxed" in r.stages:
            # outside a corner the zone-3 return (max_speed along two normals) can need more than
            # max_speed, which the other edges' caps forbid: the return is slowed (never away
            # from the violated edges), and the result says so
            relaxed += 1
            assert d.min() < 0
            assert np.all(poly.normals[d < 0] @ r.output >= -1e-12)
        else:
            assert np.all(slack >= -1e-9)
    assert 0 < relaxed < 300
    r = s.explain(np.array([1.0, 1.0]), np.array([0.3, 0.0]))
    assert r.zone == "free"
    np.testing.assert_array_equal(r.output, [0.3, 0.0])


def test_polygon_shaper_profile_arguments_are_checked():
    poly = vf.ConvexPolygon([[0, 0], [1, 0], [0, 1]])
    with pytest.raises(vf.InvalidParameter, match="profile replaces the linear buffer"):
        vf.PolygonShaper(poly, buffer=0.1, profile=LinearBuffer(buffer=0.1))
    with pytest.raises(vf.InvalidParameter, match="profile replaces the linear buffer"):
        vf.PolygonShaper(poly, method="patent", profile=LinearBuffer(buffer=0.1))
    with pytest.raises(vf.InvalidParameter, match="buffer must be given"):
        vf.PolygonShaper(poly)


def test_eq5_ratio_is_clamped_by_default_and_unbounded_as_printed():
    base = make(pre=False)
    e = 0  # stop d1
    n = inward_normals(base)[e]
    q12 = 0.5 * (base.polygon.corners[0] + base.polygon.corners[1]) - 0.01 * n  # just outside
    th = Q.T @ np.array([q12[0], q12[1], 0.0])
    e_perp = -n
    e_par = np.array([-e_perp[1], e_perp[0]])
    w = 1.0 * e_par + 1e-12 * e_perp  # tangential, a hair outward
    thd = Q.T @ np.array([w[0], w[1], 0.0])
    assert np.abs(base.shape(th, thd)).max() < 2.0
    printed = StopLimiter(STOPS, profile=paper_profile(), transform=Q, clamp_ratio=False)
    assert np.abs(printed.shape(th, thd)).max() > 1e9


def test_stop_limiter_fail_safe_policy():
    lim = StopLimiter(STOPS, profile=paper_profile(), transform=Q, on_invalid="stop")
    np.testing.assert_array_equal(lim.shape(np.full(3, np.nan), np.zeros(3)), np.zeros(3))
    r = lim.explain(np.zeros(3), np.full(3, np.inf))
    np.testing.assert_array_equal(r.output, np.zeros(3))
    with pytest.raises(vf.InvalidParameter, match="K·dt"):
        StopLimiter(
            STOPS,
            profile=paper_profile(),
            transform=Q,
            pre=RateLimiter(size=3, max_speed=2, max_acceleration=20, dt=0.02),
        )
