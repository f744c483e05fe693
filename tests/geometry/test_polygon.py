"""ConvexPolygon, Rectangle, inscribed_rectangle, decompose: US 8,676,382 geometry.

Every closed form is checked against an independent route: triangle fans and the shoelace formula
for area and centroid, the patent's own normal formula (derivations §1, [RECON]), brute-force
point-to-line distances, both patent inside tests, the literal arc-segment test against the
``atan2`` fast path, and brute-force rectangle sampling for the inscribed rectangle.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from strategies import convex_corners, convex_polygons, random_points
from velfence import ConvexPolygon, InvalidGeometry, InvalidInput, InvalidParameter, Rectangle
from velfence.geometry import ConvexPolytope, decompose
from velfence.geometry.polygon import inscribed_rectangle, wedge_angle, wedge_index

RTOL = 1e-12  # closed forms against independent closed forms
ATOL = 1e-12
MARGIN = 1e-6  # keep random points this far from boundaries / rays where tests may disagree

PENTAGON = [[0, 0], [2, 0], [2.5, 1], [1, 2], [-0.5, 1]]  # the README's pentagon
SQUARE = [[-1, -1], [1, -1], [1, 1], [-1, 1]]
DIAMOND = [[1, 0], [0, 1], [-1, 0], [0, -1]]  # |x| + |y| <= 1


def _regular(n: int, r: float = 1.0, phase: float = 0.3) -> np.ndarray:
    t = phase + 2 * math.pi * np.arange(n) / n
    return r * np.stack([np.cos(t), np.sin(t)], axis=1)


def _shoelace(c: np.ndarray) -> float:
    x, y = c[:, 0], c[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _fan_area_centroid(c: np.ndarray) -> tuple[float, np.ndarray]:
    """Area and centroid as a fan of triangles (c0, ci, ci+1), weighted by signed area."""
    total = 0.0
    moment = np.zeros(2)
    for i in range(1, len(c) - 1):
        a, b, d = c[0], c[i], c[i + 1]
        area = 0.5 * ((b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]))
        total += area
        moment += area * (a + b + d) / 3.0
    return total, moment / total


# ---------------------------------------------------------------------------- construction
class TestConstruction:
    def test_ccw_input_kept(self) -> None:
        poly = ConvexPolygon(PENTAGON)
        np.testing.assert_array_equal(poly.corners, np.array(PENTAGON, dtype=float))
        assert poly.n == 5

    def test_cw_input_normalised_to_ccw(self) -> None:
        cw = np.array(PENTAGON[::-1], dtype=float)
        assert _shoelace(cw) < 0
        poly = ConvexPolygon(cw)
        assert _shoelace(poly.corners) > 0
        np.testing.assert_array_equal(poly.corners, cw[::-1])
        ref = ConvexPolygon(PENTAGON)
        assert poly.area == pytest.approx(ref.area, rel=RTOL)
        np.testing.assert_allclose(poly.centroid, ref.centroid, rtol=RTOL, atol=ATOL)

    @given(convex_corners())
    def test_random_cw_equals_ccw(self, corners: np.ndarray) -> None:
        a = ConvexPolygon(corners)
        b = ConvexPolygon(corners[::-1])
        np.testing.assert_array_equal(a.corners, corners)  # already CCW: kept as given
        np.testing.assert_array_equal(b.corners, corners)  # CW: reversed back
        assert b.area == pytest.approx(a.area, rel=1e-12)
        np.testing.assert_allclose(a.centroid, b.centroid, rtol=1e-12, atol=1e-12)

    def test_accepts_lists_tuples_and_ints(self) -> None:
        poly = ConvexPolygon(((0, 0), (1, 0), (0, 1)))
        assert poly.corners.dtype == np.float64
        assert poly.area == pytest.approx(0.5)

    @pytest.mark.parametrize(
        ("corners", "match"),
        [
            pytest.param([[0, 0], [1, 0]], r"at least 3 corners, got 2", id="two-corners"),
            pytest.param(np.zeros((0, 2)), r"at least 3 corners, got 0", id="no-corners"),
            pytest.param(
                [[0, 0], [1, 0], [np.nan, 1]], r"corner\(s\) \[2\] are not finite", id="nan"
            ),
            pytest.param(
                [[0, 0], [1, 0], [1, 1], [0, np.inf]],
                r"corner\(s\) \[3\] are not finite",
                id="inf",
            ),
            pytest.param(
                [[0, 0], [np.inf, 0], [1, 1], [0, -np.inf]],
                r"corner\(s\) \[1, 3\] are not finite",
                id="two-non-finite",
            ),
            pytest.param(
                [[0, 0], [1, 0], [1, 1], [1, 0], [0, 1]],
                r"corners 1 and 3 are duplicates",
                id="duplicate",
            ),
            pytest.param(
                [[0, 0], [1, 0], [1, 0], [0, 1]],
                r"corners 1 and 2 are duplicates",
                id="duplicate-consecutive",
            ),
            pytest.param(
                [[0, 0], [1, 0], [2, 0], [1, 1]],
                r"corner\(s\) \[1\] are collinear",
                id="collinear",
            ),
            pytest.param(
                [[0, 0], [2, 0], [2, 2], [0, 2], [0, 1]],
                r"corner\(s\) \[4\] are collinear",
                id="collinear-last",
            ),
            pytest.param(
                [[0, 0], [2, 0], [1, 0.5], [2, 2], [0, 2]],
                r"not convex: corner\(s\) \[2\] turn the wrong way",
                id="non-convex",
            ),
            pytest.param(
                _regular(5, phase=math.pi / 2)[[0, 2, 4, 1, 3]],
                r"self-intersect .*edge 0-1 crosses edge 2-3",
                id="pentagram",
            ),
            pytest.param(
                [[0, 0], [1, 1], [2, 2]],
                r"zero area: corners 0-2 are all collinear",
                id="zero-area",
            ),
            pytest.param(
                [[0, 0], [1, 1], [1, 0], [0, 1]], r"edge 0-1 crosses edge 2-3", id="bow-tie"
            ),
            pytest.param(
                [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                r"shape \(n, 2\) .*got shape \(3, 3\)",
                id="shape-3d",
            ),
            pytest.param([1.0, 2.0, 3.0], r"got shape \(3,\)", id="shape-flat"),
            pytest.param(
                "abc",
                r"corners: expected an \(n, 2\) array of numbers, got str 'abc'",
                id="not-numbers",
            ),
            pytest.param([[0, 0], [1], [0, 1]], r"\(n, 2\) array of numbers", id="ragged"),
        ],
    )
    def test_rejections_name_the_offence(self, corners: object, match: str) -> None:
        with pytest.raises(InvalidGeometry, match=match):
            ConvexPolygon(corners)  # type: ignore[arg-type]

    def test_non_convex_cw_names_input_index(self) -> None:
        # Indices refer to the list as given, even when it is clockwise and reversed afterwards.
        ccw = [[0, 0], [2, 0], [1, 0.5], [2, 2], [0, 2]]
        cw = ccw[::-1]  # the dent (1, 0.5) is now corner 2 again (5 corners, symmetric index)
        with pytest.raises(InvalidGeometry, match=r"corner\(s\) \[2\]"):
            ConvexPolygon(cw)
        cw_rot = cw[1:] + cw[:1]  # dent moves to index 1
        with pytest.raises(InvalidGeometry, match=r"corner\(s\) \[1\]"):
            ConvexPolygon(cw_rot)

    def test_invalid_geometry_is_a_value_error(self) -> None:
        with pytest.raises(ValueError, match="at least 3"):
            ConvexPolygon([[0, 0], [1, 1]])

    def test_frozen_and_read_only(self) -> None:
        poly = ConvexPolygon(PENTAGON)
        for name in ("corners", "normals", "offsets", "centroid"):
            arr = getattr(poly, name)
            assert not arr.flags.writeable, name
            with pytest.raises(ValueError, match="read-only"):
                arr[0] = 0.0
        with pytest.raises(dataclasses.FrozenInstanceError):
            poly.area = 1.0  # type: ignore[misc]

    def test_input_array_not_aliased(self) -> None:
        src = np.array(PENTAGON, dtype=float)
        poly = ConvexPolygon(src)
        src[0] = [9.0, 9.0]
        assert poly.corners[0].tolist() == [0.0, 0.0]

    def test_repr_lists_corners(self) -> None:
        assert repr(ConvexPolygon(SQUARE)).startswith("ConvexPolygon([(-1, -1), (1, -1)")

    def test_scaled(self) -> None:
        poly = ConvexPolygon(PENTAGON)
        big = poly.scaled(2.0)
        assert big.area == pytest.approx(4.0 * poly.area, rel=RTOL)
        np.testing.assert_allclose(big.centroid, poly.centroid, rtol=RTOL, atol=ATOL)
        for bad in (0.0, -1.0, math.nan, math.inf):
            with pytest.raises(InvalidGeometry, match="factor must be finite and > 0"):
                poly.scaled(bad)


# ---------------------------------------------------------------------------- area, centroid
class TestAreaCentroid:
    @pytest.mark.parametrize(
        ("corners", "area", "centroid"),
        [
            (SQUARE, 4.0, (0.0, 0.0)),
            (DIAMOND, 2.0, (0.0, 0.0)),
            ([[0, 0], [3, 0], [0, 3]], 4.5, (1.0, 1.0)),
            ([[0, 0], [4, 0], [0, 3]], 6.0, (4 / 3, 1.0)),
        ],
    )
    def test_known(self, corners: list[list[float]], area: float, centroid: tuple) -> None:
        poly = ConvexPolygon(corners)
        assert poly.area == pytest.approx(area, rel=RTOL)
        np.testing.assert_allclose(poly.centroid, centroid, rtol=RTOL, atol=ATOL)

    @given(convex_corners())
    def test_against_triangle_fan_and_shoelace(self, corners: np.ndarray) -> None:
        poly = ConvexPolygon(corners)
        fan_area, fan_centroid = _fan_area_centroid(np.asarray(corners))
        assert poly.area == pytest.approx(_shoelace(np.asarray(corners)), rel=1e-12)
        assert poly.area == pytest.approx(fan_area, rel=1e-12)
        scale = float(np.abs(corners).max())
        np.testing.assert_allclose(poly.centroid, fan_centroid, rtol=0, atol=1e-12 * scale)
        assert poly.contains(poly.centroid)
        assert poly.signed_distances(poly.centroid).min() > 0


# ---------------------------------------------------------------------------- normals, distances
def _patent_normals(c: np.ndarray, centroid: np.ndarray) -> np.ndarray:
    """docs/derivations.md §1 [RECON]: ñ_i = r_iC − ((r_iC·e_i)/(e_i·e_i)) e_i, normalised."""
    out = []
    for i in range(len(c)):
        e = c[(i + 1) % len(c)] - c[i]
        r_ic = centroid - c[i]
        nt = r_ic - (np.dot(r_ic, e) / np.dot(e, e)) * e
        out.append(nt / np.linalg.norm(nt))
    return np.array(out)


def _brute_signed_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, inside: np.ndarray):
    """Distance from p to the line through a, b via the foot point; positive on inside's side."""
    e = b - a
    t = np.dot(p - a, e) / np.dot(e, e)
    foot = a + t * e
    dist = np.linalg.norm(p - foot)
    side_p = np.sign(e[0] * (p[1] - a[1]) - e[1] * (p[0] - a[0]))
    side_in = np.sign(e[0] * (inside[1] - a[1]) - e[1] * (inside[0] - a[0]))
    return dist if side_p == side_in or side_p == 0 else -dist


