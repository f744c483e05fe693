"""Error messages quote received numbers as plain numbers, never ``np.float64(-0.4)``.

NumPy 2 spells a scalar's repr ``np.float64(-0.4)``; a value a user computed with NumPy must
read as ``-0.4`` in the message (velfence._validate.show is the one way to quote a value).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import velfence as vf
from velfence._validate import show
from velfence.errors import VelfenceError
from velfence.geometry import Rectangle
from velfence.shaping import RateLimiter
from velfence.sim import Disturbance

NEG = np.float64(-0.4)
SQUARE = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]

CASES: dict[str, Callable[[], Any]] = {
    "check_positive": lambda: vf.SphereObstacle([0.0, 0.0, 0.0], radius=NEG),
    "profile buffer": lambda: vf.LinearBuffer(buffer=NEG),
    "rate limits": lambda: RateLimiter(max_speed=NEG, max_acceleration=1.0, dt=0.01, size=1),
    "rectangle": lambda: Rectangle(xmin=np.float64(1.0), xmax=NEG, ymin=0.0, ymax=1.0),
    "box corners": lambda: vf.ConvexPolytope.box(np.array([1.0]), np.array([-0.4])),
    "joint limits": lambda: vf.JointLimits(np.array([1.0]), np.array([-0.4]), max_speed=1.0),
    "shaper dt": lambda: vf.PolygonShaper(vf.ConvexPolygon(SQUARE), buffer=0.1, dt=NEG),
    "push times": lambda: Disturbance.push(np.float64(1.0), NEG, np.zeros(2)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_numpy_scalars_print_as_plain_numbers(case: str) -> None:
    with pytest.raises(VelfenceError) as info:
        CASES[case]()
    text = str(info.value)
    assert "-0.4" in text, text
    assert "np." not in text, text
    assert "float64" not in text, text


def test_show_unwraps_scalars_and_sequences_of_them() -> None:
    assert show(np.float64(-0.4)) == "-0.4"
    assert show(np.int64(3)) == "3"
    assert show((np.float64(1.5), [np.float32(2.0)])) == "(1.5, [2.0])"
    assert show("text") == "'text'"
