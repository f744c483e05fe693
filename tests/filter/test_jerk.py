"""The safety filter's jerk rows (``JointLimits(max_jerk=)``): the bound, the ladder, the reset.

The jerk of every cycle is measured from the outputs alone (the second difference of the output
sequence over dt², ``numpy.diff``), never from the filter's rows: in a closed loop every cycle the
filter does not flag holds it. Both routes (the Python providers and the C cycle) run the same
loops and must agree (the oracle's comparison in full is tests/core/test_filter_cycle_equal.py).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter import JointLimits, SafetyFilter, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain
from velfence.shaping.profiles import LinearBuffer

ARM = DHChain.seven_dof()
LO, HI = ARM.joint_limits[:, 0], ARM.joint_limits[:, 1]
Q0 = np.array([0.0, 0.4, 0.0, -1.2, 0.0, 1.4, 0.0])
DT = 0.01
VMAX, AMAX, JMAX = 1.5, 8.0, 200.0  # J dt = 2 rad/s² per cycle: a quarter of AMAX
try:
    import velfence_core._filter  # noqa: F401

    BACKENDS = ["python", "c"]
except ImportError:  # pragma: no cover - the core is an optional distribution
    BACKENDS = ["python"]


def _limits(jerk: Any = JMAX, acc: Any = AMAX) -> JointLimits:
    return JointLimits(LO, HI, max_speed=VMAX, max_acceleration=acc, max_jerk=jerk)


def _box() -> WorkspaceLimit:
    tcp = ARM.fk(Q0, "tcp")
    return WorkspaceLimit(ConvexPolytope.box(tcp - 0.12, tcp + 0.12), point="tcp", buffer=0.05)


@pytest.mark.parametrize(
    ("jerk", "match"),
    [
        (0.0, r"max_jerk: expected jerks > 0"),
        (-5.0, r"max_jerk: expected jerks > 0"),
        ([100.0] * 6 + [0.0], r"max_jerk: expected jerks > 0"),
        (math.nan, r"max_jerk: expected .*NaN"),
        ([100.0] * 3, r"max_jerk: expected shape \(7,\)"),
        ("fast", r"max_jerk"),
        (1e300, r"max_jerk: expected magnitudes"),
    ],
)
def test_bad_jerk_limits_are_refused_naming_max_jerk(jerk: Any, match: str) -> None:
    with pytest.raises(InvalidParameter, match=match):
        _limits(jerk=jerk)


def test_jerk_limits_scalar_or_per_joint_inf_for_none() -> None:
    assert _limits(jerk=50.0).max_jerk.tolist() == [50.0] * 7  # type: ignore[union-attr]
    per = [10.0, 20.0, 30.0, math.inf, 50.0, 60.0, 70.0]
    lim = _limits(jerk=per)
    assert lim.max_jerk.tolist() == per  # type: ignore[union-attr]
    assert not lim.max_jerk.flags.writeable  # type: ignore[union-attr]
    assert _limits(jerk=None).max_jerk is None
    f = SafetyFilter(ARM, limits=lim, dt=DT, backend="python")
    f.reset(velocity=np.zeros(7))
    r = f.explain(Q0, np.ones(7))
    assert sum("jerk" in n for n in r.constraint_names) == 12  # joint 3 has none


def test_reset_velocity_is_validated() -> None:
    f = SafetyFilter(ARM, limits=_limits(), dt=DT)
    with pytest.raises(InvalidInput, match="velocity"):
        f.reset(velocity=np.zeros(3))
    with pytest.raises(InvalidInput, match="velocity"):
        f.reset(velocity=[math.nan] * 7)


@pytest.mark.parametrize("backend", BACKENDS)
def test_reset_semantics(backend: str) -> None:
    """Fresh: no rate rows, then acceleration rows, then jerk rows; reset(velocity=) has both."""
    f = SafetyFilter(ARM, limits=_limits(), dt=DT, backend=backend)
    assert f.stateful
    u = np.full(7, 1.0)

    def kinds(r: Any) -> tuple[bool, bool]:
        names = r.constraint_names
        return any("acceleration" in n for n in names), any("jerk" in n for n in names)

    assert kinds(f.explain(Q0, u)) == (False, False)  # first cycle: nothing remembered
    assert kinds(f.explain(Q0, u)) == (True, False)  # one output remembered
    assert kinds(f.explain(Q0, u)) == (True, True)  # two: the jerk rows
    f.reset()
    assert kinds(f.explain(Q0, u)) == (False, False)
    # an explicit previous gives acceleration rows only (no output before it is known) ...
    assert kinds(f.explain(Q0, u, previous=np.zeros(7))) == (True, False)
    # ... and the next cycle's jerk rows use it and that cycle's output
    x1 = f.explain(Q0, u).output
    np.testing.assert_allclose(np.abs(x1 - 2 * f.explain(Q0, u, previous=np.zeros(7)).output), 0.0)
    f.reset(velocity=np.zeros(7))  # a robot at rest
    r = f.explain(Q0, u)
    assert kinds(r) == (True, True)
    # from rest the first acceleration is at most one period of jerk: |x| <= J dt²
    np.testing.assert_allclose(np.abs(r.output), JMAX * DT * DT, rtol=1e-12)
    r2 = f.explain(Q0, u)  # then 2 J dt² more, and so on (a ramp)
    np.testing.assert_allclose(r2.output - r.output, 2 * JMAX * DT * DT, rtol=1e-9)


def _closed_loop(f: SafetyFilter, steps: int, seed: int) -> tuple[Any, list[Any], list[float]]:
    """An operator's commands (random steps, reversals, bursts) through ``f`` from rest."""
    rng = np.random.default_rng(seed)
    q = Q0.copy()
    f.reset(velocity=np.zeros(7))
    xs = [np.zeros(7), np.zeros(7)]
    results = []
    margins = []
    box = f.workspace[0].polytope if f.workspace else None
    u = np.zeros(7)
    for k in range(steps):
        if k % 15 == 0:
            u = rng.uniform(-1.0, 1.0, 7) * VMAX * (3.0 if k % 60 == 0 else 1.0)
        r = f.explain(q, u)
        q = q + r.output * DT
        xs.append(r.output)
        results.append(r)
        if box is not None:
            margins.append(float(np.min(box.signed_distances(ARM.fk(q, "tcp")))))
    return np.array(xs), results, margins