class TestNormalsAndDistances:
    @given(convex_corners())
    def test_normals_unit_inward_and_patent_formula(self, corners: np.ndarray) -> None:
        poly = ConvexPolygon(corners)
        np.testing.assert_allclose(np.linalg.norm(poly.normals, axis=1), 1.0, rtol=0, atol=1e-14)
        # Inward: the centroid is on the positive side of every edge.
        rip = poly.centroid - poly.corners
        assert np.all(np.einsum("ij,ij->i", rip, poly.normals) > 0)
        # Perpendicular to the edges.
        e = np.roll(poly.corners, -1, axis=0) - poly.corners
        np.testing.assert_allclose(np.einsum("ij,ij->i", e, poly.normals), 0.0, atol=1e-12)
        # Independent route: the patent's reconstructed formula.
        np.testing.assert_allclose(
            poly.normals, _patent_normals(poly.corners, poly.centroid), rtol=0, atol=1e-12
        )

    def test_square_normals_exact(self) -> None:
        poly = ConvexPolygon(SQUARE)
        np.testing.assert_allclose(
            poly.normals, [[0, 1], [-1, 0], [0, -1], [1, 0]], rtol=0, atol=1e-15
        )
        np.testing.assert_allclose(poly.offsets, [-1, -1, -1, -1], rtol=0, atol=1e-15)

    @given(convex_corners(), st.integers(0, 2**32 - 1))
    def test_signed_distances_brute_force(self, corners: np.ndarray, seed: int) -> None:
        poly = ConvexPolygon(corners)
        pts = random_points(np.random.default_rng(seed), poly, 20, spread=2.0)
        D = poly.signed_distances(pts)
        assert D.shape == (20, poly.n)
        for p, row in zip(pts, D, strict=True):
            single = poly.signed_distances(p)
            assert single.shape == (poly.n,)
            np.testing.assert_allclose(single, row, rtol=0, atol=1e-14)
            ref = [
                _brute_signed_distance(
                    p, poly.corners[i], poly.corners[(i + 1) % poly.n], poly.centroid
                )
                for i in range(poly.n)
            ]
            np.testing.assert_allclose(row, ref, rtol=1e-9, atol=1e-12)

    def test_signed_distances_known(self) -> None:
        poly = ConvexPolygon(SQUARE)
        np.testing.assert_allclose(poly.signed_distances([0.5, 0.0]), [1.0, 0.5, 1.0, 1.5])
        np.testing.assert_allclose(poly.signed_distances([3.0, 0.0]), [1.0, -2.0, 1.0, 4.0])

    @pytest.mark.parametrize("bad", [[1.0, 2.0, 3.0], np.zeros((2, 3)), np.zeros((1, 2, 2)), "ab"])
    def test_point_shape_errors(self, bad: object) -> None:
        poly = ConvexPolygon(SQUARE)
        with pytest.raises(InvalidInput, match=r"expected point\(s\) of shape \(2,\) or \(N, 2\)"):
            poly.signed_distances(bad)  # type: ignore[arg-type]

    @pytest.mark.parametrize(
        "method", ["inside_by_normals", "inside_by_angle_sum", "arc_segment", "wedge"]
    )
    def test_single_point_queries_reject_batches(self, method: str) -> None:
        poly = ConvexPolygon(SQUARE)
        with pytest.raises(InvalidInput, match=r"expected one point of shape \(2,\)"):
            getattr(poly, method)(np.zeros((3, 2)))


