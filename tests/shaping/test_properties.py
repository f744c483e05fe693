"""Hypothesis properties of PolygonShaper over random convex polygons, positions and commands.

Each property is the strongest statement the law guarantees (see test_polygon_exact.py for the
one that does *not* hold literally: the exact law may add outward speed toward one edge of an
acute corner, within that edge's bound). The exact law is cross-checked against a QP solver
(qpsolvers + daqp) with the bounds assembled independently from the law's statement.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import assume, given, note
from hypothesis import strategies as st

from optional import requires_qp
from strategies import convex_polygons, min_interior_width, positions, random_points, vectors
from velfence import ConvexPolygon, InvalidInput, PolygonShaper
from velfence.shaping import ZONE_NAMES

QP_TOL = 1e-9  # target: exact == QP to 1e-9 (relative to the speed scale |v| + R) ...
# ... plus an absolute floor [velocity units] for positions within round-off of an edge, where the
# signed distances (and so the bounds) are themselves only known to ~1e-15.
QP_ABS_TOL = 1e-12
BOUND_TOL = 1e-11  # a bound the kernel enforces (its own feasibility tolerance is 1e-12·(1 + |b|))
CONTAIN_TOL = 1e-12  # closed-loop containment, workspace units
# The kernel's and NumPy's signed distances differ in the last bit: a point exactly on an edge may
# be outside for one and inside for the other. Inside-only properties start this far in.
INSIDE_MARGIN = 1e-12
# daqp's default primal tolerance (1e-6) would let the reference itself be off by ~1e-7.
DAQP_PRIMAL_TOL = 1e-14


def norm(a: np.ndarray) -> float:
    """Euclidean norm of a 2-vector without under/overflow (np.linalg.norm squares first)."""
    return math.hypot(float(a[0]), float(a[1]))


@dataclass(frozen=True)
class Scenario:
    poly: ConvexPolygon
    buffer: float
    k: float
    rmax: float | None
    p: np.ndarray
    v: np.ndarray

    def shaper(self, method: str, **kw: object) -> PolygonShaper:
        return PolygonShaper(
            self.poly,
            buffer=self.buffer,
            spring_gain=self.k,
            max_recovery_speed=self.rmax,
            method=method,
            **kw,  # type: ignore[arg-type]
        )


@st.composite
def near_boundary(draw: st.DrawFn, poly: ConvexPolygon, buffer: float, side: str) -> np.ndarray:
    """A point within 1.5 buffers of an edge (on the requested side), or 2 of a corner."""
    i = draw(st.integers(0, poly.n - 1))
    if side != "any" or draw(st.booleans()):
        t = draw(st.floats(0.0, 1.0))
        lo, hi = {"any": (-1.5, 1.5), "inside": (1e-9, 1.5), "outside": (-1.5, -1e-9)}[side]
        s = draw(st.floats(lo, hi)) * buffer
        c, e = poly.corners[i], poly.corners[(i + 1) % poly.n] - poly.corners[i]
        return c + t * e + s * poly.normals[i]
    r = draw(st.floats(0.0, 2.0)) * buffer
    a = draw(st.floats(0.0, 2 * math.pi))
    return poly.corners[i] + r * np.array([math.cos(a), math.sin(a)])


@st.composite
def radial(draw: st.DrawFn, poly: ConvexPolygon, side: str) -> np.ndarray:
    """C + t·(q - C) for a boundary point q: inside for t <= 1, outside for t > 1."""
    lo, hi = {"any": (0.0, 1.6), "inside": (0.0, 1.0 - 1e-9), "outside": (1.0 + 1e-9, 1.6)}[side]
    i = draw(st.integers(0, poly.n - 1))
    u = draw(st.floats(0.0, 1.0))
    q = poly.corners[i] + u * (poly.corners[(i + 1) % poly.n] - poly.corners[i])
    return poly.centroid + draw(st.floats(lo, hi)) * (q - poly.centroid)


@st.composite
def scenarios(draw: st.DrawFn, side: str = "any") -> Scenario:
    """Polygon, parameters, position (biased to the buffer and corners) and command."""
    poly = draw(convex_polygons())
    # up to the inradius, the widest buffer the shapers admit (wider ones are refused)
    buffer = draw(st.floats(0.05, 1.0)) * poly.inradius
    k = draw(st.sampled_from([0.0, 0.5, 3.0, 20.0]))
    # None: the default r_max = k·buffer (0 for k = 0: outward motion stopped, no recovery)
    rmax = draw(st.one_of(st.none(), st.floats(0.05, 5.0)))
    where = [near_boundary(poly, buffer, side), radial(poly, side)]
    if side == "any":
        where.append(positions(poly, spread=1.6))
    p = draw(st.one_of(*where))
    v = draw(st.one_of(vectors(3.0), st.just(np.zeros(2))))
    return Scenario(poly, buffer, k, rmax, p, v)


def law_bounds(sc: Scenario, sh: PolygonShaper) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(d, b, violated, R) for every edge, assembled from the law's statement (not the kernel).

    ``d_i = n_i·p - o_i`` is evaluated in the same operation order as the kernel: NumPy's matmul
    can differ in the last bit, which flips "on the edge" to "just outside" and changes R.
    """
    px, py = (float(x) for x in sc.p)
    d = np.array(
        [
            float(nx) * px + float(ny) * py - float(o)
            for (nx, ny), o in zip(sc.poly.normals, sc.poly.offsets, strict=True)
        ]
    )
    viol = d < 0
    rec = np.minimum(sh.spring_gain * -d, sh.max_recovery_speed)
    R = float(rec[viol].max()) if viol.any() else 0.0
    b = np.where(viol, rec, -(norm(sc.v) + R) * d / sh.buffer)
    return d, b, viol, R


