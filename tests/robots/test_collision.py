"""Capsules fitted to collision geometry: known answers, other projects' models, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from velfence.errors import InvalidGeometry, InvalidParameter, VelfenceError
from velfence.geometry import bounding_capsule
from velfence.robots import (
    PANDA_LINK_RADII,
    MujocoRobot,
    dh_mjcf,
    fit_collision_capsules,
    panda,
    ur5e,
)

_UR5_BODIES = [
    "shoulder_link",
    "upper_arm_link",
    "forearm_link",
    "wrist_1_link",
    "wrist_2_link",
    "wrist_3_link",
]


def _one_body(geoms: str, extra: str = "") -> MujocoRobot:
    """A one-joint arm whose moving body carries ``geoms`` (and a tcp site)."""
    return MujocoRobot.from_xml(
        f"""<mujoco><worldbody>{extra}
        <body name="arm" pos="0.1 0.2 0.3" quat="0.9238795 0 0.3826834 0">
          <joint name="j" type="hinge" axis="0 0 1"/>
          <site name="tcp"/>
          {geoms}
        </body></worldbody></mujoco>"""
    )


def _inside(points: np.ndarray, start: np.ndarray, end: np.ndarray, r: float) -> np.ndarray:
    """Distance of each point to the segment minus r (independent of the library's helpers)."""
    e = end - start
    ee = float(e @ e)
    t = np.zeros(len(points)) if ee == 0 else np.clip((points - start) @ e / ee, 0.0, 1.0)
    return np.linalg.norm(points - (start + t[:, None] * e), axis=1) - r


# --- geometry.bounding_capsule: answers by hand --------------------------------------------


def test_bounding_capsule_of_a_cylinder_is_its_axis_and_radius() -> None:
    # A cylinder of radius r, length l: its two end balls of radius r.
    r, length = 0.04, 0.3
    a, b, rad = bounding_capsule([[0, 0, -length / 2], [0, 0, length / 2]], radii=r)
    assert rad == pytest.approx(r, abs=1e-15)
    assert np.linalg.norm(b - a) == pytest.approx(length, abs=1e-12)
    assert abs(a[2]) == pytest.approx(length / 2)
    assert np.allclose(a[:2], 0.0)


def test_bounding_capsule_of_a_box_by_hand() -> None:
    # Half-sizes 0.3 > 0.1 > 0.05: axis x, radius sqrt(0.1² + 0.05²), segment ±0.3.
    hx, hy, hz = 0.3, 0.1, 0.05
    corners = [[i * hx, j * hy, k * hz] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)]
    a, b, rad = bounding_capsule(np.array(corners) + np.array([1.0, 2.0, 3.0]))
    assert rad == pytest.approx(math.hypot(hy, hz), abs=1e-12)
    ends = sorted([a.tolist(), b.tolist()])
    np.testing.assert_allclose(ends, [[0.7, 2.0, 3.0], [1.3, 2.0, 3.0]], atol=1e-12)


def test_bounding_capsule_contains_random_balls() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        c = rng.normal(size=(50, 3)) * rng.uniform(0.01, 1.0, size=3)
        rho = rng.uniform(0.0, 0.05, size=50)
        a, b, r = bounding_capsule(c, radii=rho)
        assert np.all(_inside(c, a, b, r) + rho <= 1e-12)
        # tight: some ball touches the surface
        assert np.max(_inside(c, a, b, r) + rho) == pytest.approx(0.0, abs=1e-9)


