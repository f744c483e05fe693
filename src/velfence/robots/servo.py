r"""The computed-torque joint velocity servo of a MuJoCo arm (one law, two users).

.. math:: \tau = \operatorname{clip}\bigl(M(q)\,\omega_c\,(\dot q_{ref} - \dot q) + b(q, \dot q),
          \ \pm\tau_{max}\bigr)

with :math:`M` the joint-space inertia, :math:`b` MuJoCo's bias force (gravity, Coriolis,
centrifugal: ``qfrc_bias``) and :math:`\omega_c` the servo bandwidth [rad/s]: below the effort
limits each joint follows its reference as the first-order lag :math:`\ddot q = \omega_c(\dot
q_{ref} - \dot q)`. :class:`~velfence.sim.physics.MujocoPlant` applies it at every physics step;
the Gymnasium shield (:mod:`velfence.integrations.gymnasium`) once per control period of a
torque-actuated environment.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from velfence._typing import FloatArray, IntArray

__all__ = ["computed_torque"]


def computed_torque(
    mujoco: Any,
    model: Any,
    data: Any,
    dofs: IntArray | slice,
    reference: FloatArray,
    *,
    bandwidth: float,
    max_effort: FloatArray,
    scratch: FloatArray,
    passive: bool = False,
) -> tuple[FloatArray, bool]:
    r"""The servo's joint torques on ``dofs`` and whether an effort limit clipped them.

    ``data`` must hold the current state's inertia and bias force (after ``mj_step1``,
    ``mj_forward`` or ``mj_fwdPosition`` + ``mj_fwdVelocity``). The arguments are the callers'
    own, already validated: this is the law, not a public entry point.

    Args:
        mujoco: The ``mujoco`` module.
        model: The ``MjModel``.
        data: The ``MjData``.
        dofs: DoF addresses of the servoed joints, shape (k,) (or a slice of them).
        reference: Joint velocity references [rad/s or m/s], shape (k,).
        bandwidth: :math:`\omega_c` [rad/s], > 0.
        max_effort: Effort limits [N·m or N], shape (k,) (``inf``: none).
        scratch: A float array of shape (nv,) the product ``M e`` is written to.
        passive: Also cancel MuJoCo's passive forces (joint damping and stiffness,
            ``qfrc_passive``), as a servo on a damped model (Gymnasium's arms) needs to track.

    Returns:
        ``(tau (k,), clipped)``.
    """
    err = np.zeros(model.nv)
    err[dofs] = bandwidth * (reference - data.qvel[dofs])
    mujoco.mj_mulM(model, data, scratch, err)
    tau: FloatArray = scratch[dofs] + data.qfrc_bias[dofs]
    if passive:
        tau = tau - data.qfrc_passive[dofs]
    sat = np.abs(tau) > max_effort
    clipped = bool(sat.any())
    if clipped:
        tau = np.clip(tau, -max_effort, max_effort)
    return tau, clipped
