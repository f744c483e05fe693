"""SO(3) helpers (velfence.geometry.so3): identities and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.errors import InvalidInput
from velfence.geometry.so3 import (
    angle_axis,
    check_rotation,
    rot_x,
    rot_y,
    rot_z,
    rotation_from_angle_axis,
    rotation_vector,
    rotations_zyx,
    skew,
    zyx_rate_map,
)

ATOL = 1e-12
FD_STEP = 1e-6
FD_ATOL = 1e-8


def _random_rotations(n: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        k = rng.normal(size=3)
        out.append(rotation_from_angle_axis(k, float(rng.uniform(0.0, math.pi))))
    return out


def _assert_rotation(R: np.ndarray) -> None:
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=ATOL)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=ATOL)


@pytest.mark.parametrize(("rot", "axis"), [(rot_x, 0), (rot_y, 1), (rot_z, 2)])
def test_elementary_rotations_are_rodrigues_about_the_unit_axes(rot, axis):
    e = np.zeros(3)
    e[axis] = 1.0
    for a in (-2.5, -0.3, 0.0, 0.7, math.pi):
        R = rot(a)
        _assert_rotation(R)
        np.testing.assert_allclose(R, rotation_from_angle_axis(e, a), atol=ATOL)
        np.testing.assert_allclose(R @ e, e, atol=ATOL)  # the axis is fixed
    # right-handed: x -> y under R_z(π/2), y -> z under R_x(π/2), z -> x under R_y(π/2)
    np.testing.assert_allclose(rot_z(math.pi / 2) @ [1, 0, 0], [0, 1, 0], atol=ATOL)
    np.testing.assert_allclose(rot_x(math.pi / 2) @ [0, 1, 0], [0, 0, 1], atol=ATOL)
    np.testing.assert_allclose(rot_y(math.pi / 2) @ [0, 0, 1], [1, 0, 0], atol=ATOL)


def test_skew_is_the_cross_product_and_antisymmetric():
    rng = np.random.default_rng(1)
    for _ in range(20):
        k, x = rng.normal(size=3), rng.normal(size=3)
        K = skew(k)
        np.testing.assert_allclose(K @ x, np.cross(k, x), atol=ATOL)
        np.testing.assert_array_equal(K, -K.T)
    with pytest.raises(InvalidInput, match="k"):
        skew([1.0, 2.0])
    with pytest.raises(InvalidInput, match="k"):
        skew([1.0, math.nan, 0.0])


def test_exp_of_log_is_the_identity_on_rotations():
    near_pi = [rotation_from_angle_axis([1.0, -2.0, 0.5], math.pi - 1e-9)]
    exact_pi = [np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0])]
    for R in [*_random_rotations(200), *near_pi, *exact_pi, np.eye(3)]:
        _assert_rotation(R)
        k, phi = angle_axis(R)
        assert 0.0 <= phi <= math.pi
        assert np.linalg.norm(k) == pytest.approx(1.0, abs=ATOL)
        np.testing.assert_allclose(rotation_from_angle_axis(k, phi), R, atol=1e-10)


def test_log_of_exp_is_the_identity_below_pi():
    rng = np.random.default_rng(2)
    for _ in range(200):
        k = rng.normal(size=3)
        k /= np.linalg.norm(k)
        phi = float(rng.uniform(1e-6, math.pi - 1e-6))
        np.testing.assert_allclose(
            rotation_vector(rotation_from_angle_axis(k, phi)), phi * k, atol=1e-8
        )
    np.testing.assert_array_equal(rotation_vector(np.eye(3)), np.zeros(3))


def test_rodrigues_derivative_is_the_skew_of_the_axis():
    # d/dθ exp(θ[k]x) = [k]x exp(θ[k]x), by central differences.
    rng = np.random.default_rng(3)
    for _ in range(20):
        k = rng.normal(size=3)
        k /= np.linalg.norm(k)
        th = float(rng.uniform(-3.0, 3.0))
        fd = (
            rotation_from_angle_axis(k, th + FD_STEP) - rotation_from_angle_axis(k, th - FD_STEP)
        ) / (2.0 * FD_STEP)
        np.testing.assert_allclose(fd, skew(k) @ rotation_from_angle_axis(k, th), atol=FD_ATOL)


def test_zyx_rotations_compose_the_elementary_ones():
    chi = np.random.default_rng(4).uniform(-3.0, 3.0, size=(50, 3))
    R = rotations_zyx(chi)
    assert R.shape == (50, 3, 3)
    for c, Rc in zip(chi, R, strict=True):
        np.testing.assert_allclose(Rc, rot_z(c[2]) @ rot_y(c[1]) @ rot_x(c[0]), atol=ATOL)
        _assert_rotation(Rc)


def test_zyx_rate_map_gives_the_base_frame_angular_velocity():
    # Ṙ Rᵀ = [ω]x with ω = E(χ) χ̇, by central differences along a random direction.
    rng = np.random.default_rng(5)
    chi = rng.uniform(-1.4, 1.4, size=(30, 3))
    chi_dot = rng.normal(size=(30, 3))
    R_dot = (rotations_zyx(chi + FD_STEP * chi_dot) - rotations_zyx(chi - FD_STEP * chi_dot)) / (
        2.0 * FD_STEP
    )
    E = zyx_rate_map(chi)
    for i in range(chi.shape[0]):
        W = R_dot[i] @ rotations_zyx(chi[i : i + 1])[0].T
        np.testing.assert_allclose(W, skew(E[i] @ chi_dot[i]), atol=FD_ATOL)
    np.testing.assert_allclose(np.linalg.det(E), np.cos(chi[:, 1]), atol=ATOL)


def test_check_rotation_refuses_non_rotations_by_name():
    R = rot_z(0.3)
    np.testing.assert_array_equal(check_rotation("R_in", R), R)
    with pytest.raises(InvalidInput, match="R_in: expected a rotation matrix"):
        check_rotation("R_in", np.diag([1.0, 1.0, -1.0]))  # a reflection
    with pytest.raises(InvalidInput, match="R_in: expected a rotation matrix"):
        check_rotation("R_in", 1.01 * np.eye(3))
    with pytest.raises(InvalidInput, match="R_in"):
        check_rotation("R_in", np.eye(4))
    with pytest.raises(InvalidInput, match="axis"):
        rotation_from_angle_axis([0.0, 0.0, 0.0], 1.0)


def test_rotation_from_quaternion_against_scipy() -> None:
    from scipy.spatial.transform import Rotation

    from velfence.geometry.so3 import rotation_from_quaternion

    rng = np.random.default_rng(11)
    for q in rng.normal(size=(50, 4)):  # not unit length: normalised first
        want = Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()  # scipy: (x, y, z, w)
        np.testing.assert_allclose(rotation_from_quaternion(q), want, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(rotation_from_quaternion([1.0, 0.0, 0.0, 0.0]), np.eye(3))


@pytest.mark.parametrize("q", [[0.0, 0.0, 0.0, 0.0], [np.nan, 0, 0, 1], [1.0, 0.0, 0.0], "q"])
def test_rotation_from_quaternion_refuses(q: object) -> None:
    from velfence.errors import InvalidInput
    from velfence.geometry.so3 import rotation_from_quaternion

    with pytest.raises(InvalidInput, match="q"):
        rotation_from_quaternion(q)
