"""Self-collision rows: the C cycle equals the Python oracle, and the rows are what they claim.

Sibling of ``test_filter_cycle_equal.py`` (its safety checks are reused) with
``self_collision=`` on: random UR5e / 7-joint arms with random capsule radii, joints anywhere in
their range, at a limit or beyond it (so link pairs near, touching and penetrating), a box
around the tool and sphere obstacles, ``dt`` unset / 1 ms / 10 ms, random excluded pairs. The
C cycle (``vf_self_row`` rows, key ``(LEVEL_OBSTACLE, k + i, j)``) must build the rows of
:class:`~velfence.filter.SelfCollisionRows` (names, ``G``, ``b``) and return the same output.
Independently: each row's ``G`` is the clearance's derivative (central differences of the
clearance along random joint directions, from the robot's own kinematics), and bad
self-collision options are refused naming the argument.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from test_filter_cycle_equal import _model_borderline, _safe

from velfence.errors import InvalidParameter
from velfence.filter import (
    Capsule,
    JointLimits,
    SafetyFilter,
    SelfCollision,
    Sphere,
    SphereObstacle,
    WorkspaceLimit,
)
from velfence.geometry.polytope import ConvexPolytope
from velfence.geometry.primitives import segment_segment_distance
from velfence.mechanisms.chain import DHChain

_filter = pytest.importorskip("velfence_core._filter")
from velfence.filter.ccycle import filter_cycle  # noqa: E402

#: The scenes start anywhere, inside a limit or beyond it: the start warning is not the point.
pytestmark = pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")


def _scene(rng: np.random.Generator) -> dict[str, Any]:
    ur = bool(rng.integers(2))
    lrad = float(rng.uniform(0.0, 0.08))
    tool = (0.0, 0.0, float(rng.uniform(0.0, 0.2)))
    robot = (DHChain.ur5e if ur else DHChain.seven_dof)(link_radius=lrad, tool=tool)
    n = robot.dof
    lo, hi = robot.joint_limits[:, 0], robot.joint_limits[:, 1]
    q = lo + rng.uniform(0, 1, n) * (hi - lo)
    for j in range(n):
        k = rng.integers(6)
        if k == 0:
            q[j] = lo[j]
        elif k == 1:
            q[j] = hi[j] + 0.02
    vmax = rng.uniform(0.3, 3.0, n)
    amax = rng.uniform(2.0, 40.0, n) if rng.integers(2) else None
    dt = [None, 1e-3, 1e-2][int(rng.integers(3))]
    prev = rng.uniform(-1, 1, n) * vmax if dt is not None and rng.integers(2) else None
    u = rng.uniform(-1, 1, n) * float(rng.choice([1e-3, 0.3, 1.0, 3.0]))
    tcp = robot.fk(q, "tcp")
    half = rng.uniform(0.1, 0.6, 3)
    c = tcp + rng.uniform(-0.6, 0.6, 3) * half + 1e-9 * np.sqrt([2.0, 3.0, 5.0])
    box = WorkspaceLimit(
        ConvexPolytope.box(c - half, c + half), buffer=float(rng.uniform(0.01, 0.2))
    )
    pts = robot.joint_positions(q)
    obs = []
    for _ in range(int(rng.integers(0, 4))):
        k = int(rng.integers(n))
        p = pts[k] + rng.uniform() * (pts[k + 1] - pts[k])
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        r = float(rng.uniform(0.01, 0.1))
        obs.append(SphereObstacle(center=p + d * (lrad + r + rng.uniform(-0.02, 0.2)), radius=r))
    pairs_all = [(i, j) for i in range(n) for j in range(i + 2, n)]
    ex = [pairs_all[int(k)] for k in rng.choice(len(pairs_all), int(rng.integers(0, 3)))]
    sf = SafetyFilter(
        robot, limits=JointLimits(lo, hi, max_speed=vmax, max_acceleration=amax), workspace=box,
        obstacles=obs, self_collision=SelfCollision(exclude=ex), dt=dt,
        obstacle_buffer=float(rng.uniform(0.01, 0.3)), spring_gain=float(rng.uniform(0, 5)),
        backend="python",
    )  # fmt: skip
    return {"sf": sf, "q": q, "u": u, "prev": prev}


def _check(sc: dict[str, Any]) -> int:
    sf, q, u, prev = sc["sf"], sc["q"], sc["u"], sc["prev"]
    fc = filter_cycle(sf)
    ref = sf.explain(q, u, previous=prev)
    x = fc.cycle(q, u, prev)
    G, b, level, ka, kb, _, _, bound = fc.rows()
    keys = list(zip(level.tolist(), ka.tolist(), kb.tolist(), strict=True))
    names = sf._c_names(keys)
    assert names == list(ref.constraint_names)
    G0, b0 = ref.rows
    np.testing.assert_allclose(G, G0, rtol=1e-9, atol=1e-12 * max(1.0, float(np.abs(G0).max())))
    np.testing.assert_allclose(b, b0, rtol=1e-9, atol=1e-12 * max(1.0, float(np.abs(b0).max())))
    self_rows = [r for r, nm in enumerate(names) if " and link " in nm]
    if _model_borderline(sf, q, u, prev, (x, ref.output)):
        _safe(x, u, G, b, level, bound)
        return len(self_rows)
    # a pair whose row is round-off (a clearance no joint can change) makes the answer's
    # direction round-off too: both routes are safe, not equal
    tiny = any(float(np.abs(G[r]).sum()) < 1e-9 for r in self_rows)
    if not tiny:
        big = max(float(np.abs(ref.output).max()), float(np.abs(u).max()), 1e-300)
        np.testing.assert_allclose(x, ref.output, rtol=1e-9, atol=1e-9 * big)
    _safe(x, u, G, b, level, bound)
    return len(self_rows)


def test_c_cycle_self_collision_equals_the_python_oracle() -> None:
    rng = np.random.default_rng(2029)
    rows = 0
    for _ in range(100):
        rows += _check(_scene(rng))
    assert rows > 100  # (the scenes do exercise the rows)


@pytest.mark.slow
def test_c_cycle_self_collision_equals_the_python_oracle_many() -> None:
    rng = np.random.default_rng(11)
    for _ in range(600):
        _check(_scene(rng))


def test_self_row_is_the_clearance_derivative() -> None:
    """G of each self row is d(clearance)/dq along any direction (central differences)."""
    robot = DHChain.seven_dof(link_radius=0.04)
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.full(7, 1.0))
    sf = SafetyFilter(robot, limits=lim, self_collision=True, obstacle_buffer=2.0, backend="python")
    rng = np.random.default_rng(4)
    checked = 0
    for _ in range(20):
        q = rng.uniform(-2, 2, 7)
        res = sf.explain(q, np.zeros(7))
        G, _ = res.rows
        for r, nm in enumerate(res.constraint_names):
            if " and link " not in nm:
                continue
            i, j = (int(w) for w in nm.replace("link ", "").split(" and "))
            v = rng.normal(size=7)
            h = 1e-6

            def clear(qq: Any, i: int = i, j: int = j) -> float:
                s = robot.link_segments(qq)
                return segment_segment_distance(s[i, 0], s[i, 1], s[j, 0], s[j, 1])

            fd = (clear(q + h * v) - clear(q - h * v)) / (2 * h)
            if clear(q) > 1e-3:  # (away from a crossing, where the distance has no derivative)
                assert math.isclose(float(G[r] @ v), fd, rel_tol=1e-5, abs_tol=1e-7)
                checked += 1
    assert checked > 50


def test_bad_self_collision_options_name_the_argument() -> None:
    robot = DHChain.ur5e(link_radius=0.03)
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.ones(6))
    with pytest.raises(InvalidParameter, match=r"self_collision.exclude\[0\].*link 2 twice"):
        SelfCollision(exclude=[(2, 2)])
    with pytest.raises(InvalidParameter, match=r"self_collision.exclude\[1\]"):
        SelfCollision(exclude=[(0, 3), (1, -1)])
    with pytest.raises(InvalidParameter, match=r"self_collision.exclude\[0\].*link 9"):
        SafetyFilter(robot, limits=lim, self_collision=SelfCollision(exclude=[(0, 9)]))
    with pytest.raises(InvalidParameter, match="self_collision: expected"):
        SafetyFilter(robot, limits=lim, self_collision="yes")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"self_collision\.min_gap"):
        SelfCollision(min_gap=0)


def test_default_pairs_leave_out_links_that_always_touch() -> None:
    """Adjacent links, and links joined through links shorter than their radii, are out."""
    robot = DHChain.seven_dof(link_radius=0.05)  # links 1, 3, 5 have zero length
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.ones(7))
    sf = SafetyFilter(robot, limits=lim, self_collision=True)
    pairs = set(sf.self_collision_pairs)
    assert not pairs & {(0, 2), (2, 4), (4, 6)}
    assert {(0, 3), (2, 5)} <= pairs
    assert all(j - i >= 2 for i, j in pairs)
    sf2 = SafetyFilter(robot, limits=lim, self_collision=SelfCollision(exclude=[(3, 0)]))
    assert set(sf2.self_collision_pairs) == pairs - {(0, 3)}
    # the C cycle is built with the same pairs and runs them
    sf3 = SafetyFilter(robot, limits=lim, self_collision=True, backend="c")
    assert sf3.cycle_in_c


# ------------------------------------------------------------------------------- attachments
def _with_shapes(sc: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    """The scene's filter rebuilt with 1-3 random spheres / capsules on random links."""
    sf = sc["sf"]
    n = sf.dof
    shapes: dict[str, Any] = {}
    for k in range(int(rng.integers(1, 4))):
        link: Any = "tcp" if rng.integers(2) else int(rng.integers(-1, n + 1))
        r = float(rng.uniform(0.0, 0.08))
        if rng.integers(2):
            shapes[f"s{k}"] = Capsule(link, rng.normal(size=3) * 0.1, rng.normal(size=3) * 0.1,
                                      radius=r)  # fmt: skip
        else:
            shapes[f"s{k}"] = Sphere(link, rng.normal(size=3) * 0.1, radius=r)
    sf2 = SafetyFilter(
        sf.robot, limits=sf.limits, workspace=sf.workspace, obstacles=sf.obstacles,
        self_collision=bool(sf.self_collision_pairs), attachments=shapes, dt=sf.dt,
        obstacle_buffer=sf.obstacle_buffer, spring_gain=sf.spring_gain, backend="python",
    )  # fmt: skip
    if rng.integers(2):  # a release and a grasp
        sf2.detach("s0")
        sf2.attach("held", Sphere("tcp", [0.0, 0.0, 0.05], radius=0.03))
    return {**sc, "sf": sf2}


