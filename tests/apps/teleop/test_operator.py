"""The synthetic operator: determinism, sub-movements, workspace and clutch, aiming."""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.apps.teleop.modes import ModeManager
from velfence.apps.teleop.operator import (
    OMNI_WORKSPACE,
    PROFILE_RANGES,
    OperatorProfile,
    SyntheticOperator,
)
from velfence.apps.teleop.session import OMNI_TO_PUMA, Session
from velfence.errors import InvalidParameter

RATE = 50.0


def _session():
    return Session(rate=RATE, modes=ModeManager(rate=RATE))


def _drive(session, op, plan, limit=90.0, on_tick=None):
    op.start(plan)
    while not op.finished and session.t < limit:
        a = op.act(session.observe())
        for k in a.keys:
            session.press(k)
        session.jog(a.linear, a.angular)
        session.advance(op.tick)
        if on_tick is not None:
            on_tick(session, op, a)


def test_profiles_are_drawn_reproducibly_within_their_ranges():
    a = OperatorProfile.draw(np.random.default_rng([3, 1]))
    b = OperatorProfile.draw(np.random.default_rng([3, 1]))
    c = OperatorProfile.draw(np.random.default_rng([3, 2]))
    assert a == b
    assert a != c
    for name, (lo, hi) in PROFILE_RANGES.items():
        assert lo <= getattr(a, name) <= hi
    assert set(a.to_dict()) == set(PROFILE_RANGES) | {"rainbow"}


def test_profile_ranges_are_read_only():
    with pytest.raises(TypeError, match="does not support item assignment"):
        PROFILE_RANGES["reaction"] = (0.0, 10.0)  # type: ignore[index]
    assert PROFILE_RANGES["reaction"] == (0.20, 0.40)


def test_profile_and_operator_validation():
    with pytest.raises(InvalidParameter, match="peak_speed"):
        OperatorProfile(peak_speed=0.0)
    with pytest.raises(InvalidParameter, match="reaction"):
        OperatorProfile(reaction=-1.0)
    with pytest.raises(InvalidParameter, match="seed"):
        SyntheticOperator(seed=-1)
    with pytest.raises(InvalidParameter, match="tick"):
        SyntheticOperator(tick=0.0)
    with pytest.raises(InvalidParameter, match="observation"):
        _ = SyntheticOperator().obs


def _reach_plan(offset, tol=0.005):
    def plan(op):
        start = op.obs.tip.copy()
        goal = start + np.asarray(offset)
        yield from op.reach(lambda o: goal, tol=tol)

    return plan


def test_same_seed_same_run_other_seed_other_run():
    traces = []
    for seed in (5, 5, 6):
        s = _session()
        op = SyntheticOperator(seed=seed)
        _drive(s, op, _reach_plan([0.06, 0.03, -0.04]))
        traces.append(s.trace)
    np.testing.assert_array_equal(traces[0], traces[1])
    assert traces[0].shape != traces[2].shape or not np.array_equal(traces[0], traces[2])


def test_reach_converges_by_corrective_submovements():
    s = _session()
    op = SyntheticOperator(seed=1)
    start = s.tip.copy()
    _drive(s, op, _reach_plan([0.05, 0.02, -0.03], tol=0.004))
    goal = start + np.array([0.05, 0.02, -0.03])
    # Within the tolerance plus the perception noise (a few mm).
    assert np.linalg.norm(s.tip - goal) < 0.008
    assert op.stats.strokes >= 2  # primary + at least one correction (10 % endpoint noise)
    assert op.stats.clutch_presses == 1  # engaged once, start-up was disengaged


def test_long_reach_stays_in_the_omni_workspace_and_indexes_with_the_clutch():
    s = _session()
    op = SyntheticOperator(seed=2)
    half = 0.5 * np.array(OMNI_WORKSPACE)
    worst = [0.0]
    frozen = []

    def watch(session, oper, action):
        worst[0] = max(worst[0], float(np.max(np.abs(oper.hand) - half)))
        if not session.modes.clutch:
            frozen.append(session.q)

    # 0.25 m down: the Omni's 120 mm height forces re-centring (PUMA z = Omni y).
    _drive(s, op, _reach_plan([0.0, 0.0, -0.25], tol=0.01), on_tick=watch)
    assert worst[0] <= 1e-9
    assert op.stats.index_events >= 2
    assert op.stats.clutch_presses == 1 + 2 * op.stats.index_events
    assert s.tip[2] == pytest.approx(s.trace[0, 6] - 0.25, abs=0.015)
    # While the clutch was out the arm stood still (the hand's motion was not sent).
    assert len(frozen) > 10


@pytest.mark.parametrize(("hand_y", "indexes"), [(0.055, True), (0.0, False)])
def test_index_moves_the_hand_against_the_stroke(hand_y, indexes):
    # 5 cm up for the robot is 5 cm up for the hand (Omni +y); near the top of the 120 mm
    # height there is no room for it: the operator indexes (clutch out, hand down) first.
    assert pytest.approx(0.05) == (OMNI_TO_PUMA @ [0.0, 0.0, 0.05]) @ [0.0, 1.0, 0.0]
    s = _session()
    op = SyntheticOperator(seed=0)
    op.hand = np.array([0.0, hand_y, 0.0])
    free_y = []  # the hand's height on the ticks the clutch was out after the first press

    def watch(session, oper, action):
        if oper.stats.clutch_presses > 1 and not session.modes.clutch:
            free_y.append(float(oper.hand[1]))

    _drive(s, op, lambda o: o.stroke(np.array([0.0, 0.0, 0.05]), tol=0.01), on_tick=watch)
    assert op.finished
    assert op.stats.index_events == int(indexes)
    if indexes:
        assert min(free_y) == pytest.approx(-0.6 * op.half[1], abs=1e-3)  # moved against it
        assert op.hand[1] > min(free_y) + 0.02  # then the stroke itself went up
    else:
        assert free_y == []
        assert op.hand[1] == pytest.approx(0.05, abs=0.01)


def test_vertical_orientation_with_planning_pauses():
    s = _session()
    op = SyntheticOperator(seed=3)
    tilt0 = math.degrees(math.acos(-s.pose[2, 2]))
    assert tilt0 > 20.0  # the ready pose is tilted like the thesis's arm

    def plan(oper):
        yield from oper.engage()
        yield from oper.vertical(math.radians(4.0))

    _drive(s, op, plan)
    assert math.degrees(math.acos(-s.pose[2, 2])) < 5.0
    assert op.stats.orient_strokes >= 1
    # Each orientation stroke is preceded by reaction + planning time.
    assert s.t > op.stats.orient_strokes * (op.profile.reaction + op.profile.orient_plan)


def test_aim_puts_the_laser_spot_on_the_target_and_keys_follow():
    s = _session()
    op = SyntheticOperator(seed=4)
    target = np.array([-0.18, 0.68, -0.6 + 1e-4])  # the destination mark

    def plan(oper):
        yield from oper.engage()
        yield from oper.aim(target, tol=0.01)
        yield from oper.record("D")

    _drive(s, op, plan)
    assert np.linalg.norm(s.observe().spot - target) < 0.015
    assert s.modes.destination is not None
    assert np.linalg.norm(s.modes.destination - target) < 0.02
    assert op.stats.keys == 1
    assert op.stats.aim_strokes >= 1
