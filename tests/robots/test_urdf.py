"""MujocoRobot.from_urdf: kinematics against hand-written transforms, packages, meshes, limits."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from velfence.errors import InvalidGeometry, InvalidParameter
from velfence.robots import MujocoRobot, dh_mjcf, panda

# A 3-link arm on a base: revolute joints about z, z (after a +90° roll) and y, a fixed joint to
# a tool frame, a package:// mesh in a visual and in a collision, limits with effort/velocity
# (joint j3's effort 0: "not given").
URDF = """<?xml version="1.0"?>
<robot name="arm3">
  <link name="base_link">
    <inertial><origin xyz="0 0 0.05"/><mass value="2"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
  </link>
  <joint name="j1" type="revolute">
    <parent link="base_link"/><child link="l1"/>
    <origin xyz="0 0 0.3" rpy="0 0 0.2"/><axis xyz="0 0 1"/>
    <limit lower="-2.96705972839" upper="2.96705972839" effort="40" velocity="1.5"/>
  </joint>
  <link name="l1">
    <inertial><origin xyz="0 0 0.1"/><mass value="1.5"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.005"/></inertial>
    <visual><geometry><mesh filename="package://my_arm/meshes/l1.stl"/></geometry></visual>
  </link>
  <joint name="j2" type="revolute">
    <parent link="l1"/><child link="l2"/>
    <origin xyz="0.05 0 0.2" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1.5" upper="1.5" effort="20" velocity="2.175"/>
  </joint>
  <link name="l2">
    <inertial><origin xyz="0.2 0 0"/><mass value="1"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><geometry><mesh filename="package://my_arm/meshes/l2.stl"/></geometry></collision>
    <collision><origin xyz="0.2 0 0"/><geometry><box size="0.4 0.05 0.05"/></geometry></collision>
  </link>
  <joint name="j3" type="revolute">
    <parent link="l2"/><child link="l3"/>
    <origin xyz="0.4 0 0" rpy="0.1 0.3 -0.2"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" effort="0" velocity="3.0"/>
  </joint>
  <link name="l3">
    <inertial><origin xyz="0.1 0 0"/><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial>
  </link>
  <joint name="flange_fixed" type="fixed">
    <parent link="l3"/><child link="tool0"/>
    <origin xyz="0.25 0 0.01" rpy="0 0.5 0"/>
  </joint>
  <link name="tool0"/>
</robot>
"""

# (parent link, child link, origin xyz, origin rpy, axis or None for fixed), in chain order.
CHAIN = [
    ("base_link", "l1", (0, 0, 0.3), (0, 0, 0.2), (0, 0, 1)),
    ("l1", "l2", (0.05, 0, 0.2), (math.pi / 2, 0, 0), (0, 0, 1)),
    ("l2", "l3", (0.4, 0, 0), (0.1, 0.3, -0.2), (0, 1, 0)),
    ("l3", "tool0", (0.25, 0, 0.01), (0, 0.5, 0), None),
]


def _rpy(r: float, p: float, y: float) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw: R = Rz(y) Ry(p) Rx(r)."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1.0]])
    ry = np.array([[cp, 0, sp], [0, 1.0, 0], [-sp, 0, cp]])
    rx = np.array([[1.0, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


def _axis_angle(axis: tuple[float, ...], q: float) -> np.ndarray:
    """Rodrigues' formula."""
    k = np.asarray(axis, dtype=float)
    k = k / np.linalg.norm(k)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(q) * K + (1 - math.cos(q)) * K @ K


def _frames(q: np.ndarray) -> tuple[dict[str, np.ndarray], list[tuple[np.ndarray, np.ndarray]]]:
    """World transforms of every link and (origin, world axis) of every moving joint."""
    T = {"base_link": np.eye(4)}
    axes = []
    k = 0
    for parent, child, xyz, rpy, axis in CHAIN:
        origin = np.eye(4)
        origin[:3, :3] = _rpy(*rpy)
        origin[:3, 3] = xyz
        Tj = T[parent] @ origin
        motion = np.eye(4)
        if axis is not None:
            axes.append((Tj[:3, 3].copy(), Tj[:3, :3] @ np.asarray(axis, dtype=float)))
            motion[:3, :3] = _axis_angle(axis, q[k])
            k += 1
        T[child] = Tj @ motion
    return T, axes