def test_bounding_capsule_of_one_point_and_of_balls_on_a_point() -> None:
    a, b, r = bounding_capsule([[1.0, 2.0, 3.0]], radii=0.5)
    np.testing.assert_array_equal(a, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(b, a)
    assert r == 0.5


@pytest.mark.parametrize(
    ("centers", "radii", "arg"),
    [
        (np.zeros((0, 3)), 0.0, "centers"),
        ([[0.0, math.nan, 0.0]], 0.0, "centers"),
        ([[0.0, 0.0]], 0.0, "centers"),
        ([[0.0, 0.0, 0.0]], -0.1, "radii"),
        ([[0.0, 0.0, 0.0]], math.inf, "radii"),
        ([[0.0, 0.0, 0.0]], [0.1, 0.2], "radii"),
    ],
)
def test_bounding_capsule_refuses_what_cannot_be_bounded(
    centers: object, radii: object, arg: str
) -> None:
    with pytest.raises(InvalidGeometry, match=rf"^{arg}: "):
        bounding_capsule(centers, radii=radii)  # type: ignore[arg-type]


# --- fit_collision_capsules on small models with known answers ------------------------------


def test_cylinder_geom_fits_its_own_capsule() -> None:
    r, h = 0.05, 0.2
    fit = fit_collision_capsules(_one_body(f'<geom type="cylinder" size="{r} {h}" pos="0 0 0.1"/>'))
    (link,) = fit.links
    assert link.body == "arm"
    assert link.radius == pytest.approx(r, abs=1e-12)
    assert link.length == pytest.approx(2 * h, abs=1e-12)
    np.testing.assert_allclose(sorted([link.start[2], link.end[2]]), [0.1 - h, 0.1 + h])
    assert link.source_volume == pytest.approx(math.pi * r * r * 2 * h, rel=1e-12)
    assert link.capsule_volume == pytest.approx(
        math.pi * r * r * 2 * h + 4 / 3 * math.pi * r**3, rel=1e-12
    )
    # the hemispheres' poles are r beyond the end disks: the largest gap (MuJoCo's distance)
    assert link.largest_gap == pytest.approx(r, abs=1e-4)


def test_box_geom_fits_the_capsule_by_hand() -> None:
    hx, hy, hz = 0.05, 0.25, 0.02  # longest along y
    fit = fit_collision_capsules(
        _one_body(f'<geom type="box" size="{hx} {hy} {hz}" euler="0 0 30"/>')
    )
    (link,) = fit.links
    assert link.radius == pytest.approx(math.hypot(hx, hz), abs=1e-12)
    assert link.length == pytest.approx(2 * hy, abs=1e-12)
    axis = (link.end - link.start) / link.length
    a = math.radians(30.0)  # MJCF angles are in degrees
    assert abs(axis @ [-math.sin(a), math.cos(a), 0.0]) == pytest.approx(1.0, abs=1e-12)
    assert link.source_volume == pytest.approx(8 * hx * hy * hz, rel=1e-12)
    assert link.largest_gap == pytest.approx(math.hypot(hx, hz), abs=1e-4)


def test_sphere_capsule_and_ellipsoid_geoms() -> None:
    fit = fit_collision_capsules(_one_body('<geom type="sphere" size="0.07" pos="0.1 0 0"/>'))
    assert fit.links[0].radius == pytest.approx(0.07)
    assert fit.links[0].length == 0.0
    np.testing.assert_allclose(fit.links[0].start, [0.1, 0, 0], atol=1e-12)
    assert fit.links[0].largest_gap == pytest.approx(0.0, abs=1e-4)
    fit = fit_collision_capsules(
        _one_body('<geom type="capsule" size="0.03" fromto="0 0 0 0 .2 0"/>')
    )
    link = fit.links[0]
    assert link.radius == pytest.approx(0.03)
    assert link.length == pytest.approx(0.2)
    assert link.volume_added == pytest.approx(0.0, abs=1e-15)
    assert link.largest_gap == pytest.approx(0.0, abs=1e-4)
    # ellipsoid a >= b >= c: radius b on ±(a - b) along a; its poles touch the capsule
    fit = fit_collision_capsules(_one_body('<geom type="ellipsoid" size="0.04 0.1 0.02"/>'))
    link = fit.links[0]
    assert link.radius == pytest.approx(0.04)
    assert link.length == pytest.approx(0.12)
    assert link.source_volume == pytest.approx(4 / 3 * math.pi * 0.04 * 0.1 * 0.02)


def test_several_geoms_and_the_collision_rule() -> None:
    # Two boxes end to end plus a visual geom (contype = conaffinity = 0) that must not count,
    # and a floor on the world body that never counts.
    geoms = (
        '<geom type="box" size="0.1 0.02 0.02" pos="0.1 0 0"/>'
        '<geom type="box" size="0.1 0.02 0.02" pos="0.3 0 0"/>'
        '<geom type="sphere" size="0.5" contype="0" conaffinity="0" group="2"/>'
    )
    floor = '<geom type="plane" size="1 1 1"/>'
    fit = fit_collision_capsules(_one_body(geoms, floor))
    (link,) = fit.links
    assert len(link.geoms) == 2
    assert all("box" in g for g in link.geoms)
    assert link.radius == pytest.approx(math.hypot(0.02, 0.02))
    assert link.length == pytest.approx(0.4)
    assert "contype" in fit.rule
    # by group: only the group-2 sphere
    fit = fit_collision_capsules(_one_body(geoms, floor), groups=[2])
    assert fit.links[0].radius == pytest.approx(0.5)
    assert "group" in fit.rule
    assert "| arm |" in fit.table()


def test_mesh_geom_bounds_every_vertex_and_its_volume() -> None:
    # A tetrahedron given inline: volume 1/6 of the unit cube corner, known by hand.
    mesh = '<asset><mesh name="t" vertex="0 0 0  0.1 0 0  0 0.1 0  0 0 0.1"/></asset>'
    robot = MujocoRobot.from_xml(
        f"""<mujoco>{mesh}<worldbody><body name="b"><joint type="hinge"/><site name="tcp"/>
        <geom type="mesh" mesh="t" pos="0.5 0 0"/></body></worldbody></mujoco>"""
    )
    link = fit_collision_capsules(robot).links[0]
    assert link.source_volume == pytest.approx(0.1**3 / 6, rel=1e-6)  # float32 vertices
    verts = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]) + np.array([0.5, 0.0, 0.0])
    assert np.all(_inside(verts, link.start, link.end, link.radius) <= 1e-7)


