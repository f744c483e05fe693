"""Tests of the PUMA 560 of Khokar 2009 (velfence.mechanisms.puma560).

Every expected value comes from a route independent of the implementation: the thesis's printed
FK formulas (eqs. 11-22), a product of exponentials from the screw axes at q = 0 (derived by hand
below), the printed Craig Table 2 multiplied out with modified-DH link matrices, central
differences, the closed-form PUMA Jacobian determinant, and the numbers the thesis prints.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.mechanisms.chain import DHChain
from velfence.mechanisms.puma560 import CONFIGURATIONS, CRAIG_TABLE2, Puma560

A2, A3, D3, D4 = 0.4318, -0.0203, 0.15, 0.4331  # [m], Khokar 2009 eqs. 11-22 (FGL, as implemented)
POSE_ATOL = 1e-12  # FK vs independent closed forms
IK_ATOL = 1e-9  # fk(ik(T)) vs T
FD_STEP = 1e-6  # [rad]
JAC_ATOL = 1e-8  # central differences vs analytic Jacobian

RECORDED_Q = np.array(
    [  # Khokar 2009 §7.1 final and §7.4 initial joint angles [rad]
        [-1.68307, -3.10591, 0.79649, -0.51276, -0.58633, 0.09572],
        [-1.18062, -3.11768, 0.56893, 0.99229, -0.48414, -0.42776],
        [-1.44424, -2.85717, 0.36547, -0.34528, -0.47725, -0.09663],
        [-1.37229, -2.27639, -0.01268, 0.01852, -1.53292, 0.27288],
    ]
)


# --------------------------------------------------------------------------------------------
# Independent routes
# --------------------------------------------------------------------------------------------
def printed_fk(q: np.ndarray, d6: float = 0.0) -> np.ndarray:
    """Thesis eqs. 11-22 (noap0..noap11), typed from the thesis."""
    c1, s1 = math.cos(q[0]), math.sin(q[0])
    c4, s4 = math.cos(q[3]), math.sin(q[3])
    c5, s5 = math.cos(q[4]), math.sin(q[4])
    c6, s6 = math.cos(q[5]), math.sin(q[5])
    c2, s2 = math.cos(q[1]), math.sin(q[1])
    c23, s23 = math.cos(q[1] + q[2]), math.sin(q[1] + q[2])
    n = [
        (-c1 * c23 * s4 - s1 * c4) * s6 + ((c1 * c23 * c4 - s1 * s4) * c5 - c1 * s23 * s5) * c6,
        (c1 * c4 - s1 * c23 * s4) * s6 + ((c1 * s4 + s1 * c23 * c4) * c5 - s1 * s23 * s5) * c6,
        s23 * s4 * s6 + (-c23 * s5 - s23 * c4 * c5) * c6,
    ]
    o = [
        (c1 * s23 * s5 + (s1 * s4 - c1 * c23 * c4) * c5) * s6 + (-c1 * c23 * s4 - s1 * c4) * c6,
        (s1 * s23 * s5 + (-c1 * s4 - s1 * c23 * c4) * c5) * s6 + (c1 * c4 - s1 * c23 * s4) * c6,
        (c23 * s5 + s23 * c4 * c5) * s6 + s23 * s4 * c6,
    ]
    a = [
        (c1 * c23 * c4 - s1 * s4) * s5 + c1 * s23 * c5,
        (c1 * s4 + s1 * c23 * c4) * s5 + s1 * s23 * c5,
        c23 * c5 - s23 * c4 * s5,
    ]
    p = [
        a[0] * d6 + c1 * s23 * D4 - s1 * D3 + c1 * c23 * A3 + c1 * c2 * A2,
        a[1] * d6 + s1 * s23 * D4 + c1 * D3 + s1 * c23 * A3 + s1 * c2 * A2,
        a[2] * d6 + c23 * D4 - s23 * A3 - s2 * A2,
    ]
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = n, o, a, p
    return T


def rodrigues(w: np.ndarray, th: float) -> np.ndarray:
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return np.eye(3) + math.sin(th) * K + (1 - math.cos(th)) * K @ K


def screw_exp(w: np.ndarray, point: np.ndarray, th: float) -> np.ndarray:
    """Rotation by th about the line through ``point`` with direction ``w``."""
    T = np.eye(4)
    R = rodrigues(w, th)
    T[:3, :3] = R
    T[:3, 3] = point - R @ point
    return T


# Home geometry (q = 0) worked out by hand from the FGL table: upper arm along +x, forearm up.
X, Y, Z = np.eye(3)
WRIST_HOME = np.array([A2 + A3, D3, D4])
HOME_SCREWS = (
    (Z, np.zeros(3)),
    (Y, np.zeros(3)),
    (Y, np.array([A2, D3, 0.0])),
    (Z, np.array([A2 + A3, D3, 0.0])),
    (Y, WRIST_HOME),
    (Z, WRIST_HOME),
)


def poe_fk(q: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    for (w, point), th in zip(HOME_SCREWS, q, strict=True):
        T = T @ screw_exp(w, point, th)
    M = np.eye(4)
    M[:3, 3] = WRIST_HOME
    return T @ M


def craig_fk(q: np.ndarray) -> np.ndarray:
    """Thesis Table 2 multiplied out with Craig's modified-DH link matrix (eq. 2, corrected)."""
    rows = [(0, 0, 0), (-90, 0, 0), (0, 0.4318, 0.15), (-90, 0.0203, 0.4331), (90, 0, 0)]
    rows.append((-90, 0, 0))
    T = np.eye(4)
    for (alpha_deg, a, d), th in zip(rows, q, strict=True):
        al = math.radians(alpha_deg)
        ct, st_ = math.cos(th), math.sin(th)
        ca, sa = math.cos(al), math.sin(al)
        A = np.array(
            [
                [ct, -st_, 0, a],
                [st_ * ca, ct * ca, -sa, -sa * d],
                [st_ * sa, ct * sa, ca, ca * d],
                [0, 0, 0, 1],
            ]
        )
        T = T @ A
    return T


