"""Configuration control with obstacle inequality tasks (US 5,150,026 claim 1, steps A–F).

Scenarios (ours; the claim gives none): a planar 3R tracking a straight end-effector line
that passes near an obstacle, two obstacles on a 4R, redundancy exhausted, critical-point switching
links, plus the shaper contract and the invalid-input policy. The closed loop is a plain explicit
Euler loop (``velfence.sim.simulate`` expects the command in the state's space).
"""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter import SphereObstacle
from velfence.mechanisms.chain import PlanarArm
from velfence.redundancy import ConfigurationController, ControlResult
from velfence.shaping.base import Shaper

DT = 0.01  # [s] control period of the closed-loop scenarios
SPEED = 0.2  # [m/s] end-effector speed along the line
RHO = 0.2  # [m] sphere of influence
EE_TOL = 2e-3  # [m] end-effector tracking error allowed while active rows <= redundancy
SECOND_ORDER_TOL = 5e-4  # [m] drift of d from the curvature of d(q) while held at ḋ = 0


def _ik(arm, target, q):
    for _ in range(100):
        J = arm.ee_jacobian(q)
        q = q + J.T @ np.linalg.solve(J @ J.T + 1e-9 * np.eye(2), target - arm.end_effector(q))
    return q


def _down_then_up(x, y0, t_turn):
    """Straight vertical line at x: down at SPEED until t_turn, then back up."""

    def cmd(t):
        if t < t_turn:
            return np.array([0.0, -SPEED]), np.array([x, y0 - SPEED * t])
        return np.array([0.0, SPEED]), np.array([x, y0 - SPEED * t_turn + SPEED * (t - t_turn)])

    return cmd


def _run(controller, q0, cmd, duration, dt=DT):
    q = np.array(q0, dtype=float)
    out = []
    for k in range(round(duration / dt) + 1):
        t = k * dt
        v, y = cmd(t)
        r = controller.control(q, v, ee_target=y)
        assert np.all(np.isfinite(r.q_dot))
        out.append((t, q.copy(), r))
        q = q + dt * r.q_dot
    return out


@pytest.fixture(scope="module")
def arm3():
    return PlanarArm.three_r()


@pytest.fixture(scope="module")
def q0_3r(arm3):
    return _ik(arm3, np.array([2.0, 1.0]), np.array([-0.4, 0.8, 1.0]))


def _ctrl(chain, obstacles, **kw):
    params = {"ee_gain": 1.0, "damping": 1e-4, "constraint_weight": 1e4}
    params.update(kw)
    return ConfigurationController(chain, obstacles, **params)


# ---------------------------------------------------------------------------- obstacle
def test_obstacle_validation_and_readonly():
    ob = SphereObstacle(center=[1.0, 2.0], radius=0.1, influence=0.3)
    np.testing.assert_array_equal(ob.center, [1.0, 2.0, 0.0])
    with pytest.raises(ValueError, match="read-only"):
        ob.center[0] = 5.0
    with pytest.raises(InvalidParameter, match="influence must exceed radius"):
        SphereObstacle(center=[0, 0, 0], radius=0.3, influence=0.3)
    with pytest.raises(InvalidParameter, match=r"center: expected finite values, got \[0.0, nan\]"):
        SphereObstacle(center=[0, np.nan], radius=0.1, influence=0.3)
    with pytest.raises(InvalidParameter, match="radius must be finite and >= 0"):
        SphereObstacle(center=[0, 0], radius=-1, influence=0.3)


def test_parameters_keyword_only_and_validated(arm3):
    sig = inspect.signature(ConfigurationController)
    for name, p in sig.parameters.items():
        if name not in ("chain", "obstacles"):
            assert p.kind is inspect.Parameter.KEYWORD_ONLY, name
    with pytest.raises(InvalidParameter, match="damping must be finite and > 0"):
        ConfigurationController(arm3, [], damping=0.0)
    with pytest.raises(InvalidParameter, match="activation_margin must be finite and >= 0"):
        ConfigurationController(arm3, [], activation_margin=-0.01)
    with pytest.raises(InvalidParameter, match="sequence of SphereObstacle"):
        ConfigurationController(arm3, [(1.0, 0.0, 0.0)])
    with pytest.raises(InvalidParameter, match="SerialChain protocol"):
        ConfigurationController(object(), [])


