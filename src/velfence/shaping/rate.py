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
``docs/derivations.md`` §6.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._validate import check_choice, check_positive
from velfence.errors import InvalidInput, InvalidParameter

__all__ = ["RateLimiter"]

FloatArray = NDArray[np.float64]


def _limits(name: str, x: Any, n: int, unit: str) -> FloatArray:
    a = np.broadcast_to(np.asarray(x, dtype=float), (n,)).copy()
    if not (np.all(np.isfinite(a)) and np.all(a > 0.0)):
        raise InvalidParameter(f"{name} must be finite and > 0 ({unit}), got {x!r}")
    a.setflags(write=False)
    return a


class RateLimiter:
    """Clamp each component's velocity and its rate of change (stateful).

    Args:
        size: Number of components n (e.g. 3 joints).
        v_max: Speed limit per component [units/s], scalar or shape (n,).
        a_max: Acceleration limit per component [units/s²], scalar or shape (n,).
        dt: Sampling period Te [s].
        mode: ``"output"`` (default; rate-limit the previous output) or ``"literal"`` (the
            paper's printed Euler form on consecutive commands; kept to document why it fails).
    """

    def __init__(
        self,
        size: int,
        *,
        v_max: ArrayLike,
        a_max: ArrayLike,
        dt: float,
        mode: str = "output",
    ) -> None:
        if not (isinstance(size, int) and size >= 1):
            raise InvalidParameter(f"size must be a positive int, got {size!r}")
        self.size = size
        self.v_max = _limits("v_max", v_max, size, "units/s")
        self.a_max = _limits("a_max", a_max, size, "units/s²")
        self.dt = check_positive("dt", dt, unit="s")
        self.mode = check_choice("mode", mode, ("output", "literal"))
        self._prev = np.zeros(size)

    @property
    def state(self) -> FloatArray:
        """The remembered previous value (output, or command in literal mode), shape (n,)."""
        s = self._prev.copy()
        s.setflags(write=False)
        return s

    def reset(self, value: ArrayLike | None = None) -> None:
        """Forget the history; start from ``value`` (default zero), shape (n,)."""
        v = np.zeros(self.size) if value is None else np.asarray(value, dtype=float)
        if v.shape != (self.size,) or not np.all(np.isfinite(v)):
            raise InvalidInput(f"reset value must be finite with shape ({self.size},), got {v!r}")
        self._prev = v.copy()

    def step(self, command: ArrayLike) -> FloatArray:
        """Limit one command and advance the state.

        Args:
            command: Commanded velocity, shape (n,) [units/s], finite.

        Returns:
            The limited velocity, shape (n,).
        """
        c = np.asarray(command, dtype=float)
        if c.shape != (self.size,):
            raise InvalidInput(f"command must have shape ({self.size},), got shape {c.shape}")
        if not np.all(np.isfinite(c)):
            raise InvalidInput(f"command must be finite, got {c.tolist()}")
        v = np.clip(c, -self.v_max, self.v_max)
        step = self.a_max * self.dt
        if self.mode == "output":
            out: FloatArray = self._prev + np.clip(v - self._prev, -step, step)
            self._prev = out
            return out.copy()
        # Literal: the increment is the difference of consecutive (clamped) *commands*, added to
        # the previous command, so a step passes after a single rate-limited sample.
        out = self._prev + np.clip(v - self._prev, -step, step)
        self._prev = v
        return np.asarray(out, dtype=float)
