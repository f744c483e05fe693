"""Former home of the arm-in-a-box demo (until 0.2); every name warns and goes in 0.3.

The demo's scene, script, runs and metrics are an application's: :mod:`velfence.apps.demo.arm_box`.
What a user builds on stayed in the library: the safety filter in twist mode is
:class:`velfence.filter.TwistMode`, the Cartesian jog :class:`velfence.sim.scenarios.TcpJog`
(called ``TcpJog(fk, phases, speed=...)``; the demo's own is
:func:`velfence.apps.demo.arm_box.arm_jog`), the baselines :mod:`velfence.sim.arm_baselines`.
"""

from __future__ import annotations

from velfence import _lazy

__all__: list[str] = []

_DEMO = "velfence.apps.demo.arm_box"

#: Old name -> its home since 0.2 (``"module"`` or ``"module:new_name"``).
_FORMER: dict[str, str] = {
    "ARM_METHODS": _DEMO,
    "ARM_SPEEDS": _DEMO,
    "ArmPhase": _DEMO,
    "ArmRun": _DEMO,
    "ArmScene": _DEMO,
    "ArmScript": _DEMO,
    "arm_box_scene": _DEMO,
    "arm_metrics": _DEMO,
    "arm_script": _DEMO,
    "build_arm_controllers": _DEMO,
    "run_arm": _DEMO,
    "TcpJog": f"{_DEMO}:arm_jog",
    "TwistMode": "velfence.filter.twist",
}

__getattr__, __dir__ = _lazy.attach(__name__, {}, globals(), former=_FORMER)
