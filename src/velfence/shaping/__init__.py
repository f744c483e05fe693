"""Shapers: ``v_out = shape(state, v_cmd)``.

Math contract: a shaper returns, for a position and a commanded velocity, an admissible velocity
that (1) equals the command wherever no constraint is near, (2) never has a larger outward normal
speed than the command towards any nearby constraint while inside, (3) outside, reduces every
violation, and (4) is finite for every input (non-finite input raises ``InvalidInput`` or, with
``on_invalid="stop"``, gives zero). Every shaper implements ``shape``, ``explain`` and
``shape_batch`` (see :mod:`velfence.shaping.base`).
"""

from velfence.shaping._kernels import STAGE_NAMES, ZONE_NAMES
from velfence.shaping.base import Shaper, ShapingResult
from velfence.shaping.polygon import PolygonShaper
from velfence.shaping.profiles import ApproachProfile, LinearBuffer, ThreeZoneBraking
from velfence.shaping.rate import RateLimiter
from velfence.shaping.stops import StopLimiter, StopResult

__all__ = [
    "STAGE_NAMES",
    "ZONE_NAMES",
    "ApproachProfile",
    "LinearBuffer",
    "PolygonShaper",
    "RateLimiter",
    "Shaper",
    "ShapingResult",
    "StopLimiter",
    "StopResult",
    "ThreeZoneBraking",
]
