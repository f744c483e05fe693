"""The frameless ``shape`` (``velfence_core._core.ShapeCall``) and the velocity-only batches.

With the C backend, ``PolygonShaper`` and ``PolytopeShaper`` install a C callable as the
instance's ``shape``: two finite float64 vectors run the core with no Python frame, every other
call goes to the Python route. These tests hold it to the Python route bit for bit (outputs as
their bytes) and message for message (exception type and text), over hypothesis-drawn polygons,
polytopes, laws and states, for both ``on_invalid`` modes and every kind of bad input; and
``shape_batch`` (the velocity-only C loops) to ``zones_batch`` and to the Python reference.
"""

from __future__ import annotations

import gc
import inspect
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from core_helpers import LAWS, law_kwargs
from hypothesis import given, settings
from hypothesis import strategies as st

from bad_inputs import BAD_VECTORS, HugeLen, LyingLen, RaisingArray
from strategies import convex_polygons, positions, vectors
from velfence.errors import VelfenceError
from velfence.geometry.polygon import ConvexPolygon
from velfence.geometry.polytope import ConvexPolytope
from velfence.shaping import PolygonShaper, PolytopeShaper
from velfence.shaping.base import ShaperBase
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking

core = pytest.importorskip(
    "velfence_core._core", reason="the compiled core is not installed (pip install ./core)"
)
pytest.importorskip("velfence_core._nd", reason="the compiled core's n-D module is not installed")

Outcome = tuple[Any, ...]


