"""Tests of the two-actuator pitch/yaw wrist (velfence.mechanisms.wrist)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon
from velfence.mechanisms import LIMIT_NAMES, Wrist, WristGeometry

JAC_RTOL = 1e-6  # Jacobian vs central differences (step 1e-6 rad)
JAC_ATOL = 1e-10  # [m/rad], for entries that pass through zero
FK_ATOL = 1e-10  # [rad], forward_kinematics round trip
SPEED_RTOL = 1e-12  # saturated peak actuator speed vs the limit

# The documented default polygon (docs/wrist.md §5), corners CCW from the least pitch.
DOCUMENTED_CORNERS = np.array(
    [
        [-0.8097, 0.0],
        [0.3719, -0.6438],
        [0.8692, -0.4153],
        [0.8692, 0.1573],
        [0.5476, 0.5631],
        [0.3719, 0.6438],
    ]
)
DOCUMENTED_EDGES = (
    "stroke_min_2",
    "stroke_max_1",
    "singularity",
    "wire",
    "stroke_max_2",
    "stroke_min_1",
)


@pytest.fixture(scope="module")
def wrist() -> Wrist:
    return Wrist()


@pytest.fixture(scope="module")
def polygon(wrist: Wrist) -> ConvexPolygon:
    return wrist.default_polygon()


def _random_poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-0.8, 0.85, n), rng.uniform(-0.6, 0.6, n)])


def _rot(q: np.ndarray) -> np.ndarray:
    """R_y(pitch) R_z(yaw) from explicit matrices (independent of the library's expansion)."""
    th, ps = q
    ry = np.array(
        [[math.cos(th), 0.0, math.sin(th)], [0.0, 1.0, 0.0], [-math.sin(th), 0.0, math.cos(th)]]
    )
    rz = np.array(
        [[math.cos(ps), -math.sin(ps), 0.0], [math.sin(ps), math.cos(ps), 0.0], [0.0, 0.0, 1.0]]
    )
    return ry @ rz


# ---------------------------------------------------------------------- geometry validation
def test_geometry_defaults_are_documented_numbers() -> None:
    g = WristGeometry()
    assert (g.anchor_setback, g.anchor_half_spacing, g.anchor_height) == (0.120, 0.020, 0.012)
    assert (g.rod_reach, g.rod_half_spacing, g.rod_height) == (0.008, 0.020, 0.012)
    assert (g.stroke_min, g.stroke_max, g.max_actuator_speed) == (0.116, 0.142, 0.05)
    assert g.wire_azimuth == pytest.approx(-math.pi / 4)
    assert (g.wire_max_bend, g.singularity_margin) == (0.76, 0.15)
    assert g.home_length == pytest.approx(0.128)


def test_geometry_is_frozen_keyword_only_and_read_only() -> None:
    g = WristGeometry()
    with pytest.raises(dataclasses.FrozenInstanceError):
        g.stroke_max = 0.2  # type: ignore[misc]
    with pytest.raises(TypeError):
        WristGeometry(0.1)  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        g.anchors[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        g.attachments[0, 0] = 1.0


def test_geometry_converts_ints_to_float() -> None:
    g = WristGeometry(anchor_setback=1, stroke_min=1, stroke_max=2)
    assert isinstance(g.anchor_setback, float)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"anchor_setback": -0.1}, InvalidGeometry, r"WristGeometry\.anchor_setback.*> 0"),
        ({"rod_height": 0.0}, InvalidGeometry, r"WristGeometry\.rod_height.*> 0"),
        ({"anchor_height": math.nan}, InvalidGeometry, r"anchor_height: expected a finite"),
        ({"rod_reach": math.inf}, InvalidGeometry, r"rod_reach: expected a finite"),
        ({"anchor_half_spacing": "2cm"}, InvalidGeometry, r"anchor_half_spacing.*real number"),
        ({"rod_half_spacing": True}, InvalidGeometry, r"rod_half_spacing.*real number"),
        ({"stroke_min": 0.142}, InvalidGeometry, r"stroke_min must be < stroke_max"),
        ({"stroke_min": 0.130}, InvalidGeometry, r"home pose q = 0 must lie strictly inside"),
        ({"stroke_max": 0.125}, InvalidGeometry, r"home pose q = 0 must lie strictly inside"),
        ({"max_actuator_speed": 0.0}, InvalidParameter, r"max_actuator_speed.*> 0 \[m/s\]"),
        ({"max_actuator_speed": -1}, InvalidParameter, r"max_actuator_speed"),
        ({"wire_azimuth": 4.0}, InvalidParameter, r"wire_azimuth.*\[-π, π\]"),
        ({"wire_azimuth": math.nan}, InvalidParameter, r"wire_azimuth: expected a finite"),
        ({"wire_max_bend": 1.6}, InvalidParameter, r"wire_max_bend.*\(0, π/2\)"),
        ({"singularity_margin": 1.0}, InvalidParameter, r"singularity_margin.*\(0, 1\)"),
        ({"singularity_margin": 0.0}, InvalidParameter, r"singularity_margin.*> 0"),
    ],
)
def test_geometry_validation_names_the_field(
    kwargs: dict[str, object], error: type[Exception], match: str
) -> None:
    with pytest.raises(error, match=match):
        WristGeometry(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"fk_tol": 0.0}, r"fk_tol must be finite and > 0 \(\[m\]\), got 0\.0"),
        ({"fk_tol": math.nan}, r"fk_tol"),
        ({"fk_max_iter": 0}, r"fk_max_iter: expected an int >= 1"),
        ({"fk_max_iter": 2.5}, r"fk_max_iter: expected a positive int"),
        ({"singular_tol": 1.0}, r"singular_tol: expected a fraction in \(0, 1\)"),
    ],
)
def test_wrist_option_validation(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InvalidParameter, match=match):
        Wrist(**kwargs)  # type: ignore[arg-type]


