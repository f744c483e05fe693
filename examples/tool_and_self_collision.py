"""A UR5e folding its elbow with a tool and a grasped payload: self-collision and tool rows.

The elbow is driven shut at 1.5 rad/s (1 kHz loop, 3 s). The filter (``self_collision=True``,
a tool capsule on the TCP, a workspace box and a sphere obstacle) stops the fold where the
forearm's and the upper arm's capsules touch, and keeps the tool capsule in the box; after 1 s
a payload is grasped (``attach``), after 2 s released (``detach``). Prints the smallest link-link
clearance, the smallest tool clearance to the box and the active self-collision pairs; with a
folder argument it writes ``tool_self_collision.png``: the arm's capsules, the tool, the
obstacle and the closest-point segments of the active pairs, side view (x–z).

Run: ``python examples/tool_and_self_collision.py [OUT_DIR]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from velfence.filter import Capsule, JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry import ConvexPolytope, closest_points_segments
from velfence.mechanisms import DHChain

DT = 1e-3
arm = DHChain.ur5e(link_radius=0.05)
lim = arm.joint_limits
box = ConvexPolytope.box([-0.9, -0.6, 0.0], [0.5, 0.6, 1.0])
tool = Capsule("tcp", [0.0, 0.0, 0.0], [0.0, 0.0, 0.12], radius=0.03)
payload = Capsule("tcp", [0.0, 0.0, 0.12], [0.0, 0.0, 0.3], radius=0.05)
obstacle = SphereObstacle([-0.3, 0.3, 0.3], radius=0.08)
f = SafetyFilter(
    arm,
    limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(6, 1.5)),
    workspace=WorkspaceLimit(box, buffer=0.05),
    obstacles=[obstacle],
    self_collision=True,
    attachments={"tool": tool},
    dt=DT,
)

q = np.array([0.0, -1.2, 1.5, -1.0, -1.57, 0.0])
fold = np.array([0.0, 0.0, 1.5, 0.0, 0.0, 0.0])  # the elbow, shut


def clearances(q: np.ndarray) -> tuple[float, float]:
    """Smallest guarded link-link clearance and tool-to-box clearance [m] (the primitives)."""
    segs = arm.link_segments(q)
    link = min(
        float(np.linalg.norm(np.subtract(*closest_points_segments(*segs[i], *segs[j])[:2]))) - 0.1
        for i, j in f.self_collision_pairs
    )
    F = arm.kinematics(q).link_frame(arm.dof)
    ends = [F[:, :3] @ p + F[:, 3] for p in tool.ends]
    N, o = np.asarray(box.normals), np.asarray(box.offsets)
    return link, float(min(np.min(N @ p - o) for p in ends)) - tool.radius


worst_link, worst_tool = np.inf, np.inf
for k in range(3000):
    if k == 1000:
        f.attach("payload", payload)
    if k == 2000:
        f.detach("payload")
    q = q + f.filter(q, fold) * DT
    lk, tl = clearances(q)
    worst_link, worst_tool = min(worst_link, lk), min(worst_tool, tl)

res = f.explain(q, fold)
pairs = [nm for nm in res.active_names if " and link " in nm]
print(f"smallest link-link clearance: {max(worst_link, 0.0):.4f} m "
      f"(no penetration beyond 1e-9 m: {worst_link > -1e-9})")  # fmt: skip
print(f"smallest tool-box clearance: {worst_tool:.3f} m")
print(f"elbow stopped at {q[2]:.2f} rad; active pairs: {pairs}")


def figure(out: Path) -> Path:
    """The final pose, side view (x–z): capsules, tool, obstacle, closest points."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Patch

    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    swatches: dict[str, Patch] = {}  # a capsule's legend entry: its fill and its axis line

    def capsule(a: np.ndarray, b: np.ndarray, r: float, colour: str, label: str) -> None:
        for t in np.linspace(0.0, 1.0, 24):
            p = a + t * (b - a)
            ax.add_patch(Circle((p[0], p[2]), r, color=colour, alpha=0.35, lw=0))
        ax.plot([a[0], b[0]], [a[2], b[2]], color=colour, lw=1.5, label=label)
        swatches[label] = Patch(facecolor=colour, edgecolor=colour, alpha=0.6, lw=1.5)

    segs = arm.link_segments(q)
    for k in range(segs.shape[0]):
        capsule(segs[k, 0], segs[k, 1], 0.05, "tab:blue", "link capsules" if k == 0 else "_")
    F = arm.kinematics(q).link_frame(arm.dof)
    ta, tb = (F[:, :3] @ p + F[:, 3] for p in tool.ends)
    capsule(ta, tb, tool.radius, "tab:orange", "tool capsule")
    c = obstacle.center
    ax.add_patch(Circle((c[0], c[2]), obstacle.radius, color="tab:red", alpha=0.4, lw=0))
    ax.plot([c[0]], [c[2]], "x", color="tab:red", label="obstacle (sphere)")
    for n, nm in enumerate(pairs):
        i, j = (int(w) for w in nm.replace("link ", "").split(" and "))
        pa, pb, _, _ = closest_points_segments(*segs[i], *segs[j])
        ax.plot([pa[0], pb[0]], [pa[2], pb[2]], "k-o", ms=4, lw=1.2,
                label="closest points, active pairs" if n == 0 else "_")  # fmt: skip
    lo, hi = box.vertices.min(axis=0), box.vertices.max(axis=0)
    ax.plot([lo[0], hi[0], hi[0], lo[0], lo[0]], [lo[2], lo[2], hi[2], hi[2], lo[2]], "g--",
            lw=1, label="workspace box")  # fmt: skip
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.set_title("UR5e, elbow driven shut: stopped where the capsules touch")
    handles, labels = ax.get_legend_handles_labels()
    ax.legend([swatches.get(t, h) for h, t in zip(handles, labels, strict=True)], labels,
              loc="upper right", fontsize=8)  # fmt: skip
    path = out / "tool_self_collision.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


if __name__ == "__main__" and len(sys.argv) > 1:
    print(f"wrote {figure(Path(sys.argv[1]))}")
