"""Bridges to other robot software: ROS 2 on the wire, vendor zones, Foxglove live view.

Math contract: none of its own. Vendor zones (:mod:`~velfence.bridge.zones`) become velfence's
polygons and polytopes with the inward-normal convention ``n · x >= offset`` inside; the live
view (:mod:`~velfence.bridge.foxglove`) draws what a shaper did and never changes it. The heavy
packages (foxglove-sdk, PyYAML) are imported inside the functions that need them.
"""

from __future__ import annotations

from velfence.bridge.foxglove import FoxgloveView, record_trajectory
from velfence.bridge.zones import (
    NavZone,
    PlaneZones,
    SafetyPlane,
    box_workspace,
    load_nav2_polygons,
    load_ur_safety_planes,
    nav2_points,
    nav2_polygons,
    ur_safety_planes,
)

__all__ = [
    "FoxgloveView",
    "NavZone",
    "PlaneZones",
    "SafetyPlane",
    "box_workspace",
    "load_nav2_polygons",
    "load_ur_safety_planes",
    "nav2_points",
    "nav2_polygons",
    "record_trajectory",
    "ur_safety_planes",
]