def qp_reference(sc: Scenario, sh: PolygonShaper) -> tuple[np.ndarray, bool]:
    """min ||x - v||² s.t. N x >= b by daqp; violated-edge bounds only if that is infeasible.

    daqp's tolerances are absolute, so the data is brought to O(1) first: the problem is
    positively homogeneous, x(s·v, s·b) = s·x(v, b).
    """
    from qpsolvers import solve_qp

    _, b, viol, R = law_bounds(sc, sh)
    s = _scale(sc, R)
    N = sc.poly.normals
    x = solve_qp(np.eye(2), -sc.v / s, -N, -b / s, solver="daqp", primal_tol=DAQP_PRIMAL_TOL)
    if x is not None:
        return s * np.asarray(x), False
    x = solve_qp(
        np.eye(2), -sc.v / s, -N[viol], -b[viol] / s, solver="daqp", primal_tol=DAQP_PRIMAL_TOL
    )
    assert x is not None
    return s * np.asarray(x), True


def _scale(sc: Scenario, R: float) -> float:
    """The law's speed scale |v| + R (1 if both are 0): tolerances are relative to it."""
    return norm(sc.v) + R or 1.0


# ---------------------------------------------------------------------------- free zone
@given(
    convex_polygons(),
    st.floats(0.05, 0.95),
    st.floats(0.0, 0.999),
    st.floats(0.0, 2 * math.pi),
    vectors(5.0),
    st.sampled_from(["patent", "exact"]),
)
def test_free_zone_pass_through(poly, frac, rad, ang, v, method) -> None:
    w = min_interior_width(poly)
    buffer = frac * w
    p = poly.centroid + rad * (w - buffer) * np.array([math.cos(ang), math.sin(ang)])
    assert poly.signed_distances(p).min() >= buffer
    sh = PolygonShaper(poly, buffer=buffer, spring_gain=2.0, method=method)
    np.testing.assert_array_equal(sh.shape(p, v), v)
    assert sh.explain(p, v).zone == "free"


# ---------------------------------------------------------------------------- inside
@given(scenarios("inside"))
def test_exact_inside(sc: Scenario) -> None:
    d = sc.poly.signed_distances(sc.p)
    assume(d.min() >= INSIDE_MARGIN)
    sh = sc.shaper("exact")
    out = sh.shape(sc.p, sc.v)
    speed = norm(sc.v)
    # (e) never faster than the command
    assert norm(out) <= speed * (1 + 1e-12)
    # every nearby edge at once: outward speed toward edge i at most |v|·d_i/d_max
    near = d < sc.buffer
    nv_o = sc.poly.normals @ out
    assert np.all(nv_o[near] >= -speed * d[near] / sc.buffer - BOUND_TOL * max(1.0, speed))
    # and no edge gets more outward speed than the command had, unless two nearby edges meet at
    # an acute angle (then the projection slides along one of them; see test_polygon_exact).
    Nn = sc.poly.normals[near]
    if np.all(Nn @ Nn.T >= 0):
        nv = sc.poly.normals @ sc.v
        assert np.all(nv_o[near] >= nv[near] - BOUND_TOL * max(1.0, speed))