# --- bad input ------------------------------------------------------------------------------


def test_unknown_geom_type_on_a_link_is_refused_naming_it() -> None:
    # MuJoCo allows a plane on a static body (not the world): it cannot be bounded.
    robot = _one_body(
        '<geom type="sphere" size="0.01"/>',
        '<body name="b"><geom name="hf" type="plane" size="1 1 1"/></body>',
    )
    with pytest.raises(InvalidGeometry, match=r"robot: geom 'hf' of body 'b'.*got type plane"):
        fit_collision_capsules(robot)


def test_no_collision_geom_and_bad_arguments() -> None:
    robot = _one_body('<geom type="sphere" size="0.1" contype="0" conaffinity="0"/>')
    with pytest.raises(InvalidGeometry, match=r"^robot: expected collision geoms"):
        fit_collision_capsules(robot)
    with pytest.raises(InvalidParameter, match=r"^robot: expected a MujocoRobot"):
        fit_collision_capsules("robot.xml")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^groups"):
        fit_collision_capsules(robot, groups=[9])
    with pytest.raises(InvalidParameter, match=r"^samples"):
        fit_collision_capsules(robot, samples=2)


@pytest.mark.parametrize(
    "geom",
    [
        '<geom type="sphere" size="-0.1"/>',
        '<geom type="box" size="0.1 -0.1 0.1"/>',
        '<geom type="cylinder" size="0.1 -0.2"/>',
    ],
)
def test_negative_size_is_refused_naming_the_argument(geom: str) -> None:
    # MuJoCo refuses it when compiling; the error names the document argument.
    with pytest.raises(VelfenceError, match=r"^text: "):
        _one_body(geom)


@pytest.mark.parametrize(
    "vertices",
    ["", "0 0 0  nan 0 0  0 1 0  0 0 1", "0 0 0  1 0 0  2 0 0"],
    ids=["empty", "nan", "flat"],
)
def test_meshes_that_cannot_be_bounded_are_refused(vertices: str) -> None:
    with pytest.raises(VelfenceError, match=r"^text: "):
        MujocoRobot.from_xml(
            f"""<mujoco><asset><mesh name="t" vertex="{vertices}"/></asset><worldbody>
            <body><joint type="hinge"/><site name="tcp"/><geom type="mesh" mesh="t"/></body>
            </worldbody></mujoco>"""
        )


def test_missing_mesh_file_is_refused_naming_it(tmp_path: Path) -> None:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        '<robot name="a"><link name="base"/><link name="l"><collision><geometry>'
        '<mesh filename="missing.stl"/></geometry></collision></link>'
        '<joint name="j" type="revolute"><parent link="base"/><child link="l"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>',
        encoding="utf-8",
    )
    with pytest.raises(InvalidGeometry, match=r"path: expected the mesh file .*missing\.stl"):
        MujocoRobot.from_urdf(urdf, meshes="collision")


def test_link_radii_arguments() -> None:
    fit = fit_collision_capsules(panda(radius=0.05))
    with pytest.raises(InvalidParameter, match=r"^bodies: expected a sequence of 7"):
        fit.link_radii(bodies=["link0"])
    with pytest.raises(InvalidParameter, match=r"^bodies\[0\]: expected a name or a list of names"):
        fit.link_radii(bodies=["nope"] + [()] * 6)
    with pytest.raises(InvalidParameter, match=r"^base: expected a body"):
        fit.link_radii(base="nope")
    with pytest.raises(InvalidParameter, match=r"^body: expected one of the fitted"):
        fit["nope"]


# --- the shipped arms' own geoms -------------------------------------------------------------


