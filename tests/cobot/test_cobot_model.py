"""The cobot model (Gillespie 1999 §2.3.2, eqs. 2.19–2.24) and the inverse route through the CVTs.

Independent routes: Λ against the Gram determinant and the Laplace expansion; the heading against
the constraint it must satisfy, (W t_i)ᵀ S_i J T = 0 (eq. 2.20), for every CVT; the two inverse
routes against each other; and the whole loop — forward heading plus inverse steering rates,
integrated by scipy's DOP853 with tight tolerances — against the circle a constant prescribed
curvature must trace.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from optional import requires
from velfence.cobot import (
    Cobot,
    CobotKinematics,
    Coupling,
    IdentityKinematics,
    RThetaKinematics,
    SteeredWheel,
    TetrahedralCVT,
    generalised_cross,
    r_theta_cobot,
    unicycle,
)
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter

W = np.array([[0.0, -1.0], [1.0, 0.0]])
EXACT_TOL = 1e-12
S_XY = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
S_YZ = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 2.0]])


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def cross2(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def random_polar(rng: np.random.Generator) -> np.ndarray:
    return np.array([rng.uniform(0.3, 2.0), rng.uniform(-3.0, 3.0)])


def three_d_cobot() -> Cobot:
    """n = 3, identity kinematics, a wheel on (x, y) and a tetrahedral CVT on (y, 2z)."""
    return Cobot(
        IdentityKinematics(n=3),
        [
            Coupling(SteeredWheel(), selection=S_XY),
            Coupling(TetrahedralCVT(convention=1), selection=S_YZ),
        ],
        name="xyz",
    )


def direct_maps(S: np.ndarray):
    def f(R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return S.copy(), np.zeros((2, S.shape[1], S.shape[1]))

    return f


class CubicKinematics:
    """q = (x, y³): J = diag(1, 3y²) is singular on the x axis (a test mechanism)."""

    dim = 2

    def joints(self, R: np.ndarray) -> np.ndarray:
        return np.array([R[0], R[1] ** 3])

    def position(self, q: np.ndarray) -> np.ndarray:
        return np.array([q[0], np.cbrt(q[1])])

    def jacobian(self, R: np.ndarray) -> np.ndarray:
        return np.diag([1.0, 3.0 * R[1] ** 2])

    def hessian(self, R: np.ndarray) -> np.ndarray:
        H = np.zeros((2, 2, 2))
        H[1, 1, 1] = 6.0 * R[1]
        return H


# ---------------------------------------------------------------------------- Λ (eq. 2.22)
@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_generalised_cross_is_orthogonal_and_has_the_gram_volume(n: int) -> None:
    rng = np.random.default_rng(n)
    for _ in range(50):
        Om = rng.normal(size=(n - 1, n))
        Lam = generalised_cross(Om)
        assert Lam.shape == (n,)
        scale = float(np.prod(np.linalg.norm(Om, axis=1)))
        np.testing.assert_allclose(Om @ Lam, 0.0, atol=1e-12 * scale * math.sqrt(n))
        # |Λ| = (n-1)-volume of the rows = sqrt(det(Ω Ωᵀ)) (Cauchy–Binet)
        gram = float(np.linalg.det(Om @ Om.T))
        assert float(np.linalg.norm(Lam)) == pytest.approx(math.sqrt(gram), rel=1e-10)
        # orientation: Laplace expansion along a first row Λᵀ gives det([Λᵀ; Ω]) = |Λ|²
        assert float(np.linalg.det(np.vstack([Lam, Om]))) == pytest.approx(
            float(Lam @ Lam), rel=1e-10
        )


def test_generalised_cross_special_cases() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=3), rng.normal(size=3)
    np.testing.assert_allclose(generalised_cross([a, b]), np.cross(a, b), atol=EXACT_TOL)
    np.testing.assert_allclose(generalised_cross([[3.0, 4.0]]), [4.0, -3.0], atol=EXACT_TOL)
    for n in (3, 4):
        Om = rng.normal(size=(n - 1, n))
        Om[-1] = 2.5 * Om[0]  # dependent rows
        np.testing.assert_allclose(generalised_cross(Om), 0.0, atol=1e-12)
    with pytest.raises(InvalidInput, match=r"Omega: expected shape \(n-1, n\)"):
        generalised_cross(np.ones((2, 2)))
    with pytest.raises(InvalidInput, match=r"Omega: expected shape \(n-1, n\)"):
        generalised_cross(np.ones(3))


# ---------------------------------------------------------------------------- heading
@pytest.mark.parametrize("convention", [1, -1])
def test_rtheta_heading_satisfies_the_cvt_constraint(convention: int) -> None:
    """The returned T, mapped by J and S, is parallel to t(φ) (eq. 2.20); T_J = JT/|JT|."""
    rng = np.random.default_rng(10 + convention)
    cob = r_theta_cobot(convention=convention)
    kin = cob.kinematics
    S = cob.couplings[0].selection
    for _ in range(200):
        q = random_polar(rng)
        phi = rng.uniform(-math.pi, math.pi)
        h = cob.heading(q, [phi])
        assert h.singular == ""
        assert h.ambiguous
        R = kin.position(q)
        J = kin.jacobian(R)
        t = TetrahedralCVT(convention=convention).direction(phi)
        np.testing.assert_allclose(h.t[0], t, atol=EXACT_TOL)
        assert float(np.linalg.norm(h.T)) == pytest.approx(1.0, abs=EXACT_TOL)
        image = S @ J @ h.T
        assert float(np.linalg.norm(image)) > 1e-6
        assert abs(cross2(unit(image), t)) < 1e-12  # (2.20): (W t)ᵀ S J T = 0
        np.testing.assert_allclose(h.T_J, unit(J @ h.T), atol=1e-12)
        np.testing.assert_allclose(h.T_J, unit(h.Lambda), atol=1e-12)  # (2.23), sign of Λ kept


def test_three_dof_heading_satisfies_every_constraint() -> None:
    rng = np.random.default_rng(3)
    cob = three_d_cobot()
    for _ in range(100):
        phi = rng.uniform(-math.pi, math.pi, size=2)
        h = cob.heading(rng.normal(size=3), phi)
        assert h.singular == ""
        for c, t in zip(cob.couplings, h.t, strict=True):
            image = c.selection @ h.T
            assert float((W @ t) @ image) == pytest.approx(0.0, abs=1e-12)
        assert float(np.linalg.norm(h.T)) == pytest.approx(1.0, abs=EXACT_TOL)


def test_direct_and_mixed_couplings_give_the_same_heading() -> None:
    """Ω built in C_EE from direct J_i equals Ω built in C_J from S_i (identity kinematics)."""
    rng = np.random.default_rng(5)
    sel = three_d_cobot()
    direct = Cobot(
        IdentityKinematics(n=3),
        [
            Coupling(SteeredWheel(), jacobian=direct_maps(S_XY)),
            Coupling(TetrahedralCVT(convention=1), jacobian=direct_maps(S_YZ)),
        ],
    )
    mixed = Cobot(
        IdentityKinematics(n=3),
        [
            Coupling(SteeredWheel(), selection=S_XY),
            Coupling(TetrahedralCVT(convention=1), jacobian=direct_maps(S_YZ)),
        ],
    )
    for _ in range(50):
        q, phi = rng.normal(size=3), rng.uniform(-3, 3, size=2)
        ref = sel.heading(q, phi).T
        for cob in (direct, mixed):
            h = cob.heading(q, phi, reference=ref)
            np.testing.assert_allclose(h.T, ref, atol=1e-12)


def test_unicycle_heading_is_the_wheel_direction() -> None:
    cob = unicycle()
    for phi in np.linspace(-3.0, 3.0, 13):
        h = cob.heading([0.3, -0.2], [phi])
        t = np.array([math.cos(phi), math.sin(phi)])
        assert abs(cross2(h.T, t)) < EXACT_TOL
        assert float(np.linalg.norm(h.T)) == pytest.approx(1.0)


def test_reference_resolves_the_sign() -> None:
    cob = r_theta_cobot()
    q, phi = np.array([1.1, 0.4]), [0.9]
    h0 = cob.heading(q, phi)
    assert h0.ambiguous
    for ref in (h0.T, -h0.T, np.array([1.0, 0.0]), np.array([0.0, -3.0])):
        h = cob.heading(q, phi, reference=ref)
        assert not h.ambiguous
        assert float(h.T @ ref) >= 0.0
        assert abs(cross2(h.T, h0.T)) < EXACT_TOL
        assert float(h.T_J @ cob.kinematics.jacobian(cob.kinematics.position(q)) @ h.T) > 0
    flipped = cob.heading(q, phi, reference=-h0.T)
    np.testing.assert_allclose(flipped.T, -h0.T, atol=EXACT_TOL)
    np.testing.assert_allclose(flipped.T_J, -h0.T_J, atol=EXACT_TOL)
    assert cob.heading(q, phi, reference=[0.0, 0.0]).ambiguous  # a zero reference resolves nothing


def test_singular_lambda_is_flagged() -> None:
    """Two CVTs constraining the same coupling space at the same angle: Ω has dependent rows."""
    cob = Cobot(
        IdentityKinematics(n=3),
        [Coupling(SteeredWheel(), selection=S_XY), Coupling(SteeredWheel(), selection=S_XY)],
    )
    h = cob.heading([0.1, 0.2, 0.3], [0.7, 0.7])
    assert h.singular == "lambda"
    np.testing.assert_array_equal(h.T, 0.0)
    np.testing.assert_array_equal(h.T_J, 0.0)
    # different angles: the only motion both wheels allow is along z
    h = cob.heading([0.1, 0.2, 0.3], [0.7, 1.2], reference=[0.0, 0.0, 1.0])
    assert h.singular == ""
    np.testing.assert_allclose(h.T, [0.0, 0.0, 1.0], atol=EXACT_TOL)


def test_singular_jacobian_is_flagged() -> None:
    kin = CubicKinematics()
    assert isinstance(kin, CobotKinematics)
    cob = Cobot(kin, [Coupling(SteeredWheel(), selection=np.eye(2))])
    h = cob.heading(kin.joints(np.array([0.4, 0.0])), [0.3])
    assert h.singular == "jacobian"
    np.testing.assert_array_equal(h.T, 0.0)
    h = cob.heading(kin.joints(np.array([0.4, 0.5])), [0.3])
    assert h.singular == ""
    # T_J ∥ t(φ) in joint space, T = J⁻¹ T_J normalised
    np.testing.assert_allclose(abs(h.T_J @ [math.cos(0.3), math.sin(0.3)]), 1.0, atol=1e-12)
    np.testing.assert_allclose(h.T, unit(np.linalg.solve(kin.jacobian([0.4, 0.5]), h.T_J)))


def test_rtheta_at_the_pivot_raises() -> None:
    """r = 0: the r-θ Jacobian itself is undefined (raised by the kinematics, named)."""
    with pytest.raises(InvalidInput, match="pivot"):
        r_theta_cobot().heading([0.0, 0.5], [0.3])


COBOTS = {
    "rtheta+": lambda: r_theta_cobot(convention=1),
    "rtheta-": lambda: r_theta_cobot(convention=-1, r_o=1.7),
    "unicycle": unicycle,
    "xyz": three_d_cobot,
}


@pytest.mark.parametrize("name", sorted(COBOTS))
def test_steering_angles_then_heading_returns_the_tangent(name: str) -> None:
    rng = np.random.default_rng(11)
    cob = COBOTS[name]()
    kin = cob.kinematics
    for _ in range(100):
        if isinstance(kin, RThetaKinematics):
            q = random_polar(rng)
            R = kin.position(q)
        else:
            R = rng.normal(size=cob.dim)
            q = kin.joints(R)
        T = unit(rng.normal(size=cob.dim))
        phi = cob.steering_angles(R, T)
        assert phi.shape == (cob.dim - 1,)
        h = cob.heading(q, phi)
        assert abs(abs(float(h.T @ T)) - 1.0) < 1e-10  # ±T
        np.testing.assert_allclose(cob.heading(q, phi, reference=T).T, T, atol=1e-10)


# ---------------------------------------------------------------------------- inverse route
@pytest.mark.parametrize("name", ["rtheta+", "rtheta-", "xyz"])
def test_direct_route_equals_joint_route(name: str) -> None:
    rng = np.random.default_rng(12)
    cob = COBOTS[name]()
    kin = cob.kinematics
    for _ in range(100):
        R = (
            kin.position(random_polar(rng))
            if isinstance(kin, RThetaKinematics)
            else rng.normal(size=cob.dim)
        )
        T = unit(rng.normal(size=cob.dim))
        kN = rng.normal(scale=2.0, size=cob.dim)
        kN -= T * (T @ kN)
        phi = rng.uniform(-3.0, 3.0, size=cob.dim - 1)
        u = rng.normal()
        a = cob.steering_rates(R, phi, T, kN, u, route="direct")
        b = cob.steering_rates(R, phi, T, kN, u, route="joint")
        np.testing.assert_allclose(a.phi_dot, b.phi_dot, rtol=1e-9, atol=1e-10)
        np.testing.assert_allclose(a.t, b.t, atol=1e-12)
        np.testing.assert_allclose(a.kappa_n, b.kappa_n, rtol=1e-9, atol=1e-10)
        np.testing.assert_allclose(a.speed, b.speed, rtol=1e-12, atol=1e-14)
        assert b.T_J.shape == (cob.dim,)
        assert a.T_J.shape == (0,)
        # the coupling speeds: ṡ_i = |J_i T| u with sign of u
        for c, si in zip(cob.couplings, a.speed, strict=True):
            J_i = c.selection @ kin.jacobian(R)
            assert si == pytest.approx(np.linalg.norm(J_i @ T) * u, rel=1e-12)


def test_zero_speed_or_zero_curvature_means_no_steering() -> None:
    cob = r_theta_cobot()
    R, T = np.array([1.0, 0.5]), unit(np.array([0.3, 1.0]))
    kN = 1.5 * (W @ T)
    np.testing.assert_array_equal(cob.steering_rates(R, [0.4], T, kN, 0.0).phi_dot, 0.0)
    # straight in C_EE is not straight in Σ (the Hessian term), so a zero κN still steers here;
    # on the unicycle it does not
    st = unicycle().steering_rates(R, [0.4], T, np.zeros(2), 2.0)
    np.testing.assert_allclose(st.phi_dot, 0.0, atol=EXACT_TOL)


def test_joint_route_needs_selections() -> None:
    with pytest.raises(InvalidParameter, match="route='joint' needs selection"):
        unicycle().steering_rates([0.0, 0.0], [0.1], [1.0, 0.0], [0.0, 0.0], 1.0, route="joint")
    with pytest.raises(InvalidParameter, match="route must be one of"):
        unicycle().steering_rates([0.0, 0.0], [0.1], [1.0, 0.0], [0.0, 0.0], 1.0, route="x")


# ---------------------------------------------------------------------------- closed loop
def integrate_constant_curvature(
    cob: Cobot, R0: np.ndarray, T0: np.ndarray, kappa: float, length: float, route: str
):
    """Forward heading + inverse steering at unit speed, ds = dt, integrated by DOP853.

    State (q, φ); dq/ds = J(R) T, dφ/ds = steering_rates(R, φ, T, κ W T, 1). The sign of T is the
    sign of Λ times a constant fixed at the start (Λ is continuous in φ and never zero here).
    """
    kin = cob.kinematics
    m = cob.dim - 1
    q0 = kin.joints(R0)
    phi0 = cob.steering_angles(R0, T0)
    sign = 1.0 if float(cob.heading(q0, phi0).T @ T0) > 0 else -1.0

    def rhs(s: float, y: np.ndarray) -> np.ndarray:
        q, phi = y[: cob.dim], y[cob.dim :]
        R = kin.position(q)
        T = sign * cob.heading(q, phi).T
        st = cob.steering_rates(R, phi, T, kappa * (W @ T), 1.0, route=route)
        return np.concatenate([kin.jacobian(R) @ T, st.phi_dot])

    from scipy.integrate import solve_ivp

    S = np.linspace(0.0, length, 41)
    sol = solve_ivp(
        rhs,
        (0.0, length),
        np.concatenate([q0, phi0]),
        method="DOP853",
        t_eval=S,
        rtol=1e-11,
        atol=1e-12,
    )
    assert sol.success
    R = np.array([kin.position(sol.y[: cob.dim, j]) for j in range(len(S))])
    assert m == 1
    return S, R


@requires("scipy")
@pytest.mark.parametrize(
    ("name", "route", "kappa"),
    [
        ("rtheta+", "direct", 2.0),
        ("rtheta+", "joint", -2.0),
        ("rtheta-", "direct", -2.0),
        ("rtheta-", "joint", 2.0),
        ("unicycle", "direct", 2.0),
        ("unicycle", "direct", -1.0),
    ],
)
def test_prescribed_curvature_traces_the_circle(name: str, route: str, kappa: float) -> None:
    """Constant κ in C_EE → the cart follows the circle of radius 1/|κ| through R0 tangent to T0."""
    cob = COBOTS[name]()
    R0, T0 = np.array([1.2, 0.3]), np.array([0.6, 0.8])
    # centre R0 + W T0/κ: for |κ| = 2 it is (0.8, 0.6) or (1.6, 0.0), so the circle keeps r >= 0.5
    center = R0 + (W @ T0) / kappa
    S, R = integrate_constant_curvature(cob, R0, T0, kappa, 0.9 * 2 * math.pi / abs(kappa), route)
    rho = 1.0 / abs(kappa)
    # the analytic circle point at arc length s: rotate R0 - c by κ s about c
    ang = kappa * S
    d0 = R0 - center
    expected = center + np.column_stack(
        [np.cos(ang) * d0[0] - np.sin(ang) * d0[1], np.sin(ang) * d0[0] + np.cos(ang) * d0[1]]
    )
    np.testing.assert_allclose(np.linalg.norm(R - center, axis=1), rho, atol=1e-8)
    np.testing.assert_allclose(R, expected, atol=1e-8)


@requires("scipy")
def test_rtheta_closed_loop_does_not_depend_on_r_o() -> None:
    R0, T0 = np.array([1.2, 0.3]), np.array([0.6, 0.8])
    _, a = integrate_constant_curvature(r_theta_cobot(r_o=0.5), R0, T0, 1.5, 2.0, "direct")
    _, b = integrate_constant_curvature(r_theta_cobot(r_o=3.0), R0, T0, 1.5, 2.0, "direct")
    np.testing.assert_allclose(a, b, atol=1e-8)


# ---------------------------------------------------------------------------- validation
def test_construction_errors() -> None:
    tet = TetrahedralCVT()
    with pytest.raises(InvalidParameter, match=r"n - 1 = 1 CVTs, got 2"):
        Cobot(RThetaKinematics(), [Coupling(tet, selection=np.eye(2))] * 2)
    with pytest.raises(InvalidParameter, match=r"n - 1 = 2 CVTs, got 1"):
        Cobot(IdentityKinematics(n=3), [Coupling(tet, selection=S_XY)])
    with pytest.raises(
        InvalidParameter, match=r"couplings\[0\].selection: expected shape \(2, 2\)"
    ):
        Cobot(RThetaKinematics(), [Coupling(tet, selection=S_XY)])
    with pytest.raises(InvalidParameter, match=r"couplings\[0\]: expected a Coupling"):
        Cobot(RThetaKinematics(), [tet])  # type: ignore[list-item]
    with pytest.raises(InvalidParameter, match="kinematics: expected CobotKinematics"):
        Cobot(object(), [])  # type: ignore[arg-type]
    with pytest.raises(
        InvalidGeometry, match=r"selection: expected shape \(2, N\), got shape \(3, 2\)"
    ):
        Coupling(tet, selection=np.ones((3, 2)))
    with pytest.raises(InvalidGeometry, match=r"selection: expected finite values"):
        Coupling(tet, selection=[[1.0, math.nan], [0.0, 1.0]])
    with pytest.raises(InvalidParameter, match=r"exactly one of selection .* got both"):
        Coupling(tet, selection=np.eye(2), jacobian=direct_maps(np.eye(2)))
    with pytest.raises(InvalidParameter, match=r"exactly one of selection .* got neither"):
        Coupling(tet)
    with pytest.raises(InvalidParameter, match="cvt: expected a CVT model"):
        Coupling("tetra", selection=np.eye(2))  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="n: expected an int >= 2"):
        IdentityKinematics(n=1)
    with pytest.raises(InvalidParameter, match="r_o must be finite and > 0"):
        r_theta_cobot(r_o=0.0)
    with pytest.raises(InvalidParameter, match="convention"):
        r_theta_cobot(convention=0)


def test_selection_is_copied_read_only() -> None:
    S = np.eye(2)
    c = Coupling(TetrahedralCVT(), selection=S)
    S[0, 0] = 5.0
    assert c.selection[0, 0] == 1.0
    with pytest.raises(ValueError, match="read-only"):
        c.selection[0, 0] = 2.0


def test_input_errors() -> None:
    cob = r_theta_cobot()
    with pytest.raises(InvalidInput, match=r"phi: expected shape \(1,\)"):
        cob.heading([1.0, 0.0], [0.1, 0.2])
    with pytest.raises(InvalidInput, match=r"q: expected finite values"):
        cob.heading([math.nan, 0.0], [0.1])
    with pytest.raises(InvalidInput, match=r"reference: expected shape \(2,\)"):
        cob.heading([1.0, 0.0], [0.1], reference=[1.0])
    with pytest.raises(InvalidInput, match="speed: expected a finite speed"):
        cob.steering_rates([1.0, 0.0], [0.1], [0.0, 1.0], [0.0, 0.0], math.nan)
    with pytest.raises(InvalidInput, match=r"kN: expected shape \(2,\)"):
        cob.steering_rates([1.0, 0.0], [0.1], [0.0, 1.0], [0.0], 1.0)
    with pytest.raises(InvalidInput, match=r"T: expected numbers of shape"):
        cob.steering_angles([1.0, 0.0], ["a", "b"])
