"""Input/output: validated configuration files and configured shapers (``docs/config.md``).

Math contract: none; every configuration is validated on load, and a bad file raises
:class:`~velfence.errors.InvalidParameter` naming the offending field before any work starts.
"""

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
    "check_run_length",
    "load_config",
    "load_joint_limits",
    "load_yaml",
    "parse_shaper",
]