def outcome(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Outcome:
    """What a call did: its output as dtype, shape and bytes, or its exception's type and text."""
    try:
        r = fn(*args, **kwargs)
    except Exception as exc:  # compared below, and checked to be a VelfenceError
        return ("raised", type(exc), str(exc))
    return ("returned", r.dtype.str, r.shape, r.tobytes())


def check_outcome(got: Outcome, *references: Outcome) -> None:
    for ref in references:
        assert got == ref
    if got[0] == "raised":
        assert issubclass(got[1], VelfenceError), got
    else:
        assert np.isfinite(np.frombuffer(got[3])).all(), got


# ------------------------------------------------------------------ builders


def polygon_trio(poly: Any, **kw: Any) -> tuple[PolygonShaper, PolygonShaper]:
    """The law with the Python reference and with the core (frameless ``shape``)."""
    py = PolygonShaper(poly, backend="python", accelerate=False, **kw)
    c = PolygonShaper(poly, backend="c", **kw)
    assert type(c.shape) is core.ShapeCall
    return py, c


def python_route(c: PolygonShaper | PolytopeShaper) -> Callable[..., Any]:
    """The C shaper's own Python route (what ShapeCall falls back to)."""
    if isinstance(c, PolygonShaper):
        return lambda *a, **k: ShaperBase.shape(c, *a, **k)
    return c._shape_generic


@st.composite
def polytopes(draw: st.DrawFn) -> ConvexPolytope:
    """A box or random unit normals around the origin (inside every facet by 0.3-2), 2-5-D."""
    dim = draw(st.integers(2, 5))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if draw(st.booleans()):
        return ConvexPolytope.box(-rng.uniform(0.3, 2.0, dim), rng.uniform(0.3, 2.0, dim))
    nf = draw(st.integers(1, 14))
    N = rng.normal(size=(nf, dim))
    N /= np.linalg.norm(N, axis=1)[:, None]
    return ConvexPolytope(N, -rng.uniform(0.3, 2.0, nf))


def polytope_kwargs(poly: ConvexPolytope, law: str, frac: float, gain: float) -> dict[str, Any]:
    width = frac * min(poly.chebyshev_radius, 1.0)
    if law == "exact":
        return {"buffer": width, "spring_gain": gain}
    if law == "exact-dt":
        return {"buffer": width, "spring_gain": gain, "dt": 0.01 + 0.1 * frac}
    if law == "linear-profile":
        return {"profile": LinearBuffer(buffer=width, spring_gain=gain)}
    return {"profile": ThreeZoneBraking(gain=gain + 2.5, max_speed=1.0, max_acceleration=2.0)}


def polytope_pair(poly: ConvexPolytope, **kw: Any) -> tuple[PolytopeShaper, PolytopeShaper]:
    py = PolytopeShaper(poly, backend="python", accelerate=False, **kw)
    c = PolytopeShaper(poly, backend="c", **kw)
    assert type(c.shape) is core.ShapeCall
    return py, c


_ON_INVALID = st.sampled_from(("raise", "stop"))


@st.composite
def polygon_cases(draw: st.DrawFn, *, bound: float = 3.0) -> tuple[Any, ...]:
    poly = draw(convex_polygons(max_n=12))
    law = draw(st.sampled_from(LAWS))
    kw = law_kwargs(
        poly,
        law,
        draw(st.floats(0.05, 1.0)),
        draw(st.floats(0.0, 20.0)),
        draw(st.one_of(st.none(), st.floats(1e-3, 0.2))),
    )
    kw["on_invalid"] = draw(_ON_INVALID)
    states = [(draw(positions(poly, spread=2.0)), draw(vectors(bound))) for _ in range(8)]
    return poly, kw, states


@st.composite
def polytope_cases(draw: st.DrawFn, *, bound: float = 3.0) -> tuple[Any, ...]:
    poly = draw(polytopes())
    law = draw(st.sampled_from(("exact", "exact-dt", "linear-profile", "three-zone")))
    kw = polytope_kwargs(poly, law, draw(st.floats(0.05, 1.0)), draw(st.floats(0.0, 20.0)))
    kw["on_invalid"] = draw(_ON_INVALID)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = draw(st.sampled_from([1e-3, 1.0, bound]))
    states = [
        (rng.uniform(-2.5, 2.5, poly.dim), rng.normal(size=poly.dim) * scale) for _ in range(8)
    ]
    return poly, kw, states


# ------------------------------------------------------------------ equal to the Python route


@given(polygon_cases())
def test_polygon_shape_bit_identical(case: tuple[Any, ...]) -> None:
    """The frameless call, the C shaper's Python route and the Python reference agree bitwise."""
    poly, kw, states = case
    py, c = polygon_trio(poly, **kw)
    route = python_route(c)
    for p, v in states:
        got = outcome(c.shape, p, v)
        check_outcome(got, outcome(route, p, v), outcome(py.shape, p, v))
        assert got[0] == "returned"


@given(polygon_cases(bound=1e150))
def test_polygon_huge_commands_bit_identical(case: tuple[Any, ...]) -> None:
    poly, kw, states = case
    py, c = polygon_trio(poly, **kw)
    for p, v in states:
        check_outcome(outcome(c.shape, p, v), outcome(py.shape, p, v))


@settings(max_examples=60)
@given(polytope_cases())
def test_polytope_shape_bit_identical(case: tuple[Any, ...]) -> None:
    poly, kw, states = case
    py, c = polytope_pair(poly, **kw)
    route = python_route(c)
    for p, v in states:
        got = outcome(c.shape, p, v)
        check_outcome(got, outcome(route, p, v), outcome(py.shape, p, v))
        assert got[0] == "returned"


# ------------------------------------------------------------------ bad inputs


def bad_vectors(n: int) -> dict[str, Any]:
    """Every kind of input off the common path, for a vector of length ``n``."""
    good = np.linspace(0.1, 0.2, n)
    out: dict[str, Any] = dict(BAD_VECTORS)
    big = np.zeros(n)
    big[0] = 1e200
    vast = np.full(n, 1e308)
    out |= {
        "hugelen": HugeLen(),
        "lyinglen": LyingLen(),
        "raising-array": RaisingArray(),
        "nan": np.where(np.arange(n) == 0, math.nan, good),
        "inf": np.where(np.arange(n) == n - 1, math.inf, good),
        "-inf": np.full(n, -math.inf),
        "short": good[:-1].copy(),
        "long": np.append(good, 0.0),
        "column": good[:, None].copy(),
        "row": good[None, :].copy(),
        "scalar": np.float64(0.5),
        "0-d": np.array(0.5),
        "float32": good.astype(np.float32),
        "int": np.arange(n),
        "big-endian": good.astype(">f8"),
        "strided": np.repeat(good, 2)[::2],
        "read-only": np.frombuffer(good.tobytes()),
        "subclass": good.view(type("Sub", (np.ndarray,), {})),
        "list": good.tolist(),
        "tuple": tuple(good.tolist()),
        "nan-list": [math.nan] * n,
        "huge": big,
        "overflowing": vast,
        "-overflowing": -vast,
        "empty": np.zeros(0),
    }
    return out


def _bad_kinds(n: int) -> list[str]:
    return sorted(bad_vectors(n))


def _check_bad(c: Any, py: Any, n: int, kind: str) -> None:
    route = python_route(c)
    bad = bad_vectors(n)[kind]
    good_p, good_v = np.full(n, 0.05), np.linspace(0.3, -0.2, n)
    for args in ((bad, good_v), (good_p, bad), (bad, bad)):
        check_outcome(outcome(c.shape, *args), outcome(route, *args), outcome(py.shape, *args))
    kw = {"position": good_p, "command": bad}
    check_outcome(outcome(c.shape, **kw), outcome(route, **kw), outcome(py.shape, **kw))


_SQUARE = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]


