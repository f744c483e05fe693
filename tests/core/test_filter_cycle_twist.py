"""Twist mode on the C cycle (``vf_filter_cycle_metric``) equals the Python route.

``SafetyFilter.explain_twist`` / ``filter_twist`` run the whole cycle in C when ``cycle_in_c``:
Python computes the Jacobian, ``H = JᵀJ + λ²I``, its Cholesky factor ``L`` and ``u = H⁻¹ Jᵀ v``
and C solves in the metric ``H`` (``y = Lᵀ x``). The oracle is the same filter built with
``backend="python"`` (rows by the Python providers, the solve by the Python kernel, the metric by
NumPy). Seeded random scenes on a 7-joint arm, the PUMA 560 and a 3-joint planar chain: joints
inside, at and beyond their limits, a workspace box around the tool point (sometimes with the tool
outside), sphere obstacles near the links (some penetrating), ``dt`` unset, 2 ms or 10 ms with
acceleration rows and jerk rows (the remembered outputs set on both filters), 3-D and 6-D twists
from 1 mm/s to beyond the command cap, damping 1e-3, 1e-2 (the default) and 5e-2. Per scene: the
same rows (names; ``G``, ``b`` to 1e-12), the same output and the same report (zone, active rows,
stages, dropped levels, relaxed rows, deadline, overrides).

Bit for bit where the rows are: the metric's change of variables is the same arithmetic on both
routes (forward and back substitution, ``velfence.filter.solve.factor_rows`` and
``vf_filter_cycle_metric``) and so is the solve, so a scene whose rows the two routes build to the
same bits has the same output bits (about a third of the scenes; most of the others too). The
rows themselves differ in the last bit where C's kinematics rounds differently from the Python
frame's, and the solve in ``y = Lᵀ x`` amplifies that by the factor's condition number: the
outputs then agree to 1e-12 relative to the output's and the joint command's size for a factor
with ``cond(L) <= 100`` (damping 1e-2 and up on these arms), and to ``1e-14 cond(L)`` beyond
(measured: at most ``7e-15 cond(L)``; ``cond(L)`` up to about 2e3 at damping 1e-3).

Where a discrete decision rests on round-off -- a row's distance within 1e-12 of 0 (violated for
one route, not the other), a model-check distance within 1e-12 of its target (each route checks
with its own kinematics), a slack within round-off of the active threshold -- the report may
differ; such scenes (counted, at most a few percent) get the safety check only: every output
meets every safety row's ``min(b, 0)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.filter.kinematics import frame_of
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain

pytest.importorskip("velfence_core._filter")
#: The scenes start anywhere, inside a limit or beyond it: the start warning is not the point.
pytestmark = pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")

_TOL = 1e-12


def _planar3(link_radius: float) -> DHChain:
    return DHChain(
        [[0.4, 0.0, 0.0, 0.0], [0.35, 0.0, 0.0, 0.0], [0.2, 0.0, 0.0, 0.0]],
        joint_limits=[[-2.6, 2.6], [-2.4, 2.4], [-2.0, 2.0]],
        link_radius=link_radius,
    )


_ROBOTS = {
    "seven_dof": lambda r: DHChain.seven_dof(link_radius=r, tool=(0.0, 0.0, 0.1)),
    "puma560": lambda r: DHChain.puma560(link_radius=r, tool=(0.0, 0.0, 0.05)),
    "planar3": _planar3,
}


def _scene(rng: np.random.Generator, name: str) -> dict[str, Any]:
    """A random filter pair (C route, Python oracle), state, twist and remembered outputs."""
    lrad = float(rng.uniform(0.0, 0.05))
    robot = _ROBOTS[name](lrad)
    n = robot.dof
    lo, hi = robot.joint_limits[:, 0], robot.joint_limits[:, 1]
    vmax = rng.uniform(0.5, 3.0, n)
    dt = [None, 2e-3, 1e-2][int(rng.integers(3))]
    amax = rng.uniform(3.0, 40.0, n) if dt is not None and rng.random() < 0.8 else None
    jmax = None
    if dt is not None and rng.random() < 0.5:
        jmax = rng.uniform(100.0, 5000.0, n)
        if rng.random() < 0.3:
            jmax[int(rng.integers(n))] = math.inf
    q = np.empty(n)
    for j in range(n):
        kind = rng.choice(["in", "in", "in", "lo", "hi", "out"])
        t = rng.random()
        q[j] = {
            "in": lo[j] + t * (hi[j] - lo[j]),
            "lo": lo[j],
            "hi": hi[j],
            "out": (lo[j] - 0.05 * t) if t < 0.5 else (hi[j] + 0.05 * t),
        }[str(kind)]
    tcp = robot.fk(q, "tcp")
    half = rng.uniform(0.05, 0.5, 3)
    shift = rng.uniform(-1.0, 1.0, 3) * half * rng.choice([0.5, 1.2])
    # (irrational jitter: no distance lands exactly on a buffer's edge)
    centre = tcp + shift + 1e-9 * np.sqrt([2.0, 3.0, 5.0])
    box = WorkspaceLimit(
        ConvexPolytope.box(centre - half, centre + half),
        point="tcp",
        buffer=float(rng.uniform(0.01, 0.2)),
    )
    pts = robot.joint_positions(q)
    obstacles = []
    for _ in range(int(rng.integers(0, 5))):
        k = int(rng.integers(n))
        p = pts[k] + rng.random() * (pts[k + 1] - pts[k])
        d = rng.normal(size=3) + 1e-3
        d /= np.linalg.norm(d)
        r = float(rng.uniform(0.01, 0.1))
        gap = float(rng.uniform(-0.02, 0.2))
        jitter = 1e-9 * np.sqrt([7.0, 11.0, 13.0])
        obstacles.append(SphereObstacle(center=p + d * (lrad + r + gap) + jitter, radius=r))
    limits = JointLimits(lo, hi, max_speed=vmax, max_acceleration=amax, max_jerk=jmax)
    kw: dict[str, Any] = {
        "limits": limits,
        "workspace": box,
        "obstacles": obstacles,
        "dt": dt,
        "obstacle_buffer": float(rng.uniform(0.02, 0.3)),
        "spring_gain": float(rng.uniform(0.0, 5.0)),
        "damping": float(rng.choice([1e-3, 1e-2, 5e-2])),
    }
    c = SafetyFilter(robot, backend="c", **kw)
    p = SafetyFilter(robot, backend="python", **kw)
    size = 6 if rng.random() < 0.5 else 3
    v = rng.normal(size=size) * float(rng.choice([1e-3, 0.1, 1.0, 5.0, 1e5]))
    prev = prev2 = None
    if dt is not None and rng.random() < 0.7:
        prev = rng.uniform(-1.0, 1.0, n) * vmax
        if rng.random() < 0.6:
            step = float(rng.choice([0.01, 0.2]))
            prev2 = prev + rng.uniform(-1.0, 1.0, n) * vmax * step
    return {"c": c, "p": p, "q": q, "v": v, "prev": prev, "prev2": prev2}


def _remember(sf: SafetyFilter, prev: Any, prev2: Any) -> None:
    """Both routes start the cycle from the same remembered outputs."""
    sf._previous = prev if sf.stateful else None
    sf._previous2 = prev2 if sf._has_jerk else None


def _borderline(sc: dict[str, Any], xs: tuple[Any, ...]) -> bool:
    """Whether a discrete decision of the cycle rests on round-off (module docstring)."""
    c, p, q = sc["c"], sc["p"], sc["q"]
    _, _, _, _, _, dist, _, _ = c._ccycle.rows()
    if bool(np.any(np.abs(dist) <= 1e-12)):
        return True
    if p.dt is None:
        return False
    u = p._twist(q, sc["v"], "tcp")[2]
    cap = 1e3 * float(np.max(p.limits.max_speed))
    big = float(np.abs(u).max())
    uc = u * (cap / big) if big > cap else u
    prev = sc["prev"] if p.stateful else None
    prev2 = sc["prev2"] if p._has_jerk else None
    cyc = p._build_rows(q, uc, prev, frame_of(p.robot, q), prev2)
    if not len(cyc.checked):
        return False
    nxt = p._next_distances(q, cyc)
    target = np.minimum(0.0, cyc.d0)
    return any(bool(np.any(np.abs(nxt(x) - target) <= 1e-12 * (1.0 + np.abs(cyc.d0)))) for x in xs)


def _safe(x: Any, u: Any, G: Any, b: Any, names: tuple[str, ...]) -> None:
    """Every safety row (not acceleration or jerk) meets min(b, 0) to the spec's round-off."""
    gx = G @ x
    xi = float(np.abs(x).max()) + float(np.abs(u).max())
    g1 = np.abs(G).sum(axis=1)
    c = np.minimum(b, 0.0)
    safety = np.array([not ("acceleration" in nm or "jerk" in nm) for nm in names], dtype=bool)
    assert np.all((gx - c >= -1e-12 * (np.abs(c) + g1 * xi))[safety])


