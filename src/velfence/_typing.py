"""Array type aliases shared by every module (one definition, imported everywhere)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["BoolArray", "FloatArray", "IntArray"]

FloatArray = NDArray[np.float64]
"""A float64 NumPy array (shape given in each docstring)."""
IntArray = NDArray[np.int64]
"""An int64 NumPy array."""
BoolArray = NDArray[np.bool_]
"""A boolean NumPy array."""
