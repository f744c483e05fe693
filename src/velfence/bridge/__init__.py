"""Bridges to other robot software (extra ``ros``): a ROS 2 node, vendor zones, Foxglove.

:class:`BridgeNode` joins a DDS domain as a ROS 2 node on ``rmw_cyclonedds_cpp`` would
(topics ``rt/<name>``, ROS 2 type names, the RIHS01 type hash in USER_DATA), reads commands
(``Twist``/``TwistStamped``, ``JointJog``, ``Float64MultiArray``) and the state (``JointState``,
``PoseStamped``, ``Odometry``), and publishes every command shaped by the configured shaper,
with watchdog, stale-state and malformed-message fail-safes and a diagnostics topic
(``docs/bridge.md``). ``velfence bridge --config bridge.yaml`` runs it. Vendor zones
(:mod:`~velfence.bridge.zones`: UR safety planes, boxes, Nav2 polygons) become velfence's
polygons and polytopes (``docs/zones.md``); :class:`FoxgloveView` shows what a shaper did
(``docs/foxglove.md``).

Math contract: each published command is ``shaper.shape(state, command)`` on the latest fresh
state (bit-identical), or zero when a fail-safe holds; nothing non-finite is ever written.
Zones use the inward-normal convention ``n · x >= offset`` inside.
"""

from velfence.bridge.config import (
    BridgeConfig,
    load_bridge_config,
    parse_bridge_config,
)
from velfence.bridge.foxglove import FoxgloveView, record_trajectory, view_hook
from velfence.bridge.node import (
    EXIT_CONFIG,
    EXIT_DDS,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    NODE_STATES,
    BridgeNode,
    CycleInfo,
    DDSFailure,
    ros_qos,
    serve,
)
from velfence.bridge.typehash import rihs01, type_description, user_data
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
    "EXIT_CONFIG",
    "EXIT_DDS",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "NODE_STATES",
    "BridgeConfig",
    "BridgeNode",
    "CycleInfo",
    "DDSFailure",
    "FoxgloveView",
    "NavZone",
    "PlaneZones",
    "SafetyPlane",
    "box_workspace",
    "load_bridge_config",
    "load_nav2_polygons",
    "load_ur_safety_planes",
    "nav2_points",
    "nav2_polygons",
    "parse_bridge_config",
    "record_trajectory",
    "rihs01",
    "ros_qos",
    "serve",
    "type_description",
    "ur_safety_planes",
    "user_data",
    "view_hook",
]