# ---------------------------------------------------------------------------- inside tests
class TestInside:
    @given(convex_corners(), st.integers(0, 2**32 - 1))
    def test_contains_agrees_with_both_patent_tests(self, corners: np.ndarray, seed: int) -> None:
        poly = ConvexPolygon(corners)
        pts = random_points(np.random.default_rng(seed), poly, 60, spread=1.6)
        dmin = poly.signed_distances(pts).min(axis=1)
        pts = pts[np.abs(dmin) > MARGIN]
        batch = poly.contains(pts)
        assert isinstance(batch, np.ndarray)
        assert batch.dtype == np.bool_
        for p, inside in zip(pts, batch, strict=True):
            assert poly.contains(p) is bool(inside)
            assert poly.inside_by_normals(p) is bool(inside)
            assert poly.inside_by_angle_sum(p) is bool(inside)

    def test_boundary_conventions(self) -> None:
        poly = ConvexPolygon(SQUARE)
        on_edge = np.array([1.0, 0.0])
        assert poly.contains(on_edge) is True
        assert poly.inside_by_normals(on_edge) is False  # strict, as printed in the patent
        assert poly.inside_by_angle_sum(on_edge) is True
        assert poly.inside_by_angle_sum(np.array([1.0, 1.0])) is True  # on a corner
        assert poly.contains(np.array([1.0 + 1e-9, 0.0])) is False
        assert poly.contains(np.array([1.0 + 1e-9, 0.0]), tol=1e-8) is True


