r"""A Gymnasium shield: the :class:`~velfence.filter.SafetyFilter` between an agent and its env.

Math contract: every ``step`` the agent's action becomes a joint-velocity command ``u`` over the
environment's control period ``T`` (``env.unwrapped.dt``): a joint velocity as given
(``action="velocity"``), ``(target - q) / T`` for a joint position target (``"position"``), or a
tool twist solved by the filter's damped least squares (``"twist"``). The filter returns the
nearest joint velocity ``x`` that meets every row (joint limits with braking, workspace
polytope, obstacle spheres, rates; ``docs/safety_filter.md``), and ``x`` goes to the
environment in its own actuation: ``x`` itself (velocity actuators), ``q + x T`` (position
actuators), or the computed-torque velocity servo's torques
(:func:`velfence.robots.servo.computed_torque`, held over the period) for torque-actuated envs
such as ``Pusher-v5`` and ``Reacher-v5``. The guarantee is on the command: the filter's rows
hold for ``x``; the servo's tracking lag and torque limits, contacts and the physics decide how
closely the simulated arm follows it (measured in ``docs/policies.md`` on MuJoCo's own state).

The joint state comes from a :class:`JointState` adapter (:class:`MujocoJointState` reads
``qpos``/``qvel`` of named joints from ``env.unwrapped.data``). :func:`mujoco_shield` builds the
filter from the env's own MJCF (:func:`mujoco_arm`: a :class:`~velfence.robots.MujocoRobot` of
the arm's joints) and its bounds from the model, refusing to start when one is unset.
:class:`ShieldWrapper` wraps one env, :class:`VectorShieldWrapper` a ``gymnasium.vector``
env with one batched filter call per step (:meth:`SafetyFilter.filter_batch`). Needs the ``gym``
extra (Gymnasium with MuJoCo).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, Protocol, runtime_checkable

from velfence._extras import missing

try:
    import gymnasium
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc
import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_choice,
    check_flag,
    check_names,
    check_positive,
    check_positive_int,
    check_seed,
    check_text,
    describe,
    readonly,
    real_array,
    require_package,
    show,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.filter.parts import obstacle_list
from velfence.geometry.polytope import ConvexPolytope
from velfence.robots import MujocoRobot
from velfence.robots.servo import computed_torque

__all__ = [
    "ActionMode",
    "Actuation",
    "BatchJointState",
    "JointState",
    "MujocoJointState",
    "Shield",
    "ShieldWrapper",
    "VectorShieldWrapper",
    "mujoco_arm",
    "mujoco_shield",
]

#: What the agent's action is: joint velocities [rad/s], joint position targets [rad], or the
#: tool point's linear velocity [m/s].
ActionMode = Literal["velocity", "position", "twist"]
#: What the wrapped environment's action is: joint velocities, joint position targets, or
#: actuator controls of joint motors (torques / gear).
Actuation = Literal["velocity", "position", "torque"]
_ACTIONS: tuple[ActionMode, ...] = ("velocity", "position", "twist")
_ACTUATIONS: tuple[Actuation, ...] = ("velocity", "position", "torque")
_ON_INVALID = ("raise", "stop")


@runtime_checkable
class JointState(Protocol):
    """Reads the arm's joint state from an environment (the shield's only view of the state).

    Attributes:
        joint_names: The arm's joints, in the filter's order.
    """

    joint_names: tuple[str, ...]

    def read(self, env: Any) -> tuple[FloatArray, FloatArray]:
        """``(positions [rad] (n,), velocities [rad/s] (n,))`` of the env's current state."""
        ...


class MujocoJointState:
    """:class:`JointState` of Gymnasium's MuJoCo envs: ``qpos``/``qvel`` of named joints.

    Reads ``env.unwrapped.data`` at the addresses of ``joint_names`` in ``env.unwrapped.model``
    (hinge and slide joints), so the shield sees MuJoCo's own state, not the observation.

    Args:
        joint_names: The arm's joints in the filter's order (names in the env's MJCF).
    """

    def __init__(self, joint_names: Sequence[str]) -> None:
        self.joint_names = check_names("joint_names", joint_names)
        self._key: Any = _UNSET
        self._qadr = np.zeros(0, dtype=np.int64)
        self._vadr = np.zeros(0, dtype=np.int64)

    def addresses(self, model: Any) -> tuple[Any, Any]:
        """``(qpos addresses, dof addresses)`` of the joints in ``model`` (a ``mujoco.MjModel``).

        Raises:
            InvalidParameter: not a MuJoCo model, or a joint is not in the model or is not a
                hinge or slide.
        """
        if self._key is not model:
            ids = _joint_ids("joint_names", model, self.joint_names)
            self._qadr = np.array([int(model.jnt_qposadr[i]) for i in ids])
            self._vadr = np.array([int(model.jnt_dofadr[i]) for i in ids])
            self._qsel = _as_slice(self._qadr)
            self._vsel = _as_slice(self._vadr)
            self._key = model
        return self._qadr, self._vadr

    def selectors(self, model: Any) -> tuple[Any, Any]:
        """:meth:`addresses` as slices where they are contiguous (faster to read)."""
        self.addresses(model)
        return self._qsel, self._vsel

    def read(self, env: Any) -> tuple[FloatArray, FloatArray]:
        """``(qpos, qvel)`` of the joints, copies, shape (n,) each.

        Raises:
            InvalidParameter: ``env`` is not a Gymnasium MuJoCo env (``env.unwrapped.model`` and
                ``.data``) or lacks a joint.
        """
        try:
            u = env.unwrapped
            m, d = u.model, u.data
        except AttributeError:
            raise InvalidParameter(
                f"env: expected a Gymnasium MuJoCo env (env.unwrapped.model and .data), got "
                f"{describe(env)}"
            ) from None
        qa, va = self.selectors(m)
        if not isinstance(d, _mujoco().MjData):
            raise InvalidParameter(f"env: expected MuJoCo data in env.unwrapped.data, got "
                                   f"{describe(d)}")  # fmt: skip
        return np.array(d.qpos[qa], dtype=np.float64), np.array(d.qvel[va], dtype=np.float64)


#: No model seen yet (``None`` is a model argument to refuse, not a cache key).
_UNSET: Any = object()