@pytest.mark.parametrize("backend", BACKENDS)
def test_every_unflagged_cycle_holds_the_jerk_limit(backend: str) -> None:
    f = SafetyFilter(ARM, limits=_limits(), dt=DT, workspace=_box(), backend=backend)
    xs, results, margins = _closed_loop(f, 400, seed=3)
    assert np.all(np.isfinite(xs))
    jerk = np.diff(xs, 2, axis=0) / DT**2  # (the outputs alone: the two zeros of the rest first)
    acc = np.diff(xs, 1, axis=0)[1:] / DT
    flagged = np.array([r.jerk_override or r.deadline is not None for r in results])
    assert f.jerk_overrides == sum(r.jerk_override for r in results)
    assert 0 < flagged.sum() < 0.5 * len(results)  # the box does make it give way, not often
    ok = np.abs(jerk) <= JMAX * (1 + 1e-9) + 1e-9 / DT**2
    assert ok[~flagged].all(), np.abs(jerk[~flagged]).max() / JMAX
    assert not ok[flagged].all(axis=1).all()  # a flagged cycle did exceed it somewhere
    rate = np.array([r.rate_override or r.deadline is not None for r in results])
    assert np.all(np.abs(acc[~rate]) <= AMAX * (1 + 1e-9) + 1e-9 / DT)
    assert min(margins) >= -1e-9  # the TCP stayed in the box: safety won
    # the unflagged cycles' rows: the jerk rows bind somewhere (they shaped the motion)
    assert any(any("jerk" in n for n in r.active_names) for r in results)


def test_both_routes_run_the_same_loop() -> None:
    pytest.importorskip("velfence_core._filter")
    fp = SafetyFilter(ARM, limits=_limits(), dt=DT, workspace=_box(), backend="python")
    fc = SafetyFilter(ARM, limits=_limits(), dt=DT, workspace=_box(), backend="c")
    assert fc.cycle_in_c
    xp, rp, _ = _closed_loop(fp, 200, seed=5)
    xc, rc, _ = _closed_loop(fc, 200, seed=5)
    np.testing.assert_allclose(xc, xp, rtol=1e-9, atol=1e-9)
    assert [r.stages for r in rc] == [r.stages for r in rp]
    assert fc.jerk_overrides == fp.jerk_overrides > 0
    # filter() (the C fast path) remembers and counts as explain() does
    ff = SafetyFilter(ARM, limits=_limits(), dt=DT, workspace=_box(), backend="c")
    ff.reset(velocity=np.zeros(7))
    q = Q0.copy()
    for k, r in enumerate(rc):
        x = ff.filter(q, r.command)
        np.testing.assert_allclose(x, xc[k + 2], rtol=1e-12, atol=1e-15)
        q = q + x * DT
    assert ff.jerk_overrides == fc.jerk_overrides


