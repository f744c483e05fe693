"""Vendor zone files shared by the tests of velfence.io.zones and of the configs that name them.

``UR_CELL``: a Universal Robots style safety-plane file; ``NAV2``: a Nav2 collision-monitor
parameter file in the published ROS 2 parameter form (``collision_monitor: {ros__parameters:
...}``) with the string and flat-list ``points`` forms Nav2 versions write and a circle.
"""

from __future__ import annotations

# A UR5e cell [m, base frame]: table top at z = 0, back wall 0.35 m behind the base, a window
# guard whose face is 0.9 m in front (0.05 m of displacement granted), a ceiling at 1.2 m; an
# operator-side plane active in reduced mode only and a trigger plane (no limit).
UR_CELL = """\
safety_planes:
  - name: table
    normal: [0.0, 0.0, 1.0]
    offset: 0.0
    restrict: both
  - name: back wall
    normal: [0.0, 1.0, 0.0]
    offset: -0.35
  - name: window guard
    normal: [-1.0, 0.0, 0.0]
    point: [0.9, 0.0, 0.5]
    displacement: 0.05
    restrict: tool
  - name: ceiling
    normal: [0.0, 0.0, -1.0]
    offset: -1.2
    restrict: both
  - name: operator side
    normal: [1.0, 0.0, 0.0]
    offset: -0.6
    mode: reduced
  - name: conveyor trigger
    normal: [0.0, -1.0, 0.0]
    offset: -0.7
    mode: trigger_reduced
bounds:
  lower: [-1.0, -1.0, -0.5]
  upper: [1.0, 1.0, 1.5]
"""

# In the spirit of Nav2's collision-monitor example: a stop box in front of the robot (Iron+
# string form), a larger slowdown box (Humble flat-list form), a round limit zone.
NAV2 = """\
collision_monitor:
  ros__parameters:
    base_frame_id: "base_footprint"
    odom_frame_id: "odom"
    cmd_vel_in_topic: "cmd_vel_smoothed"
    cmd_vel_out_topic: "cmd_vel"
    polygons: ["FrontStop", "FrontSlow", "RoundLimit"]
    FrontStop:
      type: "polygon"
      points: "[[0.35, 0.25], [0.35, -0.25], [0.05, -0.25], [0.05, 0.25]]"
      action_type: "stop"
      min_points: 3
      visualize: True
    FrontSlow:
      type: "polygon"
      points: [0.6, 0.4, 0.6, -0.4, 0.05, -0.4, 0.05, 0.4]
      action_type: "slowdown"
      slowdown_ratio: 0.4
      min_points: 3
    RoundLimit:
      type: "circle"
      radius: 0.8
      action_type: "limit"
      linear_limit: 0.3
      angular_limit: 0.5
      enabled: False
    observation_sources: ["scan"]
    scan:
      type: "scan"
      topic: "scan"
"""
