"""Specs of the names the documentation and the examples import from a module path that no
package ``__all__`` exports (harness.documented_callables): the jerk scenario of
examples/jerk_fence_box.py, the collision-fit figure of docs/robots.md and the 3-D web view of
docs/web_view.md."""

from __future__ import annotations

import functools

import numpy as np
from harness import F, call

_OUT = "/nonexistent-velfence-hostile/out.png"


@functools.cache
def _runs() -> dict[str, object]:
    """Two small synthetic runs (the real ones take a MuJoCo simulation of seconds)."""
    from velfence.apps.scenarios.jerk import JerkRun

    t = np.linspace(0.0, 0.1, 6)
    cmd = np.zeros((6, 7))
    cmd[:, 0] = np.linspace(0.0, 0.05, 6)
    jerk = np.zeros((6, 7))
    jerk[1, 0] = 5.0
    runs = {}
    for name, scale in (("velfence + jerk rows", 0.5), ("per-joint clamp", 3.0)):
        runs[name] = JerkRun(
            name, t, cmd, jerk * scale, np.abs(jerk * scale) / 7500.0,
            np.array([False, True, False, False, False, False]),
            np.full(6, 0.01), 0.0, 0,
        )  # fmt: skip
    return runs


@functools.cache
def _fit() -> object:
    from specs_robots import _fit_robot

    from velfence.robots import fit_collision_capsules

    return fit_collision_capsules(_fit_robot(), samples=32)


def _session() -> object:
    from velfence.apps.viewer import scene_session

    return scene_session("arm-box")


_PLOT = "renders a figure with matplotlib and writes a file; only refusals are tried"

SPECS: dict[str, F] = {
    "scenarios.jerk.run": F(
        lambda: call(speed=0.25, duration=0.05, methods=("per-joint clamp",)),
        types={"methods": "object"},
        heavy="a closed-loop MuJoCo simulation per method (seconds); "
        "tests/apps/scenarios/test_jerk_scenario.py runs it",
    ),
    "scenarios.jerk.jerk_table": F(lambda: call(_runs()), types={"runs": "object"}),
    "scenarios.jerk.plot_jerk": F(
        lambda: call(_runs(), _OUT), types={"runs": "object", "path": "path"}, heavy=_PLOT
    ),
    "viz.collision.plot_collision_fit": F(
        lambda: call(_fit(), _OUT),
        types={"fit": "object", "path": "path", "links": "object"},
        heavy=_PLOT,
    ),
    "viewer.web.serve_web": F(
        lambda: call(_session(), port=0, realtime=False, start=False, jog_timeout=0.5),
        types={"session": "object", "port": "seed"},
        heavy="starts a viser server and an HTTP server that a call leaves running; "
        "tests/apps/viewer/test_web.py serves and stops it",
    ),
}
