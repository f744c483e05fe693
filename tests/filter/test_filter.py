"""SafetyFilter: the optimum against an independent QP, the bounds at the output, closed loops.

The reference rows are assembled here from the law's statement (not read back from the filter):
joint approach caps from the profiles' own ``cap``, workspace rows ``n_iᵀ J x >= -s d_i /
buffer`` with the commanded point speed ``s``, obstacle rows from the capsule geometry; the
reference optimum is a QP solved by qpsolvers + daqp.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from optional import requires
from velfence.errors import InvalidInput, InvalidParameter, StartedInViolation
from velfence.filter import (
    FilterResult,
    JointLimits,
    Kinematics,
    SafetyFilter,
    SphereObstacle,
    WorkspaceLimit,
)
from velfence.geometry.polytope import ConvexPolytope
from velfence.geometry.primitives import points_segments_distances
from velfence.mechanisms.chain import DHChain, PlanarArm
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking

ARM = DHChain.seven_dof(link_radius=0.04)
LIM = ARM.joint_limits
Q0 = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
P0 = ARM.fk(Q0)
BOX = ConvexPolytope.box(P0 - 0.15, P0 + 0.15)
VMAX = np.full(7, 1.5)
AMAX = np.array([10.0, 10.0, 12.0, 12.0, 15.0, 15.0, 20.0])
DAQP_PRIMAL_TOL = 1e-14
#: Hypothesis' states start anywhere, inside a limit or beyond it: the warning is not the point.
ANY_START = pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")


def limits(acc: bool = False) -> JointLimits:
    return JointLimits(LIM[:, 0], LIM[:, 1], max_speed=VMAX, max_acceleration=AMAX if acc else None)


def box_filter(**kw: object) -> SafetyFilter:
    args: dict[str, object] = {"limits": limits(), "workspace": WorkspaceLimit(BOX, buffer=0.05)}
    args.update(kw)
    return SafetyFilter(ARM, **args)  # type: ignore[arg-type]


# ------------------------------------------------------------------------ independent rows
def reference_rows(
    f: SafetyFilter, q: np.ndarray, u: np.ndarray, acc: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Rows G x >= b from the law's statement (continuous time), built without the filter."""
    G, b = [], []
    for j in range(7):
        if acc:
            prof = ThreeZoneBraking(
                gain=2 * AMAX[j] / VMAX[j], max_speed=VMAX[j], max_acceleration=AMAX[j]
            )
            cap = lambda d, p=prof: p.cap(d)  # noqa: E731
        else:
            lb = LinearBuffer(buffer=0.1, spring_gain=1.0, max_recovery_speed=VMAX[j])
            cap = lambda d, p=lb, v=VMAX[j]: p.cap(d, v)  # noqa: E731
        e = np.eye(7)[j]
        for sign, d in ((1.0, q[j] - LIM[j, 0]), (-1.0, LIM[j, 1] - q[j])):
            c = cap(d)
            if math.isfinite(c):
                G.append(sign * e)
                b.append(min(-c, VMAX[j]))
        G += [e, -e]
        b += [-VMAX[j], -VMAX[j]]
    for w in f.workspace:
        p = ARM.fk(q, w.point)
        J = ARM.jacobian(q, w.point)
        s = np.linalg.norm(J @ u)
        for n_i, o_i in zip(w.polytope.normals, w.polytope.offsets, strict=True):
            d = n_i @ p - o_i
            if d >= w.buffer:
                continue
            G.append(n_i @ J)
            b.append(
                -s * d / w.buffer if d >= 0 else min(w.spring_gain * -d, w.spring_gain * w.buffer)
            )
    for i, o in enumerate(f.obstacles):
        segs = ARM.link_segments(q)
        for link in range(7):
            a, c = segs[link]
            ab = c - a
            t = 0.0 if ab @ ab == 0 else float(np.clip((o.center - a) @ ab / (ab @ ab), 0, 1))
            x = a + t * ab
            dist = np.linalg.norm(x - o.center)
            d = dist - o.radius - ARM.link_radius[link]
            if d >= f.obstacle_buffer:
                continue
            n = (x - o.center) / dist
            Jc = ARM.point_jacobian(q, link, t)
            s = np.linalg.norm(Jc @ u)
            G.append(n @ Jc)
            k = f.spring_gain
            b.append(-s * d / f.obstacle_buffer if d >= 0 else min(k * -d, k * f.obstacle_buffer))
        del i
    return np.array(G), np.array(b)


