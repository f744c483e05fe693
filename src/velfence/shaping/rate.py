r"""Velocity saturation and acceleration rate limiting: the pre-stage of Lê et al. 2024 §2.

Stateful, and says so: :class:`RateLimiter` keeps the previous output. Per component,

.. math::
    v = \mathrm{clamp}(\dot\theta_c[k], \pm\dot\theta_{max}),\quad
    a = \mathrm{clamp}\big((v - y[k-1])/T_e, \pm\ddot\theta_{max}\big),\quad
    y[k] = y[k-1] + T_e\,a .

The paper prints the acceleration as the difference of consecutive *commands*
(``mode="literal"``); read that way a step command gives one rate-limited sample and then jumps
to its value, which cannot produce the paper's own Fig. 8a (a 20 rad/s² ramp to 0.5 rad/s). The
default ``mode="output"`` limits the change of the previous *output*, which does. See
``docs/derivations.md`` §4.

**A rate limiter alone does not keep joint stops.** Placed after a
:class:`~velfence.shaping.stops.StopLimiter` by hand, it delays the braking the limiter asked for
and the robot crosses the stop (pushing the CoSPM into stop d1 at 1 rad/s with the paper's limits
crosses it by 3.65e-4 rad). Pass it as ``StopLimiter(..., post=RateLimiter(...))`` instead: the
limiter then re-applies the stop bounds after the rate limit, position safety first, and flags
every cycle where the acceleration limit had to give way.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_choice, check_positive, check_positive_int, real_array, show
from velfence.errors import InvalidParameter

__all__ = ["RateLimiter", "RateMode"]

#: What the rate limiter limits the change of: its previous output, or the previous command.
RateMode = Literal["output", "literal"]


#: Largest accepted number of components (a joint vector, not a data set).
MAX_SIZE = 100_000


def _limits(name: str, x: Any, n: int, unit: str) -> FloatArray:
    a = real_array(
        name, x, error=InvalidParameter, what=f"limits [{unit}], a scalar or shape ({n},)"
    )
    if a.shape not in ((), (n,)):
        raise InvalidParameter(f"{name}: expected a scalar or shape ({n},), got shape {a.shape}")
    a = np.broadcast_to(a, (n,)).copy()
    if not np.all(a > 0.0):
        raise InvalidParameter(f"{name} must be finite and > 0 ({unit}), got {show(x)}")
    a.setflags(write=False)
    return a


class RateLimiter:
    """Clamp each component's velocity and its rate of change (stateful).

    Alone it does not guarantee joint stops (module docstring): compose it with a
    :class:`~velfence.shaping.stops.StopLimiter` through ``post=``, which keeps position safety
    first and flags the cycles where the acceleration limit gave way.

    Args:
        size: Number of components n (e.g. 3 joints), keyword-only.
        max_speed: Speed limit per component [units/s], scalar or shape (n,).
        max_acceleration: Acceleration limit per component [units/s²], scalar or shape (n,).
        dt: Sampling period Te [s].
        mode: ``"output"`` (default; rate-limit the previous output) or ``"literal"`` (the
            paper's printed Euler form on consecutive commands; kept to document why it fails).
    """

    def __init__(
        self,
        *,
        size: int,
        max_speed: ArrayLike,
        max_acceleration: ArrayLike,
        dt: float,
        mode: RateMode = "output",
    ) -> None:
        self.size = check_positive_int("size", size, maximum=MAX_SIZE, example=3)
        self.max_speed = _limits("max_speed", max_speed, self.size, "units/s")
        self.max_acceleration = _limits("max_acceleration", max_acceleration, self.size, "units/s²")
        self.dt = check_positive("dt", dt, unit="s")
        self.mode: RateMode = check_choice("mode", mode, ("output", "literal"))
        self._step = self.max_acceleration * self.dt  # <= 1e300: both factors are <= 1e150
        self._prev = np.zeros(self.size)

    def __repr__(self) -> str:
        return (
            f"RateLimiter(size={self.size}, max_speed={self.max_speed.tolist()}, "
            f"max_acceleration={self.max_acceleration.tolist()}, dt={self.dt:g}, "
            f"mode={self.mode!r})"
        )

    @property
    def state(self) -> FloatArray:
        """The remembered previous value (output, or command in literal mode), shape (n,)."""
        s = self._prev.copy()
        s.setflags(write=False)
        return s

    def reset(self, value: ArrayLike | None = None) -> None:
        """Forget the history; start from ``value`` (default zero), shape (n,)."""
        if value is None:
            self._prev = np.zeros(self.size)
            return
        self._prev = real_array("value", value, (self.size,), what="a velocity to start from")

    def _command(self, command: ArrayLike) -> FloatArray:
        if (
            type(command) is np.ndarray
            and command.dtype.char == "d"
            and command.shape == (self.size,)
            and np.isfinite(command).all()
        ):
            return command
        return real_array("command", command, (self.size,), what="a velocity [units/s]")

    def bounds(self) -> tuple[FloatArray, FloatArray]:
        """The box the next output of :meth:`step` lies in, per component ``(low, high)``.

        ``state ± max_acceleration·dt``, intersected with ``±max_speed`` where that leaves a
        non-empty range (after an override the state may lie beyond ``max_speed``; the box then
        keeps the reachable end). Used by :class:`~velfence.shaping.stops.StopLimiter` to stay
        inside it when a stop bound must hold.
        """
        p, s, v = self._prev, self._step, self.max_speed
        lo = np.minimum(np.maximum(p - s, -v), p + s)
        hi = np.maximum(np.minimum(p + s, v), p - s)
        return lo, hi

    def hold(self, value: ArrayLike) -> None:
        """Remember ``value`` as the last output (output mode; literal mode keeps commands).

        A stage that replaced the rate limiter's output (the stop limiter's position-first
        override) calls this so that the next step is rate-limited from what was really sent.

        Args:
            value: The velocity really sent, shape (n,) [units/s], finite.

        Raises:
            InvalidInput: not a finite real vector of shape (n,).
        """
        if (
            type(value) is np.ndarray
            and value.dtype.char == "d"
            and value.shape == (self.size,)
            and np.isfinite(value).all()
        ):
            held = value.copy()
        else:
            held = real_array("value", value, (self.size,), what="a velocity [units/s]")
        if self.mode == "output":
            self._prev = held

    def step(self, command: ArrayLike) -> FloatArray:
        """Limit one command and advance the state.

        Args:
            command: Commanded velocity, shape (n,) [units/s], finite real numbers.

        Returns:
            The limited velocity, shape (n,).

        Raises:
            InvalidInput: wrong shape, non-real or non-finite values (naming ``command``).
        """
        c = self._command(command)
        v = np.clip(c, -self.max_speed, self.max_speed)
        step = self._step
        if self.mode == "output":
            out: FloatArray = self._prev + np.clip(v - self._prev, -step, step)
            self._prev = out
            return out.copy()
        # Literal: the increment is the difference of consecutive (clamped) *commands*, added to
        # the previous command, so a step passes after a single rate-limited sample.
        out = self._prev + np.clip(v - self._prev, -step, step)
        self._prev = v
        return np.asarray(out, dtype=float)


document_inits(globals())
