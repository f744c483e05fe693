r"""Baseline: the same end-effector task as a QP with velocity-damper inequalities.

The standard modern formulation (Faverjon & Tournassoud's velocity damper, as used by NEO —
Haviland & Corke 2021 — the Robotics Toolbox and mink), for comparison with the configuration
controller of :mod:`velfence.redundancy.configuration_control`:

.. math::
    \min_{\dot\theta}\ \|J_e\dot\theta - \dot Y_r\|^2 + \lambda\|\dot\theta\|^2
    \quad\text{s.t.}\quad -u_o^\top J_{c,o}\,\dot\theta \le
    \xi\,\frac{s_o - d_s}{d_i - d_s}\quad \text{for every obstacle with } s_o \le d_i,

with :math:`s_o = d_o - r_o` the surface-to-surface clearance between the link capsule and the
obstacle body (critical distance minus obstacle radius), :math:`d_i` the influence distance,
:math:`d_s` the safety distance and :math:`\xi` the damper gain. In continuous time the clearance
decays at most exponentially toward :math:`d_s` and never crosses it; in discrete time with period
:math:`\Delta t` it stays above :math:`d_s` (to first order) while
:math:`\xi\Delta t < d_i - d_s`. Solved with ``qpsolvers.solve_qp(..., solver=...)`` (optional
dependency ``velfence[qp]``, imported lazily). When the solver reports infeasibility the output is
zero velocity, zone ``"infeasible"``.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import MAX_MAGNITUDE, check_positive, real_array
from velfence.errors import InvalidInput, InvalidParameter
from velfence.redundancy.configuration_control import ChainObstacleBase, ControlResult
from velfence.shaping.base import OnInvalid

if TYPE_CHECKING:
    from velfence.filter.limits import SphereObstacle
    from velfence.mechanisms.chain import SerialChain

__all__ = ["VelocityDamperQP"]


def _qpsolvers(solver: str) -> Any:
    """The qpsolvers module, checked to offer ``solver`` (clear error otherwise)."""
    try:
        qp = importlib.import_module("qpsolvers")
    except ImportError:
        raise InvalidParameter(
            "VelocityDamperQP needs qpsolvers, which is not installed; install it with "
            "pip install 'velfence[qp]' (qpsolvers + daqp)"
        ) from None
    if solver not in qp.available_solvers:
        raise InvalidParameter(
            f"solver must be one of the installed qpsolvers back-ends {qp.available_solvers}, "
            f"got {solver!r}; install it (e.g. pip install daqp) or pick another"
        )
    return qp


class VelocityDamperQP(ChainObstacleBase):
    r"""Velocity-damper QP baseline (NEO / mink style) for the configuration-control scenarios.

    Same contract as :class:`~velfence.redundancy.ConfigurationController`: ``control``,
    ``shape``, ``explain``, ``shape_batch``; the :class:`ControlResult`'s ``active`` lists the
    binding damper rows (within ``task_tolerance``), ``distances`` are critical distances (centre
    to capsule surface, subtract the obstacle radius for the clearance the damper acts on).

    Args:
        chain: The kinematics (:class:`~velfence.mechanisms.chain.SerialChain`).
        obstacles: Spherical obstacles (their ``radius`` is the body; ``influence`` is unused).
        gain_xi: Damper gain :math:`\xi` [m/s], > 0.
        d_influence: Influence clearance :math:`d_i` [m], > ``d_safe``: rows exist only within it.
        d_safe: Safety clearance :math:`d_s` [m], >= 0, between link and obstacle surfaces.
        ee_gain: :math:`K_e` [1/s], >= 0, position feedback with ``ee_target``.
        damping: :math:`\lambda` [m²/rad²], > 0, joint-velocity regularisation.
        solver: qpsolvers back-end name (default ``"daqp"``).
        task_tolerance: Rate tolerance [m/s], > 0, for "binding" and "gave way" flags.
        on_invalid: ``"raise"`` or ``"stop"``.

    Raises:
        InvalidParameter: out-of-range parameters, or qpsolvers / the solver not installed.
    """

    method = "velocity-damper-qp"

    def __init__(
        self,
        chain: SerialChain,
        obstacles: Sequence[SphereObstacle],
        *,
        gain_xi: float = 1.0,
        d_influence: float = 0.3,
        d_safe: float = 0.05,
        ee_gain: float = 1.0,
        damping: float = 1e-4,
        solver: str = "daqp",
        task_tolerance: float = 1e-3,
        on_invalid: OnInvalid = "raise",
    ) -> None:
        super().__init__(chain, obstacles, on_invalid=on_invalid)
        self.gain_xi = check_positive("gain_xi", gain_xi, unit="m/s")
        self.d_safe = check_positive("d_safe", d_safe, allow_zero=True, unit="m")
        self.d_influence = check_positive("d_influence", d_influence, unit="m")
        if not self.d_influence > self.d_safe:
            raise InvalidParameter(
                f"d_influence must exceed d_safe, got d_influence={self.d_influence} m <= "
                f"d_safe={self.d_safe} m"
            )
        self.ee_gain = check_positive("ee_gain", ee_gain, allow_zero=True, unit="1/s")
        self.damping = check_positive("damping", damping, unit="m²/rad²")
        self.task_tolerance = check_positive("task_tolerance", task_tolerance, unit="m/s")
        if not isinstance(solver, str):
            raise InvalidParameter(
                f"solver must be a qpsolvers back-end name, got {type(solver).__name__}"
            )
        _qpsolvers(solver)
        self.solver = solver
        self._body = np.array([o.radius for o in self.obstacles], dtype=float)

    def clearances(self, distances: FloatArray) -> FloatArray:
        """Surface clearances :math:`s = d - r_o` from critical distances, shape (N_o,) [m].

        Raises:
            InvalidInput: ``distances`` not finite real numbers of shape (N_o,).
        """
        d = real_array(
            "distances", distances, (self._body.shape[0],), what="critical distances [m]"
        )
        return np.asarray(d - self._body, dtype=float)

    def _law(self, q: FloatArray, v: FloatArray, target: FloatArray | None) -> ControlResult:
        qp = _qpsolvers(self.solver)
        if np.max(np.abs(q), initial=0.0) > MAX_MAGNITUDE:  # the chain's own check says "q"
            raise InvalidInput(
                f"position: expected joint angles of magnitude <= {MAX_MAGNITUDE:g} [rad], "
                f"got {q.tolist()}"
            )
        je = np.asarray(self.chain.ee_jacobian(q), dtype=float)
        yr, ee_err = self._ee_reference(q, v, target, self.ee_gain)
        crit = self.critical(q)
        rows = crit.rows
        s = np.asarray(crit.distances - self._body, dtype=float)  # clearances(), unchecked
        n = self.dof
        P = je.T @ je + self.damping * np.eye(n)
        P = 0.5 * (P + P.T)
        c = -(je.T @ yr)
        free = np.linalg.solve(P, -c)
        near = np.flatnonzero(s <= self.d_influence)
        bound = self.gain_xi * (s - self.d_safe) / (self.d_influence - self.d_safe)
        zone = "free"
        if near.size == 0:
            q_dot = free
        elif not (np.all(np.isfinite(P)) and np.all(np.isfinite(c))):
            q_dot = np.full(n, math.nan)
        else:
            x = qp.solve_qp(P, c, -rows[near], bound[near], solver=self.solver)
            if x is None:
                q_dot, zone = np.zeros(n), "infeasible"
            else:
                q_dot = np.asarray(x, dtype=float).reshape(n)
        d_dot = rows @ q_dot
        tol = self.task_tolerance
        active = tuple(int(o) for o in near if -d_dot[o] >= bound[o] - tol)
        violated = tuple(int(o) for o in near if -d_dot[o] > bound[o] + tol)
        ee_rate_error = float(np.linalg.norm(je @ q_dot - yr))
        exhausted = len(active) > self.redundancy
        if zone != "infeasible":
            if exhausted:
                zone = "exhausted"
            elif any(s[o] < self.d_safe for o in active):
                zone = "recovering"
            elif active:
                zone = "active"
        sv = np.linalg.svd(P, compute_uv=False)
        return ControlResult(
            q_dot=q_dot,
            command=v,
            ee_reference=yr,
            zone=zone,
            active=active,
            critical_points=crit.points,
            links=crit.links,
            fractions=crit.fractions,
            distances=crit.distances,
            normals=crit.normals,
            d_dot=d_dot,
            d_dot_free=rows @ free,
            ee_rate_error=ee_rate_error,
            ee_error=ee_err,
            condition=float(sv[0] / sv[-1]),
            exhausted=exhausted,
            ee_yielded=ee_rate_error > tol,
            violated=violated,
            redundancy=self.redundancy,
            method=self.method,
        )


document_inits(globals())
