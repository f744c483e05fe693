"""External velocity disturbances for the closed-loop runner.

A disturbance is any callable ``w(t, p) -> velocity`` (shape (2,), workspace units per second)
that the runner adds to the shaped velocity before integrating: ``p += dt·(v + w(t, p))``. It
models a push on a backdrivable mechanism, which the shaper cannot veto: this is why US 8,676,382
adds a virtual spring outside the polygon.

:class:`Disturbance` is an immutable sum of constant pushes, each active on a half-open window
``[t0, t1)``. Build one with :meth:`Disturbance.push` (or the module alias :func:`push`) and add
them with ``+``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._validate import as_pair, check_positive
from velfence.errors import InvalidParameter

__all__ = ["Disturbance", "push"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Disturbance:
    """A sum of constant velocity pushes, callable as ``w(t, p)``.

    Attributes:
        pushes: ``((t0, t1, vx, vy), ...)``: push ``(vx, vy)`` [workspace units / s] active for
            ``t0 <= t < t1`` [s]. Empty means no disturbance.
    """

    pushes: tuple[tuple[float, float, float, float], ...] = ()

    @classmethod
    def push(cls, t0: float, t1: float, velocity: ArrayLike) -> Disturbance:
        """A constant push ``velocity`` during the half-open window ``[t0, t1)``.

        Args:
            t0: Start time, [s], finite and >= 0.
            t1: End time (exclusive), [s], > t0; ``math.inf`` for a push that never ends.
            velocity: Push velocity, shape (2,), workspace units per second, finite.

        Raises:
            InvalidParameter: for an empty or non-finite window or a non-finite velocity.
        """
        a = check_positive("t0", t0, allow_zero=True, unit="s")
        try:
            b = float(t1)
        except (TypeError, ValueError):
            raise InvalidParameter(f"t1 must be a number in s, got {t1!r}") from None
        if math.isnan(b) or b <= a:
            raise InvalidParameter(f"t1 must be > t0 = {a} s (math.inf allowed), got {t1!r}")
        try:
            vx, vy = as_pair("velocity", velocity)
        except ValueError as exc:
            raise InvalidParameter(str(exc)) from None
        if not (math.isfinite(vx) and math.isfinite(vy)):
            raise InvalidParameter(
                f"velocity must be finite (workspace units per second), got ({vx}, {vy})"
            )
        return cls(((a, b, vx, vy),))

    def __add__(self, other: Disturbance) -> Disturbance:
        """The sum of two disturbances (their pushes superpose)."""
        if not isinstance(other, Disturbance):
            return NotImplemented
        return Disturbance(self.pushes + other.pushes)

    def __call__(self, t: float, p: ArrayLike) -> FloatArray:
        """Disturbance velocity at time ``t`` [s] and position ``p`` (unused), shape (2,)."""
        wx = 0.0
        wy = 0.0
        for t0, t1, vx, vy in self.pushes:
            if t0 <= t < t1:
                wx += vx
                wy += vy
        return np.array((wx, wy))


push = Disturbance.push