# ---------------------------------------------------------------------------- scenario 1
@pytest.mark.parametrize("margin", [0.0, DT], ids=["faithful", "look-ahead"])
def test_3r_line_past_obstacle(arm3, q0_3r, margin):
    """Clearance >= ρ - tol with tol derived from discrete time; EE tracks while r >= 1 row."""
    ob = SphereObstacle(center=[1.5, -1.4], radius=0.05, influence=RHO)
    c = _ctrl(arm3, [ob], activation_margin=margin)
    res = _run(c, q0_3r, _down_then_up(2.0, 1.0, 8.0), 12.0)
    d = np.array([r.distances[0] for *_, r in res])
    dd_free = np.array([r.d_dot_free[0] for *_, r in res])
    zones = [r.zone for *_, r in res]
    # Derived tolerance (docs/configuration_control.md §4): without look-ahead the switch at
    # d = ρ is sampled, overshoot <= max|ḋ| Δt; with h = Δt only the second-order drift remains.
    first_order = 0.0 if margin > 0 else float(np.max(np.abs(dd_free))) * DT
    tol = first_order + SECOND_ORDER_TOL
    assert d.min() >= RHO - tol, (d.min() - RHO, tol)
    # Without the obstacle the line would cut through the sphere of influence.
    free = _run(_ctrl(arm3, []), q0_3r, _down_then_up(2.0, 1.0, 8.0), 12.0)
    free_d = min(c.critical(q).distances[0] for _, q, _ in free)
    assert free_d < RHO - 0.02
    # Tracking is kept: one active row <= redundancy 1.
    assert any(z in ("active", "recovering") for z in zones)
    assert all(len(r.active) <= 1 and not r.exhausted for *_, r in res)
    ee = max(r.ee_error for *_, r in res)
    assert ee < EE_TOL
    # Report (pytest -s): measured numbers quoted in the docs.
    print(f"margin={margin}: min d-rho={d.min() - RHO:+.2e} m (tol {tol:.2e}), EE err={ee:.2e} m")


def test_deactivates_when_critical_point_moves_away(arm3, q0_3r):
    ob = SphereObstacle(center=[1.5, -1.4], radius=0.05, influence=RHO)
    res = _run(_ctrl(arm3, [ob]), q0_3r, _down_then_up(2.0, 1.0, 8.0), 12.0)
    k_turn = round(8.0 / DT)
    assert res[k_turn - 1][2].active == (0,)
    after = [r for t, _, r in res if t >= 8.0]
    # As soon as the commanded motion retreats, the row is released: output = free solution.
    assert after[0].active == ()
    assert after[0].d_dot_free[0] > 0
    np.testing.assert_allclose(after[0].d_dot, after[0].d_dot_free)
    assert all(r.zone == "free" for r in after)
    assert after[-1].distances[0] > RHO


def _active_state(arm3, q0_3r):
    ob = SphereObstacle(center=[1.5, -1.4], radius=0.05, influence=RHO)
    c = _ctrl(arm3, [ob])
    res = _run(c, q0_3r, _down_then_up(2.0, 1.0, 8.0), 7.5)
    _, q, r = res[-1]
    assert r.active == (0,)
    return c, q, r


def test_only_approach_is_stopped_tangential_and_retreat_free(arm3, q0_3r):
    c, q, r = _active_state(arm3, q0_3r)
    free_c = _ctrl(arm3, [])
    # Approach: ḋ held at 0 while the EE velocity is still met (redundancy used).
    assert r.d_dot_free[0] < -0.01
    assert abs(r.d_dot[0]) < 1e-3
    assert r.ee_rate_error < 1e-3
    # Retreat: the opposite command is not touched.
    v = np.array([0.0, SPEED])
    back = c.control(q, v)
    assert back.active == ()
    assert back.d_dot[0] > 0
    np.testing.assert_allclose(back.q_dot, free_c.shape(q, v), atol=1e-12)
    # Tangential: a command whose free motion has ḋ = 0 exactly is not blocked either.
    g = np.array([c.control(q, e).d_dot_free[0] for e in np.eye(2)])  # ḋ_free is linear in v
    vt = SPEED * np.array([-g[1], g[0]]) / np.linalg.norm(g)
    tang = c.control(q, vt)
    assert abs(tang.d_dot_free[0]) < 1e-12
    assert tang.active == ()
    np.testing.assert_allclose(tang.q_dot, free_c.shape(q, vt), atol=1e-12)


