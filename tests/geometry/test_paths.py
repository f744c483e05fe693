"""Arc-length paths: closed forms, finite differences, C¹ joins, closest points, validation.

Every path type is checked against an independent route: Line and Circle against their closed
forms, all types by central finite differences (tangent = dR/ds, curvature = dT/ds), arc-length
consistency |R(s+h) - R(s)| ≈ h, the smoothed polyline's length against the hand formula, and
closest() against brute-force dense sampling.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.paths import Circle, Line, Path, Polyline, Spline

EXACT_TOL = 1e-12  # closed forms
FD_STEP = 1e-5  # central difference step [m]
FD_TOL = 1e-7  # O(h²) truncation + O(eps/h) round-off for unit-scale paths
ARC_STEP = 1e-3  # chord test step [m]
ARC_RTOL = 1e-9  # arc-length error allowed on top of the chord's own h²κ²/24
BRUTE_SAMPLES = 50_001

# ---------------------------------------------------------------------------- fixtures


def _lemniscate(n: int = 40) -> np.ndarray:
    """Gerono's lemniscate (a figure eight crossing itself at the origin), n points."""
    t = 2.0 * np.pi * np.arange(n) / n
    return np.column_stack([2.0 * np.sin(t), 2.0 * np.sin(t) * np.cos(t)])


FACTORIES: dict[str, Callable[[], Path]] = {
    "line-2d": lambda: Line([0.0, 0.0], [3.0, 4.0]),
    "line-3d": lambda: Line([1.0, -1.0, 0.5], [2.0, 1.0, -1.5]),
    "circle-2d": lambda: Circle([0.5, -0.2], radius=1.5, start_angle=0.3),
    "circle-2d-cw": lambda: Circle([0.0, 0.0], radius=0.8, ccw=False),
    "circle-3d": lambda: Circle([0.0, 1.0, 2.0], radius=1.2, normal=[1.0, 1.0, 1.0]),
    "polyline-2d": lambda: Polyline(
        [[0, 0], [2, 0], [3, 1.5], [1, 3], [0, 2]], corner_radius=[0.4, 0.5, 0.3]
    ),
    "polyline-3d": lambda: Polyline(
        [[0, 0, 0], [2, 0, 0], [2, 2, 1], [0, 2, 2]], corner_radius=0.5
    ),
    "polyline-closed": lambda: Polyline(
        [[0, 0], [3, 0], [3, 2], [0, 2]], corner_radius=0.6, closed=True
    ),
    "spline-2d": lambda: Spline([[0, 0], [1, 1], [2, 0.5], [3, 1.5], [4, 0]]),
    "spline-3d": lambda: Spline([[0, 0, 0], [1, 1, 0.5], [2, 0, 1], [3, 1, 1.5]]),
    "spline-closed": lambda: Spline(_lemniscate(), closed=True),
}


@pytest.fixture(params=sorted(FACTORIES))
def path(request: pytest.FixtureRequest) -> Path:
    return FACTORIES[request.param]()


def _interior_s(p: Path, n: int = 57, margin: float = 1e-3) -> np.ndarray:
    """Arc lengths away from the ends and from every join (where curvature may jump)."""
    S = np.linspace(margin, p.length - margin, n)
    joins = getattr(p, "joins", None)
    if joins is not None:
        joins = np.concatenate([np.asarray(joins), [p.length]])
        keep = np.min(np.abs(S[:, None] - joins[None, :]), axis=1) > margin
        S = S[keep]
    return S


# ---------------------------------------------------------------------------- closed forms


def test_line_closed_form() -> None:
    a, b = np.array([1.0, -1.0, 0.5]), np.array([2.0, 1.0, -1.5])
    line = Line(a, b)
    L = float(np.linalg.norm(b - a))
    T = (b - a) / L
    assert line.length == pytest.approx(L, abs=EXACT_TOL)
    assert not line.closed
    assert line.dim == 3
    for s in (0.0, 0.7, L):
        np.testing.assert_allclose(line.point(s), a + s * T, atol=EXACT_TOL)
        np.testing.assert_allclose(line.tangent(s), T, atol=EXACT_TOL)
        np.testing.assert_array_equal(line.curvature(s), np.zeros(3))
    # An open path clamps s to [0, length].
    np.testing.assert_allclose(line.point(-1.0), a, atol=EXACT_TOL)
    np.testing.assert_allclose(line.point(L + 2.0), b, atol=EXACT_TOL)


