"""Specs of velfence.apps.viz: every function writes a file (matplotlib), so only refusals are
tried."""

from __future__ import annotations

from common import square
from harness import C, F, call
from matplotlib.figure import Figure
from specs_sim import shaper, traj

_HEAVY = "renders a figure with matplotlib and writes a file; only refusals are tried"
_OUT = "/nonexistent-velfence-hostile/out.png"

SPECS: dict[str, F | C] = {
    "viz.animate_trajectories": F(
        lambda: call(square(), {"a": traj()}, _OUT.replace(".png", ".gif")), heavy=_HEAVY
    ),
    "viz.plot_quiver": F(lambda: call(square(), {"exact": shaper()}, _OUT), heavy=_HEAVY),
    "viz.plot_velocity_patterns": F(
        lambda: call(square(), {"exact": shaper()}, [[0.5, 0.5]], _OUT), heavy=_HEAVY
    ),
    "viz.plot_velocity_profiles": F(
        lambda: call(square(), {"a": traj()}, _OUT), types={"unit": "text"}, heavy=_HEAVY
    ),
    "viz.plot_workspace": F(lambda: call(square(), {"a": traj()}, _OUT), heavy=_HEAVY),
    # A Figure outside pyplot's registry: nothing to release when a refusal closes it.
    "viz.save_figure": F(lambda: call(Figure(), _OUT), heavy=_HEAVY),
}


def _box3() -> object:
    from velfence.geometry.polytope import ConvexPolytope

    return ConvexPolytope.box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])


def _frames(n: int = 2) -> object:
    import numpy as np

    return np.zeros((n, 16, 16, 3), dtype=np.uint8)


def _panda_model() -> object:
    from velfence.robots import panda

    return panda().model


_RENDER = "opens an OpenGL context and renders; only refusals are tried"
_ENCODE = "runs an encoder and writes a file; only refusals are tried"

SPECS.update(
    {
        "viz.PolytopeOverlay": C(
            F(lambda: call(_box3(), rgba=(0.1, 0.2, 0.3, 1.0), width=0.01)),
            {"draw": F(lambda: call(None, 0), heavy="needs a live mjvScene; test_video.py")},
        ),
        "viz.SphereOverlay": C(
            F(lambda: call([0.1, 0.2, 0.3], radius=0.1, rgba=(1.0, 0.0, 0.0, 0.5))),
            {"draw": F(lambda: call(None, 0), heavy="needs a live mjvScene; test_video.py")},
        ),
        "viz.TrailOverlay": C(
            F(lambda: call([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]], width=0.01)),
            {"draw": F(lambda: call(None, 0), heavy="needs a live mjvScene; test_video.py")},
        ),
        "viz.render_frames": F(
            lambda: call(_panda_model(), [[0.0] * 7], width=32, height=32), heavy=_RENDER
        ),
        "viz.side_by_side": F(lambda: call({"a": _frames(), "b": _frames(1)}, gap=2)),
        "viz.write_video": F(
            lambda: call(_frames(), "/nonexistent-velfence-hostile/out.mp4", fps=10.0),
            heavy=_ENCODE,
        ),
    }
)
