"""The kinematics protocol of :class:`~velfence.shaping.filter.SafetyFilter`.

Defined here, in the shaping layer, so that the filter needs no import from
:mod:`velfence.mechanisms` (a higher layer): the chains implement it structurally.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from numpy.typing import ArrayLike

from velfence._typing import FloatArray

__all__ = ["Kinematics"]


@runtime_checkable
class Kinematics(Protocol):
    """The kinematics a :class:`SafetyFilter` needs.

    Implemented structurally by ``DHChain``, ``PlanarArm`` and ``Puma560`` of
    :mod:`velfence.mechanisms` (``Puma560.fk``/``jacobian`` without a point keep returning the
    tool pose and the 6 x 6 geometric Jacobian; the filter always names the point).

    Obstacles additionally need the capsule geometry of
    :class:`~velfence.mechanisms.chain.SerialChain`: ``link_segments(q)`` (L, 2, 3),
    ``link_radius`` (L,), ``point_jacobian(q, link, t)`` (3, dof) and ``joint_positions(q)``; a
    twist of shape (6,) needs ``angular_jacobian(q)`` (3, dof).
    """

    @property
    def dof(self) -> int:
        """Number of joints."""
        ...

    @property
    def joint_names(self) -> tuple[str, ...]:
        """One name per joint."""
        ...

    @property
    def points(self) -> tuple[str, ...]:
        """Names of the points ``fk`` and ``jacobian`` accept; ``"tcp"`` always."""
        ...

    def fk(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """Position of a named point [m], shape (task_dim,), for joints ``q`` (dof,) [rad]."""
        ...

    def jacobian(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """Linear-velocity Jacobian of a named point [m/rad], shape (task_dim, dof)."""
        ...
