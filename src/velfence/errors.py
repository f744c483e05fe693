"""One exception hierarchy for the whole library.

Every error velfence raises on purpose derives from :class:`VelfenceError`. Messages say what was
expected, what was got, and what to do about it.
"""

from __future__ import annotations

__all__ = [
    "InvalidGeometry",
    "InvalidInput",
    "InvalidParameter",
    "MissingExtra",
    "NothingToReplay",
    "VelfenceError",
]


class VelfenceError(Exception):
    """Base class of every error velfence raises on purpose."""


class InvalidGeometry(VelfenceError, ValueError):
    """A geometric definition (polygon corners, path, mechanism dimensions) is unusable."""


class InvalidParameter(VelfenceError, ValueError):
    """A tuning parameter is out of range, of the wrong type or inconsistent with another."""


class InvalidInput(VelfenceError, ValueError):
    """A run-time input (position, command, state) has the wrong shape or is not finite."""


class MissingExtra(VelfenceError, ModuleNotFoundError):
    """An optional dependency is not installed; the message names the extra that installs it.

    Raised when a module of velfence that needs the package is imported, or when a call needs it
    (``pip install 'velfence[app]'`` and the like; ``docs/install.md`` has the table). It is an
    :class:`ImportError` too, so ``except ImportError`` around an optional import keeps working.
    """


class NothingToReplay(InvalidParameter):
    """A bag holds nothing a replay can shape.

    No messages, no command or state messages, or no command with a usable state. The message
    names what the bag holds (topics, types, counts) and what was looked for. It is
    an :class:`InvalidParameter` too (the bag is the argument at fault), so code that caught the
    missing-topic error before keeps catching it; ``velfence replay`` exits with code 4 on it.
    """
