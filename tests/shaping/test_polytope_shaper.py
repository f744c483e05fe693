"""PolytopeShaper: the exact law in n-D against the 2-D law, two QP solvers, and closed loops."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import velfence as vf
from strategies import convex_polygons
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polytope import ConvexPolytope
from velfence.shaping.polytope import PolytopeShaper

qpsolvers = pytest.importorskip("qpsolvers")

#: Agreement with an independent QP solver (its own accuracy is ~1e-12 on these sizes).
QP_TOL = 1e-9
#: Agreement with the 2-D law, relative to the command's speed (two different exact solves).
TWO_D_TOL = 1e-12


def random_polytope(rng: np.random.Generator, dim: int, m: int) -> ConvexPolytope:
    """A bounded polytope around the origin: a box of half-width 1 cut by m random facets."""
    N = rng.normal(size=(m, dim))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    off = -rng.uniform(0.4, 1.0, m)  # the origin is inside every cut
    box = ConvexPolytope.box(-np.ones(dim), np.ones(dim))
    return ConvexPolytope(np.vstack([box.normals, N]), np.concatenate([box.offsets, off]))


def qp_reference(shaper: PolytopeShaper, p, v, solver: str) -> np.ndarray:
    """The same minimum-change problem (the shaper's own bounds) solved by a QP library."""
    normals, lower, _ = shaper.bound_rows(p, v)
    n = len(v)
    if len(lower) == 0:
        return np.asarray(v, dtype=float)
    x = qpsolvers.solve_qp(np.eye(n), -np.asarray(v), -normals, -lower, solver=solver)
    assert x is not None
    return x


# ---------------------------------------------------------------- n = 2: the polygon law
@settings(max_examples=60)
@given(
    poly=convex_polygons(),
    frac=st.floats(0.05, 0.95),
    seed=st.integers(0, 2**31 - 1),
    gain=st.floats(0.0, 5.0),
    use_dt=st.booleans(),
)
def test_two_d_equals_the_polygon_law(poly, frac, seed, gain, use_dt):
    rng = np.random.default_rng(seed)
    buffer = frac * poly.inradius
    dt = 0.01 if use_dt else None
    ref = vf.PolygonShaper(poly, buffer=buffer, spring_gain=gain, method="exact", dt=dt)
    P = ConvexPolytope.from_polygon(poly)
    for accelerate in (False, True):
        sh = PolytopeShaper(P, buffer=buffer, spring_gain=gain, dt=dt, accelerate=accelerate)
        for _ in range(20):
            p = poly.centroid + rng.uniform(-1.6, 1.6, 2) * (1.0 + np.ptp(poly.corners, axis=0))
            v = rng.normal(size=2) * rng.uniform(0.0, 3.0)
            a, b = ref.shape(p, v), sh.shape(p, v)
            scale = 1.0 + np.linalg.norm(v) + np.abs(a).max()
            np.testing.assert_allclose(b, a, rtol=0, atol=TWO_D_TOL * scale)
            ea, eb = ref.explain(p, v), sh.explain(p, v)
            assert ea.zone == eb.zone, (p, v, ea.zone, eb.zone)


@pytest.mark.parametrize(
    "profile",
    [
        vf.LinearBuffer(buffer=0.2, spring_gain=2.0),
        vf.ThreeZoneBraking.from_actuator_limits(gain=20.0, max_speed=2.0, max_acceleration=10.0),
    ],
    ids=["linear", "three-zone"],
)
def test_two_d_equals_the_polygon_law_with_a_profile(profile):
    poly = vf.ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])
    ref = vf.PolygonShaper(poly, method="exact", profile=profile)
    sh = PolytopeShaper(ConvexPolytope.from_polygon(poly), profile=profile)
    rng = np.random.default_rng(3)
    for _ in range(400):
        p = rng.uniform(-1.0, 3.0, 2)
        v = rng.normal(size=2) * 2.0
        np.testing.assert_allclose(sh.shape(p, v), ref.shape(p, v), atol=1e-12)
        assert sh.explain(p, v).zone == ref.explain(p, v).zone


