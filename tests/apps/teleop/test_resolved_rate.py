import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from velfence.apps.teleop.resolved_rate import (
    K0,
    W0,
    ResolvedRate,
    angle_axis,
    damping,
    manipulability_of,
    pose_error,
    rotation_from_angle_axis,
    rotation_vector,
    sr_inverse,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.mechanisms.puma560 import Puma560

TOL = 1e-10
# §7.1 trajectory 1 start (thesis), well away from any singularity (w ≈ 0.07 > w0).
Q_GOOD = np.array([-1.05628, -2.1085, 0.05893, 0.17227, -0.74605, 0.01345])


@pytest.fixture(scope="module")
def puma():
    return Puma560()


# ------------------------------------------------------------------------------------------
# Damping (eq. 37), by hand: k0 (1 - w/w0)^2
# ------------------------------------------------------------------------------------------


def test_thesis_parameters():
    assert (K0, W0) == (0.025, 0.014)


@pytest.mark.parametrize(
    ("w", "expected"),
    [
        (0.0, 0.025),  # k0 at the singular point
        (0.007, 0.025 * 0.25),  # w0/2: (1 - 1/2)^2 = 1/4
        (0.0105, 0.025 * 0.0625),  # 3 w0/4: (1/4)^2
        (0.014, 0.0),  # the border
        (0.5, 0.0),  # far away
    ],
)
def test_damping_formula(w, expected):
    assert damping(w, k0=0.025, w0=0.014) == pytest.approx(expected, abs=1e-15)


def test_damping_is_continuous_at_w0_and_decreasing():
    ws = np.linspace(0.0, 0.02, 401)
    ks = np.array([damping(w) for w in ws])
    assert np.all(np.diff(ks) <= 0.0)
    assert damping(W0 * (1 - 1e-9)) < 1e-18


@pytest.mark.parametrize("w", [-1e-3, math.nan, math.inf, "x"])
def test_damping_rejects_bad_w(w):
    with pytest.raises(InvalidInput, match=r"w: expected a (finite )?manipulability >= 0"):
        damping(w)


def test_damping_rejects_bad_parameters():
    with pytest.raises(InvalidParameter, match="k0 must be finite and > 0"):
        damping(0.01, k0=0.0)
    with pytest.raises(InvalidParameter, match="w0 must be finite and > 0"):
        damping(0.01, w0=-1.0)


# ------------------------------------------------------------------------------------------
# SR inverse (eq. 36)
# ------------------------------------------------------------------------------------------


def test_sr_inverse_at_k0_equals_inverse():
    rng = np.random.default_rng(1)
    for _ in range(20):
        J = rng.normal(size=(6, 6)) + 3 * np.eye(6)
        np.testing.assert_allclose(sr_inverse(J, k=0.0), np.linalg.inv(J), atol=1e-9)


def test_sr_inverse_of_a_wide_matrix_at_k0_is_the_pseudo_inverse():
    J = np.random.default_rng(2).normal(size=(3, 5))
    np.testing.assert_allclose(sr_inverse(J, k=0.0), np.linalg.pinv(J), atol=1e-12)


def test_sr_inverse_matches_the_svd_formula_and_is_bounded_near_a_singularity():
    rng = np.random.default_rng(3)
    U, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    V, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    sigma = np.array([1.0, 0.5, 0.2, 0.05, 1e-4, 1e-12])
    J = U @ np.diag(sigma) @ V.T
    k = 0.025
    expected = V @ np.diag(sigma / (sigma**2 + k)) @ U.T  # independent route: SVD
    got = sr_inverse(J, k=k)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    assert np.linalg.norm(got, 2) <= 1 / (2 * math.sqrt(k)) + 1e-12
    assert np.linalg.norm(np.linalg.inv(J), 2) > 1e11  # what J⁻¹ would give


def test_sr_inverse_refuses_a_singular_matrix_at_k0():
    J = np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 0.0])
    with pytest.raises(InvalidInput, match=r"singular at k = 0 \(manipulability w = 0\)"):
        sr_inverse(J, k=0.0)
    assert np.all(np.isfinite(sr_inverse(J, k=1e-3)))


def test_sr_inverse_validates():
    with pytest.raises(InvalidParameter, match="k must be finite and >= 0"):
        sr_inverse(np.eye(6), k=-1.0)
    with pytest.raises(InvalidInput, match="expected a non-empty 2-D array"):
        sr_inverse(np.ones(6), k=0.1)
    with pytest.raises(InvalidInput, match="J: expected finite values"):
        sr_inverse(np.full((6, 6), np.nan), k=0.1)


