"""The compiled core (velfence_core) computes the Python reference kernels bit for bit.

Every comparison is bitwise (floats as their 8 bytes, so ``-0.0`` vs ``0.0`` would fail too): the C
code performs the reference's operations in the same order, compiled without fused multiply-adds
(``-ffp-contract=off``), and calls the same libm ``atan2``, so no tolerance is needed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from core_helpers import LAWS, bits, law_kwargs, pair
from hypothesis import given
from hypothesis import strategies as st

from strategies import convex_polygons, positions, vectors
from velfence.shaping import PolygonShaper
from velfence.shaping import _kernels as kern

core = pytest.importorskip(
    "velfence_core._core", reason="the compiled core is not installed (pip install ./core)"
)

_FRAC = st.floats(min_value=0.05, max_value=1.0)
_GAIN = st.floats(min_value=0.0, max_value=20.0)
_DT = st.one_of(st.none(), st.floats(min_value=1e-3, max_value=0.2))


@st.composite
def cases(draw: st.DrawFn, *, bound: float = 3.0) -> tuple[object, ...]:
    poly = draw(convex_polygons(max_n=12))
    law = draw(st.sampled_from(LAWS))
    kwargs = law_kwargs(poly, law, draw(_FRAC), draw(_GAIN), draw(_DT))
    states = [(draw(positions(poly, spread=2.0)), draw(vectors(bound))) for _ in range(8)]
    return poly, kwargs, states


@given(cases())
def test_single_calls_bit_identical(case: tuple[object, ...]) -> None:
    """``_law`` (what shape and explain run) agrees bit for bit, zones and stages included."""
    poly, kwargs, states = case
    py, c = pair(poly, **kwargs)  # type: ignore[arg-type]
    assert (py.backend, c.backend) == ("python", "c")
    for p, v in states:  # type: ignore[attr-defined]
        args = (*p.tolist(), *v.tolist())
        assert bits(c._law(*args)) == bits(py._law(*args)), args


@given(cases(bound=1e150))
def test_huge_commands_bit_identical(case: tuple[object, ...]) -> None:
    """Commands up to 1e150 (the kernels' rescaling by |v| + R at work) agree bit for bit."""
    poly, kwargs, states = case
    py, c = pair(poly, **kwargs)  # type: ignore[arg-type]
    for p, v in states:  # type: ignore[attr-defined]
        args = (*p.tolist(), *v.tolist())
        assert bits(c._law(*args)) == bits(py._law(*args)), args


@given(cases())
def test_batches_bit_identical(case: tuple[object, ...]) -> None:
    """``zones_batch`` through the compiled loop equals the Python reference loop bit for bit."""
    poly, kwargs, states = case
    py, c = pair(poly, **kwargs)  # type: ignore[arg-type]
    P = np.array([p for p, _ in states])  # type: ignore[attr-defined]
    V = np.array([v for _, v in states])  # type: ignore[attr-defined]
    out_c, zones_c = c.zones_batch(P, V)
    out_p, zones_p = py.zones_batch(P, V)
    assert out_c.tobytes() == out_p.tobytes()
    assert zones_c.tolist() == zones_p.tolist()
    # and each row equals the single call
    for r in range(len(P)):
        assert out_c[r].tobytes() == c.shape(P[r], V[r]).tobytes()


def test_reference_kernel_directly() -> None:
    """The binding against the module-level reference kernels on a fixed octagon grid (incl. zones
    and stages), with the 10-tuple layout of ``exact_kernel`` / ``patent_kernel``."""
    from velfence.geometry.polygon import ConvexPolygon

    ang = np.linspace(0.0, 2.0 * math.pi, 9)[:-1]
    poly = ConvexPolygon(np.c_[np.cos(ang), np.sin(ang)])
    nx, ny, off, cx, cy, a0, beta, n = poly.kernel_data
    prm = (0.2, 1.0, 0.2, 0.0, 0.0, 0.0)
    exact = core.ExactLaw(nx, ny, off, cx, cy, n, kern.PROFILE_LINEAR, prm, True, 0.0)
    patent = core.PatentLaw(nx, ny, off, cx, cy, a0, beta, n, 0.2, 1.0, 0.3, 0.0)
    grid = np.linspace(-1.2, 1.2, 25)
    zones = set()
    for px in grid:
        for py in grid:
            for vx, vy in ((1.0, 0.3), (-2.0, 0.5), (0.0, 0.0)):
                ref = kern.exact_kernel(
                    px, py, vx, vy, nx, ny, off, cx, cy, n, kern.PROFILE_LINEAR, prm, True, 0.0,
                    [0.0] * n, [0.0] * n, [0] * n,
                )  # fmt: skip
                assert bits(exact.law(px, py, vx, vy)) == bits(ref)
                zones.add(ref[2])
                ref = kern.patent_kernel(
                    px, py, vx, vy, nx, ny, off, cx, cy, a0, beta, n, 0.2, 1.0, 0.3, 0.0
                )
                assert bits(patent.law(px, py, vx, vy)) == bits(ref)
    assert zones == {0, 1, 2, 3, 4}  # every zone was compared


def test_checked_api_never_non_finite() -> None:
    """The checked C API (vf_*_shape) answers non-finite input and overflow with the documented
    stop result and return code, never a non-finite number."""
    from velfence.geometry.polygon import ConvexPolygon

    poly = ConvexPolygon(np.array([[-1.0, -0.5], [1.0, -0.5], [1.0, 0.5], [-1.0, 0.5]]))
    nx, ny, off, cx, cy, a0, beta, n = poly.kernel_data
    exact = core.ExactLaw(nx, ny, off, cx, cy, n, 0, (0.2, 1.0, 0.2, 0, 0, 0), True, 0.0)
    patent = core.PatentLaw(nx, ny, off, cx, cy, a0, beta, n, 0.2, 1.0, 0.3, 0.0)
    stop = (0.0, 0.0, kern.ZONE_INVALID, -1, -1, 0.0, 0.0, 0.0, 0.0, kern.STAGE_STOP)
    for law in (exact, patent):
        for bad in (math.nan, math.inf, -math.inf):
            for k in range(4):
                args = [0.1, 0.2, 0.3, 0.4]
                args[k] = bad
                assert law.shape(*args) == (-3, stop)
        rc, res = law.shape(0.95, 0.4, 1.0, 1.0)
        assert rc == 0
        assert bits(res) == bits(law.law(0.95, 0.4, 1.0, 1.0))
    # patent outside the left edge: spring + command overflow; the raw kernel says inf
    assert not math.isfinite(patent.law(-1.7e308, 0.0, 1.7e308, 0.0)[0])
    assert patent.shape(-1.7e308, 0.0, 1.7e308, 0.0) == (-4, stop)


def test_binding_refuses_bad_data() -> None:
    """The binding's constructors run vf_*_check: bad data is refused, not shaped."""
    with pytest.raises(ValueError, match="at least 3"):
        core.ExactLaw((1.0,), (0.0,), (0.0,), 0.0, 0.0, 1, 0, (1, 1, 1, 0, 0, 0), True, 0.0)
    with pytest.raises(ValueError, match="vf_exact_check"):
        core.ExactLaw(
            (1.0, 0.0, -1.0), (0.0, 1.0, math.nan), (0.0, 0.0, 0.0), 0.0, 0.0, 3, 0,
            (1, 1, 1, 0, 0, 0), True, 0.0,
        )  # fmt: skip
    with pytest.raises(ValueError, match="expected 3 floats"):
        core.ExactLaw((1.0, 0.0), (0.0, 1.0, 0.0), (0.0,) * 3, 0.0, 0.0, 3, 0, (1,) * 6, True, 0.0)
    law = core.ExactLaw(
        (1.0, 0.0, -1.0), (0.0, 1.0, 0.0), (0.0, 0.0, -1.0), 0.0, 0.0, 3, 0, (0.1, 1, 1, 0, 0, 0),
        True, 0.0,
    )  # fmt: skip
    with pytest.raises(TypeError, match="4 arguments"):
        law.law(1.0, 2.0)
    with pytest.raises(TypeError, match="format 'd'"):
        law.batch(np.zeros((2, 2), dtype=np.float32), np.zeros((2, 2)), np.zeros((2, 2)),
                  np.zeros(2, dtype=np.int64))  # fmt: skip
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        law.batch(np.zeros((3, 2)), np.zeros((2, 2)), np.zeros((2, 2)), np.zeros(2, dtype=np.int64))


@given(cases())
def test_shape_fast_path_bit_identical(case: tuple[object, ...]) -> None:
    """``shape`` with the core (float64 arrays: straight to C; lists: the generic path) returns
    the reference's output bit for bit, as a fresh float64 array of shape (2,)."""
    poly, kwargs, states = case
    py, c = pair(poly, **kwargs)  # type: ignore[arg-type]
    for p, v in states:  # type: ignore[attr-defined]
        ref = py.shape(p, v)
        fast = c.shape(p, v)
        assert (fast.dtype, fast.shape) == (np.float64, (2,))
        assert fast.tobytes() == ref.tobytes()
        assert c.shape(p.tolist(), v.tolist()).tobytes() == ref.tobytes()
        assert (
            c.shape(p[::1].astype(np.float32), v).tobytes()
            == py.shape(p.astype(np.float32), v).tobytes()
        )
    fast[0] = 123.0  # a fresh array each call
    p, v = states[0]  # type: ignore[index]
    assert c.shape(p, v).tobytes() == py.shape(p, v).tobytes()


def test_shape_fast_path_keeps_the_invalid_policy() -> None:
    """Non-finite input and overflow leave the fast path: the on_invalid policy answers."""
    from velfence.errors import InvalidInput
    from velfence.geometry.polygon import ConvexPolygon

    box = ConvexPolygon(np.array([[-1.0, -0.5], [1.0, -0.5], [1.0, 0.5], [-1.0, 0.5]]))
    for method in ("exact", "edge-scaling"):
        raising = PolygonShaper(box, buffer=0.2, method=method, backend="c")
        stopping = PolygonShaper(box, buffer=0.2, method=method, backend="c", on_invalid="stop")
        bad = np.array([math.nan, 0.0])
        with pytest.raises(InvalidInput, match="non-finite input"):
            raising.shape(bad, np.array([1.0, 0.0]))
        assert stopping.shape(np.array([0.0, 0.0]), bad).tolist() == [0.0, 0.0]
    patent = PolygonShaper(box, buffer=0.2, method="edge-scaling", backend="c")
    huge = (np.array([-1.7e308, 0.0]), np.array([1.7e308, 0.0]))
    with pytest.raises(InvalidInput, match="overflowed"):
        patent.shape(*huge)


def test_half_built_objects_refuse_calls() -> None:
    """An object whose __init__ failed (or never ran) raises instead of reading freed memory."""
    nx, ny, off = (1.0, 0.0, -1.0), (0.0, 1.0, math.nan), (0.0, 0.0, -1.0)  # a NaN normal
    bad = {
        core.ExactLaw: (nx, ny, off, 0.0, 0.0, 3, 0, (0.1, 1, 1, 0, 0, 0), True, 0.0),
        core.PatentLaw: (nx, ny, off, 0.0, 0.0, 0.0, (0.0, 2.0, 4.0, 6.2), 3, 0.1, 1, 0.3, 0.0),
    }
    for cls, args in bad.items():
        obj = cls.__new__(cls)
        with pytest.raises(RuntimeError, match="not initialised"):
            obj.law(0.0, 0.0, 1.0, 0.0)
        with pytest.raises(ValueError, match="check"):  # refused after the allocation
            obj.__init__(*args)
        with pytest.raises(RuntimeError, match="not initialised"):
            obj.law(0.0, 0.0, 1.0, 0.0)
        assert obj.shape_array(np.zeros(2), np.ones(2)) is None
