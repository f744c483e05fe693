"""Tangent/curvature transforms (Gillespie et al. 1999 eqs. 2.5–2.14) against finite differences.

Independent route: a curve R(s) parametrised by arc length is pushed through the r-θ inverse
kinematics q(s) = L(R(s)) and the selection r(s) = S q(s); the image's unit tangent is the finite
difference q'(s)/|q'(s)|, and its curvature vector is the derivative of that unit tangent per unit
*image* arc length, (dT_J/ds)/|q'(s)| — both by nested central differences, never touching J, H or
the closed forms. The same on a 3-D helix through a hand-made nonlinear map.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from velfence.cobot import (
    RThetaKinematics,
    coupling_from_ee,
    coupling_from_joint,
    joint_from_ee,
    map_tangent_curvature,
    normalised_derivative,
)
from velfence.cobot.transforms import hessian_term
from velfence.errors import InvalidInput

Curve = Callable[[float], np.ndarray]

H_INNER = 1e-3  # step of the inner (tangent) difference, 4th order: h⁴ ~ 1e-12, eps/h ~ 1e-13
H_OUTER = 2e-3  # step of the outer (curvature) difference, 4th order: h⁴ ~ 2e-11
# Nested 4th-order differences on unit-scale curves: the measured curvature error is <= 1e-8 and
# falls as H_OUTER⁴ (5e-6 at H_OUTER = 1e-2 on the tightest test circle, 5e-8 at 3e-3).
FD_TOL = 1e-7
EXACT_TOL = 1e-12
W = np.array([[0.0, -1.0], [1.0, 0.0]])
S_RTHETA = np.diag([1.0 / 0.5, 1.0])  # r-θ selection with r_o = 0.5 (eq. 4.2)


def d4(f: Curve, s: float, h: float) -> np.ndarray:
    """Fourth-order central difference of a vector function."""
    return (-f(s + 2 * h) + 8 * f(s + h) - 8 * f(s - h) + f(s - 2 * h)) / (12 * h)


def fd_tangent_curvature(f: Curve, s: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Unit tangent, curvature vector per unit image arc length, and |f'| — by differences only."""

    def unit_tangent(u: float) -> np.ndarray:
        d = d4(f, u, H_INNER)
        return d / np.linalg.norm(d)

    speed = float(np.linalg.norm(d4(f, s, H_INNER)))
    dT_ds = d4(unit_tangent, s, H_OUTER)
    return unit_tangent(s), dT_ds / speed, speed


# ---------------------------------------------------------------------------- test curves
def circle_curve(center: np.ndarray, rho: float, a0: float, sign: float):
    """Arc-length circle: point(s), with T and κN in closed form at s."""

    def point(s: float) -> np.ndarray:
        a = a0 + sign * s / rho
        return center + rho * np.array([math.cos(a), math.sin(a)])

    def frame(s: float) -> tuple[np.ndarray, np.ndarray]:
        a = a0 + sign * s / rho
        T = sign * np.array([-math.sin(a), math.cos(a)])
        return T, -(point(s) - center) / rho**2

    return point, frame


def clothoid_curve(R0: np.ndarray, th0: float, k0: float, k1: float, s0: float):
    """Clothoid-like curve θ(s) = th0 + k0 s + k1 s²/2, R' = (cos θ, sin θ), R(s0) = R0.

    Points near s0 are integrated from s0 with 24-point Gauss–Legendre (exact to round-off over the
    short intervals the differences need); T and κN = θ' W T are known in closed form.
    """
    x, w = np.polynomial.legendre.leggauss(24)

    def theta(s: np.ndarray | float) -> np.ndarray | float:
        return th0 + k0 * s + 0.5 * k1 * s * s

    def point(s: float) -> np.ndarray:
        half = 0.5 * (s - s0)
        u = s0 + half * (x + 1.0)
        th = theta(u)
        return R0 + half * np.array([w @ np.cos(th), w @ np.sin(th)])

    def frame(s: float) -> tuple[np.ndarray, np.ndarray]:
        th = float(theta(s))
        T = np.array([math.cos(th), math.sin(th)])
        return T, (k0 + k1 * s) * (W @ T)

    return point, frame


CURVES = {
    "circle-ccw": (*circle_curve(np.array([0.9, 0.4]), 0.7, 0.3, 1.0), 0.4),
    "circle-cw": (*circle_curve(np.array([-0.5, 1.1]), 0.45, 2.0, -1.0), 1.7),
    "clothoid": (*clothoid_curve(np.array([1.1, -0.3]), 2.2, 1.5, -2.0, 0.25), 0.25),
    "clothoid-2": (*clothoid_curve(np.array([-0.8, -0.6]), -0.4, -0.3, 3.0, 0.0), 0.0),
}


