"""The one-point frame in Python floats equals the batch evaluation bit for bit.

``_Piecewise.frame`` (Line, Circle, Polyline) evaluates one arc length in Python floats — the
path follower calls it every tick — with the same float operations as the vectorised
``_frames`` (``%`` is NumPy's ``mod``, ``bisect_right`` its ``searchsorted``, ``math.cos``/``sin``
the C library's, as NumPy's on this platform): every value equal, on hypothesis-drawn arc
lengths including the ends, the joins and far outside ``[0, length]``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from velfence.errors import InvalidInput
from velfence.geometry.paths import Circle, Line, Polyline

PATHS = {
    "line-2d": Line([0.0, 0.0], [3.0, 4.0]),
    "line-3d": Line([1.0, -1.0, 0.5], [2.0, 1.0, -1.5]),
    "circle-2d": Circle([0.5, -0.2], radius=1.5, start_angle=0.3),
    "circle-unit": Circle([0.0, 0.0], radius=1.0),
    "circle-2d-cw": Circle([0.0, 0.0], radius=0.8, ccw=False),
    "circle-3d": Circle([0.0, 1.0, 2.0], radius=1.2, normal=[1.0, 1.0, 1.0]),
    "polyline-2d": Polyline([[0, 0], [2, 0], [3, 1.5], [1, 3], [0, 2]], corner_radius=0.3),
    "polyline-closed": Polyline([[0, 0], [3, 0], [3, 2], [0, 2]], corner_radius=0.6, closed=True),
}

_S = st.floats(-1e3, 1e3) | st.sampled_from([0.0, -0.0, 1e-300, 1e12, -1e12])


def _special(path) -> list[float]:
    L = path.length
    joins = path.joins.tolist()
    return [0.0, L, -L, 2 * L, *joins, *(np.nextafter(j, -1.0) for j in joins)]


@pytest.mark.parametrize("name", sorted(PATHS))
@given(s=_S)
def test_frame_equals_the_batch_evaluation(name, s):
    path = PATHS[name]
    for x in [s, *_special(path)]:
        want = path._frames(path._normalise(np.array([float(x)])))
        got = path.frame(x)
        floats = path._frame_floats(x)
        for g, f, w in zip(got, floats, want, strict=True):
            assert g.shape == (path.dim,)
            np.testing.assert_array_equal(g, w[0])
            assert f == w[0].tolist()


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), "1.0", None, True, 1e200])
def test_frame_refuses_as_before(bad):
    with pytest.raises(InvalidInput, match=r"^s: "):
        PATHS["circle-unit"].frame(bad)
