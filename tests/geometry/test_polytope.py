"""ConvexPolytope: constructors, validation, redundancy, queries; checked by independent routes."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from optional import requires_qp
from strategies import convex_polygons
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry import ConvexPolygon, ConvexPolytope


def _brute_inside(N: np.ndarray, off: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Membership by the raw (unnormalised) rows, one point at a time."""
    return np.array([all(float(np.dot(r, x)) >= o for r, o in zip(N, off, strict=True)) for x in X])


# ------------------------------------------------------------------------------ constructor


def test_rows_are_normalised_and_distances_are_euclidean() -> None:
    P = ConvexPolytope([[2.0, 0.0], [0.0, -3.0], [-1.0, 1.0]], [2.0, -6.0, -10.0])
    assert np.allclose(np.linalg.norm(P.normals, axis=1), 1.0, atol=1e-15)
    assert np.allclose(P.offsets, [1.0, -2.0, -10.0 / math.sqrt(2.0)])
    x = np.array([3.0, 1.0])
    # distance to the line 2x = 2 is |x - 1|, to -3y = -6 is 2 - y, to y - x = -10 is (y-x+10)/√2.
    assert np.allclose(P.signed_distances(x), [2.0, 1.0, 8.0 / math.sqrt(2.0)], atol=1e-14)
    assert P.dim == 2
    assert P.n_facets == 3
    assert P.facet_names == ("facet 0", "facet 1", "facet 2")
    assert P.removed == ()
    assert P.source_rows == (0, 1, 2)
    assert P.bounded  # x >= 1, y <= 2, y >= x - 10: a triangle


def test_arrays_are_read_only_and_the_object_frozen() -> None:
    P = ConvexPolytope.box([0.0, 0.0], [1.0, 1.0])
    for a in (P.normals, P.offsets, P.chebyshev_center):
        with pytest.raises(ValueError, match="read-only"):
            a[0] = 5.0
    with pytest.raises(AttributeError):
        P.bounded = False  # type: ignore[misc]


def test_names_keyword_follows_the_kept_rows() -> None:
    N = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0], [1.0, 1.0]]
    off = [0.0, -1.0, 0.0, -1.0, -5.0]  # the last row is redundant
    P = ConvexPolytope(N, off, facet_names=["left", "right", "floor", "ceiling", "far"])
    assert P.facet_names == ("left", "right", "floor", "ceiling")
    assert P.removed == (4,)
    assert P.source_rows == (0, 1, 2, 3, -1)


@pytest.mark.parametrize(
    ("normals", "offsets", "names", "message"),
    [
        ([[1.0, np.nan]], [0.0], None, "normals: expected finite values"),
        ([[1.0, 0.0]], [np.inf], None, "offsets: expected finite values"),
        ([[1.0, "a"]], [0.0], None, "normals: expected inward facet normals"),
        ([1.0, 0.0], [0.0], None, r"normals: expected shape \(m, n\) .* got shape \(2,\)"),
        (np.zeros((0, 2)), np.zeros(0), None, r"normals: expected shape \(m, n\) with m >= 1"),
        (np.zeros((2, 0)), np.zeros(2), None, r"n >= 1 dimensions, got shape \(2, 0\)"),
        ([[1.0, 0.0], [0.0, 1.0]], [0.0], None, r"offsets: expected shape \(2,\), one offset"),
        ([[1.0, 0.0], [0.0, 1e-13]], [0.0, 0.0], None, r"got row\(s\) \[1\] of length"),
        ([[1.0, 0.0]], [0.0], ["a", "b"], "names: expected 1 names, one per facet row, got 2"),
        ([[1.0, 0.0]], [0.0], "a", "names: expected a sequence of 1 strings, got str"),
        ([[1.0, 0.0]], [0.0], [3], r"names\[0\]: expected a string, got int"),
    ],
)
def test_constructor_messages(
    normals: object, offsets: object, names: object, message: str
) -> None:
    with pytest.raises(InvalidGeometry, match=message):
        ConvexPolytope(normals, offsets, facet_names=names)  # type: ignore[arg-type]