@pytest.mark.parametrize("ccw", [True, False])
def test_circle_2d_closed_form(ccw: bool) -> None:
    c, r, a0 = np.array([0.5, -0.2]), 1.5, 0.3
    circ = Circle(c, radius=r, start_angle=a0, ccw=ccw)
    sign = 1.0 if ccw else -1.0
    assert circ.length == pytest.approx(2 * math.pi * r, abs=EXACT_TOL)
    assert circ.closed
    for s in np.linspace(0.0, circ.length, 13):
        th = a0 + sign * s / r
        radial = np.array([math.cos(th), math.sin(th)])
        np.testing.assert_allclose(circ.point(s), c + r * radial, atol=EXACT_TOL)
        np.testing.assert_allclose(
            circ.tangent(s), sign * np.array([-math.sin(th), math.cos(th)]), atol=EXACT_TOL
        )
        kn = circ.curvature(s)
        np.testing.assert_allclose(kn, -radial / r, atol=EXACT_TOL)
        assert np.linalg.norm(kn) == pytest.approx(1.0 / r, abs=EXACT_TOL)
    # Closed: s wraps modulo the length.
    np.testing.assert_allclose(circ.point(circ.length + 0.4), circ.point(0.4), atol=1e-12)
    np.testing.assert_allclose(circ.point(-0.4), circ.point(circ.length - 0.4), atol=1e-12)


def test_circle_3d_lies_in_its_plane_and_turns_about_the_normal() -> None:
    c, r = np.array([0.0, 1.0, 2.0]), 1.2
    nrm = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)
    for ccw in (True, False):
        circ = Circle(c, radius=r, normal=[1.0, 1.0, 1.0], ccw=ccw)
        for s in np.linspace(0.0, circ.length, 11):
            rel = circ.point(s) - c
            assert abs(rel @ nrm) < EXACT_TOL
            assert np.linalg.norm(rel) == pytest.approx(r, abs=EXACT_TOL)
            np.testing.assert_allclose(circ.curvature(s), -rel / r**2, atol=EXACT_TOL)
            turn = np.cross(rel, circ.tangent(s)) @ nrm
            assert turn == pytest.approx(r if ccw else -r, abs=1e-12)


# ---------------------------------------------------------------------------- all path types


def test_frame_and_batches_agree_with_the_single_queries(path: Path) -> None:
    """The Path protocol's three views of one point agree: frame(), the single and the batch
    queries; a closed path wraps modulo its length."""
    S = np.linspace(0.0, path.length, 17)
    T, K = path.tangents(S), path.curvatures(S)
    assert T.shape == K.shape == (17, path.dim)
    for s, t_row, k_row in zip(S, T, K, strict=True):
        point, tangent, curvature = path.frame(float(s))
        np.testing.assert_array_equal(point, path.point(float(s)))
        np.testing.assert_array_equal(tangent, path.tangent(float(s)))
        np.testing.assert_array_equal(curvature, path.curvature(float(s)))
        np.testing.assert_allclose(t_row, tangent, rtol=0, atol=1e-14)
        np.testing.assert_allclose(k_row, curvature, rtol=0, atol=1e-12)
    if path.closed:
        s = 0.3 * path.length
        np.testing.assert_allclose(path.point(s + path.length), path.point(s), atol=1e-12)


def test_tangent_is_unit_and_curvature_normal(path: Path) -> None:
    S = np.linspace(0.0, path.length, 301)
    T = np.asarray(path.tangents(S))
    K = np.asarray(path.curvatures(S))
    np.testing.assert_allclose(np.linalg.norm(T, axis=1), 1.0, atol=1e-13)
    np.testing.assert_allclose(np.sum(T * K, axis=1), 0.0, atol=1e-10)


def test_tangent_is_derivative_of_point(path: Path) -> None:
    h = FD_STEP
    for s in _interior_s(path):
        fd = (path.point(s + h) - path.point(s - h)) / (2 * h)
        np.testing.assert_allclose(path.tangent(s), fd, atol=FD_TOL, err_msg=f"s={s}")


