"""Speed and separation monitoring (``velfence.filter.separation``): S_p, its inverse, the rows.

The worked examples are written out from the structure of ISO/TS 15066:2016 5.5.4 by hand (the
arithmetic in the comments); the inverse is cross-checked against NumPy's polynomial roots and
SciPy's brentq on ``S_p(v) = d``; the rows' normals against finite differences of the public
segment distance; the closed loop measures the separation between the samples (ten sub-steps a
period) with ``velfence.geometry.segment_segment_distance``, not with the rows' own geometry.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest
from scipy.optimize import brentq

from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.filter import (
    LEVEL_OBSTACLE,
    WALKING_SPEED,
    JointLimits,
    PersonCapsule,
    RowContext,
    SafetyFilter,
    SeparationParameters,
    SeparationRows,
    max_approach_speed,
    separation_distance,
)
from velfence.filter.kinematics import frame_of
from velfence.geometry import closest_points_segments, segment_segment_distance
from velfence.mechanisms.chain import DHChain

ARM = DHChain.seven_dof(link_radius=0.04)
LO = np.radians([-170.0, -120.0, -170.0, -120.0, -170.0, -120.0, -175.0])
LIMITS = JointLimits(LO, -LO, max_speed=np.full(7, 1.5))
Q0 = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])

#: Example 1's terms: T_r 0.1 s, T_s 0.3 s, a_s 2 m/s², C 0.1 m, Z_d 0.05 m, Z_r 0.02 m.
P1 = SeparationParameters(
    reaction_time=0.1,
    stopping_time=0.3,
    max_deceleration=2.0,
    intrusion=0.1,
    human_uncertainty=0.05,
    robot_uncertainty=0.02,
)


def _rows(prm: SeparationParameters = P1, people: Any = ()) -> SeparationRows:
    return SeparationRows(
        prm, link_radius=ARM.link_radius, max_speed=LIMITS.max_speed, people=people
    )


# ------------------------------------------------------------------------- worked examples
def test_example_1_walking_person_constant_deceleration() -> None:
    # v_h = 1.6 m/s (the default), v_r = 1.0 m/s:
    # S_h = 1.6 (0.1 + 0.3) = 0.64; S_r = 1.0 * 0.1 = 0.10; S_s = 1.0² / (2 * 2) = 0.25;
    # C + Z_d + Z_r = 0.10 + 0.05 + 0.02 = 0.17; S_p = 0.64 + 0.10 + 0.25 + 0.17 = 1.16 m.
    assert P1.human_speed == WALKING_SPEED == 1.6
    assert separation_distance(1.0, parameters=P1) == pytest.approx(1.16, abs=1e-12)
    # the inverse: v²/4 + 0.1 v = 1.16 - (0.64 + 0.17) = 0.35 -> v² + 0.4 v - 1.4 = 0
    # -> v = (-0.4 + sqrt(0.16 + 5.6)) / 2 = (-0.4 + 2.4) / 2 = 1.0 m/s.
    assert max_approach_speed(1.16, parameters=P1) == pytest.approx(1.0, abs=1e-12)


def test_example_2_reaching_hand_fixed_stopping_distance() -> None:
    # A hand at 2.0 m/s, T_r 0.2 s, T_s 0.5 s, a fixed S_s 0.2 m, C 0.208 m (8 (40 - 14) mm),
    # no uncertainties, v_r = 0.5 m/s:
    # S_h = 2.0 (0.2 + 0.5) = 1.4; S_r = 0.5 * 0.2 = 0.1; S_s = 0.2; C = 0.208;
    # S_p = 1.4 + 0.1 + 0.2 + 0.208 = 1.908 m.
    prm = SeparationParameters(
        reaction_time=0.2, stopping_time=0.5, stopping_distance=0.2, intrusion=0.208
    )
    assert separation_distance(0.5, parameters=prm, human_speed=2.0) == pytest.approx(1.908)
    # the inverse is linear: 0.2 v = 1.908 - (1.4 + 0.2 + 0.208) = 0.1 -> v = 0.5 m/s.
    assert max_approach_speed(1.908, parameters=prm, human_speed=2.0) == pytest.approx(0.5)


def test_example_3_inside_at_rest_and_moving_away() -> None:
    # At rest S_p(0) = S_h + C + Z_d + Z_r = 0.64 + 0.17 = 0.81 m (example 1's terms): closer
    # than that, no approach at all.
    assert separation_distance(0.0, parameters=P1) == pytest.approx(0.81)
    assert max_approach_speed(0.80, parameters=P1) == 0.0
    assert max_approach_speed(-0.3, parameters=P1) == 0.0
    # a robot moving away needs no reaction or stopping distance toward the person.
    assert separation_distance(-2.0, parameters=P1) == pytest.approx(0.81)
    # a person standing still (v_h = 0): S_p(1) = 0.1 + 0.25 + 0.17 = 0.52 m.
    assert separation_distance(1.0, parameters=P1, human_speed=0.0) == pytest.approx(0.52)


def test_example_4_discrete_time() -> None:
    # dt = 0.01 s, d = 1.16 m: T_r + dt = 0.11, d - v_h dt = 1.16 - 0.016 = 1.144;
    # v²/4 + 0.11 v = 1.144 - 0.81 = 0.334 -> v² + 0.44 v - 1.336 = 0
    # -> v = (-0.44 + sqrt(0.1936 + 5.344)) / 2 = (-0.44 + 2.353210...) / 2 = 0.956605...
    v = max_approach_speed(1.16, parameters=P1, dt=0.01)
    assert v == pytest.approx((-0.44 + math.sqrt(5.5376)) / 2.0, rel=1e-12)
    assert v == pytest.approx(0.956605, abs=1e-6)
    # one period of both moving leaves S_p(v): 1.16 - (v + 1.6) 0.01 = S_p(v).
    assert 1.16 - (v + 1.6) * 0.01 == pytest.approx(separation_distance(v, parameters=P1))


# ------------------------------------------------------------------------- independent solves
def _random_parameters(rng: np.random.Generator, fixed: bool) -> SeparationParameters:
    kw: dict[str, float] = {}
    if fixed:
        kw["stopping_distance"] = float(rng.uniform(0.0, 0.5))
    else:
        kw["max_deceleration"] = float(rng.uniform(0.5, 10.0))
    return SeparationParameters(
        reaction_time=float(rng.uniform(0.01, 0.5)),
        stopping_time=float(rng.uniform(0.0, 1.0)),
        human_speed=float(rng.uniform(0.0, 2.5)),
        intrusion=float(rng.uniform(0.0, 0.85)),
        human_uncertainty=float(rng.uniform(0.0, 0.2)),
        robot_uncertainty=float(rng.uniform(0.0, 0.1)),
        **kw,
    )


@pytest.mark.parametrize("fixed", [False, True])
def test_inverse_against_numpy_roots_and_brentq(fixed: bool) -> None:
    rng = np.random.default_rng(30)
    for _ in range(200):
        prm = _random_parameters(rng, fixed)
        d = float(rng.uniform(0.0, 6.0))
        dt = None if rng.uniform() < 0.5 else float(rng.uniform(1e-3, 0.05))
        h = dt or 0.0
        v = max_approach_speed(d, parameters=prm, dt=dt)
        vh = prm.human_speed
        rest = vh * (prm.reaction_time + prm.stopping_time) + prm.intrusion
        rest += prm.human_uncertainty + prm.robot_uncertainty + vh * h
        if fixed:
            rest += prm.stopping_distance or 0.0
            coeffs = [prm.reaction_time + h, -(d - rest)]
        else:
            a = prm.max_deceleration or 1.0
            coeffs = [1.0 / (2.0 * a), prm.reaction_time + h, -(d - rest)]
        if d - rest <= 0.0:
            assert v == 0.0
            continue
        roots = np.roots(coeffs)
        pos = [r.real for r in roots if abs(r.imag) < 1e-12 and r.real >= 0.0]
        assert len(pos) == 1
        assert v == pytest.approx(pos[0], rel=1e-9, abs=1e-12)

        def excess(x: float, prm: SeparationParameters = prm, d: float = d, h: float = h) -> float:
            return separation_distance(x, parameters=prm) + (x + prm.human_speed) * h - d

        assert v == pytest.approx(brentq(excess, 0.0, 1e3, xtol=1e-14), rel=1e-9, abs=1e-12)


def test_inverse_property_round_off() -> None:
    rng = np.random.default_rng(7)
    for _ in range(500):
        prm = _random_parameters(rng, bool(rng.uniform() < 0.3))
        d = float(rng.uniform(0.0, 10.0))
        v = max_approach_speed(d, parameters=prm)
        if v > 0.0:
            assert separation_distance(v, parameters=prm) == pytest.approx(d, rel=1e-12, abs=1e-12)
        else:
            assert separation_distance(0.0, parameters=prm) >= d


# ------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    "kw",
    [
        {"reaction_time": 0.0, "stopping_time": 0.3, "max_deceleration": 2.0},
        {"reaction_time": math.nan, "stopping_time": 0.3, "max_deceleration": 2.0},
        {"reaction_time": 0.1, "stopping_time": -0.1, "max_deceleration": 2.0},
        {"reaction_time": 0.1, "stopping_time": 0.3},
        {"reaction_time": 0.1, "stopping_time": 0.3, "max_deceleration": 2, "stopping_distance": 1},
        {"reaction_time": 0.1, "stopping_time": 0.3, "max_deceleration": math.inf},
        {"reaction_time": 0.1, "stopping_time": 0.3, "max_deceleration": 2.0, "human_speed": -1},
        {"reaction_time": 0.1, "stopping_time": 0.3, "max_deceleration": 2.0, "intrusion": "0.1"},
    ],
)
def test_bad_parameters_refused(kw: dict[str, Any]) -> None:
    with pytest.raises(InvalidParameter):
        SeparationParameters(**kw)


@pytest.mark.parametrize(
    "bad",
    [
        {"a": [math.nan, 0.0, 0.0]},
        {"a": [0.0, 0.0, math.inf]},
        {"a": [0.0, 0.0]},
        {"a": [0.0, 0.0, 0.0], "b": [[0.0, 0.0, 1.0]]},
        {"a": [0.0, 0.0, 0.0], "velocity": [1.0, math.nan, 0.0]},
        {"a": [0.0, 0.0, 0.0], "velocity": [1.0, 0.0]},
        {"a": [0.0, 0.0, 0.0], "radius": -0.1},
        {"a": [0.0, 0.0, 0.0], "radius": math.inf},
    ],
)
def test_bad_people_refused(bad: dict[str, Any]) -> None:
    kw = {"radius": 0.2, **bad}
    with pytest.raises(VelfenceError):
        PersonCapsule(**kw)


def test_update_refuses_what_is_not_people() -> None:
    rows = _rows()
    for bad in (
        np.zeros((2, 3)),
        "person",
        [np.zeros(3)],
        [PersonCapsule([0, 0, 0], radius=0.1), 1],
    ):
        with pytest.raises(InvalidInput):
            rows.update(bad)  # type: ignore[arg-type]
    rows.update([], stamp=1.0)
    with pytest.raises(InvalidInput):
        rows.update([], stamp=0.5)  # earlier than the last
    with pytest.raises(InvalidInput):
        rows.update([], stamp=math.nan)
    assert rows.stamp == 1.0
    with pytest.raises(InvalidInput):
        separation_distance(math.inf, parameters=P1)
    with pytest.raises(InvalidInput):
        max_approach_speed(math.nan, parameters=P1)
    with pytest.raises(InvalidParameter):
        max_approach_speed(1.0, parameters=P1, dt=0.0)


# ------------------------------------------------------------------------- rows
def _ctx(q: np.ndarray, dt: float | None = None) -> RowContext:
    return RowContext(q, np.zeros(7), None, dt, frame_of(ARM, q))


def test_no_people_no_rows() -> None:
    rows = _rows()
    assert rows.rows(_ctx(Q0)) is None
    filt = SafetyFilter(ARM, limits=LIMITS, providers=[rows], dt=0.004)
    u = np.full(7, 0.3)
    res = filt.explain(Q0, u)
    assert not [s for s in res.constraint_names if s.startswith("separation")]
    np.testing.assert_allclose(res.output, u)


def _surface(q: np.ndarray, k: int, p: PersonCapsule) -> float:
    seg = ARM.link_segments(q)[k]
    r = float(np.asarray(ARM.link_radius)[k])
    return segment_segment_distance(seg[0], seg[1], p.a, p.b) - r - p.radius


def test_row_is_minus_the_distance_gradient_and_bound_is_vmax() -> None:
    person = PersonCapsule([0.9, 0.3, 0.2], b=[0.9, 0.3, 1.6], radius=0.15, name="torso")
    rows = _rows(people=[person])
    assert rows.level == LEVEL_OBSTACLE
    blk = rows.rows(_ctx(Q0))
    assert blk is not None
    assert blk.size > 0
    names = blk.names() if callable(blk.names) else blk.names
    for r, key in enumerate(np.asarray(blk.keys).tolist()):
        k = key % 7
        assert names[r] == f"separation torso / link {k}"
        d = _surface(Q0, k, person)
        # the row is the distance's rate nᵀ J x >= -v_max: finite differences of the public
        # distance, (d(q + h e_j) - d(q - h e_j)) / 2h, give nᵀ J
        h = 1e-6
        grad = [
            (_surface(Q0 + h * e, k, person) - _surface(Q0 - h * e, k, person)) / (2 * h)
            for e in np.eye(7)
        ]
        np.testing.assert_allclose(blk.G[r], grad, atol=1e-6)
        assert blk.b[r] == pytest.approx(-max_approach_speed(d, parameters=P1), abs=1e-12)
        assert blk.distance is not None
        assert blk.distance[r] == pytest.approx(d - separation_distance(0.0, parameters=P1))


def test_measured_velocity_enters_as_directed_speed() -> None:
    # A person walking away from the robot (velocity away from every link) gets v_h = 0; walking
    # toward it at 1 m/s gets v_h = 1 m/s along the normal; both less than the 1.6 m/s worst case.
    a, b = [0.9, 0.3, 0.2], [0.9, 0.3, 1.6]
    away = _rows(people=[PersonCapsule(a, b=b, radius=0.15, velocity=[3.0, 0.0, 0.0])])
    worst = _rows(people=[PersonCapsule(a, b=b, radius=0.15)])
    blk_a, blk_w = away.rows(_ctx(Q0)), worst.rows(_ctx(Q0))
    assert blk_a is not None
    assert blk_w is not None
    p = PersonCapsule(a, b=b, radius=0.15)
    for r, key in enumerate(np.asarray(blk_a.keys).tolist()):
        d = _surface(Q0, key % 7, p)
        assert blk_a.b[r] == pytest.approx(-max_approach_speed(d, parameters=P1, human_speed=0.0))
    for r, key in enumerate(np.asarray(blk_w.keys).tolist()):
        d = _surface(Q0, key % 7, p)
        assert blk_w.b[r] == pytest.approx(-max_approach_speed(d, parameters=P1))


def test_inside_rest_distance_rows_are_no_further_in_and_finite() -> None:
    person = PersonCapsule([0.3, 0.0, 0.6], b=[0.3, 0.0, 1.4], radius=0.2)  # on top of the arm
    rows = _rows(people=[person])
    blk = rows.rows(_ctx(Q0, 0.004))
    assert blk is not None
    assert np.all(np.isfinite(blk.G))
    assert np.all(blk.b == 0.0)
    assert np.all(blk.violated)
    filt = SafetyFilter(ARM, limits=LIMITS, providers=[rows], dt=0.004)
    rng = np.random.default_rng(3)
    for _ in range(20):
        u = rng.normal(size=7)
        res = filt.explain(Q0, u)
        assert np.all(np.isfinite(res.output))
        G, _b = res.rows
        sep = [i for i, s in enumerate(res.constraint_names) if s.startswith("separation")]
        assert sep
        assert np.all(G[sep] @ res.output >= -1e-9)


def test_fifty_capsules() -> None:
    rng = np.random.default_rng(50)
    people = []
    for i in range(50):
        c = rng.uniform([-1.5, -1.5, 0.0], [1.5, 1.5, 1.0])
        people.append(
            PersonCapsule(
                c,
                b=c + np.array([0.0, 0.0, 0.4]),
                radius=0.08,
                velocity=rng.normal(size=3),
                name=f"p{i}",
            )
        )
    rows = _rows(people=people)
    filt = SafetyFilter(ARM, limits=LIMITS, providers=[rows], dt=0.004)
    res = filt.explain(Q0, rng.normal(size=7))
    assert np.all(np.isfinite(res.output))
    sep = [s for s in res.constraint_names if s.startswith("separation")]
    assert len(sep) > 50  # many pairs within reach, each named by its part and link
    G, b = res.rows
    assert not res.relaxed
    assert np.all(G @ res.output - b >= -1e-9 * (1 + np.abs(b)))


# ------------------------------------------------------------------------- closed loop
def _reach() -> float:
    """R: the arm's largest lever (distance between any two of its link end points) [m]."""
    pts = ARM.link_segments(Q0).reshape(-1, 3)
    return float(np.max(np.linalg.norm(pts[:, None] - pts[None], axis=2))) + 1.0