def rot(axis: np.ndarray, th: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = rodrigues(axis / np.linalg.norm(axis), th)
    return T


def jacobian_fd(robot: Puma560, q: np.ndarray) -> np.ndarray:
    J = np.zeros((6, 6))
    for i in range(6):
        dq = np.zeros(6)
        dq[i] = FD_STEP
        Tp, Tm = robot.fk(q + dq), robot.fk(q - dq)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * FD_STEP)
        Rdot = (Tp[:3, :3] - Tm[:3, :3]) / (2 * FD_STEP)
        W = Rdot @ robot.fk(q)[:3, :3].T  # skew(ω)
        J[3:, i] = (W[2, 1], W[0, 2], W[1, 0])
    return J


def random_qs(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-math.pi, math.pi, size=(n, 6))


def well_conditioned(q: np.ndarray) -> bool:
    """Away from the shoulder, elbow and wrist singularities (labels well defined)."""
    c2, c3, s3 = math.cos(q[1]), math.cos(q[2]), math.sin(q[2])
    c23, s23 = math.cos(q[1] + q[2]), math.sin(q[1] + q[2])
    r = A2 * c2 + A3 * c23 + D4 * s23
    return abs(r) > 1e-3 and abs(D4 * c3 - A3 * s3) > 1e-3 and abs(math.sin(q[4])) > 1e-3


E3_PI = np.array([0, 0, math.pi, 0, 0, 0])  # Craig's joint-3 offset
TOOL = rot(np.array([0.3, -0.5, 0.8]), 0.7)
TOOL[:3, 3] = (0.02, -0.03, 0.23)


# --------------------------------------------------------------------------------------------
# Forward kinematics
# --------------------------------------------------------------------------------------------
def test_fk_matches_printed_eqs_11_22() -> None:
    robot = Puma560()
    for q in np.vstack([random_qs(200, 1), RECORDED_Q]):
        np.testing.assert_allclose(robot.fk(q), printed_fk(q), atol=POSE_ATOL)


def test_fk_matches_product_of_exponentials() -> None:
    robot = Puma560()
    for q in random_qs(200, 2):
        np.testing.assert_allclose(robot.fk(q), poe_fk(q), atol=POSE_ATOL)