def _joint_ids(arg: str, model: Any, names: tuple[str, ...]) -> list[int]:
    """The joint ids of ``names`` in a MuJoCo ``model``, every one a hinge or a slide."""
    mj = _mujoco()
    if not isinstance(model, mj.MjModel):
        raise InvalidParameter(f"model: expected a mujoco.MjModel (env.unwrapped.model), got "
                               f"{describe(model)}")  # fmt: skip
    known = [model.joint(i).name for i in range(model.njnt)]
    bad = [s for s in names if s not in known]
    if bad:
        raise InvalidParameter(f"{arg}: {bad} are not joints of the env's model; it has {known}")
    ids = [known.index(s) for s in names]
    if any(int(model.jnt_type[i]) not in (2, 3) for i in ids):  # slide 2, hinge 3
        raise InvalidParameter(f"{arg}: expected hinge or slide joints only")
    return ids


def _unwrapped(env: Any) -> Any:
    """``env.unwrapped`` of a Gymnasium MuJoCo env (its ``fullpath``, ``model`` and ``data``)."""
    mj = _mujoco()
    u = getattr(env, "unwrapped", None)
    if (
        not isinstance(getattr(u, "fullpath", None), str)
        or not isinstance(getattr(u, "model", None), mj.MjModel)
        or not isinstance(getattr(u, "data", None), mj.MjData)
    ):
        raise InvalidParameter(
            "env: expected a Gymnasium MuJoCo env (env.unwrapped.fullpath, .model and .data), "
            f"got {describe(env)}"
        )
    return u


def _as_slice(idx: Any) -> Any:
    """``idx`` as a slice when it is a contiguous ascending run, else as it is."""
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx


def _mujoco() -> Any:
    return require_package("env", "mujoco", extra="gym", what="the Gymnasium MuJoCo shield")


def mujoco_arm(
    env: Any, joints: Sequence[str], *, tip: str, tip_offset: ArrayLike = (0.0, 0.0, 0.0)
) -> MujocoRobot:
    """The arm of a Gymnasium MuJoCo env as a :class:`~velfence.robots.MujocoRobot`.

    Read from the env's own MJCF file (``env.unwrapped.fullpath``) by
    :meth:`MujocoRobot.arm_from_xml <velfence.robots.MujocoRobot.arm_from_xml>`, its numbers as
    written: every joint not in ``joints`` is removed (the object, the goal: their bodies stay,
    fixed), a site ``"tcp"`` is put on the body ``tip`` at ``tip_offset`` (by default its
    origin, the point Gymnasium's tasks measure: ``get_body_com`` is the body's ``xpos``) and a
    site ``"joint{i}"`` on each joint's anchor (the capsule links of the obstacle rows). The
    result is checked against the env: the tcp at the env's current ``qpos`` equals MuJoCo's
    own point (``xpos + xmat · tip_offset`` of ``tip``) to 1e-9 m.

    Args:
        env: A Gymnasium MuJoCo env (or a wrapper of one).
        joints: The arm's joints, in the order of the filter (and of the action): the
            model's order.
        tip: The body that carries the tool point (``"tips_arm"`` for Pusher,
            ``"fingertip"`` for Reacher).
        tip_offset: The tool point in the body's frame [m], shape (3,) (Pusher's finger
            spheres are at x = 0.1 m ahead of ``tips_arm``'s origin).

    Returns:
        The arm, with the sites ``"tcp"`` and ``"joint0"`` … (its ``chain_frames()`` lets the
        filter run its whole cycle in C).

    Raises:
        InvalidParameter: the env has no MJCF file, a joint or the body is unknown, or the
            arm read back does not match the env's kinematics.
    """
    mj = _mujoco()
    u = _unwrapped(env)
    path, model = u.fullpath, u.model
    names = check_names("joints", joints)
    _joint_ids("joints", model, names)
    state = MujocoJointState(names)
    tip = check_text("tip", tip, max_length=200)
    try:
        bid = model.body(tip).id
    except KeyError:
        bodies = [model.body(i).name for i in range(model.nbody)]
        raise InvalidParameter(f"tip: {tip!r} is not a body of the env; it has {bodies}") from None
    off = real_array("tip_offset", tip_offset, (3,), what="a position [m]",
                     error=InvalidParameter)  # fmt: skip
    try:
        with open(path, encoding="utf-8") as fh:
            text = fh.read()
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InvalidParameter(
            f"env: expected the env's MJCF file to be readable, got {path[:200]!r} "
            f"({type(exc).__name__})"
        ) from None
    robot = MujocoRobot.arm_from_xml(text, names, tcp=(tip, off))
    q, _ = state.read(env)
    tcp = robot.fk(q)
    mj.mj_kinematics(model, u.data)
    mj.mj_comPos(model, u.data)
    ref = _tip_point(u.data, bid, off)
    if not np.all(np.abs(tcp - ref) <= 1e-9):
        raise InvalidParameter(
            f"joints: the arm's tcp {tcp.tolist()} differs from the env's point on {tip!r} "
            f"{ref.tolist()}"
        )
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    mj.mj_jac(model, u.data, jacp, jacr, ref, bid)
    others = np.ones(model.nv, dtype=bool)
    others[state.addresses(model)[1]] = False
    moving = [model.joint(int(model.dof_jntid[k])).name for k in np.flatnonzero(others)
              if np.any(jacp[:, k] != 0.0) or np.any(jacr[:, k] != 0.0)]  # fmt: skip
    if moving:
        raise InvalidParameter(
            f"joints: the joint(s) {moving} move {tip!r} and are missing from joints"
        )
    return robot


def _tip_point(data: Any, body: int, offset: FloatArray) -> FloatArray:
    """MuJoCo's own position of a point fixed on a body [m] (``xpos + xmat · offset``)."""
    R = np.asarray(data.xmat[body], dtype=np.float64).reshape(3, 3)
    return np.asarray(data.xpos[body], dtype=np.float64) + R @ offset


