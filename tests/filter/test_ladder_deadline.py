"""The priority ladder, the deadline fallback, custom row providers and bad input.

The ladder is documented in docs/safety_filter.md. Scenes: a 7-joint arm (DHChain.seven_dof)
with a TCP box and spheres near the links; the reproducer states of an independent escape
campaign (kept under tests/data).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.filter import (
    LEVEL_WORKSPACE,
    JointLimits,
    RowBlock,
    RowContext,
    SafetyFilter,
    SphereObstacle,
    WorkspaceLimit,
)
from velfence.filter.ladder import meets, run_ladder, safe_fallback
from velfence.geometry import projection
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain

DATA = Path(__file__).resolve().parents[1] / "data"
ARM = DHChain.seven_dof(link_radius=0.05)
Q0 = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])


def crowded(**kw: Any) -> SafetyFilter:
    """Many binding rows: a tight TCP box and spheres hugging every link."""
    lim = ARM.joint_limits
    p0 = ARM.fk(Q0)
    segs = ARM.link_segments(Q0)
    obstacles = []
    rng = np.random.default_rng(1)
    for a, b in segs:
        if np.linalg.norm(b - a) < 1e-6:
            continue
        for _ in range(3):
            d = rng.normal(size=3)
            d -= d @ (b - a) / ((b - a) @ (b - a)) * (b - a)
            c = a + rng.uniform(0.2, 0.8) * (b - a) + (0.05 + 0.03 + 0.01) * d / np.linalg.norm(d)
            obstacles.append(SphereObstacle(c, radius=0.03))
    args: dict[str, Any] = {
        "limits": JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5)),
        "workspace": WorkspaceLimit(ConvexPolytope.box(p0 - 0.01, p0 + 0.01), buffer=0.05),
        "obstacles": obstacles,
        "obstacle_buffer": 0.1,
        "dt": 1e-3,
    }
    args.update(kw)
    return SafetyFilter(ARM, **args)


def relaxed_rows_hold(r: Any) -> bool:
    G, b = r.rows
    return meets(G, np.minimum(b, 0.0), r.output)


# ------------------------------------------------------------------------------ deadline
@pytest.mark.skipif(
    not hasattr(projection, "project_kernel_opts"),
    reason="the projection's iteration cap (project_kernel_opts) has not landed on main yet",
)
def test_an_iteration_cap_of_one_answers_the_safe_fallback() -> None:
    f = crowded(max_iterations=1)
    ref = crowded()
    u = np.array([1.0, -1.0, 1.0, 1.0, -1.0, 1.0, 1.0])
    r = f.explain(Q0, u)
    assert len(r.active) > 5, "the scene must have many binding rows"
    assert r.deadline == "iterations"
    assert "deadline" in r.stages
    assert f.deadline_misses == 1
    assert relaxed_rows_hold(r)
    assert np.all(np.isfinite(r.output))
    # the fallback is the command scaled (never another direction), and the full solve is not
    t = float(r.output @ u) / float(u @ u)
    np.testing.assert_allclose(r.output, t * u, atol=1e-15)
    assert 0.0 <= t <= 1.0
    full = ref.explain(Q0, u)
    assert full.deadline is None
    assert ref.deadline_misses == 0


def test_a_tiny_time_budget_answers_the_safe_fallback() -> None:
    f = crowded(time_budget=1e-9)
    ticks = iter(np.arange(0.0, 1e3, 1e-3))
    f._clock = lambda: float(next(ticks))  # an injected clock: 1 ms per reading, no sleeps
    u = np.array([1.0, -1.0, 1.0, 1.0, -1.0, 1.0, 1.0])
    r = f.explain(Q0, u)
    assert r.deadline == "time"
    assert "deadline" in r.stages
    assert f.deadline_misses == 1
    assert relaxed_rows_hold(r)
    # a generous budget on the same clock does not trigger it
    g = crowded(time_budget=1e6)
    g._clock = f._clock
    assert g.explain(Q0, u).deadline is None


def test_the_fallback_is_safe_on_random_rows() -> None:
    rng = np.random.default_rng(4)
    for _ in range(200):
        m, n = int(rng.integers(1, 40)), int(rng.integers(1, 8))
        G = rng.normal(size=(m, n))
        b = rng.normal(size=m)
        u = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 3)
        x, relaxed, _ = safe_fallback(u, G, b)
        assert meets(G, np.minimum(b, 0.0), x)
        assert set(relaxed) == set(np.flatnonzero(b > 0).tolist())
        t = float(x @ u) / float(u @ u)
        assert -1e-15 <= t <= 1.0 + 1e-15


@pytest.mark.parametrize("bad", [0, -3, True, 2.5, "5", None])
def test_max_iterations_is_validated(bad: Any) -> None:
    if bad is None:
        assert crowded(max_iterations=None).max_iterations is None
        return
    with pytest.raises(InvalidParameter, match="max_iterations"):
        crowded(max_iterations=bad)


@pytest.mark.parametrize("bad", [0, 0.0, -1e-3, float("nan"), float("inf"), True, "1"])
def test_time_budget_is_validated(bad: Any) -> None:
    with pytest.raises(InvalidParameter, match="time_budget"):
        crowded(time_budget=bad)


@pytest.mark.skipif(
    not hasattr(projection, "project_kernel_opts"),
    reason="the projection's warm start (project_kernel_opts) has not landed on main yet",
)
def test_warm_start_from_the_previous_active_rows() -> None:
    f = crowded(backend="python")
    u = np.array([1.0, -1.0, 1.0, 1.0, -1.0, 1.0, 1.0])
    r1 = f.explain(Q0, u)
    assert f._warm, "the binding rows are remembered by key"
    r2 = f.explain(Q0, u)  # the same state, warm: the same answer
    np.testing.assert_allclose(r2.output, r1.output, atol=1e-12)
    f.reset()
    assert not f._warm


# ------------------------------------------------------------------------------ ladder policy
def test_zero_meets_every_safety_row_so_nothing_is_dropped() -> None:
    """The projection reproducer's rows (round-off stalls the old solve): the ladder never drops
    a row and the output meets every one."""
    d = np.load(DATA / "project_filter_rows.npz")
    u, G, b = d["u"], d["G"], d["b"]
    level = np.full(b.shape[0], LEVEL_WORKSPACE)
    from velfence.filter.solve import python_solve

    out = run_ladder(G, b, level, np.zeros(b.shape[0], dtype=bool),
                     lambda G, b, w: python_solve(u, G, b, 0, w))  # fmt: skip
    assert not any(s.startswith("dropped") for s in out.stages)
    assert out.relaxed == []
    assert meets(G, b, out.x, scale=float(np.abs(u).max()))  # the projection's acceptance


@pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")  # found states
@pytest.mark.parametrize("name", ["state_ur5e_101_4_1020", "state_panda_202_0_1603"])
def test_campaign_states_stay_inside(name: str) -> None:
    """The escape campaign's states (UR5e / Panda MuJoCo models, 1 ms): the next step stays
    inside every face it is inside (no further out of one it is outside), no sphere is entered
    further, and no workspace or obstacle row is dropped."""
    robots = pytest.importorskip("velfence.robots")
    pytest.importorskip("mujoco")
    d = np.load(DATA / f"{name}.npz")
    robot = robots.ur5e() if "ur5e" in name else robots.panda()
    poly = ConvexPolytope(d["N"], d["o"])
    amax = d["amax"] if d["amax"].size else None
    lim = JointLimits(d["lo"], d["hi"], max_speed=d["vmax"], max_acceleration=amax)
    obs = [SphereObstacle(c, radius=float(r)) for c, r in zip(d["C"], d["R"], strict=True)]
    f = SafetyFilter(robot, limits=lim, workspace=WorkspaceLimit(poly), obstacles=obs, dt=1e-3)
    q = d["q"]
    r = f.explain(q, d["v"]) if str(d["mode"]) == "joint" else f.explain_twist(q, d["v"])
    assert not any(s in r.stages for s in ("dropped workspace", "dropped obstacles"))
    assert np.all(np.isfinite(r.output))
    q1 = q + r.output * 1e-3
    d0 = poly.normals @ robot.fk(q) - poly.offsets
    d1 = poly.normals @ robot.fk(q1) - poly.offsets
    assert np.all(d1 >= np.minimum(0.0, d0) - 1e-12)
    assert np.all(q1 >= d["lo"] - 1e-12)
    assert np.all(q1 <= d["hi"] + 1e-12)
    segs0, segs1 = robot.link_segments(q), robot.link_segments(q1)
    for c, rad in zip(d["C"], d["R"], strict=True):
        for (a0, b0), (a1, b1) in zip(segs0, segs1, strict=True):
            assert _clear(c, rad, a1, b1) >= min(0.0, _clear(c, rad, a0, b0)) - 1e-12


def _clear(c: np.ndarray, r: float, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    t = 0.0 if d @ d == 0 else float(np.clip((c - a) @ d / (d @ d), 0.0, 1.0))
    return float(np.linalg.norm(a + t * d - c)) - r


# ------------------------------------------------------------------------------ providers
class KeepOutOfSlab:
    """A user's provider: joint 0's velocity kept >= -0.2 rad/s (a workspace-level row)."""

    level = LEVEL_WORKSPACE
    label = "slab"

    def rows(self, ctx: RowContext) -> RowBlock:
        G = np.zeros((1, ctx.q.shape[0]))
        G[0, 0] = 1.0
        return RowBlock(G, np.array([-0.2]), np.array([False]), np.array([0]), ["slab"])


def test_a_custom_provider_takes_part() -> None:
    f = crowded(providers=[KeepOutOfSlab()], workspace=(), obstacles=())
    r = f.explain(Q0, np.array([-1.0, 0, 0, 0, 0, 0, 0]))
    assert r.output[0] == pytest.approx(-0.2, abs=1e-12)
    assert "slab" in r.active_names
    assert f.providers[-1].label == "slab"


class Raises:
    level = 1
    label = "broken"

    def rows(self, ctx: RowContext) -> RowBlock:
        raise ZeroDivisionError("oops")


class WrongShape(KeepOutOfSlab):
    label = "wrong"

    def rows(self, ctx: RowContext) -> RowBlock:
        return RowBlock(np.zeros((1, 3)), np.array([0.0]), np.array([False]), np.array([0]), [])


class NaNRows(KeepOutOfSlab):
    label = "nan"

    def rows(self, ctx: RowContext) -> RowBlock:
        G = np.full((1, ctx.q.shape[0]), np.nan)
        return RowBlock(G, np.array([0.0]), np.array([False]), np.array([0]), [])


@pytest.mark.parametrize(
    ("provider", "match"),
    [(Raises(), r"providers\[0\] \(broken\): raised ZeroDivisionError"),
     (WrongShape(), r"providers\[0\] \(wrong\): rows\(\) expected G"),
     (NaNRows(), r"providers\[0\] \(nan\): rows\(\) expected finite")],
)  # fmt: skip
def test_a_bad_provider_is_named(provider: Any, match: str) -> None:
    f = crowded(providers=[provider], workspace=(), obstacles=())
    with pytest.raises(InvalidInput, match=match):
        f.filter(Q0, np.zeros(7))


@pytest.mark.parametrize("level", [5, -1, "1", None, True])
def test_a_provider_level_is_validated(level: Any) -> None:
    p = KeepOutOfSlab()
    p.level = level  # type: ignore[assignment]
    with pytest.raises(InvalidParameter, match=r"providers\[0\]: expected level 0-4"):
        crowded(providers=[p])


# ------------------------------------------------------------------------------ bad kinematics
class Faulty:
    """The arm through its public protocol, with a fault injected into its frame."""

    def __init__(self, fault: str) -> None:
        self.fault = fault
        self.dof = ARM.dof
        self.joint_names = ARM.joint_names
        self.points = ARM.points
        self.link_radius = ARM.link_radius
        self.calls = 0

    def fk(self, q: Any, point: str = "tcp") -> Any:
        return ARM.fk(q, point)

    def jacobian(self, q: Any, point: str = "tcp") -> Any:
        return ARM.jacobian(q, point)

    def kinematics(self, q: Any) -> Any:
        self.calls += 1
        return _FaultyFrame(ARM.kinematics(q), self.fault if self.calls > 1 else "")


class _FaultyFrame:
    def __init__(self, inner: Any, fault: str) -> None:
        self.inner = inner
        self.fault = fault

    def point(self, name: str) -> Any:
        p = self.inner.point(name)
        if self.fault == "nan":
            return p * np.nan
        return p[:2] if self.fault == "shape" else p

    def jacobian(self, name: str) -> Any:
        return self.inner.jacobian(name)

    def segments(self) -> Any:
        s = self.inner.segments()
        return s[:-1] if self.fault == "links" else s

    def point_jacobian(self, link: int, t: float) -> Any:
        return self.inner.point_jacobian(link, t)


@pytest.mark.parametrize(
    ("fault", "match"),
    [("nan", r"robot: kinematics\(q\)\.point\('tcp'\) expected finite"),
     ("shape", r"robot: kinematics\(q\)\.point\('tcp'\) expected shape \(3,\)"),
     ("links", r"robot: inconsistent chain data")],
)  # fmt: skip
def test_bad_kinematics_are_named_never_passed_on(fault: str, match: str) -> None:
    lim = ARM.joint_limits
    p0 = ARM.fk(Q0)
    flt = SafetyFilter(
        Faulty(fault), limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5)),
        workspace=WorkspaceLimit(ConvexPolytope.box(p0 - 0.1, p0 + 0.1)),
        obstacles=[SphereObstacle(p0 + 0.3, radius=0.05)], dt=1e-3,
    )  # fmt: skip
    with pytest.raises(InvalidInput, match=match):
        flt.filter(Q0, np.ones(7))


def test_inconsistent_chain_data_is_refused_at_construction() -> None:
    class BadData(Faulty):
        def chain_data(self) -> Any:
            return ARM.chain_data().__class__(dh=np.zeros((3, 5)), tool=np.zeros(3), point_index={})

    lim = ARM.joint_limits
    with pytest.raises(InvalidParameter, match=r"robot: inconsistent chain data"):
        SafetyFilter(
            BadData(""), limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5))
        )


def test_every_error_is_a_velfence_error() -> None:
    assert issubclass(InvalidInput, VelfenceError)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_tool_resting_on_tilted_planes_with_joints_at_limits_stays_in(seed: int) -> None:
    """The issue's drift scene (UR5e, 500 Hz, two tilted planes, the tool on both planes, three
    joints at a limit, a command pushing out): no step leaves a plane beyond round-off, no joint
    crosses its limit, and no workspace row is ever dropped."""
    robot = DHChain.ur5e()
    dt = 2e-3
    rng = np.random.default_rng(seed)
    q = np.array([0.0, -1.2, 1.5, -1.9, -1.57, 0.0]) + rng.normal(scale=0.2, size=6)
    tw, tf = np.radians(rng.uniform(5, 40, 2))
    N = np.array([[np.cos(tw), 0.0, np.sin(tw)], [0.0, np.sin(tf), np.cos(tf)]])
    planes = ConvexPolytope(N, N @ robot.fk(q), facet_names=("wall", "floor"))
    lo, hi = q - rng.uniform(0.2, 1.0, 6), q + rng.uniform(0.2, 1.0, 6)
    for j in rng.choice(6, 3, replace=False):
        (lo if rng.random() < 0.5 else hi)[j] = q[j]
    f = SafetyFilter(
        robot, limits=JointLimits(lo, hi, max_speed=np.full(6, np.pi)),
        workspace=WorkspaceLimit(planes, buffer=0.04), dt=dt,
    )  # fmt: skip
    for _ in range(250):
        r = f.explain_twist(q, -N.sum(axis=0) * 0.2 + rng.normal(scale=0.1, size=3))
        assert not any(s.startswith("dropped workspace") for s in r.stages)
        d0 = planes.signed_distances(robot.fk(q))
        q = q + dt * r.output
        d1 = planes.signed_distances(robot.fk(q))
        assert np.all(d1 >= np.minimum(0.0, d0) - 1e-12)
        assert np.all(q >= lo - 1e-12)
        assert np.all(q <= hi + 1e-12)


def test_only_violated_recovery_bounds_are_relaxed_slower_first() -> None:
    """A workspace recovery (x >= 1, outside) against a joint speed limit (x <= 0.5): the ladder
    keeps the speed row and slows the recovery to a quarter (x >= 0.25), not to zero."""
    from velfence.filter import LEVEL_JOINT
    from velfence.filter.solve import python_solve

    G = np.array([[1.0], [-1.0]])
    b = np.array([1.0, -0.5])
    level = np.array([LEVEL_WORKSPACE, LEVEL_JOINT])
    violated = np.array([True, False])
    u = np.array([-2.0])
    out = run_ladder(G, b, level, violated, lambda G, b, w: python_solve(u, G, b, 0, w))
    assert out.relaxed == [0]
    assert out.stages == ["relaxed workspace"]
    assert out.x[0] == pytest.approx(0.25)


def test_the_model_check_keeps_outside_rows_from_going_further_out() -> None:
    """An outside row (d0 < 0) whose linearisation misses a second-order loss: the model check
    raises its bound until the true next distance is no further out (d1 >= d0)."""
    from velfence.filter.solve import python_solve

    dt = 1e-3
    G = np.array([[1.0, 0.0]])
    b = np.array([0.0])  # "no further out", as linearised
    d0 = np.array([-0.01])
    u = np.array([-1.0, 3.0])

    def nxt(x: np.ndarray) -> np.ndarray:  # the true distance loses |x_1|² dt² (a curvature)
        return d0 + dt * x[:1] - (dt * x[1]) ** 2

    out = run_ladder(
        G, b, np.array([LEVEL_WORKSPACE]), np.array([True]),
        lambda G, b, w: python_solve(u, G, b, 0, w),
        checked=np.array([0]), d0=d0, next_distances=nxt, dt=dt,
    )  # fmt: skip
    assert "model-check" in out.stages
    assert nxt(out.x)[0] >= d0[0]
    # without the model check the linear answer would go further out
    assert nxt(np.array([0.0, 3.0]))[0] < d0[0]
