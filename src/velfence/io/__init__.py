"""Input/output: validated configuration files.

Math contract: none; every configuration is validated on load, and a bad file raises
:class:`~velfence.errors.InvalidParameter` naming the offending field.
"""

from velfence.io.config import DemoConfig, load_config

__all__ = ["DemoConfig", "load_config"]
