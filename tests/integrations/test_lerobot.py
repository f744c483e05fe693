"""velfence.integrations.lerobot: the SO-ARM model, LeRobot's units, the shield's bounds and errors.

The model is cross-checked against MuJoCo's own kinematics of the URDF (example-robot-data);
the unit conversions against numbers worked by hand from LeRobot's formulas
(``lerobot/motors/motors_bus.py``, ``MotorsBus._normalize``: degrees ``(ticks - mid) * 360 /
4095``, ``range_m100_100`` ``(ticks - min) / (max - min) * 200 - 100``, ``range_0_100``
``(ticks - min) / (max - min) * 100``).
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("mujoco")

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.filter import SphereObstacle
from velfence.integrations.lerobot import (
    ARM_JOINTS,
    JOINTS,
    LeRobotShield,
    SoArm,
    calibration_ranges,
    so_arm,
)

DT = 1.0 / 30.0
BOX = ((0.10, -0.25, 0.0), (0.42, 0.25, 0.35))
SPEEDS = dict.fromkeys(JOINTS, 90.0)
LEROBOT_DEG = 4095.0 / 4096.0  # one LeRobot degree in degrees of the joint


@pytest.fixture(scope="module")
def arm() -> SoArm:
    try:
        return so_arm()
    except ImportError as exc:  # the lerobot extra is not installed
        pytest.skip(str(exc))


@pytest.fixture(scope="module")
def mj(arm: SoArm) -> Any:
    from velfence.robots import MujocoRobot

    return MujocoRobot.from_urdf(arm.source, tcp_link="gripper_frame_link")


def make(arm: SoArm, **kw: Any) -> LeRobotShield:
    args: dict[str, Any] = {
        "dt": DT,
        "max_speed": SPEEDS,
        "table_height": 0.0,
        "workspace": BOX,
        "tool_radius": 0.02,
    }
    args.update(kw)
    return LeRobotShield(arm, **args)


def pose(deg: list[float], gripper: float = 50.0) -> dict[str, float]:
    return {f"{j}.pos": float(v) for j, v in zip(JOINTS, [*deg, gripper], strict=True)}


HOME = [0.0, -20.0, 20.0, 60.0, 0.0]  # a pose inside the box (checked below)


# ---------------------------------------------------------------------------------- model
def test_the_chain_is_mujocos_kinematics_of_the_urdf(arm: SoArm, mj: Any) -> None:
    import mujoco

    assert arm.chain.joint_names == ARM_JOINTS
    assert mj.joint_names[:5] == ARM_JOINTS
    frames = arm.chain.chain_frames()  # what the compiled filter cycle runs on
    assert frames is not None
    np.testing.assert_array_equal(arm.rotation, np.eye(3))
    np.testing.assert_array_equal(arm.origin, np.zeros(3))
    m = mj.model
    data = mujoco.MjData(m)
    axes = [m.joint(j).id for j in ("elbow_flex", "wrist_flex")]
    rng = np.random.default_rng(7)
    lim = arm.joint_limits
    for _ in range(200):
        q = rng.uniform(lim[:, 0], lim[:, 1])
        qm = np.append(q, rng.uniform(*arm.gripper_range))  # the jaw does not move the tcp
        np.testing.assert_allclose(arm.gripper_position(q), mj.fk(qm, "tcp"), atol=1e-9)
        np.testing.assert_allclose(frames.fk(q, "tcp"), mj.fk(qm, "tcp"), atol=1e-9)
        J = arm.rotation @ arm.chain.jacobian(q, "tcp")
        np.testing.assert_allclose(J, mj.jacobian(qm, "tcp")[:, :5], atol=1e-8)
        # "elbow" and "wrist": MuJoCo's anchors of the elbow-flex and wrist-flex joints.
        data.qpos[:] = qm
        mujoco.mj_kinematics(m, data)
        for name, jid in zip(("elbow", "wrist"), axes, strict=True):
            np.testing.assert_allclose(frames.fk(q, name), data.xanchor[jid], atol=1e-9)
            np.testing.assert_allclose(arm.chain.fk(q, name), data.xanchor[jid], atol=1e-9)
    assert arm.fit_error < 1e-9
    np.testing.assert_array_equal(arm.chain.link_radius, np.full(5, 0.03))
    assert make(arm).filter.cycle_in_c  # the compiled cycle runs the shield


def test_a_joint_beside_the_arm_is_fixed(arm: SoArm, tmp_path: Path) -> None:
    text = Path(arm.source).read_text("utf-8")
    # A second jointed child of the base: removed with the gripper joint, the arm stays serial.
    extra = (
        '<link name="side_link"><inertial><mass value="0.1"/><inertia ixx="1e-4" ixy="0" '
        'ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial></link><joint name="side" '
        'type="revolute"><parent link="base_link"/><child link="side_link"/><axis xyz="1 0 0"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    bad = tmp_path / "so101_side.urdf"
    bad.write_text(text.replace("</robot>", extra), "utf-8")
    side = so_arm(path=bad)
    assert side.chain.joint_names == ARM_JOINTS
    assert side.fit_error < 1e-9
    q = np.array([0.3, -0.4, 0.5, 0.2, 1.0])
    np.testing.assert_allclose(side.gripper_position(q), arm.gripper_position(q), atol=1e-12)


def test_the_limits_are_the_models_and_fit_one_servo_turn(arm: SoArm, mj: Any) -> None:
    np.testing.assert_array_equal(arm.joint_limits, mj.joint_limits[:5])
    assert arm.gripper_range == tuple(mj.joint_limits[5])
    # The table of docs/lerobot.md, in degrees of the joint.
    deg = np.degrees(np.vstack([arm.joint_limits, arm.gripper_range]))
    table = [(-110.0, 110.0), (-100.0, 100.0), (-96.8, 96.8), (-95.0, 95.0), (-157.2, 162.8)]
    np.testing.assert_allclose(deg[:5], table, atol=0.05)
    np.testing.assert_allclose(deg[5], (-10.0, 100.0), atol=0.05)
    # Each range spans less than the STS3215's 4096 ticks per turn.
    ticks = (deg[:, 1] - deg[:, 0]) / 360.0 * 4096
    assert np.all(ticks < 4096), ticks
    np.testing.assert_allclose(ticks[4], 3641.0, atol=1.0)  # wrist_roll: the widest


def test_a_joint_without_range_is_refused(arm: SoArm, tmp_path: Path) -> None:
    text = Path(arm.source).read_text("utf-8")
    start = text.index('<joint name="elbow_flex" type="revolute">')
    changed = text[:start] + text[start:].replace('type="revolute"', 'type="continuous"', 1)
    bad = tmp_path / "so101_no_elbow_range.urdf"
    bad.write_text(changed, "utf-8")
    with pytest.raises(InvalidGeometry, match=r"elbow_flex.*no range"):
        so_arm(path=bad)


# ---------------------------------------------------------------------------------- units
def test_degrees_are_lerobots(arm: SoArm) -> None:
    sh = make(arm)
    # Calibrated range 1000 … 3000 (mid 2000); 512 ticks past mid is 1/8 turn = 45°, which
    # LeRobot reports as 512 * 360 / 4095 = 45.01099 degrees.
    lerobot = 512 * 360 / 4095
    assert lerobot == pytest.approx(45.010989, abs=1e-6)
    q = sh.to_radians(pose([lerobot, -lerobot, 0.0, 0.0, 0.0]))
    np.testing.assert_allclose(q, [math.pi / 4, -math.pi / 4, 0.0, 0.0, 0.0], atol=1e-15)
    back = sh.from_radians([math.pi / 4, 0.0, 0.0, 0.0, 0.0])
    assert back["shoulder_pan.pos"] == pytest.approx(lerobot, abs=1e-12)


CAL = {
    j: {"id": i + 1, "drive_mode": 0, "homing_offset": 0, "range_min": 1000, "range_max": 3000}
    for i, j in enumerate(JOINTS)
}


def test_range_m100_100_is_lerobots(arm: SoArm) -> None:
    cal = {k: dict(v) for k, v in CAL.items()}
    cal["elbow_flex"]["drive_mode"] = 1
    sh = make(arm, units="range_m100_100", calibration=cal)
    # ticks 2256: LeRobot's ((2256 - 1000) / 2000) * 200 - 100 = 25.6; 256 ticks past mid
    # 2000 = 1/16 turn = 22.5°. drive_mode 1 reports -25.6 for the same ticks.
    assert pytest.approx(25.6) == ((2256 - 1000) / 2000) * 200 - 100
    q = sh.to_radians(pose([25.6, -25.6, -25.6, 100.0, -100.0]))
    np.testing.assert_allclose(
        q, [math.pi / 8, -math.pi / 8, math.pi / 8, 1000 * 2 * math.pi / 4096, -2 * math.pi
            * 1000 / 4096], atol=1e-12,
    )  # fmt: skip
    # The calibrated range (± 1000 ticks = ± 87.89°) narrows every model limit wider than it.
    half = 1000 * 2 * math.pi / 4096
    np.testing.assert_allclose(sh.joint_limits[:, 1], np.minimum(arm.joint_limits[:, 1], half))
    # A target beyond +100 is held inside the calibrated range.
    obs = pose([0.0, 0.0, 0.0, 99.0, 0.0])
    out = sh.shield(observation=obs, action=pose([0.0, 0.0, 0.0, 140.0, 0.0])).action
    assert out["wrist_flex.pos"] <= 100.0 + 1e-9


def test_range_m100_100_needs_the_calibration(arm: SoArm) -> None:
    with pytest.raises(InvalidParameter, match=r"calibration: unset.*range_m100_100"):
        make(arm, units="range_m100_100")
    bad = {k: dict(v) for k, v in CAL.items()}
    bad["gripper"]["range_min"] = 3500
    with pytest.raises(InvalidParameter, match="range_min < range_max"):
        calibration_ranges(bad)
    with pytest.raises(InvalidParameter, match="'wrist_roll' is missing"):
        calibration_ranges({k: v for k, v in CAL.items() if k != "wrist_roll"})


def test_gripper_0_100_maps_onto_the_models_range(arm: SoArm) -> None:
    sh = make(arm)
    g_lo, g_hi = arm.gripper_range
    # 90 deg/s over 1/30 s of a 110° range: 3 / 110 * 100 = 2.7273 units per call.
    step = 90.0 * DT * 100.0 / math.degrees(g_hi - g_lo)
    assert step == pytest.approx(300 / 110, rel=1e-4)
    out = sh.shield(observation=pose(HOME, 50.0), action=pose(HOME, 80.0)).action
    assert out["gripper.pos"] == pytest.approx(50.0 + step, abs=1e-12)
    out = sh.shield(observation=pose(HOME, 50.0), action=pose(HOME, 51.0)).action
    assert out["gripper.pos"] == 51.0


# ------------------------------------------------------------------- the order of the arguments
@pytest.mark.parametrize("call", ["shield", "explain"])
def test_the_state_comes_first_and_the_old_order_is_read_safely(arm: SoArm, call: str) -> None:
    obs = {**pose(HOME), "observation.images.front": "an image"}  # LeRobot adds cameras
    act = pose([20.0, -20.0, 20.0, 60.0, -20.0])
    want = getattr(make(arm), call)(observation=obs, action=act).action
    assert want != act  # the speed limit binds: a swap would show
    # keywords in either order, and positional in the new order: the same call
    assert getattr(make(arm), call)(action=act, observation=obs).action == want
    assert getattr(make(arm), call)(obs, act).action == want
    # the order before 0.2 (action first), told by the observation's extra keys: warns
    with pytest.warns(DeprecationWarning, match=rf"{call}\(observation, action\).*goes in 0\.3"):
        assert getattr(make(arm), call)(act, obs).action == want
    # two dictionaries of only the six joints: the order cannot be told, so it is refused
    with pytest.raises(InvalidParameter, match="by keyword"):
        getattr(make(arm), call)(pose(HOME), act)
    bad = [((obs,), {}), ((obs, act, act), {}), ((obs,), {"action": act}), ((), {"action": act})]
    for args, kwargs in bad:
        with pytest.raises(InvalidParameter, match="observation"):
            getattr(make(arm), call)(*args, **kwargs)


# ---------------------------------------------------------------------------------- the cycle
def test_a_free_target_passes_unchanged(arm: SoArm) -> None:
    sh = make(arm)
    assert np.all(
        (arm.gripper_position(sh.to_radians(pose(HOME))) > np.array(BOX[0]) + 0.05)
        & (arm.gripper_position(sh.to_radians(pose(HOME))) < np.array(BOX[1]) - 0.05)
    )
    target = pose([1.0, -21.0, 22.0, 59.0, 2.0], 52.0)
    r = sh.explain(observation=pose(HOME), action=target)
    assert r.filter_result is not None
    assert r.filter_result.zone == "free"
    for k, v in target.items():
        assert r.action[k] == pytest.approx(v, abs=1e-9)
    assert not r.held
    assert r.rejected == ()
    assert not r.gripper_clamped


def test_clamp_limits_the_step_to_max_speed(arm: SoArm) -> None:
    sh = make(arm)
    out = sh.shield(observation=pose(HOME), action=pose([20.0, -20.0, 20.0, 60.0, -20.0])).action
    step = 90.0 * DT / LEROBOT_DEG  # 3° of the joint in LeRobot degrees
    assert out["shoulder_pan.pos"] == pytest.approx(step, abs=1e-9)
    assert out["wrist_roll.pos"] == pytest.approx(-step, abs=1e-9)


def test_reject_holds_the_last_safe_target_and_pass_passes(arm: SoArm) -> None:
    sh = make(
        arm,
        rate_limit={"shoulder_pan": "reject", "wrist_roll": "pass", "gripper": "reject"},
        max_speed={k: v for k, v in SPEEDS.items() if k != "wrist_roll"},
    )
    obs = pose(HOME)
    first = sh.shield(observation=obs, action=pose([1.0, *HOME[1:]]))  # a small step: accepted
    assert first.rejected == ()
    assert first.action["shoulder_pan.pos"] == pytest.approx(1.0, abs=1e-9)
    jump = pose([40.0, -20.0, 20.0, 60.0, 30.0], 90.0)
    r = sh.shield(observation=obs, action=jump)
    assert r.rejected == ("shoulder_pan", "gripper")
    assert r.action["shoulder_pan.pos"] == pytest.approx(1.0, abs=1e-9)  # the last safe one
    assert r.action["gripper.pos"] == 50.0
    assert r.action["wrist_roll.pos"] == pytest.approx(30.0, abs=1e-9)  # pass: no rate limit
    sh.reset()
    r = sh.shield(observation=obs, action=jump)  # after reset the hold is the measured position
    assert r.action["shoulder_pan.pos"] == pytest.approx(0.0, abs=1e-9)


def test_a_joint_limit_is_never_crossed(arm: SoArm) -> None:
    sh = make(arm, rate_limit={"wrist_roll": "pass"}, max_speed={
        k: v for k, v in SPEEDS.items() if k != "wrist_roll"})  # fmt: skip
    upper = math.degrees(arm.joint_limits[4, 1]) / LEROBOT_DEG
    q = list(HOME)
    for _ in range(60):
        out = sh.shield(observation=pose(q), action=pose([*q[:4], 179.0])).action
        q = [out[f"{j}.pos"] for j in ARM_JOINTS]
        assert q[4] <= upper + 1e-9
    assert q[4] == pytest.approx(upper, abs=0.5)


def _loop(sh: LeRobotShield, mj: Any, seed: int, steps: int, down: bool) -> list[Any]:
    """A perfect position servo: the next measured position is the sent target."""
    rng = np.random.default_rng(seed)
    q = list(HOME)
    out = []
    for k in range(steps):
        if k % 15 == 0:
            goal = rng.uniform(-90, 90, 5) + (np.array([0, 60, 60, 60, 0]) if down else 0)
        act = sh.shield(observation=pose(q), action=pose(list(goal))).action
        q = [act[f"{j}.pos"] for j in ARM_JOINTS]
        out.append(mj.fk(np.append(sh.to_radians(act), 0.0), "tcp"))
    return out


@pytest.mark.parametrize("seed", [1, 2])
def test_closed_loop_keeps_the_gripper_sphere_in_the_box(arm: SoArm, mj: Any, seed: int) -> None:
    sh = make(arm, table_height=0.03)
    r = 0.02
    lo = np.array(BOX[0]) + r
    lo[2] = max(lo[2], 0.03 + r)
    hi = np.array(BOX[1]) - r
    pts = np.array(_loop(sh, mj, seed, 300, down=seed == 2))
    assert np.all(pts >= lo - 1e-6), pts.min(0)
    assert np.all(pts <= hi + 1e-6), pts.max(0)
    # … and the loop did push against it (the bound is not vacuous).
    assert np.min(np.minimum(pts - lo, hi - pts)) < 0.01


def test_closed_loop_keeps_the_links_off_an_obstacle(arm: SoArm) -> None:
    from velfence.geometry.primitives import sphere_capsule_distance

    centre = np.array([0.25, 0.0, 0.30])
    sh = make(arm, obstacles=[SphereObstacle(centre, radius=0.03)], workspace=((0.0, -0.4, 0.0),
              (0.5, 0.4, 0.5)))  # fmt: skip
    c_chain = arm.from_base(centre)
    rad = arm.chain.link_radius
    rng = np.random.default_rng(3)
    q = list(HOME)
    closest = np.inf
    for k in range(300):
        if k % 15 == 0:
            goal = rng.uniform(-60, 60, 5) + np.array([0, 20, -40, 0, 0])
        act = sh.shield(observation=pose(q), action=pose(list(goal))).action
        q = [act[f"{j}.pos"] for j in ARM_JOINTS]
        seg = arm.chain.link_segments(sh.to_radians(act))
        for i, (a, b) in enumerate(seg):
            d = sphere_capsule_distance(
                c_chain, a, b, sphere_radius=0.03, capsule_radius=float(rad[i])
            )[0]
            closest = min(closest, d)
    assert closest >= -1e-6
    assert closest < 0.005  # the links did reach it (without it they go 5 cm in)


# ---------------------------------------------------------------------------------- errors
@pytest.mark.parametrize(
    ("name", "value", "match"),
    [
        ("max_speed", None, r"max_speed: unset.*pass max_speed="),
        ("table_height", None, r"table_height: unset.*pass table_height="),
        ("workspace", None, r"workspace: unset.*pass workspace="),
        ("tool_radius", None, r"tool_radius: unset.*pass tool_radius="),
        ("max_speed", {k: 90.0 for k in ARM_JOINTS}, r"unset for joint 'gripper'"),
        ("max_speed", {**SPEEDS, "elbow": 1.0}, r"unknown joint"),
        ("rate_limit", {"gripper": "hold"}, r"rate_limit\['gripper'\] must be one of"),
        ("workspace", ((0, 0, 0), (0.03, 1, 1)), r"no room for a gripper sphere"),
    ],
)
def test_an_unset_or_bad_bound_refuses_to_start(
    arm: SoArm, name: str, value: Any, match: str
) -> None:
    with pytest.raises((InvalidParameter, InvalidGeometry), match=match):
        make(arm, **{name: value})


def test_bad_input_raises_a_clear_error(arm: SoArm) -> None:
    sh = make(arm)
    obs = pose(HOME)
    with pytest.raises(InvalidInput, match=r"observation\['elbow_flex.pos'\].*finite"):
        sh.shield(observation={**obs, "elbow_flex.pos": math.nan}, action=pose(HOME))
    with pytest.raises(InvalidInput, match=r"unknown joint.*'elbow.pos'"):
        sh.shield(observation=obs, action={**pose(HOME), "elbow.pos": 1.0})
    with pytest.raises(InvalidInput, match=r"missing.*'wrist_roll.pos'"):
        sh.shield(
            observation=obs, action={k: v for k, v in pose(HOME).items() if k != "wrist_roll.pos"}
        )
    with pytest.raises(InvalidInput, match=r"gripper.pos.*0 … 100.*got 120"):
        sh.shield(observation=obs, action=pose(HOME, 120.0))


def test_gripper_clamp_mode_clamps_and_says_so(arm: SoArm) -> None:
    sh = make(arm, gripper="clamp", rate_limit={"gripper": "pass"},
              max_speed={k: v for k, v in SPEEDS.items() if k != "gripper"})  # fmt: skip
    r = sh.shield(observation=pose(HOME, 3.0), action=pose(HOME, -5.0))
    assert r.gripper_clamped
    assert r.action["gripper.pos"] == 0.0


def test_on_invalid_stop_holds_the_measured_positions(arm: SoArm) -> None:
    sh = make(arm, on_invalid="stop")
    obs = pose([5.0, -20.0, 20.0, 60.0, 0.0], 40.0)
    r = sh.shield(observation=obs, action={**pose(HOME), "shoulder_lift.pos": math.inf})
    assert r.held
    assert "shoulder_lift" in r.reason
    assert r.action == obs
    # A measurement that is NaN: held at the last target sent, never NaN.
    sent = sh.shield(observation=pose(HOME), action=pose(HOME)).action
    r = sh.shield(observation={**obs, "elbow_flex.pos": math.nan}, action=pose(HOME))
    assert r.held
    assert r.action["elbow_flex.pos"] == sent["elbow_flex.pos"]
    assert all(math.isfinite(v) for v in r.action.values())
    # No measurement and nothing sent before: no hold action exists.
    sh.reset()
    with pytest.raises(InvalidInput, match="no hold action"):
        sh.shield(observation={**obs, "elbow_flex.pos": math.nan}, action=pose(HOME))


def test_the_module_imports_neither_lerobot_nor_torch_nor_mujoco() -> None:
    code = (
        "import sys, velfence.integrations.lerobot\n"
        "bad = [m for m in ('lerobot', 'torch', 'mujoco', 'mink') if m in sys.modules]\n"
        "print(bad)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    )
    assert out.stdout.strip() == "[]"