@pytest.fixture(params=sorted(CURVES))
def curve(request: pytest.FixtureRequest):
    return CURVES[request.param]


def test_curve_fixtures_are_arc_length_parametrised(curve) -> None:
    """The test's own curves: |R'| = 1, T and κN in closed form agree with differences."""
    point, frame, s = curve
    T_fd, kN_fd, speed = fd_tangent_curvature(point, s)
    T, kN = frame(s)
    assert speed == pytest.approx(1.0, abs=FD_TOL)
    np.testing.assert_allclose(T_fd, T, atol=FD_TOL)
    np.testing.assert_allclose(kN_fd, kN, atol=FD_TOL)


# ---------------------------------------------------------------------------- C_EE -> C_J -> Σ
def test_joint_from_ee_matches_differences(curve) -> None:
    """(2.5), (2.7): T_J and κ_J N_J of q(s) = L(R(s)), and the gain |JT| = ds_J/ds."""
    point, frame, s = curve
    kin = RThetaKinematics()
    R = point(s)
    T, kN = frame(s)
    T_J, kJNJ, gain = joint_from_ee(kin.jacobian(R), kin.hessian(R), T, kN)
    T_fd, kN_fd, speed = fd_tangent_curvature(lambda u: kin.joints(point(u)), s)
    np.testing.assert_allclose(T_J, T_fd, atol=FD_TOL)
    np.testing.assert_allclose(kJNJ, kN_fd, atol=FD_TOL * max(1.0, float(np.linalg.norm(kN_fd))))
    assert gain == pytest.approx(speed, rel=FD_TOL)
    assert abs(float(T_J @ kJNJ)) < EXACT_TOL * (1 + np.linalg.norm(kJNJ))  # κN ⟂ T


def test_coupling_from_joint_matches_differences(curve) -> None:
    """(2.10), (2.11): Σ-space tangent and curvature of r(s) = S q(s), from the joint-space ones."""
    point, frame, s = curve
    kin = RThetaKinematics()
    R = point(s)
    T, kN = frame(s)
    T_J, kJNJ, gJ = joint_from_ee(kin.jacobian(R), kin.hessian(R), T, kN)
    t, kn, gS = coupling_from_joint(S_RTHETA, T_J, kJNJ)
    t_fd, kn_fd, speed = fd_tangent_curvature(lambda u: S_RTHETA @ kin.joints(point(u)), s)
    np.testing.assert_allclose(t, t_fd, atol=FD_TOL)
    np.testing.assert_allclose(kn, kn_fd, atol=FD_TOL * max(1.0, float(np.linalg.norm(kn_fd))))
    assert gJ * gS == pytest.approx(speed, rel=FD_TOL)


def test_coupling_from_ee_matches_differences(curve) -> None:
    """(2.13), (2.14) with J_i = S J and H_i = S H (eq. 2.12) against differences of S L(R(s))."""
    point, frame, s = curve
    kin = RThetaKinematics()
    R = point(s)
    T, kN = frame(s)
    J_i = S_RTHETA @ kin.jacobian(R)
    H_i = np.einsum("ai,ikj->akj", S_RTHETA, kin.hessian(R))
    t, kn, g = coupling_from_ee(J_i, H_i, T, kN)
    t_fd, kn_fd, speed = fd_tangent_curvature(lambda u: S_RTHETA @ kin.joints(point(u)), s)
    np.testing.assert_allclose(t, t_fd, atol=FD_TOL)
    np.testing.assert_allclose(kn, kn_fd, atol=FD_TOL * max(1.0, float(np.linalg.norm(kn_fd))))
    assert g == pytest.approx(speed, rel=FD_TOL)


def test_without_hessian_term_the_curvature_is_wrong(curve) -> None:
    """The Hessian term matters: dropping it misses the finite-difference curvature."""
    point, frame, s = curve
    kin = RThetaKinematics()
    R = point(s)
    T, kN = frame(s)
    _, kJNJ_no_h, _ = map_tangent_curvature(kin.jacobian(R), T, kN)
    _, kN_fd, _ = fd_tangent_curvature(lambda u: kin.joints(point(u)), s)
    assert np.linalg.norm(kJNJ_no_h - kN_fd) > 1e-2


