"""Defaults of the configuration files that the command line shows before any file is read.

Kept apart from :mod:`velfence.io.config` (which needs pydantic and PyYAML) so that
``velfence --help`` can print them without loading the validators.
"""

__all__ = ["DEFAULT_MAX_STEPS"]

#: Default cap on the steps of one simulated run (``duration / dt``): 100 s at 1 kHz, about ten
#: times the built-in scenario. Every method runs that many steps; raise it with ``max_steps``
#: (``velfence demo --max-steps N``) when a longer run is really wanted.
DEFAULT_MAX_STEPS = 100_000
