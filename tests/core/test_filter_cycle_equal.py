"""The safety filter's whole cycle in C (``velfence_filter.h``) equals the Python oracle.

Random scenes drawn by hypothesis over whole joint ranges: a UR5e or a 7-joint arm (DH chains)
with random tool, capsule radii, joint speed and acceleration limits, joints anywhere in their
range, exactly at a limit or beyond it, a box around the tool point (sometimes with the tool
outside), sphere obstacles near the links (some penetrating), ``dt`` unset or 1 ms / 10 ms, with
and without a previous output (and with jerk limits, with and without the output before it, some
far enough from it that the jerk rows conflict with the acceleration rows), commands from tiny to
beyond the command cap. Per scene the C cycle
(``velfence_core._filter.FilterCycle``, built by ``velfence.filter.ccycle.filter_cycle``) and
:meth:`velfence.filter.SafetyFilter.explain` must build the same rows (names, ``G`` and ``b`` to
1e-9 relative) and return the same output (1e-9 relative), the same stages, relaxed rows,
deadline and active rows. Independently of the oracle: every row of the safety levels is met at
least in its "no further out" form ``min(b, 0)``, every claimed bound is met, and an answer of the
first rung without a model-check raise is the projection of the command onto the rows
(:func:`velfence.geometry.projection.project`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.geometry.projection import project
from velfence.mechanisms.chain import DHChain

_filter = pytest.importorskip("velfence_core._filter")
from velfence.filter.ccycle import filter_cycle  # noqa: E402

#: The scenes start anywhere, inside a limit or beyond it: the start warning is not the point.
pytestmark = pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")

_STAGE_BITS = {
    "projection": _filter.STAGE_PROJECTION,
    "recovery": _filter.STAGE_RECOVERY,
    "model-check": _filter.STAGE_MODEL_CHECK,
    "dropped acceleration": _filter.STAGE_DROPPED_RATE,
    "dropped jerk": _filter.STAGE_DROPPED_JERK,
    "relaxed obstacles": _filter.STAGE_RELAXED_OBSTACLES,
    "relaxed workspace": _filter.STAGE_RELAXED_WORKSPACE,
    "relaxed joint limits": _filter.STAGE_RELAXED_JOINT,
    "stop": _filter.STAGE_STOP,
    "deadline": _filter.STAGE_DEADLINE,
    "command-scaled": _filter.STAGE_COMMAND_SCALED,
    "model-scaled": _filter.STAGE_MODEL_SCALED,
}
_SIDES = ("lower", "upper")


def _name(key: tuple[int, int, int], facets: tuple[str, ...]) -> str:
    """The oracle's row name of a C row key."""
    lv, a, b = key
    if lv == _filter.LEVEL_JOINT:
        what = "position" if b < 2 else "velocity"
        return f"joint {a} {what} ({_SIDES[b % 2]})"
    if lv == _filter.LEVEL_RATE:
        return f"joint {a} acceleration ({_SIDES[b]})"
    if lv == _filter.LEVEL_JERK:
        return f"joint {a} jerk ({_SIDES[b]})"
    if lv == _filter.LEVEL_WORKSPACE:
        return f"TCP face {facets[b]}"
    return f"obstacle {a} on link {b}"