def test_redundant_choice_is_validated() -> None:
    with pytest.raises(InvalidParameter, match=r"redundant must be one of \['remove', 'keep'\]"):
        ConvexPolytope([[1.0]], [0.0], redundant="drop")  # type: ignore[arg-type]


def test_empty_set_is_refused() -> None:
    with pytest.raises(InvalidGeometry, match=r"empty or lower-dimensional.*no common point"):
        ConvexPolytope([[1.0], [-1.0]], [1.0, 0.0])  # x >= 1 and x <= 0


def test_lower_dimensional_set_is_refused() -> None:
    # x >= 0 and x <= 0 in 2-D: the line x = 0.
    with pytest.raises(InvalidGeometry, match=r"empty or lower-dimensional.*Chebyshev radius 0;"):
        ConvexPolytope([[1.0, 0.0], [-1.0, 0.0]], [0.0, 0.0])
    # A slab thinner than the tolerance is refused; a slab just above it is accepted.
    with pytest.raises(InvalidGeometry, match="Chebyshev radius 5e-10"):
        ConvexPolytope([[1.0, 0.0], [-1.0, 0.0]], [0.0, -1e-9])
    P = ConvexPolytope([[1.0, 0.0], [-1.0, 0.0]], [0.0, -1e-6])
    assert P.chebyshev_radius == pytest.approx(5e-7, rel=1e-6)


# ------------------------------------------------------------------------------ redundancy


def test_box_plus_a_redundant_row() -> None:
    N = np.vstack([np.eye(3), -np.eye(3), [[1.0, 1.0, 1.0]]])
    off = np.array([0.0, 0.0, 0.0, -1.0, -1.0, -1.0, -0.5])  # x + y + z >= -0.5: redundant
    P = ConvexPolytope(N, off)
    assert P.n_facets == 6
    assert P.removed == (6,)
    assert P.source_rows == (0, 1, 2, 3, 4, 5, -1)
    kept = ConvexPolytope(N, off, redundant="keep")
    assert kept.n_facets == 7
    assert kept.removed == ()
    # A row touching the box at a corner only (x + y + z >= 0) is redundant too.
    off[6] = 0.0
    assert ConvexPolytope(N, off).removed == (6,)
    # A row cutting the corner is not.
    off[6] = 0.1
    assert ConvexPolytope(N, off).removed == ()


def test_duplicates_are_merged_keeping_the_tighter_offset() -> None:
    N = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0], [3.0, 0.0], [1.0, 0.0]]
    off = [0.0, -2.0, 0.0, -2.0, 1.5, -1.0]  # row 4 is x >= 0.5: tighter than row 0
    for mode in ("remove", "keep"):
        P = ConvexPolytope(N, off, redundant=mode)  # type: ignore[arg-type]
        assert P.n_facets == 4
        assert P.removed == (0, 5)
        assert P.source_rows == (3, 0, 1, 2, 3, 3)
        assert P.facet_names == ("facet 1", "facet 2", "facet 3", "facet 4")
        assert P.offsets[3] == 0.5
        assert P.contains([0.5, 1.0])
        assert not P.contains([0.4, 1.0])


def test_removal_does_not_change_the_set() -> None:
    rng = np.random.default_rng(7)
    for n in (2, 3, 4):
        N = rng.normal(size=(30, n))
        off = -rng.uniform(0.5, 2.0, size=30)  # the origin is inside
        P = ConvexPolytope(N, off)
        assert P.removed  # 30 random rows in a few dimensions: some are redundant
        X = rng.uniform(-4.0, 4.0, size=(4000, n))
        assert np.array_equal(P.contains_batch(X), _brute_inside(N, off, X))


# ------------------------------------------------------------------------------ box


