"""Input/output: validated configuration files, configured shapers and bag replay.

``docs/config.md`` has the configuration files, ``docs/replay.md`` the rosbag2 replay.

Math contract: none; every configuration is validated on load, and a bad file raises
:class:`~velfence.errors.InvalidParameter` naming the offending field before any work starts.
"""

from velfence.io.bag_examples import make_example_bag
from velfence.io.bags import ReplaySettings, ReplaySummary, replay
from velfence.io.config import (
    DEFAULT_MAX_STEPS,
    DemoConfig,
    check_run_length,
    load_config,
    load_joint_limits,
)
from velfence.io.shaper_config import ConfiguredShaper, load_yaml, parse_shaper

__all__ = [
    "DEFAULT_MAX_STEPS",
    "ConfiguredShaper",
    "DemoConfig",
    "ReplaySettings",
    "ReplaySummary",
    "check_run_length",
    "load_config",
    "load_joint_limits",
    "load_yaml",
    "make_example_bag",
    "parse_shaper",
    "replay",
]