@dataclass(frozen=True, eq=False, kw_only=True)
class Shield:
    """Everything a shield wrapper needs: the filter and how actions map to the env.

    Usually built by :func:`mujoco_shield` from a Gymnasium MuJoCo env; built directly (every
    argument by keyword), each field is checked as :func:`mujoco_shield` would set it.

    Attributes:
        filter: The :class:`~velfence.filter.SafetyFilter` (its ``dt``, when set, the control
            period).
        state: The :class:`JointState` adapter (one joint name per filter joint), or ``None``:
            no reader of one env, for a :class:`VectorShieldWrapper` given its own
            :class:`BatchJointState` (velocity or position actuation only).
        action: :data:`ActionMode`, what the agent sends.
        actuation: :data:`Actuation`, what the env takes.
        period: The env's control period ``T`` [s] (one ``step``), > 0.
        bandwidth: The torque servo's bandwidth [rad/s], >= 0; > 0 with ``actuation="torque"``.
        max_effort: The servo's torque limits per joint [N·m], shape (n,), > 0 (``inf``: none);
            required with ``actuation="torque"``.
        gear: Per joint, the actuator's gear (control = torque / gear), shape (n,), finite and
            non-zero; required with ``actuation="torque"``.
        actuators: Per joint, the index of its actuator in the env's action (torque and
            position actuation): n distinct ints >= 0, or ``None``: the action is ordered as the
            joints.
        twist_speed: The largest tool speed the ``"twist"`` action space allows [m/s], > 0.
        tip_body: The MuJoCo body id that carries the ``"tcp"`` (an int >= 0), or ``None``
            (other envs: the robot's ``fk``).
        tip_offset: The ``"tcp"`` in that body's frame [m], shape (3,) (``None`` with a
            ``tip_body``: its origin).

    Raises:
        InvalidParameter: a field that is not what it says above (the message names it).
    """

    filter: SafetyFilter
    state: JointState | None
    action: ActionMode
    actuation: Actuation
    period: float
    bandwidth: float = 0.0
    max_effort: FloatArray | None = None
    gear: FloatArray | None = None
    actuators: tuple[int, ...] | None = None
    twist_speed: float = 1.0
    tip_body: int | None = None
    tip_offset: FloatArray | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.filter, SafetyFilter):
            raise InvalidParameter(
                f"filter: expected a velfence.filter.SafetyFilter, got {describe(self.filter)}"
            )
        n = int(self.filter.dof)
        set_ = object.__setattr__
        set_(self, "action", check_choice("action", self.action, _ACTIONS))
        mode = check_choice("actuation", self.actuation, _ACTUATIONS)
        set_(self, "actuation", mode)
        T = check_positive("period", self.period, unit="s")
        dt = self.filter.dt
        if dt is not None and not math.isclose(T, dt, rel_tol=1e-6, abs_tol=0.0):
            raise InvalidParameter(
                f"period: expected the filter's dt ({dt:g} s), the control period it brakes "
                f"over, got {T:g} s"
            )
        set_(self, "period", T)
        if self.state is not None:
            if not isinstance(self.state, JointState):
                raise InvalidParameter(
                    "state: expected a JointState (joint_names and read(env); "
                    f"MujocoJointState for MuJoCo envs) or None, got {describe(self.state)}"
                )
            try:
                k = len(tuple(self.state.joint_names))
            except Exception:  # a hostile joint_names is refused, not propagated
                k = -1
            if k != n:
                raise InvalidParameter(
                    f"state: expected a JointState of the filter's {n} joints, got joint_names "
                    f"{show(getattr(self.state, 'joint_names', None))}"
                )
        if mode == "torque" and not callable(getattr(self.state, "addresses", None)):
            raise InvalidParameter(
                "state: the torque servo reads MuJoCo's data at the joints' addresses; expected "
                f"a MujocoJointState (or a JointState with addresses(model)), got "
                f"{describe(self.state)}"
            )
        torque = mode == "torque"
        bw = check_positive("bandwidth", self.bandwidth, allow_zero=not torque, unit="rad/s")
        set_(self, "bandwidth", bw)
        eff = _joint_values("max_effort", self.max_effort, n, torque, allow_inf=True)
        set_(self, "max_effort", eff)
        set_(self, "gear", _joint_values("gear", self.gear, n, torque, allow_inf=False))
        set_(self, "actuators", _actuator_indices(self.actuators, n))
        set_(self, "twist_speed", check_positive("twist_speed", self.twist_speed, unit="m/s"))
        tip = self.tip_body
        if tip is not None:
            tip = check_positive_int("tip_body", tip, minimum=0, maximum=2**31 - 1, example=1)
        set_(self, "tip_body", tip)
        off = self.tip_offset
        if off is not None:
            off = readonly(real_array("tip_offset", off, (3,), what="a position [m]",
                                      error=InvalidParameter))  # fmt: skip
        elif tip is not None:
            off = readonly(np.zeros(3))
        set_(self, "tip_offset", off)

    @property
    def dof(self) -> int:
        """The arm's joints."""
        return int(self.filter.dof)


def _joint_values(
    name: str, value: Any, n: int, required: bool, *, allow_inf: bool
) -> FloatArray | None:
    """A per-joint array of ``Shield``, shape (n,), or ``None`` where not ``required``.

    ``max_effort`` (``allow_inf``): > 0, inf allowed; ``gear``: finite and non-zero.
    """
    if value is None:
        if required:
            raise InvalidParameter(
                f"{name}: required with actuation='torque': one value per joint ({n})"
            )
        return None
    a = real_array(name, value, (n,), error=InvalidParameter, allow_nonfinite=allow_inf)
    if np.isnan(a).any() or (allow_inf and not np.all(a > 0.0)):
        raise InvalidParameter(f"{name}: expected values > 0 (inf: no limit), got {show(a)}")
    if not allow_inf and not np.all(a != 0.0):
        raise InvalidParameter(f"{name}: expected non-zero values, got {show(a)}")
    return readonly(a)


def _actuator_indices(value: Any, n: int) -> tuple[int, ...] | None:
    """``Shield.actuators``: ``None`` or n distinct ints >= 0."""
    if value is None:
        return None
    if isinstance(value, (str, bytes, bytearray, dict, set, frozenset)) or not isinstance(
        value, (list, tuple, range, np.ndarray)
    ):
        raise InvalidParameter(
            f"actuators: expected {n} actuator indices (ints >= 0) or None, got {describe(value)}"
        )
    items = value.tolist() if isinstance(value, np.ndarray) else list(value)
    if len(items) != n or (isinstance(value, np.ndarray) and value.ndim != 1):
        raise InvalidParameter(f"actuators: expected {n} actuator indices, got {show(value)}")
    idx = tuple(
        check_positive_int(f"actuators[{i}]", v, minimum=0, maximum=2**31 - 1, example=0)
        for i, v in enumerate(items)
    )
    if len(set(idx)) != n:
        raise InvalidParameter(f"actuators: expected distinct indices, got {list(idx)}")
    return idx