def test_a_profile_the_kernels_do_not_know_runs_the_same_formulation():
    class Halved:
        """A linear buffer written by a user (not a kernel kind)."""

        def cap(self, delta: float, speed: float = 0.0) -> float:
            return speed * delta / 0.2 if delta >= 0.0 else max(1.5 * delta, -0.3)

        def zone(self, delta: float) -> int:
            return 0

    P = ConvexPolytope.box([0, 0, 0], [1, 1, 1])
    user = PolytopeShaper(P, profile=Halved())
    builtin = PolytopeShaper(P, profile=vf.LinearBuffer(buffer=0.2, spring_gain=1.5))
    rng = np.random.default_rng(9)
    for _ in range(200):
        p = rng.uniform(-0.3, 1.3, 3)
        v = rng.normal(size=3)
        np.testing.assert_allclose(user.shape(p, v), builtin.shape(p, v), atol=1e-12)
        assert user.explain(p, v).zone == builtin.explain(p, v).zone


# ---------------------------------------------------------------- against two QP solvers
@settings(max_examples=80)
@given(
    dim=st.integers(2, 7),
    extra=st.integers(0, 12),
    seed=st.integers(0, 2**31 - 1),
    spread=st.floats(0.5, 1.6),
    use_dt=st.booleans(),
)
def test_equals_two_qp_solvers(dim, extra, seed, spread, use_dt):
    rng = np.random.default_rng(seed)
    P = random_polytope(rng, dim, extra)
    buffer = 0.8 * min(0.3, P.chebyshev_radius)
    sh = PolytopeShaper(P, buffer=buffer, spring_gain=3.0, dt=0.01 if use_dt else None)
    for _ in range(10):
        p = rng.uniform(-spread, spread, dim)
        v = rng.normal(size=dim) * rng.uniform(0.0, 3.0)
        out = sh.shape(p, v)
        for solver in ("daqp", "quadprog"):
            ref = qp_reference(sh, p, v, solver)
            np.testing.assert_allclose(out, ref, atol=QP_TOL * (1 + np.abs(ref).max()))
        normals, lower, _ = sh.bound_rows(p, v)
        if not sh.explain(p, v).relaxed:
            assert np.all(normals @ out >= lower - 1e-12 * (1 + np.abs(lower)))


@pytest.mark.parametrize("case", ["vertex", "near-parallel", "outside-several"])
def test_degenerate_instances_equal_the_qp_solvers(case):
    rng = np.random.default_rng(11)
    dim = 3
    if case == "vertex":
        # A pyramid whose 12 side facets all meet at the apex (0, 0, 1): many facets active at
        # one vertex, far more than the dimension.
        k = 12
        ang = 2 * np.pi * np.arange(k) / k
        side = np.stack([-np.cos(ang), -np.sin(ang), -np.full(k, 0.5)], axis=1)
        side /= np.linalg.norm(side, axis=1, keepdims=True)
        N = np.vstack([side, [[0.0, 0.0, 1.0]]])
        off = np.concatenate([side @ np.array([0.0, 0.0, 1.0]), [-1.0]])
        P = ConvexPolytope(N, off, redundant="keep")
        points = [np.array([0.0, 0.0, 0.98]), np.array([0.01, -0.01, 1.05])]
    elif case == "near-parallel":
        tilt = 1e-6
        N = np.array([[1.0, 0.0, 0.0], [1.0, tilt, 0.0], [1.0, -tilt, 0.0]])
        box = ConvexPolytope.box([-1, -1, -1], [1, 1, 1])
        P = ConvexPolytope(
            np.vstack([box.normals, N]), np.concatenate([box.offsets, [-0.5, -0.5, -0.5]]),
            redundant="keep",
        )  # fmt: skip
        points = [np.array([-0.48, 0.2, 0.0]), np.array([-0.52, 0.0, 0.1])]
    else:
        P = ConvexPolytope.box([0, 0, 0], [1, 1, 1])
        points = [np.array([1.1, -0.2, 1.3]), np.array([-0.05, 1.02, -0.01])]
    sh = PolytopeShaper(P, buffer=0.05, spring_gain=2.0)
    for p in points:
        for _ in range(50):
            v = rng.normal(size=dim) * 2.0
            out = sh.shape(p, v)
            for solver in ("daqp", "quadprog"):
                ref = qp_reference(sh, p, v, solver)
                np.testing.assert_allclose(out, ref, atol=QP_TOL * (1 + np.abs(ref).max()))


