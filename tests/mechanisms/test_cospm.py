"""Tests of the CoSPM of Lê et al. 2024 (velfence.mechanisms.cospm)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon
from velfence.mechanisms.cospm import (
    PAPER_STOPS,
    PAPER_WORKSPACE,
    Q_AUX,
    CoSPM,
    CoSPMDesign,
)
from velfence.mechanisms.cospm_region import (
    RegionReport,
    singular_curves,
    stops_polygon,
    validate_region,
    workspace_map,
)

IDENTITY_ATOL = 1e-12  # exact identities of the model, evaluated in float64
NOTES_ATOL = 1e-4  # reference values printed with 4-5 decimals
FD_STEP = 1e-6  # [rad], central differences
FD_RTOL = 1e-6
FD_ATOL = 1e-8
ROUND_TRIP_ATOL = 1e-9  # [rad], FKP converged to |f| <= 1e-12
DEG = math.pi / 180.0
HALF_PI = math.pi / 2.0

# Reference values of an independent hand computation of the Table 1 model (docs/cospm.md §5, §7)
NOTES_HOME_J = np.array([[-0.7071, -0.7071, 1.4142], [-0.7071, 0.7071, 0.0], [0.0, 0.0, -1.0]])
NOTES_VERTICES = {
    (0, 1): (1.15060, -1.07097),
    (1, 2): (1.51068, -0.45164),
    (2, 3): (-0.53114, 0.62644),
    (0, 3): (-0.80759, 0.15094),
}
NOTES_HOME_DELTAS = (0.29948, 1.53299, 0.30597, 0.77404)


@pytest.fixture(scope="module")
def cospm() -> CoSPM:
    return CoSPM()


# ---------------------------------------------------------------------- independent model
def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=float)


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], dtype=float)


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=float)


EZ = np.array([0.0, 0.0, 1.0])


def _f_explicit(
    theta: np.ndarray, chi: np.ndarray, *, mirror: bool = False, base_eta: bool = True
) -> np.ndarray:
    """The §2 model vectors (docs/cospm.md) from explicit rotation matrices, Table 1."""
    d = CoSPMDesign.table1()
    R = _rz(chi[2]) @ _ry(chi[1]) @ _rx(chi[0])
    out = np.empty(3)
    for i in range(3):
        base = (_rz(d.eta[i]) if base_eta else np.eye(3)) @ _rx(d.beta1 - math.pi)
        a1 = -d.alpha1[i] if mirror else d.alpha1[i]
        w = base @ _rz(theta[i]) @ _rx(a1) @ EZ
        v = R @ _rz(d.eta[i]) @ _rx(d.beta2) @ EZ
        out[i] = w @ v - math.cos(d.alpha2[i])
    return out


def _near_home(n: int, seed: int, spread: float = 0.4) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return HALF_PI + rng.uniform(-spread, spread, (n, 3))


# ---------------------------------------------------------------------- design
def test_table1_is_the_papers_table() -> None:
    d = CoSPMDesign.table1()
    np.testing.assert_allclose(d.alpha1, [math.pi / 4, math.pi / 4, HALF_PI])
    np.testing.assert_allclose(d.alpha2, [HALF_PI] * 3)
    np.testing.assert_allclose(d.eta, [math.pi / 4, -math.pi / 4, 0.0])
    assert (d.beta1, d.beta2) == (0.0, HALF_PI)


def test_design_is_frozen_read_only_keyword_only_and_comparable() -> None:
    d = CoSPMDesign.table1()
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.beta1 = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        d.alpha1[0] = 0.0
    with pytest.raises(TypeError):
        CoSPMDesign([1, 1, 1], [1, 1, 1], [0, 1, 2], 0.0, 1.0)  # type: ignore[misc]
    assert d == CoSPMDesign.table1()
    assert hash(d) == hash(CoSPMDesign.table1())
    assert d != dataclasses.replace(d, beta2=1.0)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"alpha1": [1.0, 1.0]}, r"alpha1: expected shape \(3,\)"),
        ({"alpha2": [1.0, math.pi, 1.0]}, r"alpha2: expected link arcs in \(0, π\)"),
        ({"alpha1": [0.0, 1.0, 1.0]}, r"alpha1: expected link arcs .*leg\(s\) \[0\]"),
        ({"eta": [0.0, np.nan, 1.0]}, "eta: expected finite angles"),
        ({"eta": [0.0, 2 * math.pi, 1.0]}, "eta: expected pairwise distinct"),
        ({"beta1": 0.3}, "beta1: expected 0 or π rad"),
        ({"beta2": 0.0}, "beta2: expected a tilt away from 0 and π"),
        ({"beta2": "x"}, "beta2: expected a real angle"),
        ({"alpha1": "abc"}, "alpha1: expected three angles"),
    ],
)
def test_bad_design_is_rejected_with_a_message(change: dict[str, object], message: str) -> None:
    with pytest.raises(InvalidGeometry, match=message):
        dataclasses.replace(CoSPMDesign.table1(), **change)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"design": "table1"}, "design: expected a CoSPMDesign, got str"),
        ({"mirror": 1}, "mirror: expected True or False"),
        ({"fk_tol": 0.0}, r"fk_tol must be finite and > 0 .* got 0\.0"),
        ({"fk_max_iter": 0}, "fk_max_iter: expected an int >= 1"),
        ({"fk_max_iter": True}, "fk_max_iter: expected a positive int"),
        ({"fk_step": -1.0}, r"fk_step must be finite and > 0 .* got -1\.0"),
        ({"singular_tol": 1.0}, r"singular_tol: expected a fraction in \(0, 1\)"),
    ],
)
def test_bad_options_are_rejected(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(InvalidParameter, match=message):
        CoSPM(**kwargs)  # type: ignore[arg-type]


def test_design_without_a_regular_home_is_rejected() -> None:
    # At chi = 0 leg 1's platform axis is horizontal and w_1 · v_1 spans ±sin(π/4) = ±0.707;
    # a distal arc of 0.2 rad needs w_1 · v_1 = cos 0.2 = 0.98: out of reach.
    d = dataclasses.replace(CoSPMDesign.table1(), alpha2=[0.2, HALF_PI, HALF_PI])
    with pytest.raises(InvalidGeometry, match="no home assembly at chi = 0"):
        CoSPM(design=d)


# ---------------------------------------------------------------------- geometric model
def test_home_is_half_pi_and_satisfies_the_model(cospm: CoSPM) -> None:
    theta, chi = cospm.home()
    np.testing.assert_allclose(theta, [HALF_PI] * 3, atol=1e-15)
    np.testing.assert_array_equal(chi, np.zeros(3))
    np.testing.assert_allclose(cospm.geometric_model(theta, chi), 0.0, atol=IDENTITY_ATOL)


@pytest.mark.parametrize("mirror", [False, True])
def test_model_matches_the_notes_vectors_from_explicit_matrices(mirror: bool) -> None:
    m = CoSPM(mirror=mirror)
    rng = np.random.default_rng(1)
    T = rng.uniform(-4, 4, (20, 3))
    C = rng.uniform(-3, 3, (20, 3))
    got = m.geometric_model(T, C)
    want = np.array([_f_explicit(t, c, mirror=mirror) for t, c in zip(T, C, strict=True)])
    np.testing.assert_allclose(got, want, atol=IDENTITY_ATOL)
    for k in range(3):  # batch == loop
        np.testing.assert_array_equal(m.geometric_model(T[k], C[k]), got[k])


def test_axes_are_unit_and_inputs_coaxial(cospm: CoSPM) -> None:
    u, w, v = cospm.axes(np.array([0.3, 1.2, 2.0]), np.array([0.1, -0.2, 0.5]))
    np.testing.assert_allclose(u, np.tile([0.0, 0.0, -1.0], (3, 1)), atol=IDENTITY_ATOL)
    np.testing.assert_allclose(np.linalg.norm(w, axis=1), 1.0, atol=IDENTITY_ATOL)
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=IDENTITY_ATOL)


def test_check_a_home_needs_eta_on_the_base_side_too() -> None:
    """docs/cospm.md §2 (a): without the base-side R_z(η_i), home would need θ_i = π/2 - η_i."""
    home = np.full(3, HALF_PI)
    np.testing.assert_allclose(_f_explicit(home, np.zeros(3)), 0.0, atol=IDENTITY_ATOL)
    assert np.max(np.abs(_f_explicit(home, np.zeros(3), base_eta=False))) > 0.5
    shifted = HALF_PI - CoSPMDesign.table1().eta
    np.testing.assert_allclose(
        _f_explicit(shifted, np.zeros(3), base_eta=False), 0.0, atol=IDENTITY_ATOL
    )


def test_check_b_bearing_invariance_identity_and_its_sign(cospm: CoSPM) -> None:
    rng = np.random.default_rng(2)
    for _ in range(50):
        theta = rng.uniform(-5, 5, 3)
        chi = rng.uniform(-3, 3, 3)
        eps = float(rng.uniform(-4, 4))
        lhs = cospm.geometric_model(theta + eps, chi)
        rhs = cospm.geometric_model(theta, chi + eps * np.array([0.0, 0.0, 1.0]))
        np.testing.assert_allclose(lhs, rhs, atol=IDENTITY_ATOL)
    # The sign matters (the R_x(-π) flip of docs/cospm.md §2): the opposite sign is not an identity.
    theta, chi, eps = np.array([1.0, 2.0, 0.5]), np.array([0.2, 0.3, 0.1]), 0.7
    wrong = cospm.geometric_model(theta, chi - eps * np.array([0.0, 0.0, 1.0]))
    assert np.max(np.abs(cospm.geometric_model(theta + eps, chi) - wrong)) > 0.1
    assert cospm.bearing_sign == 1.0


def test_bearing_shift_maps_assemblies_to_assemblies(cospm: CoSPM) -> None:
    theta = np.array([1.2, 1.9, 1.6])
    chi = cospm.forward_kinematics(theta)
    t2, c2 = cospm.bearing_shift(theta, chi, 0.9)
    np.testing.assert_allclose(t2, theta + 0.9)
    np.testing.assert_allclose(c2, chi - [0.0, 0.0, 0.9])
    np.testing.assert_allclose(cospm.geometric_model(t2, c2), 0.0, atol=IDENTITY_ATOL)
    np.testing.assert_allclose(cospm.jacobian(t2, c2), cospm.jacobian(theta, chi), atol=1e-12)
    assert cospm.type2(t2, c2) == pytest.approx(cospm.type2(theta, chi), abs=1e-14)
    with pytest.raises(InvalidInput, match="eps: expected a finite angle"):
        cospm.bearing_shift(theta, chi, math.inf)


def test_bearing_sign_flips_for_beta1_pi() -> None:
    d = dataclasses.replace(CoSPMDesign.table1(), beta1=math.pi)
    m = CoSPM(design=d)
    assert m.bearing_sign == -1.0
    theta, chi, eps = np.array([0.4, 1.0, 2.0]), np.array([0.1, -0.2, 0.3]), 0.37
    np.testing.assert_allclose(
        m.geometric_model(theta + eps, chi),
        m.geometric_model(theta, chi - [0.0, 0.0, eps]),
        atol=IDENTITY_ATOL,
    )


# ---------------------------------------------------------------------- velocity model
def test_jacobian_at_home_is_the_notes_matrix(cospm: CoSPM) -> None:
    J = cospm.jacobian(*cospm.home())
    np.testing.assert_allclose(J, NOTES_HOME_J, atol=NOTES_ATOL)
    np.testing.assert_allclose(J @ np.ones(3), [0.0, 0.0, -1.0], atol=IDENTITY_ATOL)


def test_check_c_pure_elevation_at_home(cospm: CoSPM) -> None:
    chi_dot = cospm.jacobian(*cospm.home()) @ np.array([-0.5, 0.5, 0.0])
    np.testing.assert_allclose(chi_dot, [0.0, math.sqrt(0.5), 0.0], atol=IDENTITY_ATOL)


def test_common_rotation_only_turns_the_bearing_anywhere(cospm: CoSPM) -> None:
    for theta in _near_home(5, 3):
        chi = cospm.forward_kinematics(theta)
        np.testing.assert_allclose(
            cospm.jacobian(theta, chi) @ np.ones(3), [0.0, 0.0, -1.0], atol=1e-12
        )


def test_jacobian_matches_finite_differences_of_the_fkp(cospm: CoSPM) -> None:
    for theta in _near_home(6, 4):
        chi = cospm.forward_kinematics(theta)
        J = cospm.jacobian(theta, chi)
        fd = np.empty((3, 3))
        for j in range(3):
            e = np.zeros(3)
            e[j] = FD_STEP
            fd[:, j] = (
                cospm.forward_kinematics(theta + e, chi) - cospm.forward_kinematics(theta - e, chi)
            ) / (2 * FD_STEP)
        np.testing.assert_allclose(J, fd, rtol=FD_RTOL, atol=FD_ATOL)


def test_a_and_b_match_finite_differences_of_the_model(cospm: CoSPM) -> None:
    rng = np.random.default_rng(5)
    theta, chi = rng.uniform(-3, 3, 3), rng.uniform(-1.2, 1.2, 3)
    fa = np.empty((3, 3))
    fb = np.empty((3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = FD_STEP
        fa[:, j] = (
            cospm.geometric_model(theta, chi + e) - cospm.geometric_model(theta, chi - e)
        ) / (2 * FD_STEP)
        fb[:, j] = (
            cospm.geometric_model(theta + e, chi) - cospm.geometric_model(theta - e, chi)
        ) / (2 * FD_STEP)
    np.testing.assert_allclose(cospm.A(theta, chi), fa, rtol=FD_RTOL, atol=FD_ATOL)
    np.testing.assert_allclose(cospm.B(theta, chi), fb, rtol=FD_RTOL, atol=FD_ATOL)
    B = cospm.B(theta, chi)
    np.testing.assert_array_equal(B, np.diag(np.diag(B)))


def test_euler_rate_map_gives_the_angular_velocity(cospm: CoSPM) -> None:
    chi = np.array([0.3, -0.7, 1.1])
    chi_dot = np.array([0.2, -0.5, 0.9])

    def rot(c: np.ndarray) -> np.ndarray:
        return _rz(c[2]) @ _ry(c[1]) @ _rx(c[0])

    h = 1e-6
    R_dot = (rot(chi + h * chi_dot) - rot(chi - h * chi_dot)) / (2 * h)
    W = R_dot @ rot(chi).T
    omega = np.array([W[2, 1], W[0, 2], W[1, 0]])
    np.testing.assert_allclose(cospm.E(chi) @ chi_dot, omega, atol=1e-9)
    assert np.linalg.det(cospm.E(chi)) == pytest.approx(math.cos(chi[1]), abs=1e-14)


def test_singularity_indicators_are_consistent(cospm: CoSPM) -> None:
    T = _near_home(8, 6)
    C = cospm.forward_kinematics(T)
    np.testing.assert_allclose(cospm.type1(T, C), np.linalg.det(cospm.B(T, C)), atol=1e-14)
    np.testing.assert_allclose(
        np.asarray(cospm.type2(T, C)) * np.cos(C[:, 1]), np.linalg.det(cospm.A(T, C)), atol=1e-14
    )
    np.testing.assert_allclose(cospm.representation(C), np.cos(C[:, 1]))
    assert isinstance(cospm.type1(T[0], C[0]), float)
    assert cospm.representation(np.array([0.0, HALF_PI, 0.0])) == pytest.approx(0.0, abs=1e-15)


def test_jacobian_refuses_gimbal_lock(cospm: CoSPM) -> None:
    with pytest.raises(InvalidInput, match=r"theta, chi: A = df/dchi is singular .*gimbal lock"):
        cospm.jacobian(np.full(3, HALF_PI), np.array([0.0, HALF_PI, 0.0]))


# ---------------------------------------------------------------------- IKP / FKP
def test_ikp_fkp_round_trips(cospm: CoSPM) -> None:
    T = _near_home(10, 7)
    C = cospm.forward_kinematics(T)
    np.testing.assert_allclose(cospm.geometric_model(T, C), 0.0, atol=IDENTITY_ATOL)
    np.testing.assert_allclose(cospm.inverse_kinematics(C, theta_prev=T), T, atol=ROUND_TRIP_ATOL)
    chi = np.array([0.1, -0.6, 2.5])
    theta = cospm.inverse_kinematics(chi, theta_prev=np.array([-1.0, -1.0, -1.0]))
    np.testing.assert_allclose(cospm.geometric_model(theta, chi), 0.0, atol=IDENTITY_ATOL)
    back = cospm.forward_kinematics(theta, chi + np.array([0.02, -0.02, 0.01]))
    np.testing.assert_allclose(back, chi, atol=ROUND_TRIP_ATOL)


def test_ikp_at_home_and_unwrapping(cospm: CoSPM) -> None:
    np.testing.assert_allclose(cospm.inverse_kinematics(np.zeros(3)), [HALF_PI] * 3, atol=1e-15)
    prev = np.array([HALF_PI + 4 * math.pi, HALF_PI - 2 * math.pi, HALF_PI])
    np.testing.assert_allclose(
        cospm.inverse_kinematics(np.zeros(3), theta_prev=prev), prev, atol=1e-12
    )


def test_ikp_modes_are_branches_of_opposite_b_sign(cospm: CoSPM) -> None:
    chi = np.array([0.1, 0.3, -0.2])
    home = cospm.inverse_kinematics(chi)
    other = cospm.inverse_kinematics(chi, modes=(1, -1, 1))
    np.testing.assert_allclose(cospm.geometric_model(other, chi), 0.0, atol=IDENTITY_ATOL)
    b_home = np.diag(cospm.B(home, chi))
    b_other = np.diag(cospm.B(other, chi))
    assert np.all(b_home > 0)  # mode -1 <=> df_i/dtheta_i > 0 (sigma = +1)
    np.testing.assert_array_equal(np.sign(b_other), [-1.0, 1.0, -1.0])
    assert other[1] == home[1]


def test_home_mode_equals_fkp_continuation_at_the_vertices_of_q_star(cospm: CoSPM) -> None:
    """docs/cospm.md §3: the '-' branch equals the FKP-continuation solutions at Q*'s vertices."""
    for q12 in stops_polygon().corners:
        q3 = (HALF_PI - Q_AUX[0, 2] * q12[0] - Q_AUX[1, 2] * q12[1]) / Q_AUX[2, 2]
        theta = Q_AUX.T @ np.array([q12[0], q12[1], q3])
        chi = cospm.forward_kinematics(theta)
        np.testing.assert_allclose(
            cospm.inverse_kinematics(chi, theta_prev=theta), theta, atol=ROUND_TRIP_ATOL
        )