@pytest.mark.parametrize("n", range(1, 8))
def test_box_in_n_dimensions(n: int) -> None:
    rng = np.random.default_rng(n)
    lo = rng.uniform(-2.0, 0.0, size=n)
    hi = lo + rng.uniform(0.5, 2.0, size=n)
    P = ConvexPolytope.box(lo, hi)
    assert P.dim == n
    assert P.n_facets == 2 * n
    assert P.bounded
    axes = ["x", "y", "z"][:n] if n <= 3 else [f"q{j}" for j in range(n)]
    assert P.facet_names == tuple(f"{a}_{s}" for a in axes for s in ("min", "max"))
    assert P.chebyshev_radius == pytest.approx(float(np.min(hi - lo)) / 2.0, rel=1e-9)
    X = rng.uniform(-3.0, 3.0, size=(500, n))
    inside = np.all((lo <= X) & (hi >= X), axis=1)
    assert np.array_equal(P.contains_batch(X), inside)
    d = P.signed_distances_batch(X)
    assert np.allclose(d[:, 0::2], X - lo, atol=1e-14)
    assert np.allclose(d[:, 1::2], hi - X, atol=1e-14)


def test_box_messages() -> None:
    with pytest.raises(InvalidGeometry, match=r"upper: expected upper > lower element-wise, got "):
        ConvexPolytope.box([0.0, 1.0], [1.0, 1.0])
    with pytest.raises(InvalidGeometry, match=r"lower, upper: expected corners of one shape, got"):
        ConvexPolytope.box([0.0, 0.0], [1.0, 1.0, 1.0])
    with pytest.raises(InvalidGeometry, match=r"lower: expected at least one dimension"):
        ConvexPolytope.box([], [])
    with pytest.raises(InvalidGeometry, match="lower: expected finite values"):
        ConvexPolytope.box([np.nan], [1.0])
    with pytest.raises(InvalidGeometry, match="names: expected 4 names"):
        ConvexPolytope.box([0.0, 0.0], [1.0, 1.0], facet_names=["a"])
    with pytest.raises(InvalidGeometry, match=r"lower, upper: the box is unusable: .*lower-dim"):
        ConvexPolytope.box([0.0, 0.0], [1.0, 1e-12])
    P = ConvexPolytope.box([0.0], [1.0], facet_names=["low", "high"])
    assert P.facet_names == ("low", "high")


# ------------------------------------------------------------------------------ polygon


@given(convex_polygons(), st.integers(min_value=0, max_value=2**32 - 1))
def test_from_polygon_matches_the_polygon(poly: ConvexPolygon, seed: int) -> None:
    P = ConvexPolytope.from_polygon(poly)
    assert P.n_facets == poly.n
    assert P.facet_names == tuple(f"edge {i}" for i in range(poly.n))
    assert np.allclose(P.normals, poly.normals, rtol=0.0, atol=1e-15)
    X = np.random.default_rng(seed).uniform(-6.0, 6.0, size=(50, 2))
    assert np.allclose(P.signed_distances_batch(X), poly.signed_distances(X), rtol=0.0, atol=1e-12)
    assert P.bounded


def test_from_polygon_refuses_other_objects() -> None:
    with pytest.raises(InvalidGeometry, match="polygon: expected a ConvexPolygon, got list"):
        ConvexPolytope.from_polygon([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])  # type: ignore[arg-type]


# ------------------------------------------------------------------------------ queries


def test_contains_at_the_boundary() -> None:
    P = ConvexPolytope.box([0.0, 0.0, 0.0], [1.0, 2.0, 3.0])
    assert P.contains([1.0, 2.0, 3.0])  # a corner
    assert P.contains([0.0, 1.0, 1.0])  # a face
    assert not P.contains([1.0 + 1e-12, 1.0, 1.0])
    assert P.contains([1.0 + 1e-12, 1.0, 1.0], tol=1e-9)
    assert not P.contains([1.1, 1.0, 1.0], tol=1e-9)
    assert P.contains_batch([[1.0, 2.0, 3.0], [1.1, 0.0, 0.0]]).tolist() == [True, False]


def test_query_messages() -> None:
    P = ConvexPolytope.box([0.0, 0.0], [1.0, 1.0])
    with pytest.raises(InvalidInput, match=r"x: expected shape \(2,\), got shape \(3,\)"):
        P.signed_distances([1.0, 2.0, 3.0])
    with pytest.raises(InvalidInput, match="x: expected finite values"):
        P.contains([np.nan, 0.0])
    with pytest.raises(InvalidInput, match=r"X: expected shape \(N, 2\), got shape \(2,\)"):
        P.signed_distances_batch([1.0, 2.0])
    with pytest.raises(InvalidParameter, match="tol must be finite and >= 0"):
        P.contains([0.5, 0.5], tol=-1.0)
    with pytest.raises(InvalidParameter, match="tol must be finite and >= 0"):
        P.contains_batch([[0.5, 0.5]], tol=math.inf)