def test_critical_point_switching_links_bounded_jumps(arm3, q0_3r):
    ob = SphereObstacle(center=[1.5, -1.4], radius=0.05, influence=RHO)
    res = _run(_ctrl(arm3, [ob]), q0_3r, _down_then_up(2.0, 1.0, 8.0), 8.0)
    links = np.array([r.links[0] for *_, r in res])
    qd = np.array([r.q_dot for *_, r in res])
    switches = np.flatnonzero(np.diff(links) != 0)
    active_switches = [k for k in switches if res[k][2].active and res[k + 1][2].active]
    assert active_switches, "scenario must switch links while the row is active"
    jumps = np.linalg.norm(np.diff(qd, axis=0), axis=1)
    for k in active_switches:
        # The critical point passes through the joint shared by both links: same point,
        # same velocity, so the row is continuous and the joint rate jumps only by O(Δt).
        assert jumps[k] < 0.05, jumps[k]
    assert np.all(np.isfinite(qd))


# ---------------------------------------------------------------------------- two obstacles
def test_4r_second_constraint_joins_while_first_stays():
    arm = PlanarArm.four_r()
    q0 = _ik(arm, np.array([2.5, 1.0]), np.array([0.3, 0.5, 0.5, 0.5]))
    obs = [
        SphereObstacle(center=[0.3, -0.8], radius=0.05, influence=RHO),
        SphereObstacle(center=[1.1, -1.8], radius=0.05, influence=RHO),
    ]
    c = _ctrl(arm, obs, activation_margin=DT, release="sequential")  # the claim's literal order
    res = _run(c, q0, _down_then_up(2.5, 1.0, 100.0), 10.0)
    actives = [r.active for *_, r in res]
    both = [k for k, a in enumerate(actives) if len(a) == 2]
    assert both, "the second row must join"
    k = both[0]
    assert len(actives[k - 1]) == 1  # rows are added one at a time
    first = actives[k - 1][0]
    assert actives[k][0] == first  # the earlier row stays enforced, listed first
    d = np.array([r.distances for *_, r in res])
    assert d.min() >= RHO - SECOND_ORDER_TOL
    ee = max(r.ee_error for *_, r in res)
    assert ee < EE_TOL  # two rows = redundancy 2: still exact
    assert not any(r.exhausted for *_, r in res)
    print(f"4R two obstacles: min d-rho={d.min() - RHO:+.2e} m, EE err={ee:.2e} m")


# ---------------------------------------------------------------------------- exhausted
def _obstacles_in_front_of_links(arm, q, v, links, controller_free):
    """Obstacles just inside ρ, in front of each link's midpoint along its free velocity."""
    qd = controller_free.shape(q, v)
    segs = arm.link_segments(q)
    obs = []
    for link in links:
        mid = 0.5 * (segs[link, 0] + segs[link, 1])
        vel = arm.point_jacobian(q, link, 0.5) @ qd
        obs.append(
            SphereObstacle(
                center=mid + (RHO - 0.01) * vel / np.linalg.norm(vel), radius=0.05, influence=RHO
            )
        )
    return obs


def test_4r_redundancy_exhausted_flagged_bounded_no_nan():
    arm = PlanarArm.four_r()
    q = _ik(arm, np.array([2.5, 1.0]), np.array([0.3, 0.5, 0.5, 0.5]))
    v = np.array([0.0, -SPEED])
    obs = _obstacles_in_front_of_links(arm, q, v, (1, 2, 3), _ctrl(arm, []))
    damping = 1e-4
    c = _ctrl(arm, obs, damping=damping, release="sequential")
    r = c.control(q, v)
    assert r.redundancy == 2
    assert len(r.active) == 3
    assert r.exhausted
    assert r.zone == "exhausted"
    assert r.ee_yielded or r.violated  # some task gave way and it is named
    assert np.all(np.isfinite(r.q_dot))
    # ‖q̇‖ <= ‖b‖/√λ with b = [√w_e Ẏ_r; √w_z ż_r; 0] (ż_r = 0 here).
    assert np.linalg.norm(r.q_dot) <= np.linalg.norm(v) / math.sqrt(damping)
    assert math.isfinite(r.condition)
    # Closed loop through the pinch: never NaN, joint rates bounded.
    res = _run(c, q, lambda t: (v, None), 2.0)
    qd = np.array([x.q_dot for *_, x in res])
    assert np.all(np.isfinite(qd))
    assert np.abs(qd).max() < 10.0
    assert any(x.exhausted for *_, x in res)


