"""``PolygonShaper(backend=...)``: the choice, its errors, and the fallback without the core."""

from __future__ import annotations

import numpy as np
import pytest

import velfence.shaping.backend as backend_module
from velfence.errors import InvalidParameter
from velfence.geometry.polygon import ConvexPolygon
from velfence.shaping import PolygonShaper
from velfence.shaping.backend import compiled_core
from velfence.shaping.profiles import ApproachProfile, LinearBuffer

SQUARE = ConvexPolygon(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))


def test_auto_picks_the_core_when_importable() -> None:
    shaper = PolygonShaper(SQUARE, buffer=0.2)
    assert shaper.backend == ("c" if compiled_core() is not None else "python")
    assert PolygonShaper(SQUARE, buffer=0.2, backend="python").backend == "python"


def test_without_the_core(monkeypatch: pytest.MonkeyPatch) -> None:
    """'auto' falls back to Python; 'c' is refused naming the argument."""
    monkeypatch.setattr(backend_module, "compiled_core", lambda: None)
    shaper = PolygonShaper(SQUARE, buffer=0.2, backend="auto")
    assert shaper.backend == "python"
    assert shaper.shape([0.95, 0.5], [1.0, 0.0])[0] == pytest.approx(0.25)
    with pytest.raises(InvalidParameter, match=r"backend='c' needs the compiled core"):
        PolygonShaper(SQUARE, buffer=0.2, backend="c")


@pytest.mark.parametrize("bad", ["C", "numba", "", None, 1, True])
def test_bad_backend_refused(bad: object) -> None:
    with pytest.raises(InvalidParameter, match=r"backend must be one of \['auto', 'python', 'c'\]"):
        PolygonShaper(SQUARE, buffer=0.2, backend=bad)  # type: ignore[arg-type]


class _Custom:
    """A profile the kernels do not know (an ApproachProfile delegating to a LinearBuffer)."""

    def __init__(self) -> None:
        self._inner = LinearBuffer(buffer=0.2, spring_gain=1.0)

    def cap(self, delta: float, speed: float = 0.0) -> float:
        return self._inner.cap(delta, speed)

    def zone(self, delta: float) -> int:
        return self._inner.zone(delta)


def test_custom_profile_runs_in_python() -> None:
    assert isinstance(_Custom(), ApproachProfile)
    assert PolygonShaper(SQUARE, profile=_Custom()).backend == "python"
    with pytest.raises(InvalidParameter, match=r"backend='c' runs the kernels' own profiles"):
        PolygonShaper(SQUARE, profile=_Custom(), backend="c")