def _stl(path: Path) -> None:
    """A binary STL tetrahedron (a mesh MuJoCo loads)."""
    v = [(0, 0, 0), (0.05, 0, 0), (0, 0.05, 0), (0, 0, 0.05)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    data = bytearray(80) + struct.pack("<I", len(faces))
    for f in faces:
        data += struct.pack("<3f", 0.0, 0.0, 0.0)
        for i in f:
            data += struct.pack("<3f", *v[i])
        data += struct.pack("<H", 0)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(bytes(data))


@pytest.fixture
def urdf(tmp_path: Path) -> Path:
    p = tmp_path / "robot" / "arm3.urdf"
    p.parent.mkdir()
    p.write_text(URDF, encoding="utf-8")
    return p


def _random_q(robot: MujocoRobot, n: int, seed: int) -> np.ndarray:
    lim = robot.joint_limits
    return np.random.default_rng(seed).uniform(lim[:, 0], lim[:, 1], size=(n, robot.dof))


def test_fk_matches_hand_written_transforms(urdf: Path) -> None:
    tool = np.array([0.02, -0.01, 0.05])
    robot = MujocoRobot.from_urdf(urdf, tool=tool)  # no mesh file exists: meshes=False
    assert robot.joint_names == ("j1", "j2", "j3")
    assert set(robot.points) == {"tcp", "base_link", "l1", "l2", "l3", "tool0"}
    for q in _random_q(robot, 40, seed=1):
        T, _ = _frames(q)
        for link, Tl in T.items():
            np.testing.assert_allclose(robot.fk(q, link), Tl[:3, 3], rtol=0, atol=1e-12)
        tcp = T["tool0"] @ np.append(tool, 1.0)
        np.testing.assert_allclose(robot.fk(q), tcp[:3], rtol=0, atol=1e-12)


def test_jacobian_matches_geometric_jacobian_and_finite_differences(urdf: Path) -> None:
    robot = MujocoRobot.from_urdf(urdf, tool=[0.0, 0.0, 0.1])
    h = 1e-6
    for q in _random_q(robot, 30, seed=2):
        _, axes = _frames(q)
        p = robot.fk(q)
        geo = np.column_stack([np.cross(z, p - o) for o, z in axes])
        np.testing.assert_allclose(robot.jacobian(q), geo, rtol=0, atol=1e-12)
        np.testing.assert_allclose(
            robot.angular_jacobian(q), np.column_stack([z for _, z in axes]), atol=1e-12
        )
        for point in ("tcp", "l2", "tool0"):
            fd = np.column_stack(
                [
                    (robot.fk(q + h * e, point) - robot.fk(q - h * e, point)) / (2 * h)
                    for e in np.eye(3)
                ]
            )
            np.testing.assert_allclose(robot.jacobian(q, point), fd, rtol=0, atol=1e-6)


def test_limits_from_the_urdf(urdf: Path) -> None:
    robot = MujocoRobot.from_urdf(urdf)
    np.testing.assert_array_equal(
        robot.joint_limits, [[-2.96705972839, 2.96705972839], [-1.5, 1.5], [-2.5, 2.5]]
    )
    np.testing.assert_array_equal(robot.velocity_limits, [1.5, 2.175, 3.0])
    np.testing.assert_array_equal(robot.effort_limits, [40.0, 20.0, np.inf])  # effort="0"
    assert not robot.velocity_limits.flags.writeable
    assert not robot.effort_limits.flags.writeable


def test_xml_round_trip_is_exact(urdf: Path) -> None:
    robot = MujocoRobot.from_urdf(urdf, tool=[0.0, 0.01, 0.02])
    again = MujocoRobot.from_xml(robot.xml)
    for name in ("body_pos", "body_quat", "jnt_axis", "jnt_range", "site_pos"):
        np.testing.assert_array_equal(getattr(again.model, name), getattr(robot.model, name))
    np.testing.assert_array_equal(again.velocity_limits, robot.velocity_limits)
    np.testing.assert_array_equal(again.effort_limits, robot.effort_limits)
    q = np.array([0.3, -0.2, 1.1])
    np.testing.assert_array_equal(again.fk(q), robot.fk(q))


def test_tcp_link_and_tool(urdf: Path) -> None:
    robot = MujocoRobot.from_urdf(urdf, tcp_link="l2", tool=[0.1, 0.0, 0.0])
    q = np.array([0.4, 0.5, -0.6])
    T, _ = _frames(q)
    np.testing.assert_allclose(robot.fk(q), (T["l2"] @ [0.1, 0, 0, 1.0])[:3], atol=1e-12)
    with pytest.raises(InvalidGeometry, match=r"tcp_link: expected one of the links \['base_link'"):
        MujocoRobot.from_urdf(urdf, tcp_link="hand")


def test_package_uris_resolve_and_meshes_load(urdf: Path, tmp_path: Path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    share = tmp_path / "share"
    for name in ("l1.stl", "l2.stl"):
        _stl(share / "my_arm" / "meshes" / name)
    robot = MujocoRobot.from_urdf(urdf, package_paths=[empty, str(share)], meshes=True)
    assert robot.model.nmesh == 2
    expected = str((share / "my_arm" / "meshes" / "l1.stl").resolve())
    assert expected in robot.xml
    # meshes never change the kinematics
    plain = MujocoRobot.from_urdf(urdf)
    assert plain.model.nmesh == 0
    q = np.array([0.1, 0.2, 0.3])
    np.testing.assert_array_equal(robot.fk(q, "tool0"), plain.fk(q, "tool0"))


def test_missing_meshes(urdf: Path, tmp_path: Path) -> None:
    share = tmp_path / "share"
    _stl(share / "my_arm" / "meshes" / "l1.stl")  # l2.stl is missing
    missing = str((share / "my_arm" / "meshes" / "l2.stl").resolve())
    with pytest.raises(
        InvalidGeometry, match=r"mesh file .*l2\.stl.* of link 'l2' to exist"
    ) as exc:
        MujocoRobot.from_urdf(urdf, package_paths=[share], meshes=True)
    assert missing in str(exc.value)
    with pytest.raises(InvalidGeometry, match=r"package 'my_arm' in a directory of package_paths"):
        MujocoRobot.from_urdf(urdf, package_paths=[tmp_path / "robot"], meshes=True)
    MujocoRobot.from_urdf(urdf, package_paths=[tmp_path / "robot"])  # meshes=False: fine


def test_validation(urdf: Path, tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match="path: expected a readable UTF-8 URDF file"):
        MujocoRobot.from_urdf(tmp_path / "nope.urdf")
    with pytest.raises(InvalidParameter, match="path: expected a str or Path"):
        MujocoRobot.from_urdf(3)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="package_paths: expected a sequence"):
        MujocoRobot.from_urdf(urdf, package_paths=str(tmp_path))  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"package_paths\[0\]: expected an existing dir"):
        MujocoRobot.from_urdf(urdf, package_paths=[tmp_path / "nope"])
    with pytest.raises(InvalidParameter, match=r"tool: expected shape \(3,\)"):
        MujocoRobot.from_urdf(urdf, tool=[0.0, 0.1])
    with pytest.raises(InvalidParameter, match="tool: expected finite"):
        MujocoRobot.from_urdf(urdf, tool=[0.0, np.nan, 0.0])
    with pytest.raises(InvalidParameter, match="meshes: expected True, False or 'collision'"):
        MujocoRobot.from_urdf(urdf, meshes="yes")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="tcp_link: expected a link name"):
        MujocoRobot.from_urdf(urdf, tcp_link=3)  # type: ignore[arg-type]
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot><link name='a'>", encoding="utf-8")
    with pytest.raises(InvalidGeometry, match=r"path: expected a URDF \(XML\) document"):
        MujocoRobot.from_urdf(bad)
    bad.write_text("<mujoco/>", encoding="utf-8")
    with pytest.raises(InvalidGeometry, match="path: expected a URDF document with a <robot>"):
        MujocoRobot.from_urdf(bad)
    bad.write_text(
        '<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
        '<joint name="f" type="floating"><parent link="a"/><child link="b"/></joint></robot>',
        encoding="utf-8",
    )
    with pytest.raises(InvalidGeometry, match=r"path: expected .*(free joint|hinge or slide)"):
        MujocoRobot.from_urdf(bad)