@st.composite
def scenes(draw: Any) -> dict[str, Any]:
    """A random filter, state and command."""
    ur = draw(st.booleans())
    u01 = st.floats(0.0, 1.0)
    tool = (0.0, 0.0, draw(st.floats(0.0, 0.2)))
    lrad = draw(st.floats(0.0, 0.06))
    robot = (
        DHChain.ur5e(link_radius=lrad, tool=tool)
        if ur
        else DHChain.seven_dof(link_radius=lrad, tool=tool)
    )
    n = robot.dof
    lo, hi = robot.joint_limits[:, 0], robot.joint_limits[:, 1]
    vmax = np.array([draw(st.floats(0.3, 3.0)) for _ in range(n)])
    has_acc = draw(st.booleans())
    amax = np.array([draw(st.floats(2.0, 40.0)) for _ in range(n)]) if has_acc else None
    # joints anywhere in their range, at a limit, or beyond it
    q = np.empty(n)
    for j in range(n):
        kind = draw(st.sampled_from(("in", "in", "lo", "hi", "out")))
        t = draw(u01)
        if kind == "in":
            q[j] = lo[j] + t * (hi[j] - lo[j])
        elif kind == "lo":
            q[j] = lo[j]
        elif kind == "hi":
            q[j] = hi[j]
        else:
            q[j] = (lo[j] - 0.05 * t) if t < 0.5 else (hi[j] + 0.05 * t)
    scale = draw(st.sampled_from((1e-3, 0.3, 1.0, 3.0, 1e4)))
    u = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(n)]) * scale
    dt = draw(st.sampled_from((None, 1e-3, 1e-2)))
    prev = prev2 = None
    if dt is not None and draw(st.booleans()):
        prev = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(n)]) * vmax
        if draw(st.booleans()):
            step = draw(st.sampled_from((0.01, 0.2)))
            prev2 = prev + np.array([draw(st.floats(-1.0, 1.0)) for _ in range(n)]) * vmax * step
    jmax = None
    if draw(st.booleans()):
        jmax = np.array([draw(st.floats(50.0, 5000.0)) for _ in range(n)])
        if draw(st.booleans()):
            jmax[draw(st.integers(0, n - 1))] = math.inf  # a joint without one
    tcp = robot.fk(q, "tcp")
    half = np.array([draw(st.floats(0.05, 0.6)) for _ in range(3)])
    shift = (
        np.array([draw(st.floats(-1.0, 1.0)) for _ in range(3)])
        * half
        * draw(st.sampled_from((0.5, 1.2)))
    )
    # (irrational jitter: no distance lands exactly on a buffer's edge, where the two routes'
    # round-off would decide whether a row exists)
    centre = tcp + shift + 1e-9 * np.sqrt([2.0, 3.0, 5.0])
    box = WorkspaceLimit(
        ConvexPolytope.box(centre - half, centre + half),
        point="tcp",
        buffer=draw(st.floats(0.01, 0.2)),
    )
    pts = robot.joint_positions(q)
    obstacles = []
    for _ in range(draw(st.integers(0, 8))):
        k = draw(st.integers(0, n - 1))
        p = pts[k] + draw(u01) * (pts[k + 1] - pts[k])
        d = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(3)]) + 1e-3
        d /= np.linalg.norm(d)
        r = draw(st.floats(0.01, 0.1))
        gap = draw(st.floats(-0.02, 0.2))
        jitter = 1e-9 * np.sqrt([7.0, 11.0, 13.0])
        obstacles.append(SphereObstacle(center=p + d * (lrad + r + gap) + jitter, radius=r))
    weights = None
    if draw(st.integers(0, 4)) == 0:
        weights = [draw(st.floats(0.2, 5.0)) for _ in range(n)]
    limits = JointLimits(lo, hi, max_speed=vmax, max_acceleration=amax, max_jerk=jmax)
    sf = SafetyFilter(
        robot, limits=limits, workspace=box,
        obstacles=obstacles, dt=dt, weights=weights,
        obstacle_buffer=draw(st.floats(0.01, 0.3)), spring_gain=draw(st.floats(0.0, 5.0)),
        backend="python",  # the oracle: the Python route (backend="auto" would run the C cycle)
    )  # fmt: skip
    if prev is not None and sf.stateful:
        # the oracle's remembered outputs (explain(previous=...) would build no jerk rows)
        sf._previous, sf._previous2 = prev, prev2
    return {
        "sf": sf, "q": q, "u": u, "prev": prev, "prev2": prev2,
        "facets": box.polytope.facet_names,
    }  # fmt: skip