def test_curvature_is_derivative_of_tangent(path: Path) -> None:
    h = FD_STEP
    for s in _interior_s(path):
        fd = (path.tangent(s + h) - path.tangent(s - h)) / (2 * h)
        np.testing.assert_allclose(path.curvature(s), fd, atol=5e-6, err_msg=f"s={s}")


def test_arc_length_consistency(path: Path) -> None:
    # A chord of arc length h is h(1 - h²κ²/24 + ...): allow that, plus ARC_RTOL.
    h = ARC_STEP
    S = np.linspace(0.0, path.length - h, 401)
    kmax = float(np.max(np.linalg.norm(path.curvatures(np.linspace(0, path.length, 2001)), axis=1)))
    chord = np.linalg.norm(path.points(S + h) - path.points(S), axis=1)
    np.testing.assert_allclose(chord, h, rtol=ARC_RTOL + 1.01 * h**2 * kmax**2 / 24)
    assert np.all(chord <= h * (1 + ARC_RTOL))  # a chord is never longer than its arc


def test_points_equals_point(path: Path) -> None:
    S = np.linspace(-0.5, path.length + 0.5, 23)
    P = path.points(S)
    assert P.shape == (23, path.dim)
    for s, row in zip(S, P, strict=True):
        np.testing.assert_allclose(path.point(float(s)), row, rtol=0, atol=1e-14)


def test_closest_matches_brute_force(path: Path) -> None:
    rng = np.random.default_rng(7)
    S = np.linspace(0.0, path.length, BRUTE_SAMPLES)
    dense = path.points(S)
    lo, hi = dense.min(axis=0) - 0.5, dense.max(axis=0) + 0.5
    spacing = path.length / (BRUTE_SAMPLES - 1)
    for q in rng.uniform(lo, hi, size=(25, path.dim)):
        s = path.closest(q)
        assert 0.0 <= s <= path.length
        ours = float(np.linalg.norm(path.point(s) - q))
        brute = float(np.min(np.linalg.norm(dense - q, axis=1)))
        # Ours is the true minimum: never worse than sampling, and at most the sampling's
        # own error (spacing²/(2·distance) ≤ spacing) better.
        assert ours <= brute + 1e-12
        assert ours >= brute - spacing


# ---------------------------------------------------------------------------- polyline


def _hand_length(V: np.ndarray, radii: list[float], closed: bool) -> float:
    seg = (np.roll(V, -1, axis=0) - V) if closed else np.diff(V, axis=0)
    total = float(np.sum(np.linalg.norm(seg, axis=1)))
    corners = range(len(V)) if closed else range(1, len(V) - 1)
    for i, r in zip(corners, radii, strict=True):
        d1 = seg[i - 1] / np.linalg.norm(seg[i - 1])
        d2 = seg[i % len(seg)] / np.linalg.norm(seg[i % len(seg)])
        alpha = math.acos(float(np.clip(d1 @ d2, -1, 1)))
        total += r * alpha - 2.0 * r * math.tan(alpha / 2.0)
    return total


