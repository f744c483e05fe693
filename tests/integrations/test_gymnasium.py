"""The Gymnasium shield on envs nobody here wrote: Gymnasium's Pusher-v5 and Reacher-v5.

Everything is measured on MuJoCo's own state (``data.qpos``, the tip body's ``xipos`` after
``mj_kinematics``), not the filter's model: the arm read from the env's MJCF against the env's
own fingertip, joint-limit violations and workspace escapes of wild policies without and with
the shield (the same velocity commands through the same servo without the filter), the refusal
of unset bounds, bad actions and states, the reward penalty, position targets, and the vector
wrapper against single wrappers (bit for bit).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")
mujoco = pytest.importorskip("mujoco")
pytest.importorskip("velfence_core._filter")

from velfence.errors import InvalidInput, InvalidParameter  # noqa: E402
from velfence.geometry.polytope import ConvexPolytope  # noqa: E402
from velfence.integrations.gymnasium import (  # noqa: E402
    MujocoJointState,
    ShieldWrapper,
    VectorShieldWrapper,
    mujoco_arm,
    mujoco_shield,
)

PUSHER = (
    "r_shoulder_pan_joint", "r_shoulder_lift_joint", "r_upper_arm_roll_joint",
    "r_elbow_flex_joint", "r_forearm_roll_joint", "r_wrist_flex_joint", "r_wrist_roll_joint",
)  # fmt: skip
#: The fingertip's workspace: above the table, in front of the shoulder [m].
BOX = ConvexPolytope.box([0.2, -0.85, -0.3], [1.05, 0.3, 0.15])
#: Bounds the Pusher's 2 N·m motors can nearly follow (the servo's command must be trackable:
#: at 0.6 rad/s and 1.5 rad/s² the shoulder saturates and the arm coasts out of the box).
BOUNDS: dict[str, Any] = {"max_speed": 0.3, "max_acceleration": 0.5, "workspace_buffer": 0.15}


def _pusher(seed: int = 0) -> Any:
    env = gym.make("Pusher-v5")
    env.reset(seed=seed)
    return env


def _tip_distance(env: Any, box: ConvexPolytope, body: str) -> float:
    """The tip's signed distance to the box [m] from MuJoCo's own kinematics (the task's point,
    ``get_body_com``)."""
    u = env.unwrapped
    mujoco.mj_kinematics(u.model, u.data)
    p = u.get_body_com(body)
    return float((np.asarray(box.normals) @ p - np.asarray(box.offsets)).min())


def test_arm_from_the_env_mjcf_matches_the_env_fingertip() -> None:
    env = _pusher()
    robot = mujoco_arm(env, PUSHER, tip="tips_arm")
    u = env.unwrapped
    qa = MujocoJointState(PUSHER).addresses(u.model)[0]
    rng = np.random.default_rng(1)
    lim = robot.joint_limits
    for _ in range(5):
        q = rng.uniform(lim[:, 0], lim[:, 1])
        u.data.qpos[qa] = q
        mujoco.mj_kinematics(u.model, u.data)
        np.testing.assert_allclose(robot.fk(q), u.get_body_com("tips_arm"), rtol=0, atol=1e-12)
        fingers = mujoco_arm(env, PUSHER, tip="tips_arm", tip_offset=[0.1, 0.0, 0.0])
        mid = (u.data.geom_xpos[u.model.geom("tip_arml").id]
               + u.data.geom_xpos[u.model.geom("tip_armr").id]) / 2  # fmt: skip
        np.testing.assert_allclose(fingers.fk(q), mid, rtol=0, atol=1e-12)
    assert robot.chain_frames() is not None  # the C cycle runs on it
    with pytest.raises(InvalidParameter, match="missing from joints"):
        mujoco_arm(env, PUSHER[:6], tip="tips_arm")  # the wrist roll moves the tip
    with pytest.raises(InvalidParameter, match="not joints"):
        mujoco_arm(env, ("elbow",), tip="tips_arm")
    with pytest.raises(InvalidParameter, match="not a body"):
        mujoco_arm(env, PUSHER, tip="hand")
    with pytest.raises(InvalidParameter, match="model order"):
        mujoco_arm(env, PUSHER[::-1], tip="tips_arm")
    # The env's numbers as MuJoCo compiled them for the env (no six-digit rewrite).
    for body in ("r_shoulder_pan_link", "r_wrist_flex_link", "tips_arm"):
        np.testing.assert_array_equal(robot.model.body(body).pos, u.model.body(body).pos)
        np.testing.assert_array_equal(robot.model.body(body).quat, u.model.body(body).quat)


def test_reacher_arm_matches_the_env_fingertip() -> None:
    env = gym.make("Reacher-v5")
    env.reset(seed=3)
    u = env.unwrapped
    robot = mujoco_arm(env, ("joint0", "joint1"), tip="fingertip")
    assert robot.joint_names == ("joint0", "joint1")
    assert robot.chain_frames() is not None
    qa = MujocoJointState(("joint0", "joint1")).addresses(u.model)[0]
    for q in ([0.3, -1.2], [-2.5, 2.0], [3.0, 0.1]):
        u.data.qpos[qa] = q
        mujoco.mj_kinematics(u.model, u.data)
        np.testing.assert_allclose(robot.fk(q), u.get_body_com("fingertip"), rtol=0, atol=1e-12)


def test_unset_bounds_refuse_to_start_and_say_how() -> None:
    env = gym.make("Reacher-v5")
    env.reset(seed=0)
    with pytest.raises(InvalidParameter, match=r"joint\(s\) \['joint0'\].*joint_limits="):
        mujoco_shield(env, joints=("joint0", "joint1"), tip="fingertip", max_speed=2.0)
    with pytest.raises(InvalidParameter, match="max_speed: MJCF has no joint speed limit"):
        mujoco_shield(env, joints=("joint0", "joint1"), tip="fingertip", max_speed=None,
                      joint_limits={"joint0": (-3.0, 3.0)})  # type: ignore[arg-type]  # fmt: skip
    with pytest.raises(InvalidParameter, match="inside the MJCF range"):
        mujoco_shield(env, joints=("joint0", "joint1"), tip="fingertip", max_speed=2.0,
                      joint_limits={"joint0": (-3.0, 3.0), "joint1": (-4.0, 1.0)})  # fmt: skip
    sh = mujoco_shield(env, joints=("joint0", "joint1"), tip="fingertip", max_speed=2.0,
                       joint_limits={"joint0": (-2.5, 2.5)})  # fmt: skip
    assert sh.actuation == "torque"  # Reacher's motors
    np.testing.assert_array_equal(sh.filter.limits.lower, [-2.5, -3.0])  # joint1: the MJCF's
    assert sh.period == pytest.approx(env.unwrapped.dt)


def _wild(name: str) -> Any:
    if name == "saturated":
        return lambda r, k: np.full(7, 2.0) * (1 if (k // 40) % 2 == 0 else -1)
    if name == "jitter":
        return lambda r, k: 2.0 * np.sign(r.normal(size=7))
    if name == "biased-out":
        bias = np.array([-1.5, -1.5, 0.5, 1.5, 0.0, 1.5, 0.0])
        return lambda r, k: np.clip(bias + 0.3 * r.normal(size=7), -2.0, 2.0)
    return lambda r, k: r.uniform(-2.0, 2.0, size=7)


def _pusher_run(
    policy: Any,
    shielded: bool,
    steps: int,
    seed: int = 0,
    strong: bool = False,
    bounds: dict[str, Any] | None = None,
) -> dict[str, float]:
    """Joint-limit violations and box escapes of ``policy`` on MuJoCo's own state (``strong``:
    motors of ±100 N·m instead of ±2, so the servo follows its command)."""
    env = _pusher(seed)
    if strong:
        env.unwrapped.model.actuator_ctrlrange[:] = [-100.0, 100.0]
    sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", workspace=BOX, **(bounds or BOUNDS))
    w = ShieldWrapper(env, sh, detail=False, bypass=not shielded)  # the same command and servo
    u = env.unwrapped
    qa, _ = sh.state.addresses(u.model)
    lo, hi = sh.filter.limits.lower, sh.filter.limits.upper
    rng = np.random.default_rng(seed)
    out = {"joint_steps": 0, "joint_max": 0.0, "box_steps": 0, "box_max": 0.0}
    for k in range(steps):
        _, _, _, _, info = w.step(policy(rng, k))
        if not shielded:
            assert not info["shield"]["changed"]
            np.testing.assert_array_equal(info["shield"]["output"], info["shield"]["command"])
        over = float(np.max(np.maximum(lo - u.data.qpos[qa], u.data.qpos[qa] - hi)))
        out["joint_steps"] += over > 1e-3
        out["joint_max"] = max(out["joint_max"], over)
        d = _tip_distance(env, BOX, "tips_arm")
        out["box_steps"] += d < -1e-3
        out["box_max"] = max(out["box_max"], -d)
    return out


@pytest.mark.parametrize("name", ["saturated", "jitter", "biased-out"])
def test_wild_policies_on_pusher_escape_far_less_with_the_shield(name: str) -> None:
    raw = _pusher_run(_wild(name), False, 240)
    safe = _pusher_run(_wild(name), True, 240)
    assert raw["box_steps"] >= 100  # the policy does drive the fingertip out
    assert safe["box_steps"] <= raw["box_steps"] / 5
    assert safe["box_max"] <= raw["box_max"] / 10
    assert safe["joint_steps"] == 0  # joint limits: never 1 mrad beyond on MuJoCo's qpos


@pytest.mark.parametrize("name", ["saturated", "jitter"])
def test_a_servo_that_can_follow_keeps_everything_inside(name: str) -> None:
    """With motors strong enough for the servo to track the shielded command, no joint passes
    its limit by 1 mrad and the fingertip (MuJoCo's) leaves the box by at most 3 mm (the
    servo's one-period lag behind a jittering command; 0 for the saturated policy); without the
    shield the same commands leave it by 30-50 cm."""
    fast = {**BOUNDS, "max_speed": 0.6, "max_acceleration": 1.5}
    raw = _pusher_run(_wild(name), False, 200, strong=True)
    assert raw["box_steps"] >= 50
    safe = _pusher_run(_wild(name), True, 200, strong=True, bounds=fast)
    assert safe["box_max"] < 3e-3
    assert safe["box_steps"] <= (0 if name == "saturated" else 5)
    assert raw["box_max"] > 0.2
    assert safe["joint_steps"] == 0


def test_info_reports_what_the_shield_did_and_the_penalty() -> None:
    env = _pusher()
    sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", workspace=BOX, **BOUNDS)
    raw_rewards: list[float] = []

    class Tap(gym.Wrapper):  # type: ignore[misc]
        def step(self, action: Any) -> Any:
            r = self.env.step(action)
            raw_rewards.append(float(r[1]))
            return r

    w = ShieldWrapper(Tap(env), sh, penalty=0.5)
    w.reset(seed=0)
    rng = np.random.default_rng(0)
    seen_active = False
    for k in range(60):
        a = rng.uniform(-0.6, 0.6, size=7) if k % 2 else np.full(7, 0.6)
        _, reward, _, _, info = w.step(a)
        s = info["shield"]
        x, u = s["output"], s["command"]
        np.testing.assert_array_equal(u, a)
        assert s["changed"] == (not np.array_equal(x, u))
        assert s["penalty"] == pytest.approx(0.5 * float(np.sum((x - u) ** 2)))
        assert reward == pytest.approx(raw_rewards[-1] - s["penalty"])
        q = env.unwrapped.data.qpos[:7]
        assert s["distance"]["joint_upper"].shape == (7,)
        assert np.all(s["distance"]["workspace tcp"] > -0.05)
        if s["changed"]:
            assert s["active"]  # names of the binding rows
            assert all(isinstance(n, str) for n in s["active"])
            seen_active = True
        assert np.isfinite(q).all()
    assert seen_active
    assert s["interventions"] == w.interventions > 0


def test_position_targets_on_pusher_stay_inside_the_limits() -> None:
    env = _pusher()
    sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", action="position", workspace=BOX,
                       **BOUNDS)  # fmt: skip
    w = ShieldWrapper(env, sh, detail=False)
    w.reset(seed=0)
    assert w.action_space.shape == (7,)
    lo, hi = sh.filter.limits.lower, sh.filter.limits.upper
    np.testing.assert_array_equal(w.action_space.low, lo)
    rng = np.random.default_rng(2)
    target = rng.uniform(lo, hi)
    qa = sh.state.addresses(env.unwrapped.model)[0]
    for k in range(150):
        if k % 50 == 0:
            target = np.where(rng.random(7) < 0.5, lo, hi)  # at the limits
        _, _, _, _, info = w.step(target)
        cmd = info["shield"]["command"]
        q = env.unwrapped.data.qpos[qa]
        assert np.all(q >= lo - 1e-3)
        assert np.all(q <= hi + 1e-3)
    assert np.all(np.abs(cmd) < 1e3)


def test_reacher_velocity_shield_keeps_the_fingertip_in_its_box() -> None:
    env = gym.make("Reacher-v5")
    env.reset(seed=0)
    box = ConvexPolytope.box([-0.05, -0.22, -1.0], [0.22, 0.22, 1.0])
    sh = mujoco_shield(env, joints=("joint0", "joint1"), tip="fingertip", max_speed=2.0,
                       max_acceleration=20.0, joint_limits={"joint0": (-1.5, 1.5)},
                       workspace=box, workspace_buffer=0.05)  # fmt: skip
    w = ShieldWrapper(env, sh, detail=False)
    w.reset(seed=0)
    rng = np.random.default_rng(4)
    worst = np.inf
    for k in range(200):
        a = np.array([2.0, -2.0]) * (1 if (k // 50) % 2 else -1) + 0.2 * rng.normal(size=2)
        w.step(a)
        worst = min(worst, _tip_distance(env, box, "fingertip"))
    assert worst > -5e-3  # MuJoCo's fingertip: at most 5 mm past a face


def test_bad_actions_and_states() -> None:
    env = _pusher()
    sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", **BOUNDS)
    w = ShieldWrapper(env, sh)
    w.reset(seed=0)
    with pytest.raises(InvalidInput, match="action"):
        w.step(np.zeros(6))
    with pytest.raises(InvalidInput, match=r"action.*booleans"):
        w.step(np.zeros(7, dtype=bool))
    with pytest.raises(InvalidInput, match="action"):
        w.step(["a"] * 7)
    nan = np.full(7, 0.1)
    nan[3] = np.nan
    with pytest.raises(InvalidInput, match="non-finite"):
        w.step(nan)
    stop = mujoco_shield(env, joints=PUSHER, tip="tips_arm", on_invalid="stop", **BOUNDS)
    sent: list[np.ndarray] = []

    class Tap(gym.Wrapper):  # type: ignore[misc]
        def step(self, action: Any) -> Any:
            sent.append(np.array(action))
            return self.env.step(action)

    w = ShieldWrapper(Tap(env), stop)
    w.reset(seed=0)
    _, _, _, _, info = w.step(nan)
    assert info["shield"]["invalid"]
    assert np.isfinite(sent[-1]).all()  # the hold action: the servo's torques for zero
    # a NaN in MuJoCo's state (the observation's source)
    qa = stop.state.addresses(env.unwrapped.model)[0]
    env.unwrapped.data.qpos[qa[2]] = np.nan
    with pytest.raises(InvalidInput, match="non-finite"):
        ShieldWrapper(env, sh)._shielded(np.zeros(7))
    env_a, rep = w._shielded(np.zeros(7))
    assert rep["invalid"]
    np.testing.assert_array_equal(env_a, np.zeros(7))  # no state: no torque


def test_vector_wrapper_equals_single_wrappers() -> None:
    n = 3

    def make() -> Any:
        return gym.make("Pusher-v5")

    venv = gym.vector.SyncVectorEnv([make for _ in range(n)])
    venv.reset(seed=[10, 11, 12])
    sh = mujoco_shield(venv.envs[0], joints=PUSHER, tip="tips_arm", workspace=BOX, **BOUNDS)
    vw = VectorShieldWrapper(venv, sh, threads=2)
    vw.reset(seed=[10, 11, 12])
    singles = []
    for k in range(n):
        e = make()
        s = mujoco_shield(e, joints=PUSHER, tip="tips_arm", workspace=BOX, **BOUNDS)
        w = ShieldWrapper(e, s, detail=False)
        w.reset(seed=10 + k)
        singles.append(w)
    rng = np.random.default_rng(0)
    total = 0
    for _ in range(40):
        A = rng.uniform(-2.0, 2.0, size=(n, 7))
        obs, rew, _, _, info = vw.step(A)
        for k, w in enumerate(singles):
            o, r, _, _, i = w.step(A[k])
            np.testing.assert_array_equal(obs[k], o)
            assert rew[k] == r
            assert bool(info["shield"]["changed"][k]) == i["shield"]["changed"]
        total += int(info["shield"]["changed"].sum())
    assert total > 0
    assert vw.action_space.shape == (n, 7)


def _scripted_pusher(env: Any, robot: Any) -> Any:
    """A reasonable Pusher policy in joint velocities: the finger point (``robot``'s tcp) to
    behind the object, down to the table, then toward the goal (damped least squares at most
    0.25 m/s, a bent-elbow posture in the null space, joint speeds clipped to 0.3 rad/s)."""
    u = env.unwrapped
    pushing = [False]
    home = np.array([0.0, 0.6, 0.0, -1.3, 0.0, -0.6, 0.0])

    def policy(q: np.ndarray) -> np.ndarray:
        mujoco.mj_kinematics(u.model, u.data)
        obj, goal = u.get_body_com("object")[:2], u.get_body_com("goal")[:2]
        tip = robot.fk(q)
        d = (goal - obj) / (np.linalg.norm(goal - obj) + 1e-9)
        behind = obj - 0.09 * d
        if not pushing[0]:
            far = np.linalg.norm(tip[:2] - behind) > 0.03
            target = np.array([*behind, -0.12 if far else -0.27])
            pushing[0] = not far and tip[2] < -0.25
        else:
            target = np.array([*(goal - 0.03 * d), -0.27])
        v = 2.0 * (target - tip)
        v *= min(1.0, 0.25 / (np.linalg.norm(v) + 1e-12))
        J = robot.jacobian(q)
        Jp = J.T @ np.linalg.inv(J @ J.T + 1e-3 * np.eye(3))
        return np.clip(Jp @ v + (np.eye(7) - Jp @ J) @ (home - q), -0.3, 0.3)

    return policy


def _pusher_return(shielded: bool, seed: int) -> tuple[float, int]:
    env = _pusher(seed)
    sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", tip_offset=[0.1, 0.0, 0.0],
                       workspace=BOX, **BOUNDS)  # fmt: skip
    w = ShieldWrapper(env, sh, detail=False, bypass=not shielded)
    w.reset(seed=seed)
    qa, _ = sh.state.addresses(env.unwrapped.model)
    policy = _scripted_pusher(env, sh.filter.robot)
    total, changed = 0.0, 0
    d = env.unwrapped.data
    for _ in range(100):  # one Pusher-v5 episode
        q = d.qpos[qa].copy()
        _, r, _, _, info = w.step(policy(q))
        changed += info["shield"]["changed"]
        total += float(r)
    return total, changed


def test_scripted_pusher_keeps_its_reward_with_the_shield() -> None:
    for seed in (1, 3):
        raw, _ = _pusher_return(False, seed)
        safe, changed = _pusher_return(True, seed)
        assert changed > 0  # the shield did act (acceleration and workspace rows)
        assert safe >= raw - 0.05 * abs(raw)  # the task's return is kept (within 5 %)


def test_twist_actions_on_pusher() -> None:
    env = _pusher()
    sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", action="twist", workspace=BOX,
                       twist_speed=0.3, **BOUNDS)  # fmt: skip
    w = ShieldWrapper(env, sh)
    w.reset(seed=0)
    assert w.action_space.shape == (3,)
    worst = np.inf
    for k in range(120):
        v = np.array([0.0, 0.3, -0.3]) if k < 60 else np.array([0.3, -0.3, 0.3])
        _, _, _, _, info = w.step(v)
        assert np.isfinite(info["shield"]["output"]).all()
        worst = min(worst, _tip_distance(env, BOX, "tips_arm"))
    assert w.interventions > 0
    assert worst > -5e-3
    with pytest.raises(InvalidInput, match="action"):
        w.step(np.zeros(7))


@pytest.mark.slow
def test_a_hundred_thousand_pusher_steps_of_wild_policies() -> None:
    """10⁵ Pusher-v5 steps in all (four wild policies, 12,500 steps each, without and with the
    shield), measured on MuJoCo's own state: the shield never lets a joint 1 mrad past its limit
    and cuts the steps with the fingertip out of the box at least five-fold."""
    for name in ("random", "saturated", "jitter", "biased-out"):
        raw = _pusher_run(_wild(name), False, 12_500, seed=7)
        safe = _pusher_run(_wild(name), True, 12_500, seed=7)
        assert safe["joint_steps"] == 0, (name, safe)
        assert safe["box_steps"] <= raw["box_steps"] / 5, (name, raw, safe)
        assert safe["box_max"] < raw["box_max"], (name, raw, safe)
