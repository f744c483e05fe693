"""Specs of velfence.robots."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from harness import C, F, call

from velfence.robots import dh_mjcf

_XML = dh_mjcf(
    [[0.0, 0.0, 0.5, 0.0], [0.3, 0.0, 0.0, 0.0]],
    joint_limits=[[-1.0, 1.0], [-2.0, 2.0]],
    velocity_limits=[2.0, 3.0],
    jerk_limits=[500.0, 600.0],
)
_FILE = Path(tempfile.mkdtemp(prefix="velfence-robots-")) / "arm.xml"
_FILE.write_text(_XML, encoding="utf-8")
_URDF = _FILE.with_name("arm.urdf")
_URDF.write_text(
    '<robot name="r"><link name="base"/><link name="tip"><inertial><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
    '<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>'
    '<origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>'
    '<limit lower="-1" upper="1" effort="5" velocity="2"/></joint></robot>',
    encoding="utf-8",
)
_Q2 = np.array([0.3, -0.4])
_ROWS = [[0.0, 0.0, 0.5, 0.0], [0.3, 0.5, 0.1, 0.0]]
_LIM = [[-1.0, 1.0], [-2.0, 2.0]]
_MAKER = {"tool": "vector", "radius": "nonneg"}
_SKIP = {"named_points": "a mapping name -> joint index ({} is valid); tests/robots checks it"}
_ARM_SKIP = {"points": "a mapping name -> joint index ({} is valid); tests/robots checks it"}
#: radius= takes one radius per link too: [1.0, 2.0] is valid on the two-link arms below.
_PER_LINK = {"radius": {"vector_for_scalar": "one radius per link (documented), two links here"}}
_ROBOT_METHODS = {
    "fk": F(lambda: call(_Q2, "joint1"), types={"point": "choice"}),
    "jacobian": F(lambda: call(_Q2, "joint1"), types={"point": "choice"}),
    "angular_jacobian": lambda: call(_Q2),
    "kinematics": lambda: call(_Q2),
    "chain_data": lambda: call(),
    "chain_frames": lambda: call(),
    "limits": lambda: call(),
    "joint_positions": lambda: call(_Q2),
    "link_segments": lambda: call(_Q2),
    "end_effector": lambda: call(_Q2),
    "ee_jacobian": lambda: call(_Q2),
    "point_jacobian": F(lambda: call(_Q2, 1, 0.5), types={"t": "scalar", "link": "seed"}),
    "from_xml": F(lambda: call(_XML), types={"text": "path"}),
    "arm": F(
        lambda: call(["joint1"], points={"p": 0}, link_radius=0.02, tcp=("link1", [0.3, 0, 0])),
        types={"tcp": "object"},
        skip=_ARM_SKIP,
    ),
    "arm_from_xml": F(
        lambda: call(
            _XML,
            ["joint0", "joint1"],
            tcp=("flange", [0.0, 0.0, 0.1]),
            points={"p": 1},
            link_radius=0.02,
        ),
        types={"xml": "path", "tcp": "object"},
        skip=_ARM_SKIP,
    ),
    "from_file": F(lambda: call(_FILE), types={"path": "path"}),
    "from_urdf": F(
        lambda: call(
            _URDF,
            package_paths=[str(_FILE.parent)],
            tcp_link="tip",
            tool=[0.0, 0.0, 0.1],
            meshes=False,
        ),
        types={"path": "path", "tcp_link": "choice", "meshes": "flag"},
        skip={
            "package_paths": "a sequence of directories (() is valid); "
            "tests/robots/test_urdf.py checks it"
        },
    ),
}
_PHYSICS = {
    "masses": [2.0, 1.0],
    "centers_of_mass": [[0.0, 0.0, -0.2], [-0.1, 0.0, 0.0]],
    "inertias": [[0.02, 0.02, 0.01], [0.01, 0.02, 0.02]],
    "velocity_limits": [2.0, 3.0],
    "effort_limits": [50.0, 20.0],
    "acceleration_limits": [10.0, 12.0],
    "jerk_limits": [500.0, 600.0],
}
_PHYSICS_TYPES = {
    "masses": "vector",
    "centers_of_mass": "rows",
    "inertias": "rows",
    "velocity_limits": "vector",
    "effort_limits": "vector",
    "acceleration_limits": "vector",
    "jerk_limits": "vector",
}

SPECS: dict[str, F | C] = {
    "robots.MujocoRobot": C(
        F(lambda: call(xml=_XML), types={"xml": "path"}),
        _ROBOT_METHODS,
    ),
    "robots.dh_mjcf": F(
        lambda: call(
            _ROWS, joint_limits=_LIM, tool=[0.0, 0.0, 0.1], name="arm", radius=0.02, **_PHYSICS
        ),
        types={
            "dh_rows": "rows",
            "joint_limits": "rows",
            "name": "text",
            **_MAKER,
            **_PHYSICS_TYPES,
        },
        skip=_SKIP,
        required=frozenset({"masses"}),
        accepts=_PER_LINK,
    ),
    "robots.mdh_mjcf": F(
        lambda: call(
            _ROWS,
            joint_limits=_LIM,
            tool=[0.0, 0.0, 0.1],
            name="arm",
            flange_d=0.1,
            radius=0.02,
            **_PHYSICS,
        ),
        types={
            "mdh_rows": "rows",
            "joint_limits": "rows",
            "name": "text",
            "flange_d": "scalar",
            **_MAKER,
            **_PHYSICS_TYPES,
        },
        skip=_SKIP,
        required=frozenset({"masses"}),
        accepts=_PER_LINK,
    ),
    "robots.panda": F(lambda: call(tool=[0.0, 0.0, 0.1], radius=0.02), types=_MAKER),
    "robots.ur5e": F(lambda: call(tool=[0.0, 0.0, 0.1], radius=0.02), types=_MAKER),
    "robots.seven_dof": F(lambda: call(tool=[0.0, 0.0, 0.1], radius=0.02), types=_MAKER),
    "robots.puma560": F(lambda: call(tool=[0.0, 0.0, 0.1], radius=0.02), types=_MAKER),
}

# --- the closed-chain wrist (velfence.robots.wrist_model) ---
from velfence.mechanisms import WristGeometry  # noqa: E402

_WRIST_OPTS = {
    "gravity_compensation": "flag",
    "actuator_armature": "positive",
    "hard_stops": "flag",
}
SPECS.update(
    {
        "robots.wrist_mjcf": F(
            lambda: call(WristGeometry(), gravity_compensation=False, actuator_armature=1.0),
            types={"geometry": "object", **_WRIST_OPTS},
        ),
        "robots.wrist_robot": F(
            lambda: call(WristGeometry(), hard_stops=False),
            types={"geometry": "object", **_WRIST_OPTS},
        ),
        "robots.wrist_qpos": F(
            lambda: call([0.2, -0.1], WristGeometry()), types={"q": "vector", "geometry": "object"}
        ),
    }
)

# --- collision geometry from the model (velfence.robots.collision) ---
from velfence.robots import MujocoRobot, fit_collision_capsules  # noqa: E402

_FIT_XML = (
    '<mujoco><worldbody><body name="arm"><joint name="j" type="hinge"/><site name="tcp"/>'
    '<site name="joint0"/><site name="flange" pos="0 0 0.3"/>'
    '<geom type="cylinder" size="0.05 0.15" pos="0 0 0.15"/></body></worldbody></mujoco>'
)


def _fit_robot() -> MujocoRobot:
    return MujocoRobot.from_xml(_FIT_XML)


_RECORD = "output record of fit_collision_capsules()"
SPECS.update(
    {
        "robots.fit_collision_capsules": F(
            lambda: call(_fit_robot(), groups=[0], samples=32),
            types={"robot": "object", "groups": "object"},  # group numbers: integers
        ),
        "robots.CollisionFit": C(
            record=_RECORD,
            instance=lambda: fit_collision_capsules(_fit_robot(), samples=32),
            methods={
                "table": lambda: call(),
                "link_radii": F(
                    lambda: call(_fit_robot(), bodies=["arm"], base="arm", poses=2, seed=1),
                    types={"robot": "object", "bodies": "object", "base": "choice"},
                ),
            },
        ),
        "robots.LinkCapsule": C(record=_RECORD),
        "robots.LinkRadii": C(
            record="output record of CollisionFit.link_radii()",
            instance=lambda: fit_collision_capsules(_fit_robot(), samples=32).link_radii(),
            methods={"table": lambda: call()},
        ),
    }
)