def test_manipulability_of_square_and_wide():
    J = np.diag([2.0, 3.0, 0.5])
    assert manipulability_of(J) == pytest.approx(3.0)
    A = np.array([[3.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    assert manipulability_of(A) == pytest.approx(6.0)


# ------------------------------------------------------------------------------------------
# ResolvedRate on the PUMA 560
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("inverse", ["jinv", "sr"])
def test_joint_rates_reproduce_the_twist_away_from_singularities(puma, inverse):
    assert puma.manipulability(Q_GOOD) > W0  # so the SR inverse is undamped here
    rr = ResolvedRate(puma, inverse=inverse)
    xdot = np.array([0.05, -0.02, 0.03, 0.1, -0.2, 0.05])
    qdot = rr.step(Q_GOOD, xdot)
    np.testing.assert_allclose(puma.jacobian(Q_GOOD) @ qdot, xdot, atol=1e-12)
    r = rr.explain(Q_GOOD, xdot)
    assert r.k == 0.0
    assert not r.singular
    assert not r.stopped
    assert r.scale == 1.0
    assert r.w == pytest.approx(puma.manipulability(Q_GOOD), rel=1e-12)
    assert r.det == pytest.approx(np.linalg.det(puma.jacobian(Q_GOOD)), rel=1e-12)


def test_sr_damps_near_a_wrist_singularity(puma):
    q = Q_GOOD.copy()
    q[4] = 1e-7  # sin θ5 ≈ 0: wrist singularity, w ≈ 1e-8
    xdot = np.array([0.0, 0.0, 0.0, 0.3, 0.0, 0.0])
    r = ResolvedRate(puma, inverse="sr").explain(q, xdot)
    assert r.w < 1e-6
    assert r.k == pytest.approx(damping(r.w), rel=1e-12)
    assert np.linalg.norm(r.qdot) <= np.linalg.norm(xdot) / (2 * math.sqrt(r.k)) + 1e-12
    J = puma.jacobian(q)
    with np.errstate(all="ignore"):
        plain = np.linalg.solve(J, xdot)
    assert np.max(np.abs(plain)) > 1e3 * np.max(np.abs(r.qdot))


def test_jinv_at_a_singular_jacobian_raises_naming_w(puma):
    q = Q_GOOD.copy()
    q[4] = 0.0  # θ5 = 0 exactly: det J = 0 up to round-off
    rr = ResolvedRate(puma, inverse="jinv")
    with pytest.raises(InvalidInput, match=r"singular at q = .*manipulability w = .* <= "):
        rr.step(q, np.ones(6))


def test_jinv_at_a_singular_jacobian_stops_when_asked(puma):
    q = Q_GOOD.copy()
    q[4] = 0.0
    rr = ResolvedRate(puma, inverse="jinv", on_invalid="stop")
    r = rr.explain(q, np.ones(6))
    assert r.stopped
    assert r.singular
    assert np.array_equal(r.qdot, np.zeros(6))
    assert not r.qdot.flags.writeable


def test_non_finite_input_raises_or_stops(puma):
    with pytest.raises(InvalidInput, match=r"non-finite input.*on_invalid='stop'"):
        ResolvedRate(puma).step(Q_GOOD, [np.nan, 0, 0, 0, 0, 0])
    out = ResolvedRate(puma, on_invalid="stop").step(np.full(6, np.inf), np.zeros(6))
    assert np.array_equal(out, np.zeros(6))


def test_overflow_never_returns_non_finite(puma):
    huge = np.full(6, 1e308)
    with pytest.raises(InvalidInput, match="overflowed"):
        ResolvedRate(puma, inverse="jinv").step(Q_GOOD, huge)
    r = ResolvedRate(puma, inverse="jinv", on_invalid="stop").explain(Q_GOOD, huge)
    assert r.stopped
    assert np.all(np.isfinite(r.qdot))


def test_max_joint_speed_scales_the_whole_vector(puma):
    xdot = np.array([0.5, 0.2, -0.3, 1.0, 0.5, 0.2])
    free = ResolvedRate(puma).step(Q_GOOD, xdot)
    cap = 0.5 * float(np.max(np.abs(free)))
    r = ResolvedRate(puma, max_speed=cap).explain(Q_GOOD, xdot)
    assert np.max(np.abs(r.qdot)) == pytest.approx(cap)
    np.testing.assert_allclose(r.qdot, 0.5 * free, atol=1e-12)
    assert r.scale == pytest.approx(0.5)


def test_shapes_and_parameters_are_validated(puma):
    rr = ResolvedRate(puma)
    with pytest.raises(InvalidInput, match=r"command: expected shape \(6,\)"):
        rr.step(Q_GOOD, np.zeros(3))
    with pytest.raises(InvalidInput, match="expected a non-empty 1-D array"):
        rr.step(np.zeros((2, 6)), np.zeros(6))
    with pytest.raises(InvalidParameter, match=r"inverse must be one of \['jinv', 'sr'\]"):
        ResolvedRate(puma, inverse="pinv")
    with pytest.raises(InvalidParameter, match="k0 must be finite and > 0"):
        ResolvedRate(puma, k0=0.0)
    with pytest.raises(InvalidParameter, match="max_speed must be finite and > 0"):
        ResolvedRate(puma, max_speed=-1.0)
    with pytest.raises(InvalidParameter, match="on_invalid must be one of"):
        ResolvedRate(puma, on_invalid="ignore")
    with pytest.raises(InvalidParameter, match=r"expected an object with a jacobian\(q\)"):
        ResolvedRate(object())


# ------------------------------------------------------------------------------------------
# Angle-axis
# ------------------------------------------------------------------------------------------


def _rz(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_rodrigues_matches_elementary_rotations():
    np.testing.assert_allclose(rotation_from_angle_axis([0, 0, 2.0], 0.7), _rz(0.7), atol=1e-15)
    Rx = rotation_from_angle_axis([1, 0, 0], math.pi / 2)
    np.testing.assert_allclose(Rx @ [0, 1, 0], [0, 0, 1], atol=1e-15)


@pytest.mark.parametrize(
    "angle",
    [0.0, 1e-12, 1e-8, 1e-4, 0.3, math.pi / 2 - 1e-9, math.pi / 2 + 1e-9, 2.5, math.pi - 1e-6,
     math.pi - 1e-9, math.pi],
)  # fmt: skip
def test_angle_axis_round_trip(angle):
    rng = np.random.default_rng(int(angle * 1e6) % 1000)
    for _ in range(20):
        k = rng.normal(size=3)
        k /= np.linalg.norm(k)
        R = rotation_from_angle_axis(k, angle)
        k2, a2 = angle_axis(R)
        assert a2 == pytest.approx(angle, abs=1e-9)
        assert np.linalg.norm(k2) == pytest.approx(1.0)
        np.testing.assert_allclose(rotation_from_angle_axis(k2, a2), R, atol=1e-12)
        if 1e-6 < angle < math.pi - 1e-6:
            np.testing.assert_allclose(k2, k, atol=1e-6)
        if angle == 0.0:
            assert np.array_equal(k2, [0.0, 0.0, 1.0])


@pytest.mark.parametrize(
    ("R", "axis"),
    [
        (np.diag([-1.0, -1.0, 1.0]), [0.0, 0.0, 1.0]),
        (np.diag([1.0, -1.0, -1.0]), [1.0, 0.0, 0.0]),
        # π about (1, 1, 0)/√2: R = 2 k kᵀ - I, exactly symmetric, so v = 0.
        (np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]), [0.5**0.5, 0.5**0.5, 0]),
    ],
)
def test_angle_axis_at_exactly_pi_picks_the_positive_axis(R, axis):
    k, a = angle_axis(R)
    assert a == math.pi
    np.testing.assert_allclose(k, axis, atol=1e-15)


@given(
    st.tuples(*[st.floats(-1, 1) for _ in range(3)]).filter(lambda v: np.linalg.norm(v) > 1e-3),
    st.floats(0.0, math.pi),
)
def test_rotation_vector_round_trip_property(axis, angle):
    R = rotation_from_angle_axis(axis, angle)
    r = rotation_vector(R)
    back = rotation_from_angle_axis(r if np.linalg.norm(r) > 0 else [0, 0, 1], np.linalg.norm(r))
    np.testing.assert_allclose(back, R, atol=1e-10)


def test_angle_axis_rejects_non_rotations():
    with pytest.raises(InvalidInput, match="expected a rotation matrix"):
        angle_axis(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(InvalidInput, match="expected a rotation matrix"):
        angle_axis(2 * np.eye(3))
    with pytest.raises(InvalidInput, match=r"expected shape \(3, 3\)"):
        angle_axis(np.eye(4))
    with pytest.raises(InvalidInput, match="expected a non-zero vector"):
        rotation_from_angle_axis([0, 0, 0], 1.0)


# ------------------------------------------------------------------------------------------
# Pose error
# ------------------------------------------------------------------------------------------


def _pose(R, p):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def test_pose_error_by_hand():
    R0 = rotation_from_angle_axis([1, 2, 3], 0.4)
    T = _pose(R0, [0.1, 0.2, 0.3])
    T_target = _pose(_rz(0.3) @ R0, [0.2, 0.1, 0.3])  # turn 0.3 rad about base z
    np.testing.assert_allclose(pose_error(T, T_target), [0.1, -0.1, 0, 0, 0, 0.3], atol=1e-12)
    cross = pose_error(T, T_target, orientation="cross")
    np.testing.assert_allclose(cross, [0.1, -0.1, 0, 0, 0, math.sin(0.3)], atol=1e-12)


def test_pose_error_near_pi_angle_axis_vs_cross():
    T = np.eye(4)
    T_target = _pose(rotation_from_angle_axis([0, 1, 0], math.pi - 1e-3), [0, 0, 0])
    np.testing.assert_allclose(pose_error(T, T_target)[3:], [0, math.pi - 1e-3, 0], atol=1e-9)
    assert np.linalg.norm(pose_error(T, T_target, orientation="cross")[3:]) < 2e-3


def test_pose_error_validates():
    bad = np.eye(4)
    bad[3, 3] = 2.0
    with pytest.raises(InvalidInput, match=r"bottom row \[0, 0, 0, 1\]"):
        pose_error(np.eye(4), bad)
    with pytest.raises(InvalidParameter, match="orientation must be one of"):
        pose_error(np.eye(4), np.eye(4), orientation="euler")
