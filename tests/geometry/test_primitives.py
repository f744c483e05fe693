"""Closest points, sphere–capsule clearance and the point–segment distance gradient.

Every closed form is checked against an independent route: brute-force sampling of the segments
(a zooming grid), the KKT optimality conditions of the convex (s, t) problem, hand-built cases
(parallel, collinear, crossing, touching ends, degenerate) and central finite differences.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence import InvalidInput
from velfence.geometry.primitives import (
    closest_point_on_segment,
    closest_points_segments,
    orthonormal_complement,
    point_segment_distance_jacobian,
    segment_segment_distance,
    sphere_capsule_distance,
)

BRUTE_TOL = 1e-6  # closed form against brute-force sampling
EXACT_TOL = 1e-12  # hand-built cases with exact answers
FD_RTOL = 1e-6  # analytic gradient against central differences
FD_STEP = 1e-6


def _brute_point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Distance and parameter by a zooming 1-D grid (the distance is convex in t)."""
    lo, hi = 0.0, 1.0
    best_t = 0.0
    for _ in range(8):
        t = np.linspace(lo, hi, 201)
        d = np.linalg.norm(a + t[:, None] * (b - a) - p, axis=1)
        i = int(np.argmin(d))
        best_t = float(t[i])
        step = (hi - lo) / 200
        lo, hi = max(0.0, best_t - 3 * step), min(1.0, best_t + 3 * step)
    return float(np.linalg.norm(a + best_t * (b - a) - p)), best_t


def _brute_segments(
    a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray
) -> tuple[float, float, float]:
    """Distance and parameters by a zooming 2-D grid over (s, t) in [0, 1]²."""
    box = [0.0, 1.0, 0.0, 1.0]
    s_best = t_best = 0.0
    for _ in range(7):
        s = np.linspace(box[0], box[1], 101)
        t = np.linspace(box[2], box[3], 101)
        P = a0 + s[:, None] * (a1 - a0)
        Q = b0 + t[:, None] * (b1 - b0)
        D = np.linalg.norm(P[:, None, :] - Q[None, :, :], axis=2)
        i, j = np.unravel_index(int(np.argmin(D)), D.shape)
        s_best, t_best = float(s[i]), float(t[j])
        ds, dt = (box[1] - box[0]) / 100, (box[3] - box[2]) / 100
        box = [
            max(0.0, s_best - 3 * ds),
            min(1.0, s_best + 3 * ds),
            max(0.0, t_best - 3 * dt),
            min(1.0, t_best + 3 * dt),
        ]
    pa = a0 + s_best * (a1 - a0)
    pb = b0 + t_best * (b1 - b0)
    return float(np.linalg.norm(pa - pb)), s_best, t_best


