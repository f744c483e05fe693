"""Tests of serial chains (velfence.mechanisms.chain): FK, point Jacobians, presets, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.mechanisms.chain import DHChain, PlanarArm, SerialChain

FK_ATOL = 1e-12  # [m], closed-form FK vs ours
JAC_RTOL = 1e-6  # Jacobian vs central differences
JAC_ATOL = 1e-9  # [m/rad], for entries that pass through zero
FD_STEP = 1e-6  # [rad]
THESIS_ATOL = 5e-5  # [m], FK vs reference values printed to 0.1 mm

# Khokar 2009 §7.1 recorded final joint angles and their FK end points from eqs. 11-22.
THESIS_POSES = (
    ((-1.68307, -3.10591, 0.79649, -0.51276, -0.58633, 0.09572), (0.2317, 0.7166, -0.2912)),
    ((-1.18062, -3.11768, 0.56893, 0.99229, -0.48414, -0.42776), (-0.1111, 0.6645, -0.3602)),
)


def chains() -> list[SerialChain]:
    return [
        PlanarArm.three_r(),
        PlanarArm((0.5, 0.8, 0.3, 0.6), base=(0.2, -0.1)),
        DHChain.puma560(),
        DHChain.puma560(tool=(0.01, -0.02, 0.1)),
        DHChain.seven_dof(),
        DHChain([[0.3, 0.4, 0.1, 0.2], [0.2, -1.0, 0.3, -0.5], [0.1, 0.7, 0.05, 1.0]]),
    ]


CHAIN_IDS = ["3r", "4r-base", "puma", "puma-tool", "iiwa", "random-dh"]


def point_fd(chain: SerialChain, q: np.ndarray, link: int, t: float) -> np.ndarray:
    """Central differences of the point at fraction t along `link`, shape (3, n)."""

    def point(qq: np.ndarray) -> np.ndarray:
        seg = chain.link_segments(qq)[link]
        p: np.ndarray = (1.0 - t) * seg[0] + t * seg[1]
        return p

    J = np.empty((3, chain.dof))
    for j in range(chain.dof):
        e = np.zeros(chain.dof)
        e[j] = FD_STEP
        J[:, j] = (point(q + e) - point(q - e)) / (2.0 * FD_STEP)
    return J


def dh_transform(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """Standard DH A_i as the product Rz(theta) Tz(d) Tx(a) Rx(alpha), built independently."""
    c, s = math.cos(theta), math.sin(theta)
    Rz = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)
    Tz = np.eye(4)
    Tz[2, 3] = d
    Tx = np.eye(4)
    Tx[0, 3] = a
    ca, sa = math.cos(alpha), math.sin(alpha)
    Rx = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1]], dtype=float)
    A: np.ndarray = Rz @ Tz @ Tx @ Rx
    return A


def puma_fgl_position(q: np.ndarray) -> np.ndarray:
    """Khokar 2009 eqs. 20-22 (telerobotics.md §8, T1): a2, a3, d3, d4 = 0.4318, -0.0203, ..."""
    a2, a3, d3, d4 = 0.4318, -0.0203, 0.15, 0.4331
    c1, s1 = math.cos(q[0]), math.sin(q[0])
    c2, s2 = math.cos(q[1]), math.sin(q[1])
    c23, s23 = math.cos(q[1] + q[2]), math.sin(q[1] + q[2])
    return np.array(
        [
            c1 * s23 * d4 - s1 * d3 + c1 * c23 * a3 + c1 * c2 * a2,
            s1 * s23 * d4 + c1 * d3 + s1 * c23 * a3 + s1 * c2 * a2,
            c23 * d4 - s23 * a3 - s2 * a2,
        ]
    )


# ------------------------------------------------------------------ planar FK
def test_planar_3r_fk_hand_computed() -> None:
    arm = PlanarArm((1.0, 2.0, 0.5), base=(1.0, -1.0))
    q = np.array([math.pi / 2, -math.pi / 2, math.pi / 4])
    # φ = (90°, 0°, 45°): P1 = base + (0, 1), P2 = P1 + (2, 0), P3 = P2 + 0.5(√2/2, √2/2).
    h = 0.5 * math.sqrt(0.5)
    expected = np.array([[1.0, -1.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3 + h, h, 0.0]])
    np.testing.assert_allclose(arm.joint_positions(q), expected, atol=FK_ATOL)
    np.testing.assert_allclose(arm.end_effector(q), [3 + h, h], atol=FK_ATOL)
    segs = arm.link_segments(q)
    np.testing.assert_allclose(segs[:, 0], expected[:-1], atol=FK_ATOL)
    np.testing.assert_allclose(segs[:, 1], expected[1:], atol=FK_ATOL)


def test_planar_3r_preset_folded_pose() -> None:
    arm = PlanarArm.three_r()
    # q = (0, π, 0): out 1 m, back 1 m, back another 1 m -> tool at (-1, 0).
    np.testing.assert_allclose(arm.end_effector([0.0, math.pi, 0.0]), [-1.0, 0.0], atol=FK_ATOL)
    # Ee Jacobian at q = 0 (stretched along x): ∂y/∂q_j = distance from joint j to the tip.
    J = arm.ee_jacobian(np.zeros(3))
    np.testing.assert_allclose(J, [[0.0, 0.0, 0.0], [3.0, 2.0, 1.0]], atol=FK_ATOL)


def test_presets_attributes() -> None:
    arm3, arm4 = PlanarArm.three_r(), PlanarArm.four_r()
    assert (arm3.dof, arm3.n_links, arm3.task_dim) == (3, 3, 2)
    assert (arm4.dof, arm4.n_links, arm4.task_dim) == (4, 4, 2)
    np.testing.assert_array_equal(arm4.lengths, [1.0, 1.0, 1.0, 1.0])
    puma, iiwa = DHChain.puma560(), DHChain.seven_dof()
    assert (puma.dof, puma.n_links, puma.task_dim) == (6, 6, 3)
    assert (iiwa.dof, iiwa.n_links, iiwa.task_dim) == (7, 7, 3)
    assert iiwa.dof - iiwa.task_dim == 4


@pytest.mark.parametrize("chain", chains(), ids=CHAIN_IDS)
def test_protocol_and_shapes(chain: SerialChain) -> None:
    assert isinstance(chain, SerialChain)
    n = chain.dof
    q = np.linspace(-0.5, 0.7, n)
    assert chain.link_segments(q).shape == (chain.n_links, 2, 3)
    assert chain.joint_positions(q).shape == (n + 1, 3)
    assert chain.point_jacobian(q, 0, 0.5).shape == (3, n)
    assert chain.end_effector(q).shape == (chain.task_dim,)
    assert chain.ee_jacobian(q).shape == (chain.task_dim, n)
    assert chain.joint_limits.shape == (n, 2)
    assert chain.link_radius.shape == (chain.n_links,)
    assert not chain.joint_limits.flags.writeable
    assert not chain.link_radius.flags.writeable
    # Consecutive links share their joint; the last link ends at the end effector.
    segs = chain.link_segments(q)
    np.testing.assert_allclose(segs[1:, 0], segs[:-1, 1], atol=FK_ATOL)
    np.testing.assert_allclose(segs[-1, 1, : chain.task_dim], chain.end_effector(q), atol=FK_ATOL)


def test_planar_points_lie_in_plane() -> None:
    arm = PlanarArm.four_r()
    q = np.array([0.3, -1.2, 2.0, 0.4])
    assert np.all(arm.joint_positions(q)[:, 2] == 0.0)
    assert np.all(arm.point_jacobian(q, 3, 0.3)[2] == 0.0)


# ------------------------------------------------------------------ Jacobians
@pytest.mark.parametrize("chain", chains(), ids=CHAIN_IDS)
def test_point_jacobian_matches_finite_differences(chain: SerialChain) -> None:
    rng = np.random.default_rng(20240401)
    for _ in range(5):
        q = rng.uniform(-math.pi, math.pi, chain.dof)
        for link in range(chain.n_links):
            for t in (0.0, 0.37, 1.0):
                np.testing.assert_allclose(
                    chain.point_jacobian(q, link, t),
                    point_fd(chain, q, link, t),
                    rtol=JAC_RTOL,
                    atol=JAC_ATOL,
                    err_msg=f"link {link}, t {t}, q {q}",
                )


@pytest.mark.parametrize("chain", chains(), ids=CHAIN_IDS)
def test_ee_jacobian_matches_finite_differences(chain: SerialChain) -> None:
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = rng.uniform(-math.pi, math.pi, chain.dof)
        J_fd = np.empty((chain.task_dim, chain.dof))
        for j in range(chain.dof):
            e = np.zeros(chain.dof)
            e[j] = FD_STEP
            J_fd[:, j] = (chain.end_effector(q + e) - chain.end_effector(q - e)) / (2 * FD_STEP)
        np.testing.assert_allclose(chain.ee_jacobian(q), J_fd, rtol=JAC_RTOL, atol=JAC_ATOL)


@pytest.mark.parametrize("chain", chains(), ids=CHAIN_IDS)
def test_distal_joints_contribute_zero_columns(chain: SerialChain) -> None:
    q = np.linspace(0.4, -0.9, chain.dof)
    for link in range(chain.n_links):
        J = chain.point_jacobian(q, link, 0.6)
        assert np.all(J[:, link + 1 :] == 0.0), f"link {link}"
        # Moving a distal joint leaves the whole link in place.
        if link + 1 < chain.dof:
            q2 = q.copy()
            q2[link + 1 :] += 0.8
            np.testing.assert_allclose(
                chain.link_segments(q2)[link], chain.link_segments(q)[link], atol=FK_ATOL
            )


def test_proximal_column_is_nonzero_on_planar_arm() -> None:
    arm = PlanarArm.three_r()
    J = arm.point_jacobian(np.array([0.2, 0.3, 0.4]), 1, 0.5)
    assert np.all(np.linalg.norm(J[:, :2], axis=0) > 0.1)


# ------------------------------------------------------------------ DH chains
def test_dh_frames_match_independent_transform_product() -> None:
    chain = DHChain.puma560()
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-math.pi, math.pi, 6)
        T = np.eye(4)
        expected = [T[:3, 3]]
        for i, (a, alpha, d, off) in enumerate(chain.dh):
            T = T @ dh_transform(a, alpha, d, q[i] + off)
            expected.append(T[:3, 3])
        np.testing.assert_allclose(chain.frames(q)[:, :3, 3], expected, atol=FK_ATOL)
        # Joint points are o_0 … o_5 and the tool point (= o_6, d6 = 0).
        np.testing.assert_allclose(chain.joint_positions(q), expected, atol=FK_ATOL)


def test_puma560_fk_matches_thesis_closed_form() -> None:
    chain = DHChain.puma560()
    rng = np.random.default_rng(11)
    qs = [np.zeros(6), *rng.uniform(-math.pi, math.pi, (10, 6))]
    for q in qs:
        np.testing.assert_allclose(chain.end_effector(q), puma_fgl_position(q), atol=FK_ATOL)


def test_puma560_zero_configuration_by_hand() -> None:
    chain = DHChain.puma560()
    # q = 0: upper arm along +x (a2), shoulder offset +y (d3), elbow offset -0.0203 along x,
    # forearm up (d4).
    np.testing.assert_allclose(
        chain.end_effector(np.zeros(6)), [0.4318 - 0.0203, 0.15, 0.4331], atol=FK_ATOL
    )


@pytest.mark.parametrize(("q", "expected"), THESIS_POSES)
def test_puma560_reproduces_thesis_end_points(
    q: tuple[float, ...], expected: tuple[float, float, float]
) -> None:
    chain = DHChain.puma560()
    np.testing.assert_allclose(chain.end_effector(q), expected, atol=THESIS_ATOL)
    assert chain.within_limits(q)


def test_puma560_table_values() -> None:
    dh = DHChain.puma560().dh
    np.testing.assert_allclose(dh[:, 0], [0, 0.4318, -0.0203, 0, 0, 0])
    np.testing.assert_allclose(dh[:, 2], [0, 0.15, 0, 0.4331, 0, 0])
    np.testing.assert_allclose(dh[:, 1], np.array([-1, 0, 1, -1, 1, 0]) * math.pi / 2)
    assert not dh.flags.writeable


def test_seven_dof_straight_up_at_zero() -> None:
    chain = DHChain.seven_dof()
    P = chain.joint_positions(np.zeros(7))
    np.testing.assert_allclose(P[:, :2], 0.0, atol=FK_ATOL)
    np.testing.assert_allclose(P[:, 2], [0, 0.36, 0.36, 0.78, 0.78, 1.18, 1.18, 1.306])
    axes = chain.frames(np.zeros(7))[:7, :3, 2]
    ez, ey = [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]
    np.testing.assert_allclose(axes, [ez, ey, ez, ey, ez, ey, ez], atol=FK_ATOL)
    np.testing.assert_allclose(
        np.degrees(chain.joint_limits[:, 1]), [170, 120, 170, 120, 170, 120, 175]
    )
    # Away from the stretched pose the position Jacobian has full rank 3.
    q = np.array([0.1, 0.5, -0.2, -1.2, 0.3, 0.8, 0.0])
    assert np.linalg.matrix_rank(chain.ee_jacobian(q)) == 3


def test_tool_offset_moves_end_effector_in_last_frame() -> None:
    tool = np.array([0.0, 0.0, 0.1])
    chain = DHChain.puma560(tool=tool)
    q = np.array([0.3, -0.4, 0.5, 0.6, -0.7, 0.8])
    T6 = chain.frames(q)[-1]
    np.testing.assert_allclose(chain.end_effector(q), T6[:3, 3] + T6[:3, :3] @ tool)
    np.testing.assert_allclose(chain.tool, tool)


# ------------------------------------------------------------------ limits
def test_within_and_clip_limits() -> None:
    arm = PlanarArm.three_r(joint_limits=[[-1.0, 1.0], [-0.5, 0.5], [0.0, 2.0]])
    assert arm.within_limits([0.0, 0.0, 1.0])
    assert not arm.within_limits([0.0, 0.6, 1.0])
    assert arm.within_limits([0.0, 0.6, 1.0], tol=0.2)
    np.testing.assert_array_equal(arm.clip_to_limits([-3.0, 0.2, 5.0]), [-1.0, 0.2, 2.0])


def test_default_limits_and_radius() -> None:
    arm = PlanarArm.three_r(link_radius=[0.1, 0.0, 0.05])
    np.testing.assert_allclose(arm.joint_limits, [[-math.pi, math.pi]] * 3)
    np.testing.assert_array_equal(arm.link_radius, [0.1, 0.0, 0.05])
    np.testing.assert_array_equal(DHChain.puma560(link_radius=0.04).link_radius, [0.04] * 6)


# ------------------------------------------------------------------ validation
@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"lengths": [1.0, 0.0]}, InvalidGeometry, r"expected finite link lengths > 0"),
        ({"lengths": [[1.0, 2.0]]}, InvalidGeometry, r"expected shape \(n,\) with n >= 1"),
        ({"lengths": []}, InvalidGeometry, r"n >= 1"),
        (
            {"lengths": [1.0], "base": (0.0, math.nan)},
            InvalidGeometry,
            r"base: expected finite values, got \[0.0, nan\]",
        ),
        (
            {"lengths": [1.0, 1.0], "joint_limits": [[0.0, 1.0]]},
            InvalidParameter,
            r"joint_limits: expected shape \(2, 2\)",
        ),
        (
            {"lengths": [1.0, 1.0], "joint_limits": [[0.0, 1.0], [1.0, -1.0]]},
            InvalidParameter,
            r"lower < upper.*joint\(s\) \[1\]",
        ),
        (
            {"lengths": [1.0], "joint_limits": [[-math.inf, 1.0]]},
            InvalidParameter,
            r"expected finite values",
        ),
        ({"lengths": [1.0], "link_radius": -0.1}, InvalidParameter, r"link_radius must be"),
        (
            {"lengths": [1.0, 1.0], "link_radius": [0.1]},
            InvalidGeometry,
            r"link_radius: expected a scalar or shape \(2,\)",
        ),
        (
            {"lengths": [1.0, 1.0], "link_radius": [0.1, -0.1]},
            InvalidGeometry,
            r"expected finite radii >= 0",
        ),
    ],
)
def test_planar_constructor_validation(
    kwargs: dict[str, object], error: type[Exception], match: str
) -> None:
    lengths = kwargs.pop("lengths")
    with pytest.raises(error, match=match):
        PlanarArm(lengths, **kwargs)  # type: ignore[arg-type]


def test_dh_constructor_validation() -> None:
    with pytest.raises(InvalidGeometry, match=r"dh: expected shape \(n, 4\)"):
        DHChain([[0.0, 0.0, 0.0]])
    with pytest.raises(InvalidGeometry, match=r"non-finite entries in row\(s\) \[1\]"):
        DHChain([[0.0, 0.0, 0.0, 0.0], [0.0, math.nan, 0.0, 0.0]])
    with pytest.raises(InvalidGeometry, match=r"tool: expected shape \(3,\), got shape \(2,\)"):
        DHChain.puma560(tool=(0.0, 0.1))
    with pytest.raises(InvalidParameter, match=r"joint_limits: expected shape \(7, 2\)"):
        DHChain.seven_dof(joint_limits=np.zeros((6, 2)))


def test_runtime_input_validation() -> None:
    arm = PlanarArm.three_r()
    with pytest.raises(InvalidInput, match=r"q: expected shape \(3,\)"):
        arm.end_effector([0.0, 0.0])
    with pytest.raises(InvalidInput, match=r"expected finite values"):
        arm.joint_positions([0.0, math.nan, 0.0])
    with pytest.raises(InvalidInput, match=r"expected one joint vector of shape \(3,\)"):
        arm.link_segments(np.zeros((2, 3)))
    with pytest.raises(InvalidInput, match=r"link: expected an index in \[0, 2\].*got 3"):
        arm.point_jacobian(np.zeros(3), 3, 0.5)
    with pytest.raises(InvalidInput, match=r"link: expected an int"):
        arm.point_jacobian(np.zeros(3), 1.0, 0.5)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"t: expected a finite fraction in \[0, 1\]"):
        arm.point_jacobian(np.zeros(3), 0, 1.5)
    with pytest.raises(InvalidInput, match=r"t: expected a finite fraction"):
        arm.point_jacobian(np.zeros(3), 0, math.nan)
    with pytest.raises(InvalidParameter, match=r"tol must be finite and >= 0"):
        arm.within_limits(np.zeros(3), tol=-1.0)


def test_point_jacobian_refuses_a_duration_as_link():
    arm = PlanarArm([1.0, 1.0])
    with pytest.raises(InvalidInput, match=r"link: expected an int in \[0, 1\], got timedelta64"):
        arm.point_jacobian([0.0, 0.0], np.timedelta64(1, "s"), 0.5)


def test_the_last_pose_is_kept_for_the_same_q_only() -> None:
    """A control loop asks for one pose several times per cycle; the chain keeps the last one.

    A q one ulp away, or the same array changed in place, is computed afresh: every answer equals
    a fresh chain's, bit for bit, and what a caller gets is its own to modify.
    """
    chain = DHChain.seven_dof(link_radius=0.05)
    rng = np.random.default_rng(7)
    q1 = rng.uniform(-1.0, 1.0, 7)
    q_ulp = np.nextafter(q1, 2.0)
    moved = q1.copy()
    for q in (q1, q1, q_ulp, q1, moved):
        fresh = DHChain.seven_dof(link_radius=0.05)
        np.testing.assert_array_equal(chain.joint_positions(q), fresh.joint_positions(q))
        np.testing.assert_array_equal(chain.end_effector(q), fresh.end_effector(q))
        np.testing.assert_array_equal(chain.link_segments(q), fresh.link_segments(q))
        np.testing.assert_array_equal(chain.jacobian(q), fresh.jacobian(q))
        moved[0] += 0.1  # in place: the next round asks for another pose in the same array
    # the test can fail: one ulp on the joints moves the points
    assert not np.array_equal(chain.joint_positions(q1), chain.joint_positions(q_ulp))
    # and the frames' independent route (4 x 4 products) agrees
    np.testing.assert_allclose(chain.joint_positions(q1)[:-1], chain.frames(q1)[:-1, :3, 3])
    # answers are copies: changing one does not change the kept pose
    for got in (chain.joint_positions(q1), chain.link_segments(q1), chain.end_effector(q1)):
        got[...] = 0.0
    np.testing.assert_array_equal(chain.end_effector(q1), DHChain.seven_dof().end_effector(q1))
