"""Specs of velfence.reproduce."""

from __future__ import annotations

from harness import C, F, call

from velfence.reproduce import Check


def _check() -> Check:
    return Check("c", "source", 1.0, 1.0, 0.1, True)


SPECS: dict[str, F | C] = {
    "reproduce.Check": C(
        F(
            lambda: call("c", "source", 1.0, 1.0, 0.1, True),
            types={"expected": "object", "measured": "object", "tolerance": "object"},
        ),
        {"to_dict": lambda: call()},
    ),
    "reproduce.Report": C(
        F(lambda: call("r", (_check(),)), types={"checks": "object", "artifacts": "object"}),
        {"to_dict": lambda: call(), "to_json": lambda: call()},
    ),
}