def test_a_shipped_arm_fits_its_own_capsules_back() -> None:
    robot = panda(radius=PANDA_LINK_RADII)
    fit = fit_collision_capsules(robot)
    radii = fit.link_radii()
    # the generated capsule (sphere) geoms are the links: the fit gives the radii back
    np.testing.assert_allclose(radii.radius, PANDA_LINK_RADII, atol=1e-12)
    np.testing.assert_allclose(radii.radius, robot.link_radius, atol=1e-12)
    assert radii.frame_error == pytest.approx(0.0, abs=1e-12)
    assert np.all(np.abs(radii.volume_added) < 1e-12)


def test_per_link_radii_of_the_generator() -> None:
    r = [0.05, 0.04, 0.03, 0.02, 0.01, 0.015]
    robot = ur5e(radius=r)
    np.testing.assert_allclose(robot.link_radius, r)
    with pytest.raises(InvalidParameter, match=r"^radius"):
        ur5e(radius=[0.1, -0.1, 0, 0, 0, 0])
    with pytest.raises(InvalidParameter, match=r"^radius"):
        ur5e(radius=[0.1, 0.1])


# --- models nobody here wrote ---------------------------------------------------------------


def _example_robot_data() -> Path:
    from importlib import metadata

    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed")
    root = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    if not root.is_dir():
        pytest.skip(f"example-robot-data has no robots/ tree at {root}")
    return root


def _panda_urdf() -> MujocoRobot:
    root = _example_robot_data()
    return MujocoRobot.from_urdf(
        root / "panda_description" / "urdf" / "panda.urdf",
        package_paths=[root.parent.parent],
        meshes="collision",
        tcp_link="panda_link8",
    )


def test_panda_collision_meshes_volumes_and_vertices_match_trimesh() -> None:
    # trimesh reads the STL files itself: volumes and vertices independent of MuJoCo.
    trimesh = pytest.importorskip("trimesh")
    root = _example_robot_data()
    fit = fit_collision_capsules(_panda_urdf())
    for k in range(1, 8):
        mesh = trimesh.load(
            root / "panda_description" / "meshes" / "collision" / f"link{k}.stl", force="mesh"
        )
        link = fit[f"panda_link{k}"]
        assert link.source_volume == pytest.approx(abs(mesh.volume), rel=1e-6)
        # every vertex of the file (URDF origin: identity) is inside the fitted capsule
        assert np.max(_inside(np.asarray(mesh.vertices), link.start, link.end, link.radius)) < 1e-6
        assert 0.0 < link.largest_gap < link.radius
        assert link.capsule_volume > link.source_volume


def test_shipped_panda_radii_cover_the_collision_meshes() -> None:
    fit = fit_collision_capsules(_panda_urdf())
    bodies = [f"panda_link{k + 1}" for k in range(7)]
    radii = fit.link_radii(panda(), bodies=bodies, poses=20, seed=1)
    # the URDF's link frames are the modified-DH frames of panda(): the same rigid segments
    assert radii.frame_error < 1e-9
    assert np.all(np.asarray(PANDA_LINK_RADII) >= radii.radius)
    assert np.all(np.asarray(PANDA_LINK_RADII) - radii.radius < 1e-3)  # rounded up to the mm
    assert "| 4 | panda_link5 | 0.0 |" in radii.table()


def test_panda_capsules_contain_the_meshes_at_random_poses() -> None:
    # End to end, outside the fit: the mesh vertices MuJoCo places in the world at a random
    # pose lie in panda(radius=PANDA_LINK_RADII)'s capsules at the same pose.
    src = _panda_urdf()
    robot = panda(radius=PANDA_LINK_RADII)
    m = src.model
    rng = np.random.default_rng(11)
    lim = robot.joint_limits
    for _ in range(5):
        q = rng.uniform(lim[:, 0], lim[:, 1])
        qs = np.zeros(src.dof)
        qs[:7] = q
        seg = robot.link_segments(q)
        import mujoco

        data = mujoco.MjData(m)
        data.qpos[:] = qs
        mujoco.mj_kinematics(m, data)
        for k in range(7):
            g = int(m.body(f"panda_link{k + 1}").geomadr[0])
            mid = int(m.geom_dataid[g])
            v = m.mesh_vert[m.mesh_vertadr[mid] : m.mesh_vertadr[mid] + m.mesh_vertnum[mid]]
            world = data.geom_xpos[g] + v @ data.geom_xmat[g].reshape(3, 3).T
            gap = _inside(world, seg[k, 0], seg[k, 1], PANDA_LINK_RADII[k])
            assert np.max(gap) <= 1e-9


