"""Specs of velfence.viz: every function writes a file (matplotlib), so only refusals are tried."""

from __future__ import annotations

from common import square
from harness import F, call
from matplotlib.figure import Figure
from specs_sim import shaper, traj

_HEAVY = "renders a figure with matplotlib and writes a file; only refusals are tried"
_OUT = "/nonexistent-velfence-hostile/out.png"

SPECS: dict[str, F] = {
    "viz.animate_trajectories": F(
        lambda: call(square(), {"a": traj()}, _OUT.replace(".png", ".gif")), heavy=_HEAVY
    ),
    "viz.plot_quiver": F(lambda: call(square(), {"exact": shaper()}, _OUT), heavy=_HEAVY),
    "viz.plot_velocity_patterns": F(
        lambda: call(square(), {"exact": shaper()}, [[0.5, 0.5]], _OUT), heavy=_HEAVY
    ),
    "viz.plot_velocity_profiles": F(lambda: call(square(), {"a": traj()}, _OUT), heavy=_HEAVY),
    "viz.plot_workspace": F(lambda: call(square(), {"a": traj()}, _OUT), heavy=_HEAVY),
    # A Figure outside pyplot's registry: nothing to release when a refusal closes it.
    "viz.save_figure": F(lambda: call(Figure(), _OUT), heavy=_HEAVY),
}
