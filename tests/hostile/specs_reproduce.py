"""Specs of velfence.apps.reproduce."""

from __future__ import annotations

from harness import C, call

from velfence.apps.reproduce import Check, Report

_RECORD = "output record of the reproductions (velfence.apps.reproduce.run_* build and return it)"


def _check() -> Check:
    return Check("c", "source", 1.0, 1.0, 0.1, True)


SPECS: dict[str, C] = {
    "reproduce.Check": C(record=_RECORD, instance=_check, methods={"to_dict": lambda: call()}),
    "reproduce.Report": C(
        record=_RECORD,
        instance=lambda: Report("r", (_check(),)),
        methods={"to_dict": lambda: call(), "to_json": lambda: call()},
    ),
}

SPECS.update(
    {
        "scenarios.PhysicsRun": C(record="a record a physics scenario builds (robot_sim.*.run)"),
        "scenarios.ScenarioResult": C(
            record="a record a physics scenario builds (robot_sim.*.run)"
        ),
    }
)