def test_wrist_rejects_non_geometry() -> None:
    with pytest.raises(InvalidParameter, match="geometry: expected a WristGeometry, got dict"):
        Wrist(geometry={"anchor_setback": 0.1})  # type: ignore[arg-type]


def test_wrist_options_are_keyword_only() -> None:
    with pytest.raises(TypeError):
        Wrist(WristGeometry())  # type: ignore[misc]


# ---------------------------------------------------------------------- kinematics
def test_home_lengths_and_closed_form_jacobian(wrist: Wrist) -> None:
    g = wrist.geometry
    L0 = g.home_length
    np.testing.assert_allclose(wrist.actuator_lengths([0.0, 0.0]), [L0, L0], rtol=1e-15)
    k = (g.anchor_height * g.rod_reach + g.anchor_setback * g.rod_height) / L0
    m = (g.anchor_setback * g.rod_half_spacing + g.anchor_half_spacing * g.rod_reach) / L0
    np.testing.assert_allclose(wrist.jacobian([0.0, 0.0]), [[k, -m], [k, m]], rtol=1e-12)
    assert wrist.home_determinant == pytest.approx(2 * k * m, rel=1e-12)


def test_lengths_match_explicit_rotation_matrices(wrist: Wrist) -> None:
    g = wrist.geometry
    for q in _random_poses(20, seed=1):
        P = g.attachments @ _rot(q).T
        expected = np.linalg.norm(P - g.anchors, axis=1)
        np.testing.assert_allclose(wrist.actuator_lengths(q), expected, rtol=1e-14)


def test_jacobian_matches_central_differences(wrist: Wrist) -> None:
    h = 1e-6
    for q in _random_poses(25, seed=2):
        fd = np.column_stack(
            [
                (wrist.actuator_lengths(q + e) - wrist.actuator_lengths(q - e)) / (2 * h)
                for e in (np.array([h, 0.0]), np.array([0.0, h]))
            ]
        )
        np.testing.assert_allclose(wrist.jacobian(q), fd, rtol=JAC_RTOL, atol=JAC_ATOL)


def test_pitch_levers_vanish_at_the_closed_form_singularity(wrist: Wrist) -> None:
    # Actuator lines through the pitch axis: tan θ* = (h_a b + l0 h_b) / (l0 b - h_a h_b).
    g = wrist.geometry
    num = g.anchor_height * g.rod_reach + g.anchor_setback * g.rod_height
    den = g.anchor_setback * g.rod_reach - g.anchor_height * g.rod_height
    q_star = np.array([math.atan2(num, den), 0.0])
    assert q_star[0] == pytest.approx(1.0825, abs=1e-4)
    np.testing.assert_allclose(wrist.jacobian(q_star)[:, 0], 0.0, atol=1e-15)
    assert wrist.singularity_measure(q_star) < 1e-12
    assert wrist.manipulability(q_star) < 1e-15
    assert not wrist.feasible(q_star)
    with pytest.raises(InvalidInput, match=r"joint_velocity: the Jacobian is singular at q ="):
        wrist.joint_velocity(q_star, [0.01, 0.01])


