"""PolygonShaper(method="patent"): US 8,676,382 algorithm 100 (derivations §2), hand-checked.

Besides the faithful behaviour (pass-through, buffer scaling, two-stage corner projection, outside
zeroing + spring + blend), two tests *demonstrate the defects* the exact method exists to remove:
the sequential corner projection re-introduces outward motion at an acute corner (and lets P creep
out in closed loop), and the output jumps across an arc-segment ray outside.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence import ConvexPolygon, PolygonShaper

TOL = 1e-12  # hand computations in double precision

SQUARE2 = ConvexPolygon([[0, 0], [2, 0], [2, 2], [0, 2]])  # centroid (1, 1), edges b, r, t, l
# 3-4-5 right triangle: acute corner (4, 0) of 36.87°. Edge 0 bottom, normal (0, 1); edge 1 the
# hypotenuse, normal (-0.6, -0.8), offset -2.4; edge 2 the left side, normal (1, 0).
TRI345 = ConvexPolygon([[0, 0], [4, 0], [0, 3]])
PENTAGON = ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])


def patent(poly: ConvexPolygon, **kw: float) -> PolygonShaper:
    return PolygonShaper(poly, method="patent", **kw)  # type: ignore[arg-type]


def exact_bound_slack(poly: ConvexPolygon, p: np.ndarray, v: np.ndarray, vo: np.ndarray, dmax):
    """n_i·v_o + |v| d_i/d_max for every edge in the buffer (inside): >= 0 means the bound holds."""
    d = poly.signed_distances(p)
    near = (d >= 0) & (d < dmax)
    return (poly.normals @ vo + np.linalg.norm(v) * d / dmax)[near]


class TestInside:
    @pytest.mark.parametrize("v", [[0.3, -0.8], [-5.0, 2.0], [0.0, 0.0], [1e6, -1e6]])
    def test_pass_through_in_free_zone(self, v: list[float]) -> None:
        sh = patent(SQUARE2, buffer=0.5, spring_gain=4.0)
        for p in ([1.0, 1.0], [0.5, 0.5], [1.5, 0.5000001], [0.7, 1.4]):
            vv = np.array(v)
            out = sh.shape(np.array(p), vv)
            np.testing.assert_array_equal(out, vv)
            r = sh.explain(p, v)
            assert r.zone == "free"
            assert r.stages == ()

    def test_single_edge_buffer_formula(self) -> None:
        sh = patent(SQUARE2, buffer=0.5)
        p = np.array([1.0, 0.1])  # bottom edge, d = 0.1, far from the side edges
        # outward: v - (1 - d/dmax)(v·n) n = (0.3, -0.8) - 0.8·(-0.8)·(0, 1) = (0.3, -0.16)
        r = sh.explain(p, np.array([0.3, -0.8]))
        np.testing.assert_allclose(r.output, [0.3, -0.16], rtol=0, atol=TOL)
        assert (r.zone, r.primary, r.stages) == ("buffer", 0, ("primary-projection",))
        assert r.d1 == pytest.approx(0.1, abs=TOL)
        # inward and tangential commands are untouched
        for v in ([0.3, 0.8], [0.5, 0.0], [-2.0, 0.0], [0.0, 0.0]):
            np.testing.assert_array_equal(sh.shape(p, np.array(v)), v)

    @pytest.mark.parametrize("d", [0.5 - 1e-9, 0.4, 0.25, 0.1, 1e-6, 0.0])
    def test_single_edge_scaling_is_gradual(self, d: float) -> None:
        sh = patent(SQUARE2, buffer=0.5)
        v = np.array([0.7, -2.0])
        out = sh.shape(np.array([1.0, d]), v)
        # normal component scaled by d/d_max (0 on the boundary), tangent kept
        assert out[1] == pytest.approx(-2.0 * d / 0.5, abs=TOL)
        assert out[0] == 0.7

    def test_corner_two_stage_order_hand_computation(self) -> None:
        sh = patent(TRI345, buffer=0.5)
        p = np.array([3.3, 0.3])  # wedge 1 (hypotenuse primary), nearer corner (4, 0)
        v = np.array([1.0, -1.0])
        r = sh.explain(p, v)
        assert (r.zone, r.primary, r.secondary) == ("corner", 1, 0)
        assert r.d1 == pytest.approx(0.18, abs=TOL)  # hypotenuse
        assert r.d2 == pytest.approx(0.3, abs=TOL)  # bottom
        # Stage 1, secondary (bottom, n2 = (0, 1)): v·n2 = -1, d̂2 = 1 - 0.3/0.5 = 0.4
        #   v' = (1, -1) + 0.4·(0, 1) = (1, -0.6)
        # Stage 2, primary (n1 = (-0.6, -0.8)): v'·n1 = -0.6 + 0.48 = -0.12, d̂1 = 0.64
        #   v_o = v' + 0.64·0.12·(-0.6, -0.8) = (1 - 0.04608, -0.6 - 0.06144)
        np.testing.assert_allclose(r.output, [0.95392, -0.66144], rtol=0, atol=TOL)
        assert r.stages == ("secondary-projection", "primary-projection")
        # The other order (primary first) gives (1, -0.6): the test above pins the order.
        assert not np.allclose(r.output, [1.0, -0.6], atol=1e-3)

    def test_corner_secondary_skipped_when_not_outward(self) -> None:
        sh = patent(TRI345, buffer=0.5)
        r = sh.explain(np.array([3.6, 0.16]), np.array([1.0, 0.0]))
        # v·n2 = 0: no first stage; v·n1 = -0.6, d1 = 0.112, d̂1 = 0.776
        assert r.d1 == pytest.approx(0.112, abs=TOL)
        np.testing.assert_allclose(r.output, [1 - 0.776 * 0.36, -0.776 * 0.48], rtol=0, atol=TOL)
        assert r.stages == ("primary-projection",)

    def test_primary_edge_alone_decides_inside_the_wedge(self) -> None:
        # Faithful step 108: d1 >= d_max passes the command through even when the secondary edge
        # is nearer than d_max (derivations §2, step 108). Just below the ray C→(4, 0) of the 3-4-5
        # triangle the primary is the bottom edge, and d(bottom) = 1.25·d(hypotenuse) there.
        sh = patent(TRI345, buffer=0.5)
        p = np.array([2.5333, 0.54])
        d = TRI345.signed_distances(p)
        assert d[0] >= 0.5 > d[1]
        v = np.array([1.0, 1.0])  # heads for the hypotenuse
        r = sh.explain(p, v)
        assert (r.zone, r.primary) == ("free", 0)
        np.testing.assert_array_equal(r.output, v)
        # Across the ray the hypotenuse is primary and the same command is scaled: an inside
        # discontinuity of the faithful reading.
        q = np.array([2.5333, 0.56])
        assert sh.explain(q, v).primary == 1
        assert np.linalg.norm(sh.shape(q, v) - v) > 0.1


def _off_corner_ray(phi: float) -> np.ndarray:
    """Point at radius 2 from SQUARE2's centroid, ``phi`` rad CCW of the ray through (2, 2)."""
    a = math.pi / 4 + phi
    return np.array([1.0 + 2.0 * math.cos(a), 1.0 + 2.0 * math.sin(a)])


