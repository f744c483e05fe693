"""MujocoRobot.chain_frames: a serial MJCF arm runs the filter's whole cycle in C.

The C cycle on the chain as frames (``ChainFrames``) against the Python route on MuJoCo's own
kinematics (``backend="python"``): the same rows (names, ``G``, ``b``) and the same outputs (to
1e-9 relative) on the shipped Panda with a TCP box and two spheres near the links, and on an MJCF
written here with a joint offset from its body, an intermediate body without joints, a slide
joint, a tilted axis and a hinge ``ref``. A branching model gives ``None`` (the Python route).
"""

from __future__ import annotations

import numpy as np
import pytest

from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter
from velfence.filter import ChainFrames, JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.robots import MujocoRobot, panda

pytest.importorskip("mujoco")
pytest.importorskip("velfence_core._filter")
#: The compared states start anywhere, inside a limit or beyond it: the start warning is not the
#: point (tests/filter/test_start_in_violation.py is).
pytestmark = pytest.mark.filterwarnings("ignore::velfence.errors.StartedInViolation")

_ODD = """
<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="base" pos="0.1 0 0.2" quat="0.9659 0 0 0.2588">
      <joint name="a" type="hinge" axis="0 0 1" pos="0.02 0 0" range="-2 2" ref="0.3"/>
      <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04"/>
      <body name="spacer" pos="0 0 0.3" quat="0.7071 0.7071 0 0">
        <body name="l2" pos="0 0.05 0">
          <joint name="b" type="hinge" axis="0 0.6 0.8" range="-1.5 1.5"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
          <body name="l3" pos="0.3 0 0">
            <joint name="c" type="slide" axis="1 0 0" range="-0.1 0.2"/>
            <geom type="box" size="0.02 0.02 0.02"/>
            <body name="tip" pos="0.1 0 0.05">
              <site name="tcp" pos="0.02 0.01 0"/>
              <site name="mid" pos="-0.05 0 0"/>
            </body>
          </body>
        </body>
      </body>
    </body>
    <site name="origin" pos="0 0 0.5"/>
  </worldbody>
</mujoco>
"""