def test_fk_home_pose_by_hand() -> None:
    T = Puma560().fk(np.zeros(6))
    np.testing.assert_allclose(T[:3, :3], np.eye(3), atol=POSE_ATOL)
    np.testing.assert_allclose(T[:3, 3], (0.4115, 0.15, 0.4331), atol=POSE_ATOL)


def test_position_is_translation_and_tool_composes() -> None:
    plain, tooled = Puma560(), Puma560(tool=TOOL)
    for q in random_qs(50, 3):
        np.testing.assert_allclose(tooled.fk(q), plain.fk(q) @ TOOL, atol=POSE_ATOL)
        np.testing.assert_allclose(tooled.position(q), (plain.fk(q) @ TOOL)[:3, 3], atol=1e-12)
    d6 = 0.23  # a pure translation along z6 is the thesis's d6
    robot = Puma560(tool=(0.0, 0.0, d6))
    q = RECORDED_Q[0]
    np.testing.assert_allclose(robot.fk(q), printed_fk(q, d6=d6), atol=POSE_ATOL)


def test_fk_reproduces_recorded_end_points() -> None:
    # Khokar 2009: FK of the §7.1 destinations vs the means of Tables 4/5: 0.2 mm and 1.3 mm.
    robot = Puma560()
    table4_mean = np.array([0.23149, 0.71659, -0.29119])
    table5_mean = np.array([-0.11033, 0.66371, -0.35949])
    assert np.linalg.norm(robot.position(RECORDED_Q[0]) - table4_mean) < 0.5e-3
    assert np.linalg.norm(robot.position(RECORDED_Q[1]) - table5_mean) < 1.5e-3
    # ... and the printed a3 = +0.0203 misses by 41 mm (telerobotics.md §8, T1): the sign matters.
    wrong_dh = [
        [0, -math.pi / 2, 0, 0],
        [A2, 0, D3, 0],
        [-A3, math.pi / 2, 0, 0],
        [0, -math.pi / 2, D4, 0],
        [0, math.pi / 2, 0, 0],
        [0, 0, 0, 0],
    ]
    wrong = DHChain(wrong_dh)
    assert np.linalg.norm(wrong.end_effector(RECORDED_Q[0]) - table4_mean) > 0.02


def test_craig_convention_is_printed_table2() -> None:
    robot = Puma560(convention="craig")
    for q in random_qs(200, 4):
        np.testing.assert_allclose(robot.fk(q), craig_fk(q), atol=POSE_ATOL)


def test_craig_and_fu_relation() -> None:
    # T_fu(q) = T_craig(q + π e3) Rz(π): the same arm (docs/telerobotics.md §8, T2).
    fu, craig = Puma560(), Puma560(convention="craig")
    Rz_pi = rot(Z, math.pi)
    for q in random_qs(100, 5):
        qc = q + E3_PI
        np.testing.assert_allclose(fu.fk(q), craig.fk(qc) @ Rz_pi, atol=POSE_ATOL)
        np.testing.assert_allclose(fu.jacobian(q), craig.jacobian(qc), atol=1e-12)
        np.testing.assert_allclose(
            craig.chain.joint_positions(qc), fu.chain.joint_positions(q), atol=1e-12
        )
    # The laser offset (-0.026, -0.115, 0.115) in the fu tool frame reads (+0.026, +0.115, 0.115)
    # in the craig tool frame: the spot is the same point in space.
    laser_fu = Puma560(tool=(-0.026, -0.115, 0.115))
    laser_craig = Puma560(convention="craig", tool=(0.026, 0.115, 0.115))
    q = RECORDED_Q[0]
    np.testing.assert_allclose(laser_fu.position(q), laser_craig.position(q + E3_PI), atol=1e-12)


def test_craig_table_constant_matches_thesis() -> None:
    assert CRAIG_TABLE2.shape == (6, 3)
    np.testing.assert_allclose(CRAIG_TABLE2[:, 0], (0, -90, 0, -90, 90, -90))
    np.testing.assert_allclose(CRAIG_TABLE2[2:4, 1:], [[0.4318, 0.15], [0.0203, 0.4331]])
    with pytest.raises(ValueError, match="read-only"):
        CRAIG_TABLE2[0, 0] = 1.0