def test_c_cycle_attachments_equal_the_python_oracle() -> None:
    rng = np.random.default_rng(77)
    for _ in range(80):
        _check(_with_shapes(_scene(rng), rng))


def test_attach_and_detach_reach_the_filters_own_c_cycle() -> None:
    """Grasp / release on a filter running the C cycle: its output equals the oracle's."""
    rng = np.random.default_rng(8)
    robot = DHChain.seven_dof(link_radius=0.04, tool=(0.0, 0.0, 0.1))
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.full(7, 1.5))
    box = WorkspaceLimit(ConvexPolytope.box([-0.7, -0.7, 0.0], [0.7, 0.7, 1.3]))
    obs = [SphereObstacle(center=[0.4, 0.2, 0.8], radius=0.1)]
    kw: dict[str, Any] = {"workspace": box, "obstacles": obs, "dt": 0.01, "self_collision": True}
    tool = {"tool": Capsule("tcp", [0, 0, 0], [0, 0, 0.12], radius=0.03)}
    c = SafetyFilter(robot, limits=lim, attachments=tool, backend="c", **kw)
    p = SafetyFilter(robot, limits=lim, attachments=tool, backend="python", **kw)
    assert c.cycle_in_c
    held = Capsule(6, [0.05, 0, 0.1], [0.05, 0, 0.3], radius=0.05)
    seen = {"box": 0, "tool": 0}
    for step in range(40):
        if step == 10:
            c.attach("box", held)
            p.attach("box", held)
        if step == 25:
            c.detach("tool")
            p.detach("tool")
        q = rng.uniform(-1.5, 1.5, 7)
        u = rng.normal(size=7)
        rc, rp = c.explain(q, u), p.explain(q, u)
        assert rc.constraint_names == rp.constraint_names
        np.testing.assert_allclose(rc.output, rp.output, rtol=1e-9, atol=1e-9)
        for key in seen:
            seen[key] += sum(nm.split(" ")[0] == key for nm in rc.constraint_names)
        if step >= 25:
            assert not any(nm.startswith("tool ") for nm in rc.constraint_names)
    assert seen["box"] > 0
    assert seen["tool"] > 0


