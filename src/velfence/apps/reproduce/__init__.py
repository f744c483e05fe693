"""Reproductions of the sources: each runs its experiment and returns a Report of named checks.

Math contract: a check compares a number the source publishes (or a claim it makes, turned into a
measurable statement) with what our implementation measures, under a stated tolerance; every
discrepancy is explained in the check's note and in ``docs/reproductions.md``.
"""

from velfence.apps.reproduce.base import Check, Report

__all__ = ["Check", "Report"]
