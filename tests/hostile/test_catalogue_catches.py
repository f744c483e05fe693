"""The catalogue's own checks, shown to fail: a defect of each class is planted in a small
callable (or class) and the catalogue must report it, by class and by the argument and kind that
found it; the same callable without the defect must come out clean.

Classes: an escaping exception, a silently accepted bad value, a non-finite output, a refusal
that does not name its argument (a vague message), a refused valid value, a RuntimeWarning, a
hang, a failing valid call, a tuning value taken by position, a default that is not keyword-only,
and a batch (or ``explain``) that disagrees with ``shape``.
"""

from __future__ import annotations

import warnings
from types import SimpleNamespace
from typing import Any

import harness
import numpy as np
import pytest
from harness import (
    F,
    Target,
    attack,
    batch_disagreements,
    call,
    constructor_rule,
    tuning_positional,
)
from numpy.typing import ArrayLike

import velfence as vf
from velfence._validate import check_positive, real_array
from velfence.errors import InvalidInput
from velfence.geometry import ConvexPolygon


def _clean(x: ArrayLike, *, gain: float = 1.0) -> np.ndarray:
    """The well-behaved callable every planted defect starts from."""
    return real_array("x", x, (2,)) * check_positive("gain", gain)


def _escape(x: ArrayLike, *, gain: float = 1.0) -> np.ndarray:
    return real_array("x", x, (2,)) * gain  # gain unchecked: a dict or a string escapes


def _silent(x: ArrayLike, *, gain: float = 1.0) -> np.ndarray:
    return real_array("x", x, (2,)) * abs(float(gain))  # takes "12", True, -1


def _nonfinite(x: ArrayLike, *, gain: float = 1.0) -> np.ndarray:
    # 1e308 let through, then scaled: inf for a huge entry
    a = real_array("x", x, (2,), max_abs=None)
    with np.errstate(over="ignore"):
        return a * 10.0 * check_positive("gain", gain)


def _vague(x: ArrayLike, *, gain: float = 1.0) -> np.ndarray:
    try:
        a = real_array("x", x, (2,))
    except InvalidInput:
        raise InvalidInput("bad value") from None  # names nothing
    return a * check_positive("gain", gain)


def _picky(x: ArrayLike, *, gain: float = 1.0) -> np.ndarray:
    if not isinstance(x, np.ndarray):  # a list or a tuple of the valid numbers is valid
        raise InvalidInput(f"x must be an ndarray, got {type(x).__name__}")
    return _clean(x, gain=gain)


def _warns(x: ArrayLike, *, gain: float = 1.0) -> np.ndarray:
    a = real_array("x", x, (2,), max_abs=None)
    if np.abs(a).max() > 1e300:  # a finite answer, but a RuntimeWarning on the way
        warnings.warn("x: a huge entry, clipped", RuntimeWarning, stacklevel=2)
    return np.clip(a, -1e300, 1e300) * check_positive("gain", gain)


def _hangs(x: ArrayLike, *, gain: float = 1.0) -> np.ndarray:
    a = real_array("x", x)
    while a.size > 2:  # one entry more: never returns
        pass
    return a * check_positive("gain", gain)


def _broken(x: ArrayLike, *, gain: float = 1.0) -> np.ndarray:
    raise InvalidInput("x: always refused")


def _target(fn: Any) -> Target:
    spec = F(lambda: call(np.array([1.0, 2.0]), gain=2.0))
    return Target(f"planted.{fn.__name__}", lambda: fn, spec, False)


def _classes(fn: Any) -> dict[str, set[tuple[str, str]]]:
    """Failure class -> {(argument, kind)} of the planted callable under the catalogue."""
    out: dict[str, set[tuple[str, str]]] = {}
    for f in attack(_target(fn))[0]:
        out.setdefault(f.klass, set()).add((f.param, f.kind))
    return out


def test_the_clean_callable_passes() -> None:
    fails, calls = attack(_target(_clean))
    assert fails == []
    assert calls > 100  # every applicable kind on both arguments


