"""The picture of a collision-capsule fit: geometry and capsules in 3-D (matplotlib, Agg)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from velfence._extras import missing

try:
    import matplotlib
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import check_output_path, check_text, describe, real_array
from velfence.apps.viz.plots import save_figure
from velfence.errors import InvalidInput
from velfence.robots import CollisionFit, LinkRadii, MujocoRobot

__all__ = ["capsule_wireframe", "plot_collision_fit"]

#: Colours: the source geometry, the fitted capsules, the filter's joint-to-joint capsules.
FIT_COLORS = {"geometry": "#7f7f7f", "fitted": "#1f77b4", "links": "#ff7f0e"}


def capsule_wireframe(start: ArrayLike, end: ArrayLike, radius: float, n: int = 16) -> FloatArray:
    """Polylines of a capsule's wireframe (rings and meridians), NaN-separated, shape (M, 3).

    Args:
        start: Segment start [m], shape (3,).
        end: Segment end [m], shape (3,).
        radius: Radius [m].
        n: Points per ring.

    Returns:
        Points [m]; consecutive rows are joined, a NaN row breaks the line.
    """
    a = np.asarray(start, dtype=float)
    b = np.asarray(end, dtype=float)
    axis = b - a
    length = float(np.linalg.norm(axis))
    e = axis / length if length > 0.0 else np.array([0.0, 0.0, 1.0])
    u = np.cross(e, [1.0, 0.0, 0.0] if abs(e[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(e, u)
    phi = np.linspace(0.0, 2 * math.pi, n + 1)
    ring = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v
    gap = np.full((1, 3), np.nan)
    lines = []
    for c in (a, b):  # the two equators
        lines += [c + radius * ring, gap]
    th = np.linspace(0.0, math.pi / 2, n // 4 + 1)[:, None]
    for k in range(0, n, max(1, n // 8)):  # meridians: pole, hemisphere, side, hemisphere, pole
        r0 = ring[k]
        half_a = a + radius * (np.sin(th) * r0 - np.cos(th) * e)
        half_b = b + radius * (np.cos(th) * r0 + np.sin(th) * e)
        lines += [np.vstack([half_a, half_b]), gap]
    return np.vstack(lines)


def _world(robot: MujocoRobot, q: FloatArray) -> list[tuple[FloatArray, FloatArray]]:
    """World pose (rotation, position) of every body of ``robot`` at ``q``."""
    import mujoco

    m = robot.model
    data = mujoco.MjData(m)
    data.qpos[:] = q
    mujoco.mj_kinematics(m, data)
    return [
        (np.array(data.xmat[b], dtype=float).reshape(3, 3), np.array(data.xpos[b], dtype=float))
        for b in range(m.nbody)
    ]


def plot_collision_fit(
    fit: CollisionFit,
    path: str | Path,
    *,
    q: ArrayLike | None = None,
    links: tuple[MujocoRobot, LinkRadii] | None = None,
    title: str = "",
) -> Path:
    """Draw a fit: each body's collision geometry and its capsule, at one pose.

    The geometry is drawn as the points it was reduced to (mesh vertices, box corners, ball
    centres; ``velfence.robots.collision``), the fitted capsules as blue wireframes and, with
    ``links``, the robot's joint-to-joint capsules (the form the safety filter takes) in
    orange; axes in metres, equal scale.

    Args:
        fit: The fit (:func:`velfence.robots.fit_collision_capsules`).
        path: Output image file (``.png``, ``.svg``, …).
        q: Joint position of the fitted robot [rad], shape (dof,); default its ``qpos0``.
        links: ``(robot, radii)``: a robot with capsule links whose joints are named as the
            fitted robot's, and its :meth:`CollisionFit.link_radii`; drawn at the same joint
            values.
        title: Figure title.

    Returns:
        The path written.

    Raises:
        InvalidInput: a bad ``fit``, ``q`` or ``links``.
        InvalidParameter: a bad ``path``.
    """
    if not isinstance(fit, CollisionFit):
        raise InvalidInput(f"fit: expected a CollisionFit, got {type(fit).__name__}")
    src = fit.robot
    qq = (
        np.array(src.model.qpos0, dtype=float)
        if q is None
        else real_array("q", q, (src.dof,), what="joint positions [rad]")
    )
    if links is not None and not (
        isinstance(links, tuple)
        and len(links) == 2
        and isinstance(links[0], MujocoRobot)
        and isinstance(links[1], LinkRadii)
    ):
        raise InvalidInput(
            f"links: expected (MujocoRobot, LinkRadii) or None, got {describe(links)}"
        )
    title = check_text("title", title)
    out = check_output_path("path", path)
    poses = _world(src, qq)
    fig = plt.figure(figsize=(7.0, 7.0))
    ax: Any = fig.add_subplot(projection="3d")
    pts_all = []
    for i, link in enumerate(fit.links):
        R, x = poses[int(src.model.body(link.body).id)]
        pts = x + link.centers @ R.T
        step = max(1, len(pts) // 400)
        ax.scatter(
            *pts[::step].T,
            s=1.5,
            color=FIT_COLORS["geometry"],
            alpha=0.6,
            label="collision geometry (vertices, corners, ball centres)" if i == 0 else None,
        )
        w = capsule_wireframe(x + R @ link.start, x + R @ link.end, link.radius)
        ax.plot(
            *w.T,
            color=FIT_COLORS["fitted"],
            lw=0.6,
            label="fitted capsule, one per body" if i == 0 else None,
        )
        pts_all.append(pts)
    if links is not None:
        robot, radii = links
        names = {n: j for j, n in enumerate(src.joint_names)}
        qt = np.array([qq[names[n]] if n in names else 0.0 for n in robot.joint_names])
        seg = robot.link_segments(qt)
        for k in range(len(seg)):
            if radii.radius[k] <= 0.0:
                continue
            w = capsule_wireframe(seg[k, 0], seg[k, 1], float(radii.radius[k]))
            ax.plot(
                *w.T,
                color=FIT_COLORS["links"],
                lw=0.6,
                alpha=0.8,
                label="joint-to-joint capsule (safety filter)" if k == 0 else None,
            )
            pts_all.append(seg[k])
    allp = np.vstack(pts_all)
    centre = 0.5 * (allp.min(axis=0) + allp.max(axis=0))
    half = 0.5 * float(np.max(allp.max(axis=0) - allp.min(axis=0))) + 0.15
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.legend(loc="upper left", fontsize=8)
    if title:
        ax.set_title(title)
    return save_figure(fig, out)
