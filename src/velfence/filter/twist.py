"""The safety filter in twist mode as a shaper: state ``q``, command a robot point's velocity."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import describe, real_array
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter.filter import SafetyFilter
from velfence.filter.result import FilterResult

__all__ = ["TwistMode"]


class TwistMode:
    """A :class:`~velfence.filter.SafetyFilter` in twist mode, as a Shaper on ``(q, v)``.

    ``explain(q, v)`` is ``safety_filter.explain_twist(q, v, point=point)``: the state is the
    joint position ``q`` [rad], the command the velocity ``v`` [m/s] of a robot point (shape (3,)),
    the output a joint velocity [rad/s]. :func:`velfence.sim.simulate` runs it like any shaper,
    and a ``safety_filter`` section of a configuration file with ``command: twist`` builds one
    (:func:`velfence.io.parse_shaper`). ``method`` is ``"safety-filter"``, the filter's own.

    Args:
        safety_filter: The filter.
        point: The robot point the twist commands (default ``"tcp"``).
    """

    method = "safety-filter"

    def __init__(self, safety_filter: SafetyFilter, *, point: str = "tcp") -> None:
        if not isinstance(safety_filter, SafetyFilter):
            raise InvalidParameter(
                f"safety_filter: expected a SafetyFilter, got {describe(safety_filter)}"
            )
        points = list(safety_filter.robot.points)
        if not isinstance(point, str) or point not in points:
            raise InvalidParameter(f"point: expected one of {points}, got {describe(point)}")
        self.filter = safety_filter
        self.point = point

    @property
    def stateful(self) -> bool:
        """Whether the filter remembers its last output (acceleration rows)."""
        return bool(getattr(self.filter, "stateful", False))

    def reset(self) -> None:
        """Forget the filter's remembered output (:func:`velfence.sim.simulate` calls it)."""
        self.filter.reset()

    def explain(self, position: ArrayLike, command: ArrayLike, /) -> FilterResult:
        """The filter's :class:`~velfence.filter.FilterResult` for the TCP twist ``command``."""
        return self.filter.explain_twist(position, command, point=self.point)

    def shape(self, position: ArrayLike, command: ArrayLike, /) -> FloatArray:
        """Joint velocity [rad/s], shape (n,), for TCP twist ``command`` [m/s] at ``position``."""
        return np.asarray(
            self.filter.filter_twist(position, command, point=self.point), dtype=float
        )

    def shape_batch(self, positions: ArrayLike, commands: ArrayLike, /) -> FloatArray:
        """:meth:`shape` on N independent states: positions (N, n), commands (N, 3) -> (N, n).

        Like :meth:`SafetyFilter.shape_batch <velfence.filter.SafetyFilter.shape_batch>`, each row
        starts from no remembered output (the filter is reset before each row, so it is left
        reset).
        """
        Qa = real_array("positions", positions, (None, None), what="joint positions [rad]")
        Va = real_array("commands", commands, (None, 3), what="TCP velocities [m/s]")
        if Qa.shape[0] != Va.shape[0] or Qa.shape[0] == 0:
            raise InvalidInput(
                f"positions, commands: expected one command per position (N >= 1 rows each), "
                f"got {Qa.shape[0]} positions and {Va.shape[0]} commands"
            )
        n = (
            len(self.filter.robot.joint_names)
            if hasattr(self.filter.robot, "joint_names")
            else None
        )
        if n is not None and Qa.shape[1] != n:
            raise InvalidInput(f"positions: expected shape (N, {n}), got shape {Qa.shape}")
        out = np.zeros(Qa.shape)
        for k in range(Qa.shape[0]):
            self.filter.reset()
            out[k] = self.filter.filter_twist(Qa[k], Va[k], point=self.point)
        return out


document_inits(globals())