def test_direct_route_equals_composed_route() -> None:
    """(2.14) equals (2.7) followed by (2.11), for random states (not only along test curves)."""
    rng = np.random.default_rng(4)
    kin = RThetaKinematics()
    for _ in range(200):
        r, th = rng.uniform(0.2, 3.0), rng.uniform(-math.pi, math.pi)
        R = r * np.array([math.cos(th), math.sin(th)])
        T = rng.normal(size=2)
        T /= np.linalg.norm(T)
        kN = rng.normal(scale=3.0) * (W @ T)
        S = rng.normal(size=(2, 2))
        J, H = kin.jacobian(R), kin.hessian(R)
        T_J, kJNJ, gJ = joint_from_ee(J, H, T, kN)
        t1, kn1, g1 = coupling_from_joint(S, T_J, kJNJ)
        t2, kn2, g2 = coupling_from_ee(S @ J, np.einsum("ai,ikj->akj", S, H), T, kN)
        scale = 1.0 + float(np.linalg.norm(kn2))
        np.testing.assert_allclose(t1, t2, atol=1e-11)
        np.testing.assert_allclose(kn1, kn2, atol=1e-9 * scale)
        assert g1 * gJ == pytest.approx(g2, rel=1e-11)


# ---------------------------------------------------------------------------- a 3-D map
def _map3(R: np.ndarray) -> np.ndarray:
    x, y, z = R
    return np.array([x * y + z, math.sin(x) + z * z, math.exp(0.3 * y) - x * z])


def _jac3(R: np.ndarray) -> np.ndarray:
    x, y, z = R
    return np.array([[y, x, 1.0], [math.cos(x), 0.0, 2 * z], [-z, 0.3 * math.exp(0.3 * y), -x]])


def _hess3(R: np.ndarray) -> np.ndarray:
    x, y, _ = R
    H = np.zeros((3, 3, 3))  # H[i, k, j] = ∂J_ij/∂R_k, derived by hand
    H[0, 1, 0] = H[0, 0, 1] = 1.0
    H[1, 0, 0] = -math.sin(x)
    H[1, 2, 2] = 2.0
    H[2, 2, 0] = H[2, 0, 2] = -1.0
    H[2, 1, 1] = 0.09 * math.exp(0.3 * y)
    return H


def test_three_dimensional_map_along_a_helix() -> None:
    """n = 3: a nonlinear map and a 2×3 selection, along an arc-length helix."""
    a, b = 0.8, 0.5
    c = math.hypot(a, b)

    def helix(s: float) -> np.ndarray:
        return np.array([a * math.cos(s / c), a * math.sin(s / c), b * s / c])

    s = 0.7
    R = helix(s)
    T = np.array([-a * math.sin(s / c), a * math.cos(s / c), b]) / c
    kN = -(a / c**2) * np.array([math.cos(s / c), math.sin(s / c), 0.0])
    # the test's own map: Jacobian and Hessian agree with differences
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-5
        np.testing.assert_allclose((_map3(R + e) - _map3(R - e)) / 2e-5, _jac3(R)[:, k], atol=1e-9)
        np.testing.assert_allclose(
            (_jac3(R + e) - _jac3(R - e)) / 2e-5, _hess3(R)[:, k, :], atol=1e-9
        )
    T_J, kJNJ, gJ = joint_from_ee(_jac3(R), _hess3(R), T, kN)
    T_fd, kN_fd, speed = fd_tangent_curvature(lambda u: _map3(helix(u)), s)
    np.testing.assert_allclose(T_J, T_fd, atol=FD_TOL)
    np.testing.assert_allclose(kJNJ, kN_fd, atol=FD_TOL * max(1.0, float(np.linalg.norm(kN_fd))))
    assert gJ == pytest.approx(speed, rel=FD_TOL)

    S = np.array([[1.0, 0.0, 0.5], [0.0, 2.0, -1.0]])
    t, kn, g = coupling_from_ee(S @ _jac3(R), np.einsum("ai,ikj->akj", S, _hess3(R)), T, kN)
    t_fd, kn_fd, speed_i = fd_tangent_curvature(lambda u: S @ _map3(helix(u)), s)
    np.testing.assert_allclose(t, t_fd, atol=FD_TOL)
    np.testing.assert_allclose(kn, kn_fd, atol=FD_TOL * max(1.0, float(np.linalg.norm(kn_fd))))
    assert g == pytest.approx(speed_i, rel=FD_TOL)


# ---------------------------------------------------------------------------- Hessians
def test_rtheta_jacobian_and_hessian_equal_differences() -> None:
    """J = ∂L/∂R (eq. 4.1) and H[i, k, j] = ∂J_ij/∂R_k (eqs. 4.3, 4.4) by central differences."""
    rng = np.random.default_rng(7)
    kin = RThetaKinematics()
    h = 1e-6
    for _ in range(50):
        r, th = rng.uniform(0.3, 2.5), rng.uniform(-2.8, 2.8)  # away from the atan2 cut
        R = r * np.array([math.cos(th), math.sin(th)])
        np.testing.assert_allclose(kin.position(kin.joints(R)), R, atol=EXACT_TOL)
        assert kin.joints(R) == pytest.approx([r, th], abs=EXACT_TOL)
        J, H = kin.jacobian(R), kin.hessian(R)
        assert H.shape == (2, 2, 2)
        for k in range(2):
            e = np.zeros(2)
            e[k] = h
            dq = (kin.joints(R + e) - kin.joints(R - e)) / (2 * h)
            np.testing.assert_allclose(J[:, k], dq, atol=1e-8 / r)
            dJ = (kin.jacobian(R + e) - kin.jacobian(R - e)) / (2 * h)
            np.testing.assert_allclose(H[:, k, :], dJ, atol=1e-7 / r**3)


