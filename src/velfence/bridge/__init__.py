"""A ROS 2 filter node over DDS (extra ``ros``): shaped commands without a ROS install.

:class:`BridgeNode` joins a DDS domain as a ROS 2 node on ``rmw_cyclonedds_cpp`` would
(topics ``rt/<name>``, ROS 2 type names, the RIHS01 type hash in USER_DATA), reads commands
(``Twist``/``TwistStamped``, ``JointJog``, ``Float64MultiArray``) and the state (``JointState``,
``PoseStamped``, ``Odometry``), and publishes every command shaped by the configured shaper,
with watchdog, stale-state and malformed-message fail-safes and a diagnostics topic
(``docs/bridge.md``). ``velfence bridge --config bridge.yaml`` runs it.

Math contract: each published command is ``shaper.shape(state, command)`` on the latest fresh
state (bit-identical), or zero when a fail-safe holds; nothing non-finite is ever written.
"""

from velfence.bridge.config import (
    BridgeConfig,
    load_bridge_config,
    parse_bridge_config,
)
from velfence.bridge.node import (
    EXIT_CONFIG,
    EXIT_DDS,
    EXIT_INTERNAL,
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
    "EXIT_OK",
    "NODE_STATES",
    "BridgeConfig",
    "BridgeNode",
    "CycleInfo",
    "DDSFailure",
    "load_bridge_config",
    "parse_bridge_config",
    "rihs01",
    "ros_qos",
    "serve",
    "type_description",
    "user_data",
]