def _actuators(model: Any, joint_ids: list[int]) -> tuple[list[int], FloatArray, FloatArray]:
    """Each joint's motor actuator: index, gear and torque limit (ctrlrange x gear)."""
    idx: list[int] = []
    gear = np.ones(len(joint_ids))
    eff = np.full(len(joint_ids), np.inf)
    for k, jid in enumerate(joint_ids):
        found = [
            a
            for a in range(model.nu)
            if int(model.actuator_trntype[a]) == 0 and int(model.actuator_trnid[a, 0]) == jid
        ]
        if len(found) != 1:
            raise InvalidParameter(
                f"actuation: joint {model.joint(jid).name!r} has {len(found)} joint actuators, "
                "expected one motor (pass actuation='velocity' or 'position' for other envs)"
            )  # fmt: skip
        a = found[0]
        g = float(model.actuator_gear[a, 0])
        idx.append(a)
        gear[k] = g
        if bool(model.actuator_ctrllimited[a]):
            lo, hi = (float(v) for v in model.actuator_ctrlrange[a])
            eff[k] = min(-lo, hi) * abs(g)
        if bool(model.jnt_actfrclimited[jid]):
            lo, hi = (float(v) for v in model.jnt_actfrcrange[jid])
            eff[k] = min(eff[k], -lo, hi)
    return idx, gear, eff


def _infer_actuation(model: Any, idx: list[int]) -> Actuation:
    """The arm's actuation read from its actuators.

    Motors (no bias) are torque actuators; MuJoCo's position / velocity actuators have an
    affine bias on qpos / qvel.
    """
    kinds = set()
    for a in idx:
        bias = np.asarray(model.actuator_biasprm[a, :3], dtype=np.float64)
        if int(model.actuator_biastype[a]) == 0:
            kinds.add("torque")
        elif bias[1] != 0.0 and bias[2] == 0.0:
            kinds.add("position")
        elif bias[2] != 0.0 and bias[1] == 0.0:
            kinds.add("velocity")
        else:
            kinds.add("?")
    if len(kinds) != 1 or "?" in kinds:
        raise InvalidParameter(
            f"actuation: the arm's actuators are of kinds {sorted(kinds)}; pass actuation="
            "'torque', 'velocity' or 'position'"
        )
    return kinds.pop()  # type: ignore[return-value]