# ---------------------------------------------------------------------------- edge cases
def test_centre_on_link_axis_uses_deterministic_fallback(arm3):
    q = np.array([0.0, 0.0, 0.0])  # links along +x
    ob = SphereObstacle(center=[0.5, 0.0, 0.0], radius=0.05, influence=RHO)
    c = _ctrl(arm3, [ob], spring_gain=1.0)
    r = c.control(q, np.array([0.0, 0.1]))
    np.testing.assert_allclose(r.normals[0], [0.0, 1.0, 0.0])  # ẑ × link direction
    assert r.distances[0] == 0.0
    assert np.all(np.isfinite(r.q_dot))
    assert r.zone in ("recovering", "free")


def test_recovery_gain_pushes_out_when_penetrated(arm3):
    q = np.array([0.3, 0.4, 0.5])
    segs = arm3.link_segments(q)
    mid = 0.5 * (segs[1, 0] + segs[1, 1])
    e = segs[1, 1] - segs[1, 0]
    nrm = np.array([-e[1], e[0], 0.0]) / np.linalg.norm(e)
    ob = SphereObstacle(center=mid + 0.1 * nrm, radius=0.05, influence=RHO)
    c = _ctrl(arm3, [ob], spring_gain=2.0)
    r = c.control(q, np.zeros(2))
    assert r.active == (0,)
    assert r.zone == "recovering"
    np.testing.assert_allclose(r.d_dot[0], 2.0 * (RHO - r.distances[0]), rtol=1e-2)


def test_link_radius_counts_in_critical_distance():
    thick = PlanarArm.three_r(link_radius=0.05)
    thin = PlanarArm.three_r()
    q = np.array([0.2, 0.3, 0.4])
    ob = SphereObstacle(center=[1.0, 1.0], radius=0.05, influence=RHO)
    d_thick = _ctrl(thick, [ob]).critical(q).distances[0]
    d_thin = _ctrl(thin, [ob]).critical(q).distances[0]
    assert d_thick == pytest.approx(d_thin - 0.05)


# ---------------------------------------------------------------------------- contract
def test_shaper_contract(arm3, q0_3r):
    ob = SphereObstacle(center=[1.5, -1.4], radius=0.05, influence=RHO)
    c = _ctrl(arm3, [ob])
    assert isinstance(c, Shaper)
    rng = np.random.default_rng(0)
    Q = q0_3r + rng.uniform(-0.5, 0.5, (20, 3))
    V = rng.normal(0.0, 0.3, (20, 2))
    out = c.shape_batch(Q, V)
    assert out.shape == (20, 3)
    for k in range(20):
        np.testing.assert_array_equal(out[k], c.shape(Q[k], V[k]))
        r = c.explain(Q[k], V[k])
        assert isinstance(r, ControlResult)
        np.testing.assert_array_equal(r.output, out[k])
        assert r.zone in ("free", "active", "recovering", "exhausted")
    with pytest.raises(InvalidInput, match=r"shapes \(N, 3\) and \(N, 2\)"):
        c.shape_batch(Q, V[:, :1])


def test_invalid_input_policy(arm3, q0_3r):
    ob = SphereObstacle(center=[1.5, -1.4], radius=0.05, influence=RHO)
    c = _ctrl(arm3, [ob])
    with pytest.raises(InvalidInput, match="expected finite values"):
        c.shape(q0_3r, np.array([np.nan, 0.0]))
    with pytest.raises(InvalidInput, match="expected finite values"):
        c.control(q0_3r, np.zeros(2), ee_target=np.array([np.inf, 0.0]))
    with pytest.raises(InvalidInput, match=r"command: expected shape \(2,\)"):
        c.shape(q0_3r, np.zeros(3))
    with pytest.raises(InvalidInput, match=r"position: expected shape \(3,\)"):
        c.shape(np.zeros(2), np.zeros(2))
    stop = _ctrl(arm3, [ob], on_invalid="stop")
    r = stop.explain(np.array([np.nan, 0.0, 0.0]), np.zeros(2))
    assert r.zone == "invalid"
    np.testing.assert_array_equal(r.output, np.zeros(3))
    huge = stop.explain(q0_3r, np.array([1e308, 1e308]))
    assert np.all(np.isfinite(huge.output))
    out = stop.shape_batch(np.vstack([q0_3r, q0_3r]), np.array([[np.nan, 0.0], [0.0, -0.1]]))
    np.testing.assert_array_equal(out[0], np.zeros(3))
    np.testing.assert_array_equal(out[1], stop.shape(q0_3r, np.array([0.0, -0.1])))


