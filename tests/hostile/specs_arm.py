"""Specs of the module-level names users import directly: ``velfence.apps.demo.arm_box`` (the
arm-in-a-box demo of docs/arm_box.md), ``velfence.filter.TwistMode`` (docs/physics.md) and
``velfence.apps.scenarios.lag`` (examples/physics_lag.py)."""

from __future__ import annotations

import functools

import numpy as np
from harness import C, F, call
from specs_shaping import safety_filter

_Q7 = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
_TWIST = np.array([0.05, 0.0, -0.02])


@functools.cache
def _lag_row() -> object:
    from velfence.apps.scenarios.lag import LagRow

    return LagRow(
        bandwidth=20.0, speed=0.1, buffer=0.05, penetration=0.0, penetration_lookahead=0.0
    )


def _scene() -> object:
    from velfence.apps.demo.arm_box import arm_box_scene

    return arm_box_scene()


def _script() -> object:
    from velfence.apps.demo.arm_box import arm_script

    return arm_script(_scene(), 0.1)


def _twist_mode() -> object:
    from velfence.filter import TwistMode

    return TwistMode(safety_filter())


_SIM = "a closed-loop simulation of five controllers over the whole script (seconds)"

SPECS: dict[str, F | C] = {
    "demo.arm_box.ArmPhase": C(record="output record of arm_script()"),
    "demo.arm_box.ArmRun": C(record="output record of run_arm()"),
    "demo.arm_box.ArmScene": C(record="scene record built by arm_box_scene()"),
    "demo.arm_box.ArmScript": C(record="output record of arm_script()"),
    "demo.arm_box.arm_jog": F(
        lambda: call(_scene().robot, _script()),  # type: ignore[attr-defined]
        types={"robot": "object", "script": "object"},
    ),
    "demo.arm_box.arm_methods": F(lambda: call(["no-limit"]), types={"methods": "object"}),
    "filter.TwistMode": C(
        F(lambda: call(safety_filter()), types={"safety_filter": "object", "point": "choice"}),
        {
            "explain": lambda: call(_Q7, _TWIST),
            "reset": lambda: call(),
            "shape": lambda: call(_Q7, _TWIST),
            "shape_batch": lambda: call(np.array([_Q7, _Q7]), np.array([_TWIST, -_TWIST])),
        },
        instance=_twist_mode,
    ),
    "demo.arm_box.arm_box_scene": F(lambda: call()),
    "demo.arm_box.arm_metrics": F(lambda: call(_scene(), {}), heavy="needs the runs of run_arm"),
    "demo.arm_box.arm_script": F(lambda: call(_scene(), 0.1), types={"scene": "object"}),
    "demo.arm_box.build_arm_controllers": F(
        lambda: call(_scene()), types={"scene": "object", "methods": "object"}
    ),
    "demo.arm_box.run_arm": F(lambda: call(_scene(), 0.1), heavy=_SIM),
    "scenarios.lag.LagRow": C(record="output record of lag_table()"),
    "scenarios.lag.lag_table": F(lambda: call(), heavy="a sweep of closed-loop runs"),
    "scenarios.lag.plot_lag": F(
        lambda: call([_lag_row()], "lag.png"), types={"path": "path"}, heavy="writes a figure"
    ),
}