def mujoco_shield(
    env: Any,
    *,
    joints: Sequence[str],
    tip: str,
    max_speed: float | ArrayLike,
    tip_offset: ArrayLike = (0.0, 0.0, 0.0),
    action: ActionMode = "velocity",
    joint_limits: dict[str, tuple[float, float]] | None = None,
    max_acceleration: float | ArrayLike | None = None,
    workspace: ConvexPolytope | WorkspaceLimit | None = None,
    workspace_buffer: float = 0.05,
    obstacles: Sequence[SphereObstacle] = (),
    actuation: Actuation | None = None,
    bandwidth: float | None = None,
    twist_speed: float = 1.0,
    on_invalid: Literal["raise", "stop"] = "raise",
) -> Shield:
    """A :class:`Shield` for a Gymnasium MuJoCo env, built from the env's own model.

    The robot is :func:`mujoco_arm`; the joint position limits are the MJCF ``range`` of each
    joint, and a joint without one (``limited="false"``: Reacher's ``joint0``) stops the shield
    from starting unless ``joint_limits`` gives it. MJCF has no joint speed limit, so
    ``max_speed`` is required. The filter's period is the env's control period
    (``env.unwrapped.dt``).

    Args:
        env: A Gymnasium MuJoCo env.
        joints: The arm's joints (MJCF names), in the model's order.
        tip: The body that carries the tool point (:func:`mujoco_arm`).
        max_speed: Joint speed limits [rad/s], > 0: a scalar or one per joint.
        tip_offset: The tool point in ``tip``'s frame [m] (:func:`mujoco_arm`).
        action: What the agent sends (:data:`ActionMode`).
        joint_limits: Position limits [rad] by joint name, for joints the MJCF leaves unlimited
            (or to narrow a range: they must lie inside it).
        max_acceleration: Joint acceleration limits [rad/s²], > 0 (scalar or per joint), or
            ``None``: no acceleration rows.
        workspace: The tool point's workspace (a polytope, or a :class:`WorkspaceLimit` on
            ``"tcp"``), or ``None``.
        workspace_buffer: The polytope's braking buffer [m], > 0 (a polytope given bare).
        obstacles: Sphere obstacles against the arm's capsule links.
        actuation: What the env takes (:data:`Actuation`); ``None``: read from the arm's
            actuators (motors: ``"torque"``).
        bandwidth: The torque servo's bandwidth [rad/s], > 0; ``None``: ``1 / T`` (the
            servo's time constant is one control period).
        twist_speed: The ``"twist"`` action space's bound on each component [m/s], > 0.
        on_invalid: ``"raise"`` (a NaN state or action raises
            :class:`~velfence.errors.InvalidInput`) or ``"stop"`` (a hold action and
            ``info["shield"]["invalid"]``).

    Returns:
        The :class:`Shield` for :class:`ShieldWrapper` or :class:`VectorShieldWrapper`.

    Raises:
        InvalidParameter: an unset bound (naming it and how to set it), a bad argument, or an
            env that is not a Gymnasium MuJoCo env.
    """
    act = check_choice("action", action, _ACTIONS)
    pol = check_choice("on_invalid", on_invalid, _ON_INVALID)
    if actuation is not None:
        check_choice("actuation", actuation, _ACTUATIONS)
    if joint_limits is not None and not isinstance(joint_limits, Mapping):
        raise InvalidParameter(
            "joint_limits: expected a mapping joint name -> (lower, upper) [rad] or None, got "
            f"{describe(joint_limits)}"
        )
    if workspace is not None and not isinstance(workspace, (ConvexPolytope, WorkspaceLimit)):
        raise InvalidParameter(
            "workspace: expected a ConvexPolytope, a WorkspaceLimit or None, got "
            f"{describe(workspace)}"
        )
    obs = obstacle_list(obstacles)
    robot = mujoco_arm(env, joints, tip=tip, tip_offset=tip_offset)
    u = env.unwrapped
    model = u.model
    names = robot.joint_names
    n = len(names)
    T = check_positive("env.unwrapped.dt", getattr(u, "dt", None), unit="s")
    lo = np.empty(n)
    hi = np.empty(n)
    given = {} if joint_limits is None else dict(joint_limits)
    unknown = [k for k in given if k not in names]
    if unknown:
        raise InvalidParameter(f"joint_limits: {show(unknown)} are not among joints {list(names)}")
    unset = []
    for k, jn in enumerate(names):
        jid = model.joint(jn).id
        limited = bool(model.jnt_limited[jid])
        r = (float(model.jnt_range[jid, 0]), float(model.jnt_range[jid, 1]))
        if jn in given:
            g = real_array(f"joint_limits[{jn!r}]", given[jn], (2,), what="limits [rad]",
                           error=InvalidParameter)  # fmt: skip
            if not g[0] < g[1] or (limited and (g[0] < r[0] or g[1] > r[1])):
                raise InvalidParameter(
                    f"joint_limits[{jn!r}]: expected lower < upper inside the MJCF range "
                    f"{r if limited else '(none)'}, got {g.tolist()}"
                )
            lo[k], hi[k] = g
        elif limited:
            lo[k], hi[k] = r
        else:
            unset.append(jn)
    if unset:
        raise InvalidParameter(
            f"joint_limits: the env's MJCF sets no position range for joint(s) {unset} "
            f'(limited="false"); the shield will not invent one: pass joint_limits='
            f"{{{', '.join(f'{s!r}: (lower, upper)' for s in unset)}}} in rad"
        )
    vmax = _per_joint("max_speed", max_speed, n, "rad/s")
    if vmax is None:
        raise InvalidParameter(
            "max_speed: MJCF has no joint speed limit, so the shield needs one: pass "
            f"max_speed= a speed > 0 in rad/s, or one per joint ({n})"
        )
    amax = _per_joint("max_acceleration", max_acceleration, n, "rad/s²")
    limits = JointLimits(lo, hi, max_speed=vmax, max_acceleration=amax, names=names)
    ws: Any = ()
    if isinstance(workspace, ConvexPolytope):
        buf = check_positive("workspace_buffer", workspace_buffer, unit="m")
        ws = WorkspaceLimit(workspace, point="tcp", buffer=buf)
    elif workspace is not None:
        ws = workspace
    filt = SafetyFilter(
        robot, limits=limits, workspace=ws, obstacles=obs, dt=T,
        on_invalid="stop" if pol == "stop" else "raise",
    )  # fmt: skip
    ids = [model.joint(s).id for s in names]
    mode = actuation
    idx: list[int] | None = None
    gear = eff = None
    if mode is None or mode in ("torque", "position"):
        try:
            idx, gear, eff = _actuators(model, ids)
        except InvalidParameter:
            if mode is not None:
                raise
        if mode is None:
            if idx is None:
                raise InvalidParameter(
                    "actuation: the arm's joints have no single joint actuator each; pass "
                    "actuation='torque', 'velocity' or 'position'"
                )
            mode = _infer_actuation(model, idx)
    mode = check_choice("actuation", mode, _ACTUATIONS)
    bw = check_positive("bandwidth", 1.0 / T if bandwidth is None else bandwidth, unit="rad/s")
    return Shield(
        filter=filt, state=MujocoJointState(names), action=act, actuation=mode, period=T,
        bandwidth=bw, max_effort=eff, gear=gear, actuators=None if idx is None else tuple(idx),
        twist_speed=check_positive("twist_speed", twist_speed, unit="m/s"),
        tip_body=int(model.body(tip).id),
        tip_offset=real_array("tip_offset", tip_offset, (3,), error=InvalidParameter),
    )  # fmt: skip


def _per_joint(name: str, value: Any, n: int, unit: str) -> FloatArray | None:
    if value is None:
        return None
    a = real_array(name, value, None, what=f"speeds [{unit}]", error=InvalidParameter)
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,) or not np.all(a > 0.0):
        raise InvalidParameter(
            f"{name}: expected a value > 0 [{unit}] or {n} of them, got {a.tolist()}"
        )
    return a


def _reset_options(options: Any) -> dict[str, Any] | None:
    """The ``options`` of a wrapper's ``reset``: ``None`` or a dict with string keys."""
    if options is None:
        return None
    if not isinstance(options, dict) or not all(isinstance(k, str) for k in options):
        raise InvalidParameter(
            f"options: expected a dict of reset options (str keys) or None, got {describe(options)}"
        )
    return options


def _action_space(shield: Shield) -> Any:
    lim = shield.filter.limits
    if shield.action == "velocity":
        v = np.asarray(lim.max_speed, dtype=np.float64)
        return gymnasium.spaces.Box(-v, v, dtype=np.float64)
    if shield.action == "position":
        return gymnasium.spaces.Box(np.asarray(lim.lower), np.asarray(lim.upper),
                                    dtype=np.float64)  # fmt: skip
    s = shield.twist_speed
    return gymnasium.spaces.Box(-s, s, shape=(3,), dtype=np.float64)