class TestOutside:
    def test_outward_zeroed_tangent_kept_spring_added(self) -> None:
        k = 4.0
        sh = patent(SQUARE2, buffer=0.2, spring_gain=k)
        p = np.array([1.0, -0.3])  # below the bottom edge, far from the corners
        r = sh.explain(p, np.array([0.5, -1.0]))
        assert (r.zone, r.primary) == ("outside", 0)
        np.testing.assert_allclose(r.spring, [0.0, k * 0.3], rtol=0, atol=TOL)
        np.testing.assert_allclose(r.output, [0.5, k * 0.3], rtol=0, atol=TOL)
        assert r.stages == ("zero-outward", "spring")
        # an inward command is kept and the spring added on top
        np.testing.assert_allclose(
            sh.shape(p, np.array([0.5, 1.0])), [0.5, 1.0 + k * 0.3], rtol=0, atol=TOL
        )

    def test_zero_spring_gain_stops_outward_only(self) -> None:
        sh = patent(SQUARE2, buffer=0.2, spring_gain=0.0)
        out = sh.shape(np.array([1.0, -0.3]), np.array([0.5, -1.0]))
        np.testing.assert_allclose(out, [0.5, 0.0], rtol=0, atol=TOL)

    def test_blend_weight_half_on_corner_ray(self) -> None:
        k = 4.0
        sh = patent(SQUARE2, buffer=0.2, spring_gain=k, corner_blend_angle=0.3)
        p = np.array([2.5, 2.5])  # on the ray C→(2, 2): wedge 2 (top edge) starts there
        r = sh.explain(p, np.zeros(2))
        assert (r.primary, r.secondary) == (2, 1)
        # θ̂_2 = ½(1 - θ_2/θ_max) = ½ at θ_2 = 0: spring = k·0.5·(½ n_top + ½ n_right)
        np.testing.assert_allclose(r.spring, [-1.0, -1.0], rtol=0, atol=TOL)
        assert "spring-blend" in r.stages

    @pytest.mark.parametrize(("frac", "w"), [(0.0, 0.5), (0.25, 0.375), (0.5, 0.25), (0.9, 0.05)])
    def test_blend_weight_reconstruction(self, frac: float, w: float) -> None:
        k, tmax = 2.0, 0.3
        sh = patent(SQUARE2, buffer=0.2, spring_gain=k, corner_blend_angle=tmax)
        phi = frac * tmax  # angle from the corner ray (45°) into wedge 2
        p = _off_corner_ray(phi)
        pen = p[1] - 2.0
        r = sh.explain(p, np.zeros(2))
        assert r.primary == 2
        n1, n2 = np.array([0.0, -1.0]), np.array([-1.0, 0.0])
        np.testing.assert_allclose(r.spring, k * pen * ((1 - w) * n1 + w * n2), rtol=1e-9)

    def test_no_blend_beyond_corner_blend_angle(self) -> None:
        k, tmax = 2.0, 0.3
        sh = patent(SQUARE2, buffer=0.2, spring_gain=k, corner_blend_angle=tmax)
        phi = 0.31
        p = _off_corner_ray(phi)
        r = sh.explain(p, np.zeros(2))
        np.testing.assert_allclose(r.spring, [0.0, -k * (p[1] - 2.0)], rtol=0, atol=TOL)
        assert "spring-blend" not in r.stages
        assert "spring" in r.stages

    def test_secondary_stage_outside(self) -> None:
        # Outside the bottom edge near the corner (2, 0), inside the right edge's buffer.
        sh = patent(SQUARE2, buffer=0.5, spring_gain=0.0)
        p = np.array([1.8, -0.1])  # wedge 0, nearer corner 1, secondary = right edge (d2 = 0.2)
        r = sh.explain(p, np.array([1.0, -1.0]))
        assert (r.zone, r.primary, r.secondary) == ("outside-corner", 0, 1)
        # zero outward: (1, 0); secondary (n2 = (-1, 0), d̂2 = 1 - 0.2/0.5 = 0.6): x scaled to 0.4
        np.testing.assert_allclose(r.output, [0.4, 0.0], rtol=0, atol=TOL)


