"""Integrations: velfence's laws as parts of other libraries' controllers.

Math contract: an integration states velfence's rows in the other library's form and changes
nothing of the law: :class:`PolytopeLimit` gives ``mink.solve_ik`` (differential IK, one QP in
``Δq = v dt``) the rows ``n_iᵀ J_p Δq >= dt · b_i(d_i)`` of a workspace polytope, ``b_i`` the
:class:`~velfence.filter.SafetyFilter`'s own workspace bound
(:func:`velfence.filter.rows.workspace_bounds`); :mod:`velfence.integrations.gymnasium` puts the
:class:`~velfence.filter.SafetyFilter` between a Gymnasium agent and its environment
(``docs/policies.md``); :class:`~velfence.integrations.lerobot.LeRobotShield` runs it on
LeRobot's position targets (``docs/lerobot.md``; the SO-ARM's joint names of its action and
observation dictionaries: ``JOINTS``, the arm's ``ARM_JOINTS`` and the ``GRIPPER``). The names
load on first use, each with its own extra (mink: the ``physics`` extra; Gymnasium: the ``gym``
extra; the SO-ARM model: the ``lerobot`` extra, while the shield itself imports neither lerobot
nor torch); ``import velfence`` does not import this package.
"""

from __future__ import annotations

from velfence import _lazy

#: Public name -> defining module, loaded on first use (each module needs its own extra).
_EXPORTS: dict[str, str] = {
    "PolytopeLimit": "velfence.integrations.mink_limits",
    "BatchJointState": "velfence.integrations.gymnasium",
    "JointState": "velfence.integrations.gymnasium",
    "MujocoJointState": "velfence.integrations.gymnasium",
    "Shield": "velfence.integrations.gymnasium",
    "ShieldWrapper": "velfence.integrations.gymnasium",
    "VectorShieldWrapper": "velfence.integrations.gymnasium",
    "mujoco_arm": "velfence.integrations.gymnasium",
    "mujoco_shield": "velfence.integrations.gymnasium",
    "ARM_JOINTS": "velfence.integrations.lerobot",
    "GRIPPER": "velfence.integrations.lerobot",
    "JOINTS": "velfence.integrations.lerobot",
    "LeRobotShield": "velfence.integrations.lerobot",
    "so_arm": "velfence.integrations.lerobot",
}

__getattr__, __dir__ = _lazy.attach("velfence.integrations", _EXPORTS, globals())

TYPE_CHECKING = False
if TYPE_CHECKING:
    from velfence.integrations.gymnasium import (
        BatchJointState,
        JointState,
        MujocoJointState,
        Shield,
        ShieldWrapper,
        VectorShieldWrapper,
        mujoco_arm,
        mujoco_shield,
    )
    from velfence.integrations.lerobot import ARM_JOINTS, GRIPPER, JOINTS, LeRobotShield, so_arm
    from velfence.integrations.mink_limits import PolytopeLimit

__all__ = [
    "ARM_JOINTS",
    "GRIPPER",
    "JOINTS",
    "BatchJointState",
    "JointState",
    "LeRobotShield",
    "MujocoJointState",
    "PolytopeLimit",
    "Shield",
    "ShieldWrapper",
    "VectorShieldWrapper",
    "mujoco_arm",
    "mujoco_shield",
    "so_arm",
]
