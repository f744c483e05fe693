"""One exception hierarchy for the whole library.

Every error velfence raises on purpose derives from :class:`VelfenceError`. Messages say what was
expected, what was got, and what to do about it. The few warnings velfence gives on purpose
(other than the ``DeprecationWarning`` of a renamed name) derive from :class:`VelfenceWarning`.
"""

from __future__ import annotations

__all__ = [
    "InvalidGeometry",
    "InvalidInput",
    "InvalidParameter",
    "MissingExtra",
    "NothingToReplay",
    "StartedInViolation",
    "VelfenceError",
    "VelfenceWarning",
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


class VelfenceWarning(UserWarning):
    """Base class of the warnings velfence gives on purpose (not the deprecations).

    A ``UserWarning``: shown once per place by Python's default filters; silence or escalate one
    category with :func:`warnings.filterwarnings` (``"ignore"`` or ``"error"``).
    """


class StartedInViolation(VelfenceWarning):
    """A safety filter's first cycle starts with a constraint already violated.

    Given once per start (the first cycle after the filter is built or ``reset()``) by
    ``SafetyFilter``'s single-state calls when the joint position is already beyond a limit: a
    link inside an obstacle, the tool outside the workspace, a joint past its limit. The message
    names each violated constraint and its depth; the cycle's ``FilterResult.violations`` has
    them too. The filter is then in recovery: its output moves the robot back out, even for a
    zero command. Usually a set-up mistake (an obstacle placed over the arm, link radii or
    units off), sometimes a real start in contact; ``docs/safety_filter.md`` §4.
    """
