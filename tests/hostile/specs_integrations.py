"""Specs of velfence.integrations (mink's differential-IK limits)."""

from __future__ import annotations

import mink
import numpy as np
from harness import C, F, call

from velfence.geometry.polytope import ConvexPolytope
from velfence.robots import panda

_ROBOT = panda()
_MODEL = _ROBOT.model
_Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
_P0 = _ROBOT.fk(_Q0)
_BOX = ConvexPolytope.box(_P0 - 0.15, _P0 + 0.15)


def _configuration() -> mink.Configuration:
    conf = mink.Configuration(_MODEL)
    conf.update(_Q0)
    return conf


SPECS: dict[str, F | C] = {
    "integrations.PolytopeLimit": C(
        F(
            lambda: call(_MODEL, _BOX, frame_name="tcp", buffer=0.05, speed=0.5),
            types={"model": "object", "polytope": "object", "profile": "object"},
        ),
        {
            "compute_qp_inequalities": F(
                lambda: call(_configuration(), 0.01),
                types={"configuration": "object", "dt": "positive"},
            ),
        },
    ),
}

# --- the Gymnasium shield (velfence.integrations.gymnasium) on Gymnasium's Reacher-v5 ---------
# Every factory builds a fresh env (about 10 ms) and shield (about 25 ms): the wrappers hold a
# compiled filter cycle that cannot be copied, so each call gets its own.

_NONE = "documented: an empty sequence means none"
_NO_LIMIT = "documented: inf is no torque limit (a motor without ctrlrange or force range)"
_REACHER = ("joint0", "joint1")
_REACHER_LIMITS = {"joint0": (-2.5, 2.5)}  # Reacher's joint0 has no range in its MJCF
_REACHER_BOX = ConvexPolytope.box([-0.3, -0.3, -0.1], [0.3, 0.3, 0.1])


def _reacher() -> object:
    import gymnasium

    env = gymnasium.make("Reacher-v5")
    env.reset(seed=0)
    return env


def _reacher_shield(env: object | None = None) -> object:
    from velfence.integrations import mujoco_shield

    return mujoco_shield(
        _reacher() if env is None else env,
        joints=_REACHER,
        tip="fingertip",
        max_speed=2.0,
        joint_limits=_REACHER_LIMITS,
        max_acceleration=20.0,
        workspace=_REACHER_BOX,
        workspace_buffer=0.02,
    )


_FIELDS: list[dict[str, object]] = []


def _shield_fields() -> dict[str, object]:
    """The fields of a torque shield of Reacher, as ``Shield(**...)`` takes them.

    Built once per worker process: ``Shield(...)`` only checks its fields and builds nothing
    from them that it could change (a hostile value replaces one field of a copy whose arrays
    are copies).
    """
    from velfence.integrations import MujocoJointState

    if _FIELDS:
        return _fresh(_FIELDS[0])
    sh = _reacher_shield()
    fields: dict[str, object] = {
        "filter": sh.filter,  # type: ignore[attr-defined]
        "state": MujocoJointState(_REACHER),
        "action": "velocity",
        "actuation": "torque",
        "period": sh.period,  # type: ignore[attr-defined]
        "bandwidth": 50.0,
        "max_effort": np.array(sh.max_effort),  # type: ignore[attr-defined]
        "gear": np.array(sh.gear),  # type: ignore[attr-defined]
        "actuators": (0, 1),
        "twist_speed": 0.5,
        "tip_body": sh.tip_body,  # type: ignore[attr-defined]
        "tip_offset": [0.0, 0.0, 0.0],
    }
    _FIELDS.append(fields)
    return _fresh(fields)


def _fresh(fields: dict[str, object]) -> dict[str, object]:
    """A copy of ``fields`` whose arrays and lists are copies too (a kind may write to them)."""
    return {k: v.copy() if isinstance(v, (np.ndarray, list)) else v for k, v in fields.items()}


