"""Reports of named checks, the JSON format of ``velfence reproduce NAME --json``.

Every reproduction returns a :class:`Report`: a list of :class:`Check` (what the source claims or
publishes, what we measured, the tolerance we can honestly meet, and whether it passed) plus the
paths of the artifacts (plots) it wrote. The JSON shape is fixed::

    {"name": ..., "checks": [{"name", "source", "expected", "measured", "tolerance", "passed"}],
     "artifacts": [paths]}

A check may also carry ``"note"``, ``"source_defect": true`` (the source's own law misses its
claim) or ``"expected_miss": true`` (a known miss of ours, documented); a failed check with either
flag is a *documented miss*, which the command reports but does not fail on.
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
        expected_miss: True when the check is a known miss of ours, explained in its ``note``
            and in ``docs/reproductions.md`` (e.g. a reading of the source we could not make
            meet two of its claims at once). Like a source defect it is a *documented* miss: it
            stays a failure in the report and the JSON, but it does not fail the command.
    """

    name: str
    source: str
    expected: Any
    measured: Any
    tolerance: Any
    passed: bool
    note: str = ""
    source_defect: bool = False
    expected_miss: bool = False

    @property
    def documented_miss(self) -> bool:
        """True for a failed check that is documented: a source defect or an expected miss."""
        return not self.passed and (self.source_defect or self.expected_miss)

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
        if self.expected_miss:
            d["expected_miss"] = True
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
        """True when every check passed or is a documented miss (source defect, expected miss)."""
        return all(c.passed or c.source_defect or c.expected_miss for c in self.checks)

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
