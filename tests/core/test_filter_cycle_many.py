"""``velfence_core._filter.cycle_many``: many arms' cycles in one call, each row its own cycle().

Every row must equal ``FilterCycle.cycle`` of that object and state bit for bit (output, stages,
deadline misses), with and without the previous outputs, a refused row must not disturb the
others, and the call's own argument errors must be clear.
"""

from __future__ import annotations

import numpy as np
import pytest

from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.filter.ccycle import c_cycle_or_none
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain
from velfence.shaping.backend import compiled_filter

_filter = compiled_filter()
pytestmark = pytest.mark.skipif(
    _filter is None or not hasattr(_filter, "cycle_many"), reason="needs the compiled core"
)


def _arms(count: int, *, seed: int = 0, accel: bool = False, cap: int | None = None) -> list:
    """``count`` filters of one 7-joint arm with different limits, boxes and spheres."""
    rng = np.random.default_rng(seed)
    robot = DHChain.seven_dof(link_radius=0.05, tool=(0.0, 0.0, 0.05))
    out = []
    for _ in range(count):
        q = rng.uniform(-1.0, 1.0, 7)
        p = robot.fk(q)
        box = ConvexPolytope.box(p - rng.uniform(0.05, 0.3, 3), p + rng.uniform(0.05, 0.3, 3))
        spheres = [
            SphereObstacle(p + rng.uniform(-0.3, 0.3, 3), radius=float(rng.uniform(0.02, 0.1)))
            for _ in range(int(rng.integers(0, 4)))
        ]
        limits = JointLimits(
            q - rng.uniform(0.05, 1.0, 7),
            q + rng.uniform(0.05, 1.0, 7),
            max_speed=np.full(7, 2.0),
            max_acceleration=np.full(7, 50.0) if accel else None,
            max_jerk=np.full(7, 5e4) if accel else None,
        )
        sf = SafetyFilter(robot, limits=limits, workspace=[WorkspaceLimit(box, buffer=0.03)],
                          obstacles=spheres, dt=1e-3, max_iterations=cap)  # fmt: skip
        out.append((sf, q))
    return out


def test_each_row_is_its_own_cycle_bit_for_bit() -> None:
    arms = _arms(9)
    rng = np.random.default_rng(1)
    Q = np.array([q + rng.normal(0.0, 0.2, 7) for _, q in arms])
    U = rng.uniform(-3.0, 3.0, Q.shape)
    mine = [c_cycle_or_none(sf) for sf, _ in arms]
    theirs = [c_cycle_or_none(sf) for sf, _ in arms]
    X, status, stages = _filter.cycle_many(mine, Q, U)
    assert X.shape == Q.shape
    for r, cyc in enumerate(theirs):
        x = cyc.cycle(Q[r], U[r])
        assert np.array_equal(X[r], x)
        assert stages[r] == cyc.stages
        assert status[r] == cyc.info()["status"] >= 0
        assert mine[r].info() == cyc.info()
    assert np.any(stages != 0)  # some rows were filtered, not passed through


def test_previous_outputs_per_row_and_a_caller_array() -> None:
    arms = _arms(5, seed=2, accel=True)
    rng = np.random.default_rng(3)
    Q = np.array([q for _, q in arms])
    U = rng.uniform(-2.0, 2.0, Q.shape)
    P = rng.uniform(-0.5, 0.5, Q.shape)
    P2 = rng.uniform(-0.5, 0.5, Q.shape)
    mine = [c_cycle_or_none(sf) for sf, _ in arms]
    theirs = [c_cycle_or_none(sf) for sf, _ in arms]
    out = np.zeros_like(Q)
    X, _, _ = _filter.cycle_many(mine, Q, U, P, P2, out)
    assert X is out
    for r, cyc in enumerate(theirs):
        assert np.array_equal(out[r], cyc.cycle(Q[r], U[r], P[r], None, P2[r]))
    # without previous2 (no jerk rows) the answers differ from those with it somewhere
    Y, _, _ = _filter.cycle_many(mine, Q, U, P)
    for r, cyc in enumerate(theirs):
        assert np.array_equal(Y[r], cyc.cycle(Q[r], U[r], P[r]))


def test_a_refused_row_is_zero_and_leaves_the_others_alone() -> None:
    arms = _arms(4, seed=4)
    Q = np.array([q for _, q in arms])
    U = np.full(Q.shape, 0.5)
    Q[2, 3] = np.nan
    cycles = [c_cycle_or_none(sf) for sf, _ in arms]
    X, status, _ = _filter.cycle_many(cycles, Q, U)
    assert status[2] == -3  # VF_ERR_NONFINITE
    assert np.all(X[2] == 0.0)
    ref = [c_cycle_or_none(sf) for sf, _ in arms]
    for r in (0, 1, 3):
        assert status[r] >= 0
        assert np.array_equal(X[r], ref[r].cycle(Q[r], U[r]))


def test_deadline_misses_are_counted_per_object() -> None:
    arms = _arms(6, seed=5, cap=1)  # one iteration per solve: the fallback often answers
    rng = np.random.default_rng(6)
    Q = np.array([q for _, q in arms])
    U = rng.uniform(-3.0, 3.0, Q.shape)
    mine = [c_cycle_or_none(sf) for sf, _ in arms]
    theirs = [c_cycle_or_none(sf) for sf, _ in arms]
    _, status, _ = _filter.cycle_many(mine, Q, U)
    for r, cyc in enumerate(theirs):
        cyc.cycle(Q[r], U[r])
        assert mine[r].deadline_misses == cyc.deadline_misses == int(status[r] == 3)
    assert np.any(status == 3)  # VF_ITERATION_CAP


def test_bad_arguments_are_refused() -> None:
    arms = _arms(2, seed=7)
    cycles = [c_cycle_or_none(sf) for sf, _ in arms]
    Q = np.zeros((2, 7))
    with pytest.raises(TypeError, match="cycles"):
        _filter.cycle_many(iter(cycles), Q, Q)
    with pytest.raises(TypeError, match="cycles\\[1\\]"):
        _filter.cycle_many([cycles[0], "no"], Q, Q)
    with pytest.raises(ValueError, match="at least one"):
        _filter.cycle_many([], Q[:0], Q[:0])
    with pytest.raises(TypeError, match="q"):
        _filter.cycle_many(cycles, np.zeros((3, 7)), np.zeros((3, 7)))
    with pytest.raises(TypeError, match="u"):
        _filter.cycle_many(cycles, Q, np.zeros((2, 6)))
    with pytest.raises(TypeError, match="out"):
        _filter.cycle_many(cycles, Q, Q, None, None, np.zeros((2, 7), dtype=np.float32))
    other = DHChain.ur5e(link_radius=0.05)
    sf6 = SafetyFilter(other, limits=JointLimits(np.full(6, -3.0), np.full(6, 3.0),
                                                 max_speed=np.full(6, 1.0)), dt=1e-3)  # fmt: skip
    with pytest.raises(ValueError, match="joints"):
        _filter.cycle_many([cycles[0], c_cycle_or_none(sf6)], Q, Q)
