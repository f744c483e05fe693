r"""Look-ahead for a lagging velocity servo: shape at the position a stop would end at.

Every velfence law is exact for an ideal plant (the commanded velocity is the velocity). A real
joint velocity servo follows its reference with a lag; for a first-order lag of time constant
:math:`T`

.. math:: \dot v = (v_{ref} - v)/T,

the robot keeps moving after the reference drops to zero and comes to rest at
:math:`p + T\,v`. Shaped at :math:`p`, the approach through a buffer of width :math:`b` (normal
speed :math:`u\,d/b` for a command :math:`u`) is the second-order loop
:math:`T\ddot d + \dot d + (u/b)\,d = 0`, which overshoots the wall when :math:`u\,T/b > 1/4`:
the buffer must be at least :math:`4\,u\,T` wide, or the robot goes through it.

:class:`LagCompensation` shapes at the predicted stopping position :math:`\hat p = p + T\,\hat v`
first, with :math:`\hat v` the servo's velocity predicted from the shaper's own past outputs
(the discrete first-order model :math:`\hat v_{k+1} = \hat v_k + (1 - e^{-\Delta t/T})(v_k -
\hat v_k)`, needing no velocity measurement). The loop becomes
:math:`T\ddot d + (1 + uT/b)\,\dot d + (u/b)\,d = 0`, whose damping ratio
:math:`(1 + uT/b)/(2\sqrt{uT/b}) \ge 1` for every speed, buffer and lag: no overshoot in the
linear regime, and at rest (:math:`\hat v = 0`) the whole set stays usable.

The predicted point alone is not enough: passing an obstacle, the arm now is closer to it than
where it would stop, and a filter that only looks ahead lets it touch (seen in MuJoCo). So the
result of the look-ahead stage is shaped once more at the measured position by ``guard`` (the
wrapped shaper itself when its command and output live in one space; for a twist-mode filter the
same :class:`~velfence.filter.SafetyFilter` in joint mode): the output keeps every
guarantee the guard gives at the measured state, and the look-ahead only adds braking.
``docs/physics.md`` has the penetration measured in MuJoCo with and without it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_positive, real_array
from velfence.errors import InvalidParameter

__all__ = ["LagCompensation"]


class LagCompensation:
    r"""A shaper evaluated at the predicted stopping position of a lagging servo (module docs).

    ``explain(p, v)`` is ``guard.explain(p, shaper.explain(p + T * v_hat, v).output)`` (a single
    call while ``v_hat`` is zero); the result is the guard's, at the measured position.
    Stateful: the predicted servo velocity ``v_hat`` starts at zero and :meth:`reset` forgets it
    (the runner resets it before a run). :meth:`shape_batch` evaluates every row from rest (no
    history). The wrapped shaper and the guard must be stateless (two calls a cycle would
    advance a rate limiter twice).

    Args:
        shaper: Any shaper whose output lives in the state's space (joint velocities for a
            joint state, workspace velocities for a workspace point).
        time_constant: The servo's lag time constant :math:`T` [s], > 0 (for
            :class:`~velfence.sim.physics.MujocoPlant`'s computed-torque servo ``1/bandwidth``).
        dt: Control period [s], > 0 (one :meth:`explain` per period).
        guard: A shaper whose command is ``shaper``'s output (e.g. the SafetyFilter in joint mode
            under a twist-mode wrapper); default ``shaper`` itself, which needs equal command and
            output spaces.

    Raises:
        InvalidParameter: a shaper or guard without ``explain``/``shape_batch`` or stateful, or
            a bad time.
    """

    stateful = True

    def __init__(self, shaper: Any, *, time_constant: float, dt: float, guard: Any = None) -> None:
        for name, obj in (("shaper", shaper), ("guard", guard)):
            if obj is None and name == "guard":
                continue
            if not all(callable(getattr(obj, m, None)) for m in ("explain", "shape_batch")):
                raise InvalidParameter(
                    f"{name} must implement explain and shape_batch, got {type(obj).__name__}"
                )
            if getattr(obj, "stateful", False) is True:
                raise InvalidParameter(
                    f"{name} must be stateless (it is called twice a cycle), got a stateful "
                    f"{type(obj).__name__}; drop its rate or acceleration limits"
                )
        self.shaper = shaper
        self.guard = shaper if guard is None else guard
        self._own_guard = guard is None
        self.time_constant = check_positive("time_constant", time_constant, unit="s")
        self.dt = check_positive("dt", dt, unit="s")
        self._alpha = -math.expm1(-self.dt / self.time_constant)
        self._v: FloatArray | None = None

    @property
    def method(self) -> str:
        """The wrapped shaper's method, marked as lag-compensated."""
        return f"{getattr(self.shaper, 'method', type(self.shaper).__name__)} + look-ahead"

    @property
    def predicted_velocity(self) -> FloatArray | None:
        """The servo velocity the model predicts now (``None`` before the first call)."""
        return None if self._v is None else self._v.copy()

    def reset(self) -> None:
        """Forget the predicted velocity (start from rest)."""
        self._v = None

    def explain(self, position: ArrayLike, command: ArrayLike, /) -> Any:
        """The wrapped shaper's result at the predicted stopping position.

        Args:
            position: State (as the wrapped shaper takes it).
            command: Command (as the wrapped shaper takes it).

        Returns:
            The wrapped shaper's result (its ``output`` is the shaped velocity).

        Raises:
            InvalidInput: what the wrapped shaper raises for bad input.
            InvalidParameter: the output does not have the state's shape.
        """
        p = real_array("position", position, None, allow_nonfinite=True)
        v_hat = np.zeros_like(p) if self._v is None or self._v.shape != p.shape else self._v
        if not np.any(v_hat):
            res = self.shaper.explain(p, command)
        else:
            ahead = np.asarray(
                self.shaper.explain(p + self.time_constant * v_hat, command).output, dtype=float
            )
            c = np.asarray(command)
            if self._own_guard and c.shape != ahead.shape:
                raise InvalidParameter(
                    f"guard: the shaper's command {c.shape} and output {ahead.shape} live in "
                    "different spaces; pass guard= a shaper of its output (e.g. the SafetyFilter "
                    "itself in joint mode)"
                )
            res = self.guard.explain(p, ahead)
        out = np.asarray(res.output, dtype=float)
        if out.shape != p.shape:
            raise InvalidParameter(
                f"shaper: LagCompensation needs an output of the state's shape {p.shape}, got "
                f"{out.shape}"
            )
        if np.all(np.isfinite(out)):
            self._v = v_hat + self._alpha * (out - v_hat)
        return res

    def shape(self, position: ArrayLike, command: ArrayLike, /) -> FloatArray:
        """The shaped velocity (``explain(position, command).output``).

        Args:
            position: State.
            command: Command.

        Returns:
            The shaped velocity.
        """
        return np.asarray(self.explain(position, command).output, dtype=float)

    def shape_batch(self, positions: ArrayLike, commands: ArrayLike, /) -> FloatArray:
        """The wrapped shaper's batch, every row from rest (``v_hat = 0``).

        Args:
            positions: States, one per row.
            commands: Commands, one per row.

        Returns:
            Shaped velocities, one per row.
        """
        return np.asarray(self.shaper.shape_batch(positions, commands), dtype=float)


document_inits(globals())
