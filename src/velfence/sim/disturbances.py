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
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_positive, finite_scalar, real_array, show
from velfence.errors import InvalidParameter

__all__ = ["Disturbance", "push"]


def _t1(t1: object, t0: float) -> float:
    """The end of a push window [s]: a real number > t0, ``math.inf`` allowed."""
    b = float(
        real_array(
            "t1",
            t1,
            (),
            error=InvalidParameter,
            what="an end time [s]",
            allow_nonfinite=True,
            max_abs=None,
        )
    )
    if math.isnan(b) or b <= t0:
        raise InvalidParameter(f"t1 must be > t0 = {t0} s (math.inf allowed), got {show(t1)}")
    return b


@dataclass(frozen=True, kw_only=True)
class Disturbance:
    """A sum of constant velocity pushes, callable as ``w(t, p)``.

    Attributes:
        pushes: ``((t0, t1, vx, vy), ...)``: push ``(vx, vy)`` [workspace units / s] active for
            ``t0 <= t < t1`` [s]. Empty means no disturbance.
    """

    pushes: tuple[tuple[float, float, float, float], ...] = ()

    def __post_init__(self) -> None:
        rows = real_array(
            "pushes",
            list(self.pushes) if isinstance(self.pushes, tuple) else self.pushes,
            None,
            error=InvalidParameter,
            what="rows (t0, t1, vx, vy)",
            allow_nonfinite=True,
        )
        if rows.size == 0:
            rows = rows.reshape(0, 4)
        if rows.ndim != 2 or rows.shape[1] != 4:
            raise InvalidParameter(
                f"pushes: expected rows (t0, t1, vx, vy) of shape (N, 4), got shape {rows.shape}"
            )
        clean = []
        for i, (t0, t1, vx, vy) in enumerate(rows.tolist()):
            a = check_positive(f"pushes[{i}] t0", t0, allow_zero=True, unit="s")
            try:
                b = _t1(t1, a)
            except InvalidParameter as exc:
                raise InvalidParameter(f"pushes[{i}]: {exc}") from None
            if not (math.isfinite(vx) and math.isfinite(vy)):
                raise InvalidParameter(
                    f"pushes[{i}]: velocity must be finite (workspace units per second), got "
                    f"({vx}, {vy})"
                )
            clean.append((a, b, float(vx), float(vy)))
        object.__setattr__(self, "pushes", tuple(clean))

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
        b = _t1(t1, a)
        vx, vy = real_array(
            "velocity", velocity, (2,), error=InvalidParameter, what="a push velocity"
        ).tolist()
        return cls(pushes=((a, b, vx, vy),))

    def __add__(self, other: Disturbance) -> Disturbance:
        """The sum of two disturbances (their pushes superpose)."""
        if not isinstance(other, Disturbance):
            return NotImplemented
        return Disturbance(pushes=self.pushes + other.pushes)

    def __call__(self, t: float, p: ArrayLike) -> FloatArray:
        """Disturbance velocity at time ``t`` [s] and position ``p`` (unused), shape (2,).

        Args:
            t: Time [s], finite.
            p: Position, shape (2,), finite (checked although a constant push does not use it:
                a NaN or wrong-shape position is a caller's bug).

        Returns:
            The summed velocity of the pushes active at ``t``, shape (2,).


        Raises:
            InvalidInput: ``t`` not a finite real number, or ``p`` not a finite position of
                shape (2,).
        """
        t = finite_scalar("t", t, unit="s", what="time")
        real_array("p", p, (2,), what="a position (x, y) of finite numbers")
        wx = 0.0
        wy = 0.0
        for t0, t1, vx, vy in self.pushes:
            if t0 <= t < t1:
                wx += vx
                wy += vy
        return np.array((wx, wy))


push = Disturbance.push

document_inits(globals())