class _Core:
    """The per-step arithmetic both wrappers share (one env's part of it)."""

    def __init__(self, shield: Shield, penalty: float) -> None:
        if not isinstance(shield, Shield):
            raise InvalidParameter(
                f"shield: expected a Shield (mujoco_shield), got {describe(shield)}"
            )
        self.shield = shield
        self.penalty = check_positive("penalty", penalty, allow_zero=True)
        self.width = 3 if shield.action == "twist" else shield.dof
        self._scratch: FloatArray | None = None
        self._mj: Any = None
        lim = shield.filter.limits
        self._lower = np.asarray(lim.lower, dtype=np.float64)
        self._upper = np.asarray(lim.upper, dtype=np.float64)
        self._ws = [(w.point, np.asarray(w.polytope.normals), np.asarray(w.polytope.offsets))
                    for w in shield.filter.workspace]  # fmt: skip

    def forward(self, env: Any) -> None:
        """Bring the env's derived quantities (poses, inertia, bias) to its current state.

        Gymnasium's ``step`` leaves them at the start of the last physics step. MuJoCo's own
        stages, no integration (the state is not changed): ``mj_kinematics`` (the poses) and,
        for the torque servo, ``mj_comPos``, ``mj_crb`` (the inertia), ``mj_comVel``,
        ``mj_passive`` (joint damping) and ``mj_rne`` (the bias force into ``qfrc_bias``) —
        what ``mj_fwdPosition`` and ``mj_fwdVelocity`` compute for these, without the collision
        detection and the constraints.
        """
        torque = self.shield.actuation == "torque"
        if self.shield.tip_body is None and not torque:
            return
        mj = self._mj
        if mj is None:
            mj = self._mj = _mujoco()
        u = env.unwrapped
        m, d = u.model, u.data
        mj.mj_kinematics(m, d)
        if torque:
            mj.mj_comPos(m, d)
            mj.mj_crb(m, d)
            mj.mj_comVel(m, d)
            mj.mj_passive(m, d)
            mj.mj_rne(m, d, 0, d.qfrc_bias)

    def check_action(self, action: Any, rows: int | None) -> FloatArray:
        """The action as float64 of the action space's shape (rows x width for a vector env).

        Non-finite entries, and finite ones beyond :data:`~velfence._validate.MAX_MAGNITUDE`,
        are kept (the ``on_invalid`` policy decides: :func:`_invalid_rows`).
        """
        shape = (self.width,) if rows is None else (rows, self.width)
        name = "action" if rows is None else "actions"
        return real_array(name, action, shape, allow_nonfinite=True, max_abs=None)

    def command(self, q: FloatArray, a: FloatArray) -> FloatArray:
        """The joint-velocity command of an action (velocity and position modes)."""
        if self.shield.action == "position":
            return (a - q) / self.shield.period
        return a

    def to_env(self, env: Any, q: FloatArray, qd: FloatArray, x: FloatArray) -> FloatArray:
        """The env's action for the shielded joint velocity ``x`` (one env)."""
        sh = self.shield
        if sh.actuation == "velocity":
            return x
        if sh.actuation == "position":
            return q + x * sh.period
        if self._mj is None:
            self._mj = _mujoco()
        u = env.unwrapped
        m, d = u.model, u.data
        if self._scratch is None or self._scratch.shape[0] != m.nv:
            self._scratch = np.zeros(m.nv)
            limited = np.asarray(m.actuator_ctrllimited, dtype=bool)
            rng = np.asarray(m.actuator_ctrlrange, dtype=np.float64)
            self._ctrl_lo = np.where(limited, rng[:, 0], -np.inf)
            self._ctrl_hi = np.where(limited, rng[:, 1], np.inf)
            act = np.arange(sh.dof) if sh.actuators is None else np.asarray(sh.actuators)
            if act.size and int(act.max()) >= m.nu:
                raise InvalidParameter(
                    f"shield: actuators {act.tolist()} are not all among the env's {m.nu} actuators"
                )
            self._act = _as_slice(act)
            self._all = self._act == slice(0, m.nu)
            st: Any = sh.state  # a MuJoCo reader (Shield checks it has addresses)
            sel = st.selectors(m) if hasattr(st, "selectors") else None
            self._dofs = sel[1] if sel is not None else st.addresses(m)[1]
        assert sh.max_effort is not None
        assert sh.gear is not None
        tau, _ = computed_torque(self._mj, m, d, self._dofs, x, bandwidth=sh.bandwidth,
                                 max_effort=sh.max_effort, scratch=self._scratch,
                                 passive=True)  # fmt: skip
        if self._all:
            ctrl = tau / sh.gear
        else:
            ctrl = np.zeros(m.nu)
            ctrl[self._act] = tau / sh.gear
        return np.minimum(np.maximum(ctrl, self._ctrl_lo), self._ctrl_hi)

    def hold(self, env: Any, q: FloatArray, qd: FloatArray) -> FloatArray:
        """The env's action that holds the arm (zero joint velocity; MuJoCo brought forward)."""
        n = self.shield.dof
        ok = bool(np.all(np.isfinite(q)) and np.all(np.isfinite(qd)))
        if self.shield.actuation == "torque" and not ok:
            return np.zeros(env.unwrapped.model.nu)
        if self.shield.actuation == "position" and not ok:
            raise InvalidInput("the joint state is not finite: no position to hold")
        if ok:
            self.forward(env)
        return self.to_env(env, q, qd, np.zeros(n))

    def distances(self, env: Any, q: FloatArray) -> dict[str, Any]:
        """Distance to each limit at ``q``: joints (lower, upper) [rad], workspace facets [m].

        The tool point is MuJoCo's own (the tip body's pose after :meth:`forward`)
        in a MuJoCo env, else the robot's ``fk``.
        """
        out: dict[str, Any] = {"joint_lower": q - self._lower, "joint_upper": self._upper - q}
        tip = self.shield.tip_body
        for point, N, o in self._ws:
            if point == "tcp" and tip is not None and self.shield.tip_offset is not None:
                p = _tip_point(env.unwrapped.data, tip, self.shield.tip_offset)
            else:
                p = self.shield.filter.robot.fk(q, point)
            out[f"workspace {point}"] = N @ p - o
        return out