@pytest.mark.parametrize(
    ("V", "radii", "closed"),
    [
        ([[0, 0], [2, 0], [3, 1.5], [1, 3], [0, 2]], [0.4, 0.5, 0.3], False),
        ([[0, 0, 0], [2, 0, 0], [2, 2, 1], [0, 2, 2]], [0.5, 0.5], False),
        ([[0, 0], [3, 0], [3, 2], [0, 2]], [0.6, 0.6, 0.6, 0.6], True),
        ([[0, 0], [1, 0], [2, 0], [2, 1]], [0.3, 0.2], False),  # a straight "corner"
    ],
)
def test_polyline_length_and_joins(V: list[list[float]], radii: list[float], closed: bool) -> None:
    Va = np.asarray(V, dtype=float)
    pl = Polyline(Va, corner_radius=radii, closed=closed)
    assert pl.length == pytest.approx(_hand_length(Va, radii, closed), abs=1e-12)
    if closed:
        np.testing.assert_allclose(pl.point(0.0), pl.point(pl.length), atol=1e-12)
    else:
        np.testing.assert_allclose(pl.point(0.0), Va[0], atol=EXACT_TOL)
        np.testing.assert_allclose(pl.point(pl.length), Va[-1], atol=EXACT_TOL)
    eps = 1e-9
    joins = [float(j) for j in pl.joins if j > 0.0] + ([pl.length] if closed else [])
    assert joins, "expected at least one join"
    for j in joins:
        before, after = j - eps, j + eps
        # C¹: point and tangent continuous across the join.
        np.testing.assert_allclose(pl.point(before), pl.point(after), atol=3 * eps)
        np.testing.assert_allclose(pl.tangent(before), pl.tangent(after), atol=1e-8)
        # Curvature jumps between 0 (straight) and 1/r (arc).
        k_b = float(np.linalg.norm(pl.curvature(before)))
        k_a = float(np.linalg.norm(pl.curvature(after)))
        assert min(k_b, k_a) == 0.0
        # (Both 0 only where a straight "corner" got no arc.)
        assert max(k_b, k_a) == 0.0 or any(
            max(k_b, k_a) == pytest.approx(1.0 / r, rel=1e-12) for r in radii
        )


def test_polyline_arc_clearance_from_vertex() -> None:
    # The arc passes r(1/cos(α/2) - 1) from the vertex it rounds (right angle: r(√2 - 1)).
    r = 0.5
    pl = Polyline([[0, 0], [2, 0], [2, 2]], corner_radius=r)
    dense = pl.points(np.linspace(0, pl.length, 100_001))
    gap = np.min(np.linalg.norm(dense - np.array([2.0, 0.0]), axis=1))
    assert gap == pytest.approx(r * (math.sqrt(2.0) - 1.0), abs=1e-8)
    # Arc curvature points towards the inside of the turn with magnitude 1/r.
    mid = pl.length / 2.0
    np.testing.assert_allclose(pl.curvature(mid), np.array([-1.0, 1.0]) / math.sqrt(2) / r)


def test_polyline_radius_that_just_fits_is_accepted() -> None:
    # Right angle, segments of length 2: tangent length r·tan(45°) = r must be <= 1.
    pl = Polyline([[0, 0], [2, 0], [2, 2]], corner_radius=1.0)
    assert pl.length == pytest.approx(1.0 + math.pi / 2 + 1.0, abs=1e-12)


# ---------------------------------------------------------------------------- spline


def test_spline_passes_through_its_points() -> None:
    P = np.array([[0, 0], [1, 1], [2, 0.5], [3, 1.5], [4, 0]], dtype=float)
    sp = Spline(P)
    for q in P:
        assert np.linalg.norm(sp.point(sp.closest(q)) - q) < 1e-12
    np.testing.assert_allclose(sp.point(0.0), P[0], atol=1e-12)
    np.testing.assert_allclose(sp.point(sp.length), P[-1], atol=1e-12)
    # Natural end conditions: zero curvature at both ends.
    assert np.linalg.norm(sp.curvature(0.0)) < 1e-12
    assert np.linalg.norm(sp.curvature(sp.length)) < 1e-12


def test_spline_length_against_dense_chords() -> None:
    sp = Spline([[0, 0, 0], [1, 1, 0.5], [2, 0, 1], [3, 1, 1.5]])
    P = sp.points(np.linspace(0.0, sp.length, 40_001))
    chords = float(np.sum(np.linalg.norm(np.diff(P, axis=0), axis=1)))
    assert chords == pytest.approx(sp.length, rel=1e-8)  # chord error ≈ h²κ²/24 ≈ 1e-9


def test_closed_spline_is_c2_at_the_wrap() -> None:
    sp = Spline(_lemniscate(), closed=True)
    eps = 1e-7
    L = sp.length
    np.testing.assert_allclose(sp.point(L - eps), sp.point(eps), atol=3 * eps)
    np.testing.assert_allclose(sp.tangent(L - eps), sp.tangent(eps), atol=1e-6)
    np.testing.assert_allclose(sp.curvature(L - eps), sp.curvature(eps), atol=1e-5)