@given(scenarios("inside"))
def test_patent_inside(sc: Scenario) -> None:
    d = sc.poly.signed_distances(sc.p)
    assume(d.min() >= INSIDE_MARGIN)
    sh = sc.shaper("patent")
    r = sh.explain(sc.p, sc.v)
    out = r.output
    speed = norm(sc.v)
    tol = BOUND_TOL * max(1.0, speed)
    assert norm(out) <= speed * (1 + 1e-12)
    if r.zone == "free":
        np.testing.assert_array_equal(out, sc.v)
        return
    n1, n2 = sc.poly.normals[r.primary], sc.poly.normals[r.secondary]
    # The primary edge's outward speed is at most |v|·d1/d_max (the last stage guarantees it).
    assert n1 @ out >= -speed * r.d1 / sc.buffer - tol
    if r.zone == "buffer":  # one edge: tangent kept, normal speed never more outward
        t1 = np.array([-n1[1], n1[0]])
        assert t1 @ out == pytest.approx(t1 @ sc.v, abs=tol)
        assert n1 @ out >= n1 @ sc.v - tol
    elif n1 @ n2 >= 0:  # right or obtuse corner: neither stage undoes the other
        assert n1 @ out >= n1 @ sc.v - tol
        assert n2 @ out >= n2 @ sc.v - tol


# ---------------------------------------------------------------------------- outside
@given(scenarios("outside"))
def test_exact_outside_reduces_every_violation(sc: Scenario) -> None:
    d = sc.poly.signed_distances(sc.p)
    assume(d.min() < 0)
    sh = sc.shaper("exact")
    out = sh.shape(sc.p, sc.v)
    _, b, viol, R = law_bounds(sc, sh)
    nv_o = sc.poly.normals @ out
    # relaxed or not, every violated edge gets its recovery speed min(k·pen, r_max) ...
    assert np.all(nv_o[viol] >= b[viol] - BOUND_TOL * _scale(sc, R))
    # ... which is > 0 whenever there is a spring: no deadlock, even for a zero command
    if sh.spring_gain > 0:
        assert np.all(nv_o[viol] > 0)


@given(scenarios("outside"))
def test_patent_outside(sc: Scenario) -> None:
    d = sc.poly.signed_distances(sc.p)
    assume(d.min() < 0)
    sh = sc.shaper("patent")
    r = sh.explain(sc.p, sc.v)
    assume(r.d1 < 0)  # the wedge's own edge is violated (else the patent treats P as inside)
    n1, n2 = sc.poly.normals[r.primary], sc.poly.normals[r.secondary]
    tol = BOUND_TOL * max(1.0, norm(sc.v), sh.spring_gain * -r.d1)
    # outward motion through the primary edge is zeroed and the spring only adds inward motion;
    # the secondary stage can undo part of it only at an acute corner.
    if r.zone == "outside" or n1 @ n2 >= 0:
        assert n1 @ r.output >= max(n1 @ sc.v, 0.0) - tol
        if sh.spring_gain > 0:
            assert n1 @ r.output > 0


# ---------------------------------------------------------------------------- QP agreement
# Largest |exact - QP| / (|v| + R) seen over cases with |v| + R >= 1e-6, for the report.
QP_MAX_DIFF = [0.0]


@requires_qp
@given(scenarios())
def test_exact_agrees_with_qp_solver(sc: Scenario) -> None:
    sh = sc.shaper("exact")
    r = sh.explain(sc.p, sc.v)
    ref, relaxed = qp_reference(sc, sh)
    _, b, _, R = law_bounds(sc, sh)
    scale = _scale(sc, R)
    diff = float(np.abs(r.output - ref).max())
    if scale >= 1e-6:
        QP_MAX_DIFF[0] = max(QP_MAX_DIFF[0], diff / scale)
    note(f"zone={r.zone} stages={r.stages} relaxed(QP)={relaxed} diff={diff:.3g} scale={scale}")
    assert diff <= QP_TOL * scale + QP_ABS_TOL
    # Both relax exactly when the full bound set is infeasible; on the feasibility border (the
    # set shrinks to a point) they may disagree, but then the answer meets every bound anyway.
    slack = float((sc.poly.normals @ r.output - b).min())
    if "relaxed" not in r.stages:
        assert slack >= -BOUND_TOL * scale - QP_ABS_TOL
    if ("relaxed" in r.stages) != relaxed:
        assert slack >= -QP_TOL * scale - QP_ABS_TOL


# ---------------------------------------------------------------------------- batch == loop
@given(convex_polygons(), st.integers(0, 2**32 - 1), st.floats(0.05, 2.0))
def test_batch_equals_loop(poly: ConvexPolygon, seed: int, bfrac: float) -> None:
    rng = np.random.default_rng(seed)
    P = random_points(rng, poly, 40, spread=1.8)
    V = rng.normal(size=(40, 2)) * rng.uniform(0, 3, size=(40, 1))
    V[::7] = 0.0
    buffer = min(bfrac, 1.0) * poly.inradius  # wider buffers are refused
    for method, accelerate, dt in itertools.product(
        ("patent", "exact"), (True, False), (None, 0.05)
    ):
        sh = PolygonShaper(
            poly, buffer=buffer, spring_gain=3.0, method=method, accelerate=accelerate, dt=dt
        )
        out, zones = sh.zones_batch(P, V)
        loop = np.array([sh.shape(p, v) for p, v in zip(P, V, strict=True)])
        np.testing.assert_array_equal(out, loop)
        names = [sh.explain(p, v).zone for p, v in zip(P, V, strict=True)]
        assert [ZONE_NAMES[z] for z in zones] == names