def test_ikp_out_of_reach_raises_with_leg_and_values(cospm: CoSPM) -> None:
    with pytest.raises(InvalidInput, match=r"out of reach of leg \d: expected \|C_i\| <= R_i"):
        cospm.inverse_kinematics(np.array([60 * DEG, 60 * DEG, 0.0]))
    with pytest.raises(InvalidParameter, match=r"modes: expected three values in \{-1, \+1\}"):
        cospm.inverse_kinematics(np.zeros(3), modes=(1, 0, 1))  # type: ignore[arg-type]


def test_fkp_continuation_options(cospm: CoSPM) -> None:
    theta = np.array([1.0235, 2.1181, 1.5708])  # the reference stop configuration at d4
    chi = cospm.forward_kinematics(theta)
    assert chi[1] == pytest.approx(57.79 * DEG, abs=0.01 * DEG)  # docs/cospm.md §7: +57.79 deg
    # a large common rotation is applied exactly through the invariance
    far = cospm.forward_kinematics(theta + 40.0)
    np.testing.assert_allclose(far, chi - [0.0, 0.0, 40.0], atol=ROUND_TRIP_ATOL)
    # continuation from a given assembly
    theta2 = theta + np.array([0.3, -0.4, 0.2])
    via = cospm.forward_kinematics(theta2, chi, theta0=theta)
    np.testing.assert_allclose(via, cospm.forward_kinematics(theta2), atol=ROUND_TRIP_ATOL)
    # batch == loop
    T = _near_home(4, 8)
    np.testing.assert_allclose(
        cospm.forward_kinematics(T), [cospm.forward_kinematics(t) for t in T], atol=1e-13
    )