def test_actuator_and_joint_velocity_are_inverse(wrist: Wrist) -> None:
    rng = np.random.default_rng(3)
    for q in _random_poses(20, seed=4):
        qdot = rng.normal(size=2)
        ldot = wrist.actuator_velocity(q, qdot)
        np.testing.assert_allclose(ldot, wrist.jacobian(q) @ qdot, rtol=1e-14)
        np.testing.assert_allclose(wrist.joint_velocity(q, ldot), qdot, rtol=1e-10, atol=1e-12)


def test_forward_kinematics_round_trip(wrist: Wrist) -> None:
    for q in _random_poses(30, seed=5):
        L = wrist.actuator_lengths(q)
        np.testing.assert_allclose(wrist.forward_kinematics(L), q, atol=FK_ATOL)
        np.testing.assert_allclose(wrist.forward_kinematics(L, q0=q + 0.05), q, atol=FK_ATOL)


def test_forward_kinematics_reports_non_convergence(wrist: Wrist) -> None:
    with pytest.raises(InvalidInput, match=r"forward_kinematics did not converge.*reachable"):
        wrist.forward_kinematics([0.05, 0.05])
    target = wrist.actuator_lengths([0.5, 0.3])
    with pytest.raises(InvalidInput, match=r"did not converge in 1 iterations"):
        Wrist(fk_max_iter=1).forward_kinematics(target)


def test_forward_kinematics_q0_shape_is_checked(wrist: Wrist) -> None:
    L = wrist.actuator_lengths(_random_poses(3, seed=6))
    with pytest.raises(InvalidInput, match=r"q0: expected shape \(2,\) or \(3, 2\)"):
        wrist.forward_kinematics(L, q0=np.zeros((2, 2)))


def test_batch_equals_loop(wrist: Wrist) -> None:
    Q = _random_poses(12, seed=7)
    V = np.random.default_rng(8).normal(size=(12, 2)) * 5.0
    Ld = np.random.default_rng(9).normal(size=(12, 2)) * 0.01
    L = wrist.actuator_lengths(Q)
    checks = {
        "actuator_lengths": (wrist.actuator_lengths(Q), [wrist.actuator_lengths(q) for q in Q]),
        "jacobian": (wrist.jacobian(Q), [wrist.jacobian(q) for q in Q]),
        "actuator_velocity": (
            wrist.actuator_velocity(Q, V),
            [wrist.actuator_velocity(q, v) for q, v in zip(Q, V, strict=True)],
        ),
        "joint_velocity": (
            wrist.joint_velocity(Q, Ld),
            [wrist.joint_velocity(q, v) for q, v in zip(Q, Ld, strict=True)],
        ),
        "forward_kinematics": (
            wrist.forward_kinematics(L),
            [wrist.forward_kinematics(x) for x in L],
        ),
        "saturate": (
            wrist.saturate(Q, V),
            [wrist.saturate(q, v) for q, v in zip(Q, V, strict=True)],
        ),
        "saturation_factor": (
            wrist.saturation_factor(Q, V),
            [wrist.saturation_factor(q, v) for q, v in zip(Q, V, strict=True)],
        ),
        "manipulability": (wrist.manipulability(Q), [wrist.manipulability(q) for q in Q]),
        "singularity_measure": (
            wrist.singularity_measure(Q),
            [wrist.singularity_measure(q) for q in Q],
        ),
        "wire_bend": (wrist.wire_bend(Q), [wrist.wire_bend(q) for q in Q]),
        "limit_values": (wrist.limit_values(Q), [wrist.limit_values(q) for q in Q]),
        "feasible": (wrist.feasible(Q), [wrist.feasible(q) for q in Q]),
    }
    for name, (batch, loop) in checks.items():
        np.testing.assert_allclose(
            np.asarray(batch, dtype=float), np.array(loop, dtype=float), rtol=1e-12, err_msg=name
        )
    assert np.shape(wrist.jacobian(Q)) == (12, 2, 2)
    assert isinstance(wrist.feasible(Q[0]), bool)
    assert isinstance(wrist.manipulability(Q[0]), float)


@pytest.mark.parametrize(
    ("q", "match"),
    [
        ([0.1, 0.2, 0.3], r"q: expected shape \(2,\) or \(N, 2\).*got shape \(3,\)"),
        ([[[0.1, 0.2]]], r"q: expected shape \(2,\) or \(N, 2\)"),
        ([0.1, math.nan], r"q: expected finite values.*row\(s\) \[0\]"),
        ([[0.0, 0.0], [math.inf, 0.0]], r"q: expected finite values.*row\(s\) \[1\]"),
        (["a", "b"], r"q: expected numbers of shape"),
    ],
)
def test_invalid_positions_raise(wrist: Wrist, q: object, match: str) -> None:
    with pytest.raises(InvalidInput, match=match):
        wrist.actuator_lengths(q)  # type: ignore[arg-type]


