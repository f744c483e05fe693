"""The arm baselines and the arm metrics, each checked against an independent route."""

from __future__ import annotations

import math
import types

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from velfence.errors import InvalidInput
from velfence.geometry.polytope import ConvexPolytope
from velfence.geometry.primitives import points_segments_distances, sphere_capsule_distance
from velfence.mechanisms.chain import DHChain
from velfence.sim.arm_baselines import DamperQP, JointClamp, ResolvedRate, ScalarScale
from velfence.sim.metrics import (
    box_penetration,
    face_sliding_ratio,
    joint_limit_violation,
    max_joint_acceleration,
    sphere_penetration,
    time_to_reach,
)
from velfence.sim.runner import Trajectory

ROBOT = DHChain.seven_dof(link_radius=0.05)
HI = np.radians([170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0])
LIMITS = types.SimpleNamespace(lower=-HI, upper=HI, max_speed=np.full(7, 1.5))
Q0 = np.array([0.0, 0.5, 0.0, 1.6, 0.0, -1.0, 0.0])
BOX = ConvexPolytope.box([0.45, -0.25, 0.35], [0.80, 0.25, 0.70])
DT = 1e-3

joint = st.floats(-0.4, 0.4)
twist = st.lists(st.floats(-0.6, 0.6), min_size=3, max_size=3).map(np.array)


def near_q0(offsets: list[float]) -> np.ndarray:
    return Q0 + np.array(offsets)


qs = st.lists(joint, min_size=7, max_size=7).map(near_q0)