@pytest.mark.parametrize("convention", ["fu", "craig"])
def test_chain_reuses_dh_and_tool_point(convention: str) -> None:
    robot = Puma560(convention=convention, tool=TOOL)
    assert isinstance(robot.chain, DHChain)
    expected = np.array(DHChain.puma560().dh)
    if convention == "craig":
        expected[2, 3] -= math.pi  # accepts Craig's θ3 = θ3(fu) + π
    np.testing.assert_allclose(robot.chain.dh, expected)
    for q in random_qs(20, 6):
        np.testing.assert_allclose(robot.chain.end_effector(q), robot.position(q), atol=1e-12)
        np.testing.assert_allclose(robot.chain.ee_jacobian(q), robot.jacobian(q)[:3], atol=1e-12)


# --------------------------------------------------------------------------------------------
# Jacobian and manipulability
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "robot",
    [Puma560(), Puma560(tool=TOOL), Puma560(convention="craig", tool=TOOL)],
    ids=["fu", "fu-tool", "craig-tool"],
)
def test_jacobian_matches_central_differences(robot: Puma560) -> None:
    for q in np.vstack([random_qs(30, 7), RECORDED_Q]):
        J = robot.jacobian(q)
        fd = jacobian_fd(robot, q)
        np.testing.assert_allclose(J[:3], fd[:3], atol=JAC_ATOL)  # linear [m/rad]
        np.testing.assert_allclose(J[3:], fd[3:], atol=JAC_ATOL)  # angular


def test_manipulability_closed_form_and_yoshikawa() -> None:
    for robot in (Puma560(), Puma560(tool=TOOL)):
        for q in np.vstack([random_qs(100, 8), RECORDED_Q]):
            c2, c3, s3 = math.cos(q[1]), math.cos(q[2]), math.sin(q[2])
            c23, s23 = math.cos(q[1] + q[2]), math.sin(q[1] + q[2])
            closed = abs(
                A2 * (D4 * c3 - A3 * s3) * (A2 * c2 + A3 * c23 + D4 * s23) * math.sin(q[4])
            )
            J = jacobian_fd(robot, q)
            yoshikawa = math.sqrt(max(np.linalg.det(J @ J.T), 0.0))
            w = robot.manipulability(q)
            assert w == pytest.approx(closed, abs=1e-12)
            assert w == pytest.approx(yoshikawa, abs=1e-7)


def test_manipulability_at_thesis_trajectory_1_start() -> None:
    # Khokar 2009 §5.4, §7.4: w = 0.054 at the start of §7.4 trajectory 1 (w0 = 0.014).
    assert Puma560().manipulability(RECORDED_Q[2]) == pytest.approx(0.054, abs=5e-4)


def test_manipulability_zero_at_singularities() -> None:
    robot = Puma560()
    q = RECORDED_Q[0].copy()
    q[4] = 0.0  # wrist
    assert robot.manipulability(q) < 1e-15
    q = RECORDED_Q[0].copy()
    q[2] = math.atan2(D4, A3)  # d4 c3 - a3 s3 = 0: elbow stretched
    assert robot.manipulability(q) < 1e-15


# --------------------------------------------------------------------------------------------
# Inverse kinematics
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("convention", ["fu", "craig"])
@pytest.mark.parametrize("tool", [None, TOOL], ids=["no-tool", "tool"])
def test_ik_all_branches_round_trip(convention: str, tool: np.ndarray | None) -> None:
    robot = Puma560(convention=convention, tool=tool)
    n_checked = 0
    for q in random_qs(150, 9):
        if not well_conditioned(q):
            continue
        T = robot.fk(q)
        sols = robot.ik_all(T)
        assert list(sols) == list(CONFIGURATIONS)  # a generic reachable pose has all 8
        for labels, qs in sols.items():
            np.testing.assert_allclose(robot.fk(qs), T, atol=IK_ATOL)
            assert robot.configuration(qs) == labels
            s, e, w = labels
            np.testing.assert_allclose(robot.ik(T, shoulder=s, elbow=e, wrist=w), qs)
        # The branch q itself belongs to gives back q (mod 2π).
        s, e, w = robot.configuration(q)
        back = robot.ik(T, shoulder=s, elbow=e, wrist=w)
        np.testing.assert_allclose(np.cos(back - q), 1.0, atol=1e-9)
        np.testing.assert_allclose(np.sin(back - q), 0.0, atol=1e-9)
        n_checked += 1
    assert n_checked > 100


