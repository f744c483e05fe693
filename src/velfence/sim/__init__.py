r"""Closed-loop simulation: run shapers against scripted operators, disturbances and noise.

Math contract (``docs/simulation.md``): time :math:`t_k = k\,\Delta t` [s], default
:math:`\Delta t` = 1 ms (1 kHz); positions in workspace units (e.g. [rad] for the wrist),
velocities in workspace units per second. Each step measures :math:`\tilde p_k = p_k +
\varepsilon_k` (seeded Gaussian noise), asks the operator for :math:`v^{cmd}_k = c(t_k, p_k)`,
shapes :math:`v_k = \mathrm{shaper}(\tilde p_k, v^{cmd}_k)`, optionally saturates it at the true
position, and integrates the true state by **explicit Euler** with the external velocity
disturbance :math:`w`:

.. math:: p_{k+1} = p_k + \Delta t\,\bigl(v_k + w(t_k, p_k)\bigr).

The same seed gives the same run. Baselines (:class:`NoLimit`, :class:`HardStop`,
:class:`AxisLimits`) follow the shaper contract; every metric in :mod:`velfence.sim.metrics` has
one definition, stated in its docstring and in ``docs/simulation.md`` §2.

:class:`MujocoPlant` (the ``physics`` extra) replaces the integrator by MuJoCo rigid-body dynamics
behind a joint velocity servo (``docs/physics.md``); the shaped velocity is then a reference held
over each control period.
"""

from velfence.sim.baselines import AxisLimits, HardStop, NoLimit
from velfence.sim.cobot import (
    CobotTrace,
    HeadingController,
    constant_speed,
    follow_in_ee,
    pushing,
    simulate_cobot,
)
from velfence.sim.disturbances import Disturbance, push
from velfence.sim.metrics import (
    area_gain,
    chatter_rate,
    corner_escape_time,
    max_output_jump,
    max_penetration,
    sliding_ratio,
    summarize,
    time_outside,
)
from velfence.sim.physics import BodyPush, MujocoPlant, PhysicsRecord
from velfence.sim.runner import DynamicPlant, Trajectory, simulate, simulate_many

__all__ = [
    "AxisLimits",
    "BodyPush",
    "CobotTrace",
    "Disturbance",
    "DynamicPlant",
    "HardStop",
    "HeadingController",
    "MujocoPlant",
    "NoLimit",
    "PhysicsRecord",
    "Trajectory",
    "area_gain",
    "chatter_rate",
    "constant_speed",
    "corner_escape_time",
    "follow_in_ee",
    "max_output_jump",
    "max_penetration",
    "push",
    "pushing",
    "simulate",
    "simulate_cobot",
    "simulate_many",
    "sliding_ratio",
    "summarize",
    "time_outside",
]