def qp(H: np.ndarray, c: np.ndarray, G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """argmin ½ xᵀHx + cᵀx s.t. G x >= b, by qpsolvers + daqp."""
    from qpsolvers import solve_qp

    x = solve_qp(H, c, -G, -b, solver="daqp", primal_tol=DAQP_PRIMAL_TOL)
    assert x is not None
    return np.asarray(x)


@st.composite
def states(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    dq = np.array([draw(st.floats(-0.5, 0.5)) for _ in range(7)])
    scale = draw(st.sampled_from([0.05, 0.5, 2.0]))
    u = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(7)]) * scale
    return Q0 + dq, u


@requires("qpsolvers", "daqp")
@ANY_START
@given(states())
def test_joint_mode_equals_an_independent_qp(state: tuple[np.ndarray, np.ndarray]) -> None:
    q, u = state
    f = box_filter()
    r = f.explain(q, u)
    assert r.dropped == ()
    G, b = reference_rows(f, q, u)
    ref = qp(np.eye(7), -u, G, b)
    np.testing.assert_allclose(r.output, ref, atol=1e-9, rtol=0)
    # every row holds at the output (to round-off)
    assert np.all(G @ r.output - b >= -1e-12 * (1 + np.abs(b)))


@requires("qpsolvers", "daqp")
@ANY_START
@given(states())
def test_three_zone_joints_and_weights_equal_an_independent_qp(
    state: tuple[np.ndarray, np.ndarray],
) -> None:
    q, u = state
    w = np.array([1.0, 2.0, 0.5, 3.0, 1.0, 0.2, 1.5])
    f = box_filter(limits=limits(acc=True), weights=w)
    r = f.explain(q, u)
    G, b = reference_rows(f, q, u, acc=True)
    ref = qp(np.diag(w), -w * u, G, b)
    np.testing.assert_allclose(r.output, ref, atol=1e-9, rtol=0)


@requires("qpsolvers", "daqp")
@ANY_START
@given(states())
def test_obstacle_rows_equal_an_independent_qp(state: tuple[np.ndarray, np.ndarray]) -> None:
    q, u = state
    obs = [SphereObstacle(ARM.fk(Q0, "elbow") + np.array([0.0, 0.12, 0.0]), radius=0.03)]
    f = box_filter(obstacles=obs, obstacle_buffer=0.1, workspace=())
    r = f.explain(q, u)
    G, b = reference_rows(f, q, u)
    ref = qp(np.eye(7), -u, G, b)
    np.testing.assert_allclose(r.output, ref, atol=1e-9, rtol=0)


@requires("qpsolvers", "daqp")
@ANY_START
@given(states(), st.sampled_from([3, 6]))
def test_twist_mode_equals_damped_least_squares_under_the_rows(
    state: tuple[np.ndarray, np.ndarray], size: int
) -> None:
    q, u = state
    f = box_filter()
    v = np.resize(u, size)
    r = f.explain_twist(q, v)
    J = ARM.jacobian(q)
    if size == 6:
        J = np.vstack((J, ARM.angular_jacobian(q)))
    H = J.T @ J + f.damping**2 * np.eye(7)
    target = np.linalg.solve(H, J.T @ v)
    G, b = reference_rows(f, q, target)
    ref = qp(H, -J.T @ v, G, b)
    np.testing.assert_allclose(r.output, ref, atol=1e-9, rtol=0)


def test_unconstrained_twist_is_the_damped_least_squares_solution() -> None:
    f = SafetyFilter(ARM, limits=limits())
    v = np.array([0.01, -0.02, 0.005])
    x = f.filter_twist(Q0, v)
    J = ARM.jacobian(Q0)
    A = np.vstack((J, f.damping * np.eye(7)))
    ref = np.linalg.lstsq(A, np.concatenate((v, np.zeros(7))), rcond=None)[0]
    np.testing.assert_allclose(x, ref, atol=1e-12)


# ------------------------------------------------------------------------ bounds at the output
@ANY_START
@given(states())
def test_reported_rows_hold_at_the_output(state: tuple[np.ndarray, np.ndarray]) -> None:
    q, u = state
    obs = [SphereObstacle(ARM.fk(Q0, "wrist") + np.array([0.0, 0.1, 0.0]), radius=0.03)]
    f = box_filter(obstacles=obs, dt=0.002, limits=limits(acc=True))
    r = f.explain(q, u, previous=u * 0.9)
    G, b = r.rows
    if not r.dropped:
        assert np.all(G @ r.output - b >= -1e-12 * (1 + np.abs(b))), r.stages
    assert len(r.slack) == len(r.constraint_names) == len(b)
    assert set(r.active) <= set(range(len(b)))
    assert r.active_names == tuple(r.constraint_names[i] for i in r.active)
    assert np.all(np.isfinite(r.output))