@given(q=st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6))
def test_ik_round_trip_property(q: list[float]) -> None:
    qa = np.array(q)
    robot = Puma560()
    if not well_conditioned(qa):
        return
    T = robot.fk(qa)
    for s, e, w in CONFIGURATIONS:
        qs = robot.ik(T, shoulder=s, elbow=e, wrist=w)
        np.testing.assert_allclose(robot.fk(qs), T, atol=IK_ATOL)
        assert robot.configuration(qs) == (s, e, w)


def test_eight_branches_are_distinct() -> None:
    robot = Puma560()
    sols = robot.ik_all(robot.fk(RECORDED_Q[0]))
    qs = np.array(list(sols.values()))
    d = np.abs(np.angle(np.exp(1j * (qs[:, None] - qs[None]))))
    dist = d.sum(axis=2) + np.eye(8) * 10
    assert dist.min() > 0.1


def test_recorded_poses_are_default_branch_and_recovered_exactly() -> None:
    robot = Puma560()
    for q in RECORDED_Q:
        assert robot.configuration(q) == ("right", "up", "noflip")
        assert robot.within_limits(q)
        np.testing.assert_allclose(robot.ik(robot.fk(q)), q, atol=1e-12)


def test_configuration_labels_by_hand() -> None:
    robot = Puma560()
    # Home: r = a2 + a3 > 0 -> left (FGL ARM = -1); d4 c3 - a3 s3 = d4 > 0 -> ELBOW = -1: down.
    assert robot.configuration(np.zeros(6)) == ("left", "down", "noflip")
    assert robot.configuration([0, 0, 0, 0, 0.3, 0]) == ("left", "down", "flip")
    # q2 = π turns the upper arm backwards: r = -(a2 + a3) < 0 -> right, and up.
    assert robot.configuration([0, math.pi, 0, 0, -0.3, 0]) == ("right", "up", "noflip")


def test_ik_wrist_singular_pose() -> None:
    robot = Puma560()
    q = np.array([0.3, -2.5, 0.6, 0.4, 0.0, -0.2])
    T = robot.fk(q)
    for labels in CONFIGURATIONS:
        s, e, w = labels
        qs = robot.ik(T, shoulder=s, elbow=e, wrist=w)
        np.testing.assert_allclose(robot.fk(qs), T, atol=IK_ATOL)
    qs = robot.ik(T)
    assert qs[4] == pytest.approx(0.0, abs=1e-9)
    assert qs[3] + qs[5] == pytest.approx(0.2, abs=1e-9)


def test_ik_respects_limits_and_nearest() -> None:
    robot = Puma560()
    q = RECORDED_Q[1]
    T = robot.fk(q)
    within = robot.ik_all(T, respect_limits=True)
    assert within
    assert all(robot.within_limits(v) for v in within.values())
    assert len(within) < 8  # the thesis's stops exclude some branches here
    excluded = next(k for k in CONFIGURATIONS if k not in within)
    with pytest.raises(InvalidInput, match=r"outside .* try another branch"):
        robot.ik(T, shoulder=excluded[0], elbow=excluded[1], wrist=excluded[2], respect_limits=True)
    np.testing.assert_allclose(robot.ik_nearest(T, q + 0.05), q, atol=1e-12)


def test_ik_angles_fit_inside_limits() -> None:
    # θ2 ≈ -178° needs the 2π-equivalent inside (-225°, 45°), not the wrapped +182°.
    robot = Puma560()
    q = np.array([0.2, math.radians(-200.0), 0.5, 0.1, -0.4, 0.3])
    qs = robot.ik(robot.fk(q), shoulder="right", elbow="up", wrist="noflip")
    np.testing.assert_allclose(qs, q, atol=1e-12)