@pytest.mark.parametrize("backend", BACKENDS)
def test_jerk_gives_way_to_a_joint_limit_and_the_acceleration_limit_holds(backend: str) -> None:
    """Joint 3 at 1 rad/s, 2 mrad below its limit: the jerk rows go first, then acceleration."""
    f = SafetyFilter(ARM, limits=_limits(), dt=DT, backend=backend)
    q = Q0.copy()
    q[3] = HI[3] - 2e-3
    v = np.zeros(7)
    v[3] = 1.0
    f.reset(velocity=v)
    r = f.explain(q, v)
    assert r.jerk_override
    assert r.rate_override
    assert r.dropped[:2] == ("jerk", "acceleration")
    assert r.stages.index("dropped jerk") < r.stages.index("dropped acceleration")
    assert q[3] + r.output[3] * DT <= HI[3]
    assert f.jerk_overrides == 1
    # only the jerk rows give way when the acceleration limit suffices: a linear buffer whose
    # cap 0.9495 rad/s is one acceleration step (0.08 rad/s) below the steady 1 rad/s but more
    # than one jerk step (0.02 rad/s) below it
    f2 = SafetyFilter(
        ARM, limits=_limits(), dt=DT, profile=LinearBuffer(buffer=0.1), backend=backend
    )
    q2 = Q0.copy()
    q2[3] = HI[3] - 0.0633
    f2.reset(velocity=v)
    r = f2.explain(q2, v)
    assert r.jerk_override
    assert not r.rate_override
    assert r.dropped == ("jerk",)
    assert r.output[3] == pytest.approx(VMAX * 0.0633 / 0.1, rel=1e-12)
    assert abs(r.output[3] - 1.0) <= AMAX * DT  # the acceleration limit held


def test_no_jerk_rows_without_dt_or_limits() -> None:
    f = SafetyFilter(ARM, limits=_limits(), backend="python")  # continuous time
    assert not f.stateful
    f2 = SafetyFilter(ARM, limits=_limits(jerk=[math.inf] * 7, acc=None), dt=DT)
    assert not f2.stateful
    f3 = SafetyFilter(ARM, limits=_limits(acc=None), dt=DT, backend="python")
    assert f3.stateful  # jerk rows alone remember the outputs too
    f3.reset(velocity=np.zeros(7))
    r = f3.explain(Q0, np.ones(7))
    assert [n for n in r.constraint_names if "acceleration" in n] == []
    np.testing.assert_allclose(r.output, JMAX * DT * DT)


def test_ros2_control_jerk_fields() -> None:
    """``has_jerk_limits`` / ``max_jerk`` of a ros2_control joint_limits entry are read."""
    names = [f"j{k}" for k in range(7)]
    entry = {"has_velocity_limits": True, "max_velocity": 1.0}
    doc: dict[str, Any] = {"joint_limits": {n: dict(entry) for n in names}}
    doc["joint_limits"]["j2"] |= {"has_jerk_limits": True, "max_jerk": 300.0}
    doc["joint_limits"]["j5"] |= {"max_jerk": 40.0}  # no flag: a value given is the limit
    doc["joint_limits"]["j6"] |= {"has_jerk_limits": False, "max_jerk": 1.0}  # flag off: ignored
    lim = JointLimits.from_ros2_control(doc, names)
    assert lim.max_jerk is not None
    assert lim.max_jerk.tolist() == [math.inf] * 2 + [300.0] + [math.inf] * 2 + [40.0, math.inf]
    plain = {"joint_limits": {n: dict(entry) for n in names}}
    assert JointLimits.from_ros2_control(plain, names).max_jerk is None
    doc["joint_limits"]["j0"] |= {"has_jerk_limits": True, "max_jerk": -1.0}
    with pytest.raises(InvalidParameter, match="max_jerk"):
        JointLimits.from_ros2_control(doc, names)
    doc["joint_limits"]["j0"] = dict(entry) | {"has_jerk_limits": True}
    with pytest.raises(InvalidParameter, match=r"j0\.max_jerk: missing"):
        JointLimits.from_ros2_control(doc, names)