def test_velocity_shape_must_match_position(wrist: Wrist) -> None:
    with pytest.raises(InvalidInput, match=r"qdot: expected the same shape as q"):
        wrist.saturate([0.0, 0.0], np.zeros((2, 2)))
    with pytest.raises(InvalidInput, match=r"ldot: expected finite values"):
        wrist.joint_velocity([0.0, 0.0], [math.nan, 0.0])


# ---------------------------------------------------------------------- speed saturation
def test_saturate_passes_slow_commands_unchanged(wrist: Wrist) -> None:
    q = np.array([0.3, -0.2])
    qdot = np.array([0.4, -0.3])
    assert np.max(np.abs(wrist.actuator_velocity(q, qdot))) < wrist.geometry.max_actuator_speed
    out = wrist.saturate(q, qdot)
    assert np.array_equal(out, qdot)
    assert wrist.saturation_factor(q, qdot) == 1.0
    assert np.array_equal(wrist.saturate(q, np.zeros(2)), np.zeros(2))


def test_saturate_keeps_direction_and_meets_the_limit_exactly(wrist: Wrist) -> None:
    vmax = wrist.geometry.max_actuator_speed
    rng = np.random.default_rng(10)
    for q in _random_poses(20, seed=11):
        qdot = rng.normal(size=2) * 20.0  # rad/s: far above the limit
        out = wrist.saturate(q, qdot)
        s = wrist.saturation_factor(q, qdot)
        assert 0.0 < s < 1.0
        np.testing.assert_allclose(out, s * qdot, rtol=1e-15)
        assert out[0] * qdot[1] - out[1] * qdot[0] == pytest.approx(0.0, abs=1e-12)
        assert out @ qdot > 0.0
        peak = np.max(np.abs(wrist.actuator_velocity(q, out)))
        assert peak == pytest.approx(vmax, rel=SPEED_RTOL)


def test_saturate_at_the_boundary_and_twice_over(wrist: Wrist) -> None:
    vmax = wrist.geometry.max_actuator_speed
    q = np.array([-0.2, 0.4])
    ldot = np.array([vmax, -0.3 * vmax])  # actuator 1 exactly at its limit
    qdot = wrist.joint_velocity(q, ldot)
    out = wrist.saturate(q, qdot)
    np.testing.assert_allclose(out, qdot, rtol=1e-14)
    np.testing.assert_allclose(wrist.actuator_velocity(q, out), ldot, rtol=1e-12, atol=1e-16)
    assert wrist.saturation_factor(q, 2.0 * qdot) == pytest.approx(0.5, rel=1e-12)
    np.testing.assert_allclose(wrist.saturate(q, 2.0 * qdot), qdot, rtol=1e-12)


# ---------------------------------------------------------------------- limits and polygon
def test_limit_values_follow_their_definitions(wrist: Wrist) -> None:
    g = wrist.geometry
    q = np.array([0.4, -0.3])
    L = wrist.actuator_lengths(q)
    hand_axis = _rot(q) @ np.array([1.0, 0.0, 0.0])
    w = np.array([0.0, math.cos(g.wire_azimuth), math.sin(g.wire_azimuth)])
    expected = [
        L[0] - g.stroke_max,
        L[1] - g.stroke_max,
        g.stroke_min - L[0],
        g.stroke_min - L[1],
        g.singularity_margin - abs(np.linalg.det(wrist.jacobian(q))) / wrist.home_determinant,
        math.asin(hand_axis @ w) - g.wire_max_bend,
    ]
    np.testing.assert_allclose(wrist.limit_values(q), expected, rtol=1e-12, atol=1e-15)
    assert len(LIMIT_NAMES) == 6
    assert wrist.feasible([0.0, 0.0]) is True
    assert wrist.feasible([0.0, 1.2]) is False  # yaw past the strokes


def test_default_polygon_shape(wrist: Wrist, polygon: ConvexPolygon) -> None:
    assert isinstance(polygon, ConvexPolygon)
    assert 5 <= polygon.n <= 7
    c = polygon.corners
    angles = []
    for i in range(polygon.n):
        u = c[i - 1] - c[i]
        v = c[(i + 1) % polygon.n] - c[i]
        angles.append(math.degrees(math.acos(u @ v / np.linalg.norm(u) / np.linalg.norm(v))))
    assert min(angles) < 80.0  # the extension tip where both actuators reach stroke_min
    assert max(angles) > 90.0
    assert -0.9 < c[:, 0].min() < -0.7
    assert 0.8 < c[:, 0].max() < 0.95
    assert 0.55 < c[:, 1].max() < 0.7
    assert -0.7 < c[:, 1].min() < -0.55
    assert polygon.contains([0.0, 0.0])
    edges = wrist.default_polygon_edges()
    assert len(edges) == polygon.n
    assert set(edges) == set(LIMIT_NAMES)


