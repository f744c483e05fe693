"""Bad inputs shared by the per-module validation tests (the full catalogue is tests/hostile)."""

from __future__ import annotations

import contextlib
import datetime
import inspect
import math
import sys
import typing
from typing import Any, Literal

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


def bad_tuning_values(cls: type) -> list[tuple[str, Any]]:
    """``(parameter, value)`` pairs every keyword-only tuning parameter of ``cls`` must refuse.

    Derived from the constructor's annotations, each evaluated in the class's module (a name
    imported only for type checking stays a string): a ``Literal`` (or plain ``str``) choice gets an
    unknown option; a ``float`` gets NaN, infinity and a word. Booleans and other types get none.
    """
    namespace = dict(vars(sys.modules[cls.__module__]))
    out: list[tuple[str, Any]] = []
    for p in inspect.signature(cls.__init__).parameters.values():
        if p.kind is not inspect.Parameter.KEYWORD_ONLY:
            continue
        ann = p.annotation
        hint = ann
        if isinstance(ann, str):
            with contextlib.suppress(NameError):
                hint = eval(ann, namespace)
        text = str(ann)
        if typing.get_origin(hint) is Literal:
            out.append((p.name, "no-such-choice"))
        elif "bool" in text:
            continue
        elif "float" in text:
            out.extend((p.name, bad) for bad in (math.nan, math.inf, "fast"))
        elif "str" in text:
            out.append((p.name, "no-such-choice"))
    return out
