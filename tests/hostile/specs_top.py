"""Specs of names defined in the top-level modules (errors only hold exception classes)."""

from __future__ import annotations

from harness import C, F

SPECS: dict[str, F | C] = {}
