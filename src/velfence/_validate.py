"""The one validation layer: every public input of velfence passes through these functions.

It sits below geometry (only :mod:`velfence.errors` is imported) so that every layer can use it.
Rules, the same everywhere:

* **Real numbers only.** Booleans, complex numbers, strings, bytes, dicts, sets, ``None``,
  datetimes and object arrays are refused, even where NumPy would convert them (``"12"`` is not
  the position (1, 2); ``True`` is not a speed of 1; ``"0.2"`` is not a buffer width).
* **Shapes checked**, with the expected and the received shape in the message.
* **Finite checked** (NaN and inf refused unless a caller asks for them explicitly, as the
  shapers' ``on_invalid`` policy does).
* **Magnitudes that would overflow refused**: no input may exceed :data:`MAX_MAGNITUDE` in absolute
  value, so squares and products of two inputs stay finite.
* **Step and iteration counts bounded** before any allocation or loop (:func:`step_count`,
  :func:`check_positive_int` with ``maximum``).

Every refusal is a :class:`~velfence.errors.VelfenceError` subclass whose message names the
*public* argument, what was expected and what was got.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Mapping, Set
from pathlib import Path
from typing import Any, TypeGuard, TypeVar

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "MAX_MAGNITUDE",
    "MAX_SEQUENCE_LENGTH",
    "MAX_STEPS",
    "as_pair",
    "as_rows",
    "check_choice",
    "check_flag",
    "check_names",
    "check_positive",
    "check_positive_int",
    "check_range",
    "check_seed",
    "describe",
    "finite_array",
    "finite_rows",
    "finite_scalar",
    "is_finite_vector",
    "readonly",
    "real_array",
    "real_floats",
    "rigid_transform",
    "show",
    "step_count",
]

#: Largest accepted magnitude of any numeric input (positions, commands, gains, lengths). Far
#: beyond any physical quantity in SI units, and small enough that the product of two inputs
#: (1e300) is still a finite double.
MAX_MAGNITUDE = 1e150

#: Default cap on the number of steps a simulator or iterative routine may be asked to run
#: (10⁸ steps of 1 ms is more than a day of simulated time).
MAX_STEPS = 100_000_000

#: Longest Python sequence (list, tuple, ...) converted to an array; longer inputs must be passed
#: as ndarrays (a sequence that claims 10¹² entries must not trigger the allocation).
MAX_SEQUENCE_LENGTH = 10_000_000

A = TypeVar("A", bound=np.ndarray[Any, Any])

_REAL_KINDS = frozenset("iuf")
_NOT_NUMBERS = (str, bytes, bytearray, memoryview, Mapping, Set)


def _error(error: type[Exception] | None) -> type[Exception]:
    from velfence.errors import InvalidInput

    return error or InvalidInput


def show(x: Any, limit: int = 80) -> str:
    """``repr(x)``, cut to ``limit`` characters (huge inputs must not make huge messages).

    The one way velfence quotes a received value in an error message, in every package.

    Args:
        x: The value (any object; a ``__repr__`` that raises gives ``<TypeName>``).
        limit: Longest text returned [characters]; a longer ``repr`` ends in ``...``.

    Returns:
        The (possibly cut) ``repr``; NumPy scalars (also inside a tuple or list) print as plain
        numbers, ``-0.4`` rather than ``np.float64(-0.4)``.
    """
    try:
        text = repr(_plain(x))
    except Exception:  # a hostile __repr__ must not escape as its own exception
        text = f"<{type(x).__name__}>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _plain(x: Any, depth: int = 0) -> Any:
    """``x`` with NumPy scalars as Python numbers (in tuples and lists up to 3 levels deep)."""
    if isinstance(x, np.generic):
        return x.item()
    if type(x) in (tuple, list) and depth < 3 and len(x) <= 100:
        return type(x)(_plain(e, depth + 1) for e in x)
    return x


def _type_text(x: Any) -> str:
    if isinstance(x, np.ndarray):
        return f"an array of dtype {x.dtype}"
    return f"{type(x).__name__} {show(x)}"


def _shape_text(shape: tuple[int | None, ...]) -> str:
    parts = ["N" if s is None else str(s) for s in shape]
    return "(" + ", ".join(parts) + ("," if len(parts) == 1 else "") + ")"


def readonly(a: A) -> A:
    """Mark ``a`` read-only in place and return it (immutable, explicit state)."""
    a.setflags(write=False)
    return a


#: Arrays up to this many entries are checked in Python floats (one ``tolist``): cheaper than a
#: NumPy reduction for the 2- and 3-vectors of a control loop.
_SMALL = 16


def _fast_accept(
    x: Any, shape: tuple[int | None, ...] | None, allow_nonfinite: bool, max_abs: float | None
) -> bool:
    """Whether ``x`` passes :func:`real_array`'s checks without the full route.

    The common case in a control loop: a non-empty float64 ndarray of the right shape whose
    entries are all finite and within ``max_abs`` (the comparison is False for NaN and inf).
    False means "take the full checks", never "refuse".
    """
    if not (type(x) is np.ndarray and x.dtype == np.float64 and x.size):
        return False
    if not (
        shape is None
        or x.shape == shape
        or (
            x.ndim == len(shape)
            and all(s is None or s == k for s, k in zip(shape, x.shape, strict=True))
        )
    ):
        return False
    if max_abs is None:
        # allow_nonfinite without a magnitude cap accepts every float64 value (NaN and inf go
        # to the caller's policy): nothing to reduce.
        return allow_nonfinite or bool(np.isfinite(x).all())
    if x.size <= _SMALL:
        vals = x.tolist() if x.ndim == 1 else x.ravel().tolist()
        return all(map(float(max_abs).__ge__, map(abs, vals)))
    return bool(np.abs(x).max() <= max_abs)


def is_finite_vector(x: Any, n: int) -> TypeGuard[NDArray[np.float64]]:
    """Whether ``x`` is already a finite float64 vector of shape (n,), entries <= MAX_MAGNITUDE.

    What :func:`real_array` with shape ``(n,)`` accepts as it is: for callers that take a
    cheap route for such a vector (a copy) and the full checks, with their messages,
    otherwise. False never means "refuse".
    """
    return _fast_accept(x, (n,), False, MAX_MAGNITUDE)


def real_floats(
    name: str,
    x: Any,
    n: int,
    *,
    error: type[Exception] | None = None,
    what: str = "numbers",
) -> list[float]:
    """``x`` as a list of ``n`` floats: :func:`real_array` with shape ``(n,)``, as Python floats.

    The same acceptance, refusals and messages as ``real_array(name, x, (n,))`` (for the
    callers that compute with 2- and 3-vectors in plain float arithmetic).
    """
    vals: list[float] = (
        x
        if _fast_accept(x, (n,), False, MAX_MAGNITUDE)
        else real_array(name, x, (n,), error=error, what=what)
    ).tolist()
    return vals


def real_array(
    name: str,
    x: Any,
    shape: tuple[int | None, ...] | None = None,
    *,
    error: type[Exception] | None = None,
    what: str = "numbers",
    allow_nonfinite: bool = False,
    max_abs: float | None = MAX_MAGNITUDE,
    copy: bool = True,
) -> NDArray[np.float64]:
    """``x`` as a new float64 array of real numbers, validated.

    Args:
        name: The public argument's name, for messages.
        x: Array-like input (a number, a sequence of numbers, nested sequences, an ndarray).
        shape: Required shape; ``None`` entries match any length, ``None`` as a whole any shape.
        error: The exception class to raise (a :class:`~velfence.errors.VelfenceError`
            subclass); :class:`~velfence.errors.InvalidInput` by default.
        what: What the values are, for messages ("joint angles [rad]").
        allow_nonfinite: Let NaN and inf through (for callers that apply their own
            ``on_invalid`` policy); magnitudes of finite entries are still checked.
        max_abs: Largest accepted magnitude of a finite entry (``None``: no limit).
        copy: ``False`` for callers that only read the result: a float64 ndarray that passes
            as it is is returned itself rather than copied (large batches).

    Returns:
        A float64 ndarray (a copy unless ``copy=False``; the caller may then modify it).

    Raises:
        InvalidInput: (or ``error``) not real numbers, wrong shape, non-finite or too large
            entries; the message names ``name``, what was expected and what was got.
    """
    if _fast_accept(x, shape, allow_nonfinite, max_abs):
        fast: NDArray[np.float64] = x.copy() if copy else x
        return fast
    err = _error(error)
    want = "" if shape is None else f" of shape {_shape_text(shape)}"
    if isinstance(x, _NOT_NUMBERS) or x is None or isinstance(x, (bool, np.bool_)):
        raise err(f"{name}: expected {what}{want}, got {_type_text(x)}")
    if isinstance(x, np.ma.MaskedArray) and np.ma.getmaskarray(x).any():
        # NumPy would hand over the masked entries' stale data as if they were values.
        raise err(f"{name}: expected {what}{want}, got a masked array with masked entries")
    if not isinstance(x, (np.ndarray, list, tuple, range, numbers.Real, np.generic)) and not (
        hasattr(x, "__array__") or hasattr(x, "__array_interface__")
    ):
        # Other containers (custom sequences, deques, iterators) are refused rather than read
        # item by item: their length may lie and NumPy would trust it.
        raise err(
            f"{name}: expected {what}{want} as a number, list, tuple or array, got {_type_text(x)}"
        )
    if not isinstance(x, np.ndarray) and hasattr(x, "__len__"):
        # A sequence claiming billions of entries would make NumPy try the allocation first.
        try:
            n = len(x)
        except Exception:  # a hostile __len__ is refused, not propagated
            raise err(f"{name}: expected {what}{want}, got {show(x)}") from None
        if n > MAX_SEQUENCE_LENGTH:
            raise err(
                f"{name}: expected {what}{want} with at most {MAX_SEQUENCE_LENGTH} entries, got "
                f"a {type(x).__name__} of length {n}; pass an ndarray"
            )
    try:
        raw = np.asarray(x)
    except Exception:  # whatever a hostile __array__/__getitem__/__float__ raises is refused
        raise err(f"{name}: expected {what}{want}, got {show(x)}") from None
    if isinstance(x, (list, tuple)) and raw.dtype.kind in _REAL_KINDS and _has_bool(x):
        raise err(f"{name}: expected {what}{want}, got booleans among the numbers: {show(x)}")
    if raw.dtype.kind not in _REAL_KINDS:
        if raw.dtype.kind == "O" and raw.size and _all_real(raw):
            try:
                raw = raw.astype(float)
            except OverflowError:  # Python ints beyond the float range (10**400)
                raise err(f"{name}: expected {what} of magnitude <= {MAX_MAGNITUDE:g}") from None
        else:
            kind = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "bytes"}.get(
                raw.dtype.kind, f"values of dtype {raw.dtype}"
            )
            raise err(f"{name}: expected {what}{want}, got {kind}: {show(x)}")
    if shape is not None and (
        raw.ndim != len(shape)
        or any(s is not None and s != n for s, n in zip(shape, raw.shape, strict=True))
    ):
        raise err(f"{name}: expected shape {_shape_text(shape)}, got shape {raw.shape}")
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            a = np.array(raw, dtype=np.float64)
    except OverflowError:
        raise err(f"{name}: expected {what} of magnitude <= {MAX_MAGNITUDE:g}") from None
    finite = np.isfinite(a)
    # A long double beyond the float64 range became inf in the cast: too large, not NaN/inf.
    if raw.dtype.kind == "f" and raw.dtype.itemsize > 8 and not finite.all():  # noqa: SIM102
        if np.isfinite(raw[~finite]).any():
            raise err(f"{name}: expected {what} of magnitude <= {MAX_MAGNITUDE:g}, got {show(x)}")
    if not allow_nonfinite and not finite.all():
        got = show(a.tolist(), 200)
        raise err(f"{name}: expected finite values, got {got}; filter NaN/inf before calling")
    if max_abs is not None and a.size:
        with np.errstate(invalid="ignore"):
            big = np.abs(np.where(finite, a, 0.0)) > max_abs
        if big.any():
            raise err(
                f"{name}: expected {what} of magnitude <= {max_abs:g}, got "
                f"{a[big].ravel()[:4].tolist()}"
            )
    return a


def _has_bool(x: list[Any] | tuple[Any, ...]) -> bool:
    """Whether a nested list/tuple holds a boolean (NumPy would read ``True`` as 1)."""
    stack: list[Any] = [x]
    while stack:
        for e in stack.pop():
            if isinstance(e, (bool, np.bool_)):
                return True
            if isinstance(e, (list, tuple)):
                stack.append(e)
    return False


def _all_real(a: np.ndarray[Any, Any]) -> bool:
    return all(
        isinstance(e, numbers.Real) and not isinstance(e, (bool, np.bool_)) for e in a.ravel()
    )


def finite_array(
    name: str,
    x: Any,
    shape: tuple[int | None, ...] | None = None,
    *,
    error: type[Exception] | None = None,
    what: str = "numbers",
) -> NDArray[np.float64]:
    """``x`` as a new finite float64 array of real numbers (:func:`real_array`, finite)."""
    return real_array(name, x, shape, error=error, what=what)


def finite_scalar(
    name: str,
    x: Any,
    *,
    unit: str = "",
    what: str = "number",
    error: type[Exception] | None = None,
    max_abs: float | None = MAX_MAGNITUDE,
) -> float:
    """``x`` as a finite real float, or a clear error.

    Args:
        name: The public argument's name, for messages.
        x: The value: an int, a float, a NumPy real scalar or a 0-d real array.
        unit: Unit shown in messages, e.g. ``"m"`` or ``"rad"``.
        what: What the value is, for messages (``"arc length"``, ``"steering angle"``).
        error: Exception class (default :class:`~velfence.errors.InvalidInput`).
        max_abs: Largest accepted magnitude (``None``: no limit).

    Raises:
        InvalidInput: (or ``error``) not a real number (booleans, strings, complex refused), not
            finite, or too large.
    """
    if type(x) is float and (math.isfinite(x) if max_abs is None else abs(x) <= max_abs):
        return x  # the common case: a finite float in range (False for NaN and inf)
    err = _error(error)
    u = f" [{unit}]" if unit else ""
    v = _real_float(x)
    if v is None:
        article = "an" if what[:1] in "aeiou" else "a"
        raise err(f"{name}: expected {article} {what}{u}, got {_type_text(x)}")
    if not math.isfinite(v):
        raise err(f"{name}: expected a finite {what}{u}, got {v}")
    if max_abs is not None and abs(v) > max_abs:
        raise err(f"{name}: expected a {what}{u} of magnitude <= {max_abs:g}, got {v:g}")
    return v


def _real_float(x: Any) -> float | None:
    """``float(x)`` for a real number, ``None`` for anything else (bool, str, complex, ...)."""
    if isinstance(x, (bool, np.bool_, np.timedelta64, np.datetime64)):
        return None  # NumPy counts time deltas as integers; they are durations, not numbers
    if isinstance(x, np.ndarray):
        if x.shape != () or x.dtype.kind not in _REAL_KINDS:
            return None
        x = x.item()
    if not isinstance(x, numbers.Real):
        return None
    try:
        return float(x)
    except (OverflowError, ValueError, TypeError):
        return math.inf if isinstance(x, numbers.Integral) else None


def check_range(
    name: str,
    value: Any,
    *,
    low: float = -math.inf,
    high: float = math.inf,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
    error: type[Exception] | None = None,
) -> float:
    """A finite real scalar in ``[low, high]`` (or open ends), as float.

    Raises:
        InvalidParameter: (or ``error``) not a real number or outside the range.
    """
    from velfence.errors import InvalidParameter

    err = error or InvalidParameter
    x = finite_scalar(name, value, unit=unit, error=err)
    lo_ok = x > low if low_open else x >= low
    hi_ok = x < high if high_open else x <= high
    if not (lo_ok and hi_ok):
        lb = "(" if low_open else "["
        hb = ")" if high_open else "]"
        u = f" {unit}" if unit else ""
        raise err(f"{name}: expected a value in {lb}{low:g}, {high:g}{hb}{u}, got {x:g}")
    return x


def check_positive(
    name: str,
    value: Any,
    *,
    allow_zero: bool = False,
    unit: str = "",
    error: type[Exception] | None = None,
) -> float:
    """A finite positive (or non-negative) real scalar parameter, as float.

    Raises:
        InvalidParameter: (or ``error``) not a real number (booleans and strings refused), not
            finite, too large (see :data:`MAX_MAGNITUDE`), or not > 0 (>= 0 with ``allow_zero``).
    """
    from velfence.errors import InvalidParameter

    err = error or InvalidParameter
    x = _real_float(value)
    u = f" in {unit}" if unit else ""
    if x is None:
        raise err(f"{name} must be a number{u}, got {_type_text(value)}")
    ok = math.isfinite(x) and (x >= 0.0 if allow_zero else x > 0.0)
    if not ok:
        bound = ">= 0" if allow_zero else "> 0"
        raise err(
            f"{name} must be finite and {bound}{unit and ' (' + unit + ')'}, got {show(value)}"
        )
    if x > MAX_MAGNITUDE:
        raise err(f"{name} must be <= {MAX_MAGNITUDE:g}{unit and ' ' + unit}, got {x:g}")
    return x


def check_positive_int(
    name: str,
    value: Any,
    *,
    example: int = 1,
    minimum: int = 1,
    maximum: int | None = None,
    error: type[Exception] | None = None,
) -> int:
    """An int parameter in ``[minimum, maximum]`` (booleans and floats refused).

    Raises:
        InvalidParameter: (or ``error``) not an int, or out of range.
    """
    from velfence.errors import InvalidParameter

    err = error or InvalidParameter
    if isinstance(value, np.ndarray) and value.shape == () and value.dtype.kind in "iu":
        value = value[()]  # a 0-d integer array is a scalar, as everywhere in this layer
    # np.timedelta64 subclasses np.signedinteger but is a duration, not a count.
    if isinstance(value, (bool, np.bool_, np.timedelta64)) or not isinstance(
        value, (int, np.integer)
    ):
        want = "a positive int" if minimum == 1 else f"an int >= {minimum}"
        raise err(f"{name}: expected {want}, got {_type_text(value)}; e.g. {example}")
    if value < minimum:
        raise err(f"{name}: expected an int >= {minimum}, got {show(value)}")
    if maximum is not None and value > maximum:
        raise err(f"{name}: expected an int <= {maximum:,}, got {show(value)}")
    return int(value)


def step_count(
    duration_name: str,
    duration: Any,
    dt_name: str,
    dt: Any,
    *,
    max_steps: int = MAX_STEPS,
    error: type[Exception] | None = None,
) -> int:
    """The number of steps ``ceil(duration / dt)``, validated before anything is allocated.

    Args:
        duration_name: Public name of the duration argument.
        duration: Length of the run [s], finite and > 0.
        dt_name: Public name of the step argument.
        dt: Step [s], finite and > 0.
        max_steps: Largest accepted number of steps.
        error: Exception class (default :class:`~velfence.errors.InvalidParameter`).

    Returns:
        The number of steps, ``>= 1``.

    Raises:
        InvalidParameter: (or ``error``) non-numbers, non-positive values, or a step count above
            ``max_steps`` (message gives both values and the count they imply).
    """
    from velfence.errors import InvalidParameter

    err = error or InvalidParameter
    T = check_positive(duration_name, duration, unit="s", error=err)
    h = check_positive(dt_name, dt, unit="s", error=err)
    ratio = T / h  # finite or inf, never an exception for positive floats
    if not ratio <= max_steps:
        raise err(
            f"{duration_name}={T:g} s with {dt_name}={h:g} s needs {ratio:.3g} steps; at most "
            f"{max_steps:,} are allowed: shorten {duration_name} or increase {dt_name}"
        )
    return max(1, math.ceil(ratio - 1e-9))


_Choice = TypeVar("_Choice", bound=str)


def check_choice(name: str, value: Any, choices: tuple[_Choice, ...]) -> _Choice:
    """A string option among ``choices`` (typed as the choices' ``Literal``, when they have one).

    Raises:
        InvalidParameter: anything else (the allowed values are listed).
    """
    from velfence.errors import InvalidParameter

    if not isinstance(value, str) or value not in choices:
        raise InvalidParameter(f"{name} must be one of {list(choices)}, got {show(value)}")
    return value


def as_pair(name: str, x: Any) -> tuple[float, float]:
    """A 2-vector of real numbers as two floats.

    Non-finite and huge entries pass: the shapers' ``on_invalid`` policy decides about them.

    Raises:
        InvalidInput: not a 2-vector of real numbers (strings, bytes, dicts, booleans, complex
            refused).
    """
    from velfence.errors import InvalidInput

    if isinstance(x, np.ndarray):
        if x.shape != (2,):
            raise InvalidInput(f"{name} must have shape (2,), got shape {x.shape}")
        if x.dtype.kind not in _REAL_KINDS:
            raise InvalidInput(f"{name} must be a 2-vector of real numbers, got {_type_text(x)}")
        a, b = x.tolist()
    elif isinstance(x, (list, tuple)) and len(x) == 2:
        a, b = x
    else:
        raise InvalidInput(f"{name} must be a 2-vector of real numbers, got {_type_text(x)}")
    fa, fb = _real_float(a), _real_float(b)
    if fa is None or fb is None:
        raise InvalidInput(f"{name} must be a 2-vector of real numbers, got {show(x)}")
    return fa, fb


def finite_rows(name: str, x: Any, width: int, what: str = "") -> tuple[NDArray[np.float64], bool]:
    """``x`` as finite float rows (N, width) and whether it was a single (width,) vector.

    Args:
        name: The public argument's name, for messages.
        x: One vector of shape (width,) or rows of shape (N, width).
        width: Row length.
        what: What a row is, for messages (e.g. "as (pitch, yaw) pairs").

    Raises:
        InvalidInput: not real numbers, wrong shape, or non-finite entries (rows named).
    """
    from velfence.errors import InvalidInput

    a = real_array(
        name, x, allow_nonfinite=True, what=f"numbers of shape ({width},) or (N, {width})"
    )
    if a.ndim == 1 and a.shape[0] == width:
        single = True
        a = a[None, :]
    elif a.ndim == 2 and a.shape[1] == width:
        single = False
    else:
        sep = " " if what else ""
        raise InvalidInput(
            f"{name}: expected shape ({width},) or (N, {width}){sep}{what}, got shape {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        bad = np.flatnonzero(~np.all(np.isfinite(a), axis=1))
        raise InvalidInput(
            f"{name}: expected finite values, got non-finite entries in row(s) "
            f"{bad[:10].tolist()}; filter NaN/inf before calling"
        )
    return a, single


def as_rows(name: str, X: Any, n_cols: int = 2, *, copy: bool = True) -> NDArray[np.float64]:
    """An (N, n_cols) float array of real numbers; non-finite and huge entries pass.

    The shapers' ``on_invalid`` policy decides about non-finite and huge entries. ``copy=False``:
    a float64 ndarray input is returned itself (for callers that only read it).

    Raises:
        InvalidInput: not real numbers or wrong shape.
    """
    from velfence.errors import InvalidInput

    a = real_array(
        name, X, allow_nonfinite=True, max_abs=None, what=f"numbers of shape (N, {n_cols})",
        copy=copy,
    )  # fmt: skip
    if a.ndim != 2 or a.shape[1] != n_cols:
        raise InvalidInput(f"{name} must have shape (N, {n_cols}), got shape {a.shape}")
    return a


def rigid_transform(name: str, T: Any, *, tol: float = 1e-6) -> NDArray[np.float64]:
    """``T`` as a validated 4 x 4 rigid transform (float copy).

    The rotation block must be orthonormal with determinant +1 to ``tol`` and the bottom row
    ``[0, 0, 0, 1]`` to 1e-9 (poses read from logs with 6-7 significant digits pass).

    Raises:
        InvalidInput: Not real numbers, not (4, 4), non-finite, or not rigid.
    """
    from velfence.errors import InvalidInput

    a = real_array(name, T, (4, 4), what="a 4 x 4 homogeneous transform")
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


def check_flag(name: str, value: Any, *, error: type[Exception] | None = None) -> bool:
    """A boolean option, as ``bool``: ``True``/``False`` (or NumPy booleans, 0-d included) only.

    ``bool(x)`` would turn ``"no"``, ``"False"``, ``2`` and ``[]`` into flags silently.

    Raises:
        InvalidParameter: (or ``error``) anything else.
    """
    from velfence.errors import InvalidParameter

    if isinstance(value, np.ndarray) and value.shape == () and value.dtype.kind == "b":
        value = value[()]  # a 0-d boolean array is a scalar, as everywhere in this layer
    if not isinstance(value, (bool, np.bool_)):
        raise (error or InvalidParameter)(
            f"{name}: expected True or False, got {_type_text(value)}"
        )
    return bool(value)


def describe(x: Any) -> str:
    """A short, safe description of ``x`` for messages (type and cut ``repr``; never raises)."""
    return _type_text(x)


#: Largest accepted integer seed (NumPy seeds any int, but a seed of 10⁴⁰⁰ is a mistake).
MAX_SEED = 2**63 - 1


def check_text(
    name: str, value: Any, *, max_length: int = 1000, error: type[Exception] | None = None
) -> str:
    """A label (a name, a title) as ``str``: ``str`` or ``np.str_`` of at most ``max_length``.

    Raises:
        InvalidParameter: (or ``error``) not a string, or longer than ``max_length``.
    """
    from velfence.errors import InvalidParameter

    if not isinstance(value, str):
        raise (error or InvalidParameter)(f"{name}: expected a string, got {_type_text(value)}")
    if len(value) > max_length:
        raise (error or InvalidParameter)(
            f"{name}: expected at most {max_length} characters, got {len(value):,}"
        )
    return str(value)


def check_names(
    name: str,
    value: Any,
    *,
    count: int | None = None,
    max_length: int = 200,
    error: type[Exception] | None = None,
) -> tuple[str, ...]:
    """A list or tuple of distinct non-empty names (joints, points), as a tuple of ``str``.

    A single string is refused (``tuple("ab")`` would be the names ``"a"`` and ``"b"``), and so
    is any other container (sets have no order; an iterator's length is unknown).

    Args:
        name: The public argument's name, for messages.
        value: The names.
        count: Required number of names (``None``: at least one).
        max_length: Longest accepted name [characters].
        error: Exception class (default :class:`~velfence.errors.InvalidParameter`).

    Raises:
        InvalidParameter: (or ``error``) not a list or tuple of strings, an empty or repeated
            name, or not ``count`` of them.
    """
    from velfence.errors import InvalidParameter

    err = error or InvalidParameter
    want = "names" if count is None else f"{count} names"
    if not isinstance(value, (list, tuple)):
        raise err(f"{name}: expected a list or tuple of {want}, got {_type_text(value)}")
    if len(value) > 100_000:
        raise err(f"{name}: expected at most 100,000 names, got {len(value):,}")
    names = tuple(check_text(f"{name}[{i}]", v, max_length=max_length, error=err)
                  for i, v in enumerate(value))  # fmt: skip
    n = len(names) if count is None else count
    if len(names) != n or n < 1 or len(set(names)) != n or not all(names):
        raise err(f"{name}: expected {want} (distinct, non-empty), got {show(list(names))}")
    return names


def check_seed(
    name: str, seed: Any, *, allow_generator: bool = False, error: type[Exception] | None = None
) -> Any:
    """An int seed in ``[0, MAX_SEED]`` (or, with ``allow_generator``, a NumPy ``Generator``).

    Raises:
        InvalidParameter: (or ``error``) anything else.
    """
    from velfence.errors import InvalidParameter

    if allow_generator and isinstance(seed, np.random.Generator):
        return seed
    if (
        isinstance(seed, (bool, np.bool_, np.timedelta64, np.datetime64))
        or not isinstance(seed, (int, np.integer))
        or not 0 <= seed <= MAX_SEED
    ):
        alt = " or a numpy.random.Generator" if allow_generator else ""
        raise (error or InvalidParameter)(
            f"{name}: expected an int in [0, 2**63 - 1]{alt}, got {_type_text(seed)}"
        )
    return int(seed)


#: Longest accepted output file path [characters].
MAX_PATH_LENGTH = 4096


def check_output_path(name: str, value: Any, *, error: type[Exception] | None = None) -> Path:
    """A file path to write, as :class:`~pathlib.Path`, whose directory exists.

    ``str`` or :class:`os.PathLike` (``bytes`` refused), non-empty, without NUL characters, at
    most :data:`MAX_PATH_LENGTH` characters, not a directory, in an existing directory: checked
    before any expensive work so that a typo costs nothing.

    Raises:
        InvalidParameter: (or ``error``) anything else; the message names ``name``.
    """
    from velfence.errors import InvalidParameter

    err = error or InvalidParameter
    if isinstance(value, (bytes, bytearray)) or not isinstance(value, (str, os.PathLike)):
        raise err(f"{name}: expected a file path (str or pathlib.Path), got {_type_text(value)}")
    try:
        text = os.fspath(value)
    except Exception:  # a hostile __fspath__ is refused, not propagated
        raise err(
            f"{name}: expected a file path (str or pathlib.Path), got {show(value)}"
        ) from None
    if not isinstance(text, str) or not text or "\x00" in text or len(text) > MAX_PATH_LENGTH:
        raise err(
            f"{name}: expected a non-empty file path of at most {MAX_PATH_LENGTH} characters "
            f"without NUL, got {show(text)}"
        )
    out = Path(text)
    if out.is_dir():
        raise err(f"{name}: expected a file path, got the directory {text!r}; add a file name")
    if not out.parent.is_dir():
        raise err(f"{name}: the directory {str(out.parent)!r} does not exist; create it first")
    return out


def require_package(name: str, package: str, *, extra: str, what: str) -> Any:
    """Import an optional dependency that the public argument ``name`` needs when it is used.

    The message is :func:`velfence._extras.message`'s, prefixed with ``name``.

    Args:
        name: The public argument whose use needs the package (named in the message).
        package: The module to import (e.g. ``"mujoco"``).
        extra: The velfence extra that installs it (e.g. ``"physics"``).
        what: What needs it, for the message (e.g. ``"a physics plant"``).

    Returns:
        The imported module.

    Raises:
        MissingExtra: the package is not installed (an ``ImportError`` and a ``VelfenceError``).
    """
    from velfence._extras import require
    from velfence.errors import MissingExtra

    try:
        return require(package, what=what, extra=extra)
    except MissingExtra as exc:
        raise MissingExtra(f"{name}: {exc}", name=exc.name) from exc.__cause__
