"""The cobot's array checks: :func:`velfence._validate.real_array` with a fast accept path.

A cobot tick validates a dozen small vectors and matrices (every public input, and the outputs of
a user's kinematics). :func:`real_array` accepts a float64 ndarray of the right shape whose
entries are finite and at most :data:`~velfence._validate.MAX_MAGNITUDE` in magnitude by
returning a copy; this module answers exactly that case with one reduction and hands every other
input (lists, other dtypes, subclasses, wrong shapes, NaN/inf, huge entries, empty arrays) to
:func:`real_array` itself, so what is accepted, what is returned and every refusal and its message
are unchanged.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import MAX_MAGNITUDE
from velfence._validate import real_array as _real_array

__all__ = ["real_array"]


def real_array(
    name: str,
    x: Any,
    shape: tuple[int | None, ...] | None = None,
    *,
    error: type[Exception] | None = None,
    what: str = "numbers",
) -> FloatArray:
    """:func:`velfence._validate.real_array` (finite, magnitude-capped) with a fast accept path.

    Args:
        name: The public argument's name, for messages.
        x: Array-like input.
        shape: Required shape (``None`` entries match any length; ``None``: any shape).
        error: The exception class to raise (``InvalidInput`` by default).
        what: What the values are, for messages.

    Returns:
        A new float64 array.
    """
    if (
        type(x) is np.ndarray
        and x.dtype == np.float64
        and x.size
        and (
            shape is None
            or (
                x.ndim == len(shape)
                and all(s is None or s == k for s, k in zip(shape, x.shape, strict=True))
            )
        )
        and np.abs(x).max() <= MAX_MAGNITUDE  # False for NaN and inf
    ):
        return x.copy()
    return _real_array(name, x, shape, error=error, what=what)
