"""Bridges to other robot software (extras ``ros`` and ``app``): a ROS 2 node and Foxglove.

:class:`BridgeNode` joins a DDS domain as a ROS 2 node on ``rmw_cyclonedds_cpp`` would
(topics ``rt/<name>``, ROS 2 type names, the RIHS01 type hash in USER_DATA), reads commands
(``Twist``/``TwistStamped``, ``JointJog``, ``Float64MultiArray``) and the state (``JointState``,
``PoseStamped``, ``Odometry``), and publishes every command shaped by the configured shaper,
with watchdog, stale-state and malformed-message fail-safes and a diagnostics topic
(``docs/bridge.md``). ``velfence bridge --config bridge.yaml`` runs it. :class:`FoxgloveView`
shows what a shaper did (``docs/foxglove.md``). The vendor zones (UR safety planes, boxes, Nav2
polygons) moved to :mod:`velfence.io.zones`; their old names here and the old module path
``velfence.bridge.zones`` warn until 0.3.

Math contract: each published command is ``shaper.shape(state, command)`` on the latest fresh
state (bit-identical), or zero when a fail-safe holds; nothing non-finite is ever written.
"""

from velfence import _lazy

#: Public name -> defining module, loaded on first use: ``import velfence.bridge`` needs nothing
#: optional; a name whose module needs a missing extra raises MissingExtra naming it.
_EXPORTS: dict[str, str] = {
    "BridgeConfig": "velfence.bridge.config",
    "load_bridge_config": "velfence.bridge.config",
    "parse_bridge_config": "velfence.bridge.config",
    "FoxgloveView": "velfence.bridge.foxglove",
    "record_trajectory": "velfence.bridge.foxglove",
    "view_hook": "velfence.bridge.foxglove",
    "EXIT_CONFIG": "velfence.bridge.node",
    "EXIT_DDS": "velfence.bridge.node",
    "EXIT_INTERNAL": "velfence.bridge.node",
    "EXIT_INTERRUPTED": "velfence.bridge.node",
    "EXIT_OK": "velfence.bridge.node",
    "NODE_STATES": "velfence.bridge.node",
    "BridgeNode": "velfence.bridge.node",
    "CycleInfo": "velfence.bridge.node",
    "DDSFailure": "velfence.bridge.node",
    "ros_qos": "velfence.bridge.node",
    "serve": "velfence.bridge.node",
    "rihs01": "velfence.bridge.typehash",
    "type_description": "velfence.bridge.typehash",
    "user_data": "velfence.bridge.typehash",
}

#: The vendor zones moved to velfence.io.zones (they are no ROS); the old names warn until 0.3.
_FORMER: dict[str, str] = {
    "NavZone": "velfence.io.zones",
    "PlaneZones": "velfence.io.zones",
    "SafetyPlane": "velfence.io.zones",
    "box_workspace": "velfence.io.zones",
    "load_nav2_polygons": "velfence.io.zones",
    "load_ur_safety_planes": "velfence.io.zones",
    "nav2_points": "velfence.io.zones",
    "nav2_polygons": "velfence.io.zones",
    "ur_safety_planes": "velfence.io.zones",
}

__getattr__, __dir__ = _lazy.attach("velfence.bridge", _EXPORTS, globals(), former=_FORMER)

TYPE_CHECKING = False
if TYPE_CHECKING:  # the same names, eagerly, for type checkers and IDEs
    from velfence.bridge.config import BridgeConfig, load_bridge_config, parse_bridge_config
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
    "load_bridge_config",
    "parse_bridge_config",
    "record_trajectory",
    "rihs01",
    "ros_qos",
    "serve",
    "type_description",
    "user_data",
    "view_hook",
]