def test_default_polygon_matches_documented_corners(wrist: Wrist, polygon: ConvexPolygon) -> None:
    np.testing.assert_allclose(polygon.corners, DOCUMENTED_CORNERS, atol=1e-4)
    assert wrist.default_polygon_edges() == DOCUMENTED_EDGES
    assert wrist.default_polygon() is polygon  # computed once


def test_default_polygon_area_ratio(polygon: ConvexPolygon) -> None:
    ratio = polygon.area_ratio()
    assert ratio >= 1.3
    assert ratio == pytest.approx(2.01, abs=0.01)


def test_default_polygon_corners_respect_every_limit(wrist: Wrist, polygon: ConvexPolygon) -> None:
    g = wrist.geometry
    L = wrist.actuator_lengths(polygon.corners)
    assert np.all((g.stroke_min <= L) & (g.stroke_max >= L))
    det = np.asarray(wrist.manipulability(polygon.corners))
    assert np.all(det >= g.singularity_margin * wrist.home_determinant)
    assert np.all(np.asarray(wrist.wire_bend(polygon.corners)) <= g.wire_max_bend)
    assert np.all(np.asarray(wrist.feasible(polygon.corners)))


def test_default_polygon_lies_in_the_feasible_region(wrist: Wrist, polygon: ConvexPolygon) -> None:
    c = polygon.corners
    pitch = np.linspace(c[:, 0].min(), c[:, 0].max(), 301)
    yaw = np.linspace(c[:, 1].min(), c[:, 1].max(), 301)
    T, S = np.meshgrid(pitch, yaw, indexing="ij")
    grid = np.column_stack([T.ravel(), S.ravel()])
    inside = grid[np.asarray(polygon.contains(grid))]
    t = np.linspace(0.0, 1.0, 500, endpoint=False)
    nxt = np.roll(c, -1, axis=0)
    boundary = (c[:, None, :] + t[None, :, None] * (nxt - c)[:, None, :]).reshape(-1, 2)
    pts = np.vstack([inside, boundary])
    assert inside.shape[0] > 40_000
    assert np.all(np.asarray(wrist.feasible(pts)))
    assert np.min(np.asarray(wrist.singularity_measure(pts))) >= wrist.geometry.singularity_margin
    # The grid helper agrees with the pointwise test, and the polygon is a strict subset.
    mask = wrist.feasible_grid(pitch, yaw)
    np.testing.assert_array_equal(mask.ravel(), np.asarray(wrist.feasible(grid)))
    assert wrist.feasible([-0.85, 0.0])
    assert not polygon.contains([-0.85, 0.0])


def test_default_polygon_is_larger_than_its_rectangle(polygon: ConvexPolygon) -> None:
    rect = polygon.inscribed_rectangle()
    assert all(polygon.contains(p, tol=1e-9) for p in rect.corners)
    assert polygon.area >= 1.3 * rect.area


def test_default_polygon_follows_the_wire_limit() -> None:
    tight = Wrist(geometry=WristGeometry(wire_max_bend=0.70)).default_polygon()
    loose = Wrist(geometry=WristGeometry()).default_polygon()
    assert tight.area < loose.area
    assert (
        Wrist(geometry=WristGeometry(wire_max_bend=0.70)).default_polygon_edges().count("wire") == 1
    )


def test_default_polygon_refuses_a_margin_that_cuts_home() -> None:
    w = Wrist(geometry=WristGeometry(singularity_margin=0.9))
    with pytest.raises(InvalidGeometry, match=r"excluded the home pose"):
        w.default_polygon()


def test_feasible_grid_validates_its_axes(wrist: Wrist) -> None:
    with pytest.raises(InvalidInput, match=r"pitch: expected a non-empty finite 1-D array"):
        wrist.feasible_grid([], [0.0])
    with pytest.raises(InvalidInput, match=r"yaw: expected a non-empty finite 1-D array"):
        wrist.feasible_grid([0.0], [[0.0]])


def test_home_stroke_message_names_the_dimensions():
    with pytest.raises(InvalidGeometry, match=r"anchor_setback, anchor_half_spacing"):
        WristGeometry(anchor_setback=0.3)


def test_feasible_grid_is_bounded():
    with pytest.raises(InvalidInput, match=r"pitch, yaw: expected at most 250000 grid points"):
        Wrist().feasible_grid(np.zeros(1000), np.zeros(1000))