class ShieldWrapper(gymnasium.Wrapper):
    """A Gymnasium env whose actions pass the safety filter first.

    The action space is the shield's (:data:`ActionMode`: joint velocities bounded by
    ``max_speed``, joint positions within the limits, or a tool velocity); observations are the
    env's. ``step`` reads the joint state (:class:`JointState`), filters, sends the env its own
    action and adds ``info["shield"]``:

    * ``changed`` (bool): the filter changed the command; ``interventions``: steps changed so
      far in the episode; ``invalid`` (bool): a NaN state or action was replaced by the hold
      action (``on_invalid="stop"``);
    * ``command``, ``output``: the joint velocity asked and sent [rad/s] (``"twist"``: the
      twist as given [m/s], and no penalty);
    * ``active``: the names of the rows binding at the output (``"joint 3 position
      (upper)"``, ``"TCP face x_max"``), ``stages`` (``"projection"``, ``"stop"``, …);
    * ``distance``: ``joint_lower``/``joint_upper`` [rad] per joint and, per workspace limit,
      each facet's signed distance [m] (positive inside), at the state the action was read at;
    * ``penalty``: what was subtracted from the reward, ``penalty * |x - u|²``.

    Args:
        env: The env.
        shield: The :class:`Shield` (:func:`mujoco_shield`).
        penalty: Reward penalty per (rad/s)² of change, >= 0 (0: the reward as is).
        detail: ``True``: ``explain`` every step (the row names); ``False``: ``filter`` only
            (``active`` and ``stages`` empty, faster).
        bypass: ``True``: the same wrapper without the filter (the command goes to the env's
            actuation, the servo included, as asked; ``changed`` always false): the twin to
            compare a shielded run with. Not for the ``"twist"`` action.

    Raises:
        InvalidParameter: a bad shield or penalty, or ``bypass`` with twist actions.
    """

    def __init__(
        self,
        env: Any,
        shield: Shield,
        *,
        penalty: float = 0.0,
        detail: bool = True,
        bypass: bool = False,
    ) -> None:
        core = _Core(shield, penalty)
        if shield.state is None:
            raise InvalidParameter(
                "shield: expected a Shield with a JointState (its state reads the env), got "
                "state=None"
            )
        detail = check_flag("detail", detail)
        bypass = check_flag("bypass", bypass)
        if bypass and shield.action == "twist":
            raise InvalidParameter("bypass: expected joint velocity or position actions")
        if not isinstance(env, gymnasium.Env):
            raise InvalidParameter(f"env: expected a gymnasium.Env, got {describe(env)}")
        super().__init__(env)
        self._core = core
        self.shield = shield
        self.detail = detail
        self.bypass = bypass
        self.action_space = _action_space(shield)
        self.interventions = 0
        self._last_q: FloatArray | None = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        """Reset the env and the episode's intervention count.

        Args:
            seed: The env's seed, an int in [0, 2**63 - 1], or ``None``.
            options: The env's reset options, a dict, or ``None``.

        Raises:
            InvalidParameter: a bad seed or options.
        """
        sd = None if seed is None else check_seed("seed", seed)
        opts = _reset_options(options)
        self.interventions = 0
        self.shield.filter.reset()
        return self.env.reset(seed=sd, options=opts)

    def _shielded(self, action: Any) -> tuple[FloatArray, dict[str, Any]]:
        core, sh = self._core, self.shield
        f = sh.filter
        a = core.check_action(action, None)
        assert sh.state is not None  # checked by __init__
        q, qd = sh.state.read(self.env)
        # NaN fails both comparisons; an action beyond MAX_MAGNITUDE is as invalid as inf
        # (the filter's own rule), so it meets the on_invalid policy too.
        bad = not (float(a.min()) >= -MAX_MAGNITUDE and float(a.max()) <= MAX_MAGNITUDE)
        total = float(q.sum()) + float(qd.sum())  # finite: every entry is
        if not bad and not math.isfinite(total):
            bad = not (np.isfinite(q).all() and np.isfinite(qd).all())
        if bad:
            if f.on_invalid == "raise":
                raise InvalidInput(
                    f"non-finite input (or beyond {MAX_MAGNITUDE:g}): joint state "
                    f"q={q.tolist()}, qd={qd.tolist()}, action={a.tolist()}"
                )
            env_a = core.hold(self.env, q, qd)
            n = sh.dof
            return env_a, {
                "changed": True, "invalid": True, "command": np.full(n, np.nan),
                "output": np.zeros(n), "active": (), "stages": ("stop",), "distance": {},
            }  # fmt: skip
        if sh.action == "twist":
            r = f.explain_twist(q, a)
            u = a  # the twist as given (the joint command is its damped least squares)
            x = r.output
            active, stages = r.active_names, r.stages
            changed = "projection" in stages or "stop" in stages
        elif self.bypass:
            u = core.command(q, a)
            x, active, stages, changed = u, (), (), False
        else:
            u = core.command(q, a)
            if self.detail:
                r = f.explain(q, u)
                x, active, stages = r.output, r.active_names, r.stages
            else:
                x = f.filter(q, u)
                active, stages = (), ()
            changed = bool((x != u).any())
        core.forward(self.env)
        return core.to_env(self.env, q, qd, x), {
            "changed": changed, "invalid": False, "command": u, "output": x,
            "active": active, "stages": stages, "distance": core.distances(self.env, q),
        }  # fmt: skip

    def step(self, action: Any) -> Any:
        """Filter ``action``, step the env with the result, report in ``info["shield"]``."""
        env_a, rep = self._shielded(action)
        obs, reward, terminated, truncated, info = self.env.step(env_a)
        if rep["changed"]:
            self.interventions += 1
        pen = 0.0
        if self._core.penalty > 0.0 and not rep["invalid"] and self.shield.action != "twist":
            pen = self._core.penalty * float(np.sum((rep["output"] - rep["command"]) ** 2))
        rep["penalty"] = pen
        rep["interventions"] = self.interventions
        info = dict(info)
        info["shield"] = rep
        return obs, float(reward) - pen, terminated, truncated, info


@runtime_checkable
class BatchJointState(Protocol):
    """Reads every sub-env's joint state of a vector env at once.

    Attributes:
        joint_names: The arm's joints, in the filter's order.
    """

    joint_names: tuple[str, ...]

    def read_batch(self, envs: Any) -> tuple[FloatArray, FloatArray]:
        """``(positions (N, n), velocities (N, n))`` of the vector env's sub-envs."""
        ...


