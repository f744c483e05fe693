"""Safety-path regressions of the 2-D polygon shapers (derivations §3.1-3.3).

Each test carries the reproducer that showed the defect: tolerance-level escapes, near-flat
corners, recovery lost under huge commands, buffers wider than the polygon, discrete-time
overshoot, and the default spring gain.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, note, settings
from hypothesis import strategies as st

from strategies import convex_polygons, positions, vectors
from velfence import ConvexPolygon, InvalidParameter, PolygonShaper
from velfence.cobot import CasterWall
from velfence.shaping import _kernels as kern
from velfence.sim import simulate

UNIT = ConvexPolygon([[0, 0], [1, 0], [1, 1], [0, 1]])
FLAT = ConvexPolygon([[0, 0], [0.5, -1e-6], [1, 0], [1, 1], [0, 1]])  # 4e-6 rad corner at (0.5, ·)
#: Round-off allowed on a claimed bound, relative to the speed scale |v| + R (derivations §3.1).
BOUND_RTOL = 1e-14


def exact_qp(normals: np.ndarray, lower: np.ndarray, v: np.ndarray) -> tuple[Fraction, Fraction]:
    """argmin |x - v|² s.t. normals @ x >= lower, in exact rational arithmetic (enumeration)."""
    N = [(Fraction(a), Fraction(b)) for a, b in normals.tolist()]
    L = [Fraction(b) for b in lower.tolist()]
    vx, vy = Fraction(v[0]), Fraction(v[1])

    def feasible(x: Fraction, y: Fraction) -> bool:
        return all(a * x + b * y >= lo for (a, b), lo in zip(N, L, strict=True))

    cands = [(vx, vy)]
    for (a, b), lo in zip(N, L, strict=True):
        nn = a * a + b * b
        g = (lo - (a * vx + b * vy)) / nn
        cands.append((vx + g * a, vy + g * b))
    for i in range(len(N)):
        for j in range(i + 1, len(N)):
            (a, b), (c, d) = N[i], N[j]
            det = a * d - b * c
            if det != 0:
                cands.append(((L[i] * d - b * L[j]) / det, (a * L[j] - L[i] * c) / det))
    ok = [(x, y) for x, y in cands if feasible(x, y)]
    return min(ok, key=lambda q: (q[0] - vx) ** 2 + (q[1] - vy) ** 2)


def slack(sh: PolygonShaper, p: np.ndarray, v: np.ndarray, out: np.ndarray) -> float:
    """Smallest ``n_i·v_o - L_i`` over the claimed bounds, relative to |v| + R (>= 0: all hold)."""
    normals, lower, _ = sh.bounds(p, v)
    if not len(lower):
        return math.inf
    scale = math.hypot(*v) + max(0.0, float(lower.max()))
    return float((normals @ out - lower).min()) / max(scale, 1e-300)


# ---------------------------------------------------------------------------- 1. tolerance
class TestToleranceEscapes:
    def test_tiny_outward_component_on_the_boundary_is_removed(self) -> None:
        # Was returned unchanged (1e-12 feasibility tolerance): one step left the polygon.
        sh = PolygonShaper(UNIT, buffer=0.1, spring_gain=4)
        out = sh.shape([0.5, 0.0], [1e3, -5e-10])
        assert out[1] >= 0.0
        assert out[0] == pytest.approx(1e3)
        assert slack(sh, np.array([0.5, 0.0]), np.array([1e3, -5e-10]), out) >= 0.0

    def test_random_inside_steps_never_leave(self) -> None:
        # ~1 % of these left by up to 1.2e-11 before.
        sh = PolygonShaper(UNIT, buffer=0.1, spring_gain=4)
        rng = np.random.default_rng(7)
        worst = 0.0
        for _ in range(3000):
            p = np.array([rng.uniform(0, 1), rng.choice([0.0, rng.uniform(0, 1e-9)])])
            v = np.array([rng.normal() * 1e3, -abs(rng.normal()) * 1e-9])
            out = sh.shape(p, v)
            assert slack(sh, p, v, out) >= -BOUND_TOL_ABS
            worst = min(worst, float(p[1] + 1e-3 * out[1]))
        assert worst >= 0.0

    def test_near_flat_corner_is_the_exact_qp_optimum(self) -> None:
        # A QP with a 1e-12 tolerance (and the old kernel) answered 2.5e-7 away, violating the
        # second bound by 1e-12; the exact optimum is the vertex.
        sh = PolygonShaper(FLAT, buffer=0.1, spring_gain=1)
        p = np.array([0.5, 0.05])
        v = np.array([-7.525455109279625e-07, -0.9999999999997168])
        out = sh.shape(p, v)
        normals, lower, _ = sh.bounds(p, v)
        x, y = exact_qp(normals, lower, v)
        assert math.hypot(out[0] - float(x), out[1] - float(y)) < 1e-14
        assert slack(sh, p, v, out) >= 0.0

    def test_near_flat_corners_against_the_exact_qp(self) -> None:
        sh = PolygonShaper(FLAT, buffer=0.1, spring_gain=1)
        rng = np.random.default_rng(3)
        for _ in range(300):
            p = np.array([0.5 + rng.normal() * 0.02, rng.uniform(-0.01, 0.08)])
            a = rng.uniform(-math.pi, 0.0)
            v = np.array([math.cos(a), math.sin(a)])
            out = sh.shape(p, v)
            normals, lower, _ = sh.bounds(p, v)
            if not len(lower):
                continue
            x, y = exact_qp(normals, lower, v)
            err = math.hypot(out[0] - float(x), out[1] - float(y))
            assert err < 1e-9, (p.tolist(), v.tolist(), err)
            assert slack(sh, p, v, out) >= -BOUND_RTOL

    def test_numba_twin_agrees_on_these_cases(self) -> None:
        pytest.importorskip("numba")
        P = np.array([[0.5, 0.0], [0.5, 0.05], [0.5, -0.05], [0.3, 0.0]])
        V = np.array([[1e3, -5e-10], [-7.5e-7, -1.0], [0.0, -1e15], [2.0, -3.0]])
        for poly in (UNIT, FLAT):
            for dt in (None, 0.05):
                for method in ("exact", "patent"):
                    fast = PolygonShaper(poly, buffer=0.1, method=method, dt=dt)
                    slow = PolygonShaper(poly, buffer=0.1, method=method, dt=dt, accelerate=False)
                    loop = np.array([slow.shape(p, v) for p, v in zip(P, V, strict=True)])
                    np.testing.assert_array_equal(fast.shape_batch(P, V), loop)
                    np.testing.assert_array_equal(slow.shape_batch(P, V), loop)


BOUND_TOL_ABS = 1e-14


# ---------------------------------------------------------------------------- 2. huge commands
class TestHugeCommands:
    @pytest.mark.parametrize("speed", [1e15, 1e100, 1e300])
    def test_recovery_survives_a_huge_command(self, speed: float) -> None:
        # (0, -1e15) at 0.05 outside gave (0, 0): `v + gap n` lost the 5e-17 recovery term.
        sh = PolygonShaper(UNIT, buffer=0.1, spring_gain=1)
        out = sh.shape([0.5, -0.05], [0.0, -speed])
        np.testing.assert_allclose(out, [0.0, 0.05], rtol=1e-12, atol=0)

    def test_oblique_huge_command_keeps_recovery(self) -> None:
        sh = PolygonShaper(UNIT, buffer=0.1, spring_gain=1)
        out = sh.shape([0.5, -0.05], [-1e15, -1e15])
        assert out[1] >= 0.05 * (1 - 1e-12)


# ---------------------------------------------------------------------------- 3. wide buffers
class TestBufferLimit:
    def test_buffer_wider_than_the_inradius_is_refused(self) -> None:
        box = ConvexPolygon([[0, 0], [2, 0], [2, 1], [0, 1]])  # inradius 0.5
        assert box.inradius == pytest.approx(0.5, rel=1e-12)
        with pytest.raises(
            InvalidParameter, match=r"buffer=5 .*inradius.* is 0\.5.*buffer <= 0\.5"
        ):
            PolygonShaper(box, buffer=5)
        with pytest.raises(InvalidParameter, match="inradius"):
            PolygonShaper(box, buffer=0.6, method="patent")
        with pytest.raises(InvalidParameter, match="inradius"):
            CasterWall(box, buffer=0.6)
        PolygonShaper(box, buffer=0.5)  # the limit itself is admissible

    @settings(max_examples=60)
    @given(convex_polygons())
    def test_the_cheap_bound_is_below_the_inradius(self, poly: ConvexPolygon) -> None:
        """``inradius_bound`` (area / perimeter, which spares the shapers the search) is at most
        the inradius, itself checked against the Chebyshev centre as SciPy's linear program
        (maximise r with every edge distance >= r); buffers up to the inradius are admitted,
        beyond it refused, whichever side of the bound they fall."""
        from scipy.optimize import linprog

        n = len(poly.offsets)
        lp = linprog(
            [0.0, 0.0, -1.0],
            A_ub=np.c_[-poly.normals, np.ones(n)],
            b_ub=-poly.offsets,
            bounds=[(None, None)] * 3,
        )
        assert lp.status == 0
        assert poly.inradius == pytest.approx(-lp.fun, rel=1e-9, abs=1e-12)
        assert 0.0 < poly.inradius_bound <= poly.inradius * (1.0 + 1e-12)
        for buffer in (poly.inradius_bound, min(1.01 * poly.inradius_bound, poly.inradius)):
            assert PolygonShaper(poly, buffer=buffer).buffer == buffer
        with pytest.raises(InvalidParameter, match="inradius"):
            PolygonShaper(poly, buffer=1.01 * poly.inradius)

    def test_inradius_of_known_shapes(self) -> None:
        tri = ConvexPolygon([[0, 0], [4, 0], [0, 3]])  # 3-4-5 triangle: r = 1, centre (1, 1)
        assert tri.inradius == pytest.approx(1.0, rel=1e-12)
        assert np.all(tri.signed_distances(tri.incenter) >= 1.0 - 1e-12)
        t = np.linspace(0, 2 * np.pi, 1000, endpoint=False)
        circle = ConvexPolygon(np.c_[np.cos(t), np.sin(t)])
        assert circle.inradius == pytest.approx(math.cos(math.pi / 1000), rel=1e-12)

    def test_no_relaxed_stage_at_the_admissible_limit(self) -> None:
        strip = ConvexPolygon([[0, 0], [3, 0], [3, 0.15], [0, 0.15]])
        sh = PolygonShaper(strip, buffer=strip.inradius, spring_gain=4.0)
        rng = np.random.default_rng(1)
        for _ in range(500):
            p = np.array([rng.uniform(-0.1, 3.1), rng.uniform(-0.1, 0.25)])
            v = rng.normal(size=2)
            assert "relaxed" not in sh.explain(p, v).stages


# ---------------------------------------------------------------------------- 4. discrete time
class TestDiscreteTime:
    def test_without_dt_a_20_hz_loop_overshoots(self) -> None:
        # The continuous-time guarantee only: 3 m/s into the wall at 20 Hz, buffer 0.05.
        tr = simulate(
            PolygonShaper(UNIT, buffer=0.05), lambda t, p: np.array([0.0, -3.0]),
            [0.5, 0.5], duration=1.0, dt=0.05,
        )  # fmt: skip
        assert tr.p[:, 1].min() < -0.05

    @pytest.mark.parametrize("method", ["exact", "patent"])
    def test_with_dt_a_20_hz_loop_stays_inside(self, method: str) -> None:
        sh = PolygonShaper(UNIT, buffer=0.05, method=method, dt=0.05)
        rng = np.random.default_rng(2)
        for trial in range(20):
            a = rng.uniform(0, 2 * np.pi)
            s = rng.uniform(0.5, 10.0)
            cmd = np.array([s * math.cos(a), s * math.sin(a)])
            tr = simulate(
                sh, lambda t, p, c=cmd: c, rng.uniform(0.1, 0.9, 2), duration=2.0, dt=0.05
            )
            d = UNIT.signed_distances(tr.p).min()
            assert d >= -1e-15, (trial, cmd.tolist(), d)

    def test_caster_wall_with_dt_stays_inside(self) -> None:
        wall = CasterWall(UNIT, buffer=0.05, dt=0.05)
        tr = simulate(wall, lambda t, p: np.array([1.0, -3.0]), [0.5, 0.5], duration=2.0, dt=0.05)
        assert UNIT.signed_distances(tr.p).min() >= -1e-15

    def test_dt_is_validated_and_refused_with_a_profile(self) -> None:
        from velfence.shaping.profiles import LinearBuffer

        for bad in ("0.05", True, 0.0, -1.0, math.inf):
            with pytest.raises(InvalidParameter, match="dt"):
                PolygonShaper(UNIT, buffer=0.1, dt=bad)  # type: ignore[arg-type]
        with pytest.raises(InvalidParameter, match="dt is not supported with a profile"):
            PolygonShaper(UNIT, profile=LinearBuffer(buffer=0.1), dt=0.05)

    def test_period_cap_stage_is_reported(self) -> None:
        sh = PolygonShaper(UNIT, buffer=0.05, method="patent", dt=0.05)
        r = sh.explain([0.5, 0.2], [0.0, -10.0])
        assert "period-cap" in r.stages
        assert 0.2 + 0.05 * r.output[1] == pytest.approx(0.0, abs=1e-15)


# ---------------------------------------------------------------------------- 5. defaults
def test_default_shaper_recovers_from_outside() -> None:
    sh = PolygonShaper(UNIT, buffer=0.1)
    assert sh.spring_gain == 1.0
    out = sh.shape([0.5, -0.05], [0.0, 0.0])
    np.testing.assert_allclose(out, [0.0, 0.05], atol=1e-15)
    tr = simulate(sh, lambda t, p: np.zeros(2), [0.5, -0.05], duration=5.0, dt=0.01)
    assert UNIT.signed_distances(tr.p[-1]).min() > -0.05 * math.exp(-4.0)


# ---------------------------------------------------------------------------- properties
@settings(max_examples=150, deadline=None)
@given(
    data=st.data(),
    poly=convex_polygons(),
    buffer_frac=st.floats(0.05, 1.0),
    k=st.floats(0.0, 5.0),
    dt=st.one_of(st.none(), st.floats(1e-3, 0.2)),
    method=st.sampled_from(["exact", "patent"]),
)
def test_claimed_bounds_hold_and_one_step_never_leaves(
    data: st.DataObject,
    poly: ConvexPolygon,
    buffer_frac: float,
    k: float,
    dt: float | None,
    method: str,
) -> None:
    buffer = buffer_frac * poly.inradius
    sh = PolygonShaper(poly, buffer=buffer, spring_gain=k, dt=dt, method=method)
    p = data.draw(positions(poly))
    v = data.draw(vectors(bound=data.draw(st.sampled_from([1e-6, 1.0, 1e3, 1e9]))))
    out = sh.shape(p, v)
    d = poly.signed_distances(p)
    if method == "exact":
        note(f"slack={slack(sh, p, v, out)}")
        assert slack(sh, p, v, out) >= -BOUND_RTOL
    if d.min() < 0.0:
        return
    # One explicit-Euler step from inside: with dt any command; without dt (continuous-time law)
    # only steps short enough that |v|·h <= buffer are covered by the guarantee.
    h = dt if dt is not None else min(1.0, buffer / max(math.hypot(*v), 1e-300))
    if method == "patent" and dt is None:
        return  # the patent's sequential stages bound two edges only (derivations §2)
    q = p + h * out
    roundoff = 1e-15 * (1.0 + float(np.abs(p).max()) + h * float(np.abs(out).max()))
    assert poly.signed_distances(q).min() >= -roundoff


@settings(max_examples=150, deadline=None)
@given(
    data=st.data(),
    poly=convex_polygons(),
    buffer_frac=st.floats(0.05, 1.0),
    k=st.floats(0.0, 5.0),
    dt=st.one_of(st.none(), st.floats(1e-3, 0.2)),
)
def test_caster_wall_properties(
    data: st.DataObject, poly: ConvexPolygon, buffer_frac: float, k: float, dt: float | None
) -> None:
    wall = CasterWall(poly, buffer=buffer_frac * poly.inradius, spring_gain=k, dt=dt)
    p = data.draw(positions(poly))
    v = data.draw(vectors(bound=3.0))
    w = wall.shape(p, v)
    ell, w2, stages = wall.line(p, v)
    np.testing.assert_array_equal(w, w2)
    # On the Thales circle of the intent: w = (ℓᵀv) ℓ.
    np.testing.assert_allclose(w, float(ell @ v) * ell, atol=1e-12 * (1 + math.hypot(*v)))
    normals, lower, _ = wall.shaper.bounds(p, v)
    if len(lower):
        # The same bounds as the actuated law; when recovery is not realisable (stage
        # "relaxed", e.g. no intent outside) the recovery bounds become "not further out".
        if stages & kern.STAGE_RELAXED:
            lower = np.minimum(lower, 0.0)
        scale = math.hypot(*v) + max(0.0, float(lower.max()))
        assert float((normals @ w - lower).min()) >= -1e-12 * max(scale, 1e-300)
    if poly.signed_distances(p).min() >= 0.0:
        h = dt if dt is not None else min(1.0, wall.buffer / max(math.hypot(*v), 1e-300))
        q = p + h * w
        assert poly.signed_distances(q).min() >= -1e-12 * (1 + h * math.hypot(*v))


@settings(max_examples=25, deadline=None)
@given(poly=convex_polygons(), seed=st.integers(0, 2**16), dt=st.floats(0.01, 0.1))
def test_caster_wall_closed_loop_never_leaves(poly: ConvexPolygon, seed: int, dt: float) -> None:
    wall = CasterWall(poly, buffer=0.5 * poly.inradius, dt=dt)
    rng = np.random.default_rng(seed)
    cmd = rng.normal(size=2) * 3.0
    tr = simulate(wall, lambda t, p: cmd, poly.incenter, duration=20 * dt, dt=dt)
    assert poly.signed_distances(tr.p).min() >= -1e-12


# ---------------------------------------------------------------------------- 8. inputs
def _two_d_shapers(on_invalid: str) -> list[object]:
    from velfence.sim import AxisLimits, HardStop, NoLimit

    rect = UNIT.inscribed_rectangle()
    return [
        PolygonShaper(UNIT, buffer=0.1, on_invalid=on_invalid),
        PolygonShaper(UNIT, buffer=0.1, method="patent", on_invalid=on_invalid),
        PolygonShaper(UNIT, buffer=0.1, dt=0.05, on_invalid=on_invalid),
        CasterWall(UNIT, buffer=0.1, on_invalid=on_invalid),
        HardStop(UNIT, dt=0.01, on_invalid=on_invalid),
        AxisLimits(rect, buffer=0.1, on_invalid=on_invalid),
        NoLimit(on_invalid=on_invalid),
    ]


BAD_PAIRS = [
    "12",
    b"\x01\x02",
    {0: 5, 1: 7},
    np.array([1 + 1j, 2]),
    np.array([object(), object()]),
    np.array(["2020-01-01", "2020-01-02"], dtype="datetime64[D]"),
    np.array(["1", "2"]),
    [True, False],
    None,
    [1.0, 2.0, 3.0],
]


@pytest.mark.parametrize("on_invalid", ["raise", "stop"])
@pytest.mark.parametrize(
    "bad", BAD_PAIRS, ids=lambda b: type(b).__name__ + str(getattr(b, "dtype", ""))
)
def test_type_errors_raise_for_every_2d_shaper(on_invalid: str, bad: object) -> None:
    from velfence import InvalidInput

    for sh in _two_d_shapers(on_invalid):
        for call in ("shape", "explain"):
            with pytest.raises(InvalidInput, match="position"):
                getattr(sh, call)(bad, [0.0, 0.0])
            with pytest.raises(InvalidInput, match="command"):
                getattr(sh, call)([0.5, 0.5], bad)
        with pytest.raises(InvalidInput, match="positions"):
            sh.shape_batch([bad], [[0.0, 0.0]])  # type: ignore[attr-defined]
        with pytest.raises(InvalidInput, match="commands"):
            sh.shape_batch([[0.5, 0.5]], [bad])  # type: ignore[attr-defined]


def test_tuning_parameters_are_keyword_only_and_validated() -> None:
    import inspect

    for cls in (PolygonShaper, CasterWall):
        params = list(inspect.signature(cls).parameters.values())
        assert [p.kind for p in params[1:]] == [inspect.Parameter.KEYWORD_ONLY] * (len(params) - 1)
    for name in ("buffer", "spring_gain", "corner_blend_angle", "max_recovery_speed", "dt"):
        for bad in ("0.2", True, 1j, None if name == "buffer" else "x"):
            with pytest.raises(InvalidParameter, match=name):
                PolygonShaper(UNIT, **{"buffer": 0.1, name: bad})  # type: ignore[arg-type]
    for bad_flag in (1, "yes", None):
        with pytest.raises(InvalidParameter, match="accelerate"):
            PolygonShaper(UNIT, buffer=0.1, accelerate=bad_flag)  # type: ignore[arg-type]
    for name in ("buffer", "spring_gain", "dt"):
        with pytest.raises(InvalidParameter, match=name):
            CasterWall(UNIT, **{"buffer": 0.1, name: "0.2"})  # type: ignore[arg-type]