def _compare(robot: MujocoRobot, q0: np.ndarray, obstacles: list[SphereObstacle]) -> None:
    lim = robot.joint_limits
    n = robot.dof
    p0 = robot.fk(q0)

    def make(backend: str) -> SafetyFilter:
        return SafetyFilter(
            robot,
            limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(n, 1.5),
                               max_acceleration=np.full(n, 10.0)),
            workspace=WorkspaceLimit(ConvexPolytope.box(p0 - 0.12, p0 + 0.12), buffer=0.05),
            obstacles=obstacles, dt=0.002, backend=backend,  # type: ignore[arg-type]
        )  # fmt: skip

    fc, fp = make("auto"), make("python")
    assert fc.cycle_in_c  # the C cycle runs
    assert not fp.cycle_in_c
    rng = np.random.default_rng(3)
    changed = 0
    for _ in range(150):
        q = q0 + rng.normal(size=n) * 0.25
        u = rng.normal(size=n) * rng.choice([0.2, 1.0, 5.0])
        a, b = fc.explain(q, u), fp.explain(q, u)
        assert a.constraint_names == b.constraint_names
        np.testing.assert_allclose(a.rows[0], b.rows[0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.rows[1], b.rows[1], rtol=0, atol=1e-9)
        scale = 1.0 + float(np.abs(u).max())
        np.testing.assert_allclose(a.output, b.output, rtol=0, atol=1e-9 * scale)
        assert [nm for nm, _ in a.violations] == [nm for nm, _ in b.violations]
        np.testing.assert_allclose(
            [d for _, d in a.violations], [d for _, d in b.violations], rtol=0, atol=1e-9
        )
        changed += not np.array_equal(a.output, u)
    assert changed > 20  # the rows did bind


def test_panda_c_cycle_equals_mujoco_python_route() -> None:
    robot = panda(tool=[0.0, 0.0, 0.1], radius=0.05)
    q0 = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
    p0 = robot.fk(q0)
    frames = robot.chain_frames()
    assert isinstance(frames, ChainFrames)
    assert frames.joints.shape == (7, 17)
    assert set(frames.points) == set(robot.points)
    _compare(robot, q0, [SphereObstacle(p0 + np.array([0.1, 0.1, 0.2]), radius=0.05),
                         SphereObstacle([0.2, 0.0, 0.5], radius=0.05)])  # fmt: skip


def test_offset_joints_slide_and_jointless_bodies() -> None:
    robot = MujocoRobot.from_xml(_ODD)
    f = robot.chain_frames()
    assert f is not None
    assert f.points["origin"][0] == -1.0  # a world site: the base frame
    assert f.joints[2, 15] == 1.0  # the slide
    assert f.joints[0, 16] == pytest.approx(-0.3)  # the hinge's ref
    _compare(robot, np.array([0.4, 0.3, 0.05]), [])


def test_branching_model_gives_none() -> None:
    xml = _ODD.replace(
        '<site name="origin" pos="0 0 0.5"/>',
        '<body name="side"><joint name="d" type="hinge" axis="1 0 0"/>'
        '<geom type="sphere" size="0.01"/></body>',
    )
    assert MujocoRobot.from_xml(xml).chain_frames() is None


def test_frames_fk_is_mujocos_at_every_site() -> None:
    robot = panda(tool=[0.0, 0.0, 0.1], radius=0.05)
    frames = robot.chain_frames()
    assert frames is not None
    rng = np.random.default_rng(5)
    lim = robot.joint_limits
    for _ in range(20):
        q = rng.uniform(lim[:, 0], lim[:, 1])
        for name in robot.points:
            np.testing.assert_allclose(frames.fk(q, name), robot.fk(q, name), atol=1e-12)
    odd = MujocoRobot.from_xml(_ODD)  # a slide, a ref, an offset joint, a world site
    f = odd.chain_frames()
    assert f is not None
    for q in ([0.4, 0.3, 0.05], [-1.0, 1.2, -0.1]):
        for name in odd.points:
            np.testing.assert_allclose(f.fk(q, name), odd.fk(q, name), atol=1e-12)
    with pytest.raises(InvalidInput, match="point"):
        f.fk([0.0, 0.0, 0.0], "nowhere")
    with pytest.raises(InvalidInput, match="q"):
        f.fk([0.0, np.nan, 0.0])


_BRANCHED = _ODD.replace(
    '<site name="origin" pos="0 0 0.5"/>',
    '<site name="origin" pos="0 0 0.5"/><body name="side" pos="0.3 0 0">'
    '<joint name="d" type="hinge" axis="1 0 0"/><geom type="sphere" size="0.01"/>'
    '<site name="joint0" pos="0 0 0"/></body>',
)


def test_arm_fixes_the_other_joints_and_adds_sites_and_capsules() -> None:
    full = MujocoRobot.from_xml(_BRANCHED)
    assert full.chain_frames() is None  # a branch
    arm = full.arm(["a", "b"], points={"elbow": 1}, link_radius=0.025)
    assert arm.joint_names == ("a", "b")
    f = arm.chain_frames()
    assert f is not None  # "c" (the slide) and "d" are fixed: one chain again
    np.testing.assert_array_equal(arm.link_radius, [0.04, 0.03])  # the model's own are larger
    thin = full.arm(["a", "b"], link_radius=0.05)
    np.testing.assert_array_equal(thin.link_radius, [0.05, 0.05])
    rng = np.random.default_rng(2)
    for _ in range(10):
        q = rng.uniform([-2.0, -1.5], [2.0, 1.5])
        qf = np.array([*q, 0.0, 0.0])  # the removed joints at zero
        for name in ("tcp", "mid", "origin"):
            np.testing.assert_allclose(arm.fk(q, name), full.fk(qf, name), atol=1e-12)
            np.testing.assert_allclose(f.fk(q, name), full.fk(qf, name), atol=1e-12)
        # The joint sites and the named point sit on the joints' anchors (MuJoCo's xanchor).
        import mujoco

        d = mujoco.MjData(full.model)
        d.qpos[:] = qf
        mujoco.mj_kinematics(full.model, d)
        np.testing.assert_allclose(arm.fk(q, "joint0"), d.xanchor[0], atol=1e-12)
        np.testing.assert_allclose(arm.fk(q, "joint1"), d.xanchor[1], atol=1e-12)
        np.testing.assert_allclose(arm.fk(q, "elbow"), d.xanchor[1], atol=1e-12)
        seg = arm.link_segments(q)
        np.testing.assert_allclose(seg[1, 1], full.fk(qf, "tcp"), atol=1e-12)  # last link: tcp
    assert arm.model.nu == 0
    for bad, match in [
        (dict(joints=["b", "a"]), "model order"),
        (dict(joints=["a", "x"]), r"joints\[1\]"),
        (dict(joints=[]), "model order"),
        (dict(joints=["a"], points={"mid": 0}), "new site names"),
        (dict(joints=["a"], points={"joint3": 0}), "new site names"),
        (dict(joints=["a"], points={"p": 1}), r"points\['p'\]"),
        (dict(joints=["a"], link_radius=-1.0), "link_radius"),
    ]:
        with pytest.raises(InvalidParameter, match=match):
            full.arm(**bad)  # type: ignore[arg-type]


#: _BRANCHED as a scene rather than a robot: no "tcp" site, a free box, a motor, a long number.
_SCENE = (
    _BRANCHED.replace('<site name="tcp" pos="0.02 0.01 0"/>', "")
    .replace('pos="0.3 0 0">', 'pos="0.30000000123456789 0 0">', 1)
    .replace(
        "</worldbody>",
        '<body name="box" pos="1 0.5 0.2"><freejoint name="float"/>'
        '<geom type="box" size="0.05 0.05 0.05"/></body></worldbody>'
        '<actuator><motor joint="a"/><motor joint="d"/></actuator>',
    )
)


def test_arm_from_a_scene_puts_the_tcp_on_a_body() -> None:
    import mujoco

    scene = mujoco.MjModel.from_xml_string(_SCENE)  # MuJoCo's own reading of the scene
    assert scene.nsite
    assert scene.jnt_type[-1] == mujoco.mjtJoint.mjJNT_FREE
    off = np.array([0.02, 0.01, 1e-3 / 3])
    arm = MujocoRobot.arm_from_xml(_SCENE, ["a", "b"], tcp=("tip", off), link_radius=0.02)
    assert arm.joint_names == ("a", "b")
    assert arm.points[0] == "tcp"
    assert arm.model.nu == 0
    l3 = scene.body("l3").id
    assert arm.model.body_pos[arm.model.body("l3").id][0] == scene.body_pos[l3][0]  # as written
    assert arm.model.body_pos[arm.model.body("l3").id][0] != 0.3
    f = arm.chain_frames()
    assert f is not None
    d = mujoco.MjData(scene)
    tip = scene.body("tip").id
    rng = np.random.default_rng(4)
    for _ in range(10):
        q = rng.uniform([-2.0, -1.5], [2.0, 1.5])
        d.qpos[:] = scene.qpos0
        d.qpos[:2] = q
        mujoco.mj_kinematics(scene, d)
        ref = d.xpos[tip] + d.xmat[tip].reshape(3, 3) @ off
        np.testing.assert_allclose(arm.fk(q), ref, rtol=0, atol=1e-12)
        np.testing.assert_allclose(f.fk(q), ref, rtol=0, atol=1e-12)
        np.testing.assert_allclose(arm.link_segments(q)[1, 1], ref, rtol=0, atol=1e-12)
    # tcp= through arm() of a robot: the site moves (to l3's point that is tip's origin).
    full = MujocoRobot.from_xml(_BRANCHED)
    moved = full.arm(["a", "b"], tcp=("l3", [0.1, 0.0, 0.05]))
    assert moved.points.count("tcp") == 1
    q = np.array([0.7, -0.4])
    dd = mujoco.MjData(full.model)
    dd.qpos[:] = [*q, 0.0, 0.0]
    mujoco.mj_kinematics(full.model, dd)
    np.testing.assert_allclose(moved.fk(q), dd.xpos[full.model.body("tip").id], atol=1e-12)
    with pytest.raises(InvalidParameter, match="no 'tcp' site"):
        MujocoRobot.arm_from_xml(_SCENE, ["a", "b"])
    for bad, match in [
        (dict(tcp=("nowhere", [0, 0, 0])), "tcp: expected a body"),
        (dict(tcp=("tip", [0, 0])), "tcp offset"),
        (dict(tcp=("tip", [0, np.nan, 0])), "tcp offset"),
        (dict(tcp="tip"), r"tcp: expected \(body name"),
        (dict(tcp=("tip", off), points={"tcp": 0}), "new site names"),
        (dict(tcp=("tip", off), joints=["b", "a"]), "model order"),
    ]:
        with pytest.raises(InvalidParameter, match=match):
            MujocoRobot.arm_from_xml(_SCENE, **{"joints": ["a", "b"], **bad})  # type: ignore[arg-type]
    with pytest.raises(InvalidGeometry, match="hinge or slide"):
        MujocoRobot.arm_from_xml(_SCENE, ["a", "float"], tcp=("tip", off))
    with pytest.raises(InvalidGeometry, match="compiles"):
        MujocoRobot.arm_from_xml("<mujoco><nonsense/></mujoco>", ["a"], tcp=("tip", off))
    with pytest.raises(InvalidParameter, match="xml"):
        MujocoRobot.arm_from_xml(b"<mujoco/>", ["a"])  # type: ignore[arg-type]


def test_an_arm_cut_again_is_a_model_of_its_own_equal_to_the_first() -> None:
    """The same arm cut twice from the same document: the second is read back (no second edit
    and no second compile), but each robot owns its model: a change to one leaves the other."""
    off = np.array([0.02, 0.01, 0.0])
    first = MujocoRobot.arm_from_xml(_SCENE, ["a", "b"], tcp=("tip", off), link_radius=0.02)
    again = MujocoRobot.arm_from_xml(_SCENE, ["a", "b"], tcp=("tip", off), link_radius=0.02)
    assert again.model is not first.model
    q = np.array([0.3, -0.8])
    assert np.array_equal(first.fk(q), again.fk(q))
    assert np.array_equal(first.jacobian(q), again.jacobian(q))
    other = MujocoRobot.arm_from_xml(_SCENE, ["a", "b"], tcp=("tip", off), link_radius=0.03)
    assert other.model.ngeom == first.model.ngeom
    assert not np.array_equal(other.model.geom_size, first.model.geom_size)  # its own radius
    again.model.body_pos[again.model.body("l3").id] += 1.0
    assert not np.array_equal(first.fk(q), again.fk(q))
    third = MujocoRobot.arm_from_xml(_SCENE, ["a", "b"], tcp=("tip", off), link_radius=0.02)
    assert np.array_equal(first.fk(q), third.fk(q))  # the remembered model was not touched