def _compare(sc: dict[str, Any]) -> tuple[bool, bool, float]:
    """Checks one scene; returns (borderline, rows bit for bit, output's relative difference)."""
    c, p, q, v = sc["c"], sc["p"], sc["q"], sc["v"]
    assert c.cycle_in_c
    assert not p.cycle_in_c
    _remember(c, sc["prev"], sc["prev2"])
    _remember(p, sc["prev"], sc["prev2"])
    rc = c.explain_twist(q, v)
    rp = p.explain_twist(q, v)
    # filter_twist: the same C cycle without the report, the same bits
    _remember(c, sc["prev"], sc["prev2"])
    np.testing.assert_array_equal(c.filter_twist(q, v), rc.output)
    assert rc.constraint_names == rp.constraint_names
    G, b = rc.rows
    Gp, bp = rp.rows
    scale_g = max(1.0, float(np.abs(Gp).max(initial=0.0)))
    np.testing.assert_allclose(G, Gp, rtol=_TOL, atol=_TOL * scale_g)
    np.testing.assert_allclose(b, bp, rtol=_TOL, atol=_TOL * max(1.0, float(np.abs(bp).max())))
    _, _, u, L, _ = c._twist(q, v, "tcp")
    big = max(float(np.abs(rp.output).max()), float(np.abs(u).max()), 1e-300)
    diff = float(np.abs(rc.output - rp.output).max()) / big
    tol = _TOL * max(1.0, float(np.linalg.cond(L)) / 100.0)
    rows_equal = np.array_equal(G, Gp) and np.array_equal(b, bp)
    _safe(rc.output, u, G, b, rc.constraint_names)
    _safe(rp.output, u, Gp, bp, rp.constraint_names)
    report_c = (rc.zone, rc.stages, rc.dropped, rc.relaxed, rc.deadline, rc.rate_override,
                rc.jerk_override)  # fmt: skip
    report_p = (rp.zone, rp.stages, rp.dropped, rp.relaxed, rp.deadline, rp.rate_override,
                rp.jerk_override)  # fmt: skip
    binding = 1e-9 * (1.0 + np.abs(b))
    unsure = np.abs(rc.slack - binding) <= 1e-10 * (1.0 + np.abs(b)) + 1e-12
    odd = set(rc.active) ^ set(rp.active)
    same = (
        report_c == report_p
        and all(unsure[i] for i in odd)
        and diff <= tol
        and (diff == 0.0 or not rows_equal)  # the same rows: the same bits
    )
    if not same:
        assert _borderline(sc, (rc.output, rp.output)), (
            diff, tol, rows_equal, report_c, report_p, sorted(odd), rc.constraint_names
        )  # fmt: skip
        return True, rows_equal, diff
    assert np.array_equal(rc.command, v)
    assert np.array_equal(rc.position, q)
    return False, rows_equal, diff


