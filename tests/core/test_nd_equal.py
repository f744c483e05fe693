"""The compiled n-D core (velfence_core._nd) computes the Python reference kernels bit for bit.

``project_kernel`` (the dual active-set projection) and ``polytope_kernel`` (the n-D exact law)
are ported operation for operation (``-ffp-contract=off``, the same ``sqrt`` / ``pow``), so every
float is compared as its 8 bytes, on hypothesis-drawn polytopes (2–6 dimensions, bounded or not),
laws (built-in buffer with and without ``max_recovery_speed`` and ``dt``, ``LinearBuffer`` and
``ThreeZoneBraking`` profiles) and states. The safety filter's solve and bounds are compared the
same way; its obstacle rows (numpy in Python, scalar C in the core) agree to round-off.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from velfence.errors import InvalidInput
from velfence.filter.rows import PLAIN_BOUNDS, rate_bounds
from velfence.geometry.polytope import ConvexPolytope
from velfence.geometry.projection import project
from velfence.shaping import PolytopeShaper
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking

nd = pytest.importorskip(
    "velfence_core._nd",
    reason="the compiled core's n-D module is not installed (pip install ./core)",
)


def fbits(xs: Any) -> list[bytes]:
    """Every float as its 8 bytes (``0.0`` and ``-0.0`` differ, ``nan`` equals ``nan``)."""
    return [struct.pack("<d", float(x)) for x in xs]


def rbits(r: tuple[Any, ...]) -> tuple[Any, ...]:
    return tuple(struct.pack("<d", x) if isinstance(x, float) else x for x in r)


@st.composite
def polytopes(draw: st.DrawFn) -> ConvexPolytope:
    """Random unit normals around the origin (inside every facet by 0.3–2), or a box."""
    dim = draw(st.integers(2, 6))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if draw(st.booleans()):
        lo = -rng.uniform(0.3, 2.0, dim)
        return ConvexPolytope.box(lo, rng.uniform(0.3, 2.0, dim))
    nf = draw(st.integers(1, 16))
    N = rng.normal(size=(nf, dim))
    N /= np.linalg.norm(N, axis=1)[:, None]
    return ConvexPolytope(N, -rng.uniform(0.3, 2.0, nf))


_LAWS = ("exact", "exact-rmax", "exact-dt", "linear-profile", "three-zone")


def law_kwargs(poly: ConvexPolytope, law: str, frac: float, gain: float) -> dict[str, Any]:
    width = frac * min(poly.chebyshev_radius, 1.0)
    if law == "exact":
        return {"buffer": width, "spring_gain": gain}
    if law == "exact-rmax":
        return {"buffer": width, "spring_gain": gain, "max_recovery_speed": 0.5 * gain + 0.01}
    if law == "exact-dt":
        return {"buffer": width, "spring_gain": gain, "dt": 0.01 + frac * 0.1}
    if law == "linear-profile":
        return {"profile": LinearBuffer(buffer=width, spring_gain=gain)}
    return {"profile": ThreeZoneBraking(gain=gain + 2.5, max_speed=1.0, max_acceleration=2.0)}


@st.composite
def cases(draw: st.DrawFn, *, bound: float = 3.0) -> tuple[Any, ...]:
    poly = draw(polytopes())
    law = draw(st.sampled_from(_LAWS))
    kwargs = law_kwargs(
        poly, law, draw(st.floats(0.05, 1.0)), draw(st.floats(0.0, 20.0, allow_subnormal=False))
    )
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    dim = poly.dim
    scale = draw(st.sampled_from([1e-3, 1.0, bound]))
    states = [(rng.uniform(-2.5, 2.5, dim), rng.normal(size=dim) * scale) for _ in range(12)]
    return poly, kwargs, states


def pair(poly: ConvexPolytope, **kwargs: Any) -> tuple[PolytopeShaper, PolytopeShaper]:
    py = PolytopeShaper(poly, backend="python", accelerate=False, **kwargs)
    c = PolytopeShaper(poly, backend="c", **kwargs)
    assert (py.backend, c.backend) == ("python", "c")
    return py, c


def same_run(py: PolytopeShaper, c: PolytopeShaper, p: np.ndarray, v: np.ndarray) -> None:
    """``_run`` (what shape and explain use): output, result tuple, active, distances, bounds."""
    o1, r1, a1, d1, (b1, w1) = py._run(p, v)
    o2, r2, a2, d2, (b2, w2) = c._run(p, v)
    where = (p.tolist(), v.tolist())
    assert fbits(o2) == fbits(o1), where
    assert rbits(tuple(r2)) == rbits(tuple(r1)), where
    q, m = r1[2], r1[7]
    assert list(a2)[:q] == list(a1)[:q], where
    assert fbits(d2) == fbits(d1), where
    assert list(w2)[:m] == list(w1)[:m], where
    assert fbits(b2[e] for e in list(w1)[:m]) == fbits(b1[e] for e in list(w1)[:m]), where


@settings(max_examples=60)
@given(cases())
def test_law_bit_identical(case: tuple[Any, ...]) -> None:
    poly, kwargs, states = case
    py, c = pair(poly, **kwargs)
    for p, v in states:
        same_run(py, c, p, v)
        assert fbits(c.shape(p, v)) == fbits(py.shape(p, v))


@settings(max_examples=40)
@given(cases(bound=1e150))
def test_huge_commands_bit_identical(case: tuple[Any, ...]) -> None:
    """Commands up to 1e150 (the kernel's rescaling and its second, shortened solve)."""
    poly, kwargs, states = case
    py, c = pair(poly, **kwargs)
    for p, v in states:
        same_run(py, c, p, v)


@settings(max_examples=30)
@given(cases())
def test_explain_and_batches_identical(case: tuple[Any, ...]) -> None:
    poly, kwargs, states = case
    py, c = pair(poly, on_invalid="stop", **kwargs)
    P = np.array([s[0] for s in states])
    V = np.array([s[1] for s in states])
    P[3, 0] = np.nan  # an invalid row: zero velocity, zone "invalid" on both
    o1, z1 = py.zones_batch(P, V)
    o2, z2 = c.zones_batch(P, V)
    assert fbits(o2.ravel()) == fbits(o1.ravel())
    assert z2.tolist() == z1.tolist()
    for p, v in states[:4]:
        e1, e2 = py.explain(p, v), c.explain(p, v)
        assert fbits(e2.output) == fbits(e1.output)
        assert (e2.zone, e2.active, e2.binding, e2.stages) == (
            e1.zone,
            e1.active,
            e1.binding,
            e1.stages,
        )
        assert fbits(e2.lower) == fbits(e1.lower)
        assert fbits(e2.slack) == fbits(e1.slack)


def test_shape_fast_path_and_generic_path_agree() -> None:
    """Lists, other dtypes and inputs beyond 1e150 take the generic path: the same answers."""
    poly = ConvexPolytope.box([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])
    py, c = pair(poly, buffer=0.2)
    p, v = np.array([0.95, 0.0, 0.9]), np.array([1.0, 0.5, 2.0])
    fast = c.shape(p, v)
    assert fbits(fast) == fbits(c.shape(p.tolist(), v.tolist())) == fbits(py.shape(p, v))
    assert fbits(c.shape(p.astype(np.float32), v)) == fbits(py.shape(p.astype(np.float32), v))
    with pytest.raises(InvalidInput, match="command"):
        c.shape(p, np.array([1e200, 0.0, 0.0]))


@st.composite
def problems(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n = draw(st.integers(1, 8))
    m = draw(st.integers(0, 30))
    G = rng.normal(size=(m, n))
    if m and draw(st.booleans()):
        G[rng.integers(0, m)] = 0.0  # a zero row
    x0 = rng.normal(size=n)
    feasible = draw(st.booleans())
    b = G @ x0 - (rng.uniform(0.0, 1.0, m) if feasible else rng.normal(size=m))
    if m and draw(st.booleans()):
        b[rng.integers(0, m)] = -np.inf
    u = rng.normal(size=n) * draw(st.sampled_from([1e-6, 1.0, 1e6]))
    return u, G, b


@given(problems())
def test_projection_bit_identical(prob: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    same_projection(*prob)


def _hexes(text: str) -> np.ndarray:
    return np.array([float.fromhex(t) for t in text.split()])


def test_projection_rows_of_extreme_scale_bit_identical() -> None:
    """A problem fuzz_nd found (core/fuzz/crashes/nd-project-extreme-scale-overfull-active-set):
    15 rows in 2-D with norms from 1e-162 to 1e117. Gram-Schmidt of such rows leaves the basis
    far from orthonormal, and the third row was taken as independent of two active ones, a third
    active row in 2-D written past the end of the active set. Both kernels now stop at n active
    rows, and agree."""
    u = np.zeros(2)
    G = _hexes(
        "0x1.021cp-837 -0x1.2c2c2c2008p+45 -0x1.fcf8p-1 0x1.020008008008p-1015 "
        "0x1.6464646464646p+101 -0x1.418p-191 -0x1.418p-191 -0x1.418p-191 -0x1.418p-191 "
        "-0x1.768p-191 -0x1.418p-191 0x1.1be8p+389 0x1.fffffffffffffp+1023 "
        "0x1.fffffffffffffp+1023 0x1p-844 -0x0p+0 -0x0p+0 -0x0p+0 0x1.68p-6 0x0.051515151p-1022 "
        "-0x1.e9fp-537 -0x1.f1f8p-537 0x1.82p-196 -0x1.f1fp-537 -0x1.f1f8p-537 -0x1.f1f8p-537 "
        "-0x1.f1f8p-537 -0x1.f1f8p-537 -0x1.f1f8p-537 -0x1.f1f8p-537"
    ).reshape(15, 2)
    b = _hexes(
        "-0x1.f1f8p-537 -0x1.f1f8p-537 -0x1.f1f8p-537 -0x1.f1f8p-537 -0x1.f1f8p-537 -0x0p+0 "
        "0x1p-485 -0x1.e9fp-280 -0x0p+0 -0x0p+0 0x1p-286 0x0.0c2c2464646c2p-1022 0x0p+0 0x0p+0 "
        "0x0p+0"
    )
    q = same_projection(u, G, b)
    assert q <= 2


def same_projection(u: np.ndarray, G: np.ndarray, b: np.ndarray) -> int:
    """The C projection and the Python kernel agree bit for bit; returns the active count."""
    # project() refuses -inf bounds and normals beyond 1e150 (the kernels take both)
    checked = np.isfinite(b).all() and np.abs(G).max(initial=0.0) <= 1e150
    ref = project(u, G, b) if checked else None
    status, q, iters, x, act, lam = nd.project_full(u, np.ascontiguousarray(G), b)
    # the plain kernel itself (project() refuses -inf bounds; the kernel ignores those rows)
    from velfence.geometry.projection import project_kernel, projection_scratch

    wsf, lam_r, act_r = projection_scratch(G.shape[0], u.shape[0])
    xr = np.zeros(u.shape[0])
    with np.errstate(all="ignore"):  # the kernel overflows to inf as C does, without a warning
        s_r, q_r, it_r = project_kernel(
            u.tolist(), G.ravel().tolist(), b.tolist(), G.shape[0], u.shape[0], xr, lam_r, act_r,
            wsf.tolist(),
        )  # fmt: skip
    assert (status, q, iters) == (s_r, q_r, it_r)
    assert fbits(x) == fbits(xr)
    assert act == act_r[:q].tolist()
    assert fbits(lam) == fbits(lam_r[:q])
    if ref is not None:
        assert fbits(ref.x) == fbits(x)
        assert ref.feasible == (status == 0)
    s2, x2 = nd.project(u, np.ascontiguousarray(G), b)
    assert s2 == status
    assert fbits(x2) == fbits(x)
    return int(q)


@given(
    st.integers(0, 2**32 - 1),
    st.sampled_from(["linear", "three-zone"]),
    st.sampled_from([0.0, 250.0]),
)
def test_filter_bounds_bit_identical(seed: int, kind: str, idt: float) -> None:
    rng = np.random.default_rng(seed)
    prof: Any = (
        LinearBuffer(buffer=0.1, spring_gain=2.0, max_recovery_speed=1.5)
        if kind == "linear"
        else ThreeZoneBraking(gain=2.0 * 10.0 / 1.5, max_speed=1.5, max_acceleration=10.0)
    )
    dist = rng.uniform(-0.3, 0.6, 14)
    speed = float(rng.uniform(0.0, 3.0))
    ref = rate_bounds(prof, dist, speed, idt, PLAIN_BOUNDS)
    got = rate_bounds(prof, dist, speed, idt, (None, nd))
    assert fbits(got) == fbits(ref)
