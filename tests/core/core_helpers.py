"""Shared helpers of the compiled-core tests: bitwise comparison and shaper builders."""

from __future__ import annotations

import struct
from typing import Any

from velfence.geometry.polygon import ConvexPolygon
from velfence.shaping import PolygonShaper
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking


def bits(r: tuple[Any, ...]) -> tuple[Any, ...]:
    """A kernel result with every float as its 8 bytes: equal tuples mean bit-identical results
    (``0.0 == -0.0`` and ``nan != nan`` under float equality; neither here)."""
    return tuple(struct.pack("<d", x) if isinstance(x, float) else x for x in r)


def law_kwargs(
    poly: ConvexPolygon, law: str, frac: float, gain: float, dt: float | None
) -> dict[str, Any]:
    """Keyword arguments of one PolygonShaper law on ``poly`` (``frac`` of the inradius)."""
    width = frac * poly.inradius
    if law == "exact":
        return {"buffer": width, "spring_gain": gain, "dt": dt}
    if law == "exact-rmax":
        return {
            "buffer": width,
            "spring_gain": gain,
            "max_recovery_speed": 0.5 * gain + 0.01,
            "dt": dt,
        }
    if law == "patent":
        return {"buffer": width, "spring_gain": gain, "method": "edge-scaling", "dt": dt}
    if law == "linear-profile":
        return {"profile": LinearBuffer(buffer=width, spring_gain=gain)}
    if law == "three-zone":
        return {"profile": ThreeZoneBraking(gain=gain + 2.5, max_speed=1.0, max_acceleration=2.0)}
    raise ValueError(law)


LAWS = ("exact", "exact-rmax", "patent", "linear-profile", "three-zone")


def pair(poly: ConvexPolygon, **kwargs: Any) -> tuple[PolygonShaper, PolygonShaper]:
    """The same law with the Python reference and with the compiled core."""
    return (
        PolygonShaper(poly, backend="python", accelerate=False, **kwargs),
        PolygonShaper(poly, backend="c", **kwargs),
    )
