"""Shapers: ``v_out = shape(state, v_cmd)``.

Math contract: a shaper returns, for a position and a commanded velocity, an admissible velocity
that (1) equals the command wherever no constraint is near, (2) inside, approaches every nearby
constraint no faster than its approach profile allows at that distance (a cap that vanishes on the
boundary; for the exact polygon law ``‖v‖·d/d_max``, and never faster than the command overall —
though at an acute corner it may trade some approach to one edge, within that edge's cap, for
the other's), (3) outside, reduces every violation, and (4) is finite for every input (non-finite
input raises ``InvalidInput`` or, with ``on_invalid="stop"``, gives zero). Every 2-D shaper
implements ``shape``, ``explain`` and ``shape_batch`` (see :mod:`velfence.shaping.base`); the
joint-stop limiter and the n-D polytope shaper do the same on n-vectors.
"""

from velfence._deprecate import module_getattr
from velfence.shaping._kernels import STAGE_NAMES, ZONE_NAMES
from velfence.shaping.base import Shaper, ShapingResult, ShapingResultProtocol
from velfence.shaping.fixtures import (
    OMNI_CONTINUOUS_FORCE,
    OMNI_MAX_FORCE,
    FixtureResult,
    LineFixture,
    LineScaling,
    ScalingResult,
)
from velfence.shaping.lookahead import LagCompensation
from velfence.shaping.polygon import PolygonShaper
from velfence.shaping.polytope import PolytopeResult, PolytopeShaper
from velfence.shaping.profiles import ApproachProfile, LinearBuffer, ThreeZoneBraking
from velfence.shaping.rate import RateLimiter
from velfence.shaping.stops import StopLimiter, StopResult

__all__ = [
    "OMNI_CONTINUOUS_FORCE",
    "OMNI_MAX_FORCE",
    "STAGE_NAMES",
    "ZONE_NAMES",
    "ApproachProfile",
    "FixtureResult",
    "LagCompensation",
    "LineFixture",
    "LineScaling",
    "LinearBuffer",
    "PolygonShaper",
    "PolytopeResult",
    "PolytopeShaper",
    "RateLimiter",
    "ScalingResult",
    "Shaper",
    "ShapingResult",
    "ShapingResultProtocol",
    "StopLimiter",
    "StopResult",
    "ThreeZoneBraking",
]

__getattr__ = module_getattr(__name__, {"ShaperResult": "ShapingResultProtocol"}, globals())
