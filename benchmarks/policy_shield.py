"""The Gymnasium shield: vector throughput, wrapper overhead on Pusher-v5, and the big runs.

Usage: ``PYTHONPATH=src python benchmarks/policy_shield.py [--envs 1024] [--steps 300]
[--pusher-steps 2000] [--wild-steps 12500] [--skip-wild]`` prints Markdown tables with the load
average before and after. Numbers in docs/policies.md and docs/benchmarks.md.

* **Vector throughput**: a ``gymnasium.vector.VectorEnv`` of N kinematic seven-joint arms
  (``DHChain.seven_dof``, ``q += a dt``, ``dt`` = 10 ms) behind :class:`VectorShieldWrapper`:
  joint limits at 1.5 rad/s, a TCP box and 5 spheres, one :meth:`SafetyFilter.filter_batch`
  call per step (the C batch on 1 and on every core), a smooth random policy (an
  Ornstein-Uhlenbeck process per arm, at most 1.2 rad/s per joint). Timed: the
  wrapper's whole ``step`` (read the states, the batched filter, the env's own step) and the
  batched call alone; against a Python loop of ``SafetyFilter.filter`` over the same rows.
  Shielded env-steps/s = N / (median time of one vector step).
* **Wrapper overhead on Pusher-v5**: ``env.step`` alone against ``ShieldWrapper.step`` (torque
  servo, joint-velocity actions of a random policy; ``detail=False``: ``filter``; ``detail=True``:
  ``explain`` and the row names), the two interleaved step by step.
* **Wild policies, 10^5 steps** (``--wild-steps`` per policy and run): joint-limit violations and
  fingertip escapes on MuJoCo's own state, without and with the shield (the same command through
  the same servo), and the return of a scripted Pusher policy over 10 episodes.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.integrations.gymnasium import (
    Shield,
    ShieldWrapper,
    VectorShieldWrapper,
    mujoco_shield,
)
from velfence.mechanisms import DHChain

PUSHER = (
    "r_shoulder_pan_joint", "r_shoulder_lift_joint", "r_upper_arm_roll_joint",
    "r_elbow_flex_joint", "r_forearm_roll_joint", "r_wrist_flex_joint", "r_wrist_roll_joint",
)  # fmt: skip
BOX = ConvexPolytope.box([0.2, -0.85, -0.3], [1.05, 0.3, 0.15])
BOUNDS: dict[str, Any] = {"max_speed": 0.3, "max_acceleration": 0.5, "workspace_buffer": 0.15}
DT = 0.01


def stats(samples: list[float]) -> tuple[float, float, float]:
    a = np.asarray(samples) * 1e6
    return float(np.median(a)), float(np.percentile(a, 99)), float(a.max())


class KinematicArms(gym.vector.VectorEnv):  # type: ignore[misc]
    """N seven-joint arms integrating their joint velocity action (``q += a dt``)."""

    def __init__(self, n: int, q0: np.ndarray) -> None:
        self.num_envs = n
        self.q0 = q0
        self.q = np.tile(q0, (n, 1))
        box = gym.spaces.Box(-10.0, 10.0, shape=(7,), dtype=np.float64)
        self.single_observation_space = self.single_action_space = box
        self.observation_space = gym.vector.utils.batch_space(box, n)
        self.action_space = gym.vector.utils.batch_space(box, n)

    def reset(self, *, seed: Any = None, options: Any = None) -> Any:
        self.q = np.tile(self.q0, (self.num_envs, 1))
        return self.q.copy(), {}

    def step(self, actions: Any) -> Any:
        self.q += np.asarray(actions) * DT
        z = np.zeros(self.num_envs)
        f = np.zeros(self.num_envs, dtype=bool)
        return self.q.copy(), z, f, f, {}


class ArmsState:
    """The :class:`BatchJointState` of :class:`KinematicArms`."""

    joint_names = tuple(f"joint{i}" for i in range(7))

    def read_batch(self, envs: Any) -> tuple[np.ndarray, np.ndarray]:
        base = envs
        while not isinstance(base, KinematicArms):
            base = base.env
        return base.q.copy(), np.zeros_like(base.q)


def vector_bench(n: int, steps: int) -> list[str]:
    arm = DHChain.seven_dof(link_radius=0.05)
    lim = arm.joint_limits
    q0 = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.9, 0.0])
    p0 = arm.fk(q0)
    rng = np.random.default_rng(0)
    spheres = [SphereObstacle(p0 + rng.uniform(-0.3, 0.3, 3), radius=0.05) for _ in range(5)]
    f = SafetyFilter(
        arm,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5)),
        workspace=WorkspaceLimit(ConvexPolytope.box(p0 - 0.25, p0 + 0.25), buffer=0.05),
        obstacles=spheres, dt=DT,
    )  # fmt: skip
    assert f.backend == "c"
    assert f.cycle_in_c
    lines = [f"### Vector env: {n} arms, TCP box + 5 spheres, {steps} steps\n",
             "| what | threads | median [µs] | p99 [µs] | max [µs] | env-steps/s (median) |",
             "|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    # a smooth random policy (an Ornstein-Uhlenbeck process per arm, within the speed limits)
    actions = np.zeros((steps + 20, n, 7))
    a = np.zeros((n, 7))
    for k in range(steps + 20):
        a = 0.9 * a + 0.3 * rng.normal(size=(n, 7))
        actions[k] = np.clip(a, -1.2, 1.2)
    loop_med = 0.0
    for threads in (1, 0):
        env = KinematicArms(n, q0)
        sh = Shield(filter=f, state=None, action="velocity", actuation="velocity", period=DT)
        vw = VectorShieldWrapper(env, sh, state=ArmsState(), threads=threads)
        vw.reset(seed=0)
        for k in range(20):  # warm-up, the arms spread out
            vw.step(actions[k])
        step_t, batch_t, loop_t, paired_b, changed = [], [], [], [], 0
        for k in range(20, steps + 20):
            Q = env.q.copy()
            U = actions[k]
            t0 = time.perf_counter()
            r = f.filter_batch(Q, U, threads=threads)
            t1 = time.perf_counter()
            _, _, _, _, info = vw.step(actions[k])
            t2 = time.perf_counter()
            batch_t.append(t1 - t0)
            step_t.append(t2 - t1)
            changed += int(info["shield"]["changed"].sum())
            if threads == 1 and k % 10 == 0:  # the Python loop on the very same states
                t3 = time.perf_counter()
                X = [f.filter(Q[i], U[i]) for i in range(n)]
                loop_t.append(time.perf_counter() - t3)
                paired_b.append(t1 - t0)
                assert np.array_equal(np.array(X), r.output)  # bit for bit
        label = "1" if threads == 1 else f"{os.cpu_count()} (all)"
        for what, s in (("wrapper step", step_t), ("filter_batch alone", batch_t)):
            med, p99, mx = stats(s)
            lines.append(f"| {what} | {label} | {med:.0f} | {p99:.0f} | {mx:.0f} | "
                         f"{n / (med * 1e-6):,.0f} |")  # fmt: skip
        if loop_t:
            med, p99, mx = stats(loop_t)
            lines.append(f"| Python loop of `filter`, same states | 1 | {med:.0f} | {p99:.0f} | "
                         f"{mx:.0f} | {n / (med * 1e-6):,.0f} |")  # fmt: skip
            ratio = np.median(np.asarray(loop_t) / np.asarray(paired_b))
            lines.append(f"| (batch on 1 thread against that loop, median ratio) | | | | | "
                         f"{ratio:.1f}x |")  # fmt: skip
            loop_med = float(np.median(loop_t))
        else:
            lines.append(f"| (batch on every core against the loop, medians) | | | | | "
                         f"{loop_med / float(np.median(batch_t)):.1f}x |")  # fmt: skip
        lines.append(f"\n(threads {label}: {changed / (steps * n):.0%} of the rows changed)\n")
    return lines


class _Timed(gym.Wrapper):  # type: ignore[misc]
    """Times the wrapped env's own ``step`` (the physics and Gymnasium's bookkeeping)."""

    def __init__(self, env: Any) -> None:
        super().__init__(env)
        self.last = 0.0

    def step(self, action: Any) -> Any:
        t0 = time.perf_counter()
        out = self.env.step(action)
        self.last = time.perf_counter() - t0
        return out


def pusher_overhead(steps: int) -> list[str]:
    """The wrapper's own time per step: its whole ``step`` minus the env's ``step`` inside it
    (the same step, so the physics' cost, which depends on the state, cancels)."""
    lines = ["### One Pusher-v5 step\n", "| what | median [µs] | p99 [µs] | max [µs] | "
             "overhead / env step (medians) |", "|---|---:|---:|---:|---:|"]  # fmt: skip
    for detail in (False, True):
        env = gym.make("Pusher-v5")
        env.reset(seed=0)
        sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", workspace=BOX, **BOUNDS)
        inner = _Timed(env)
        w = ShieldWrapper(inner, sh, detail=detail)
        w.reset(seed=0)
        rng = np.random.default_rng(1)
        env_t, over_t = [], []
        for k in range(steps + 50):
            a = rng.uniform(-0.3, 0.3, size=7)
            t0 = time.perf_counter()
            w.step(a)
            t1 = time.perf_counter()
            if k >= 50:
                env_t.append(inner.last)
                over_t.append(t1 - t0 - inner.last)
        e, o = stats(env_t), stats(over_t)
        if not detail:
            lines.append(f"| `env.step` (inside the wrapper) | {e[0]:.0f} | {e[1]:.0f} | "
                         f"{e[2]:.0f} | |")  # fmt: skip
        lines.append(f"| wrapper's own time, detail={detail} | {o[0]:.0f} | {o[1]:.0f} | "
                     f"{o[2]:.0f} | {o[0] / e[0]:.0%} |")  # fmt: skip
    return lines


def wild(name: str) -> Any:
    if name == "saturated":
        return lambda r, k: np.full(7, 2.0) * (1 if (k // 40) % 2 == 0 else -1)
    if name == "jitter":
        return lambda r, k: 2.0 * np.sign(r.normal(size=7))
    if name == "biased-out":
        bias = np.array([-1.5, -1.5, 0.5, 1.5, 0.0, 1.5, 0.0])
        return lambda r, k: np.clip(bias + 0.3 * r.normal(size=7), -2.0, 2.0)
    return lambda r, k: r.uniform(-2.0, 2.0, size=7)


def pusher_run(name: str, shielded: bool, steps: int) -> dict[str, float]:
    env = gym.make("Pusher-v5")
    env.reset(seed=7)
    sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", workspace=BOX, **BOUNDS)
    w = ShieldWrapper(env, sh, detail=False, bypass=not shielded)  # the same command and servo
    u = env.unwrapped
    qa, _ = sh.state.addresses(u.model)
    lo, hi = sh.filter.limits.lower, sh.filter.limits.upper
    N, o = np.asarray(BOX.normals), np.asarray(BOX.offsets)
    rng = np.random.default_rng(7)
    policy = wild(name)
    out = {"joint_steps": 0, "joint_max": 0.0, "box_steps": 0, "box_max": 0.0}
    for k in range(steps):
        w.step(policy(rng, k))
        q = u.data.qpos[qa]
        over = float(np.max(np.maximum(lo - q, q - hi)))
        out["joint_steps"] += over > 1e-3
        out["joint_max"] = max(out["joint_max"], over)
        mujoco.mj_kinematics(u.model, u.data)
        d = float((N @ u.get_body_com("tips_arm") - o).min())
        out["box_steps"] += d < -1e-3
        out["box_max"] = max(out["box_max"], -d)
    return out


def scripted_return(shielded: bool, seed: int) -> float:
    env = gym.make("Pusher-v5")
    env.reset(seed=seed)
    sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", tip_offset=[0.1, 0.0, 0.0],
                       workspace=BOX, **BOUNDS)  # fmt: skip
    w = ShieldWrapper(env, sh, detail=False, bypass=not shielded)
    w.reset(seed=seed)
    u = env.unwrapped
    qa, _ = sh.state.addresses(u.model)
    robot = sh.filter.robot
    home = np.array([0.0, 0.6, 0.0, -1.3, 0.0, -0.6, 0.0])
    pushing = False
    total = 0.0
    for _ in range(100):
        q = u.data.qpos[qa].copy()
        mujoco.mj_kinematics(u.model, u.data)
        obj, goal = u.get_body_com("object")[:2], u.get_body_com("goal")[:2]
        tip = robot.fk(q)
        dv = (goal - obj) / (np.linalg.norm(goal - obj) + 1e-9)
        behind = obj - 0.09 * dv
        if not pushing:
            far = np.linalg.norm(tip[:2] - behind) > 0.03
            target = np.array([*behind, -0.12 if far else -0.27])
            pushing = not far and tip[2] < -0.25
        else:
            target = np.array([*(goal - 0.03 * dv), -0.27])
        v = 2.0 * (target - tip)
        v *= min(1.0, 0.25 / (np.linalg.norm(v) + 1e-12))
        J = robot.jacobian(q)
        Jp = J.T @ np.linalg.inv(J @ J.T + 1e-3 * np.eye(3))
        a = np.clip(Jp @ v + (np.eye(7) - Jp @ J) @ (home - q), -0.3, 0.3)
        _, r, _, _, _ = w.step(a)
        total += float(r)
    return total


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--envs", type=int, default=1024)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--pusher-steps", type=int, default=2000)
    ap.add_argument("--wild-steps", type=int, default=12_500)
    ap.add_argument("--skip-wild", action="store_true")
    args = ap.parse_args()
    load0 = os.getloadavg()
    out = vector_bench(args.envs, args.steps)
    out += ["", *pusher_overhead(args.pusher_steps)]
    if not args.skip_wild:
        out += ["", f"### Wild policies on Pusher-v5, {args.wild_steps} steps per run "
                f"({8 * args.wild_steps:,} in all)\n",
                "| policy | shield | joint steps > 1 mrad | max beyond [mrad] | box steps > 1 mm | "
                "max outside [mm] |", "|---|---|---:|---:|---:|---:|"]  # fmt: skip
        for name in ("random", "saturated", "jitter", "biased-out"):
            for shielded in (False, True):
                r = pusher_run(name, shielded, args.wild_steps)
                out.append(f"| {name} | {'with' if shielded else 'without'} | "
                           f"{r['joint_steps']} | {1e3 * r['joint_max']:.2f} | {r['box_steps']} | "
                           f"{1e3 * r['box_max']:.1f} |")  # fmt: skip
        raw = [scripted_return(False, s) for s in range(10)]
        safe = [scripted_return(True, s) for s in range(10)]
        out += ["", f"Scripted Pusher policy, 10 episodes: return {np.mean(raw):.2f} ± "
                f"{np.std(raw):.2f} without, {np.mean(safe):.2f} ± {np.std(safe):.2f} with the "
                "shield."]  # fmt: skip
    load1 = os.getloadavg()
    print("\n".join(out))
    print(f"\nLoad average {load0[0]:.2f} -> {load1[0]:.2f} on {os.cpu_count()} cores.")


if __name__ == "__main__":
    main()
