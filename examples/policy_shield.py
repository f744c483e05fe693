"""A wild policy on Gymnasium's Pusher-v5, without and with the velfence shield.

The policy drives the arm out of the fingertip's workspace box (joint velocities biased outward,
saturated at 2 rad/s, with jitter). Both runs send their joint velocity command through the same
computed-torque servo to Pusher's torque motors; the shielded one lets the SafetyFilter shape it
first (``velfence.integrations.gymnasium``). Everything is measured on MuJoCo's own state (the
``tips_arm`` body, ``data.qpos``). Writes a figure (the fingertip's path against the box, the
joints against their limits, the interventions) and a side-by-side video::

    MUJOCO_GL=egl python examples/policy_shield.py [OUT_DIR] [--steps N] [--no-video]

Needs the ``gym``, ``physics`` and ``app`` extras (Gymnasium with MuJoCo, imageio-ffmpeg,
matplotlib). About 40 s with the video (200 steps).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering, before MuJoCo is imported

import gymnasium as gym
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mujoco
import numpy as np

from velfence.geometry import ConvexPolytope
from velfence.integrations import ShieldWrapper, mujoco_shield

PUSHER = (
    "r_shoulder_pan_joint", "r_shoulder_lift_joint", "r_upper_arm_roll_joint",
    "r_elbow_flex_joint", "r_forearm_roll_joint", "r_wrist_flex_joint", "r_wrist_roll_joint",
)  # fmt: skip
BOX = ConvexPolytope.box([0.2, -0.85, -0.3], [1.05, 0.3, 0.15])  # the fingertip's box [m]
BOUNDS: dict[str, Any] = {"max_speed": 0.3, "max_acceleration": 0.5, "workspace_buffer": 0.15}
BIAS = np.array([-1.5, -1.5, 0.5, 1.5, 0.0, 1.5, 0.0])  # rad/s: out of the box, into the limits


def wild(rng: np.random.Generator) -> np.ndarray:
    """Saturated, jittering, biased out of the workspace."""
    return np.clip(BIAS + 1.0 * rng.normal(size=7), -2.0, 2.0)


def run(shielded: bool, steps: int, seed: int = 0) -> dict[str, Any]:
    env = gym.make("Pusher-v5")
    env.reset(seed=seed)
    sh = mujoco_shield(env, joints=PUSHER, tip="tips_arm", workspace=BOX, **BOUNDS)
    # unshielded: the same wrapper with the filter bypassed (the same command, the same servo)
    w = ShieldWrapper(env, sh, detail=False, bypass=not shielded)
    w.reset(seed=seed)
    u = env.unwrapped
    qa, _ = sh.state.addresses(u.model)
    rng = np.random.default_rng(seed)
    rec: dict[str, list[Any]] = {"qpos": [], "tip": [], "q": [], "changed": []}
    for _ in range(steps):
        a = wild(rng)
        _, _, _, _, info = w.step(a)
        rec["changed"].append(bool(info["shield"]["changed"]))
        mujoco.mj_kinematics(u.model, u.data)
        rec["qpos"].append(u.data.qpos.copy())
        rec["tip"].append(u.get_body_com("tips_arm").copy())
        rec["q"].append(u.data.qpos[qa].copy())
    out = {k: np.array(v) for k, v in rec.items()}
    d = out["tip"] @ np.asarray(BOX.normals).T - np.asarray(BOX.offsets)
    lo, hi = sh.filter.limits.lower, sh.filter.limits.upper
    out["box_depth"] = np.maximum(0.0, -d.min(axis=1))
    out["joint_over"] = np.maximum(0.0, np.maximum(lo - out["q"], out["q"] - hi).max(axis=1))
    out["limits"] = (np.asarray(lo), np.asarray(hi))
    out["model"] = u.model
    out["dt"] = u.dt
    return out


def figure(raw: dict[str, Any], safe: dict[str, Any], path: Path) -> Path:
    fig, axes = plt.subplots(1, 3, figsize=(15.0, 4.4))
    ax = axes[0]
    corners = np.array([[0.2, -0.85], [1.05, -0.85], [1.05, 0.3], [0.2, 0.3], [0.2, -0.85]])
    ax.plot(corners[:, 0], corners[:, 1], color="0.3", lw=1.5, label="workspace box")
    ax.plot(raw["tip"][:, 0], raw["tip"][:, 1], color="tab:red", label="without shield")
    ax.plot(safe["tip"][:, 0], safe["tip"][:, 1], color="tab:blue", label="with shield")
    ax.set_xlabel("fingertip x [m]")
    ax.set_ylabel("fingertip y [m]")
    ax.set_title("fingertip path (top view, MuJoCo's tips_arm)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best")
    ax = axes[1]
    t = np.arange(len(raw["q"])) * raw["dt"]
    jlo, jhi = raw["limits"]
    for j, colour in ((1, "tab:green"), (3, "tab:purple"), (5, "tab:orange")):
        span = jhi[j] - jlo[j]
        ax.plot(t, (raw["q"][:, j] - jlo[j]) / span, color=colour, ls="--",
                label=f"joint {j}, without")  # fmt: skip
        ax.plot(t, (safe["q"][:, j] - jlo[j]) / span, color=colour, label=f"joint {j}, with")
    ax.axhline(0.0, color="0.3", lw=1.0)
    ax.axhline(1.0, color="0.3", lw=1.0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("joint position within its range (0, 1: the limits) [1]")
    ax.set_title("joints against their limits (data.qpos)")
    ax.legend(loc="best", fontsize=8)
    ax = axes[2]
    ax.plot(t, np.cumsum(safe["changed"]), color="tab:blue", label="interventions (shield)")
    ax.plot(t, 1e3 * raw["box_depth"], color="tab:red", label="fingertip outside, without [mm]")
    ax.plot(t, 1e3 * safe["box_depth"], color="tab:cyan", label="fingertip outside, with [mm]")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("count [1] / depth outside the box [mm]")
    ax.set_title("interventions and escapes over time")
    ax.legend(loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def video(raw: dict[str, Any], safe: dict[str, Any], path: Path) -> Path:
    from velfence.apps.viz.video import (
        PolytopeOverlay,
        TrailOverlay,
        render_frames,
        side_by_side,
        write_video,
    )

    panels = {}
    for name, rec in (("without shield", raw), ("with shield", safe)):
        k = slice(None, None, 2)
        panels[name] = render_frames(
            rec["model"], rec["qpos"][k], width=320, height=240,
            overlays=[PolytopeOverlay(BOX), TrailOverlay(rec["tip"][k])],
            captions=[f"{name}  t = {i * 2 * rec['dt']:.2f} s" for i in range(len(rec["qpos"][k]))],
            lookat=[0.5, -0.3, -0.1], distance=2.2, floor=None,
        )  # fmt: skip
    return write_video(side_by_side(panels), path, fps=10.0)


def main(argv: list[str]) -> None:
    steps = 200
    rest = list(argv)
    if "--steps" in rest:
        k = rest.index("--steps")
        steps = int(rest[k + 1])
        del rest[k : k + 2]
    args = [a for a in rest if not a.startswith("--")]
    out = Path(args[0] if args else ".")
    out.mkdir(parents=True, exist_ok=True)
    raw, safe = run(False, steps), run(True, steps)
    for name, rec in (("without shield", raw), ("with shield", safe)):
        print(
            f"{name}: fingertip outside the box {int((rec['box_depth'] > 1e-3).sum())} of "
            f"{steps} steps, at most {1e3 * rec['box_depth'].max():.1f} mm; joints beyond their "
            f"limits {int((rec['joint_over'] > 1e-3).sum())} steps, at most "
            f"{1e3 * rec['joint_over'].max():.2f} mrad; interventions {int(sum(rec['changed']))}"
        )
    print("wrote", figure(raw, safe, out / "policy_shield.png"))
    if "--no-video" not in argv:
        print("wrote", video(raw, safe, out / "policy_shield.mp4"))


if __name__ == "__main__":
    main(sys.argv[1:])
