"""The named scenes of the 3-D web view (``velfence view --scenario NAME``).

:func:`scene_session` builds one of :data:`SCENES`; :func:`serve_scene` serves it with
:func:`velfence.apps.viewer.web.serve_web`. This module sits at the top of the layers (beside
:mod:`velfence.apps.scenarios`), because the ``fence-box`` scene is the MuJoCo scenario of
:mod:`velfence.apps.scenarios.fence_box`; the web view itself (:mod:`velfence.apps.viewer.web`)
knows only
the :class:`~velfence.apps.viewer.server.SessionLike` protocol.
"""

from __future__ import annotations

import math

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_choice, check_flag, check_positive_int, check_range
from velfence.apps.viewer.server import MAX_JOG_TIMEOUT, SessionLike
from velfence.apps.viewer.web import (
    WebView,
    _arm_box_session,
    _ArmSession,
    _TeleopSession,
    serve_web,
)

__all__ = ["SCENES", "scene_session", "serve_scene"]

#: The scenes :func:`scene_session` builds.
SCENES: tuple[str, ...] = ("teleop", "arm-box", "fence-box")


def _fence_box_session() -> _ArmSession:
    from velfence.apps.scenarios import fence_box as fb
    from velfence.filter.limits import SphereObstacle
    from velfence.geometry.polytope import ConvexPolytope
    from velfence.robots import panda
    from velfence.sim.physics import MujocoPlant
    from velfence.sim.scenarios import TcpJog

    robot = panda(radius=0.05)
    box = ConvexPolytope.box(np.array(fb.BOX_LOWER), np.array(fb.BOX_UPPER))
    lim = np.array(robot.joint_limits)
    lim[0] = fb.CELL_JOINT1
    # The look-ahead variant: servo lag lets the plain filter graze the wall by 0.17 mm
    # (docs/physics.md); with the look-ahead the scenario stays inside.
    method = "safety-filter-look-ahead"
    shaper = fb.build_controllers(robot, box, lim, (method,))[method]
    sphere = SphereObstacle(np.array(fb.SPHERE_CENTER), radius=fb.SPHERE_RADIUS, name="sphere")
    physics = MujocoPlant(
        robot, bandwidth=fb.BANDWIDTH, physics_dt=fb.PHYSICS_DT, obstacles=[sphere]
    )
    q0 = np.array(fb.Q0)
    physics.reset(q0, fb.DT)
    speed = 0.25
    phases = fb.script_phases(robot.fk(q0), speed, dwell=0.4)
    jog = TcpJog(robot.fk, [(p[2], p[3][0]) for p in phases], speed=speed)

    def plant(q: FloatArray, qdot: FloatArray, t: float) -> FloatArray:
        if len(physics._rows) > 20_000:  # a live view runs for hours: keep the record short
            physics.reset(q, fb.DT)
        return np.asarray(physics.advance(qdot, t), dtype=float)

    return _ArmSession(
        "fence-box",
        robot,
        shaper,
        plant,
        q0,
        fb.DT,
        np.array(fb.BOX_LOWER),
        np.array(fb.BOX_UPPER),
        (np.array(fb.SPHERE_CENTER), fb.SPHERE_RADIUS),
        lambda t, q: jog(t, q),
    )


def scene_session(scene: str) -> SessionLike:
    """A fresh simulated scene for the web view (or the teleop viewer).

    * ``"teleop"`` — :class:`velfence.apps.teleop.session.Session` (the PUMA 560, laser, fixture);
    * ``"arm-box"`` — the 7-DoF arm of ``docs/arm_box.md`` under the SafetyFilter (5 ms);
    * ``"fence-box"`` — the Panda-like arm of :mod:`velfence.apps.scenarios.fence_box` in MuJoCo
      (2 ms; the ``physics`` extra), shaped by its ``"safety-filter-look-ahead"`` controller.

    Args:
        scene: One of :data:`SCENES`.

    Returns:
        A :class:`~velfence.apps.viewer.server.SessionLike`; its snapshot adds ``scene``, ``tcp``
        [m] (3,), ``commanded`` and ``shaped`` TCP velocities [m/s] (3,) to the session's keys
        (the arm scenes also ``margin`` and ``min_margin``: the TCP's distance inside the box
        now and at worst so far [m]).

    Raises:
        InvalidParameter: an unknown scene name.
    """
    check_choice("scene", scene, SCENES)
    if scene == "teleop":
        return _TeleopSession()
    if scene == "arm-box":
        return _arm_box_session()
    return _fence_box_session()


def serve_scene(
    scene: str = "teleop",
    *,
    port: int = 0,
    realtime: bool = True,
    start: bool = False,
    jog_timeout: float = 0.5,
) -> WebView:
    """Build a named scene and serve it on ``http://127.0.0.1:port/``.

    Args:
        scene: One of :data:`SCENES`.
        port: TCP port on ``127.0.0.1``; 0 picks a free one.
        realtime: Advance with wall-clock time (default); ``False`` only on ``POST /step``.
        start: Start the clock at once; ``False`` (default) waits for the first client.
        jog_timeout: Dead-man on held jogs [s]; ``math.inf`` disables it.

    Returns:
        The running :class:`~velfence.apps.viewer.web.WebView`.

    Raises:
        InvalidParameter: an unknown scene, a bad argument, or viser missing.
        OSError: the port is in use.
    """
    # The cheap checks first: a bad port must not cost a scene build and a viser start.
    check_positive_int("port", port, minimum=0, maximum=65535, example=8765)
    check_flag("realtime", realtime)
    check_flag("start", start)
    if not (isinstance(jog_timeout, float) and jog_timeout == math.inf):
        check_range(
            "jog_timeout", jog_timeout, low=0.0, low_open=True, high=MAX_JOG_TIMEOUT, unit="s"
        )
    session = scene_session(scene)
    return serve_web(session, port=port, realtime=realtime, start=start, jog_timeout=jog_timeout)