def _model_borderline(sf: Any, q: Any, u: Any, prev: Any, xs: tuple[Any, ...]) -> bool:
    """Whether a model-checked row's next distance is within round-off of its target."""
    if sf.dt is None:
        return False
    cap = 1e3 * float(np.max(sf.limits.max_speed))
    big = float(np.abs(u).max())
    uc = u * (cap / big) if big > cap else u
    cyc = sf._build_rows(q, uc, prev if sf.stateful else None)  # (the Python providers)
    if not len(cyc.checked):
        return False
    nxt = sf._next_distances(q, cyc)
    target = np.minimum(0.0, cyc.d0)
    return any(bool(np.any(np.abs(nxt(x) - target) <= 1e-12 * (1.0 + np.abs(cyc.d0)))) for x in xs)


def _safe(x: Any, u: Any, G: Any, b: Any, level: Any, bound: Any) -> None:
    """Every row met: "no further out" (min(b, 0)) for the safety levels, and every claim, to
    the round-off of forming x from u: 1e-12 (|c| + |g|_1 (|x|_inf + |u|_inf)) (spec-24 2)."""
    gx = G @ x
    xi = float(np.abs(x).max()) + float(np.abs(u).max())
    g1 = np.abs(G).sum(axis=1)
    c = np.minimum(b, 0.0)
    safety = (level != _filter.LEVEL_RATE) & (level != _filter.LEVEL_JERK)
    assert np.all((gx - c >= -1e-12 * (np.abs(c) + g1 * xi))[safety])
    claimed = bound != -math.inf
    assert np.all((gx - bound >= -1e-12 * (np.abs(bound) + g1 * xi))[claimed])


def _near_axis(sf: Any, level: Any, ka: Any, kb: Any, dist: Any) -> bool:
    """Whether an obstacle row's centre lies within 1 µm of its link's axis."""
    link_r = np.asarray(sf.robot.link_radius, dtype=float).reshape(-1)
    for lv, a, b, d in zip(level.tolist(), ka.tolist(), kb.tolist(), dist.tolist(), strict=True):
        if lv == _filter.LEVEL_OBSTACLE:
            axis = d + link_r[b] + sf._obstacles[a].radius
            if abs(axis) < 1e-6:
                return True
    return False