def test_batch_forms_equal_looping() -> None:
    rng = np.random.default_rng(3)
    N = rng.normal(size=(9, 4))
    P = ConvexPolytope(N, -np.ones(9), redundant="keep")
    X = rng.uniform(-3.0, 3.0, size=(200, 4))
    D = P.signed_distances_batch(X)
    assert np.array_equal(D, np.array([P.signed_distances(x) for x in X]))
    assert np.array_equal(P.contains_batch(X), np.array([P.contains(x) for x in X]))
    assert P.signed_distances_batch(np.zeros((0, 4))).shape == (0, 9)


# ------------------------------------------------------------------------------ unbounded


def test_two_tilted_planes_in_3d() -> None:
    # z >= x and z >= -x: a wedge along y, holding arbitrarily large balls.
    P = ConvexPolytope([[-1.0, 0.0, 1.0], [1.0, 0.0, 1.0]], [0.0, 0.0])
    assert not P.bounded
    assert P.chebyshev_radius == math.inf
    assert np.all(np.isfinite(P.chebyshev_center))
    assert P.contains(P.chebyshev_center)
    assert P.contains([0.0, 1e6, 5.0])
    assert not P.contains([1.0, 0.0, 0.5])


def test_slab_is_unbounded_with_a_finite_radius() -> None:
    P = ConvexPolytope([[1.0, 1.0, 0.0], [-1.0, -1.0, 0.0]], [0.0, -math.sqrt(2.0)])
    assert not P.bounded
    assert P.chebyshev_radius == pytest.approx(0.5, rel=1e-9)
    assert P.signed_distances(P.chebyshev_center) == pytest.approx([0.5, 0.5], rel=1e-9)


def test_bounded_agrees_with_coordinate_lps() -> None:
    """``bounded`` against an independent route: maximise ±x_j over the set by scipy's simplex."""
    from scipy.optimize import linprog

    rng = np.random.default_rng(11)
    for trial in range(40):
        n = int(rng.integers(1, 5))
        m = int(rng.integers(1, 3 * n + 2))
        N = rng.normal(size=(m, n))
        off = -rng.uniform(0.1, 1.0, size=m)
        P = ConvexPolytope(N, off, redundant="keep")
        finite = True
        for j, s in itertools.product(range(n), (1.0, -1.0)):
            c = np.zeros(n)
            c[j] = -s
            res = linprog(c, A_ub=-N, b_ub=-off, bounds=[(None, None)] * n, method="highs-ds")
            finite &= res.status == 0
        assert P.bounded == finite, trial


# ------------------------------------------------------------------------------ closest point


def _random_polytope(rng: np.random.Generator, n: int, m: int) -> ConvexPolytope:
    """Random half-spaces around a random point (the point is inside by at least 0.2)."""
    c = rng.uniform(-1.0, 1.0, size=n)
    N = rng.normal(size=(m, n))
    N /= np.linalg.norm(N, axis=1)[:, None]
    return ConvexPolytope(N, N @ c - rng.uniform(0.2, 1.5, size=m), redundant="keep")


@requires_qp
@pytest.mark.parametrize("n", range(1, 8))
def test_closest_point_matches_daqp(n: int) -> None:
    from qpsolvers import solve_qp

    rng = np.random.default_rng(100 + n)
    for _ in range(6):
        P = _random_polytope(rng, n, int(rng.integers(1, 3 * n + 3)))
        X = rng.uniform(-4.0, 4.0, size=(20, n))
        Y = P.closest_point_batch(X)
        for x, y in zip(X, Y, strict=True):
            ref = solve_qp(np.eye(n), -x, -P.normals, -P.offsets, solver="daqp")
            np.testing.assert_allclose(y, ref, atol=1e-9)
            assert np.array_equal(y, P.closest_point(x))  # batch = one at a time
            # inside, as evaluated or (where many facets meet) to round-off
            assert np.all(P.signed_distances(y) >= -1e-12 * (1.0 + np.abs(P.offsets)))