# ---------------------------------------------------------------------------- arc segments
def _angular_gap_to_rays(poly: ConvexPolygon, p: np.ndarray) -> float:
    r = p - poly.centroid
    rc = poly.corners - poly.centroid
    a = np.arctan2(r[1], r[0]) - np.arctan2(rc[:, 1], rc[:, 0])
    a = np.abs((a + math.pi) % (2 * math.pi) - math.pi)
    return float(a.min())


class TestArcSegment:
    @given(convex_corners(), st.integers(0, 2**32 - 1))
    def test_literal_patent_test_equals_atan2_fast_path(
        self, corners: np.ndarray, seed: int
    ) -> None:
        poly = ConvexPolygon(corners)
        pts = random_points(np.random.default_rng(seed), poly, 40, spread=3.0)
        for p in pts:
            if _angular_gap_to_rays(poly, p) < MARGIN:
                continue
            i = poly.arc_segment(p)
            assert poly.wedge(p) == i
            # Independent check of the answer: p lies strictly between rays C→c_i and C→c_{i+1}.
            rc = poly.corners - poly.centroid
            r = p - poly.centroid
            a, b = rc[i], rc[(i + 1) % poly.n]
            assert a[0] * r[1] - a[1] * r[0] > 0  # CCW of ray i
            assert r[0] * b[1] - r[1] * b[0] > 0  # CW of ray i+1

    def test_known_wedges_of_square(self) -> None:
        poly = ConvexPolygon(SQUARE)  # corners at -135°, -45°, 45°, 135°
        assert poly.arc_segment([0.0, -5.0]) == 0  # below: bottom edge 0
        assert poly.arc_segment([5.0, 0.1]) == 1
        assert poly.arc_segment([0.2, 0.5]) == 2
        assert poly.arc_segment([-0.5, 0.0]) == 3

    @pytest.mark.parametrize("corners", [SQUARE, DIAMOND, [[0, 0], [2, 0], [2, 2], [0, 2]]])
    @pytest.mark.parametrize("t", [0.25, 0.5, 2.0, 3.0])
    def test_on_a_corner_ray_the_wedge_starting_there(
        self, corners: list[list[float]], t: float
    ) -> None:
        poly = ConvexPolygon(corners)
        for i, c in enumerate(poly.corners):
            p = poly.centroid + t * (c - poly.centroid)  # exact in binary for these shapes
            assert poly.arc_segment(p) == i
            assert poly.wedge(p) == i

    @pytest.mark.parametrize("corners", [SQUARE, PENTAGON, [[0, 0], [3, 0], [0, 3]]])
    def test_centroid_is_wedge_zero(self, corners: list[list[float]]) -> None:
        poly = ConvexPolygon(corners)
        assert poly.arc_segment(poly.centroid) == 0
        assert poly.wedge(poly.centroid) == 0
        cx, cy = poly.centroid
        assert wedge_angle(cx, cy, cx, cy, 1.0) == 0.0

    def test_wedge_index_matches_method(self) -> None:
        # Deliberately internal: the scalar kernel (the compiled shapers' path) is checked
        # against the public method, so it reads the polygon's packed kernel constants.
        poly = ConvexPolygon(PENTAGON)
        _, _, _, cx, cy, a0, beta, n = poly._fast
        for p in random_points(np.random.default_rng(3), poly, 50):
            assert wedge_index(float(p[0]), float(p[1]), cx, cy, a0, beta, n) == poly.wedge(p)