def _random_segments(rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    return tuple(rng.normal(size=3) for _ in range(4))


def _sin_angle(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> float:
    d1, d2 = a1 - a0, b1 - b0
    return float(np.linalg.norm(np.cross(d1, d2)) / (np.linalg.norm(d1) * np.linalg.norm(d2)))


# ---------------------------------------------------------------------------- point–segment
class TestClosestPointOnSegment:
    def test_random_against_brute_force(self) -> None:
        rng = np.random.default_rng(0)
        for _ in range(100):
            p, a, b = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
            x, t = closest_point_on_segment(p, a, b)
            d_ref, t_ref = _brute_point_segment(p, a, b)
            assert 0.0 <= t <= 1.0
            assert float(np.linalg.norm(p - x)) == pytest.approx(d_ref, abs=BRUTE_TOL)
            assert t == pytest.approx(t_ref, abs=BRUTE_TOL)
            np.testing.assert_allclose(x, a + t * (b - a), atol=EXACT_TOL)

    def test_interior_projection_and_clamped_ends(self) -> None:
        a, b = np.array([0.0, 0.0, 0.0]), np.array([2.0, 0.0, 0.0])
        x, t = closest_point_on_segment([0.5, 1.0, -3.0], a, b)
        np.testing.assert_allclose(x, [0.5, 0.0, 0.0], atol=EXACT_TOL)
        assert t == pytest.approx(0.25)
        x, t = closest_point_on_segment([-1.0, 1.0, 0.0], a, b)
        assert t == 0.0
        np.testing.assert_array_equal(x, a)
        x, t = closest_point_on_segment([5.0, 1.0, 0.0], a, b)
        assert t == 1.0
        np.testing.assert_array_equal(x, b)  # exact at the end, not a + 1 * (b - a)

    def test_endpoints_are_exact(self) -> None:
        a, b = np.array([0.1, 0.2, 0.3]), np.array([0.7, -0.3, 1e-3])
        x, t = closest_point_on_segment(b + 5 * (b - a), a, b)
        assert t == 1.0
        np.testing.assert_array_equal(x, b)

    def test_degenerate_segment_gives_t_zero(self) -> None:
        a = np.array([1.0, 2.0, 3.0])
        x, t = closest_point_on_segment([4.0, 6.0, 3.0], a, a.copy())
        assert t == 0.0
        np.testing.assert_array_equal(x, a)

    def test_2d_callers_pass_z_zero(self) -> None:
        x, t = closest_point_on_segment([1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0])
        np.testing.assert_array_equal(x, [1.0, 0.0, 0.0])
        assert t == 0.5

    def test_returns_float_array_and_float(self) -> None:
        x, t = closest_point_on_segment([1, 1, 0], [0, 0, 0], [2, 0, 0])
        assert isinstance(x, np.ndarray)
        assert x.dtype == np.float64
        assert x.shape == (3,)
        assert type(t) is float


# ---------------------------------------------------------------------------- segment–segment
class TestClosestPointsSegments:
    def test_random_against_brute_force(self) -> None:
        rng = np.random.default_rng(1)
        compared_points = 0
        for _ in range(60):
            a0, a1, b0, b1 = _random_segments(rng)
            pa, pb, s, t = closest_points_segments(a0, a1, b0, b1)
            d_ref, s_ref, t_ref = _brute_segments(a0, a1, b0, b1)
            assert 0.0 <= s <= 1.0
            assert 0.0 <= t <= 1.0
            np.testing.assert_allclose(pa, a0 + s * (a1 - a0), atol=EXACT_TOL)
            np.testing.assert_allclose(pb, b0 + t * (b1 - b0), atol=EXACT_TOL)
            assert float(np.linalg.norm(pa - pb)) == pytest.approx(d_ref, abs=BRUTE_TOL)
            if _sin_angle(a0, a1, b0, b1) > 0.1:  # unique, well-conditioned minimiser
                compared_points += 1
                assert s == pytest.approx(s_ref, abs=BRUTE_TOL)
                assert t == pytest.approx(t_ref, abs=BRUTE_TOL)
        assert compared_points > 40

    def test_random_satisfy_kkt_conditions(self) -> None:
        """The (s, t) problem is convex, so KKT certifies the global optimum independently."""
        rng = np.random.default_rng(2)
        for _ in range(500):
            a0, a1, b0, b1 = (rng.normal(size=3) * rng.uniform(0.1, 10) for _ in range(4))
            pa, pb, s, t = closest_points_segments(a0, a1, b0, b1)
            w = pa - pb
            scale = 1e-10 * (1 + np.abs(np.concatenate([a0, a1, b0, b1])).max()) ** 2
            gs = float(w @ (a1 - a0))  # ∂f/∂s / 2
            gt = -float(w @ (b1 - b0))  # ∂f/∂t / 2
            for g, x in ((gs, s), (gt, t)):
                if x == 0.0:
                    assert g >= -scale
                elif x == 1.0:
                    assert g <= scale
                else:
                    assert abs(g) <= scale

    def test_crossing_in_a_plane(self) -> None:
        pa, pb, s, t = closest_points_segments([-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 3, 0])
        np.testing.assert_allclose(pa, [0, 0, 0], atol=EXACT_TOL)
        np.testing.assert_allclose(pb, [0, 0, 0], atol=EXACT_TOL)
        assert (s, t) == pytest.approx((0.5, 0.25))

    def test_skew_lines_distance_is_offset(self) -> None:
        pa, pb, _, _ = closest_points_segments([-1, 0, 0], [1, 0, 0], [0, -1, 2], [0, 1, 2])
        assert float(np.linalg.norm(pa - pb)) == pytest.approx(2.0)
        np.testing.assert_allclose(pa, [0, 0, 0], atol=EXACT_TOL)
        np.testing.assert_allclose(pb, [0, 0, 2], atol=EXACT_TOL)

    def test_parallel_offset_overlapping_takes_middle_of_overlap(self) -> None:
        # B's shadow on A is [1, 3] ∩ [0, 2] = [1, 2]; middle 1.5.
        pa, pb, s, t = closest_points_segments([0, 0, 0], [2, 0, 0], [1, 1, 0], [3, 1, 0])
        np.testing.assert_allclose(pa, [1.5, 0, 0], atol=EXACT_TOL)
        np.testing.assert_allclose(pb, [1.5, 1, 0], atol=EXACT_TOL)
        assert (s, t) == pytest.approx((0.75, 0.25))

    def test_parallel_antiparallel_same_choice(self) -> None:
        pa, pb, _, t = closest_points_segments([0, 0, 0], [2, 0, 0], [3, 1, 0], [1, 1, 0])
        np.testing.assert_allclose(pa, [1.5, 0, 0], atol=EXACT_TOL)
        np.testing.assert_allclose(pb, [1.5, 1, 0], atol=EXACT_TOL)
        assert t == pytest.approx(0.75)

    def test_parallel_disjoint_gives_facing_ends(self) -> None:
        pa, pb, s, t = closest_points_segments([0, 0, 0], [1, 0, 0], [3, 1, 0], [5, 1, 0])
        assert (s, t) == (1.0, 0.0)
        np.testing.assert_array_equal(pa, [1, 0, 0])
        np.testing.assert_array_equal(pb, [3, 1, 0])
        pa, pb, s, t = closest_points_segments([0, 0, 0], [1, 0, 0], [-5, 0, 1], [-3, 0, 1])
        assert (s, t) == (0.0, 1.0)
        assert float(np.linalg.norm(pa - pb)) == pytest.approx(math.hypot(3.0, 1.0))

    def test_collinear_overlapping(self) -> None:
        pa, pb, s, t = closest_points_segments([0, 0, 0], [4, 0, 0], [1, 0, 0], [2, 0, 0])
        assert float(np.linalg.norm(pa - pb)) == pytest.approx(0.0, abs=EXACT_TOL)
        np.testing.assert_allclose(pa, [1.5, 0, 0], atol=EXACT_TOL)  # middle of the overlap
        assert (s, t) == pytest.approx((0.375, 0.5))

    def test_collinear_disjoint(self) -> None:
        d = segment_segment_distance([0, 0, 0], [1, 0, 0], [3, 0, 0], [4, 0, 0])
        assert d == pytest.approx(2.0)

    def test_touching_at_ends(self) -> None:
        a1 = np.array([0.3, -0.7, 1.1])
        pa, pb, s, t = closest_points_segments([0.0, 0.0, 0.0], a1, a1, [2.0, 5.0, -1.0])
        assert (s, t) == (1.0, 0.0)
        np.testing.assert_array_equal(pa, a1)
        np.testing.assert_array_equal(pb, a1)

    def test_end_touching_interior(self) -> None:
        pa, pb, s, t = closest_points_segments([0, 0, 0], [0, 1, 0], [-1, 1, 0], [1, 1, 0])
        assert (s, t) == pytest.approx((1.0, 0.5))
        np.testing.assert_allclose(pa, pb, atol=EXACT_TOL)

    def test_ends_nearest_beyond_both(self) -> None:
        # Lines cross at the origin, but both segments stop short of it.
        pa, pb, s, t = closest_points_segments([1, 0, 0], [2, 0, 0], [0, 1, 0], [0, 2, 0])
        assert (s, t) == (0.0, 0.0)
        assert float(np.linalg.norm(pa - pb)) == pytest.approx(math.sqrt(2.0))

    def test_degenerate_point_and_segment(self) -> None:
        p = [1.0, 1.0, 0.0]
        pa, pb, s, t = closest_points_segments(p, p, [0, 0, 0], [2, 0, 0])
        assert (s, t) == (0.0, 0.5)
        np.testing.assert_array_equal(pa, p)
        np.testing.assert_allclose(pb, [1, 0, 0], atol=EXACT_TOL)
        pa, pb, s, t = closest_points_segments([0, 0, 0], [2, 0, 0], p, p)
        assert (s, t) == (0.5, 0.0)
        np.testing.assert_allclose(pa, [1, 0, 0], atol=EXACT_TOL)

    def test_degenerate_both_points(self) -> None:
        pa, pb, s, t = closest_points_segments([1, 2, 3], [1, 2, 3], [4, 6, 3], [4, 6, 3])
        assert (s, t) == (0.0, 0.0)
        assert float(np.linalg.norm(pa - pb)) == pytest.approx(5.0)

    @pytest.mark.parametrize("angle", [1e-3, 1e-6, 1e-9, 1e-12, 0.0])
    def test_nearly_parallel_crossing(self, angle: float) -> None:
        """Segments crossing at a tiny angle: distance 0 however ill-conditioned the point."""
        c, sn = math.cos(angle), math.sin(angle)
        a0, a1 = np.array([-1.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
        b0, b1 = np.array([-c, -sn, 0.0]), np.array([c, sn, 0.0])
        assert segment_segment_distance(a0, a1, b0, b1) == pytest.approx(0.0, abs=1e-7)
        # And lifted off the plane: the distance becomes the offset.
        lift = np.array([0.0, 0.0, 0.5])
        d = segment_segment_distance(a0, a1, b0 + lift, b1 + lift)
        assert d == pytest.approx(0.5, abs=1e-7)

    @pytest.mark.parametrize("angle", [1e-5, 1e-9, 1e-13])
    def test_nearly_parallel_offset_against_brute_force(self, angle: float) -> None:
        a0, a1 = np.array([0.0, 0.0, 0.0]), np.array([3.0, 0.0, 0.0])
        b0 = np.array([1.0, 0.2, 0.1])
        b1 = b0 + 2.0 * np.array([math.cos(angle), math.sin(angle), 0.0])
        d_ref, _, _ = _brute_segments(a0, a1, b0, b1)
        assert segment_segment_distance(a0, a1, b0, b1) == pytest.approx(d_ref, abs=BRUTE_TOL)

    def test_symmetry_under_swap_and_reversal(self) -> None:
        rng = np.random.default_rng(3)
        for _ in range(200):
            a0, a1, b0, b1 = _random_segments(rng)
            pa, pb, s, t = closest_points_segments(a0, a1, b0, b1)
            qb, qa, t2, s2 = closest_points_segments(b0, b1, a0, a1)
            np.testing.assert_allclose(qa, pa, atol=1e-9)
            np.testing.assert_allclose(qb, pb, atol=1e-9)
            assert (s2, t2) == pytest.approx((s, t), abs=1e-9)
            ra, _, rs, _ = closest_points_segments(a1, a0, b0, b1)
            np.testing.assert_allclose(ra, pa, atol=1e-9)
            assert rs == pytest.approx(1.0 - s, abs=1e-9)

    def test_parallel_choice_is_symmetric_under_swap(self) -> None:
        a0, a1, b0, b1 = ([0, 0, 0], [2, 0, 0], [1, 1, 1], [3, 1, 1])
        pa, pb, _, _ = closest_points_segments(a0, a1, b0, b1)
        qb, qa, _, _ = closest_points_segments(b0, b1, a0, a1)
        np.testing.assert_allclose(qa, pa, atol=EXACT_TOL)
        np.testing.assert_allclose(qb, pb, atol=EXACT_TOL)

    def test_distance_convenience_matches(self) -> None:
        rng = np.random.default_rng(4)
        for _ in range(50):
            a0, a1, b0, b1 = _random_segments(rng)
            pa, pb, _, _ = closest_points_segments(a0, a1, b0, b1)
            d = segment_segment_distance(a0, a1, b0, b1)
            assert type(d) is float
            assert d == pytest.approx(float(np.linalg.norm(pa - pb)), abs=EXACT_TOL)


# ---------------------------------------------------------------------------- sphere–capsule
class TestSphereCapsule:
    def test_clearance_against_brute_force(self) -> None:
        rng = np.random.default_rng(5)
        signs = set()
        for _ in range(100):
            c, a, b = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
            rs, rc = rng.uniform(0, 0.8), rng.uniform(0, 0.8)
            clearance, x, t, _ = sphere_capsule_distance(
                c, a, b, sphere_radius=rs, capsule_radius=rc
            )
            d_ref, t_ref = _brute_point_segment(c, a, b)
            assert clearance == pytest.approx(d_ref - rs - rc, abs=BRUTE_TOL)
            assert t == pytest.approx(t_ref, abs=BRUTE_TOL)
            np.testing.assert_allclose(x, a + t * (b - a), atol=EXACT_TOL)
            signs.add(clearance > 0)
        assert signs == {True, False}  # both separated and penetrating cases were drawn

    def test_negative_when_penetrating_positive_when_apart(self) -> None:
        a, b = [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]
        clearance, *_ = sphere_capsule_distance(
            [1.0, 0.5, 0.0], a, b, sphere_radius=0.3, capsule_radius=0.1
        )
        assert clearance == pytest.approx(0.1)
        clearance, *_ = sphere_capsule_distance(
            [1.0, 0.3, 0.0], a, b, sphere_radius=0.3, capsule_radius=0.1
        )
        assert clearance == pytest.approx(-0.1)
        clearance, *_ = sphere_capsule_distance(
            [3.0, 0.0, 0.0], a, b, sphere_radius=0.5, capsule_radius=0.5
        )
        assert clearance == pytest.approx(0.0, abs=EXACT_TOL)  # touching the end cap

    def test_normal_is_unit_and_points_from_centre_to_axis(self) -> None:
        rng = np.random.default_rng(6)
        for _ in range(100):
            c, a, b = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
            _, x, _, n = sphere_capsule_distance(c, a, b, sphere_radius=0.1, capsule_radius=0.2)
            assert float(np.linalg.norm(n)) == pytest.approx(1.0, abs=EXACT_TOL)
            np.testing.assert_allclose(n * np.linalg.norm(x - c), x - c, atol=1e-12)

    def test_centre_on_axis_gives_fixed_perpendicular(self) -> None:
        a, b = np.array([0.0, 0.0, 0.0]), np.array([1.0, 1.0, 0.0])
        clearance, x, t, n = sphere_capsule_distance(
            [0.5, 0.5, 0.0], a, b, sphere_radius=0.1, capsule_radius=0.2
        )
        assert clearance == pytest.approx(-0.3)
        assert t == pytest.approx(0.5)
        np.testing.assert_allclose(x, [0.5, 0.5, 0.0], atol=EXACT_TOL)
        np.testing.assert_allclose(n, [-math.sqrt(0.5), math.sqrt(0.5), 0.0], atol=EXACT_TOL)
        assert float(n @ (b - a)) == pytest.approx(0.0, abs=EXACT_TOL)  # in-plane for 2-D use

    def test_centre_on_vertical_or_degenerate_axis(self) -> None:
        _, _, _, n = sphere_capsule_distance(
            [0, 0, 0.5], [0, 0, 0], [0, 0, 1], sphere_radius=0.1, capsule_radius=0.1
        )
        np.testing.assert_array_equal(n, [1.0, 0.0, 0.0])
        clearance, x, t, n = sphere_capsule_distance(
            [1, 1, 1], [1, 1, 1], [1, 1, 1], sphere_radius=0.1, capsule_radius=0.1
        )
        assert (clearance, t) == pytest.approx((-0.2, 0.0))
        np.testing.assert_array_equal(x, [1, 1, 1])
        np.testing.assert_array_equal(n, [1.0, 0.0, 0.0])

    def test_capsule_with_zero_radii_is_point_segment_distance(self) -> None:
        clearance, *_ = sphere_capsule_distance(
            [0, 3, 4], [-1, 0, 0], [1, 0, 0], sphere_radius=0, capsule_radius=0
        )
        assert clearance == pytest.approx(5.0)


# ---------------------------------------------------------------------------- distance gradient
def _moving(q: np.ndarray, base: np.ndarray, J: np.ndarray) -> np.ndarray:
    return base + J @ q


class TestDistanceJacobian:
    def test_against_central_differences(self) -> None:
        rng = np.random.default_rng(7)
        n_params = 4
        clamped = interior = 0
        while clamped + interior < 80:
            p0, a0, b0 = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
            P, A, B = (rng.normal(size=(3, n_params)) for _ in range(3))
            q0 = rng.normal(size=n_params)

            def dist(q: np.ndarray, p0=p0, a0=a0, b0=b0, P=P, A=A, B=B) -> float:
                p, a, b = _moving(q, p0, P), _moving(q, a0, A), _moving(q, b0, B)
                x, _ = closest_point_on_segment(p, a, b)
                return float(np.linalg.norm(p - x))

            p, a, b = _moving(q0, p0, P), _moving(q0, a0, A), _moving(q0, b0, B)
            t_free = float((p - a) @ (b - a) / ((b - a) @ (b - a)))
            if min(abs(t_free), abs(t_free - 1.0)) < 1e-3 or dist(q0) < 1e-2:
                continue  # stay away from the kinks where the gradient jumps
            if 0.0 < t_free < 1.0:
                interior += 1
            else:
                clamped += 1
            g = point_segment_distance_jacobian(p, a, b, P, A, B)
            fd = np.array(
                [
                    (dist(q0 + FD_STEP * e) - dist(q0 - FD_STEP * e)) / (2 * FD_STEP)
                    for e in np.eye(n_params)
                ]
            )
            assert g.shape == (n_params,)
            np.testing.assert_allclose(g, fd, rtol=FD_RTOL, atol=FD_RTOL * np.abs(fd).max())
        assert clamped > 10
        assert interior > 10

    def test_point_moving_away_along_normal(self) -> None:
        # p = (1, d, 0) above segment x-axis; d(dist)/dd = 1, endpoints fixed.
        dp = np.array([[0.0], [1.0], [0.0]])
        zero = np.zeros((3, 1))
        g = point_segment_distance_jacobian([1, 0.5, 0], [0, 0, 0], [2, 0, 0], dp, zero, zero)
        np.testing.assert_allclose(g, [1.0], atol=EXACT_TOL)
        # Moving the endpoints with the point leaves the distance unchanged.
        g = point_segment_distance_jacobian([1, 0.5, 0], [0, 0, 0], [2, 0, 0], dp, dp, dp)
        np.testing.assert_allclose(g, [0.0], atol=EXACT_TOL)

    def test_zero_distance_is_finite_and_consistent_with_capsule_normal(self) -> None:
        a, b, c = [0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.5, 0.5, 0.0]
        J = np.eye(3)
        zero = np.zeros((3, 3))
        g = point_segment_distance_jacobian(c, a, b, J, zero, zero)
        _, _, _, n = sphere_capsule_distance(c, a, b, sphere_radius=0.0, capsule_radius=0.0)
        np.testing.assert_allclose(g, -n, atol=EXACT_TOL)

    def test_zero_columns(self) -> None:
        z = np.zeros((3, 0))
        g = point_segment_distance_jacobian([0, 1, 0], [0, 0, 0], [1, 0, 0], z, z, z)
        assert g.shape == (0,)


# ---------------------------------------------------------------------------- invalid input
class TestInvalidInput:
    def test_two_d_point_is_refused_with_hint(self) -> None:
        with pytest.raises(InvalidInput, match=r"p: expected shape \(3,\), got shape \(2,\); 2-D"):
            closest_point_on_segment([1.0, 2.0], [0, 0, 0], [1, 0, 0])

    def test_non_finite_point(self) -> None:
        with pytest.raises(
            InvalidInput, match=r"b1: expected finite values, got \[0.0, nan, 0.0\]; filter"
        ):
            closest_points_segments([0, 0, 0], [1, 0, 0], [0, 1, 0], [0, math.nan, 0])
        with pytest.raises(InvalidInput, match="a0: expected finite values"):
            segment_segment_distance([math.inf, 0, 0], [1, 0, 0], [0, 1, 0], [0, 2, 0])

    def test_not_numbers(self) -> None:
        with pytest.raises(InvalidInput, match="center: expected a point of 3 numbers"):
            sphere_capsule_distance(
                "abc", [0, 0, 0], [1, 0, 0], sphere_radius=0.1, capsule_radius=0.1
            )
        with pytest.raises(InvalidInput, match="a: expected a point of 3 numbers"):
            closest_point_on_segment([0, 0, 0], [[1, 2], [3]], [1, 0, 0])

    def test_matrix_instead_of_point(self) -> None:
        with pytest.raises(InvalidInput, match=r"a: expected shape \(3,\), got shape \(1, 3\)"):
            closest_point_on_segment([0, 0, 0], [[1, 2, 3]], [1, 0, 0])

    @pytest.mark.parametrize("radius", [-0.1, math.nan, math.inf])
    def test_bad_radius(self, radius: float) -> None:
        with pytest.raises(InvalidInput, match="sphere_radius must be finite and >= 0"):
            sphere_capsule_distance(
                [0, 0, 0], [0, 0, 1], [1, 0, 1], sphere_radius=radius, capsule_radius=0.1
            )
        with pytest.raises(InvalidInput, match="capsule_radius must be finite and >= 0"):
            sphere_capsule_distance(
                [0, 0, 0], [0, 0, 1], [1, 0, 1], sphere_radius=0.1, capsule_radius=radius
            )

    def test_radius_not_a_number(self) -> None:
        with pytest.raises(
            InvalidInput, match="capsule_radius must be a number in length units, got"
        ):
            sphere_capsule_distance(
                [0, 0, 0], [0, 0, 1], [1, 0, 1], sphere_radius=0.1, capsule_radius="wide"
            )

    def test_jacobian_shapes(self) -> None:
        J = np.zeros((3, 2))
        with pytest.raises(
            InvalidInput,
            match=r"da: expected shape \(3, N\), got shape \(3,\); expected a Jacobian of shape "
            r"\(3, n\)",
        ):
            point_segment_distance_jacobian([0, 1, 0], [0, 0, 0], [1, 0, 0], J, np.zeros(3), J)
        with pytest.raises(InvalidInput, match=r"got shape \(2, 2\)"):
            point_segment_distance_jacobian([0, 1, 0], [0, 0, 0], [1, 0, 0], np.eye(2), J, J)
        with pytest.raises(InvalidInput, match=r"same number of columns.*\(3, 3\)"):
            point_segment_distance_jacobian([0, 1, 0], [0, 0, 0], [1, 0, 0], J, J, np.zeros((3, 3)))

    def test_jacobian_not_finite(self) -> None:
        J = np.zeros((3, 2))
        bad = J.copy()
        bad[1, 1] = math.nan
        with pytest.raises(InvalidInput, match="db: expected finite values"):
            point_segment_distance_jacobian([0, 1, 0], [0, 0, 0], [1, 0, 0], J, J, bad)

    def test_errors_are_value_errors(self) -> None:
        with pytest.raises(ValueError, match="expected"):
            closest_point_on_segment([0, 0], [0, 0, 0], [1, 0, 0])


ORTHO_TOL = 1e-15  # unit lengths and dot products of the complement basis (a few ulps)


class TestOrthonormalComplement:
    def test_right_handed_orthonormal_frame_for_random_directions(self) -> None:
        rng = np.random.default_rng(5)
        for n in rng.normal(size=(200, 3)) * rng.uniform(1e-3, 1e3, (200, 1)):
            e1, e2 = orthonormal_complement(n)
            u = n / np.linalg.norm(n)
            frame = np.column_stack([u, e1, e2])
            np.testing.assert_allclose(frame.T @ frame, np.eye(3), atol=4 * ORTHO_TOL)
            assert np.linalg.det(frame) == pytest.approx(1.0, abs=4 * ORTHO_TOL)

    def test_depends_on_the_direction_only(self) -> None:
        n = np.array([0.3, -0.2, 0.9])
        for a, b in zip(orthonormal_complement(n), orthonormal_complement(250.0 * n), strict=True):
            np.testing.assert_allclose(a, b, atol=ORTHO_TOL)
        # the opposite normal keeps e1 and flips e2 (so e1 × e2 follows the normal)
        e1, e2 = orthonormal_complement(n)
        f1, f2 = orthonormal_complement(-n)
        np.testing.assert_allclose(f1, e1, atol=ORTHO_TOL)
        np.testing.assert_allclose(f2, -e2, atol=ORTHO_TOL)

    def test_the_fixed_choice(self) -> None:
        # x̂ projected for a vertical normal, ŷ projected once |n_x| >= 0.9
        e1, e2 = orthonormal_complement([0.0, 0.0, 2.0])
        np.testing.assert_array_equal(e1, [1.0, 0.0, 0.0])
        np.testing.assert_array_equal(e2, [0.0, 1.0, 0.0])
        e1, e2 = orthonormal_complement([1.0, 0.0, 0.0])
        np.testing.assert_array_equal(e1, [0.0, 1.0, 0.0])
        np.testing.assert_array_equal(e2, [0.0, 0.0, 1.0])
        just_below = np.array([0.8999, math.sqrt(1.0 - 0.8999**2), 0.0])
        assert orthonormal_complement(just_below)[0][0] > 0.4  # x̂'s projection, not ŷ's

    def test_invalid(self) -> None:
        with pytest.raises(InvalidInput, match=r"n: expected a non-zero direction"):
            orthonormal_complement([0.0, 0.0, 0.0])
        with pytest.raises(InvalidInput, match=r"n: expected shape \(3,\), got shape \(2,\)"):
            orthonormal_complement([1.0, 0.0])
        with pytest.raises(InvalidInput, match="n: expected finite values"):
            orthonormal_complement([math.nan, 0.0, 1.0])


def test_points_segments_distances_equals_the_scalar_route():
    from velfence.geometry.primitives import (
        closest_point_on_segment,
        points_segments_distances,
    )

    rng = np.random.default_rng(11)
    P = rng.normal(size=(7, 3))
    A = rng.normal(size=(5, 3))
    B = A + rng.normal(size=(5, 3))
    B[2] = A[2]  # a degenerate segment
    r = rng.uniform(0.0, 0.2, 5)
    t, clear = points_segments_distances(P, A, B, radii=r)
    for i in range(7):
        for j in range(5):
            x, tj = closest_point_on_segment(P[i], A[j], B[j])
            assert t[i, j] == pytest.approx(tj, abs=1e-12)
            assert clear[i, j] == pytest.approx(np.linalg.norm(P[i] - x) - r[j], abs=1e-12)


def test_polygon_closest_point_against_dense_boundary_sampling():
    import velfence as vf

    poly = vf.ConvexPolygon([[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]])
    a = poly.corners
    b = np.roll(a, -1, axis=0)
    s = np.linspace(0.0, 1.0, 2001)
    boundary = (a[:, None, :] + s[None, :, None] * (b - a)[:, None, :]).reshape(-1, 2)
    rng = np.random.default_rng(3)
    for p in rng.uniform(-2.0, 4.0, (200, 2)):
        c = poly.closest_point(p)
        if poly.contains(p):
            np.testing.assert_array_equal(c, p)
            continue
        best = boundary[np.argmin(np.linalg.norm(boundary - p, axis=1))]
        assert np.linalg.norm(c - p) <= np.linalg.norm(best - p) + 1e-12
        assert np.linalg.norm(c - best) < 2e-3
        assert abs(poly.signed_distances(c).min()) < 1e-12  # on the boundary