# --------------------------------------------------------------------------------------------
# Errors and parameters
# --------------------------------------------------------------------------------------------
def test_unreachable_pose_names_distance_and_reach() -> None:
    robot = Puma560()
    T = np.eye(4)
    T[:3, 3] = (1.0, 0.3, 0.2)
    with pytest.raises(InvalidInput, match=r"distance 1\.0\d* m .* reach 0\.878") as exc:
        robot.ik(T)
    assert "allowed [" in str(exc.value)
    with pytest.raises(InvalidInput, match="reach"):
        robot.ik_all(T)
    T[:3, 3] = (0.05, 0.05, 0.2)  # inside the shoulder-offset cylinder
    with pytest.raises(InvalidInput, match=r"at least d3 = 0\.15 m .* got 0\.0707"):
        robot.ik(T)
    assert robot.reach == pytest.approx(math.hypot(A2 + math.hypot(A3, D4), D3))


def test_boundary_pose_is_reachable() -> None:
    robot = Puma560()
    q = np.array([0.4, -1.0, math.atan2(D4, A3), 0.2, -0.5, 0.1])  # elbow fully stretched
    T = robot.fk(q)
    qs = robot.ik(T)
    np.testing.assert_allclose(robot.fk(qs), T, atol=1e-7)


@pytest.mark.parametrize(
    ("T", "match"),
    [
        (np.full((4, 4), np.nan), "finite"),
        (np.eye(3), r"shape \(4, 4\)"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "rigid"),
        (np.diag([2.0, 1.0, 1.0, 1.0]), "rigid"),
        ("pose", "homogeneous transform"),
    ],
)
def test_bad_pose_rejected(T: object, match: str) -> None:
    with pytest.raises(InvalidInput, match=match):
        Puma560().ik(T)  # type: ignore[arg-type]


@pytest.mark.parametrize("method", ["fk", "position", "jacobian", "manipulability"])
def test_bad_joint_vector_rejected(method: str) -> None:
    robot = Puma560()
    with pytest.raises(InvalidInput, match="finite"):
        getattr(robot, method)([0, 0, np.inf, 0, 0, 0])
    with pytest.raises(InvalidInput, match="shape"):
        getattr(robot, method)(np.zeros(5))
    with pytest.raises(InvalidInput, match="finite"):
        robot.configuration([0, 0, np.nan, 0, 0, 0])


def test_parameter_validation() -> None:
    with pytest.raises(InvalidParameter, match=r"convention must be one of \['fu', 'craig'\]"):
        Puma560(convention="paul")
    with pytest.raises(InvalidParameter, match=r"elbow must be one of \['up', 'down'\]"):
        Puma560().ik(np.eye(4), elbow="middle")
    with pytest.raises(
        InvalidParameter, match=r"shoulder must be one of \[.right., .left.\], got .RIGHT."
    ):
        Puma560().ik(np.eye(4), shoulder="RIGHT")
    with pytest.raises(
        InvalidParameter, match=r"wrist must be one of \[.noflip., .flip.\], got .up."
    ):
        Puma560().ik(np.eye(4), wrist="up")
    with pytest.raises(InvalidGeometry, match="rigid"):
        Puma560(tool=np.diag([1.0, 2.0, 1.0, 1.0]))
    with pytest.raises(InvalidGeometry, match=r"shape \(3,\)"):
        Puma560(tool=(1.0, 2.0))
    with pytest.raises(InvalidGeometry, match="finite"):
        Puma560(tool=(1.0, np.nan, 0.0))
    with pytest.raises(InvalidParameter, match="joint_limits"):
        Puma560(joint_limits=np.zeros((6, 2)))


def test_joint_limits_defaults_and_override() -> None:
    fu, craig = Puma560(), Puma560(convention="craig")
    np.testing.assert_allclose(fu.joint_limits, DHChain.puma560().joint_limits)
    np.testing.assert_allclose(craig.joint_limits[2], np.radians([-45.0, 225.0]) + math.pi)
    custom = np.tile([-1.0, 1.0], (6, 1))
    robot = Puma560(joint_limits=custom)
    np.testing.assert_allclose(robot.joint_limits, custom)
    assert robot.within_limits(np.full(6, 0.9))
    assert not robot.within_limits(np.full(6, 1.05))
    assert robot.within_limits(np.full(6, 1.05), tol=0.1)
    with pytest.raises(ValueError, match="read-only"):
        robot.joint_limits[0, 0] = 0.0
    np.testing.assert_allclose(Puma560(tool=(0, 0, 0.1)).tool[:3, 3], (0, 0, 0.1))
    assert fu.convention == "fu"
    assert craig.convention == "craig"
