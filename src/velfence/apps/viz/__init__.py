"""Plots and animations (matplotlib, Agg backend; imported lazily by the CLI) and physics videos.

Math contract: none; every function takes data already computed and writes one file, returning
its path. Workspace axes are labelled in the polygon's units (pitch/yaw [rad] for the wrist).
"""

from velfence.apps.viz.plots import (
    animate_trajectories,
    plot_quiver,
    plot_velocity_patterns,
    plot_velocity_profiles,
    plot_workspace,
    save_figure,
)
from velfence.apps.viz.video import (
    PolytopeOverlay,
    SphereOverlay,
    TrailOverlay,
    render_frames,
    side_by_side,
    write_video,
)

__all__ = [
    "PolytopeOverlay",
    "SphereOverlay",
    "TrailOverlay",
    "animate_trajectories",
    "plot_quiver",
    "plot_velocity_patterns",
    "plot_velocity_profiles",
    "plot_workspace",
    "render_frames",
    "save_figure",
    "side_by_side",
    "write_video",
]
