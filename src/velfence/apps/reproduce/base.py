"""Reports of named checks, the JSON format of ``velfence reproduce NAME --json``.

Every reproduction returns a :class:`Report`: a list of :class:`Check` (what the source claims or
publishes, what we measured, the tolerance we can honestly meet, and whether it passed) plus the
paths of the artifacts (plots) it wrote. The JSON shape is fixed::

    {"name": ..., "checks": [{"name", "source", "expected", "measured", "tolerance", "passed"}],
     "artifacts": [paths]}
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Check", "Report", "check_at_least", "check_at_most", "check_close", "jsonable"]


def jsonable(x: Any) -> Any:
    """A strict-JSON-ready copy: non-finite floats become strings, arrays lists, dicts recurse."""
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(a) for a in x]
    if hasattr(x, "tolist"):
        return jsonable(x.tolist())
    return x


@dataclass(frozen=True)
class Check:
    """One named check of a reproduction (an output record: the reproductions build it).

    Attributes:
        name: Short identifier, e.g. ``"free-zone pass-through"``.
        source: Where the claim comes from, e.g. ``"US 8,676,382 claims 5, 9, 13"``.
        expected: The source's value or statement.
        measured: Our measured value.
        tolerance: The tolerance applied (number or text).
        passed: Whether the measurement meets the expectation within the tolerance.
        note: Optional explanation (always given when we cannot match the source).
        source_defect: True when the check documents a claim that the source's *own* law does
            not meet (measured and explained); such a failure is a finding about the source,
            not a failure of the reproduction.
    """

    name: str
    source: str
    expected: Any
    measured: Any
    tolerance: Any
    passed: bool
    note: str = ""
    source_defect: bool = False

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        d = {
            "name": self.name,
            "source": self.source,
            "expected": jsonable(self.expected),
            "measured": jsonable(self.measured),
            "tolerance": jsonable(self.tolerance),
            "passed": bool(self.passed),
        }
        if self.note:
            d["note"] = self.note
        if self.source_defect:
            d["source_defect"] = True
        return d


@dataclass(frozen=True)
class Report:
    """The outcome of one reproduction (an output record: each reproduction returns one).

    Args:
        name: The reproduction's name.
        checks: Its checks, each expected value against the measured one.
        artifacts: The files it wrote (paths as text).
    """

    name: str
    checks: tuple[Check, ...]
    artifacts: tuple[str, ...] = field(default=())

    @property
    def passed(self) -> bool:
        """True when every check passed, except those that document a source defect."""
        return all(c.passed or c.source_defect for c in self.checks)

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of the report (shape in the module docstring)."""
        return {
            "name": self.name,
            "checks": [c.to_dict() for c in self.checks],
            "artifacts": list(self.artifacts),
        }

    def to_json(self) -> str:
        """One JSON object, indented."""
        return json.dumps(self.to_dict(), indent=2)


def check_close(
    name: str, source: str, expected: float, measured: float, tol: float, note: str = ""
) -> Check:
    """A check that ``|measured - expected| <= tol``."""
    ok = bool(math.isfinite(measured) and abs(measured - expected) <= tol)
    return Check(name, source, expected, measured, tol, ok, note)


def check_at_most(name: str, source: str, limit: float, measured: float, note: str = "") -> Check:
    """A check that ``measured <= limit`` (expected is written as ``<= limit``)."""
    return Check(name, source, f"<= {limit:g}", measured, limit, bool(measured <= limit), note)


def check_at_least(name: str, source: str, limit: float, measured: float, note: str = "") -> Check:
    """A check that ``measured >= limit`` (expected is written as ``>= limit``)."""
    return Check(name, source, f">= {limit:g}", measured, limit, bool(measured >= limit), note)