class TestDefects:
    """What the exact method fixes (derivations §2, known defects; ArduPilot issue #4807)."""

    def test_two_stage_projection_reintroduces_outward_motion_at_acute_corner(self) -> None:
        dmax = 0.5
        pat = patent(TRI345, buffer=dmax)
        exact = PolygonShaper(TRI345, buffer=dmax, method="exact")
        p = np.array([3.6, 0.16])  # inside, d(bottom) = 0.16, d(hypotenuse) = 0.112
        v = np.array([1.0, 0.05])  # slightly *inward* w.r.t. the bottom edge
        out = pat.shape(p, v)
        n_bottom = TRI345.normals[0]
        assert v @ n_bottom > 0
        # The primary (hypotenuse) stage pushes along n1, whose bottom component is -0.8:
        # the output now moves *out* through the bottom edge, faster than the buffer allows.
        assert out @ n_bottom < -0.3
        slack = exact_bound_slack(TRI345, p, v, out, dmax)
        assert slack.min() < -0.02  # the bound n·v_o >= -|v|·d/d_max is violated
        ex = exact.shape(p, v)
        assert exact_bound_slack(TRI345, p, v, ex, dmax).min() >= -1e-12

    def test_patent_creeps_out_of_an_acute_corner_in_closed_loop(self) -> None:
        dt, steps = 0.01, 1000
        worst = {}
        for method in ("patent", "exact"):
            sh = PolygonShaper(TRI345, buffer=0.5, spring_gain=2.0, method=method)
            p = np.array([2.0, 0.3])
            v = np.array([1.0, 0.05])  # slides along the bottom edge into the acute corner
            dmin = math.inf
            for _ in range(steps):
                p = p + dt * sh.shape(p, v)
                dmin = min(dmin, float(TRI345.signed_distances(p).min()))
            worst[method] = dmin
        assert worst["patent"] < -0.5  # escaped by more than the buffer width
        assert worst["exact"] >= -1e-12

    def test_patent_output_jumps_across_a_ray_outside(self) -> None:
        # Outside the pentagon's corner (2, 0), on the ray from the centroid through it. The
        # primary edge swaps across the ray and k·d_1 differs between the two edge lines.
        pat = patent(PENTAGON, buffer=0.2, spring_gain=4.0)
        exact = PolygonShaper(PENTAGON, buffer=0.2, spring_gain=4.0, method="exact")
        c = PENTAGON.corners[1]
        u = (c - PENTAGON.centroid) / np.linalg.norm(c - PENTAGON.centroid)
        perp = np.array([-u[1], u[0]])
        on_ray = c + 0.15 * u
        v = np.array([0.3, -0.5])
        for eps in (1e-4, 1e-7, 1e-10):
            a, b = on_ray - eps * perp, on_ray + eps * perp
            assert pat.explain(a, v).primary != pat.explain(b, v).primary
            jump = np.linalg.norm(pat.shape(a, v) - pat.shape(b, v))
            assert jump > 0.05  # does not shrink with eps: a discontinuity
            ex_jump = np.linalg.norm(exact.shape(a, v) - exact.shape(b, v))
            assert ex_jump < 100 * eps  # Lipschitz


def test_explain_reports_method_and_inputs() -> None:
    sh = patent(SQUARE2, buffer=0.5)
    r = sh.explain([1.0, 0.1], [0.0, -1.0])
    assert r.method == "edge-scaling"  # the canonical name of the alias "patent"
    assert sh.method == "edge-scaling"
    np.testing.assert_array_equal(r.position, [1.0, 0.1])
    np.testing.assert_array_equal(r.command, [0.0, -1.0])
    np.testing.assert_array_equal(r.spring, [0.0, 0.0])
    assert "edge-scaling" in repr(sh)