def test_bad_attachments_name_the_argument() -> None:
    robot = DHChain.ur5e(link_radius=0.03)
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.ones(6))
    with pytest.raises(InvalidParameter, match="radius"):
        Capsule("tcp", [0, 0, 0], [0, 0, 0.1], radius=-0.01)
    with pytest.raises(InvalidParameter, match="radius"):
        Sphere(2, [0, 0, 0], radius=float("nan"))
    with pytest.raises(InvalidParameter, match="link"):
        Sphere("flange", [0, 0, 0], radius=0.1)
    with pytest.raises(InvalidParameter, match=r"attachments\[0\]\.link: link 9 does not exist"):
        SafetyFilter(robot, limits=lim, attachments=[Sphere(9, [0, 0, 0], radius=0.1)])
    sf = SafetyFilter(robot, limits=lim, attachments={})
    with pytest.raises(InvalidParameter, match=r"shape\.link: link 7 does not exist"):
        sf.attach("x", Capsule(7, [0, 0, 0], [0, 0, 1], radius=0.1))
    with pytest.raises(InvalidParameter, match="name: no shape 'x'"):
        sf.detach("x")
    with pytest.raises(InvalidParameter, match="without attachments"):
        SafetyFilter(robot, limits=lim).attach("x", Sphere(0, [0, 0, 0], radius=0.1))