def _check(scene: dict[str, Any]) -> None:
    sf, q, u, prev, prev2 = scene["sf"], scene["q"], scene["u"], scene["prev"], scene["prev2"]
    fc = filter_cycle(sf)
    ref = sf.explain(q, u) if prev is not None and sf.stateful else sf.explain(q, u, previous=prev)
    x = fc.cycle(q, u, prev, None, prev2 if sf._has_jerk else None)
    info = fc.info()
    G, b, level, ka, kb, dist, slack, bound = fc.rows()
    keys = list(zip(level.tolist(), ka.tolist(), kb.tolist(), strict=True))
    names = [_name(k, scene["facets"]) for k in keys]
    # the same rows
    assert names == list(ref.constraint_names), (
        set(names) ^ set(ref.constraint_names),
        dist[[nm not in ref.constraint_names for nm in names]],
    )
    G0, b0 = ref.rows
    # an obstacle centre within a micrometre of a link's axis: the row's direction (from the
    # axis to the centre) is round-off for both routes, and exactly on the axis any direction is
    # right; then the rows and answers may differ and only the safety checks apply
    if _near_axis(sf, level, ka, kb, dist):
        _safe(x, u, G, b, level, bound)
        _safe(ref.output, u, G0, b0, level, np.full_like(bound, -math.inf))
        return
    scale_g = max(1.0, float(np.abs(G0).max(initial=0.0)))
    np.testing.assert_allclose(G, G0, rtol=1e-9, atol=1e-12 * scale_g)
    np.testing.assert_allclose(
        b, b0, rtol=1e-9, atol=1e-12 * max(1.0, float(np.abs(b0).max(initial=0.0)))
    )
    # the model check's d1 >= min(0, d0) has no tolerance: a row whose next distance is within
    # round-off of its target (a row the motion cannot change, say) may pass for one route's
    # kinematics and fail for the other's (both safe); then only the safety checks below apply
    if _model_borderline(sf, q, u, prev, (x, ref.output)):
        _safe(x, u, G, b, level, bound)
        return
    # the same answer and report
    # (relative to the output's and the command's size: an output of 1e-19 where the command is
    # 1e-3 is zero to the solve's round-off)
    big = max(float(np.abs(ref.output).max()), float(np.abs(u).max()), 1e-300)
    np.testing.assert_allclose(
        x, ref.output, rtol=1e-9, atol=1e-9 * big,
        err_msg=f"{ref.stages} {info} rows {len(b)} min dist {np.min(dist, initial=np.inf)}",
    )  # fmt: skip
    # a distance within round-off of 0 is "violated" for one route and not the other (both are
    # right); the report then may differ, the output not
    borderline = bool(np.any(np.abs(dist) <= 1e-12))
    bits = 0
    for s in ref.stages:
        bits |= _STAGE_BITS[s]
    if not borderline:
        assert info["stages"] == bits, (ref.stages, info)
        # the violated rows and their depths: the C cycle's distances below zero
        viol = np.flatnonzero(dist < 0.0).tolist()
        assert [nm for nm, _ in ref.violations] == [names[i] for i in viol]
        np.testing.assert_allclose(
            [d for _, d in ref.violations], -dist[viol], rtol=1e-9, atol=1e-12
        )
        assert {_name(k, scene["facets"]) for k in fc.relaxed()} == set(ref.relaxed)
    assert info["deadline"] == {None: 0, "iterations": 1, "time": 2}[ref.deadline]
    # the active rows, up to round-off at the 1e-9 threshold
    tol = 1e-9 * (1.0 + np.abs(b))
    unsure = np.abs(slack - tol) <= 1e-10 * (1.0 + np.abs(b)) + 1e-12
    mine = {names[i] for i in range(len(names)) if (slack[i] <= tol[i] or dist[i] < 0.0)}
    theirs = set(ref.active_names)
    if not borderline:
        assert {nm for nm in mine ^ theirs if not unsure[names.index(nm)]} == set()
    _safe(x, u, G, b, level, bound)
    # ... and a first-rung answer without a raise is the projection of u onto the rows
    if (
        info["rung"] == 1
        and not info["stages"] & (_filter.STAGE_MODEL_CHECK | _filter.STAGE_MODEL_SCALED)
        and info["stages"] & _filter.STAGE_PROJECTION
        and sf._metric is None
        and not info["stages"] & _filter.STAGE_COMMAND_SCALED
        and len(b)
    ):
        p = project(u, G, b)
        if p.feasible:
            xi = float(np.abs(x).max())
            np.testing.assert_allclose(x, p.x, rtol=1e-9, atol=1e-9 * max(xi, 1e-300))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenes())
def test_c_cycle_equals_the_python_oracle(scene: dict[str, Any]) -> None:
    _check(scene)


def test_deadline_fallback_equals_the_oracle() -> None:
    """With an iteration cap of 1 the C cycle and the oracle take the same safe fallback."""
    from velfence.geometry import projection

    if not hasattr(projection, "project_kernel_opts"):
        pytest.skip("the oracle's iteration cap needs project_kernel_opts (spec-24 section 2)")
    robot = DHChain.seven_dof(link_radius=0.05)
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.full(7, 1.5))
    box = WorkspaceLimit(ConvexPolytope.box([-0.5, -0.5, 0.2], [0.5, 0.5, 1.2]), point="tcp")
    rng = np.random.default_rng(11)
    seen = 0
    for _ in range(60):
        sf = SafetyFilter(
            robot, limits=lim, workspace=box, dt=0.001, max_iterations=1, backend="python"
        )
        fc = filter_cycle(sf)
        fc.set_options(max_iterations=1)
        q = rng.uniform(-2.5, 2.5, 7)
        u = rng.normal(size=7) * 3.0
        ref = sf.explain(q, u)
        x = fc.cycle(q, u)
        np.testing.assert_allclose(x, ref.output, rtol=1e-9, atol=1e-12)
        assert fc.info()["deadline"] == (1 if ref.deadline == "iterations" else 0)
        seen += ref.deadline is not None
    assert seen > 0
