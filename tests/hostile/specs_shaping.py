"""Specs of velfence.shaping (and of the 2-D shaper methods shared with sim and cobot)."""

from __future__ import annotations

import numpy as np
from common import P2, P_ROWS, V2, V_ROWS, square
from harness import C, F, call

import velfence as vf
from velfence.mechanisms import PAPER_STOPS, Q_AUX

#: The methods every 2-D shaper has (ShaperBase).
SHAPER_2D = {
    "explain": lambda: call(P2, V2),
    "shape": lambda: call(P2, V2),
    "shape_batch": lambda: call(P_ROWS, V_ROWS),
    "zones_batch": lambda: call(P_ROWS, V_ROWS),
}
_DELTA = {"delta": "scalar", "speed": "nonneg"}
_PROFILE_METHODS = {
    "cap": F(lambda: call(0.1, 1.0), types=_DELTA),
    "zone": F(lambda: call(0.1), types=_DELTA),
}
_P3 = np.array([0.1, 0.02, 0.0])
_V3 = np.array([0.05, 0.01, 0.0])
_LINE_METHODS = {
    "explain": lambda: call(_P3, _V3),
    "shape": lambda: call(_P3, _V3),
    "shape_batch": lambda: call(np.array([_P3, _P3 * 0.5]), np.array([_V3, -_V3])),
}
_THETA = np.array([0.2, 0.1, 0.0])
_THETA_DOT = np.array([0.5, -0.2, 0.1])


def profile() -> vf.ThreeZoneBraking:
    """A valid braking profile (max_speed above max_acceleration/gain, as the profile requires)."""
    return vf.ThreeZoneBraking(gain=4.0, max_speed=1.0, max_acceleration=2.0)


def box3() -> vf.ConvexPolytope:
    return vf.ConvexPolytope.box([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])


_PT3 = np.array([0.95, 0.2, -0.1])
_VT3 = np.array([0.5, -0.2, 0.1])
_POLYTOPE_METHODS = {
    "explain": lambda: call(_PT3, _VT3),
    "shape": lambda: call(_PT3, _VT3),
    "shape_batch": lambda: call(np.array([_PT3, -_PT3]), np.array([_VT3, _VT3])),
    "zones_batch": lambda: call(np.array([_PT3, -_PT3]), np.array([_VT3, _VT3])),
    "bound_rows": lambda: call(_PT3, _VT3),
}


def stop_limiter() -> vf.StopLimiter:
    return vf.StopLimiter(PAPER_STOPS, profile=profile(), transform=Q_AUX)


SPECS: dict[str, F | C] = {
    "shaping.ApproachProfile": C(abstract="Protocol: exercised through its implementations"),
    "shaping.Shaper": C(abstract="Protocol: exercised through its implementations"),
    "shaping.ShaperResult": C(abstract="Protocol: satisfied by every shaper's explain() record"),
    "shaping.LinearBuffer": C(F(lambda: call(buffer=0.2, spring_gain=4.0)), _PROFILE_METHODS),
    "shaping.ThreeZoneBraking": C(
        lambda: call(gain=4.0, max_speed=1.0, max_acceleration=2.0),
        {
            **_PROFILE_METHODS,
            "check_period": lambda: call(0.001),
            "from_actuator_limits": lambda: call(gain=4.0, max_speed=1.0, max_acceleration=2.0),
        },
    ),
    # accelerate=False: the numba batch kernel takes 10+ s to compile on this machine and only
    # ever sees arrays the validation layer has already checked; the flag itself is attacked.
    "shaping.PolygonShaper": C(
        F(
            lambda: call(square(), buffer=0.2, spring_gain=2.0, accelerate=False),
            required=frozenset({"buffer"}),
        ),
        {
            **SHAPER_2D,
            "bounds": lambda: call(P2, V2),
            "bound_rows": lambda: call(P2, V2),
        },
    ),
    # accelerate=False as for PolygonShaper (the compiled kernels see only validated arrays).
    "shaping.PolytopeShaper": C(
        F(
            lambda: call(box3(), buffer=0.2, spring_gain=2.0, accelerate=False),
            required=frozenset({"buffer"}),
        ),
        _POLYTOPE_METHODS,
    ),
    "shaping.PolytopeResult": C(record="output record of PolytopeShaper.explain()"),
    "shaping.RateLimiter": C(
        lambda: call(size=2, max_speed=1.0, max_acceleration=10.0, dt=0.001),
        {
            "bounds": lambda: call(),
            "hold": lambda: call(np.array([0.1, 0.2])),
            "reset": lambda: call([0.1, 0.2]),
            "step": lambda: call([0.5, 0.2]),
        },
    ),
    "shaping.StopLimiter": C(
        lambda: call(PAPER_STOPS, profile=profile(), transform=Q_AUX),
        {
            "explain": lambda: call(_THETA, _THETA_DOT),
            "reset": lambda: call(),
            "shape": lambda: call(_THETA, _THETA_DOT),
            "shape_batch": lambda: call(np.array([_THETA, _THETA]), np.array([_THETA_DOT] * 2)),
        },
        instance=stop_limiter,
    ),
    "shaping.LineFixture": C(
        lambda: call([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
        {**_LINE_METHODS, "force": lambda: call(_P3)},
    ),
    "shaping.LineScaling": C(
        # across = 0 is documented (motion across the line suppressed): >= 0, not > 0
        F(lambda: call([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]), types={"across": "nonneg"}),
        _LINE_METHODS,
    ),
    "shaping.ShapingResult": C(
        record="output record built by every shaper's explain()",
        instance=lambda: vf.PolygonShaper(square(), buffer=0.2).explain(P2, V2),
    ),
    "shaping.FixtureResult": C(record="output record of LineFixture.explain()"),
    "shaping.ScalingResult": C(record="output record of LineScaling.explain()"),
    "shaping.StopResult": C(record="output record of StopLimiter.explain()"),
}