# ------------------------------------------------------------------------ closed loops
def _run(f: SafetyFilter, q: np.ndarray, commands, dt: float, twist: bool = True):
    qs = [q]
    for v in commands:
        x = f.filter_twist(q, v) if twist else f.filter(q, v)
        q = q + x * dt
        qs.append(q)
    return np.array(qs)


def _walk(seed: int, steps: int, speed: float, every: int = 250) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out = []
    for k in range(steps):
        if k % every == 0:
            d = rng.normal(size=3)
            d = speed * d / np.linalg.norm(d)
        out.append(d)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_closed_loop_tcp_box_has_no_escape(seed: int) -> None:
    dt = 0.002
    f = box_filter(dt=dt)
    speed = 0.8  # dt · speed = 1.6 mm < buffer 50 mm
    qs = _run(f, Q0, _walk(seed, 2500, speed), dt)
    d = np.array([BOX.signed_distances(ARM.fk(q)).min() for q in qs])
    assert d.min() >= -1e-9, d.min()
    assert d.min() < 0.01  # the walk did press on the walls
    assert np.all((qs >= LIM[:, 0]) & (qs <= LIM[:, 1]))


def test_closed_loop_tcp_box_short() -> None:
    dt = 0.002
    f = box_filter(dt=dt)
    qs = _run(f, Q0, _walk(3, 400, 1.0, every=100), dt)
    d = np.array([BOX.signed_distances(ARM.fk(q)).min() for q in qs])
    assert d.min() >= -1e-9, d.min()


def test_joint_limits_are_never_crossed() -> None:
    dt = 0.002
    f = SafetyFilter(ARM, limits=limits(acc=True), dt=dt)
    q = Q0.copy()
    q[3] = LIM[3, 0] + 0.3  # joint 3 0.3 rad from its lower limit
    u = np.zeros(7)
    u[3] = -1.5
    u[1] = 1.5
    qs = _run(f, q, [u] * 600, dt, twist=False)
    assert np.all(qs >= LIM[:, 0])
    assert np.all(qs <= LIM[:, 1])
    assert LIM[3, 0] + 1e-3 > qs[-1, 3] >= LIM[3, 0]  # reached the limit and stayed


def test_an_obstacle_is_never_penetrated() -> None:
    dt = 0.002
    centre = ARM.fk(Q0, "elbow") + np.array([0.0, 0.15, 0.0])
    ob = SphereObstacle(centre, radius=0.05)
    f = SafetyFilter(ARM, limits=limits(), obstacles=[ob], dt=dt, obstacle_buffer=0.08)
    # drive the elbow straight at the obstacle with the elbow's twist
    qs = [Q0]
    q = Q0
    for _ in range(800):
        v = 0.5 * (centre - ARM.fk(q, "elbow")) / np.linalg.norm(centre - ARM.fk(q, "elbow"))
        q = q + f.filter_twist(q, v, point="elbow") * dt
        qs.append(q)
    clear = [
        points_segments_distances(centre[None], s[:, 0], s[:, 1], radii=ARM.link_radius)[1].min()
        - 0.05
        for s in (ARM.link_segments(q) for q in qs)
    ]
    assert min(clear) >= 0.0, min(clear)
    assert min(clear) < 0.01  # it did approach


def test_recovery_from_outside_the_box() -> None:
    dt = 0.002
    f = box_filter(dt=dt)
    q = Q0.copy()
    q[1] += 0.3  # the TCP swings out of the box
    d0 = BOX.signed_distances(ARM.fk(q)).min()
    assert d0 < 0
    with pytest.warns(StartedInViolation, match=r"1 constraint already violated: TCP face "):
        r = f.explain(q, np.zeros(7))
    assert r.zone.startswith("outside")
    assert "recovery" in r.stages
    assert any("TCP face" in s for s in r.active_names)
    # the violated face and its depth, as the polytope measures them
    out = np.flatnonzero(BOX.signed_distances(ARM.fk(q)) < 0)
    assert [nm for nm, _ in r.violations] == [f"TCP face {BOX.facet_names[i]}" for i in out]
    np.testing.assert_allclose([d for _, d in r.violations], [-d0], rtol=1e-12)
    qs = _run(f, q, [np.zeros(7)] * 1500, dt, twist=False)
    d = np.array([BOX.signed_distances(ARM.fk(x)).min() for x in qs])
    assert np.all(np.diff(d[d < 0]) > 0)  # the violation shrinks every step while outside
    assert d[-1] > d0 / 5