def _wrapper() -> object:
    from velfence.integrations import ShieldWrapper

    env = _reacher()
    return ShieldWrapper(env, _reacher_shield(env), penalty=0.1)


def _vector_env() -> object:
    import gymnasium

    venv = gymnasium.vector.SyncVectorEnv([lambda: gymnasium.make("Reacher-v5")] * 2)
    venv.reset(seed=0)
    return venv


def _vector_wrapper() -> object:
    from velfence.integrations import VectorShieldWrapper

    return VectorShieldWrapper(_vector_env(), _reacher_shield(), penalty=0.1, threads=1)


_OBJ = {"env": "object", "shield": "object"}
_RESET = F(
    lambda: call(seed=1, options=None),
    types={"seed": "seed", "options": "object"},
    accepts={
        "options": {
            "dict_empty": "documented: Gymnasium's reset options, {} is none",
            "dict_xy": "documented: forwarded to the env's reset, which reads its own keys",
        }
    },
)

SPECS.update(
    {
        "integrations.JointState": C(abstract="Protocol: exercised through MujocoJointState"),
        "integrations.BatchJointState": C(
            abstract="Protocol: exercised through VectorShieldWrapper(state=...) in "
            "tests/integrations/test_gymnasium.py"
        ),
        "integrations.MujocoJointState": C(
            F(lambda: call(_REACHER), types={"joint_names": "object"}),
            {
                "addresses": F(
                    lambda: call(_reacher().unwrapped.model),  # type: ignore[attr-defined]
                    types={"model": "object"},
                ),
                "selectors": F(
                    lambda: call(_reacher().unwrapped.model),  # type: ignore[attr-defined]
                    types={"model": "object"},
                ),
                "read": F(lambda: call(_reacher()), types={"env": "object"}),
            },
        ),
        "integrations.mujoco_arm": F(
            lambda: call(_reacher(), _REACHER, tip="fingertip", tip_offset=[0.0, 0.0, 0.0]),
            types={**_OBJ, "joints": "object", "tip": "choice"},
        ),
        "integrations.mujoco_shield": F(
            lambda: call(
                _reacher(),
                joints=_REACHER,
                tip="fingertip",
                max_speed=[2.0, 2.0],
                tip_offset=[0.0, 0.0, 0.0],
                joint_limits=_REACHER_LIMITS,
                max_acceleration=[20.0, 20.0],
                workspace=_REACHER_BOX,
                workspace_buffer=0.02,
                bandwidth=50.0,
                twist_speed=0.5,
            ),
            types={
                **_OBJ,
                "joints": "object",
                "tip": "choice",
                "joint_limits": "object",
                "workspace": "object",
                "obstacles": "object",
                "max_speed": "vector",
                "max_acceleration": "vector",
            },
            # Reacher's joint0 has no MJCF range: the shield refuses to start without one
            required=frozenset({"joint_limits"}),
            accepts={"obstacles": {"empty_list": _NONE, "empty_tuple": _NONE}},
        ),
        "integrations.Shield": C(
            F(
                lambda: call(**_shield_fields()),
                types={
                    "filter": "object",
                    "state": "object",
                    "bandwidth": "nonneg",
                    "max_effort": "vector",
                    "gear": "vector",
                    "actuators": "object",
                    "tip_body": "seed",  # a MuJoCo body id: 0 is the world body
                },
                # the valid call is a torque shield: these are required there
                required=frozenset({"state", "max_effort", "gear"}),
                accepts={"max_effort": {"inf_in_valid": _NO_LIMIT}},
                nonfinite={"out.max_effort": _NO_LIMIT},
            ),
        ),
        "integrations.ShieldWrapper": C(
            F(lambda: call(_reacher(), _reacher_shield(), penalty=0.1, detail=True), types=_OBJ),
            {
                "reset": _RESET,
                "step": F(lambda: call(np.array([0.1, -0.1])), types={"action": "vector"}),
            },
            instance=_wrapper,
        ),
        "integrations.VectorShieldWrapper": C(
            F(
                lambda: call(_vector_env(), _reacher_shield(), state=None, penalty=0.1, threads=1),
                types={**_OBJ, "state": "object", "threads": "seed"},
            ),
            {
                "reset": _RESET,
                "step": F(
                    lambda: call(np.array([[0.1, -0.1], [-0.2, 0.3]])),
                    types={"actions": "vector"},
                ),
            },
            instance=_vector_wrapper,
        ),
    }
)