# ---------------------------------------------------------------------------- rectangles
class TestInscribedRectangle:
    def test_square_is_its_own_rectangle(self) -> None:
        poly = ConvexPolygon(SQUARE)
        rect = poly.inscribed_rectangle()
        assert rect.area == pytest.approx(4.0, rel=1e-9)
        assert poly.area_ratio() == pytest.approx(1.0, rel=1e-9)

    def test_diamond(self) -> None:
        poly = ConvexPolygon(DIAMOND)  # |x| + |y| <= 1: area 2, best box is [-½, ½]², area 1
        rect = inscribed_rectangle(poly)
        assert poly.area == pytest.approx(2.0, rel=RTOL)
        assert rect.area == pytest.approx(1.0, rel=1e-6)
        np.testing.assert_allclose(
            [rect.xmin, rect.xmax, rect.ymin, rect.ymax], [-0.5, 0.5, -0.5, 0.5], atol=1e-3
        )
        assert poly.area_ratio() == pytest.approx(2.0, rel=1e-6)

    def test_right_triangle(self) -> None:
        # Largest box in the triangle x, y >= 0, x/a + y/b <= 1 has area a·b/4.
        poly = ConvexPolygon([[0, 0], [4, 0], [0, 3]])
        assert poly.inscribed_rectangle().area == pytest.approx(3.0, rel=1e-6)

    @pytest.mark.parametrize("seed", range(6))
    def test_corners_inside_and_no_sampled_box_is_larger(self, seed: int) -> None:
        rng = np.random.default_rng(seed)
        n = int(rng.integers(3, 9))
        corners = _regular(n, phase=rng.uniform(0, 6)) * [rng.uniform(0.5, 2), rng.uniform(0.5, 2)]
        corners = corners @ np.array([[1.0, 0.3], [0.0, 1.0]])  # shear: not symmetric
        poly = ConvexPolygon(corners)
        rect = poly.inscribed_rectangle()
        assert np.all(poly.contains(rect.corners, tol=1e-9))
        assert rect.area > 0
        # Brute force: random boxes from random x and y pairs, keep those inside.
        lo, hi = poly.corners.min(axis=0), poly.corners.max(axis=0)
        m = 40000
        xs = np.sort(rng.uniform(lo[0], hi[0], size=(m, 2)), axis=1)
        ys = np.sort(rng.uniform(lo[1], hi[1], size=(m, 2)), axis=1)
        box_corners = np.stack(
            [
                np.stack([xs[:, 0], ys[:, 0]], 1),
                np.stack([xs[:, 1], ys[:, 0]], 1),
                np.stack([xs[:, 1], ys[:, 1]], 1),
                np.stack([xs[:, 0], ys[:, 1]], 1),
            ],
            axis=1,
        )
        inside = poly.contains(box_corners.reshape(-1, 2)).reshape(m, 4).all(axis=1)
        areas = (xs[:, 1] - xs[:, 0]) * (ys[:, 1] - ys[:, 0])
        assert inside.sum() > 100
        best = areas[inside].max()
        assert best <= rect.area * (1 + 1e-9)
        assert best >= 0.5 * rect.area  # the sampling is dense enough to mean something

    @given(convex_polygons())
    def test_random_polygons_corners_inside(self, poly: ConvexPolygon) -> None:
        rect = poly.inscribed_rectangle()
        assert np.all(poly.contains(rect.corners, tol=1e-9))
        assert 0 < rect.area <= poly.area * (1 + 1e-12)

    def test_rectangle_basics(self) -> None:
        rect = Rectangle(xmin=-1.0, xmax=2.0, ymin=0.0, ymax=0.5)
        assert rect.area == pytest.approx(1.5)
        np.testing.assert_array_equal(rect.corners, [[-1, 0], [2, 0], [2, 0.5], [-1, 0.5]])
        assert _shoelace(rect.corners) > 0
        assert rect.contains([2.0, 0.5])
        assert not rect.contains([2.0, 0.51])
        with pytest.raises(dataclasses.FrozenInstanceError):
            rect.xmin = 0.0  # type: ignore[misc]