@pytest.mark.parametrize("name", sorted(_ROBOTS))
def test_twist_mode_in_c_equals_the_python_route(name: str) -> None:
    rng = np.random.default_rng({"seven_dof": 7, "puma560": 560, "planar3": 3}[name])
    borderline = moved = equal_rows = equal_out = 0
    count = 90
    for _ in range(count):
        sc = _scene(rng, name)
        odd, rows_equal, diff = _compare(sc)
        borderline += odd
        equal_rows += rows_equal
        equal_out += diff == 0.0
        moved += "projection" in sc["c"].explain_twist(sc["q"], sc["v"]).stages
    assert borderline <= count // 20, borderline  # round-off decides rarely
    assert moved >= count // 3  # the scenes do make the filter work
    assert equal_rows >= count // 10  # the bit-for-bit case is exercised
    assert equal_out >= count // 2, equal_out


def test_a_closed_loop_in_twist_mode_follows_the_python_route() -> None:
    """50 cycles of the 7-joint arm jogging into a box wall past a sphere, 2 ms, acceleration
    and jerk rows: the remembered outputs, the jerk overrides and the joint path of the C route
    follow the Python route's (each integrating its own outputs)."""
    robot = DHChain.seven_dof(link_radius=0.04)
    n = robot.dof
    lim = JointLimits(
        robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.full(n, 1.5),
        max_acceleration=np.full(n, 8.0), max_jerk=np.full(n, 400.0),
    )  # fmt: skip
    q0 = np.array([0.1, 0.4, -0.1, -1.2, 0.1, 1.0, 0.2])
    tcp = robot.fk(q0, "tcp")
    hi = tcp + np.array([0.08, 0.3, 0.3])
    box = WorkspaceLimit(ConvexPolytope.box(tcp - 0.3, hi), point="tcp")
    sphere = SphereObstacle(center=tcp + np.array([0.05, 0.12, 0.0]), radius=0.05)
    kw: dict[str, Any] = {"limits": lim, "workspace": box, "obstacles": [sphere], "dt": 2e-3}
    c = SafetyFilter(robot, backend="c", **kw)
    p = SafetyFilter(robot, backend="python", **kw)
    qc, qp = q0.copy(), q0.copy()
    v = np.array([0.8, 0.5, 0.1, 0.0, 0.0, 0.3])
    binding = 0
    for _ in range(50):
        rc = c.explain_twist(qc, v)
        rp = p.explain_twist(qp, v)
        np.testing.assert_allclose(rc.output, rp.output, rtol=1e-10, atol=1e-10)
        assert rc.stages == rp.stages
        assert rc.active_names == rp.active_names
        binding += bool(rc.active)
        qc = qc + rc.output * 2e-3
        qp = qp + rp.output * 2e-3
    assert binding >= 10
    assert c.jerk_overrides == p.jerk_overrides
    assert c._previous is not None
    assert p._previous is not None
    np.testing.assert_allclose(c._previous, p._previous, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(qc, qp, rtol=0.0, atol=1e-10)


def test_twist_deadline_fallback_equals_the_python_route() -> None:
    """An iteration cap of 1: both routes answer the same safe fallback in twist mode."""
    robot = DHChain.seven_dof(link_radius=0.05)
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.full(7, 1.5))
    box = WorkspaceLimit(ConvexPolytope.box([-0.5, -0.5, 0.2], [0.5, 0.5, 1.2]), point="tcp")
    rng = np.random.default_rng(11)
    seen = 0
    for _ in range(40):
        kw: dict[str, Any] = {"limits": lim, "workspace": box, "dt": 1e-3, "max_iterations": 1}
        c = SafetyFilter(robot, backend="c", **kw)
        p = SafetyFilter(robot, backend="python", **kw)
        q = rng.uniform(-2.5, 2.5, 7)
        v = rng.normal(size=6) * 3.0
        rc, rp = c.explain_twist(q, v), p.explain_twist(q, v)
        np.testing.assert_allclose(rc.output, rp.output, rtol=1e-12, atol=1e-14)
        assert rc.deadline == rp.deadline
        assert rc.stages == rp.stages
        assert c.deadline_misses == p.deadline_misses
        seen += rc.deadline is not None
    assert seen > 0