def test_recovery_past_a_joint_limit() -> None:
    f = SafetyFilter(ARM, limits=limits(), dt=0.002)
    q = Q0.copy()
    q[2] = LIM[2, 1] + 0.05
    with pytest.warns(StartedInViolation, match=r"joint 2 position \(upper\) \(0\.05 rad deep\)"):
        r = f.explain(q, np.full(7, 0.3))
    assert r.output[2] < 0  # back toward the range, against the command
    assert "joint 2 position (upper)" in r.active_names
    assert r.zone.startswith("outside")
    assert len(r.violations) == 1
    assert r.violations[0][0] == "joint 2 position (upper)"
    assert r.violations[0][1] == pytest.approx(0.05, rel=1e-12)


# ------------------------------------------------------------------------ priorities
def test_workspace_conflicting_with_joint_limits_gives_way() -> None:
    slow = JointLimits(LIM[:, 0], LIM[:, 1], max_speed=np.full(7, 1e-4))
    q = Q0.copy()
    q[1] += 0.3  # outside the box; recovery needs ~0.05 m/s, the joints allow ~1e-4 m/s
    f = SafetyFilter(ARM, limits=slow, workspace=WorkspaceLimit(BOX, buffer=0.05))
    with pytest.warns(StartedInViolation):
        r = f.explain(q, np.zeros(7))
    assert r.dropped == ("workspace",)
    assert np.all(np.abs(r.output) <= 1e-4 * (1 + 1e-12))
    # relaxed to "no further out": the TCP does not move further out of any violated face
    J = ARM.jacobian(q)
    d = BOX.signed_distances(ARM.fk(q))
    rates = BOX.normals @ J @ r.output
    assert np.all(rates[d < 0] >= -1e-15)
    # a slower way back is taken before "no further out": the violated faces are approached
    assert np.abs(r.output).max() > 1e-6
    assert np.all(rates[d < 0] > 0.0)


def test_absurd_commands_are_shortened_not_answered_with_zero() -> None:
    # A TCP 30 cm outside the box; commands up to 1e140 rad/s: the answer is the projection of
    # the command shortened to 1e3 x the fastest joint limit, and it still recovers.
    q = Q0.copy()
    q[1] += 0.3
    f = SafetyFilter(ARM, limits=limits(), workspace=WorkspaceLimit(BOX, buffer=0.05))
    J = ARM.jacobian(q)
    d = BOX.signed_distances(ARM.fk(q))
    with pytest.warns(StartedInViolation):  # the first cycle only
        f.explain(q, np.zeros(7))
    for mag in (1e6, 1e20, 1e140):
        r = f.explain(q, np.full(7, mag))
        assert "command-scaled" in r.stages
        assert np.all(np.isfinite(r.output))
        assert r.dropped == ()
        assert np.all((BOX.normals @ J @ r.output)[d < 0] > 0.0)


def test_acceleration_gives_way_to_a_joint_limit() -> None:
    dt = 0.01
    f = SafetyFilter(ARM, limits=limits(acc=True), dt=dt)
    q = Q0.copy()
    q[3] = LIM[3, 1] - 1e-4  # 0.1 mrad below the upper limit, moving up at 1 rad/s
    prev = np.zeros(7)
    prev[3] = 1.0
    r = f.explain(q, prev, previous=prev)
    assert r.rate_override
    assert r.dropped[0] == "acceleration"
    assert q[3] + r.output[3] * dt <= LIM[3, 1]


def test_the_filter_remembers_its_last_output_for_the_acceleration_rows() -> None:
    dt = 0.01
    f = SafetyFilter(ARM, limits=limits(acc=True), dt=dt)
    assert f.stateful
    u = np.full(7, 1.0)
    first = f.filter(Q0, u)  # no previous: no acceleration rows
    np.testing.assert_allclose(first, u)
    f.reset()
    f.filter(Q0, np.zeros(7))
    second = f.filter(Q0, u)  # remembered zero: at most a·dt per joint
    np.testing.assert_allclose(second, AMAX * dt, rtol=1e-12)


