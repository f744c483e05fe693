"""Line fixtures: run-time inputs are real 3-vectors; overflow under "stop" is reported invalid."""

from __future__ import annotations

import numpy as np
import pytest

from velfence import InvalidInput
from velfence.shaping.fixtures import LineFixture, LineScaling

P0, U = np.zeros(3), np.array([0.0, 0.0, 1.0])
BAD = ["abc", b"\x00\x01\x02", {"a": 1}, [1j, 0, 0], [True, False, True], None, ["1", "2", "3"]]


@pytest.mark.parametrize("make", [lambda: LineScaling(P0, U), lambda: LineFixture(P0, U)])
@pytest.mark.parametrize("bad", BAD)
def test_positions_and_commands_must_be_real_3_vectors(make, bad):
    s = make()
    with pytest.raises(InvalidInput, match="position: expected a position"):
        s.shape(bad, np.zeros(3))
    with pytest.raises(InvalidInput, match="command: expected a velocity"):
        s.explain(P0, bad)
    with pytest.raises(InvalidInput, match=r"command: expected shape \(3,\)"):
        s.shape(P0, [0.0, 1.0])


def test_overflow_under_stop_is_zero_velocity_and_zone_invalid():
    s = LineScaling(P0, U, along=1e10, on_invalid="stop")
    r = s.explain(P0, [0.0, 0.0, 1e300])
    assert r.zone == "invalid"
    np.testing.assert_array_equal(r.output, 0.0)
    with pytest.raises(InvalidInput, match="overflowed"):
        LineScaling(P0, U, along=1e10).explain(P0, [0.0, 0.0, 1e300])
    assert LineScaling(P0, U).explain(P0, [0.0, 0.0, 1.0]).zone == "scaled"
    f = LineFixture(P0, U, on_invalid="stop")
    r = f.explain([0.0, 0.0, 1.0], [1.7e308, 1.7e308, 0.0])
    assert r.zone in ("free", "snapped", "invalid")
    assert np.all(np.isfinite(r.output))
    r = f.explain([np.nan, 0.0, 0.0], [0.0, 0.0, 0.0])
    assert r.zone == "invalid"
    np.testing.assert_array_equal(r.output, 0.0)