def test_the_binding_refuses_a_bad_factor() -> None:
    """A factor with NaN / inf below or on the diagonal, or a non-positive diagonal: the C status
    VF_ERR_ARGUMENT (ValueError, output zero); a wrong shape, dtype or layout: TypeError. NaN
    above the diagonal is not read."""
    robot = DHChain.seven_dof()
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1], max_speed=np.full(7, 1.5))
    sf = SafetyFilter(robot, limits=lim, backend="c")
    cyc = sf._ccycle
    q = np.zeros(7)
    u = np.full(7, 0.3)
    L = np.linalg.cholesky(np.eye(7) * 2.0 + 0.1)
    ok = cyc.cycle(q, u, None, None, None, L)
    assert np.all(np.isfinite(ok))
    up = L.copy()
    up[0, 3] = math.nan
    np.testing.assert_array_equal(cyc.cycle(q, u, None, None, None, up), ok)
    for at, bad in (((3, 1), math.nan), ((5, 0), math.inf), ((4, 4), 0.0), ((2, 2), -1.0)):
        B = L.copy()
        B[at] = bad
        with pytest.raises(ValueError, match="status -"):
            cyc.cycle(q, u, None, None, None, B)
        assert cyc.info()["status"] < 0
        assert cyc.info()["stages"] == 128
    for wrong in (L[:6, :6].copy(), L.astype(np.float32), np.asfortranarray(L + 0.0), L.ravel()):
        if wrong.flags.c_contiguous and wrong.dtype == np.float64 and wrong.shape == (7, 7):
            continue  # (np.asfortranarray of a lower-triangular L is not C-contiguous)
        with pytest.raises(TypeError, match="factor"):
            cyc.cycle(q, u, None, None, None, wrong)