def test_compiled_and_plain_python_kernels_agree():
    rng = np.random.default_rng(5)
    P = random_polytope(rng, 4, 6)
    fast = PolytopeShaper(P, buffer=0.2, spring_gain=2.0)
    slow = PolytopeShaper(P, buffer=0.2, spring_gain=2.0, accelerate=False)
    X = rng.uniform(-1.4, 1.4, (300, 4))
    V = rng.normal(size=(300, 4))
    a = fast.shape_batch(X, V)
    b = slow.shape_batch(X, V)
    # Not bit-identical (unlike the 2-D kernels): the compiled active-set loop differs from the
    # interpreted one in the last bits (measured: at most 7e-15 here).
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-13)
    loop = np.array([fast.shape(x, v) for x, v in zip(X, V, strict=True)])
    np.testing.assert_array_equal(a, loop)


# ---------------------------------------------------------------- closed loops
@pytest.mark.parametrize("dim", [2, 3, 4, 5, 6, 7])
def test_closed_loop_never_escapes_and_recovers(dim):
    rng = np.random.default_rng(100 + dim)
    P = random_polytope(rng, dim, 2 * dim)
    dt = 0.01
    buffer = 0.8 * min(0.2, P.chebyshev_radius)
    sh = PolytopeShaper(P, buffer=buffer, spring_gain=2.0, dt=dt)
    worst = math.inf
    for _ in range(6):
        p = P.chebyshev_center.copy()
        direction = rng.normal(size=dim)
        for _ in range(400):
            v = 1.5 * direction / np.linalg.norm(direction) + 0.3 * rng.normal(size=dim)
            p = p + dt * sh.shape(p, v)
            worst = min(worst, P.signed_distances(p).min())
            direction += 0.05 * rng.normal(size=dim)
    assert worst >= -1e-12, worst
    # From outside: with a zero command the point comes back and stays.
    p = P.chebyshev_center + 3.0 * rng.normal(size=dim)
    d0 = P.signed_distances(p).min()
    assert d0 < 0
    for _ in range(3000):
        p = p + dt * sh.shape(p, np.zeros(dim))
    assert P.signed_distances(p).min() >= -1e-9


def test_outside_several_facets_every_violation_shrinks():
    P = ConvexPolytope.box([0, 0, 0], [1, 1, 1])
    sh = PolytopeShaper(P, buffer=0.1, spring_gain=2.0)
    p = np.array([1.2, -0.3, 1.1])
    r = sh.explain(p, np.array([1.0, -1.0, 1.0]))  # pushing further out on all three
    assert r.zone == "outside-corner"
    n = P.normals
    d = P.signed_distances(p)
    for i in np.flatnonzero(d < 0):
        assert n[i] @ r.output > 0  # every violated facet is approached from outside
    assert "spring" in r.stages


def test_the_output_is_continuous_in_position_and_command():
    rng = np.random.default_rng(8)
    P = random_polytope(rng, 3, 5)
    sh = PolytopeShaper(P, buffer=0.2, spring_gain=2.0)
    for _ in range(300):
        p = rng.uniform(-1.2, 1.2, 3)
        v = rng.normal(size=3)
        dp = 1e-7 * rng.normal(size=3)
        dv = 1e-7 * rng.normal(size=3)
        gap = np.linalg.norm(sh.shape(p + dp, v + dv) - sh.shape(p, v))
        # Lipschitz in v (a projection, constant 1) and in p (bounds move at rate <= gain and
        # (|v| + R)/buffer), so the jump is a small multiple of the perturbation.
        assert gap <= 1e-7 * (10.0 + 20.0 * np.linalg.norm(v)) + 1e-12


def test_explain_names_the_binding_facets_and_their_slack():
    P = ConvexPolytope.box([0, 0, 0], [1, 1, 1])
    sh = PolytopeShaper(P, buffer=0.1, spring_gain=2.0)
    p = np.array([0.97, 0.5, 0.96])
    r = sh.explain(p, np.array([1.0, 0.3, 1.0]))
    assert r.zone == "corner"
    assert set(r.binding_names) == {"x_max", "z_max"}
    assert set(r.active_names) == {"x_max", "z_max"}
    slack = dict(zip(r.active, r.slack, strict=True))
    assert all(slack[f] <= 1e-12 for f in r.binding)
    assert P.facet_names.index("y_min") not in r.active
    np.testing.assert_array_equal(r.output, sh.shape(p, np.array([1.0, 0.3, 1.0])))
    # The tangential part is kept: y moves on as commanded.
    assert r.output[1] == pytest.approx(0.3)


def test_free_inside_and_a_free_command_passes_unchanged():
    P = ConvexPolytope.box([0, 0, 0], [1, 1, 1])
    sh = PolytopeShaper(P, buffer=0.1)
    v = np.array([0.3, -0.2, 0.1])
    r = sh.explain(np.array([0.5, 0.5, 0.5]), v)
    assert r.zone == "free"
    np.testing.assert_array_equal(r.output, v)