@pytest.mark.parametrize(
    ("measured", "walk", "assumed"),
    [(True, 1.2, WALKING_SPEED), (False, 1.2, WALKING_SPEED), (False, 1.5, 1.0)],
    ids=["measured", "worst-case", "faster-than-assumed"],
)
def test_closed_loop_keeps_the_protective_distance(
    measured: bool, walk: float, assumed: float
) -> None:
    """A 7-joint arm jogged at its TCP toward a person walking toward it at constant velocity.

    Every period, on ten sub-steps (the robot holding ``x``, the person walking on), the
    separation of every approaching link stays >= S_p(v_r) at the person's true directed speed
    ``v_h`` (``v_r`` the link point's approach speed that period), minus the documented bounds
    (docs/derivations.md): the discretisation ``(Σ_j |x_j|)² R τ²`` and, for a person faster
    than the rows assume (``v̂_h``), the lag ``(v_h - v̂_h)(T_r + T_s + dt)``.
    """
    dt = 0.01
    vel = np.array([-walk, 0.0, 0.0])
    start = np.array([2.2, 0.1, 0.0])
    prm = dataclasses.replace(P1, human_speed=assumed)
    rows = _rows(prm)
    filt = SafetyFilter(ARM, limits=LIMITS, providers=[rows], dt=dt)
    R = _reach()
    radius = np.asarray(ARM.link_radius)
    q = Q0.copy()
    worst = math.inf
    approached = 0
    for k in range(150):
        base = start + vel * (k * dt)
        person = PersonCapsule(
            base, b=base + np.array([0.0, 0.0, 1.7]), radius=0.2, velocity=vel if measured else None
        )
        rows.update([person], stamp=k * dt)
        fr = frame_of(ARM, q)
        u = np.linalg.pinv(fr.jacobian("tcp")) @ np.array([0.8, 0.0, 0.0])
        x = filt.filter(q, u)
        spin = float(np.sum(np.abs(x)))
        segs = ARM.link_segments(q)
        for link in range(7):
            # the link point closest to the person, the normal person -> link and the point's
            # approach speed, from velfence.geometry's public closest points
            pa, pb, s, _t = closest_points_segments(
                segs[link][0], segs[link][1], person.a, person.b
            )
            n = (pa - pb) / np.linalg.norm(pa - pb)
            vr = float(-n @ (fr.point_jacobian(link, s) @ x))
            if vr <= 1e-9:  # not approaching (to the round-off of a zero approach speed)
                continue
            approached += 1
            vh = max(0.0, float(n @ vel))  # the true directed speed
            vh_rows = vh if measured else assumed
            lag = max(0.0, vh - vh_rows) * (prm.reaction_time + prm.stopping_time + dt)
            sp = separation_distance(vr, parameters=prm, human_speed=vh)
            for j in range(1, 11):
                tau = dt * j / 10
                seg_t = ARM.link_segments(q + x * tau)[link]
                d = segment_segment_distance(
                    seg_t[0], seg_t[1], person.a + vel * tau, person.b + vel * tau
                )
                d -= float(radius[link]) + person.radius
                eps = spin * spin * R * tau * tau + 1e-9
                worst = min(worst, d - sp + eps + lag)
        q = q + x * dt
    assert approached > 100  # the arm did approach, the rows were exercised
    assert worst >= 0.0, worst
    # the person walked into the arm: by the end everything within reach is stopped or retreating
    final = rows.rows(_ctx(q, dt))
    assert final is not None
    assert np.any(final.violated)