class VectorShieldWrapper(gymnasium.vector.VectorWrapper):
    """A ``gymnasium.vector`` env whose actions pass the safety filter, one batched call a step.

    Every step reads all sub-envs' joint states, runs :meth:`SafetyFilter.filter_batch` once
    (the C batch on one thread per core when the robot gives its chain as data) and sends each
    sub-env its own action. ``info["shield"]`` holds arrays over the sub-envs: ``changed``,
    ``invalid``, ``stopped`` (bool), ``status`` and ``stages`` (the C status and stage bits,
    :class:`~velfence.filter.FilterBatch`), ``interventions`` (per sub-env, since its last
    reset), ``joint_lower``/``joint_upper`` distances [rad] and ``penalty``.

    Sub-envs are read through ``state``: a :class:`BatchJointState`, or by default, for a
    ``SyncVectorEnv`` of MuJoCo envs, the shield's :class:`MujocoJointState` on each sub-env.
    The sub-envs' own actions need their MuJoCo data only for ``actuation="torque"`` (the
    servo, per sub-env).

    Args:
        env: The vector env (``num_envs`` sub-envs of one arm).
        shield: The :class:`Shield` (the filter of one arm; its ``state`` reads one sub-env).
        state: A :class:`BatchJointState`, or ``None`` (read each sub-env of a
            ``SyncVectorEnv``).
        penalty: Reward penalty per (rad/s)² of change, >= 0.
        threads: The batch's worker threads, >= 0 (0: one per core).

    Raises:
        InvalidParameter: a bad argument, or no ``state`` for a vector env whose sub-envs
            cannot be read in process (``AsyncVectorEnv``).
    """

    def __init__(
        self,
        env: Any,
        shield: Shield,
        *,
        state: Any = None,
        penalty: float = 0.0,
        threads: int = 0,
    ) -> None:
        core = _Core(shield, penalty)
        if shield.action == "twist":
            raise InvalidParameter(
                "shield: the vector shield takes joint velocity or position actions (twist "
                "mode has no batched C route)"
            )
        if not isinstance(env, gymnasium.vector.VectorEnv):
            raise InvalidParameter(
                f"env: expected a gymnasium.vector.VectorEnv, got {describe(env)}"
            )
        if state is not None and not isinstance(state, BatchJointState):
            raise InvalidParameter(
                "state: expected a BatchJointState (joint_names and read_batch(envs)) or None, "
                f"got {describe(state)}"
            )
        if state is None and not hasattr(env, "envs"):
            raise InvalidParameter(
                "state: expected a BatchJointState for a vector env without in-process "
                f"sub-envs ({type(env).__name__}); pass state="
            )
        if state is None and shield.state is None:
            raise InvalidParameter(
                "state: expected a BatchJointState, as the shield has no JointState of one "
                "sub-env (shield.state is None)"
            )
        threads = check_positive_int("threads", threads, minimum=0, maximum=64, example=2)
        n = check_positive_int("env.num_envs", getattr(env, "num_envs", None), example=4)
        super().__init__(env)
        self._core = core
        self.shield = shield
        self._state = state
        self._threads = threads
        self.single_action_space = _action_space(shield)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, n)
        self.interventions = np.zeros(n, dtype=np.int64)
        self._prev: FloatArray | None = None

    def _read(self) -> tuple[FloatArray, FloatArray]:
        if self._state is not None:
            Q, QD = self._state.read_batch(self.env)
            n = self.shield.dof
            N = int(self.env.num_envs)
            return (real_array("state positions", Q, (N, n), allow_nonfinite=True, max_abs=None),
                    real_array("state velocities", QD, (N, n), allow_nonfinite=True,
                               max_abs=None))  # fmt: skip
        envs: Any = getattr(self.env, "envs", ())
        one = self.shield.state
        assert one is not None  # checked by __init__
        rows = [one.read(e) for e in envs]
        return np.array([r[0] for r in rows]), np.array([r[1] for r in rows])

    def reset(self, *, seed: Any = None, options: dict[str, Any] | None = None) -> Any:
        """Reset the sub-envs and their intervention counts.

        Args:
            seed: ``None``, an int in [0, 2**63 - 1] (the vector env seeds its sub-envs from
                it), or one such int (or ``None``) per sub-env.
            options: The reset options, a dict, or ``None``.

        Raises:
            InvalidParameter: a bad seed or options.
        """
        sd: Any = seed
        if seed is not None and isinstance(seed, (list, tuple)):
            N = int(self.env.num_envs)
            if len(seed) != N:
                raise InvalidParameter(
                    f"seed: expected one seed per sub-env ({N}), got {len(seed)}"
                )
            sd = [None if v is None else check_seed(f"seed[{k}]", v) for k, v in enumerate(seed)]
        elif seed is not None:
            sd = check_seed("seed", seed)
        opts = _reset_options(options)
        self.interventions[:] = 0
        self._prev = None
        return self.env.reset(seed=sd, options=opts)

    def step(self, actions: Any) -> Any:
        """Filter every sub-env's action in one call, step the vector env, report."""
        core, sh = self._core, self.shield
        N = int(self.env.num_envs)
        A = core.check_action(actions, N)
        Q, QD = self._read()
        U = core.command(Q, A)
        prev = self._prev if sh.filter.limits.max_acceleration is not None else None
        try:
            r = sh.filter.filter_batch(Q, U, previous=prev, threads=self._threads)
        except InvalidInput as exc:  # the filter's commands are the actions, its positions Q
            raise InvalidInput(f"actions or joint state (on_invalid='raise'): {exc}") from None
        X = r.output
        bad = r.invalid | ~np.all(np.isfinite(QD), axis=1)
        if sh.actuation == "velocity":
            env_a = X.copy()
        elif sh.actuation == "position":
            env_a = np.where(bad[:, None], Q, Q + X * sh.period)
        else:
            envs: Any = getattr(self.env, "envs", ())
            rows = []
            for k in range(N):
                if not bad[k]:
                    core.forward(envs[k])
                    rows.append(core.to_env(envs[k], Q[k], QD[k], X[k]))
                else:
                    rows.append(core.hold(envs[k], Q[k], QD[k]))
            env_a = np.array(rows)
        if not np.all(np.isfinite(env_a)):  # pragma: no cover - position hold of a NaN state
            raise InvalidInput("the hold action of a non-finite joint state is not finite")
        self._prev = X
        obs, reward, terminated, truncated, info = self.env.step(env_a)
        changed = r.changed
        self.interventions += changed
        pen = np.zeros(N)
        if core.penalty > 0.0:
            diff = np.where(bad[:, None], 0.0, X - np.nan_to_num(U))
            pen = core.penalty * np.sum(diff**2, axis=1)
        done = np.asarray(terminated) | np.asarray(truncated)
        info = dict(info)
        info["shield"] = {
            "changed": changed, "invalid": bad, "stopped": r.stopped, "status": r.status,
            "stages": r.stages, "interventions": self.interventions.copy(), "penalty": pen,
            "joint_lower": Q - np.asarray(sh.filter.limits.lower),
            "joint_upper": np.asarray(sh.filter.limits.upper) - Q,
        }  # fmt: skip
        self.interventions[done] = 0
        if self._prev is not None:
            self._prev = np.where(done[:, None], 0.0, self._prev)
        return obs, np.asarray(reward, dtype=np.float64) - pen, terminated, truncated, info


document_inits(globals())
