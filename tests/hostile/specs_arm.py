"""Specs of the module-level names users import directly: ``velfence.sim.arm`` (the arm scene
of docs/physics.md) and ``velfence.apps.scenarios.lag`` (examples/physics_lag.py)."""

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
    from velfence.sim.arm import arm_box_scene

    return arm_box_scene()


def _script() -> object:
    from velfence.sim.arm import arm_script

    return arm_script(_scene(), 0.1)


def _twist_mode() -> object:
    from velfence.sim.arm import TwistMode

    return TwistMode(safety_filter())


_SIM = "a closed-loop simulation of five controllers over the whole script (seconds)"

SPECS: dict[str, F | C] = {
    "sim.arm.ArmPhase": C(record="output record of arm_script()"),
    "sim.arm.ArmRun": C(record="output record of run_arm()"),
    "sim.arm.ArmScene": C(record="scene record built by arm_box_scene()"),
    "sim.arm.ArmScript": C(record="output record of arm_script()"),
    "sim.arm.TcpJog": C(
        F(
            lambda: call(_scene().robot, _script()),  # type: ignore[attr-defined]
            types={"robot": "object", "script": "object"},
        ),
        {"target": F(lambda: call(0.5), types={"t": "scalar"})},
    ),
    "sim.arm.TwistMode": C(
        F(lambda: call(safety_filter()), types={"safety_filter": "object", "point": "choice"}),
        {
            "explain": lambda: call(_Q7, _TWIST),
            "reset": lambda: call(),
            "shape": lambda: call(_Q7, _TWIST),
            "shape_batch": lambda: call(np.array([_Q7, _Q7]), np.array([_TWIST, -_TWIST])),
        },
        instance=_twist_mode,
    ),
    "sim.arm.arm_box_scene": F(lambda: call()),
    "sim.arm.arm_metrics": F(lambda: call(_scene(), {}), heavy="needs the runs of run_arm"),
    "sim.arm.arm_script": F(lambda: call(_scene(), 0.1), types={"scene": "object"}),
    "sim.arm.build_arm_controllers": F(
        lambda: call(_scene()), types={"scene": "object", "methods": "object"}
    ),
    "sim.arm.run_arm": F(lambda: call(_scene(), 0.1), heavy=_SIM),
    "scenarios.lag.LagRow": C(record="output record of lag_table()"),
    "scenarios.lag.lag_table": F(lambda: call(), heavy="a sweep of closed-loop runs"),
    "scenarios.lag.plot_lag": F(
        lambda: call([_lag_row()], "lag.png"), types={"path": "path"}, heavy="writes a figure"
    ),
}