def test_hessian_term_is_the_quadratic_form_per_row() -> None:
    """(2.8): [Tᵀ ∂A/∂R T]_i = Tᵀ H_i T, and equals d²q/ds² along a straight line (κN = 0)."""
    rng = np.random.default_rng(8)
    H = rng.normal(size=(3, 2, 2))
    T = rng.normal(size=2)
    expected = [T @ H[i] @ T for i in range(3)]
    np.testing.assert_allclose(hessian_term(H, T), expected, atol=EXACT_TOL)
    kin = RThetaKinematics()
    R0, T0 = np.array([0.9, -0.4]), np.array([0.6, 0.8])
    h = 1e-4
    q2 = (kin.joints(R0 + h * T0) - 2 * kin.joints(R0) + kin.joints(R0 - h * T0)) / h**2
    np.testing.assert_allclose(hessian_term(kin.hessian(R0), T0), q2, atol=1e-6)


# ---------------------------------------------------------------------------- eq. 2.6
def test_normalised_derivative_matches_differences() -> None:
    """(2.6): d/dσ (X/|X|) = [I - AAᵀ] X'/|X| along a smooth X(σ)."""

    def X(u: float) -> np.ndarray:
        return np.array([math.sin(u) + 2.0, u * u - 0.3, math.cos(3 * u), math.exp(0.5 * u)])

    def Xp(u: float) -> np.ndarray:
        return np.array([math.cos(u), 2 * u, -3 * math.sin(3 * u), 0.5 * math.exp(0.5 * u)])

    for u in (-0.7, 0.0, 0.4, 1.3):
        A, Ap = normalised_derivative(X(u), Xp(u))
        np.testing.assert_allclose(A, X(u) / np.linalg.norm(X(u)), atol=EXACT_TOL)
        fd = d4(lambda v: X(v) / np.linalg.norm(X(v)), u, 1e-3)
        np.testing.assert_allclose(Ap, fd, atol=1e-10)
        assert abs(float(A @ Ap)) < EXACT_TOL  # a unit vector's derivative is ⟂ to it


def test_normalised_derivative_rejects_zero_and_bad_input() -> None:
    with pytest.raises(InvalidInput, match="non-zero"):
        normalised_derivative([0.0, 0.0], [1.0, 0.0])
    with pytest.raises(InvalidInput, match="finite"):
        normalised_derivative([1.0, math.nan], [1.0, 0.0])
    with pytest.raises(InvalidInput, match="shape"):
        normalised_derivative([1.0, 0.0], [1.0, 0.0, 0.0])


# ---------------------------------------------------------------------------- validation
def test_singular_map_along_tangent_raises() -> None:
    """|A T| = 0: the image does not move and its tangent is undefined."""
    A = np.array([[1.0, 0.0], [2.0, 0.0]])
    with pytest.raises(InvalidInput, match="singular"):
        map_tangent_curvature(A, [0.0, 1.0], [1.0, 0.0])
    # same map, a tangent it does not annihilate, is fine
    t, _, g = map_tangent_curvature(A, [1.0, 0.0], [0.0, 1.0])
    np.testing.assert_allclose(t, np.array([1.0, 2.0]) / math.sqrt(5.0), atol=EXACT_TOL)
    assert g == pytest.approx(math.sqrt(5.0))


def test_map_validation_messages() -> None:
    A = np.eye(2)
    with pytest.raises(InvalidInput, match=r"shape \(m, n\)"):
        map_tangent_curvature(np.ones(3), [1.0, 0.0], [0.0, 0.0])
    with pytest.raises(InvalidInput, match=r"A: .* n = len\(T\) = 3, got shape \(2, 2\)"):
        map_tangent_curvature(A, [1.0, 0.0, 0.0], [0.0, 0.0])
    with pytest.raises(InvalidInput, match=r"kN: expected finite"):
        map_tangent_curvature(A, [1.0, 0.0], [math.inf, 0.0])
    with pytest.raises(InvalidInput, match=r"H: expected shape \(2, 2, 2\)"):
        map_tangent_curvature(A, [1.0, 0.0], [0.0, 0.0], np.zeros((2, 2)))
    with pytest.raises(InvalidInput, match="expected numbers"):
        map_tangent_curvature(A, ["a", "b"], [0.0, 0.0])