def test_the_c_check_refuses_bad_pairs_and_shapes() -> None:
    """vf_filter_check: a pair naming one link twice or out of range, a shape of negative
    radius or on a missing link; set_attachments keeps the old table when refused."""
    robot = DHChain.ur5e(link_radius=0.03)
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.ones(6))
    tcp = robot.fk(np.zeros(6), "tcp")
    box = WorkspaceLimit(ConvexPolytope.box(tcp - 0.13, tcp + 0.13))  # the tool's rows in reach
    tool = {"tool": Capsule("tcp", [0, 0, 0], [0, 0, 0.1], radius=0.02)}
    sf = SafetyFilter(robot, limits=lim, workspace=box, self_collision=True, attachments=tool,
                      backend="c")  # fmt: skip
    fc = sf._ccycle
    assert fc is not None
    q, u = np.zeros(6), np.full(6, 0.5)
    x0 = fc.cycle(q, u).copy()
    for bad in (
        [6.0, 0, 0, 0, 0, 0, 0.1, 0.02],  # link 6 of a 6-joint arm is the tool (ok) ...
        [7.0, 0, 0, 0, 0, 0, 0.1, 0.02],  # ... link 7 does not exist
        [6.0, 0, 0, 0, 0, 0, 0.1, -0.02],  # negative radius
        [6.0, 0, 0, 0, 0, 0, float("nan"), 0.02],
    )[1:]:
        with pytest.raises(ValueError, match="attachments"):
            fc.set_attachments(bad)
        np.testing.assert_array_equal(fc.cycle(q, u), x0)  # the old table still in use
    fc.set_attachments([6.0, 0, 0, 0, 0, 0, 0.1, 0.02])
    np.testing.assert_array_equal(fc.cycle(q, u), x0)  # the same shape as built
    assert any(k[0] == _filter.LEVEL_WORKSPACE and k[2] >= 6 for k in _keys(fc))
    fc.set_attachments([])
    fc.cycle(q, u)
    assert not any(k[0] == _filter.LEVEL_WORKSPACE and k[2] >= 6 for k in _keys(fc))
    args = _cycle_args(sf)
    for pairs in ([2, 2], [3, 1], [0, 6], [-1, 2], [0]):
        with pytest.raises(ValueError, match=r"self_pairs|invalid"):
            _filter.FilterCycle(*args, self_pairs=pairs)


def _keys(fc: Any) -> list[tuple[int, int, int]]:
    _, _, level, ka, kb, *_ = fc.rows()
    return list(zip(level.tolist(), ka.tolist(), kb.tolist(), strict=True))


def _cycle_args(sf: Any) -> tuple[Any, ...]:
    """The positional arguments filter_cycle passes for ``sf`` (captured from the binding)."""
    seen: dict[str, Any] = {}

    class Capture:
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            seen["args"] = args

        def set_options(self, **kwargs: Any) -> None:
            pass

    import velfence.filter.ccycle as cc

    real = cc.compiled_filter

    class Fake:
        FilterCycle = Capture

    cc.compiled_filter = lambda: Fake  # type: ignore[assignment]
    try:
        cc.filter_cycle(sf)
    finally:
        cc.compiled_filter = real  # type: ignore[assignment]
    return tuple(seen["args"])
