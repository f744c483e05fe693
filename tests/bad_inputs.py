"""Bad inputs shared by the per-module validation tests (the full catalogue is tests/hostile)."""

from __future__ import annotations

import datetime
from typing import Any

import numpy as np

#: Values that are not a vector of real numbers, each refused by the validation layer.
BAD_VECTORS: dict[str, Any] = {
    "str": "12",
    "bytes": b"12",
    "dict": {"x": 1.0},
    "None": None,
    "bool": True,
    "complex": np.array([1j, 2j]),
    "object": np.array([object(), object()], dtype=object),
    "datetime": datetime.datetime(2020, 1, 1),
    "ragged": [[1.0, 2.0], [3.0]],
    "huge-int": [10**400, 0],
}


class HugeLen:
    """A sequence that claims 10**12 entries (NumPy would try to allocate them) and has three."""

    def __len__(self) -> int:
        return 10**12

    def __getitem__(self, i: int) -> float:
        if i < 3:
            return 0.0
        raise IndexError(i)


class LyingLen:
    """A sequence whose ``__len__`` says 3 but whose items run out after one."""

    def __len__(self) -> int:
        return 3

    def __getitem__(self, i: int) -> float:
        if i == 0:
            return 1.0
        raise IndexError(i)


class RaisingArray:
    """An array-like whose conversion raises its own exception."""

    def __array__(self, *args: Any, **kwargs: Any) -> Any:
        raise ZeroDivisionError("hostile __array__")
