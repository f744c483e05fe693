"""The demo's built-in wrist script, derived from the workspace polygon's features.

Used by ``velfence demo`` when the configuration leaves ``start``, ``waypoints`` or ``pushes``
out (:mod:`velfence.apps.demo.config`); the operator that follows it is the library's
:class:`~velfence.sim.scenarios.WaypointOperator`.
"""

from __future__ import annotations

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_positive
from velfence.geometry.polygon import ConvexPolygon, as_polygon
from velfence.sim.scenarios import Script, Waypoint

__all__ = ["default_script"]


def default_script(polygon: ConvexPolygon, *, buffer: float) -> Script:
    """The built-in demo script, derived from the polygon's features.

    Phases, each long enough to travel its distance at its speed and then dwell: start outside the
    longest edge and come in; press into that edge and sweep along it; push into the most acute
    corner; push into the most obtuse corner; a fast move into the far side; hold near the long
    edge while an external push drives the mechanism outward, then let go.

    Args:
        polygon: The workspace (:class:`~velfence.geometry.polygon.ConvexPolygon`).
        buffer: The shaper's buffer width, workspace units, > 0 (sets the start and hold points).

    Raises:
        InvalidParameter: ``polygon`` not a polygon or ``buffer`` not finite and > 0.
    """
    polygon = as_polygon(polygon)
    buffer = check_positive("buffer", buffer, unit="workspace units")
    c = polygon.corners
    n = polygon.n
    cen = polygon.centroid
    size = float(np.max(np.linalg.norm(c - cen, axis=1)))
    lengths = np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1)
    e = int(np.argmax(lengths))
    a, b = c[e], c[(e + 1) % n]
    normal = polygon.normals[e]
    start = 0.5 * (a + b) - 0.6 * buffer * normal
    ang = polygon.interior_angles
    acute = int(np.argmin(ang))
    obtuse = int(np.argmax(np.where(np.arange(n) == acute, -1.0, ang)))
    far = int(np.argmin(polygon.normals @ polygon.normals[obtuse - 1]))  # faces corner's edge

    def beyond_corner(i: int) -> FloatArray:
        d = c[i] - cen
        return np.asarray(c[i] + 0.4 * size * d / np.linalg.norm(d), dtype=float)

    plan: list[tuple[str, FloatArray, float, float]] = [  # label, target, speed, dwell [s]
        ("start outside, come in", cen.copy(), 0.6, 0.2),
        ("press into the long edge", a + 0.3 * (b - a) - 0.4 * size * normal, 0.8, 0.4),
        ("sweep along it, pressing", a + 0.85 * (b - a) - 0.4 * size * normal, 0.7, 0.3),
        (f"push into acute corner {acute}", beyond_corner(acute), 0.6, 0.8),
        (f"push into obtuse corner {obtuse}", beyond_corner(obtuse), 0.6, 0.8),
        (
            "fast move into the far side",
            0.5 * (c[far] + c[(far + 1) % n]) - 0.4 * size * polygon.normals[far],
            2.0,
            0.4,
        ),
        ("hold near the long edge", 0.5 * (a + b) + 0.5 * buffer * normal, 0.6, 0.3),
    ]
    t = 0.0
    pos = np.asarray(start, dtype=float)
    wps = []
    for _label, target, speed, dwell in plan:
        wps.append(Waypoint(t=t, target=(float(target[0]), float(target[1])), speed=speed))
        reach = polygon.closest_point(target)
        t += float(np.linalg.norm(reach - pos)) / speed + dwell
        pos = reach
    push_v = -0.5 * normal
    pushes = ((t, t + 0.8, (float(push_v[0]), float(push_v[1]))),)
    return Script(
        start=(float(start[0]), float(start[1])),
        waypoints=tuple(wps),
        pushes=pushes,
        duration=t + 2.0,
        labels=tuple(p[0] for p in plan),
    )
