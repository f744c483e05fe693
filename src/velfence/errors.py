"""One exception hierarchy for the whole library.

Every error velfence raises on purpose derives from :class:`VelfenceError`. Messages say what was
expected, what was got, and what to do about it.
"""

from __future__ import annotations

__all__ = ["InvalidGeometry", "InvalidInput", "InvalidParameter", "VelfenceError"]


class VelfenceError(Exception):
    """Base class of every error velfence raises on purpose."""


class InvalidGeometry(VelfenceError, ValueError):
    """A geometric definition (polygon corners, path, mechanism dimensions) is unusable."""


class InvalidParameter(VelfenceError, ValueError):
    """A tuning parameter is out of range, of the wrong type or inconsistent with another."""


class InvalidInput(VelfenceError, ValueError):
    """A run-time input (position, command, state) has the wrong shape or is not finite."""