def test_spatial_seven_dof_single_state():
    from velfence.mechanisms.chain import DHChain

    chain = DHChain.seven_dof()
    q = np.full(chain.dof, 0.3)
    mid = chain.link_segments(q)[3].mean(axis=0)
    ob = SphereObstacle(center=mid + np.array([0.1, 0.0, 0.0]), radius=0.02, influence=0.15)
    c = _ctrl(chain, [ob])
    v = np.array([0.1, 0.0, 0.05])
    r = c.control(q, v)
    assert r.redundancy == 4
    assert r.active == (0,)
    assert r.d_dot_free[0] < 0
    assert abs(r.d_dot[0]) < 1e-4  # approach stopped
    assert np.all(np.isfinite(r.q_dot))
    back = c.control(q, -v)
    assert back.active == ()
    assert back.d_dot[0] > 0


@pytest.mark.slow
def test_blocked_path_the_constraint_holds_and_the_end_effector_yields():
    """The EE path forces link 1 through the sphere: the controller must not spin the arm.

    Found in review: with damping 1e-4 the near-singular (EE task + constraint) solve gave
    ~28 rad/s and, over 1 ms steps, the second-order motion drove the link 0.24 m into the
    sphere although the linearised ḋ was 0. Default damping 1e-2 (or max_speed) fixes it.
    """
    from velfence.filter import SphereObstacle
    from velfence.mechanisms.chain import PlanarArm
    from velfence.redundancy import ConfigurationController

    arm = PlanarArm.three_r()
    q0 = np.array([0.4, 0.9, 0.9])
    y0 = arm.end_effector(q0)
    y1 = np.array([-0.9, 1.6])
    T = 5.0
    vel = (y1 - y0) / T
    obs = [SphereObstacle(center=np.array([0.5, 1.0]), radius=0.05, influence=0.25)]
    for ctrl in (
        ConfigurationController(arm, obs, activation_margin=1e-3),
        ConfigurationController(arm, obs, activation_margin=1e-3, damping=1e-4, max_speed=2.0),
    ):
        q = q0.copy()
        worst = np.inf
        for k in range(6000):
            t = k * 1e-3
            yd = y0 + min(t, T) * vel
            cmd = (vel if t < T else 0 * vel) + 5.0 * (yd - arm.end_effector(q))
            r = ctrl.control(q, cmd)
            worst = min(worst, float(r.distances[0] - 0.25))
            assert np.abs(r.q_dot).max() < 3.0
            q = q + 1e-3 * r.q_dot
        assert worst > -5e-3  # vs -0.24 m before the fix
        assert np.linalg.norm(y1 - arm.end_effector(q)) > 0.3  # the EE task gave way


def test_recheck_release_never_holds_a_row_whose_point_would_retreat():
    """Review finding: with rows kept in order, an earlier row could block a retreat."""
    arm = PlanarArm.four_r()
    obs = [
        SphereObstacle(center=[0.3, -0.8], radius=0.05, influence=RHO),
        SphereObstacle(center=[1.1, -1.8], radius=0.05, influence=RHO),
    ]
    recheck = ConfigurationController(arm, obs)
    rng = np.random.default_rng(4)
    held = 0
    for _ in range(3000):
        q = rng.uniform(-np.pi, np.pi, 4)
        v = rng.normal(size=2)
        r = recheck.control(q, v)
        if len(r.active) < 2:
            continue
        held += 1
        for o in r.active:
            others = [a for a in r.active if a != o]
            alone = ConfigurationController(arm, [obs[a] for a in others]).control(q, v)
            # every kept row is needed: without it, its point would approach
            crit = ConfigurationController(arm, [obs[o]]).critical(q)
            assert float(crit.rows[0] @ alone.q_dot) < 1e-9
    assert held > 0
