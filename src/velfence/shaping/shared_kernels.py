"""Shaping's kernels that other packages of velfence run (internal API, not for users).

The safety filter (:mod:`velfence.filter`), the caster walls (:mod:`velfence.cobot.walls`) and the
simulator's baselines (:mod:`velfence.sim.baselines`) run the same scalar code as the shapers, so
that the zone rule and the bounds agree with them bit for bit. They take it from here, never from
the private modules behind it (``tests/test_private_names.py``):

* :func:`zone_code` and :data:`ZONE_NAMES`: the one zone rule of every 2-D law;
* :data:`STAGE_PROJECT`, :data:`STAGE_RELAXED`: the stage bits of the exact law's projection;
* :func:`fill_bounds`, :func:`bounds_from_distances`: the approach profiles' bounds on the
  velocity along each facet normal, from the distances;
* :func:`compiled_loop`: a module's plain-Python loop compiled with numba (None without numba).
"""

from __future__ import annotations

from velfence.shaping._accel import compiled_loop
from velfence.shaping._kernels import (
    STAGE_PROJECT,
    STAGE_RELAXED,
    ZONE_NAMES,
    bounds_from_distances,
    fill_bounds,
    zone_code,
)

__all__ = [
    "STAGE_PROJECT",
    "STAGE_RELAXED",
    "ZONE_NAMES",
    "bounds_from_distances",
    "compiled_loop",
    "fill_bounds",
    "zone_code",
]