def test_spline_on_a_circle_approximates_the_circle() -> None:
    r = 2.0
    t = 2 * np.pi * np.arange(24) / 24
    sp = Spline(np.column_stack([r * np.cos(t), r * np.sin(t)]), closed=True)
    assert sp.length == pytest.approx(2 * math.pi * r, rel=1e-5)
    S = np.linspace(0, sp.length, 500)
    np.testing.assert_allclose(np.linalg.norm(sp.points(S), axis=1), r, rtol=1e-4)
    np.testing.assert_allclose(np.linalg.norm(sp.curvatures(S), axis=1), 1 / r, rtol=1e-2)


# ---------------------------------------------------------------------------- closest: local


@pytest.mark.parametrize(
    "factory",
    [
        lambda: Spline(_lemniscate(), closed=True),
        lambda: Polyline(
            [[0, 0], [2, 1], [2, -1], [-2, 1], [-2, -1]], corner_radius=0.3, closed=True
        ),
    ],
    ids=["spline-figure-eight", "polyline-bow-tie"],
)
def test_local_window_follows_a_moving_point_through_a_crossing(
    factory: Callable[[], Path],
) -> None:
    fig = factory()
    L = fig.length
    steps = 200
    rng = np.random.default_rng(3)
    s_true = np.arange(steps + 1) * L / steps * 1.5  # one and a half laps
    prev = 0.0
    jumps_global = 0
    for st in s_true:
        tn = fig.tangent(float(st))
        off = rng.normal(scale=0.02, size=fig.dim)
        q = fig.point(float(st)) + off - (off @ tn) * tn  # offset across the path only
        s_loc = fig.closest(q, s0=prev, window=0.05 * L)
        err = abs(s_loc - st % L)
        assert min(err, L - err) < 1e-3 * L, f"tracker jumped at s={st}: got {s_loc}"
        prev = s_loc
        eg = abs(fig.closest(q) - st % L)
        jumps_global += min(eg, L - eg) > 0.1 * L
    # The test has teeth: a global search does jump branches near the crossing.
    assert jumps_global > 0


def test_closest_ties_are_deterministic() -> None:
    circ = Circle([0.0, 0.0], radius=1.0)
    assert circ.closest([0.0, 0.0]) == 0.0  # every point ties: smallest s
    assert circ.closest([0.0, 0.0], s0=2.0, window=0.5) == pytest.approx(2.0)
    # Two ends of a U equally far from a point on its axis: smallest s, or nearest s0.
    pl = Polyline([[0, 1], [0, 0], [2, 0], [2, 1]], corner_radius=0.5)
    q = [1.0, 5.0]
    assert pl.closest(q) == 0.0
    assert pl.closest(q, s0=pl.length) == pytest.approx(pl.length)


def test_local_window_on_open_path_is_clipped() -> None:
    line = Line([0.0, 0.0], [10.0, 0.0])
    assert line.closest([9.0, 1.0], s0=1.0, window=2.0) == pytest.approx(3.0)
    assert line.closest([-5.0, 1.0], s0=1.0, window=2.0) == pytest.approx(0.0)
    assert line.closest([9.0, 1.0], s0=1.0) == pytest.approx(9.0)