def _crowd(seed: int, count: int) -> list[PersonCapsule]:
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        c = rng.uniform([-1.2, -1.2, 0.0], [1.2, 1.2, 1.2])
        vel = rng.normal(size=3) if i % 2 else None
        out.append(PersonCapsule(c, b=c + np.array([0.0, 0.3, 0.4]), radius=0.1, velocity=vel))
    return out


def test_next_distances_at_the_same_pose_are_the_block_distances_exactly() -> None:
    # The model check compares them with >=: a last-bit difference at a pose that did not move
    # would stop the arm for nothing.
    rows = _rows(people=_crowd(1, 20))
    for dt in (None, 0.004):
        ctx = _ctx(Q0, dt)
        blk = rows.rows(ctx)
        assert blk is not None
        assert blk.distance is not None
        np.testing.assert_array_equal(rows.next_distances(ctx.frame, blk), blk.distance)


@pytest.mark.skipif(
    SeparationRows(P1, link_radius=[0.04], max_speed=[1.0]).backend != "c",
    reason="the compiled core is not installed",
)
def test_python_and_c_closest_points_give_the_same_rows() -> None:
    people = _crowd(2, 30)
    blocks = []
    for backend in ("python", "c"):
        rows = SeparationRows(
            P1,
            link_radius=ARM.link_radius,
            max_speed=LIMITS.max_speed,
            people=people,
            backend=backend,
        )
        assert rows.backend == backend
        blk = rows.rows(_ctx(Q0, 0.004))
        assert blk is not None
        blocks.append(blk)
    py, c = blocks
    np.testing.assert_array_equal(py.keys, c.keys)
    np.testing.assert_array_equal(py.G, c.G)
    np.testing.assert_array_equal(py.b, c.b)
    np.testing.assert_array_equal(py.distance, c.distance)