# ---------------------------------------------------------------------------- closed loop
@given(
    convex_polygons(),
    st.floats(0.05, 3.0),
    st.integers(0, 10**6),
    st.floats(0.0, 0.999),
    st.floats(0.0, 1.0),
    st.floats(0.05, 0.95),
    vectors(5.0),
)
def test_exact_closed_loop_never_crosses(poly, bfrac, corner, t, u, c, v) -> None:
    speed = norm(v)
    assume(speed > 1e-3)
    buffer = min(bfrac, 1.0) * poly.inradius  # wider buffers are refused
    dt = c * buffer / speed  # dt·|v| < buffer
    i = corner % poly.n
    edge_point = poly.corners[i] + u * (poly.corners[(i + 1) % poly.n] - poly.corners[i])
    p = poly.centroid + t * (edge_point - poly.centroid)
    sh = PolygonShaper(poly, buffer=buffer, spring_gain=2.0, method="exact")
    dmin = math.inf
    for _ in range(300):
        p = p + dt * sh.shape(p, v)
        dmin = min(dmin, float(poly.signed_distances(p).min()))
    note(f"dmin={dmin}")
    assert dmin >= -CONTAIN_TOL


# ---------------------------------------------------------------------------- invalid input
NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])
FINITE = st.floats(-5.0, 5.0)


@given(
    st.lists(st.one_of(NON_FINITE, FINITE), min_size=4, max_size=4).filter(
        lambda xs: not all(math.isfinite(x) for x in xs)
    ),
    st.sampled_from(["patent", "exact"]),
)
def test_non_finite_input(xs: list[float], method: str) -> None:
    poly = ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])
    p, v = np.array(xs[:2]), np.array(xs[2:])
    raising = PolygonShaper(poly, buffer=0.2, spring_gain=4.0, method=method)
    with pytest.raises(InvalidInput, match="finite"):
        raising.shape(p, v)
    with pytest.raises(InvalidInput, match="finite"):
        raising.explain(p, v)
    with pytest.raises(InvalidInput, match=r"finite.*row\(s\) \[1\]"):
        raising.shape_batch(np.array([[1.0, 1.0], p]), np.array([[0.0, 0.0], v]))
    stopping = PolygonShaper(poly, buffer=0.2, spring_gain=4.0, method=method, on_invalid="stop")
    np.testing.assert_array_equal(stopping.shape(p, v), [0.0, 0.0])
    r = stopping.explain(p, v)
    assert r.zone == "invalid"
    assert r.stages == ("stop",)
    np.testing.assert_array_equal(r.output, [0.0, 0.0])
    out, zones = stopping.zones_batch(np.array([[1.0, 1.0], p]), np.array([[0.3, 0.0], v]))
    np.testing.assert_array_equal(out, [[0.3, 0.0], [0.0, 0.0]])
    assert zones.tolist() == [0, 5]


HUGE = st.one_of(
    st.floats(-1e300, 1e300),
    st.sampled_from([1e300, -1e300, 1.7e308, -1.7e308, 1e154, 5e-324, 0.0]),
)


@given(st.tuples(HUGE, HUGE, HUGE, HUGE), st.sampled_from(["patent", "exact"]))
def test_huge_finite_input_never_gives_nan(xs: tuple[float, ...], method: str) -> None:
    poly = ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])
    p, v = np.array(xs[:2]), np.array(xs[2:])
    raising = PolygonShaper(poly, buffer=0.2, spring_gain=4.0, method=method)
    try:
        out = raising.shape(p, v)
    except InvalidInput as exc:  # overflow is reported, never returned
        out, message = None, str(exc)
    if out is None:
        assert "too large" in message
        with pytest.raises(InvalidInput, match="too large"):
            raising.shape_batch(p[None], v[None])
    else:
        assert np.all(np.isfinite(out))
        np.testing.assert_array_equal(raising.shape_batch(p[None], v[None])[0], out)
    stopping = PolygonShaper(poly, buffer=0.2, spring_gain=4.0, method=method, on_invalid="stop")
    assert np.all(np.isfinite(stopping.shape(p, v)))
    assert np.all(np.isfinite(stopping.shape_batch(p[None], v[None])))
