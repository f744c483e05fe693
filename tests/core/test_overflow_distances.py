"""Positions beyond ~1e300: the signed distances overflow, and every route refuses the state.

(Edge normals along the axes never overflow: |n·p| <= |p|. A hexagon's oblique ones do.)

Formerly (an open defect of the fuzz run) the checked C entry returned ``VF_OK`` with a finite
velocity and ``d1 = -inf``. Now the checked entry returns ``VF_ERR_OVERFLOW`` (-4) with the stop
result, and the Python shaper (either backend) applies its ``on_invalid`` policy in ``shape``,
``explain`` and the batches alike, so no route reports a non-finite number.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from core_helpers import pair

import velfence as vf

core = pytest.importorskip(
    "velfence_core._core", reason="the compiled core is not installed (pip install ./core)"
)

BOX = vf.ConvexPolygon([[-1.0, -0.5], [1.0, -0.5], [1.0, 0.5], [-1.0, 0.5]])
HEXAGON = vf.ConvexPolygon(
    [[math.cos(a), math.sin(a)] for a in np.linspace(0, 2 * math.pi, 6, endpoint=False)]
)
FAR = [(1.7e308, 1.7e308), (-1.7e308, 1.7e308), (1.7e308, -1.7e308), (-1.7e308, -1.7e308)]


@pytest.mark.parametrize("poly", [HEXAGON])
@pytest.mark.parametrize("method", ["exact", "edge-scaling"])
def test_far_positions_are_refused_everywhere(poly: vf.ConvexPolygon, method: str) -> None:
    kwargs = {"buffer": 0.2, "spring_gain": 2.0, "max_recovery_speed": 1.0, "method": method}
    if method == "edge-scaling":
        del kwargs["max_recovery_speed"]
    for p in FAR:
        probe = vf.PolygonShaper(poly, backend="python", accelerate=False, **kwargs)
        ref = probe._law(*p, 0.3, -0.2)
        assert not (math.isfinite(ref[5]) and math.isfinite(ref[6]))  # the distances overflow
    py, c = pair(poly, **kwargs)
    for sh in (py, c):
        stop = vf.PolygonShaper(poly, backend=sh.backend, on_invalid="stop", **kwargs)
        for p in FAR:
            rc, res = c._core.__self__.shape(*p, 0.3, -0.2)
            assert rc == -4
            assert res == (0.0, 0.0, 5, -1, -1, 0.0, 0.0, 0.0, 0.0, 128)
            with pytest.raises(vf.InvalidInput, match="overflowed"):
                sh.shape(np.array(p), np.array((0.3, -0.2)))
            with pytest.raises(vf.InvalidInput, match="overflowed"):
                sh.explain(p, (0.3, -0.2))
            assert stop.shape(np.array(p), np.array((0.3, -0.2))).tolist() == [0.0, 0.0]
            r = stop.explain(p, (0.3, -0.2))
            assert r.zone == "invalid"
            assert r.stages == ("stop",)
            P = np.array([p, (0.0, 0.0)])
            V = np.array([(0.3, -0.2), (0.3, -0.2)])
            out, zones = stop.zones_batch(P, V)
            assert out[0].tolist() == [0.0, 0.0]
            assert zones[0] == 5
            assert np.isfinite(out).all()
            assert zones[1] != 5
            with pytest.raises(vf.InvalidInput, match="overflowed"):
                sh.shape_batch(P, V)


def test_positions_just_below_the_overflow_are_answered() -> None:
    """1e300 itself still has finite distances: answered (recovery), not refused."""
    py, c = pair(BOX, buffer=0.2, spring_gain=2.0, max_recovery_speed=1.0)
    for sh in (py, c):
        r = sh.explain((1e300, -1e300), (0.0, 0.0))
        assert r.zone.startswith("outside")
        assert all(math.isfinite(x) for x in (r.d1, r.d2, *r.output))
        assert r.output.tolist() == [-1.0, 1.0]  # each violated edge: recovery at r_max = 1