def test_fkp_non_convergence_raises(cospm: CoSPM) -> None:
    one_step = CoSPM(fk_max_iter=1)
    with pytest.raises(InvalidInput, match=r"Newton did not converge at theta = .*max \|f\| <="):
        one_step.forward_kinematics(np.array([1.0, 2.0, 1.5]), np.zeros(3))
    with pytest.raises(InvalidParameter, match="theta0: expected together with chi0"):
        cospm.forward_kinematics(np.ones(3), theta0=np.ones(3))


@pytest.mark.parametrize(
    ("theta", "message"),
    [
        (np.array([1.0, np.nan, 1.0]), "theta: expected finite values"),
        (np.ones(4), r"theta: expected shape \(3,\) or \(N, 3\)"),
        ("abc", "theta: expected numbers"),
    ],
)
def test_bad_inputs_raise(cospm: CoSPM, theta: object, message: str) -> None:
    with pytest.raises(InvalidInput, match=message):
        cospm.geometric_model(theta, np.zeros(3))  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=message):
        cospm.forward_kinematics(theta)  # type: ignore[arg-type]


# ---------------------------------------------------------------------- mirror convention
def test_mirror_flips_bank_and_elevation(cospm: CoSPM) -> None:
    mirror = CoSPM(mirror=True)
    assert mirror.mirror
    assert not cospm.mirror
    np.testing.assert_allclose(mirror.home()[0], [HALF_PI] * 3, atol=1e-15)
    T = _near_home(6, 9)
    C = cospm.forward_kinematics(T)
    Cm = mirror.forward_kinematics(T)
    np.testing.assert_allclose(Cm, C * [-1.0, -1.0, 1.0], atol=ROUND_TRIP_ATOL)
    np.testing.assert_allclose(mirror.inverse_kinematics(Cm, theta_prev=T), T, atol=1e-9)
    # Why (cos α2 = 0 for Table 1): f_mirror(θ, χ) = -f(θ, (-χ1, -χ2, χ3)) identically.
    rng = np.random.default_rng(11)
    T, C = rng.uniform(-3, 3, (10, 3)), rng.uniform(-3, 3, (10, 3))
    np.testing.assert_allclose(
        mirror.geometric_model(T, C),
        -cospm.geometric_model(T, C * [-1.0, -1.0, 1.0]),
        atol=IDENTITY_ATOL,
    )