# ------------------------------------------------------------------------ contract details
def test_names_zone_and_result_type() -> None:
    f = box_filter()
    r = f.explain(Q0, np.zeros(7))
    assert isinstance(r, FilterResult)
    assert r.zone == "free"
    assert r.active == ()
    assert r.method == "safety-filter"
    assert "joint 4 velocity (upper)" in r.constraint_names
    # 1 cm from the x_max face, pushed along +x: that face binds, and only it
    near = ConvexPolytope.box(P0 - 0.15, P0 + np.array([0.01, 0.15, 0.15]))
    g = SafetyFilter(ARM, limits=limits(), workspace=WorkspaceLimit(near, buffer=0.05))
    r = g.explain_twist(Q0, [0.2, 0.0, 0.0])
    assert r.active_names == ("TCP face x_max",)
    assert r.zone == "buffer"
    i = r.active[0]
    assert abs(r.slack[i]) <= 1e-9
    assert "projection" in r.stages
    # the x_max approach is the buffer's cap: s·d/buffer with s the commanded TCP speed
    J = ARM.jacobian(Q0)
    s = np.linalg.norm(J @ np.linalg.solve(J.T @ J + 1e-4 * np.eye(7), J.T @ [0.2, 0.0, 0.0]))
    np.testing.assert_allclose((J @ r.output)[0], s * 0.01 / 0.05, rtol=1e-9)


def test_on_invalid_stop_answers_zero() -> None:
    f = box_filter(on_invalid="stop")
    r = f.explain(np.full(7, math.nan), np.zeros(7))
    assert r.zone == "invalid"
    assert np.array_equal(r.output, np.zeros(7))
    with pytest.raises(InvalidInput, match="finite"):
        box_filter().filter(Q0, np.full(7, math.inf))


def test_inputs_are_validated() -> None:
    f = box_filter()
    with pytest.raises(InvalidInput, match="command"):
        f.filter(Q0, np.zeros(6))
    with pytest.raises(InvalidInput, match="command: expected a twist"):
        f.filter_twist(Q0, np.zeros(4))
    with pytest.raises(InvalidInput, match="point"):
        f.filter_twist(Q0, np.zeros(3), point="knee")
    with pytest.raises(InvalidParameter, match="limits"):
        SafetyFilter(ARM, limits=JointLimits([-1.0] * 6, [1.0] * 6, max_speed=1.0))
    with pytest.raises(InvalidParameter, match="point"):
        SafetyFilter(ARM, limits=limits(), workspace=WorkspaceLimit(BOX, point="knee"))
    square = ConvexPolytope.box([-1.0, -1.0], [1.0, 1.0])
    with pytest.raises(InvalidParameter, match="2-D"):
        SafetyFilter(ARM, limits=limits(), workspace=WorkspaceLimit(square))
    with pytest.raises(InvalidParameter, match="dt"):
        box_filter(dt=0.0)
    with pytest.raises(InvalidParameter, match="weights"):
        box_filter(weights=np.zeros(7))
    with pytest.raises(TypeError):
        SafetyFilter(ARM, limits())  # type: ignore[misc]


def test_joint_limits_are_validated() -> None:
    with pytest.raises(InvalidParameter, match="upper"):
        JointLimits([0.0, 1.0], [1.0, 0.5], max_speed=1.0)
    with pytest.raises(InvalidParameter, match="max_speed"):
        JointLimits([0.0], [1.0], max_speed=0.0)
    with pytest.raises(InvalidParameter, match="max_acceleration"):
        JointLimits([0.0], [1.0], max_speed=1.0, max_acceleration=[-1.0])
    with pytest.raises(InvalidParameter, match="names"):
        JointLimits([0.0], [1.0], max_speed=1.0, names=("a", "b"))
    lim = JointLimits([-math.inf], [1.0], max_speed=[2.0])
    assert lim.dof == 1
    assert not lim.lower.flags.writeable


