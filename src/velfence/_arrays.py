"""Array helpers shared by every layer (only velfence.errors is imported, lazily)."""

from __future__ import annotations

import math
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

__all__ = ["finite_array", "finite_scalar", "readonly", "rigid_transform"]

A = TypeVar("A", bound=np.ndarray[Any, Any])


def readonly(a: A) -> A:
    """Mark ``a`` read-only in place and return it (DESIGN: immutable, explicit state)."""
    a.setflags(write=False)
    return a


def finite_array(
    name: str,
    x: Any,
    shape: tuple[int, ...] | None = None,
    *,
    error: type[Exception] | None = None,
) -> NDArray[np.float64]:
    """``x`` as a new float array, validated: numbers, the given shape, all finite.

    Args:
        name: Argument name for messages.
        x: Array-like input.
        shape: Required shape, or ``None`` for any.
        error: The exception class to raise (a :class:`~velfence.errors.VelfenceError`
            subclass); :class:`~velfence.errors.InvalidInput` by default, e.g.
            ``InvalidGeometry`` for a constructor's geometry or ``InvalidParameter``.

    Returns:
        A float64 ndarray (a copy; the caller may modify it).

    Raises:
        InvalidInput: Not numbers, wrong shape, or non-finite entries (messages name ``name``,
            what was expected and what was got).
    """
    from velfence.errors import InvalidInput

    err = error or InvalidInput
    want = "" if shape is None else f" of shape {_shape_text(shape)}"
    try:
        a = np.array(x, dtype=float)
    except (TypeError, ValueError):
        raise err(f"{name}: expected numbers{want}, got {x!r}") from None
    if shape is not None and a.shape != shape:
        raise err(f"{name}: expected shape {_shape_text(shape)}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise err(
            f"{name}: expected finite values, got {a.tolist()}; filter NaN/inf before calling"
        )
    return np.asarray(a, dtype=np.float64)


def rigid_transform(name: str, T: Any, *, tol: float = 1e-6) -> NDArray[np.float64]:
    """``T`` as a validated 4 x 4 rigid transform (float copy).

    The rotation block must be orthonormal with determinant +1 to ``tol`` and the bottom row
    ``[0, 0, 0, 1]`` to 1e-9 (poses read from logs with 6-7 significant digits pass).

    Raises:
        InvalidInput: Not numbers, not (4, 4), non-finite, or not rigid.
    """
    from velfence.errors import InvalidInput

    try:
        np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name}: expected a 4 x 4 homogeneous transform, got {T!r}") from None
    a = finite_array(name, T, (4, 4))
    if float(np.max(np.abs(a[3] - (0.0, 0.0, 0.0, 1.0)))) > 1e-9:
        raise InvalidInput(
            f"{name}: expected a rigid transform with bottom row [0, 0, 0, 1], got {a[3].tolist()}"
        )
    R = a[:3, :3]
    err = float(np.max(np.abs(R.T @ R - np.eye(3))))
    det = float(np.linalg.det(R))
    if err > tol or abs(det - 1.0) > tol:
        raise InvalidInput(
            f"{name}: expected a rigid transform (orthonormal rotation, det +1, to {tol:g}), got "
            f"|RᵀR - I| = {err:.3g}, det = {det:.6g}; re-orthonormalise the rotation"
        )
    return a


def _shape_text(shape: tuple[int, ...]) -> str:
    return "(" + ", ".join(str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"


def finite_scalar(
    name: str,
    x: Any,
    *,
    unit: str = "",
    what: str = "number",
    error: type[Exception] | None = None,
) -> float:
    """``x`` as a finite float (booleans refused), or a clear error.

    Args:
        name: Argument name for messages.
        x: The value.
        unit: Unit shown in messages, e.g. ``"m"`` or ``"rad"``.
        what: What the value is, for messages (``"arc length"``, ``"steering angle"``).
        error: Exception class (default :class:`~velfence.errors.InvalidInput`).

    Raises:
        InvalidInput: Not a number, a boolean, or not finite.
    """
    from velfence.errors import InvalidInput

    err = error or InvalidInput
    u = f" [{unit}]" if unit else ""
    try:
        if isinstance(x, bool):
            raise TypeError
        v = float(x)
    except (TypeError, ValueError):
        article = "an" if what[:1] in "aeiou" else "a"
        raise err(f"{name}: expected {article} {what}{u}, got {x!r}") from None
    if not math.isfinite(v):
        raise err(f"{name}: expected a finite {what}{u}, got {v}")
    return v