# ---------------------------------------------------------------------------- decompose
@given(
    st.tuples(st.floats(-10, 10), st.floats(-10, 10)),
    st.floats(0, 2 * math.pi),
)
def test_decompose(v: tuple[float, float], angle: float) -> None:
    n = np.array([math.cos(angle), math.sin(angle)])
    vn, vt = decompose(v, n)
    np.testing.assert_allclose(vn * n + vt, v, rtol=0, atol=1e-12)
    assert abs(float(vt @ n)) <= 1e-12
    assert vn == pytest.approx(float(np.dot(v, n)), abs=1e-15)


# ---------------------------------------------------------------------------- input hardening
class TestInputHardening:
    @pytest.mark.parametrize(
        ("corners", "match"),
        [
            pytest.param("abc", "got str", id="string"),
            pytest.param(np.array([[1 + 1j, 0], [1, 0], [0, 1]]), "complex", id="complex"),
            pytest.param(np.ones((3, 2), dtype=bool), "booleans", id="bool"),
            pytest.param(
                [[0, 0], [1, np.nan], [0, 1]], r"corner\(s\) \[1\] are not finite", id="nan"
            ),
            pytest.param([[0, 0], [1e300, 0], [0, 1e300]], "magnitude <= 1e\\+150", id="huge"),
            pytest.param([[0, 0], [1, 0], [None, 1]], "corners", id="none"),
        ],
    )
    def test_bad_corners_name_corners(self, corners: object, match: str) -> None:
        with pytest.raises(InvalidGeometry, match="corner") as info:
            ConvexPolygon(corners)  # type: ignore[arg-type]
        assert re.search(match, str(info.value))

    def test_large_polygons_validate(self) -> None:
        # Validation was O(n²) in Python (4,000 corners: 48 s); now vectorised (10⁴: ~10 ms).
        t = np.linspace(0.0, 2.0 * np.pi, 10_000, endpoint=False)
        c = np.c_[np.cos(t), np.sin(t)]
        assert ConvexPolygon(c).n == 10_000
        dup = np.insert(c, 5000, c[123], axis=0)
        with pytest.raises(InvalidGeometry, match="corners 123 and 5000 are duplicates"):
            ConvexPolygon(dup)
        dent = c.copy()
        dent[7000] *= 0.99
        with pytest.raises(InvalidGeometry, match=r"corner\(s\) \[7000\] turn the wrong way"):
            ConvexPolygon(dent)

    @pytest.mark.parametrize(
        "bad", [[np.nan, 1.0], [1.0, np.inf], "ab", [1 + 1j, 0], [True, False]]
    )
    def test_queries_refuse_non_finite_and_non_real_points(self, bad: object) -> None:
        poly = ConvexPolygon(SQUARE)
        with pytest.raises(InvalidInput, match=r"^p: "):
            poly.signed_distances(bad)  # type: ignore[arg-type]
        with pytest.raises(InvalidInput, match=r"^p: "):
            poly.closest_point(bad)  # type: ignore[arg-type]
        with pytest.raises(InvalidInput, match=r"^v: "):
            decompose(bad, [0.0, 1.0])  # type: ignore[arg-type]
        with pytest.raises(InvalidInput, match=r"^n: "):
            decompose([0.0, 1.0], bad)  # type: ignore[arg-type]

    def test_decompose_known(self) -> None:
        vn, vt = decompose(np.array([3.0, 4.0]), np.array([0.0, 1.0]))
        assert vn == 4.0
        np.testing.assert_array_equal(vt, [3.0, 0.0])

    def test_rectangle_is_validated(self) -> None:
        with pytest.raises(InvalidGeometry, match="xmin <= xmax"):
            Rectangle(xmin=1, xmax=0, ymin=0, ymax=1)  # area was -1
        with pytest.raises(InvalidGeometry, match="ymin <= ymax"):
            Rectangle(xmin=0, xmax=1, ymin=2, ymax=1)
        with pytest.raises(InvalidGeometry, match="ymax"):
            Rectangle(xmin=0, xmax=1, ymin=0, ymax=math.inf)
        with pytest.raises(TypeError):
            Rectangle(0, 1, 0, 1)  # type: ignore[misc]
        assert Rectangle(xmin=0, xmax=2, ymin=0, ymax=0).area == 0.0

    def test_inscribed_rectangle_iterations_bounded(self) -> None:
        poly = ConvexPolygon(SQUARE)
        with pytest.raises(InvalidParameter, match=r"iterations: expected an int <= 200"):
            inscribed_rectangle(poly, iterations=10**30)
        with pytest.raises(InvalidParameter, match="iterations"):
            inscribed_rectangle(poly, iterations=2.5)  # type: ignore[arg-type]

    def test_contains_tol_and_scale_factor_validated(self) -> None:
        poly = ConvexPolygon(SQUARE)
        with pytest.raises(InvalidParameter, match="tol"):
            poly.contains([0.5, 0.5], tol="0.1")  # type: ignore[arg-type]
        with pytest.raises(InvalidGeometry, match="factor must be a number"):
            poly.scaled("2")  # type: ignore[arg-type]


@pytest.mark.parametrize("height", [1e-12, 1e-10, 3e-9])
def test_thin_polygon_follows_the_polytope_rule(height: float) -> None:
    # a sliver used to be a valid ConvexPolygon while ConvexPolytope.from_polygon refused it:
    # both now refuse an inscribed circle of radius <= THIN * (1 + max |offset|)
    from velfence.geometry.polygon import THIN

    corners = [[0.0, 0.0], [1.0, 0.0], [1.0, height], [0.0, height]]
    with pytest.raises(InvalidGeometry, match="too thin"):
        ConvexPolygon(corners)
    thick = [[0.0, 0.0], [1.0, 0.0], [1.0, 10 * THIN * 2], [0.0, 10 * THIN * 2]]
    poly = ConvexPolygon(thick)
    assert ConvexPolytope.from_polygon(poly).n_facets == 4  # accepted by both