def fd_jacobian(q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central finite differences of the TCP position, shape (3, 7)."""
    cols = []
    for i in range(7):
        e = np.zeros(7)
        e[i] = h
        cols.append((ROBOT.end_effector(q + e) - ROBOT.end_effector(q - e)) / (2 * h))
    return np.array(cols).T


@given(qs, twist)
def test_resolved_rate_tracks_the_twist(q: np.ndarray, v: np.ndarray) -> None:
    ctrl = ResolvedRate(ROBOT, limits=LIMITS, damping=1e-10)
    qd = ctrl.shape(q, v)
    J = fd_jacobian(q)
    if np.linalg.svd(J, compute_uv=False)[-1] > 1e-2:
        np.testing.assert_allclose(J @ qd, v, atol=1e-5)
        # the minimum-norm solution: orthogonal to the null space of J
        np.testing.assert_allclose(qd, np.linalg.pinv(J) @ v, atol=1e-5)


@given(qs, twist.map(lambda v: 10 * v))
def test_joint_clamp_is_the_per_joint_clip(q: np.ndarray, v: np.ndarray) -> None:
    free = ResolvedRate(ROBOT, limits=LIMITS).shape(q, v)
    out = JointClamp(ROBOT, limits=LIMITS, dt=DT).shape(q, v)
    for i in range(7):
        lo = max(-LIMITS.max_speed[i], (LIMITS.lower[i] - q[i]) / DT)
        hi = min(LIMITS.max_speed[i], (LIMITS.upper[i] - q[i]) / DT)
        assert lo - 1e-12 <= out[i] <= hi + 1e-12
        assert out[i] == pytest.approx(min(max(free[i], lo), hi), abs=1e-12)


@given(qs, twist.map(lambda v: 8 * v))
def test_scalar_scale_is_the_largest_admissible_scalar(q: np.ndarray, v: np.ndarray) -> None:
    sphere = types.SimpleNamespace(
        center=ROBOT.end_effector(Q0) + np.array([0.0, 0.0, -0.12]), radius=0.05
    )
    ctrl = ScalarScale(ROBOT, limits=LIMITS, obstacles=(sphere,), dt=DT, singular_slow=1e6,
                       singular_stop=2e6)  # fmt: skip
    segs = ROBOT.link_segments(q)
    clear = [
        sphere_capsule_distance(sphere.center, a, b, sphere_radius=0.05, capsule_radius=0.05)[0]
        for a, b in segs
    ]
    assume(min(clear) > 0.0)  # a scalar on the command cannot push a link out of the sphere
    free = ResolvedRate(ROBOT, limits=LIMITS).shape(q, v)
    res = ctrl.explain(q, v)
    s = res.scale
    np.testing.assert_allclose(res.output, s * free, atol=1e-12)
    assert 0.0 <= s <= 1.0

    def admissible(x: float) -> bool:
        qd = x * free
        if np.any(np.abs(qd) > LIMITS.max_speed + 1e-12):
            return False
        g = ctrl.position_gain / DT
        if np.any(qd > g * (LIMITS.upper - q) + 1e-12) or np.any(
            qd < g * (LIMITS.lower - q) - 1e-12
        ):
            return False
        # sphere damper by finite differences of the clearance of every link within influence
        for link in range(7):
            d, *_ = sphere_capsule_distance(
                sphere.center, segs[link, 0], segs[link, 1], sphere_radius=0.05, capsule_radius=0.05
            )
            if d > ctrl.influence:
                continue
            h = 1e-7
            s2 = ROBOT.link_segments(q + h * qd)
            d2, *_ = sphere_capsule_distance(
                sphere.center, s2[link, 0], s2[link, 1], sphere_radius=0.05, capsule_radius=0.05
            )
            if (d2 - d) / h < -ctrl.obstacle_gain * d / ctrl.influence - 1e-5:
                return False
        return True

    assert admissible(s)
    if s < 1.0:
        # 1e-4 absolute: the finite-difference check above allows 1e-5 of slack on a rate, which
        # a probe of s * 1.001 alone does not exceed when s is tiny.
        assert not admissible(min(1.0, s * 1.001 + 1e-4))


@pytest.mark.parametrize("seed", range(8))
def test_damper_qp_matches_an_independent_solver(seed: int) -> None:
    scipy_optimize = pytest.importorskip("scipy.optimize")
    rng = np.random.default_rng(seed)
    q = Q0 + rng.uniform(-0.3, 0.3, 7)
    p = ROBOT.end_effector(q)
    # a box whose x_max face is 2 mm ahead of the TCP, pushed into at 0.5 m/s
    box = ConvexPolytope.box(p - 0.3, p + np.array([0.002, 0.3, 0.3]))
    v = np.array([0.5, rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)])
    ctrl = DamperQP(ROBOT, limits=LIMITS, workspace=box, dt=DT)
    res = ctrl.explain(q, v)
    J = fd_jacobian(q)
    lam = ctrl.damping

    def cost(x: np.ndarray) -> float:
        return float(np.sum((J @ x - v) ** 2) + lam * np.sum(x**2))

    d = box.signed_distances(p)
    cons = [{"type": "ineq", "fun": lambda x: box.normals @ (J @ x) + ctrl.workspace_gain * d / DT}]
    g = ctrl.position_gain / DT
    bounds = [
        (max(-1.5, g * (LIMITS.lower[i] - q[i])), min(1.5, g * (LIMITS.upper[i] - q[i])))
        for i in range(7)
    ]
    opts = {"ftol": 1e-14, "maxiter": 500}
    ref = scipy_optimize.minimize(
        cost, np.zeros(7), method="SLSQP", bounds=bounds, constraints=cons, options=opts
    )
    assert ref.success
    assert cost(res.output) == pytest.approx(ref.fun, rel=1e-4, abs=1e-9)
    # the x_max face binds: 2 mm at gain 0.5 per ms allows at most 1 m/s... the command is 0.5
    # m/s, so the face binds only when its bound is below the request
    assert (box.normals @ (J @ res.output) + ctrl.workspace_gain * d / DT).min() >= -1e-6


# ------------------------------------------------------------------------------ metrics


def test_box_penetration_against_brute_force() -> None:
    rng = np.random.default_rng(1)
    X = rng.uniform(0.3, 0.9, (200, 3))
    lo, hi = np.array([0.45, -0.25, 0.35]), np.array([0.80, 0.25, 0.70])
    brute = max(0.0, max(max(np.max(lo - x), np.max(x - hi)) for x in X))
    assert box_penetration(X, BOX) == pytest.approx(brute, abs=1e-15)
    assert box_penetration(np.clip(X, lo, hi), BOX) == 0.0


def test_sphere_penetration_against_the_pairwise_distance() -> None:
    rng = np.random.default_rng(2)
    segs = rng.uniform(-0.2, 0.2, (30, 4, 2, 3))
    c = np.array([0.0, 0.0, 0.05])
    worst = 0.0
    for row in segs:
        for seg in row:
            d, *_ = sphere_capsule_distance(
                c, seg[0], seg[1], sphere_radius=0.04, capsule_radius=0.02
            )
            worst = max(worst, -d)
    assert sphere_penetration(segs, np.full(4, 0.02), c, 0.04) == pytest.approx(worst, abs=1e-12)


def test_sphere_penetration_of_many_rows_is_the_worst_row() -> None:
    """Rows are taken in blocks: the answer is the row-by-row maximum exactly, across blocks."""
    rng = np.random.default_rng(3)
    links = 5000  # blocks of 13 rows
    segs = rng.uniform(-1.0, 1.0, (30, links, 2, 3))
    radii = rng.uniform(0.0, 0.03, links)
    c = np.array([0.1, -0.2, 0.3])
    per_row = [
        float(-(points_segments_distances(c[None], s[:, 0], s[:, 1], radii=radii)[1].min() - 0.1))
        for s in segs
    ]
    assert max(per_row) > 0.0
    assert sphere_penetration(segs, radii, c, 0.1) == max(per_row)
    assert sphere_penetration(segs, 0.02, c, 0.1) > 0.0
    with pytest.raises(InvalidInput, match="link_radius"):
        sphere_penetration(segs, np.zeros(3), c, 0.1)


def test_joint_limit_violation() -> None:
    q = np.array([[0.0, 0.5], [1.2, -0.1], [0.2, -0.75]])
    assert joint_limit_violation(q, [-1.0, -0.5], [1.0, 0.5]) == pytest.approx(0.25)
    assert joint_limit_violation(q, [-2.0, -1.0], [2.0, 1.0]) == 0.0


@pytest.mark.parametrize("kept", [1.0, 0.5, 0.0])
def test_face_sliding_ratio_of_a_synthetic_slide(kept: float) -> None:
    # The TCP sits on the face x = 0.8 and is commanded (+0.1, -0.2, 0) m/s: pressing out
    # through x_max while sliding in -y; it moves at kept·0.2 m/s in -y.
    n = 101
    t = 0.01 * np.arange(n)
    X = np.stack([np.full(n, 0.8), 0.2 - kept * 0.2 * t, np.full(n, 0.5)], axis=1)
    V = np.tile([0.1, -0.2, 0.0], (n, 1))
    assert face_sliding_ratio(t, X, V, BOX, band=0.01) == pytest.approx(kept, abs=1e-12)
    # a command that does not press (pointing inwards) gives no sample
    assert math.isnan(face_sliding_ratio(t, X, -V, BOX, band=0.01))


def test_time_to_reach_and_acceleration() -> None:
    t = 0.1 * np.arange(11)
    X = np.stack([t, np.zeros(11)], axis=1)
    assert time_to_reach(t, X, [0.5, 0.0], tol=0.01) == pytest.approx(0.5)
    assert time_to_reach(t, X, [0.5, 0.0], tol=0.01, after=0.6) == math.inf
    v = np.zeros((11, 2))
    v[4:, 1] = 0.3  # a step of 0.3 in one period of 0.1 s
    traj = Trajectory(t, X, v, v)
    assert max_joint_acceleration(traj) == pytest.approx(3.0)