# ---------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("build", "error", "match"),
    [
        (lambda: Line([1, 2], [1, 2]), InvalidGeometry, r"distinct start and end"),
        (lambda: Line([1, 2], [1, 2, 3]), InvalidGeometry, r"end: expected shape \(2,\)"),
        (lambda: Line([1, math.nan], [1, 2]), InvalidGeometry, r"expected finite"),
        (lambda: Circle([0, 0], radius=0.0), InvalidParameter, r"radius must be finite and > 0"),
        (lambda: Circle([0, 0], radius=-1), InvalidParameter, r"radius must be finite and > 0"),
        (lambda: Circle([0, 0, 0], radius=1.0), InvalidGeometry, r"needs its plane normal"),
        (lambda: Circle([0, 0], radius=1.0, normal=[0, 0, 1]), InvalidGeometry, r"normal=None"),
        (lambda: Circle([0, 0, 0], radius=1.0, normal=[0, 0, 0]), InvalidGeometry, r"non-zero"),
        (lambda: Circle([0, 0, 0, 0], radius=1.0), InvalidGeometry, r"2-D or 3-D"),
        (lambda: Circle([0, 0], radius=1.0, ccw="yes"), InvalidParameter, r"ccw: expected True"),
        (
            lambda: Polyline([[0, 0], [2, 0], [2, 2]], corner_radius=1.5),
            InvalidGeometry,
            r"corner 0 \(vertex 1 at \[2\.0, 0\.0\]\).*tangent length.*expected <= half.*"
            r"reduce corner_radius to <= 1 m",
        ),
        (
            lambda: Polyline([[0, 0], [2, 0], [2, 2], [2.2, 0]], corner_radius=[0.5, 0.5]),
            InvalidGeometry,
            r"corner 1 \(vertex 2 at \[2\.0, 2\.0\]\)",
        ),
        (
            lambda: Polyline([[0, 0], [2, 0], [1, 0]], corner_radius=0.1),
            InvalidGeometry,
            r"corner 0 \(vertex 1 .*reverses direction",
        ),
        (
            lambda: Polyline([[0, 0], [0, 0], [1, 0]], corner_radius=0.1),
            InvalidGeometry,
            r"distinct consecutive vertices, got vertex 0 equal to vertex 1",
        ),
        (
            lambda: Polyline([[0, 0], [1, 0], [1, 1]], corner_radius=[0.1, 0.1]),
            InvalidParameter,
            r"one radius per corner, shape \(1,\)",
        ),
        (
            lambda: Polyline([[0, 0], [1, 0], [1, 1]], corner_radius=0),
            InvalidParameter,
            r"corner_radius must be finite and > 0",
        ),
        (lambda: Polyline([[0, 0]], corner_radius=0.1), InvalidGeometry, r"at least 2 points"),
        (
            lambda: Polyline([[0, 0], [1, 0]], corner_radius=0.1, closed=True),
            InvalidGeometry,
            r"at least 3 points",
        ),
        (lambda: Spline([[0, 0], [1, 1], [1, 1]]), InvalidGeometry, r"point 1 equal to point 2"),
        (lambda: Spline([[0, 0, 0]]), InvalidGeometry, r"at least 2 points"),
        (lambda: Spline([0, 1, 2]), InvalidGeometry, r"shape \(N, n\)"),
        (lambda: Spline([[0, 0], [1, 1]], closed=1), InvalidParameter, r"closed: expected"),
        (
            lambda: Spline([[0, 0], [1, 0], [0, 0.0]]),
            InvalidGeometry,
            r"nearly stops",
        ),
    ],
)
def test_construction_errors(
    build: Callable[[], object], error: type[Exception], match: str
) -> None:
    with pytest.raises(error, match=match):
        build()


def test_runtime_input_errors() -> None:
    line = Line([0.0, 0.0], [1.0, 0.0])
    with pytest.raises(InvalidInput, match=r"s: expected a finite arc length \[m\], got nan"):
        line.point(math.nan)
    with pytest.raises(InvalidInput, match=r"s: expected an arc length \[m\]"):
        line.tangent("a")  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"S: expected finite arc lengths.*\[1\]"):
        line.points([0.0, math.inf])
    with pytest.raises(InvalidInput, match=r"S: expected shape \(N,\)"):
        line.points([[0.0]])
    with pytest.raises(InvalidInput, match=r"p: expected shape \(2,\)"):
        line.closest([0.0, 0.0, 0.0])
    with pytest.raises(InvalidInput, match=r"p: expected finite values"):
        line.closest([0.0, math.nan])
    with pytest.raises(InvalidParameter, match=r"window=0.5 needs s0"):
        line.closest([0.0, 0.0], window=0.5)
    with pytest.raises(InvalidParameter, match=r"window must be finite and > 0"):
        line.closest([0.0, 0.0], s0=0.0, window=0.0)


def test_arrays_are_read_only() -> None:
    pl = Polyline([[0, 0], [2, 0], [2, 2]], corner_radius=0.5)
    sp = Spline([[0, 0], [1, 1], [2, 0]])
    for arr in (pl.vertices, pl.corner_radii, pl.joins, sp.points_through):
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 1.0
