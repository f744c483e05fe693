"""The dual active-set solve in C equals the Python reference bit for bit on many-edge polygons.

``test_core_equal.py`` draws 3- to 12-gons; here regular and elliptic 64- to 1024-gons, where many
edges are bounded at once (the case the dual solve exists for), with states inside, in the buffer
and outside (far edges added), commands up to 1e12, continuous and discrete time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from core_helpers import bits, pair

import velfence as vf
from velfence.shaping.profiles import ThreeZoneBraking

core = pytest.importorskip(
    "velfence_core._core", reason="the compiled core is not installed (pip install ./core)"
)


def _ngon(n: int, aspect: float) -> vf.ConvexPolygon:
    a = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    return vf.ConvexPolygon(np.c_[np.cos(a), np.sin(a) / aspect])


@pytest.mark.parametrize("n", [64, 256, 1024])
@pytest.mark.parametrize(
    "kwargs",
    [
        {"buffer": 0.1, "spring_gain": 2.0},
        {"buffer": 0.2, "spring_gain": 5.0, "max_recovery_speed": 0.3, "dt": 0.01},
        {"profile": ThreeZoneBraking(gain=3.0, max_speed=1.0, max_acceleration=2.0)},
    ],
    ids=["exact", "exact-rmax-dt", "three-zone"],
)
def test_many_edges_bit_identical(n: int, kwargs: dict[str, object]) -> None:
    rng = np.random.default_rng(n)
    poly = _ngon(n, 1.0 if n != 256 else 2.5)
    py, c = pair(poly, **kwargs)  # type: ignore[arg-type]
    count = 150 if n < 1024 else 40
    r = rng.uniform(0.6, 1.4, count)
    a = rng.uniform(0.0, 2.0 * math.pi, count)
    P = np.c_[r * np.cos(a), r * np.sin(a)]
    V = rng.normal(size=(count, 2)) * rng.choice([0.0, 1.0, 30.0, 1e12], size=(count, 1))
    zones = set()
    for p, v in zip(P.tolist(), V.tolist(), strict=True):
        ref = py._law(*p, *v)
        assert bits(c._law(*p, *v)) == bits(ref), (p, v)
        zones.add(ref[2])
    assert {2, 4} <= zones  # several bounded edges, inside and outside


def test_shape_batch_writes_no_zone_array_and_equals_the_generic_path() -> None:
    """``shape_batch`` with the core passes ``zones=None`` to the loop (nothing thrown away) and
    returns what ``zones_batch`` (the generic path, zones included) returns, bit for bit."""
    poly = _ngon(8, 1.0)
    py, c = pair(poly, buffer=0.2, spring_gain=2.0, dt=0.01)
    rng = np.random.default_rng(3)
    P = rng.uniform(-1.3, 1.3, (5000, 2))
    V = rng.normal(size=P.shape)
    out = c.shape_batch(P, V)
    assert out.tobytes() == c.zones_batch(P, V)[0].tobytes()
    assert out.tobytes() == py.zones_batch(P, V)[0].tobytes()
    loop = np.full_like(P, 7.0)
    c._core.__self__.batch(P, V, loop, None)
    assert loop.tobytes() == out.tobytes()
    # lists and a non-finite row take the generic path (its policy, the same answers elsewhere)
    stop = vf.PolygonShaper(poly, backend="c", on_invalid="stop", buffer=0.2, spring_gain=2.0)
    Pn = P[:4].copy()
    Pn[1, 0] = math.nan
    got = stop.shape_batch(Pn.tolist(), V[:4].tolist())
    assert got[1].tolist() == [0.0, 0.0]
    assert got[[0, 2, 3]].tobytes() == stop.shape_batch(P[[0, 2, 3]], V[[0, 2, 3]]).tobytes()
