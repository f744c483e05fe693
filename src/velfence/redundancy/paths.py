"""Desired end-effector lines for configuration control: ``t -> (Y_d(t), Ẏ_d(t))``.

A configuration controller tracks a desired end-effector position and velocity; this module
builds the straight line with a cosine (rest-to-rest) speed profile that the obstacle
reproductions and ``examples/obstacle_avoidance.py`` drive it along.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import check_flag, check_positive, finite_array
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter

__all__ = ["Line", "cosine_line"]

#: A desired end-effector line: time [s] -> (position [m], velocity [m/s]).
Line = Callable[[float], tuple[FloatArray, FloatArray]]


def cosine_line(
    y0: ArrayLike, direction: ArrayLike, length: float, period: float, *, back: bool
) -> Line:
    """A straight end-effector line with a cosine speed profile: ``t -> (Y_d(t), Ẏ_d(t))``.

    The line goes ``length`` along ``direction`` in ``period`` (zero speed at both ends) and,
    with ``back``, returns to ``y0`` in a second ``period``; it holds its end point afterwards
    (and its start point before ``t = 0``).

    Args:
        y0: Start point [m] (2-D or 3-D).
        direction: Direction of travel (any non-zero length; normalised), the size of ``y0``.
        length: Distance travelled along ``direction`` [m], positive.
        period: Time of one way [s], positive.
        back: Whether the line returns to ``y0`` in a second ``period``.

    Returns:
        The line as a function of time ``t`` [s] returning new arrays ``(Y_d, Ẏ_d)``.

    Raises:
        InvalidInput: ``y0`` not a finite 2-D or 3-D point, ``direction`` not a finite vector of
            its size.
        InvalidGeometry: ``direction`` of zero length.
        InvalidParameter: ``length`` or ``period`` not positive, ``back`` not a bool.
    """
    start = finite_array("y0", y0, (None,))
    if start.size not in (2, 3):
        raise InvalidInput(f"y0: expected a 2-D or 3-D point, got {start.size} numbers")
    e = finite_array("direction", direction, (None,))
    if e.size != start.size:
        raise InvalidInput(
            f"y0, direction: expected vectors of one size, got {start.size} and {e.size} numbers"
        )
    norm = float(np.linalg.norm(e))
    if not norm > 0.0 or not math.isfinite(norm):
        raise InvalidGeometry(f"direction: expected a non-zero vector, got {e.tolist()}")
    e = e / norm
    length = check_positive("length", length, unit="m", error=InvalidParameter)
    period = check_positive("period", period, unit="s", error=InvalidParameter)
    back = check_flag("back", back, error=InvalidParameter)
    end = 2.0 * period if back else period

    def line(t: float) -> tuple[FloatArray, FloatArray]:
        tt = min(max(float(t), 0.0), end)
        s = 0.5 * length * (1.0 - math.cos(math.pi * tt / period))
        inside = 0.0 < float(t) < end
        ds = 0.5 * length * math.pi / period * math.sin(math.pi * tt / period) if inside else 0.0
        return start + s * e, ds * e

    return line
