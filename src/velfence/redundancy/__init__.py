r"""Obstacle avoidance for redundant arms by configuration control (US 5,150,026).

Math contract (derivation in ``docs/configuration_control.md``). For a chain with joint angles
:math:`\theta \in \mathbb R^n`, end-effector coordinates :math:`Y = k_e(\theta) \in \mathbb R^m`
(redundancy :math:`r = n - m`) and obstacles :math:`o` with centre :math:`x_o`, body radius and
sphere of influence :math:`\rho_o`, every control cycle:

A. critical point :math:`c_o` = closest point of any link axis to :math:`x_o`; critical distance
   :math:`d_o = \|c_o - x_o\| - r_{link}` (obstacle centre to the link's capsule surface);
B. inequality :math:`d_o > \rho_o`;
C. constraint row :math:`J_{z,o} = u_o^\top J_{c,o}`, :math:`u_o = (c_o - x_o)/\|c_o - x_o\|`, so
   :math:`\dot d_o = J_{z,o}\dot\theta`;
D. active set: :math:`o` joins iff :math:`d_o \le \rho_o + h\max(0, -\dot d_o)` and the motion
   computed without it approaches (:math:`\dot d_o < \dot z_{r,o}`), rows added one at a time in
   order of clearance :math:`d_o - \rho_o`;
E. weighted damped least squares on the augmented task
   :math:`\dot\theta = [J_e^\top W_e J_e + \sum J_z^\top w_z J_z + W_v]^{-1}
   [J_e^\top W_e \dot Y_r + \sum J_z^\top w_z \dot z_r]`, :math:`\dot z_r = K_z\max(0, \rho - d)`;
F. further obstacles join while the earlier rows stay enforced.

The output is always finite; with more active rows than :math:`r` the result is flagged
``exhausted`` and the tasks that gave way are named. :class:`VelocityDamperQP` is the QP baseline
(velocity-damper inequalities, as in NEO / mink), solved with qpsolvers (optional dependency).
"""

from velfence._deprecate import module_getattr
from velfence.filter.limits import SphereObstacle as SphereObstacle  # for the old names
from velfence.redundancy.configuration_control import ConfigurationController, ControlResult
from velfence.redundancy.paths import cosine_line
from velfence.redundancy.qp_baseline import VelocityDamperQP

__all__ = [
    "ConfigurationController",
    "ControlResult",
    "VelocityDamperQP",
    "cosine_line",
]

#: Former names of :class:`velfence.filter.SphereObstacle`; they construct it until 0.3.
__getattr__ = module_getattr(
    __name__, {"Obstacle": "SphereObstacle", "InfluenceObstacle": "SphereObstacle"}, globals()
)