# --- the LeRobot shield (velfence.integrations.lerobot) on the SO-101 of example-robot-data ---

_ARM: list[object] = []
_LR_SPEEDS = dict.fromkeys(
    ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"), 90.0
)
_LR_BOX = ((0.10, -0.25, 0.0), (0.42, 0.25, 0.35))
_LR_HOME = [0.0, -20.0, 20.0, 60.0, 0.0]


def _so101() -> object:
    """The SO-101 model, built once (a frozen record; so_arm itself is attacked below)."""
    if not _ARM:
        from velfence.integrations import so_arm

        _ARM.append(so_arm())
    return _ARM[0]


def _pose(deg: list[float], gripper: float = 50.0) -> dict[str, float]:
    keys = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")
    return {f"{j}.pos": float(v) for j, v in zip(keys, [*deg, gripper], strict=True)}


def _lerobot() -> object:
    from velfence.integrations import LeRobotShield

    return LeRobotShield(
        _so101(),  # type: ignore[arg-type]
        dt=1.0 / 30.0,
        max_speed=_LR_SPEEDS,
        table_height=0.0,
        workspace=_LR_BOX,
        tool_radius=0.02,
    )


_LR_DICTS = {"action": "object", "observation": "object"}
_LR_STEP = [1.0, -18.0, 22.0, 58.0, 1.0]

SPECS.update(
    {
        "integrations.so_arm": F(
            lambda: call("so101", path=None, link_radius=0.03),
            types={"model": "choice", "path": "path"},
        ),
        "integrations.LeRobotShield": C(
            F(
                lambda: call(
                    _so101(),
                    dt=1.0 / 30.0,
                    max_speed=_LR_SPEEDS,
                    table_height=0.0,
                    workspace=_LR_BOX,
                    tool_radius=0.02,
                    obstacles=(),
                    rate_limit={"gripper": "reject"},
                    joint_buffer=5.0,
                    workspace_buffer=0.02,
                    obstacle_buffer=0.03,
                ),
                types={
                    "arm": "object",
                    "max_speed": "object",
                    "workspace": "object",
                    "obstacles": "object",
                    "rate_limit": "object",
                    "calibration": "object",
                    "table_height": "scalar",  # a plane z = table_height: any height
                    "tool_radius": "nonneg",  # 0: the gripper frame's origin itself
                },
                # documented: the shield does not start while these bounds are unset
                required=frozenset({"max_speed", "table_height", "workspace", "tool_radius"}),
                accepts={
                    "obstacles": {"empty_list": _NONE, "empty_tuple": _NONE},
                    "rate_limit": {"dict_empty": "documented: a joint not named is 'clamp'"},
                },
            ),
            {
                "explain": F(
                    lambda: call(observation=_pose(_LR_HOME), action=_pose(_LR_STEP)),
                    types=_LR_DICTS,
                    # both needed: None only marks "given positionally" (the order of 0.2)
                    required=frozenset({"observation", "action"}),
                ),
                "shield": F(
                    lambda: call(observation=_pose(_LR_HOME), action=_pose(_LR_STEP)),
                    types=_LR_DICTS,
                    # both needed: None only marks "given positionally" (the order of 0.2)
                    required=frozenset({"observation", "action"}),
                ),
                "reset": lambda: call(),
                "to_radians": F(lambda: call(_pose(_LR_HOME)), types={"values": "object"}),
                "from_radians": lambda: call(np.radians(_LR_HOME)),
            },
            instance=_lerobot,
        ),
    }
)
