"""Velocity-damper QP baseline (NEO / mink style) on the configuration-control scenario."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter import SphereObstacle
from velfence.mechanisms.chain import PlanarArm
from velfence.redundancy import (
    ConfigurationController,
    ControlResult,
    VelocityDamperQP,
)
from velfence.shaping.base import Shaper

pytest.importorskip("qpsolvers")
pytest.importorskip("daqp")

DT = 0.01  # [s]
SPEED = 0.2  # [m/s]
RHO = 0.2  # [m] controller's sphere of influence (centre to link surface)
BODY = 0.05  # [m] obstacle radius
D_SAFE = RHO - BODY  # [m] same surface clearance as the controller's ρ
D_INFL = 0.3  # [m]
XI = 0.5  # [m/s]; ξ Δt / (d_i - d_s) = 0.033 << 1: no discrete-time overshoot
CLEAR_TOL = 5e-4  # [m] second-order drift allowance
EE_TOL = 2e-3  # [m]


def _ik(arm, target, q):
    for _ in range(100):
        J = arm.ee_jacobian(q)
        q = q + J.T @ np.linalg.solve(J @ J.T + 1e-9 * np.eye(2), target - arm.end_effector(q))
    return q


def _cmd(t, t_turn=8.0):
    if t < t_turn:
        return np.array([0.0, -SPEED]), np.array([2.0, 1.0 - SPEED * t])
    return np.array([0.0, SPEED]), np.array([2.0, 1.0 - SPEED * t_turn + SPEED * (t - t_turn)])


def _run(controller, q0, duration=12.0):
    q = np.array(q0, dtype=float)
    out = []
    for k in range(round(duration / DT) + 1):
        v, y = _cmd(k * DT)
        r = controller.control(q, v, ee_target=y)
        out.append((q.copy(), r))
        q = q + DT * r.q_dot
    return out


@pytest.fixture(scope="module")
def arm3():
    return PlanarArm.three_r()


@pytest.fixture(scope="module")
def q0_3r(arm3):
    return _ik(arm3, np.array([2.0, 1.0]), np.array([-0.4, 0.8, 1.0]))


@pytest.fixture(scope="module")
def obstacle():
    return SphereObstacle(center=[1.5, -1.4], radius=BODY, influence=RHO)


def _qp(chain, obstacles, **kw):
    params = {"gain_xi": XI, "d_influence": D_INFL, "d_safe": D_SAFE, "ee_gain": 1.0}
    params.update(kw)
    return VelocityDamperQP(chain, obstacles, **params)


def test_same_scenario_clearance_and_comparison(arm3, q0_3r, obstacle):
    qp = _qp(arm3, [obstacle])
    res = _run(qp, q0_3r)
    clear = np.array([qp.clearances(r.distances)[0] for _, r in res])
    ee = max(r.ee_error for _, r in res)
    assert clear.min() >= D_SAFE - CLEAR_TOL
    assert ee < EE_TOL
    assert any(r.zone == "active" for _, r in res)
    assert all(np.all(np.isfinite(r.q_dot)) for _, r in res)
    # The configuration controller on the same scenario: same surface clearance bound.
    cc = ConfigurationController(arm3, [obstacle], activation_margin=DT)
    res_cc = _run(cc, q0_3r)
    clear_cc = np.array([r.distances[0] - BODY for _, r in res_cc])
    ee_cc = max(r.ee_error for _, r in res_cc)
    assert clear_cc.min() >= D_SAFE - CLEAR_TOL
    # Agreement in spirit: both keep the surface clearance within a few mm of d_s and track.
    assert abs(clear.min() - clear_cc.min()) < 0.02
    print(
        f"surface clearance: QP min={clear.min():.5f} m, config-control min={clear_cc.min():.5f}"
        f" m (d_s={D_SAFE}); EE err QP={ee:.2e} m, config-control={ee_cc:.2e} m"
    )


def test_far_from_obstacles_is_damped_least_squares(arm3, q0_3r):
    far = SphereObstacle(center=[-3.0, -3.0], radius=BODY, influence=RHO)
    qp = _qp(arm3, [far], damping=1e-3)
    v = np.array([0.1, -0.2])
    r = qp.control(q0_3r, v)
    J = arm3.ee_jacobian(q0_3r)
    expected = np.linalg.solve(J.T @ J + 1e-3 * np.eye(3), J.T @ v)
    np.testing.assert_allclose(r.q_dot, expected, atol=1e-12)
    assert r.zone == "free"
    assert r.active == ()


def test_damper_inequality_holds_at_single_states(arm3, q0_3r, obstacle):
    qp = _qp(arm3, [obstacle])
    rng = np.random.default_rng(3)
    checked = 0
    for _ in range(100):
        q = q0_3r + rng.uniform(-0.6, 0.6, 3)
        v = rng.normal(0.0, 0.3, 2)
        r = qp.control(q, v)
        s = qp.clearances(r.distances)[0]
        if s <= D_INFL and r.zone != "infeasible":
            bound = XI * (s - D_SAFE) / (D_INFL - D_SAFE)
            assert -r.d_dot[0] <= bound + 1e-6
            checked += 1
    assert checked > 5


def test_parameters_validated_and_keyword_only(arm3, obstacle):
    for name, p in inspect.signature(VelocityDamperQP).parameters.items():
        if name not in ("chain", "obstacles"):
            assert p.kind is inspect.Parameter.KEYWORD_ONLY, name
    with pytest.raises(InvalidParameter, match="d_influence must exceed d_safe"):
        _qp(arm3, [obstacle], d_influence=0.1, d_safe=0.15)
    with pytest.raises(InvalidParameter, match="installed qpsolvers back-ends"):
        _qp(arm3, [obstacle], solver="no-such-solver")
    with pytest.raises(InvalidParameter, match="gain_xi must be finite and > 0"):
        _qp(arm3, [obstacle], gain_xi=0.0)


def test_contract_and_invalid_policy(arm3, q0_3r, obstacle):
    qp = _qp(arm3, [obstacle])
    assert isinstance(qp, Shaper)
    rng = np.random.default_rng(1)
    Q = q0_3r + rng.uniform(-0.4, 0.4, (10, 3))
    V = rng.normal(0.0, 0.3, (10, 2))
    out = qp.shape_batch(Q, V)
    for k in range(10):
        r = qp.explain(Q[k], V[k])
        assert isinstance(r, ControlResult)
        np.testing.assert_array_equal(r.output, out[k])
    with pytest.raises(InvalidInput, match="expected finite values"):
        qp.shape(q0_3r, np.array([np.inf, 0.0]))
    stop = _qp(arm3, [obstacle], on_invalid="stop")
    r = stop.explain(q0_3r, np.array([np.nan, 0.0]))
    assert r.zone == "invalid"
    np.testing.assert_array_equal(r.output, np.zeros(3))
