"""Specs of velfence.robots."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from harness import C, F, call

from velfence.robots import dh_mjcf

_XML = dh_mjcf([[0.0, 0.0, 0.5, 0.0], [0.3, 0.0, 0.0, 0.0]], [[-1.0, 1.0], [-2.0, 2.0]])
_FILE = Path(tempfile.mkdtemp(prefix="velfence-robots-")) / "arm.xml"
_FILE.write_text(_XML, encoding="utf-8")
_Q2 = np.array([0.3, -0.4])
_ROWS = [[0.0, 0.0, 0.5, 0.0], [0.3, 0.5, 0.1, 0.0]]
_LIM = [[-1.0, 1.0], [-2.0, 2.0]]
_MAKER = {"tool": "vector", "radius": "nonneg"}
_SKIP = {"named_points": "a mapping name -> joint index ({} is valid); tests/robots checks it"}
_ROBOT_METHODS = {
    "fk": F(lambda: call(_Q2, "joint1"), types={"point": "choice"}),
    "jacobian": F(lambda: call(_Q2, "joint1"), types={"point": "choice"}),
    "angular_jacobian": lambda: call(_Q2),
    "from_xml": F(lambda: call(_XML), types={"text": "path"}),
    "from_file": F(lambda: call(_FILE), types={"path": "path"}),
    "joint_positions": lambda: call(_Q2),
    "link_segments": lambda: call(_Q2),
    "point_jacobian": F(lambda: call(_Q2, 1, 0.5), types={"link": "count", "t": "nonneg"}),
    "end_effector": lambda: call(_Q2),
    "ee_jacobian": lambda: call(_Q2),
}

SPECS: dict[str, F | C] = {
    "robots.MujocoRobot": C(
        F(lambda: call(xml=_XML), types={"xml": "path"}),
        _ROBOT_METHODS,
    ),
    "robots.dh_mjcf": F(
        lambda: call(_ROWS, _LIM, [0.0, 0.0, 0.1], "arm", radius=0.02),
        types={"dh_rows": "rows", "joint_limits": "rows", "name": "text", **_MAKER},
        skip=_SKIP,
    ),
    "robots.mdh_mjcf": F(
        lambda: call(_ROWS, _LIM, [0.0, 0.0, 0.1], "arm", flange_d=0.1, radius=0.02),
        types={
            "mdh_rows": "rows",
            "joint_limits": "rows",
            "name": "text",
            "flange_d": "scalar",
            **_MAKER,
        },
        skip=_SKIP,
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