def test_unbounded_polytope_two_safety_planes():
    # Two tilted safety planes in 3-D: z >= 0.1 and x + z <= 1 (a wedge, unbounded).
    N = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, -1.0]])
    P = ConvexPolytope(N, np.array([0.1, -1.0]))
    assert not P.bounded
    sh = PolytopeShaper(P, buffer=0.05, spring_gain=1.0, dt=0.002)
    p = np.array([0.3, 0.0, 0.3])
    for _ in range(2000):
        p = p + 0.002 * sh.shape(p, np.array([0.4, 0.2, -0.5]))
        assert P.signed_distances(p).min() >= -1e-12
    assert p[1] > 0.5  # slid along the planes


# ---------------------------------------------------------------- validation
def test_parameters_are_validated_and_named():
    P = ConvexPolytope.box([0, 0, 0], [1, 1, 1])
    with pytest.raises(InvalidParameter, match="buffer"):
        PolytopeShaper(P)
    with pytest.raises(InvalidParameter, match="Chebyshev radius"):
        PolytopeShaper(P, buffer=0.6)
    with pytest.raises(InvalidParameter, match="polytope must be a ConvexPolytope"):
        PolytopeShaper(vf.ConvexPolygon([[0, 0], [1, 0], [0, 1]]), buffer=0.1)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="dt"):
        PolytopeShaper(P, profile=vf.LinearBuffer(buffer=0.1), dt=0.01)
    with pytest.raises(InvalidParameter, match="spring_gain"):
        PolytopeShaper(P, buffer=0.1, spring_gain=-1.0)
    with pytest.raises(TypeError):
        PolytopeShaper(P, 0.1)  # type: ignore[misc]


def test_inputs_are_validated():
    P = ConvexPolytope.box([0, 0, 0], [1, 1, 1])
    sh = PolytopeShaper(P, buffer=0.1)
    with pytest.raises(InvalidInput, match="position"):
        sh.shape(np.zeros(2), np.zeros(3))
    with pytest.raises(InvalidInput, match="command"):
        sh.shape(np.zeros(3), "abc")
    with pytest.raises(InvalidInput, match="finite"):
        sh.shape(np.array([0.5, math.nan, 0.5]), np.zeros(3))
    stop = PolytopeShaper(P, buffer=0.1, on_invalid="stop")
    np.testing.assert_array_equal(stop.shape(np.zeros(3), np.array([math.inf, 0, 0])), 0.0)
    assert stop.explain(np.zeros(3), np.array([math.inf, 0, 0])).zone == "invalid"
    with pytest.raises(AttributeError, match="immutable"):
        sh.buffer = 0.2  # type: ignore[misc]


@pytest.mark.parametrize("magnitude", [1e-300, 1e-12, 1.0, 1e6, 1e12, 1e18, 1e60, 1e149])
@pytest.mark.parametrize("profile", [False, True], ids=["buffer", "three-zone"])
def test_every_bound_holds_in_caller_units_at_any_command_magnitude(magnitude, profile):
    # A bound tiny against the command (1 m/s against 1e18) must still hold to its own
    # precision; when the arithmetic cannot resolve it the law shortens the command
    # (stage "command-scaled") or stops, never answers a violation.
    rng = np.random.default_rng(int(math.log10(magnitude) + 400))
    P = ConvexPolytope.box(-np.ones(3), np.ones(3))
    if profile:
        prof = vf.ThreeZoneBraking.from_actuator_limits(
            gain=20.0, max_speed=1.0, max_acceleration=5.0
        )
        sh = PolytopeShaper(P, profile=prof)
    else:
        sh = PolytopeShaper(P, buffer=0.3, spring_gain=2.0, dt=1e-3)
    for _ in range(300):
        p = rng.uniform(-1.1, 1.1, 3)
        v = rng.normal(size=3) * magnitude
        r = sh.explain(p, v)
        assert np.all(np.isfinite(r.output))
        normals, lower, _ = sh.bound_rows(p, v)
        if r.relaxed:
            continue
        gap = normals @ r.output - lower
        assert np.all(gap >= -1e-9 * (np.abs(lower) + 1e-300)), (p, v, gap, r.stages)
        if not profile and P.contains(p):
            assert P.signed_distances(p + 1e-3 * r.output).min() >= -1e-12