def test_ur5_meshes_match_its_dh_table_but_not_the_ur5e() -> None:
    root = _example_robot_data()
    src = MujocoRobot.from_urdf(
        root / "ur_description" / "urdf" / "ur5_robot.urdf",
        package_paths=[root.parent.parent],
        meshes="collision",
        tcp_link="tool0",
    )
    fit = fit_collision_capsules(src)
    h = math.pi / 2
    rows = [
        [0.0, h, 0.089159, 0.0],
        [-0.425, 0.0, 0.0, 0.0],
        [-0.39225, 0.0, 0.0, 0.0],
        [0.0, h, 0.10915, 0.0],
        [0.0, -h, 0.09465, 0.0],
        [0.0, 0.0, 0.0823, 0.0],
    ]
    xml = dh_mjcf(rows, joint_limits=[[-6.0, 6.0]] * 6)
    for i, name in enumerate(src.joint_names):
        xml = xml.replace(f'<joint name="joint{i}" ', f'<joint name="{name}" ', 1)
    ur5 = MujocoRobot.from_xml(xml)
    # the DH base is ur_description's "base" link (base_link turned by π): matched, 1e-11 m
    assert fit.link_radii(ur5, bodies=_UR5_BODIES, base="base").frame_error < 1e-9
    assert fit.link_radii(ur5, bodies=_UR5_BODIES).frame_error > 1.0  # without: turned by π
    # the UR5e's dimensions differ (d1 0.1625 vs 0.089159 m …): its frames do not match
    assert fit.link_radii(ur5e(), bodies=_UR5_BODIES, base="base").frame_error > 0.05


def test_gymnasium_reacher_capsules_fit_back() -> None:
    # Gymnasium's Reacher: each arm link is one capsule geom given by fromto; a tcp site added.
    from importlib import resources

    gym_assets = pytest.importorskip("gymnasium.envs.mujoco").__name__
    text = (resources.files(gym_assets) / "assets" / "reacher.xml").read_text()
    text = text.replace(
        '<body name="fingertip" pos="0.11 0 0">',
        '<body name="fingertip" pos="0.11 0 0"><site name="tcp"/>',
    )
    robot = MujocoRobot.from_xml(text)
    fit = fit_collision_capsules(robot)
    for body in ("body0", "body1"):
        link = fit[body]
        assert link.radius == pytest.approx(0.01, abs=1e-12)
        np.testing.assert_allclose(
            sorted([link.start.tolist(), link.end.tolist()]), [[0, 0, 0], [0.1, 0, 0]], atol=1e-9
        )
        assert link.largest_gap == pytest.approx(0.0, abs=1e-4)
    assert fit["fingertip"].radius == pytest.approx(0.01)
    # walls and targets (world body, contype 0) are not links
    assert {k.body for k in fit.links} == {"body0", "body1", "fingertip"}


def test_urdf_meshes_option_is_checked(tmp_path: Path) -> None:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text('<robot name="a"><link name="l"/></robot>', encoding="utf-8")
    with pytest.raises(InvalidParameter, match=r"^meshes: expected True, False or 'collision'"):
        MujocoRobot.from_urdf(urdf, meshes="visual")  # type: ignore[arg-type]


@pytest.mark.parametrize("backend", ["python", "c"])
def test_filter_keeps_the_fitted_panda_capsules_off_an_obstacle(backend: str) -> None:
    # The per-link radii reach the filter (both backends): pushed down onto a sphere, the
    # arm stops with every capsule outside it.
    from velfence.filter import JointLimits, SafetyFilter, SphereObstacle

    if backend == "c":
        pytest.importorskip("velfence_core")
    robot = panda(radius=PANDA_LINK_RADII)
    q = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
    lim = robot.joint_limits
    obstacle = SphereObstacle(center=robot.fk(q) + np.array([0.0, 0.0, -0.45]), radius=0.05)
    f = SafetyFilter(
        robot,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5)),
        obstacles=[obstacle],
        dt=0.002,
        backend=backend,
    )
    closest = math.inf
    for _ in range(600):
        q = q + 0.002 * np.asarray(f.filter_twist(q, np.array([0.0, 0.0, -0.4])))
        seg = robot.link_segments(q)
        gaps = [
            _inside(obstacle.center[None], seg[k, 0], seg[k, 1], PANDA_LINK_RADII[k])[0]
            for k in range(7)
        ]
        closest = min(closest, min(gaps) - obstacle.radius)
    assert closest >= -1e-9  # never inside
    assert closest < 1e-3  # it did come down onto the sphere