def test_closest_point_of_an_inside_point_is_the_point() -> None:
    P = ConvexPolytope.box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    x = np.array([0.25, 0.5, 1.0])
    y = P.closest_point(x)
    assert np.array_equal(y, x)
    assert y is not x
    # Outside a box, the projection is the clip (an independent route).
    X = np.random.default_rng(5).uniform(-2.0, 3.0, size=(100, 3))
    np.testing.assert_allclose(P.closest_point_batch(X), np.clip(X, 0.0, 1.0), atol=1e-15)
    with pytest.raises(InvalidInput, match=r"x: expected shape \(3,\), got shape \(2,\)"):
        P.closest_point([1.0, 2.0])
    with pytest.raises(InvalidInput, match=r"X: expected shape \(N, 3\)"):
        P.closest_point_batch([[1.0, 2.0]])


def test_closest_point_on_an_unbounded_set() -> None:
    P = ConvexPolytope([[-1.0, 0.0, 1.0], [1.0, 0.0, 1.0]], [0.0, 0.0])  # z >= |x|
    np.testing.assert_allclose(P.closest_point([0.0, 7.0, -1.0]), [0.0, 7.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(P.closest_point([2.0, 0.0, 0.0]), [1.0, 0.0, 1.0], atol=1e-15)


# ------------------------------------------------------------------------------ vertices, hull


def _rows(P: ConvexPolytope) -> np.ndarray:
    """The facets as rows (normal, offset), sorted, for set comparisons."""
    R = np.round(np.hstack([P.normals, P.offsets[:, None]]), 9) + 0.0
    return R[np.lexsort(R.T[::-1])]


@pytest.mark.parametrize("n", range(1, 8))
def test_from_vertices_of_box_corners_is_the_box(n: int) -> None:
    rng = np.random.default_rng(n)
    lo = rng.uniform(-2.0, 0.0, size=n)
    hi = lo + rng.uniform(0.5, 2.0, size=n)
    corners = np.array(list(itertools.product(*zip(lo, hi, strict=True))))
    inner = lo + (hi - lo) * rng.uniform(0.1, 0.9, size=(10, n))  # ignored interior points
    H = ConvexPolytope.from_vertices(np.vstack([inner, corners]))
    B = ConvexPolytope.box(lo, hi)
    assert H.n_facets == 2 * n
    np.testing.assert_allclose(_rows(H), _rows(B), atol=1e-9)
    V = B.vertices
    assert V.shape == (2**n, n)
    got = {tuple(np.round(v, 9)) for v in V}
    assert got == {tuple(np.round(c, 9)) for c in corners}
    assert B.volume == pytest.approx(float(np.prod(hi - lo)), rel=1e-9)


@pytest.mark.parametrize("n", range(2, 6))
def test_vertices_of_random_polytopes(n: int) -> None:
    rng = np.random.default_rng(20 + n)
    P = _random_polytope(rng, n, 4 * n + 4)
    P = ConvexPolytope(P.normals, P.offsets)  # redundant rows removed: facets are the hull's
    if not P.bounded:
        P = ConvexPolytope(
            np.vstack([P.normals, np.eye(n), -np.eye(n)]),
            np.concatenate([P.offsets, -5.0 * np.ones(2 * n)]),
        )
    V = P.vertices
    D = P.signed_distances_batch(V)
    assert np.all(D >= -1e-9)  # inside
    assert np.all(np.sum(np.abs(D) <= 1e-9, axis=1) >= n)  # on at least n facets: vertices
    # The hull of the vertices is the polytope again (facets compared as sets).
    np.testing.assert_allclose(_rows(ConvexPolytope.from_vertices(V)), _rows(P), atol=1e-7)
    # Volume against Monte Carlo in the bounding box (independent of qhull).
    lo, hi = V.min(axis=0), V.max(axis=0)
    X = rng.uniform(lo, hi, size=(200_000, n))
    mc = float(np.prod(hi - lo)) * float(np.mean(P.contains_batch(X)))
    assert P.volume == pytest.approx(mc, rel=0.03)


def test_simplex_volume_and_vertices() -> None:
    for n in range(1, 8):
        P = ConvexPolytope(np.vstack([np.eye(n), -np.ones((1, n))]), np.r_[np.zeros(n), -1.0])
        assert P.volume == pytest.approx(1.0 / math.factorial(n), rel=1e-9)
        assert P.vertices.shape == (n + 1, n)


def test_unbounded_sets_have_no_vertices_and_infinite_volume() -> None:
    P = ConvexPolytope([[1.0, 0.0], [0.0, 1.0]], [0.0, 0.0])
    assert P.volume == math.inf
    with pytest.raises(InvalidGeometry, match="vertices: expected a bounded polytope, got an"):
        _ = P.vertices
    with pytest.raises(InvalidGeometry, match="largest_inscribed_box: expected a bounded"):
        P.largest_inscribed_box()


def test_from_vertices_messages() -> None:
    with pytest.raises(InvalidGeometry, match=r"points: expected at least n \+ 1 = 3 points"):
        ConvexPolytope.from_vertices([[0.0, 0.0], [1.0, 0.0]])
    with pytest.raises(InvalidGeometry, match="points: expected points spanning 3 dimensions"):
        ConvexPolytope.from_vertices([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 3, 0]])
    with pytest.raises(InvalidGeometry, match="points: expected points spanning 2 dimensions"):
        ConvexPolytope.from_vertices([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])  # collinear
    with pytest.raises(InvalidGeometry, match=r"points: the hull is unusable: .*lower-dimensional"):
        ConvexPolytope.from_vertices([[1.0], [1.0]])
    with pytest.raises(InvalidGeometry, match=r"points: expected shape \(k, n\)"):
        ConvexPolytope.from_vertices([1.0, 2.0, 3.0])
    with pytest.raises(InvalidGeometry, match="points: expected finite values"):
        ConvexPolytope.from_vertices([[0.0, 0.0], [1.0, 0.0], [0.0, np.inf]])
    with pytest.raises(InvalidGeometry, match="names: expected 3 names"):
        ConvexPolytope.from_vertices([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], facet_names=["a"])
    T = ConvexPolytope.from_vertices(
        [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], facet_names=["a", "b", "c"]
    )
    assert T.facet_names == ("a", "b", "c")
    assert T.volume == pytest.approx(0.5, rel=1e-12)
    line = ConvexPolytope.from_vertices([[2.0], [-1.0], [0.5]])
    np.testing.assert_allclose(line.vertices.ravel(), [-1.0, 2.0])


# ------------------------------------------------------------------------------ inscribed box


def _corners_inside(P: ConvexPolytope, lo: np.ndarray, hi: np.ndarray) -> bool:
    corners = np.array(list(itertools.product(*zip(lo, hi, strict=True))))
    return bool(np.all(P.contains_batch(corners, tol=1e-12)))


@pytest.mark.parametrize("n", range(1, 8))
def test_largest_box_of_a_box_is_the_box(n: int) -> None:
    rng = np.random.default_rng(n)
    lo = rng.uniform(-2.0, 0.0, size=n)
    hi = lo + rng.uniform(0.5, 2.0, size=n)
    L, U = ConvexPolytope.box(lo, hi).largest_inscribed_box()
    np.testing.assert_allclose(L, lo, atol=1e-9)
    np.testing.assert_allclose(U, hi, atol=1e-9)


@pytest.mark.parametrize("n", range(1, 8))
def test_largest_box_in_the_simplex_and_the_cross_polytope(n: int) -> None:
    # Simplex x >= 0, Σx <= 1: by AM-GM the box is [0, 1/n]^n.
    S = ConvexPolytope(np.vstack([np.eye(n), -np.ones((1, n))]), np.r_[np.zeros(n), -1.0])
    L, U = S.largest_inscribed_box()
    np.testing.assert_allclose(L, 0.0, atol=1e-7)
    np.testing.assert_allclose(U, 1.0 / n, atol=1e-7)
    assert _corners_inside(S, L, U)
    # Cross-polytope Σ|x| <= 1 (2^n facets): the box is [-1/n, 1/n]^n.
    signs = np.array(list(itertools.product((1.0, -1.0), repeat=n)))
    X = ConvexPolytope(signs, -np.ones(len(signs)))
    L, U = X.largest_inscribed_box()
    np.testing.assert_allclose(L, -1.0 / n, atol=1e-7)
    np.testing.assert_allclose(U, 1.0 / n, atol=1e-7)
    assert _corners_inside(X, L, U)


@given(convex_polygons())
def test_largest_box_matches_the_polygon_rectangle(poly: ConvexPolygon) -> None:
    L, U = ConvexPolytope.from_polygon(poly).largest_inscribed_box()
    r = poly.inscribed_rectangle()  # grid search on log-concave area: an independent route
    area = float(np.prod(U - L))
    # Inside (so at most the optimum) and never smaller than the grid search's rectangle, which
    # is itself up to ~1e-5 below the optimum on some polygons (the convex solve finds more).
    assert _corners_inside(ConvexPolytope.from_polygon(poly), L, U)
    assert area >= r.area * (1.0 - 1e-9)
    assert area == pytest.approx(r.area, rel=1e-4)


def test_largest_box_is_read_only_and_cached() -> None:
    P = ConvexPolytope.from_vertices([[0.0, 0.0], [2.0, 0.0], [0.0, 1.0]])
    L, U = P.largest_inscribed_box()
    assert P.largest_inscribed_box()[0] is L
    with pytest.raises(ValueError, match="read-only"):
        L[0] = 1.0
    np.testing.assert_allclose(L, [0.0, 0.0], atol=1e-8)
    np.testing.assert_allclose(U, [1.0, 0.5], atol=1e-8)


@pytest.mark.parametrize("n", range(2, 7))
def test_largest_box_meets_the_kkt_conditions(n: int) -> None:
    """An optimality certificate independent of the solver: at the optimum, the objective's
    gradient is a non-negative combination of the active facets' rows (non-negative least
    squares on the active set), and the box is inside."""
    from scipy.optimize import nnls

    rng = np.random.default_rng(40 + n)
    for _ in range(4):
        pts = rng.normal(size=(int(rng.integers(n + 3, 25)), n)) * rng.uniform(0.5, 3.0, size=n)
        P = ConvexPolytope.from_vertices(pts)
        L, U = P.largest_inscribed_box()
        assert _corners_inside(P, L, U)
        N = P.normals
        A = np.hstack([np.maximum(N, 0.0), -np.maximum(-N, 0.0)])  # min of n_i·x over the box
        w = U - L
        active = A @ np.r_[L, U] - P.offsets <= 1e-7 * P.chebyshev_radius
        grad = np.r_[1.0 / w, -1.0 / w]  # minus the gradient of Σ log w_j in (l, u)
        _, residual = nnls(A[active].T, grad)
        assert residual <= 1e-6 * float(np.linalg.norm(grad))


def test_a_polytope_built_again_reuses_its_programs_and_equals_the_first(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The construction's linear programs are remembered by their input bytes: the same rows
    built again run none and give the same polytope bit for bit; other rows still run them."""
    import velfence.geometry.polytope as poly

    rng = np.random.default_rng(11)
    N = rng.normal(size=(9, 3))
    off = -rng.uniform(0.5, 1.5, size=9)
    first = ConvexPolytope(N, off)
    calls: list[int] = []
    real = poly._linprog

    def counted(*args: object, **kwargs: object) -> object:
        calls.append(1)
        return real(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(poly, "_linprog", counted)
    again = ConvexPolytope(N.copy(), off.copy())
    assert calls == []
    for name in ("normals", "offsets", "chebyshev_center", "removed", "source_rows", "bounded"):
        a, b = getattr(first, name), getattr(again, name)
        assert np.array_equal(a, b), name
    assert first.chebyshev_radius == again.chebyshev_radius
    ConvexPolytope(N, off - 0.25)  # other offsets: its own programs
    assert calls
