"""Array helpers shared by every layer (no velfence imports, so any module may use them)."""

from __future__ import annotations

from typing import Any, TypeVar

import numpy as np

__all__ = ["readonly"]

A = TypeVar("A", bound=np.ndarray[Any, Any])


def readonly(a: A) -> A:
    """Mark ``a`` read-only in place and return it (DESIGN: immutable, explicit state)."""
    a.setflags(write=False)
    return a
