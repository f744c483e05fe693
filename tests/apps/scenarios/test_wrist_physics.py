"""The patent wrist in MuJoCo: the closed chain against the kinematic model, and the scenario.

The closed-chain checks compare MuJoCo's own kinematics and dynamics of ``wrist_mjcf`` (site
positions, body frames, the motion ``mj_step`` produces) with
:class:`velfence.mechanisms.Wrist`'s closed-form kinematics. The scenario (slow, one run per
module) is checked from its record: penetrations recomputed from the recorded ``qpos``, the
push's penetration against the servo's compliance computed from the actuator Jacobian.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import shared_runs
from optional import requires
from velfence.errors import InvalidInput, InvalidParameter
from velfence.mechanisms import Wrist, WristGeometry

pytestmark = [requires("mujoco")]


def _rot(q: np.ndarray) -> np.ndarray:
    """R_y(pitch) R_z(yaw), written out independently of the model code."""
    t, p = q
    ry = np.array([[math.cos(t), 0, math.sin(t)], [0, 1, 0], [-math.sin(t), 0, math.cos(t)]])
    rz = np.array([[math.cos(p), -math.sin(p), 0], [math.sin(p), math.cos(p), 0], [0, 0, 1]])
    return ry @ rz


def _feasible_grid(wrist: Wrist, n: int = 9) -> np.ndarray:
    poly = wrist.default_polygon()
    lo, hi = poly.corners.min(axis=0), poly.corners.max(axis=0)
    P, Y = np.meshgrid(np.linspace(lo[0], hi[0], n), np.linspace(lo[1], hi[1], n), indexing="ij")
    Q = np.column_stack([P.ravel(), Y.ravel()])
    return Q[poly.contains(Q)]


GEOMETRIES = {
    "default": WristGeometry(),
    "short": WristGeometry(anchor_setback=0.1, stroke_min=0.095, stroke_max=0.12, rod_height=0.015),
}


@pytest.mark.parametrize("key", list(GEOMETRIES))
def test_assembled_pose_closes_the_chain_and_matches_the_lengths(key: str) -> None:
    import mujoco

    from velfence.robots import wrist_mjcf, wrist_qpos

    geo = GEOMETRIES[key]
    wrist = Wrist(geometry=geo)
    model = mujoco.MjModel.from_xml_string(wrist_mjcf(geo))
    data = mujoco.MjData(model)
    grid = _feasible_grid(wrist)
    assert len(grid) >= 30
    worst_gap = worst_len = worst_pin = worst_rot = 0.0
    A, B = geo.anchors, geo.attachments
    for q in grid:
        data.qpos[:] = wrist_qpos(q, geo)
        mujoco.mj_forward(model, data)
        # The equality rows (MuJoCo's own residual of the two connect constraints).
        eq = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        assert int(np.count_nonzero(eq)) == 6
        worst_gap = max(worst_gap, float(np.abs(data.efc_pos[eq]).max()))
        lengths = wrist.actuator_lengths(q)
        R = _rot(q)
        for k in (1, 2):
            # Pin-to-pin: the forearm anchor (the cylinder body's origin) to the rod end.
            pin = data.site(f"rod{k}_end").xpos - data.body(f"cylinder{k}").xpos
            worst_len = max(worst_len, abs(float(np.linalg.norm(pin)) - lengths[k - 1]))
            slide = data.qpos[model.joint(f"actuator{k}").qposadr[0]]
            worst_len = max(worst_len, abs(float(slide) - lengths[k - 1]))
            assert np.allclose(data.body(f"cylinder{k}").xpos, A[k - 1], atol=1e-15)
            worst_pin = max(
                worst_pin,
                float(np.abs(data.site(f"hand_pin{k}").xpos - R @ B[k - 1]).max()),
            )
        worst_rot = max(worst_rot, float(np.abs(data.body("hand").xmat.reshape(3, 3) - R).max()))
    assert worst_gap < 1e-9
    assert worst_len < 1e-9
    assert worst_pin < 1e-12
    assert worst_rot < 1e-12


def test_closed_chain_velocity_map_is_the_actuator_jacobian() -> None:
    """Drive the actuators at small constant speeds through mj_step; compare ΔL with J Δq."""
    from velfence.robots import wrist_qpos, wrist_robot
    from velfence.robots.wrist_model import WRIST_ACTUATED, WRIST_JOINTS
    from velfence.sim.physics import MujocoPlant

    wrist = Wrist()
    speeds = np.array([2e-3, -1.5e-3])  # [m/s]
    plant = MujocoPlant(
        wrist_robot(),
        joints=WRIST_JOINTS,
        actuated=WRIST_ACTUATED,
        transmission=lambda q, v: speeds,
        assemble=wrist_qpos,
        servo="velocity",
        kv=2000.0,
    )
    slides = [plant.model.joint(n).qposadr[0] for n in WRIST_ACTUATED]
    worst = 0.0
    poly = wrist.default_polygon()
    for q0 in ([0.0, 0.0], [0.3, -0.25], [-0.2, 0.25], [0.5, 0.2]):
        plant.reset(np.array(q0), 2e-3)
        for k in range(60):  # 120 ms: the servo (lag ≈ 3.5 ms) has settled
            plant.advance(np.zeros(2), k * 2e-3)
        qpos = plant.record.qpos
        for a, b in ((-11, -1), (-31, -21)):  # two 20 ms windows
            dq = qpos[b, :2] - qpos[a, :2]
            dL = qpos[b, slides] - qpos[a, slides]
            J = wrist.jacobian(0.5 * (qpos[a, :2] + qpos[b, :2]))
            assert poly.signed_distances(qpos[b, :2]).min() > 0.05  # no hard stop touched
            assert np.linalg.norm(dL) > 0.5 * 0.02 * np.linalg.norm(speeds)
            worst = max(worst, float(np.linalg.norm(J @ dq - dL) / np.linalg.norm(dL)))
    # Measured 2e-6; the soft connect constraints and the finite difference stay far below 1e-4.
    assert worst < 1e-4


def test_hard_stops_are_the_stroke() -> None:
    import mujoco

    from velfence.robots import wrist_mjcf

    geo = WristGeometry()
    stopped = mujoco.MjModel.from_xml_string(wrist_mjcf(geo))
    free = mujoco.MjModel.from_xml_string(wrist_mjcf(geo, hard_stops=False))
    for k in (1, 2):
        j = stopped.joint(f"actuator{k}")
        assert bool(stopped.jnt_limited[j.id])
        assert np.allclose(stopped.jnt_range[j.id], (geo.stroke_min, geo.stroke_max))
        assert not bool(free.jnt_limited[free.joint(f"actuator{k}").id])
    # Gravity compensation on every moving body, and the stated hand mass.
    assert np.allclose(stopped.body_gravcomp[1:], 1.0)
    assert stopped.body("hand").mass[0] == pytest.approx(0.3)
    plain = mujoco.MjModel.from_xml_string(wrist_mjcf(geo, gravity_compensation=False))
    assert np.allclose(plain.body_gravcomp, 0.0)


def test_robot_and_bad_inputs() -> None:
    from velfence.robots import wrist_qpos, wrist_robot

    robot = wrist_robot()
    assert robot.dof == 8
    assert robot.joint_names[:2] == ("pitch", "yaw")
    q = np.array([0.2, -0.1])
    full = wrist_qpos(q)
    tcp = robot.fk(full)
    assert np.allclose(tcp, _rot(q) @ np.array([0.1, 0.0, 0.0]), atol=1e-12)
    with pytest.raises(InvalidInput, match="q"):
        wrist_qpos([0.1, math.nan])
    with pytest.raises(InvalidInput, match="q"):
        wrist_qpos([0.1, 0.2, 0.3])
    with pytest.raises(InvalidParameter, match="geometry"):
        wrist_qpos(q, geometry="default")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="actuator_armature"):
        wrist_robot(actuator_armature=0.0)
    with pytest.raises(InvalidParameter, match="hard_stops"):
        wrist_robot(hard_stops=1)  # type: ignore[arg-type]


# --- the scenario ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def scenario():
    return shared_runs.scenario("wrist-push")  # shared with the figure and progress tests


@pytest.mark.slow
def test_named_checks_pass(scenario) -> None:
    failed = [(c.name, c.measured) for c in scenario.report.checks if not c.passed]
    assert not failed
    assert set(scenario.runs) == {"patent", "exact"}


@pytest.mark.slow
def test_penetrations_recomputed_from_the_recorded_qpos(scenario) -> None:
    from velfence.apps.scenarios.wrist import CORNER_TIME, PUSH_START

    poly = Wrist().default_polygon()
    for name, run in scenario.runs.items():
        q = run.record.qpos[:, :2]
        assert np.array_equal(q, run.trajectory.p)
        # Distance to every edge line from its corner and inward normal (not signed_distances).
        d = np.einsum("nek,ek->ne", q[:, None, :] - poly.corners[None, :, :], poly.normals)
        out = np.maximum(-d.min(axis=1), 0.0)
        t = run.record.t
        m = scenario.metrics[name]
        assert m["corner_leak"] == pytest.approx(out[t < CORNER_TIME].max(), abs=1e-12)
        assert m["push_penetration"] == pytest.approx(out[t >= PUSH_START].max(), abs=1e-12)


@pytest.mark.slow
def test_corner_leak_physics_against_kinematics(scenario) -> None:
    from velfence.apps.scenarios.wrist import CORNER_TIME

    geo = WristGeometry()
    patent, exact = scenario.metrics["patent"], scenario.metrics["exact"]
    # docs/reproductions.md: the faithful law leaks 0.160 rad at the 57° corner (kinematic).
    assert patent["kinematic_corner_leak"] == pytest.approx(0.160, abs=0.002)
    # Without hard stops MuJoCo finds the same leak: the servo only delays it.
    assert patent["corner_leak_no_stops"] == pytest.approx(
        patent["kinematic_corner_leak"], rel=0.02
    )
    # With them, both actuators bottom out on stroke_min: the leak ends there.
    run = scenario.runs["patent"]
    slides = [run.model.joint(f"actuator{k}").qposadr[0] for k in (1, 2)]
    late = run.record.t > 0.6 * CORNER_TIME
    lengths = run.record.qpos[late][:, slides]
    assert np.all(lengths[run.record.t[late] < CORNER_TIME].min(axis=0) < geo.stroke_min + 1e-5)
    assert 0.02 < patent["corner_leak"] < 0.5 * patent["corner_leak_no_stops"]
    # The exact law stays in: the kinematic run exactly, MuJoCo within its servo lag.
    assert exact["kinematic_corner_leak"] == 0.0
    assert exact["corner_leak"] <= 1e-3
    assert exact["corner_leak_no_stops"] <= 1e-3


@pytest.mark.slow
def test_push_penetration_against_the_servo_compliance(scenario) -> None:
    """A velocity servo gives way at F/kv: the wrist drifts at J⁻¹J⁻ᵀQ/kv during the push.

    Against the shaper's return (patent: operator P-law plus spring k·pen, superposed; exact:
    the P-law alone, its recovery floor k·pen being below it) the normal penetration follows
    a first-order law; the patent reaches its steady state, the exact law is 95 % there.
    """
    from velfence.apps.reproduce.wrist import BUFFER, GAIN
    from velfence.apps.scenarios.wrist import HOLD_GAIN, KV, PUSH_DURATION, PUSH_TORQUE

    wrist = Wrist()
    poly = wrist.default_polygon()
    lengths = np.linalg.norm(np.roll(poly.corners, -1, axis=0) - poly.corners, axis=1)
    e = int(np.argmax(lengths))
    n = poly.normals[e]
    mid = 0.5 * (poly.corners[e] + poly.corners[(e + 1) % poly.n])
    Ji = np.linalg.inv(wrist.jacobian(mid - 0.02 * n))
    drift = -float(n @ (Ji @ Ji.T @ (-PUSH_TORQUE * n)) / KV)  # outward speed [rad/s]
    hold = 0.5 * BUFFER
    patent = (drift - HOLD_GAIN * hold) / (HOLD_GAIN + GAIN)
    steady = drift / HOLD_GAIN - hold
    exact = steady - (hold + steady) * math.exp(-HOLD_GAIN * PUSH_DURATION)
    assert scenario.metrics["patent"]["push_penetration"] == pytest.approx(patent, rel=0.1)
    assert scenario.metrics["exact"]["push_penetration"] == pytest.approx(exact, rel=0.1)
    # Recovery: back within 1e-4 rad well within a second, the patent's spring first.
    rec = {m: scenario.metrics[m]["recovery_time"] for m in ("patent", "exact")}
    assert 0.0 < rec["patent"] < rec["exact"] < 0.5


@pytest.mark.slow
def test_no_chatter_and_the_chain_holds(scenario) -> None:
    for m in scenario.metrics.values():
        assert m["chatter"] == 0.0
        assert m["kinematic_chatter"] == 0.0
        assert 0.0 < m["chain_residual"] < 2e-5
