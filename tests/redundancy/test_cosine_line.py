"""cosine_line: the rest-to-rest desired end-effector line of the obstacle scenarios."""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.redundancy import cosine_line


def test_ends_at_rest_at_the_right_points() -> None:
    line = cosine_line([2.0, 1.0], [0.0, -2.0], 2.0, 5.0, back=False)
    p0, v0 = line(0.0)
    p1, v1 = line(5.0)
    np.testing.assert_allclose(p0, [2.0, 1.0])
    np.testing.assert_allclose(p1, [2.0, -1.0], atol=1e-12)
    assert np.all(v0 == 0.0)
    assert np.all(v1 == 0.0)
    p_late, v_late = line(50.0)
    np.testing.assert_allclose(p_late, p1)
    assert np.all(v_late == 0.0)


def test_velocity_is_the_derivative_of_position_and_peaks_mid_way() -> None:
    length, period = 0.6, 4.0
    line = cosine_line([0.1, 0.2, 0.3], [0.0, 1.0, 0.0], length, period, back=True)
    h = 1e-6
    for t in np.linspace(0.05, 2 * period - 0.05, 37):
        numeric = (line(t + h)[0] - line(t - h)[0]) / (2 * h)
        np.testing.assert_allclose(line(t)[1], numeric, atol=1e-6)
    peak = float(np.linalg.norm(line(period / 2)[1]))
    assert peak == pytest.approx(length * math.pi / (2 * period))
    np.testing.assert_allclose(line(2 * period)[0], [0.1, 0.2, 0.3], atol=1e-12)


def test_refuses_bad_input() -> None:
    with pytest.raises(InvalidGeometry):
        cosine_line([0.0, 0.0], [0.0, 0.0], 1.0, 1.0, back=False)
    with pytest.raises(InvalidInput):
        cosine_line([0.0, 0.0], [1.0, 0.0, 0.0], 1.0, 1.0, back=False)
    with pytest.raises(InvalidParameter):
        cosine_line([0.0, 0.0], [1.0, 0.0], -1.0, 1.0, back=False)
    with pytest.raises(InvalidParameter):
        cosine_line([0.0, 0.0], [1.0, 0.0], 1.0, 0.0, back=False)
