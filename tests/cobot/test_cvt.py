"""CVT models (Gillespie 1999 eqs. 2.15–2.18): directions, angle rates, inverse maps, steer rates.

Independent routes: the polar angle of ``direction(φ)`` differentiated numerically (for
``angle_rate``); the ratio ω1/ω2 read off the direction (for eq. 2.16); and the turning rate of
``direction(φ(t))`` under the commanded ``steering_rate`` measured by differences and divided by
the speed (for eqs. 2.15/2.18: it must be the requested curvature).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.cobot import CVT, SteeredWheel, TetrahedralCVT
from velfence.errors import InvalidInput, InvalidParameter

EXACT_TOL = 1e-12
FD_TOL = 1e-9  # 4th-order central difference with h = 1e-3 on O(1) smooth functions
W = np.array([[0.0, -1.0], [1.0, 0.0]])
PHIS = np.linspace(-3.1, 3.1, 41)

MODELS = {
    "wheel": SteeredWheel(),
    "tetra+": TetrahedralCVT(convention=1),
    "tetra-": TetrahedralCVT(convention=-1),
}


@pytest.fixture(params=sorted(MODELS))
def cvt(request: pytest.FixtureRequest) -> CVT:
    return MODELS[request.param]


def d4(f, x: float, h: float = 1e-3):
    return (-f(x + 2 * h) + 8 * f(x + h) - 8 * f(x - h) + f(x - 2 * h)) / (12 * h)


def test_models_are_named_for_plots(cvt: CVT) -> None:
    expected = "wheel" if isinstance(cvt, SteeredWheel) else "tetrahedral"
    assert cvt.name == expected


def test_direction_is_unit(cvt: CVT) -> None:
    for phi in PHIS:
        t = cvt.direction(phi)
        assert t.shape == (2,)
        assert float(np.linalg.norm(t)) == pytest.approx(1.0, abs=EXACT_TOL)


def test_tetrahedral_direction_closed_form() -> None:
    """(2.17) written out, both signs of the lost minus (c = ±1)."""
    for c in (1, -1):
        m = TetrahedralCVT(convention=c)
        for phi in PHIS:
            g = np.array(
                [
                    math.sin(phi) + c * math.sqrt(2) * math.cos(phi),
                    math.sin(phi) - c * math.sqrt(2) * math.cos(phi),
                ]
            )
            np.testing.assert_allclose(m.direction(phi), g / np.linalg.norm(g), atol=EXACT_TOL)
    # the two conventions mirror φ: t_{-1}(φ) = t_{+1}(-φ) up to sign
    for phi in PHIS:
        a, b = (
            TetrahedralCVT(convention=-1).direction(phi),
            TetrahedralCVT(convention=1).direction(-phi),
        )
        assert abs(a[0] * b[1] - a[1] * b[0]) < EXACT_TOL


def test_angle_rate_equals_derivative_of_polar_angle(cvt: CVT) -> None:
    """dψ/dφ with ψ = atan2(t_y, t_x), by differences of the (locally unwrapped) angle."""
    for phi in PHIS:
        t0 = cvt.direction(phi)
        psi0 = math.atan2(t0[1], t0[0])

        def psi(p: float, psi0: float = psi0) -> float:
            t = cvt.direction(p)
            return psi0 + math.remainder(math.atan2(t[1], t[0]) - psi0, 2 * math.pi)

        assert cvt.angle_rate(phi) == pytest.approx(d4(psi, phi), abs=FD_TOL)


def test_tetrahedral_angle_rate_value_from_notes() -> None:
    """docs/cobot.md §2: dψ/dφ = 0.756574 at φ = 0.37 (convention +1); mirrored for -1."""
    assert TetrahedralCVT(convention=1).angle_rate(0.37) == pytest.approx(0.756574, abs=1e-6)
    assert TetrahedralCVT(convention=-1).angle_rate(0.37) == pytest.approx(-0.756574, abs=1e-6)


def test_steering_angle_inverts_direction(cvt: CVT) -> None:
    """direction(steering_angle(t)) = t/|t| exactly (not only up to sign), any scale of t."""
    rng = np.random.default_rng(1)
    for _ in range(200):
        t = rng.normal(size=2) * rng.uniform(1e-3, 1e3)
        np.testing.assert_allclose(
            cvt.direction(cvt.steering_angle(t)), t / np.linalg.norm(t), atol=1e-12
        )
    for phi in PHIS:
        t = cvt.direction(phi)
        np.testing.assert_allclose(cvt.direction(cvt.steering_angle(t)), t, atol=1e-12)
        # the recovered angle is φ itself or φ + π (opposite direction) modulo 2π — here φ mod 2π
        d = math.remainder(cvt.steering_angle(t) - phi, 2 * math.pi)
        assert abs(d) < 1e-12


def test_tetrahedral_phi_and_phi_plus_pi_are_opposite() -> None:
    for c in (1, -1):
        m = TetrahedralCVT(convention=c)
        for phi in PHIS:
            np.testing.assert_allclose(m.direction(phi + math.pi), -m.direction(phi), atol=1e-12)


def test_ratio_is_omega1_over_omega2() -> None:
    """(2.16): M(φ) = ω1/ω2 = t_1/t_2."""
    for c in (1, -1):
        m = TetrahedralCVT(convention=c)
        for phi in PHIS:
            t = m.direction(phi)
            if abs(t[1]) > 1e-6:
                assert m.ratio(phi) == pytest.approx(t[0] / t[1], rel=1e-10)
        # ω2 = 0 where tan φ = c√2: the ratio is unbounded there
        assert abs(m.ratio(math.atan(c * math.sqrt(2)))) > 1e12
    # M(0) = (0 + √2)/(0 - √2) = -1 for c = +1; M(π/2) = 1 for both
    assert TetrahedralCVT(convention=1).ratio(0.0) == pytest.approx(-1.0)
    assert TetrahedralCVT(convention=-1).ratio(math.pi / 2) == pytest.approx(1.0)


def test_steering_rate_realises_the_curvature(cvt: CVT) -> None:
    """Turning direction(φ) at the commanded φ̇ turns t at κ·ṡ: (W t)ᵀ dt/dt / ṡ = κ."""
    rng = np.random.default_rng(2)
    for _ in range(100):
        phi = rng.uniform(-math.pi, math.pi)
        kappa = rng.normal(scale=2.0)
        speed = rng.normal(scale=1.5)
        rate = cvt.steering_rate(phi, kappa, speed)
        t = cvt.direction(phi)
        h = 1e-3 / (1.0 + abs(rate))  # a step of at most 1e-3 rad in φ
        dt_dtime = d4(lambda tau, phi=phi, rate=rate: cvt.direction(phi + rate * tau), 0.0, h)
        assert float((W @ t) @ dt_dtime) == pytest.approx(kappa * speed, rel=1e-9, abs=1e-9)
        # the identity the code documents: φ̇ · dψ/dφ = κ ṡ
        assert rate * cvt.angle_rate(phi) == pytest.approx(kappa * speed, rel=1e-12, abs=1e-15)


def test_wheel_steering_rate_is_eq_2_15() -> None:
    """(2.15): φ̇ = u κ for the wheel, whatever φ."""
    w = SteeredWheel()
    for phi, kappa, u in [(0.3, 2.0, 1.5), (-2.0, -0.5, 0.8), (1.0, 3.0, -2.0), (0.0, 0.0, 5.0)]:
        assert w.steering_rate(phi, kappa, u) == pytest.approx(u * kappa, abs=EXACT_TOL)
        assert w.angle_rate(phi) == 1.0


def test_tetrahedral_steering_rate_is_eq_2_18() -> None:
    """(2.18): φ̇ = ṡ κ (1 + cos²φ)/√2, with a leading minus for the mirrored convention."""
    for phi, kappa, u in [(0.37, 1.2, 0.9), (-2.5, -0.7, 1.1), (1.4, 2.5, -0.4)]:
        expected = u * kappa * (1 + math.cos(phi) ** 2) / math.sqrt(2)
        assert TetrahedralCVT(convention=1).steering_rate(phi, kappa, u) == pytest.approx(expected)
        assert TetrahedralCVT(convention=-1).steering_rate(phi, kappa, u) == pytest.approx(
            -expected
        )


def test_steering_rate_does_not_depend_on_the_sign_of_t() -> None:
    """κ ṡ is invariant under t → -t (both flip), so φ and φ + π steer at the same rate."""
    m = TetrahedralCVT(convention=1)
    phi, kappa, u = 0.8, 1.3, 0.7
    assert m.steering_rate(phi + math.pi, -kappa, -u) == pytest.approx(
        m.steering_rate(phi, kappa, u)
    )


# ---------------------------------------------------------------------------- validation
@pytest.mark.parametrize("phi", [math.nan, math.inf, -math.inf])
def test_non_finite_phi_raises(cvt: CVT, phi: float) -> None:
    with pytest.raises(InvalidInput, match="finite steering angle"):
        cvt.direction(phi)


def test_non_numeric_phi_raises() -> None:
    with pytest.raises(InvalidInput, match=r"expected a steering angle \[rad\]"):
        TetrahedralCVT().direction("left")  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="finite steering angle"):
        TetrahedralCVT().angle_rate(math.nan)
    with pytest.raises(InvalidInput, match="finite steering angle"):
        TetrahedralCVT().ratio(math.inf)


@pytest.mark.parametrize(
    "t", [[0.0, 0.0], [1.0, 0.0, 0.0], [math.nan, 1.0], [1.0], [[1.0, 0.0]]], ids=str
)
def test_bad_direction_raises(cvt: CVT, t: list) -> None:
    with pytest.raises(
        InvalidInput,
        match=r"^t: expected (shape \(2,\)|finite values|a non-zero direction of shape \(2,\))",
    ):
        cvt.steering_angle(np.asarray(t, dtype=float))


@pytest.mark.parametrize("c", [0, 2, -2, True, 1.5, "1"])
def test_bad_convention_raises(c: object) -> None:
    with pytest.raises(InvalidParameter, match=r"convention: expected \+1 or -1"):
        TetrahedralCVT(convention=c)  # type: ignore[arg-type]