def test_planar_arm_in_the_plane() -> None:
    arm = PlanarArm.three_r(link_radius=0.02)
    lim = JointLimits(arm.joint_limits[:, 0], arm.joint_limits[:, 1], max_speed=1.0)
    square = ConvexPolytope.box([0.5, 0.5], [2.0, 2.0])
    f = SafetyFilter(
        arm,
        limits=lim,
        workspace=WorkspaceLimit(square, buffer=0.1),
        obstacles=[SphereObstacle([1.0, 0.2], radius=0.05)],
        dt=0.01,
    )
    q = np.array([0.5, 0.5, 0.5])
    assert isinstance(arm, Kinematics)
    depth = -square.signed_distances(arm.fk(q)).min()  # the TCP starts above the square
    with pytest.warns(StartedInViolation, match=f"TCP face y_max \\({depth:.4g} m deep\\)"):
        x = f.filter_twist(q, [0.3, -0.2])
    assert x.shape == (3,)
    assert np.all(np.isfinite(x))


def test_shape_batch_equals_loop() -> None:
    f = box_filter()
    rng = np.random.default_rng(4)
    Q = Q0 + rng.uniform(-0.3, 0.3, (10, 7))
    V = rng.normal(size=(10, 7))
    np.testing.assert_array_equal(
        f.shape_batch(Q, V), [f.shape(q, v) for q, v in zip(Q, V, strict=True)]
    )


@requires("qpsolvers", "daqp")
@ANY_START
@given(states())
def test_a_full_weight_matrix_equals_an_independent_qp(
    state: tuple[np.ndarray, np.ndarray],
) -> None:
    q, u = state
    A = np.random.default_rng(7).normal(size=(7, 7))
    W = A @ A.T + 0.5 * np.eye(7)
    f = box_filter(weights=W)
    r = f.explain(q, u)
    G, b = reference_rows(f, q, u)
    ref = qp(W, -W @ u, G, b)
    np.testing.assert_allclose(r.output, ref, atol=1e-9, rtol=0)


@pytest.mark.parametrize("robot", ["puma560", "ur5e"])
def test_other_arms_keep_a_named_point_in_a_box(robot: str) -> None:
    from velfence.mechanisms.puma560 import Puma560

    if robot == "puma560":
        arm, point = Puma560(tool=(0.0, 0.0, 0.1)), "wrist"
        q0 = np.array([0.0, -0.6, 0.4, 0.0, -0.5, 0.0])
    else:
        arm, point = DHChain.ur5e(), "tcp"
        q0 = np.array([0.0, -1.2, 1.4, -1.7, -1.57, 0.0])
    lim = np.asarray(arm.joint_limits)
    p0 = arm.fk(q0, point)
    box = ConvexPolytope.box(p0 - 0.06, p0 + 0.06)
    dt = 0.002
    f = SafetyFilter(
        arm,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(6, 2.0)),
        workspace=WorkspaceLimit(box, point=point, buffer=0.02),
        dt=dt,
    )
    q = q0
    worst = math.inf
    for v in _walk(5, 400, 0.5, every=100):
        q = q + f.filter_twist(q, v, point=point) * dt
        worst = min(worst, float(box.signed_distances(arm.fk(q, point)).min()))
    assert worst >= -1e-9, worst
    assert worst < 0.01  # the walk did press on a face


def test_a_non_symmetric_weight_matrix_is_refused_saying_how_far_off() -> None:
    W = np.eye(7)
    W[0, 1] = 0.5
    with pytest.raises(InvalidParameter, match=r"weights: expected a symmetric \(7, 7\).*0\.5"):
        SafetyFilter(ARM, limits=limits(), weights=W)


def test_a_planar_obstacle_centre_is_refused_by_the_3d_filter() -> None:
    # A (2,) centre becomes (x, y, 0) in SphereObstacle (for planar scenes); a spatial arm's
    # filter refuses it instead of guessing its height (a planar arm's takes it:
    # test_planar_arm_in_the_plane).
    from velfence.errors import InvalidParameter
    from velfence.filter import SafetyFilter, SphereObstacle
    from velfence.filter.limits import JointLimits
    from velfence.robots import ur5e

    flat = SphereObstacle([0.4, 0.1], radius=0.05)
    assert flat.dimension == 2
    assert SphereObstacle([0.4, 0.1, 0.2], radius=0.05).dimension == 3
    robot = ur5e()
    n = len(robot.joint_names)
    limits = JointLimits(-np.pi * np.ones(n), np.pi * np.ones(n), max_speed=np.ones(n))
    with pytest.raises(InvalidParameter, match=r"obstacles\[0\].*3-D"):
        SafetyFilter(robot, limits=limits, obstacles=[flat])
    ok = SafetyFilter(
        robot, limits=limits, obstacles=[SphereObstacle([0.4, 0.1, 0.2], radius=0.05)]
    )
    assert ok.task_dim == 3