def _example_robot_data() -> Path:
    """The URDF tree of the ``example-robot-data`` wheel (data only, no download), or skip."""
    from importlib import metadata

    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed")
    root = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    if not root.is_dir():
        pytest.skip(f"example-robot-data has no robots/ tree at {root}")
    return root


def test_example_robot_data_panda_matches_the_shipped_panda() -> None:
    # franka_description's link frames are the modified-DH frames: link i+1 is our joint<i>
    # site, panda_link8 the flange. Its meshes are .dae (MuJoCo reads none): meshes=False.
    root = _example_robot_data()
    robot = MujocoRobot.from_urdf(root / "panda_description" / "urdf" / "panda.urdf")
    ref = panda()
    assert robot.joint_names[:7] == ref.joint_names
    np.testing.assert_allclose(robot.joint_limits[:7], ref.joint_limits, atol=1e-12)
    np.testing.assert_array_equal(robot.velocity_limits[:7], ref.velocity_limits)
    np.testing.assert_array_equal(robot.effort_limits[:7], ref.effort_limits)
    for q in _random_q(ref, 30, seed=4):
        qq = np.zeros(robot.dof)
        qq[:7] = q
        np.testing.assert_allclose(robot.fk(qq, "panda_link8"), ref.fk(q, "flange"), atol=1e-12)
        for i in range(7):
            np.testing.assert_allclose(
                robot.fk(qq, f"panda_link{i + 1}"), ref.fk(q, f"joint{i}"), atol=1e-12
            )


def test_example_robot_data_ur5_matches_its_dh_table() -> None:
    # UR5 (CB3; the package has no UR5e): ur_description's "tool0" is the DH flange, expressed
    # here in its "base" frame (base_link turned by π about z).
    root = _example_robot_data()
    robot = MujocoRobot.from_urdf(root / "ur_description" / "urdf" / "ur5_robot.urdf")
    h = math.pi / 2
    rows = [
        [0.0, h, 0.089159, 0.0],
        [-0.425, 0.0, 0.0, 0.0],
        [-0.39225, 0.0, 0.0, 0.0],
        [0.0, h, 0.10915, 0.0],
        [0.0, -h, 0.09465, 0.0],
        [0.0, 0.0, 0.0823, 0.0],
    ]
    ref = MujocoRobot.from_xml(dh_mjcf(rows, joint_limits=[[-7.0, 7.0]] * 6))
    flip = np.array([-1.0, -1.0, 1.0])
    for q in np.random.default_rng(5).uniform(-3.0, 3.0, size=(30, 6)):
        # the URDF's rpy are rounded to 1e-11 rad (1.57079632679)
        np.testing.assert_allclose(flip * robot.fk(q, "tool0"), ref.fk(q), atol=1e-10)
