"""Input/output: validated configuration files (format: ``docs/config.md``).

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

__all__ = [
    "DEFAULT_MAX_STEPS",
    "DemoConfig",
    "check_run_length",
    "load_config",
    "load_joint_limits",
]