@pytest.mark.parametrize("on_invalid", ["raise", "stop"])
@pytest.mark.parametrize("method", ["exact", "edge-scaling"])
@pytest.mark.parametrize("kind", _bad_kinds(2))
def test_polygon_bad_inputs_take_the_python_route(on_invalid: str, method: str, kind: str) -> None:
    """Off the common path the answer (or the error, type and message) is the Python route's."""
    kw = {"buffer": 0.2, "method": method, "on_invalid": on_invalid}
    py, c = polygon_trio(ConvexPolygon(_SQUARE), **kw)
    _check_bad(c, py, 2, kind)


@pytest.mark.parametrize("on_invalid", ["raise", "stop"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kind", _bad_kinds(3))
def test_polytope_bad_inputs_take_the_python_route(on_invalid: str, dim: int, kind: str) -> None:
    poly = ConvexPolytope.box(-np.ones(dim), np.ones(dim))
    py, c = polytope_pair(poly, buffer=0.2, on_invalid=on_invalid)
    _check_bad(c, py, dim, kind)


@pytest.mark.parametrize("nargs", [0, 1, 3])
def test_wrong_argument_counts_raise_as_the_method(nargs: int) -> None:
    """Not two arguments: the Python route's own TypeError (a call error, as for any method)."""
    c = PolygonShaper(ConvexPolygon(_SQUARE), buffer=0.2, backend="c")
    args = [np.zeros(2)] * nargs
    with pytest.raises(TypeError) as fast:
        c.shape(*args)
    with pytest.raises(TypeError) as route:
        ShaperBase.shape(c, *args)
    assert str(fast.value) == str(route.value)


# ------------------------------------------------------------------ the batches


@given(polygon_cases())
def test_polygon_batch_velocity_only_bit_identical(case: tuple[Any, ...]) -> None:
    """``shape_batch`` (the core's loop writing velocities only) equals ``zones_batch`` and the
    Python reference bit for bit, bad rows included."""
    poly, kw, states = case
    py, c = polygon_trio(poly, **kw)
    P = np.array([p for p, _ in states])
    V = np.array([v for _, v in states])
    check_outcome(
        outcome(c.shape_batch, P, V),
        outcome(lambda a, b: c.zones_batch(a, b)[0], P, V),
        outcome(py.shape_batch, P, V),
    )
    P[2, 1] = math.nan
    V[5] = [1e308, -1e308]
    check_outcome(outcome(c.shape_batch, P, V), outcome(py.shape_batch, P, V))


@settings(max_examples=60)
@given(polytope_cases())
def test_polytope_batch_velocity_only_bit_identical(case: tuple[Any, ...]) -> None:
    poly, kw, states = case
    py, c = polytope_pair(poly, **kw)
    P = np.array([p for p, _ in states])
    V = np.array([v for _, v in states])
    got = outcome(c.shape_batch, P, V)
    check_outcome(
        got, outcome(lambda a, b: c.zones_batch(a, b)[0], P, V), outcome(py.shape_batch, P, V)
    )
    assert got[0] == "returned"
    assert got[3] == b"".join(c.shape(p, v).tobytes() for p, v in states)
    P[1, 0] = math.inf
    V[4, -1] = math.nan
    check_outcome(outcome(c.shape_batch, P, V), outcome(py.shape_batch, P, V))
    # non-contiguous and transposed inputs, lists
    Pf, Vf = np.asfortranarray(P), np.asfortranarray(V)
    check_outcome(outcome(c.shape_batch, Pf, Vf), outcome(py.shape_batch, P, V))
    check_outcome(outcome(c.shape_batch, P.tolist(), V.tolist()), outcome(py.shape_batch, P, V))


@pytest.mark.parametrize("on_invalid", ["raise", "stop"])
@pytest.mark.parametrize(
    "bad",
    ["empty", "mismatch", "wrong-width", "huge", "overflowing", "strings", "1-d", "float32"],
)
def test_polytope_batch_bad_inputs(on_invalid: str, bad: str) -> None:
    """Refusals and the on_invalid policy of ``shape_batch`` are ``zones_batch``'s own."""
    poly = ConvexPolytope.box(-np.ones(3), np.ones(3))
    py, c = polytope_pair(poly, buffer=0.2, on_invalid=on_invalid)
    rng = np.random.default_rng(7)
    P, V = rng.uniform(-1.2, 1.2, (6, 3)), rng.normal(size=(6, 3))
    if bad == "empty":
        P, V = P[:0], V[:0]
    elif bad == "mismatch":
        V = V[:4]
    elif bad == "wrong-width":
        P = P[:, :2]
    elif bad == "huge":
        V[2, 0] = 1e200
    elif bad == "overflowing":
        V[2] = 1e150
    elif bad == "strings":
        P = P.astype(str)
    elif bad == "1-d":
        P = P[0]
    else:
        P = P.astype(np.float32)
    check_outcome(
        outcome(c.shape_batch, P, V),
        outcome(lambda a, b: c.zones_batch(a, b)[0], P, V),
        outcome(py.shape_batch, P, V),
    )


def test_polytope_batch_velocity_binding() -> None:
    """``PolytopeLaw.batch_velocity`` writes only ``out`` and counts rows not finite in or out."""
    poly = ConvexPolytope.box(-np.ones(3), np.ones(3))
    c = PolytopeShaper(poly, buffer=0.2, backend="c")
    rng = np.random.default_rng(3)
    P, V = rng.uniform(-1.2, 1.2, (50, 3)), rng.normal(size=(50, 3))
    out = np.full_like(P, 7.0)
    assert c._core.batch_velocity(P, V, out) == 0
    assert out.tobytes() == c.zones_batch(P, V)[0].tobytes()
    P[[3, 9], 1] = math.nan
    assert c._core.batch_velocity(P, V, out) == 2
    assert (out[[3, 9]] == 0.0).all()
    with pytest.raises(ValueError, match="P, V, out"):
        c._core.batch_velocity(P, V[:3], out)
    with pytest.raises(TypeError):
        c._core.batch_velocity(P, V)


# ------------------------------------------------------------------ the callable itself


def test_installed_only_with_the_core_and_the_own_method() -> None:
    poly = ConvexPolygon(_SQUARE)
    assert inspect.ismethod(PolygonShaper(poly, buffer=0.2, backend="python").shape)
    box = ConvexPolytope.box(-np.ones(2), np.ones(2))
    assert inspect.ismethod(PolytopeShaper(box, buffer=0.2, backend="python").shape)

    class Own(PolygonShaper):
        __slots__ = ()

        def shape(self, position: Any, command: Any) -> Any:
            return np.full(2, 42.0)

    own = Own(poly, buffer=0.2, backend="c")
    assert own.shape(np.zeros(2), np.ones(2)).tolist() == [42.0, 42.0]


def test_signature_doc_repr_and_immutability() -> None:
    c = PolygonShaper(ConvexPolygon(_SQUARE), buffer=0.2, backend="c")
    assert list(inspect.signature(c.shape).parameters) == ["position", "command"]
    assert "Shaped velocity" in c.shape.__doc__
    assert "ShapeCall" in repr(c.shape)
    with pytest.raises(AttributeError, match="immutable"):
        c.shape = print  # type: ignore[method-assign]
    box = ConvexPolytope.box(-np.ones(3), np.ones(3))
    d = PolytopeShaper(box, buffer=0.2, backend="c")
    assert list(inspect.signature(d.shape).parameters) == ["position", "command"]


def test_shapers_are_collected() -> None:
    """The cycle shaper -> shape -> fallback -> shaper is visible to the garbage collector."""

    def alive() -> int:
        return sum(isinstance(o, (PolygonShaper, PolytopeShaper)) for o in gc.get_objects())

    gc.collect()
    before = alive()
    box = ConvexPolytope.box(-np.ones(3), np.ones(3))
    for _ in range(20):
        PolygonShaper(ConvexPolygon(_SQUARE), buffer=0.2, backend="c").shape(
            np.zeros(2), np.ones(2)
        )
        PolytopeShaper(box, buffer=0.2, backend="c").shape(np.zeros(3), np.ones(3))
    gc.collect()
    assert alive() == before


def test_shape_call_refuses_what_it_cannot_call() -> None:
    law = PolygonShaper(ConvexPolygon(_SQUARE), buffer=0.2, backend="c")._core.__self__
    with pytest.raises(TypeError, match="fast"):
        core.ShapeCall(lambda p, v: None, print)
    with pytest.raises(TypeError, match="fast"):
        core.ShapeCall(law.batch.__call__, print)
    with pytest.raises(TypeError, match="fallback"):
        core.ShapeCall(law.shape_array, 3)
    call = core.ShapeCall(law.shape_array, lambda *a, **k: ("fallback", a, k))
    assert call([0.0, 0.0], np.ones(2))[0] == "fallback"
    assert (
        call(np.zeros(2), np.ones(2)).tolist() == law.shape_array(np.zeros(2), np.ones(2)).tolist()
    )
