"""Input/output: validated configuration files, configured shapers, vendor zones and bag replay.

``docs/config.md`` has the configuration files (the demo's own, ``DemoConfig``, is an
application's: :mod:`velfence.apps.demo.config`), ``docs/zones.md`` the vendor zones (UR safety
planes, boxes, Nav2 polygons), ``docs/replay.md`` the rosbag2 replay. The names load on first use;
one whose module needs an extra that is not installed raises
:class:`~velfence.errors.MissingExtra` naming it (``docs/install.md`` has the table).

Math contract: none; every configuration is validated on load, and a bad file raises
:class:`~velfence.errors.InvalidParameter` naming the offending field before any work starts.
"""

from __future__ import annotations

from velfence import _lazy

#: Public name -> defining module; loaded on first use (the bags need rosbags, the configs
#: pydantic and PyYAML, the zones NumPy and SciPy only), so ``import velfence.io`` is cheap and
#: a CLI's ``--help`` stays fast.
_EXPORTS: dict[str, str] = {
    "make_example_bag": "velfence.io.bag_examples",
    "ReplaySettings": "velfence.io.bags",
    "ReplaySummary": "velfence.io.bags",
    "load_replay_config": "velfence.io.bags",
    "replay": "velfence.io.bags",
    "DEFAULT_MAX_STEPS": "velfence.io.defaults",
    "load_joint_limits": "velfence.io.joint_limits",
    "SensorMessage": "velfence.io.sensors",
    "SensorPoints": "velfence.io.sensors",
    "accept_sensor_message": "velfence.io.sensors",
    "cloud_points": "velfence.io.sensors",
    "decode_laser_scan": "velfence.io.sensors",
    "decode_point_cloud2": "velfence.io.sensors",
    "scan_points": "velfence.io.sensors",
    "TransformStore": "velfence.io.transforms",
    "ConfiguredShaper": "velfence.io.shaper_config",
    "load_yaml": "velfence.io.shaper_config",
    "parse_shaper": "velfence.io.shaper_config",
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

#: The demo's configuration is an application's since 0.2 (velfence.apps.demo.config); the old
#: names warn until 0.3.
_FORMER: dict[str, str] = {
    "DemoConfig": "velfence.apps.demo",
    "check_run_length": "velfence.apps.demo",
    "load_config": "velfence.apps.demo",
}

__getattr__, __dir__ = _lazy.attach("velfence.io", _EXPORTS, globals(), former=_FORMER)

TYPE_CHECKING = False
if TYPE_CHECKING:  # the same names, eagerly, for type checkers and IDEs
    from velfence.io.bag_examples import make_example_bag
    from velfence.io.bags import ReplaySettings, ReplaySummary, load_replay_config, replay
    from velfence.io.defaults import DEFAULT_MAX_STEPS
    from velfence.io.joint_limits import load_joint_limits
    from velfence.io.sensors import (
        SensorMessage,
        SensorPoints,
        accept_sensor_message,
        cloud_points,
        decode_laser_scan,
        decode_point_cloud2,
        scan_points,
    )
    from velfence.io.shaper_config import ConfiguredShaper, load_yaml, parse_shaper
    from velfence.io.transforms import TransformStore
    from velfence.io.zones import (
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
    "DEFAULT_MAX_STEPS",
    "ConfiguredShaper",
    "NavZone",
    "PlaneZones",
    "ReplaySettings",
    "ReplaySummary",
    "SafetyPlane",
    "SensorMessage",
    "SensorPoints",
    "TransformStore",
    "accept_sensor_message",
    "box_workspace",
    "cloud_points",
    "decode_laser_scan",
    "decode_point_cloud2",
    "load_joint_limits",
    "load_nav2_polygons",
    "load_replay_config",
    "load_ur_safety_planes",
    "load_yaml",
    "make_example_bag",
    "nav2_points",
    "nav2_polygons",
    "parse_shaper",
    "replay",
    "scan_points",
    "ur_safety_planes",
]