# ---------------------------------------------------------------------- auxiliary map and stops
def test_q_aux_is_eq1_orthogonal_read_only_with_the_invariance_axis() -> None:
    np.testing.assert_allclose(Q_AUX @ Q_AUX.T, np.eye(3), atol=1e-15)
    r2, r3, r6 = math.sqrt(2), math.sqrt(3), math.sqrt(6)
    explicit = [[2 / r6, -1 / r6, -1 / r6], [0, 1 / r2, -1 / r2], [1 / r3, 1 / r3, 1 / r3]]
    np.testing.assert_allclose(Q_AUX, explicit, atol=1e-15)
    np.testing.assert_allclose((r3 / 3) * Q_AUX @ np.ones(3), [0.0, 0.0, 1.0], atol=1e-15)
    with pytest.raises(ValueError, match="read-only"):
        Q_AUX[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        PAPER_STOPS[0, 0] = 1.0


def test_stops_polygon_vertices_and_home_distances_match_the_notes() -> None:
    poly = stops_polygon(PAPER_STOPS)
    assert isinstance(poly, ConvexPolygon)
    S = PAPER_STOPS
    for (i, j), vertex in NOTES_VERTICES.items():
        np.testing.assert_allclose(S[[i, j], :2] @ vertex + S[[i, j], 2], 0.0, atol=1e-4)
        assert np.min(np.abs(poly.corners - vertex).max(axis=1)) < NOTES_ATOL
    # edge k lies on stop k: the polygon's signed distances are the paper's deltas, in order
    np.testing.assert_allclose(poly.signed_distances([0.0, 0.0]), NOTES_HOME_DELTAS, atol=1e-5)


def test_stops_polygon_rejects_bad_stops() -> None:
    with pytest.raises(InvalidGeometry, match=r"stops: expected shape \(m, 3\)"):
        stops_polygon(PAPER_STOPS[:, :2])
    with pytest.raises(InvalidGeometry, match="do not bound"):
        stops_polygon([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [1.0, 1.0, 1.0]])
    with pytest.raises(InvalidGeometry, match=r"half-plane\(s\) \[4\]"):
        stops_polygon(np.vstack([PAPER_STOPS, [0.0, 1.0, 10.0]]))  # redundant: never an edge
    with pytest.raises(InvalidGeometry, match="stops: expected finite"):
        stops_polygon(np.where(PAPER_STOPS == 1.0, np.inf, PAPER_STOPS))


# ---------------------------------------------------------------------- region validation
@pytest.fixture(scope="module")
def paper_report(cospm: CoSPM) -> RegionReport:
    return validate_region(cospm, PAPER_STOPS, step=0.02)


def test_checks_d_and_e_on_the_notes_grid(paper_report: RegionReport) -> None:
    """docs/cospm.md §7: the flood-fill grid of Q* at step 0.02 and its numbers."""
    r = paper_report
    assert r.n_points == 3651
    assert r.n_failed == 0
    assert (r.sign_det_a, r.sign_det_b) == (-1, 1)
    assert r.leg_modes_constant
    assert r.min_abs_det_a == pytest.approx(0.164, abs=5e-4)
    assert r.min_abs_det_b == pytest.approx(0.0433, abs=5e-5)
    assert r.min_abs_type2 == pytest.approx(0.306, abs=5e-4)
    np.testing.assert_allclose(np.degrees(r.bank_range), [-34.8, 34.0], atol=0.05)
    np.testing.assert_allclose(np.degrees(r.elevation_range), [-55.9, 57.5], atol=0.05)
    assert r.workspace_included
    assert r.workspace_margin > 0
    assert r.ok
    # "about [-54.7, 53.1], [-55.9, 57.7] and [-54.6, 53.2] deg" (grid-read); ours are exact
    notes = [(-10, -54.7, 53.1), (0, -55.9, 57.7), (10, -54.6, 53.2)]
    for (b, lo, hi), (nb, nlo, nhi) in zip(r.elevation_at_bank, notes, strict=True):
        assert math.degrees(b) == pytest.approx(nb)
        assert math.degrees(lo) == pytest.approx(nlo, abs=0.15)
        assert math.degrees(hi) == pytest.approx(nhi, abs=0.15)


def test_validate_region_coarse_grid_is_regular_and_dextrous(cospm: CoSPM) -> None:
    r = validate_region(cospm, PAPER_STOPS, step=0.1)
    assert r.ok
    assert r.n_failed == 0
    assert (r.sign_det_a, r.sign_det_b) == (-1, 1)
    assert np.all(r.det_a < 0)
    assert np.all(r.det_b > 0)
    assert r.workspace == PAPER_WORKSPACE
    assert r.q.shape == (r.n_points, 2)
    assert r.chi.shape == (r.n_points, 3)
    np.testing.assert_allclose(cospm.geometric_model(r.theta, r.chi), 0.0, atol=1e-12)
    np.testing.assert_allclose(r.theta[:, 2], HALF_PI, atol=1e-12)  # "immobilize the 3rd leg"


def test_q3_choice_changes_only_the_bearing(cospm: CoSPM) -> None:
    a = validate_region(cospm, step=0.1)
    b = validate_region(cospm, step=0.1, theta3=None)
    assert b.theta3 is None
    np.testing.assert_allclose(b.chi[:, :2], a.chi[:, :2], atol=1e-12)
    np.testing.assert_allclose(b.det_a, a.det_a, atol=1e-12)
    np.testing.assert_allclose(b.det_b, a.det_b, atol=1e-12)
    assert np.max(np.abs(b.chi[:, 2] - a.chi[:, 2])) > 0.1


@pytest.mark.parametrize("shift", [5.0, -5.0])
def test_check_d_inclusion_is_tight(cospm: CoSPM, shift: float) -> None:
    """docs/cospm.md §2 (d): shifting W*'s elevation by ±5 deg breaks the inclusion."""
    lo_b, hi_b, lo_e, hi_e = PAPER_WORKSPACE
    r = validate_region(
        cospm, step=0.1, workspace=(lo_b, hi_b, lo_e + shift * DEG, hi_e + shift * DEG), banks=()
    )
    assert not r.workspace_included
    assert r.workspace_margin < 0
    assert not r.ok


def test_validate_region_detects_a_region_crossing_a_singularity(cospm: CoSPM) -> None:
    # Push stop d4 outwards by 1 rad: the region then crosses a Type-1 curve (det B = 0).
    stops = PAPER_STOPS.copy()
    stops[3, 2] += 1.0
    r = validate_region(cospm, stops, step=0.05, banks=())
    assert r.sign_det_b == 0
    assert not r.leg_modes_constant
    assert not r.ok


def test_mirror_region_is_equally_valid() -> None:
    r = validate_region(CoSPM(mirror=True), step=0.1, banks=())
    assert r.ok


def test_validate_region_rejects_bad_options(cospm: CoSPM) -> None:
    with pytest.raises(InvalidParameter, match="step must be finite and > 0"):
        validate_region(cospm, step=0.0)
    with pytest.raises(InvalidParameter, match="workspace: expected"):
        validate_region(cospm, workspace=(1.0, 0.0, 0.0, 1.0))
    with pytest.raises(InvalidParameter, match="cospm: expected a CoSPM"):
        validate_region("x")  # type: ignore[arg-type]


def test_singular_curves_grid(cospm: CoSPM) -> None:
    g = singular_curves(cospm, window=(-1.6, 2.4, -1.8, 1.4), step=0.1)
    assert g.det_a.shape == (g.q2.size, g.q1.size) == g.reached.shape
    i0, j0 = int(np.argmin(np.abs(g.q2))), int(np.argmin(np.abs(g.q1)))
    assert g.reached[i0, j0]
    assert g.det_a[i0, j0] == pytest.approx(float(np.linalg.det(cospm.A(*cospm.home()))))
    # Type-1 curves cross the window: det B changes sign on the leaf; det[v×w] keeps its sign
    assert np.nanmin(g.det_b) < 0 < np.nanmax(g.det_b)
    assert np.all(g.type2[g.reached] < 0)
    assert np.all(np.isnan(g.det_a[~g.reached]))
    # Q* lies inside the central cell where det B > 0
    for q in stops_polygon().corners:
        i, j = int(np.argmin(np.abs(g.q2 - q[1]))), int(np.argmin(np.abs(g.q1 - q[0])))
        assert g.det_b[i, j] > 0
    with pytest.raises(InvalidParameter, match="window: expected"):
        singular_curves(cospm, window=(0.5, 1.0, 0.5, 1.0))


def test_workspace_map_is_fig3b(cospm: CoSPM) -> None:
    m = workspace_map(cospm, bank=(-80 * DEG, 80 * DEG))
    assert m.q.shape == (m.elevation.size, m.bank.size, 2)
    # home working mode: every leg's B_ii > 0, so det B > 0 inside; the edge is Type-1
    assert np.all(m.det_b[m.reachable] > 0)
    assert not m.reachable.all()
    # no Type-2 singularity in the home working mode (the leaf the paper certifies)
    assert np.all(m.type2[m.reachable] < 0)
    # FKP(Q*) = {stop_margin >= 0} contains W* and matches the grid's bank/elevation spans
    bank, elev = np.meshgrid(m.bank, m.elevation)
    lo_b, hi_b, lo_e, hi_e = np.array(PAPER_WORKSPACE) + 1e-9 * np.array([-1, 1, -1, 1])
    in_ws = (bank >= lo_b) & (bank <= hi_b) & (elev >= lo_e) & (elev <= hi_e)
    assert np.all(m.stop_margin[in_ws] > 0)
    inside = m.stop_margin >= 0
    assert math.degrees(bank[inside].min()) == pytest.approx(-34.0)
    assert math.degrees(elev[inside].max()) == pytest.approx(57.0)
    # the IKP samples are on the FKP leaf from home (same chi by continuation)
    rng = np.random.default_rng(10)
    ii, jj = np.nonzero(inside)
    for k in rng.choice(ii.size, 5, replace=False):
        i, j = ii[k], jj[k]
        chi = cospm.forward_kinematics(m.theta[i, j])
        np.testing.assert_allclose(chi, [m.bank[j], m.elevation[i], 0.0], atol=ROUND_TRIP_ATOL)
    with pytest.raises(InvalidParameter, match=r"elevation: expected a range inside"):
        workspace_map(cospm, elevation=(-HALF_PI, 0.0))
    with pytest.raises(InvalidParameter, match="bank: expected"):
        workspace_map(cospm, bank=(1.0, 0.0))


def test_unbounded_stops_are_named():
    bad = np.tile([1.0, 1.0, 1.0], (4, 1))
    with pytest.raises(InvalidGeometry, match=r"^stops: "):
        stops_polygon(bad)


def test_singular_curves_window_must_be_four_numbers():
    with pytest.raises(InvalidParameter, match=r"window: expected shape \(4,\)"):
        singular_curves(window=[[-0.2, 0.2, -0.2, 0.2]], step=0.1)
