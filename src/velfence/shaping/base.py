"""The shaper contract shared by every shaper in velfence.

A shaper maps a commanded velocity to an admissible one given the current state::

    v_out = shaper.shape(state, v_cmd)

Every shaper implements :meth:`Shaper.shape` (one call, fast), :meth:`Shaper.explain` (same answer
plus diagnostics in a :class:`ShapingResult`) and :meth:`Shaper.shape_batch` (many states at once,
equal to looping :meth:`Shaper.shape`). Non-finite inputs never produce a non-finite output: by
default they raise :class:`~velfence.errors.InvalidInput`; with ``on_invalid="stop"`` the shaper
returns zero velocity and flags zone ``"invalid"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence.errors import InvalidInput, InvalidParameter

__all__ = [
    "OnInvalid",
    "Shaper",
    "ShapingResult",
    "as_pair",
    "as_rows",
    "check_choice",
    "check_positive",
]

FloatArray = NDArray[np.float64]
OnInvalid = Literal["raise", "stop"]


@dataclass(frozen=True)
class ShapingResult:
    """What a shaper did to one command, for logs, plots and tests.

    Attributes:
        output: Shaped velocity, shape (2,), same units as the command.
        command: The command as given, shape (2,).
        position: The position as given, shape (2,).
        zone: ``"free"``, ``"buffer"``, ``"corner"``, ``"outside"``, ``"outside-corner"`` or
            ``"invalid"``.
        primary: Index of the primary edge (patent: the wedge's edge; exact: the nearest edge).
        secondary: Index of the secondary edge (patent: the neighbour at the nearer corner;
            exact: the second-nearest edge).
        d1: Signed distance to the primary edge, positive inside, workspace units.
        d2: Signed distance to the secondary edge, positive inside, workspace units.
        spring: The virtual-spring velocity added outside (patent), shape (2,); zero for
            methods that express recovery as a bound instead.
        stages: Names of the stages applied, in order of the ``STAGE_NAMES`` table.
        method: Name of the law that produced the output.
    """

    output: FloatArray
    command: FloatArray
    position: FloatArray
    zone: str
    primary: int
    secondary: int
    d1: float
    d2: float
    spring: FloatArray
    stages: tuple[str, ...]
    method: str


@runtime_checkable
class Shaper(Protocol):
    """Anything that shapes commanded velocities (see module docstring for the contract)."""

    def shape(self, p: ArrayLike, v: ArrayLike) -> FloatArray:
        """Shaped velocity for position ``p`` and command ``v``."""
        ...

    def explain(self, p: ArrayLike, v: ArrayLike) -> ShapingResult:
        """Shaped velocity with diagnostics."""
        ...

    def shape_batch(self, P: ArrayLike, V: ArrayLike) -> FloatArray:
        """Shaped velocities for many states; equal to looping :meth:`shape`."""
        ...


def check_positive(name: str, value: Any, *, allow_zero: bool = False, unit: str = "") -> float:
    """Validate a finite positive (or non-negative) scalar parameter and return it as float."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InvalidParameter(
            f"{name} must be a number{unit and ' in ' + unit}, got {value!r}"
        ) from None
    ok = math.isfinite(x) and (x >= 0.0 if allow_zero else x > 0.0)
    if not ok:
        bound = ">= 0" if allow_zero else "> 0"
        raise InvalidParameter(
            f"{name} must be finite and {bound}{unit and ' (' + unit + ')'}, got {value!r}"
        )
    return x


def check_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    """Validate a string option against its allowed values."""
    if value not in choices:
        raise InvalidParameter(f"{name} must be one of {list(choices)}, got {value!r}")
    return str(value)


def as_pair(name: str, x: Any) -> tuple[float, float]:
    """Read a 2-vector as two floats, with a clear error for anything else (finite or not)."""
    if isinstance(x, np.ndarray) and x.shape != (2,):
        raise InvalidInput(f"{name} must have shape (2,), got shape {x.shape}")
    try:
        a, b = x
        return float(a), float(b)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} must be a 2-vector of numbers, got {x!r}") from None


def as_rows(name: str, X: ArrayLike, n_cols: int = 2) -> FloatArray:
    """Read an (N, n_cols) float array, with a clear error for anything else."""
    try:
        a = np.asarray(X, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} must be an (N, {n_cols}) array of numbers") from None
    if a.ndim != 2 or a.shape[1] != n_cols:
        raise InvalidInput(f"{name} must have shape (N, {n_cols}), got shape {a.shape}")
    return a