@pytest.mark.parametrize(
    ("fn", "klass", "found"),
    [
        (_escape, "escape:TypeError", ("gain", "dict_xy")),
        (_silent, "silently-accepted", ("gain", "str_int")),
        (_nonfinite, "non-finite", ("x", "huge_in_valid")),
        (_vague, "unnamed", ("x", "nan_in_valid")),
        (_picky, "refused-valid", ("x", "list_of_valid")),
        (_warns, "warning", ("x", "huge_in_valid")),
    ],
    ids=["escape", "silent-acceptance", "non-finite", "vague-message", "refused-valid", "warning"],
)
def test_a_planted_defect_is_reported(fn: Any, klass: str, found: tuple[str, str]) -> None:
    classes = _classes(fn)
    assert found in classes.get(klass, set()), classes


def test_a_planted_hang_is_stopped_and_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(harness, "TIMEOUT_S", 0.05)  # the CPU-time guard, shortened
    classes = _classes(_hangs)
    assert ("x", "one_longer") in classes["hang"], classes


def test_a_failing_valid_call_is_reported() -> None:
    fails, _ = attack(_target(_broken))
    assert [(f.klass, f.param) for f in fails] == [("valid-failed", "(valid)")]


def _positional(x: ArrayLike, radius: float) -> float:
    return 0.0


def _keyword(x: ArrayLike, *, radius: float) -> float:
    return 0.0


def test_a_planted_positional_tuning_value_is_reported() -> None:
    assert tuning_positional("planted.f", _positional) == ["planted.f: radius"]
    assert tuning_positional("planted.f", _keyword) == []


class _Positional:
    def __init__(self, polygon: ConvexPolygon, gain: float = 1.0) -> None:
        pass


class _Keyword:
    def __init__(self, polygon: ConvexPolygon, *, gain: float = 1.0) -> None:
        pass


def test_a_planted_positional_default_is_reported() -> None:
    assert constructor_rule(_Positional) == [
        "gain has a default but is not keyword-only",
        "gain: float is positional (scalar tuning values are keyword-only)",
    ]
    assert constructor_rule(_Keyword) == []


class _Agreeing:
    """A shaper whose batch and ``explain`` agree with its ``shape`` (a PolygonShaper's)."""

    def __init__(self) -> None:
        square = ConvexPolygon([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
        self.inner = vf.PolygonShaper(square, buffer=0.2)

    def shape(self, p: ArrayLike, v: ArrayLike) -> np.ndarray:
        return np.asarray(self.inner.shape(p, v))

    def shape_batch(self, P: ArrayLike, V: ArrayLike) -> np.ndarray:
        return np.array([self.inner.shape(p, v) for p, v in zip(P, V, strict=True)])

    def explain(self, p: ArrayLike, v: ArrayLike) -> Any:
        return self.inner.explain(p, v)


class _DriftingBatch(_Agreeing):
    def shape_batch(self, P: ArrayLike, V: ArrayLike) -> np.ndarray:
        out = super().shape_batch(P, V)
        out[5] *= 1.0 + 1e-6  # one row off by a part in a million
        return out


class _DriftingExplain(_Agreeing):
    def explain(self, p: ArrayLike, v: ArrayLike) -> Any:
        return SimpleNamespace(output=self.shape(p, v) + 1e-6)


def test_a_planted_batch_disagreement_is_reported() -> None:
    valid = call(np.array([[0.5, 0.2]]), np.array([[1.0, 0.3]]))
    assert batch_disagreements(_Agreeing, valid) == []
    bad = batch_disagreements(_DriftingBatch, valid)
    assert len(bad) == 1, bad
    assert bad[0].startswith("row 5: shape "), bad
    bad = batch_disagreements(_DriftingExplain, valid)
    assert bad, "a drifting explain() was not reported"
    assert all("explain().output" in b for b in bad), bad
