r"""A MuJoCo physics plant for the closed-loop runner (the ``physics`` extra).

:class:`MujocoPlant` replaces the runner's ideal integrator :math:`q_{k+1} = q_k + \Delta t\,
\dot q_k` by a simulated robot: the shaped joint velocity is a *reference* held constant over the
control period (zero-order hold) and tracked by a joint velocity servo, while MuJoCo integrates the
rigid-body dynamics at its own, finer step, with gravity, effort limits, external pushes on bodies
and contacts with obstacle geoms.

Two servos (``servo=``), both common on real velocity-controlled arms:

* ``"computed-torque"`` (default, serial arms): at every physics step

  .. math:: \tau = \operatorname{clip}\bigl(M(q)\,\omega_c\,(\dot q_{ref} - \dot q) + b(q, \dot q),
            \ \pm\tau_{max}\bigr),

  with :math:`b` MuJoCo's bias force (gravity, Coriolis, centrifugal: ``qfrc_bias``) and
  :math:`\omega_c` the servo bandwidth [rad/s]. Below the effort limits every joint follows its
  reference as the first-order lag :math:`\dot q' = \omega_c(\dot q_{ref} - \dot q)`: one known
  time constant :math:`1/\omega_c` in every pose, and a zero reference holds the arm still
  against gravity. An external force :math:`F` on the arm makes it drift at about
  :math:`(\omega_c M)^{-1} J^T F` (a velocity servo has no position memory): the backdrivable case.
* ``"velocity"`` (any model, closed chains included): MuJoCo's own velocity actuators
  :math:`\tau = k_v(\dot q_{ref} - \dot q)` clipped at the effort limit, on the ``actuated``
  joints, whose references come from the state joints' through ``transmission`` (e.g. the
  wrist's actuator Jacobian). Its lag depends on the pose (:math:`M/k_v`) and gravity is not
  compensated.

Obstacles (:class:`~velfence.filter.limits.SphereObstacle`) become sphere geoms with
``contype=0, conaffinity=2``: they touch the shipped arms' link capsules (``contype=2``) and
nothing else. Contacts are counted by MuJoCo's collision detection, the ground truth, not by the
filter's own geometry. The record (:attr:`MujocoPlant.record`) holds, per control step, the
joint velocities, efforts, whether an effort limit clipped, the contacts and their depth, and the
whole ``qpos`` (for rendering).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import KW_ONLY, dataclass
from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import renamed_args, renamed_attribute
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_choice,
    check_names,
    check_positive,
    check_text,
    finite_scalar,
    readonly,
    real_array,
    require_package,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter.limits import SphereObstacle
from velfence.robots.servo import computed_torque

__all__ = ["SERVOS", "BodyPush", "MujocoPlant", "PhysicsRecord", "Servo"]

Servo = Literal["computed-torque", "velocity"]
SERVOS: tuple[Servo, ...] = get_args(Servo)

#: Collision bits: the shipped arms' link capsules have ``contype=2, conaffinity=0``.
OBSTACLE_CONTYPE = 0
OBSTACLE_CONAFFINITY = 2
_MAX_SUBSTEPS = 10_000


def _mujoco() -> Any:
    return require_package("robot", "mujoco", extra="physics", what="a physics plant")


@dataclass(frozen=True)
class BodyPush:
    """An external force and torque on a body during a time window (MuJoCo ``xfrc_applied``).

    Every field is keyword-only: ``BodyPush(body="link7", force=[0, 0, -20], start=0.5)``.

    Attributes:
        body: Name of the MJCF body pushed.
        force: Force at the body's centre of mass, world frame [N], shape (3,).
        torque: Torque, world frame [N·m], shape (3,) (default zero).
        start: Time the push starts [s], >= 0.
        duration: How long it lasts [s], > 0.
    """

    _: KW_ONLY
    body: str
    force: FloatArray
    torque: FloatArray | None = None
    start: float = 0.0
    duration: float = 0.1

    def __post_init__(self) -> None:
        object.__setattr__(self, "body", check_text("body", self.body, max_length=200))
        f = real_array("force", self.force, (3,), error=InvalidParameter, what="a force [N]")
        object.__setattr__(self, "force", readonly(f))
        tq = np.zeros(3) if self.torque is None else self.torque
        tqa = real_array("torque", tq, (3,), error=InvalidParameter, what="a torque [N·m]")
        object.__setattr__(self, "torque", readonly(tqa))
        object.__setattr__(
            self, "start", check_positive("start", self.start, allow_zero=True, unit="s")
        )
        object.__setattr__(self, "duration", check_positive("duration", self.duration, unit="s"))

    def active(self, t: float) -> bool:
        """Whether the push acts at time ``t`` [s] (``start <= t < start + duration``).

        Args:
            t: Time [s].

        Returns:
            True inside the window.

        Raises:
            InvalidInput: ``t`` not a finite real number.
        """
        t = finite_scalar("t", t, unit="s", what="time")
        return self.start <= t < self.start + self.duration


@dataclass(frozen=True)
class PhysicsRecord:
    """What the physics did during a run, one row per control step (read-only arrays).

    Row ``k`` is the state at the start of control period ``k`` (the same rows as the runner's
    :class:`~velfence.sim.Trajectory`); contacts and effort clipping are those seen during the
    period that ends there (row 0: none).

    Attributes:
        t: Times [s], shape (N,).
        qpos: MuJoCo's whole ``qpos``, shape (N, nq) (for rendering).
        qvel: Velocities of the state joints [rad/s or m/s], shape (N, n).
        effort: Servo efforts of the actuated joints [N·m or N], shape (N, m), the last physics
            step's.
        clipped: Whether an effort limit clipped the servo in the period, shape (N,).
        contacts: Largest number of robot-obstacle contacts at one physics step, shape (N,).
        contact_depth: Deepest robot-obstacle penetration reported by MuJoCo [m], shape (N,)
            (0 without contact).
    """

    t: FloatArray
    qpos: FloatArray
    qvel: FloatArray
    effort: FloatArray
    clipped: np.ndarray[Any, np.dtype[np.bool_]]
    contacts: np.ndarray[Any, np.dtype[np.int64]]
    contact_depth: FloatArray

    @property
    def contact_steps(self) -> int:
        """Number of control periods with at least one robot-obstacle contact."""
        return int(np.count_nonzero(self.contacts))


class MujocoPlant:
    r"""A robot in MuJoCo, driven by joint velocity references (module docstring).

    Pass it as ``plant=`` to :func:`velfence.sim.simulate`; the runner calls :meth:`reset` once
    and :meth:`advance` once per control period. One instance runs one simulation at a time; its
    :attr:`record` is that of the last run.

    Args:
        robot: A :class:`~velfence.robots.MujocoRobot` or an MJCF document (str).
        joints: Names of the joints the runner's state ``q`` holds, in order (default: every
            joint of the model, which must then all be hinges or slides).
        actuated: Names of the joints the servo drives (default ``joints``).
        transmission: ``(q, qdot_ref) -> actuated velocity references``, shape (m,), for
            ``actuated != joints`` (e.g. :meth:`velfence.mechanisms.Wrist.actuator_velocity`).
        assemble: ``q -> qpos`` of the whole model for :meth:`reset` (closed chains: the
            passive joints consistent with ``q``); default ``q`` in the state joints, zero
            elsewhere.
        servo: ``"computed-torque"`` or ``"velocity"`` (module docstring).
        bandwidth: Computed-torque servo bandwidth :math:`\omega_c` [rad/s], > 0 (time constant
            :math:`1/\omega_c`).
        kv: Velocity-actuator gain [N·m·s/rad or N·s/m], > 0, for ``servo="velocity"``; a scalar
            or one per actuated joint.
        max_effort: Effort limits [N·m or N], a scalar or one per actuated joint (default: the
            model's ``actuatorfrcrange``; unlimited where it has none).
        max_speed: Joint speed limits of the actuated joints [rad/s or m/s], a scalar or
            one per joint, applied to the reference (default: the robot's ``velocity_limits``
            when it has them; else none). ``max_velocity`` is its deprecated name (warns; goes
            in 0.3).
        physics_dt: MuJoCo's time step [s], > 0; the control period passed to the runner must
            be a whole multiple of it.
        obstacles: Spheres added as geoms (module docstring).
        pushes: External pushes on bodies.
        gravity: Standard gravity, -9.81 m/s² along world ``z`` (whatever the document says);
            ``False`` switches it off.

    Raises:
        InvalidParameter: a bad parameter, an unknown joint or body name, or MuJoCo missing.
        InvalidGeometry: MuJoCo rejects the document.
    """

    max_velocity = renamed_attribute("max_velocity", "max_speed")

    @renamed_args(max_velocity="max_speed")
    def __init__(
        self,
        robot: Any,
        *,
        joints: Sequence[str] | None = None,
        actuated: Sequence[str] | None = None,
        transmission: Callable[[FloatArray, FloatArray], ArrayLike] | None = None,
        assemble: Callable[[FloatArray], ArrayLike] | None = None,
        servo: Servo = "computed-torque",
        bandwidth: float = 40.0,
        kv: float | ArrayLike = 50.0,
        max_effort: float | ArrayLike | None = None,
        max_speed: float | ArrayLike | None = None,
        physics_dt: float = 5e-4,
        obstacles: Sequence[SphereObstacle] = (),
        pushes: Sequence[BodyPush] = (),
        gravity: bool = True,
    ) -> None:
        mujoco = _mujoco()
        self._mj = mujoco
        xml, robot_vlim = self._document(robot)
        self.servo: Servo = check_choice("servo", servo, SERVOS)
        self.bandwidth = check_positive("bandwidth", bandwidth, unit="rad/s")
        self.physics_dt = check_positive("physics_dt", physics_dt, unit="s")
        if not isinstance(gravity, bool):
            raise InvalidParameter(f"gravity must be True or False, got {type(gravity).__name__}")
        for name, f in (("transmission", transmission), ("assemble", assemble)):
            if f is not None and (not callable(f) or isinstance(f, type)):
                raise InvalidParameter(f"{name} must be a function or None, got {type(f).__name__}")
        self._transmission = transmission
        self._assemble = assemble
        self.obstacles = self._obstacles(obstacles)
        self.pushes = self._pushes(pushes)

        try:
            spec = mujoco.MjSpec.from_string(xml)
        except ValueError as exc:
            from velfence.errors import InvalidGeometry

            first = (str(exc).strip().splitlines() or ["no message"])[0][:200]
            raise InvalidGeometry(
                f"robot: expected an MJCF document MuJoCo parses, got the error: {first}"
            ) from None
        spec.option.timestep = self.physics_dt
        spec.option.gravity = [0.0, 0.0, -9.81] if gravity else [0.0, 0.0, 0.0]
        for i, ob in enumerate(self.obstacles):
            g = spec.worldbody.add_geom()
            g.name = f"velfence_obstacle{i}"
            g.type = mujoco.mjtGeom.mjGEOM_SPHERE
            g.size = [max(ob.radius, 1e-6), 0.0, 0.0]
            g.pos = [float(x) for x in ob.center]
            g.contype = OBSTACLE_CONTYPE
            g.conaffinity = OBSTACLE_CONAFFINITY
            g.rgba = [0.85, 0.2, 0.2, 0.35]
        # Joint names must be known before actuators are added (velocity servo).
        probe = self._compile(spec)
        all_joints = [probe.joint(i).name for i in range(probe.njnt)]
        self.joints = self._names("joints", joints, all_joints, default=all_joints)
        self.actuated = self._names("actuated", actuated, all_joints, default=list(self.joints))
        if self.actuated != self.joints and transmission is None:
            raise InvalidParameter(
                "transmission: expected a function (q, qdot_ref) -> actuated velocities when "
                f"actuated {list(self.actuated)} differs from joints {list(self.joints)}, got None"
            )
        m = len(self.actuated)
        jid = [probe.joint(n).id for n in self.actuated]
        frc = np.array(
            [
                probe.jnt_actfrcrange[j] if bool(probe.jnt_actfrclimited[j]) else (-np.inf, np.inf)
                for j in jid
            ]
        )
        self.max_effort = self._per_joint(
            "max_effort", max_effort, m, np.maximum(-frc[:, 0], frc[:, 1]), "N·m or N"
        )
        self.max_speed = self._per_joint(
            "max_speed", max_speed, m, self._default_vlim(robot_vlim, all_joints), "rad/s"
        )
        if kv is None:
            raise InvalidParameter(
                "kv: expected a gain > 0 [N·m·s/rad], a scalar or per joint, got None"
            )
        self.kv = self._per_joint("kv", kv, m, None, "N·m·s/rad")
        if self.servo == "computed-torque":
            if probe.nv != len(self.joints) or probe.nq != probe.nv or self.actuated != self.joints:
                raise InvalidParameter(
                    "servo: 'computed-torque' needs a serial model whose state joints are all its "
                    f"degrees of freedom (nv = {probe.nv}, joints {list(self.joints)}); use "
                    "servo='velocity' for closed chains"
                )
        else:
            spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
            for i, name in enumerate(self.actuated):
                a = spec.add_actuator()
                a.name = f"velfence_servo_{name}"
                a.target = name
                a.trntype = mujoco.mjtTrn.mjTRN_JOINT
                a.set_to_velocity(kv=float(self.kv[i]))
                if math.isfinite(self.max_effort[i]):
                    a.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
                    a.forcerange = [-float(self.max_effort[i]), float(self.max_effort[i])]
        self.model = self._compile(spec)
        self.data = mujoco.MjData(self.model)
        mdl = self.model
        self._qadr = np.array([mdl.jnt_qposadr[mdl.joint(n).id] for n in self.joints])
        self._vadr = np.array([mdl.jnt_dofadr[mdl.joint(n).id] for n in self.joints])
        self._aadr = np.array([mdl.jnt_dofadr[mdl.joint(n).id] for n in self.actuated])
        self._bodies = {}
        for p in self.pushes:
            bid = mujoco.mj_name2id(mdl, mujoco.mjtObj.mjOBJ_BODY, p.body)
            if bid < 0:
                names = [mdl.body(i).name for i in range(mdl.nbody)]
                raise InvalidParameter(f"pushes: unknown body {p.body!r}; bodies: {names[:20]}")
            self._bodies[p.body] = bid
        self._obstacle_geoms = {
            int(mujoco.mj_name2id(mdl, mujoco.mjtObj.mjOBJ_GEOM, f"velfence_obstacle{i}"))
            for i in range(len(self.obstacles))
        }
        self._dt = 0.0
        self._sub = 1
        self._t = 0.0
        self._rows: dict[str, list[Any]] = {}
        self._Mv = np.zeros(mdl.nv)

    # -- construction helpers -------------------------------------------------------------------

    @staticmethod
    def _document(robot: Any) -> tuple[str, FloatArray | None]:
        if isinstance(robot, str):
            return check_text("robot", robot, max_length=100_000_000), None
        xml = getattr(robot, "xml", None)
        if not isinstance(xml, str):
            raise InvalidParameter(
                f"robot: expected a velfence.robots.MujocoRobot or an MJCF document (str), got "
                f"{type(robot).__name__}"
            )
        vlim = getattr(robot, "velocity_limits", None)
        return xml, None if vlim is None else np.asarray(vlim, dtype=float)

    def _compile(self, spec: Any) -> Any:
        from velfence.errors import InvalidGeometry

        try:
            return spec.compile()
        except ValueError as exc:
            first = (str(exc).strip().splitlines() or ["no message"])[0][:200]
            raise InvalidGeometry(
                f"robot: expected an MJCF document MuJoCo compiles, got the error: {first}"
            ) from None

    @staticmethod
    def _obstacles(obstacles: Any) -> tuple[SphereObstacle, ...]:
        if isinstance(obstacles, (str, bytes)) or not isinstance(obstacles, Sequence):
            raise InvalidParameter(
                f"obstacles: expected a sequence of SphereObstacle, got {type(obstacles).__name__}"
            )
        bad = [i for i, o in enumerate(obstacles) if not isinstance(o, SphereObstacle)]
        if bad:
            raise InvalidParameter(f"obstacles: entries {bad[:5]} are not SphereObstacle")
        return tuple(obstacles)

    @staticmethod
    def _pushes(pushes: Any) -> tuple[BodyPush, ...]:
        if isinstance(pushes, (str, bytes)) or not isinstance(pushes, Sequence):
            raise InvalidParameter(
                f"pushes: expected a sequence of BodyPush, got {type(pushes).__name__}"
            )
        bad = [i for i, p in enumerate(pushes) if not isinstance(p, BodyPush)]
        if bad:
            raise InvalidParameter(f"pushes: entries {bad[:5]} are not BodyPush")
        return tuple(pushes)

    @staticmethod
    def _names(arg: str, names: Any, known: list[str], *, default: list[str]) -> tuple[str, ...]:
        if names is None:
            return tuple(default)
        out = check_names(arg, names)
        unknown = [n for n in out if n not in known]
        if unknown:
            raise InvalidParameter(
                f"{arg}: expected names from {known[:20]}, got unknown {unknown[:5]}"
            )
        return out

    @staticmethod
    def _per_joint(
        arg: str, value: Any, m: int, default: FloatArray | None, unit: str
    ) -> FloatArray:
        if value is None:
            if default is None:
                return readonly(np.full(m, np.inf))
            return readonly(np.array(default, dtype=float))
        a = real_array(arg, value, None, error=InvalidParameter, what=f"limits [{unit}]")
        if a.ndim == 0:
            a = np.full(m, float(a))
        if a.shape != (m,):
            raise InvalidParameter(
                f"{arg}: expected a scalar or shape ({m},) [{unit}], got {a.shape}"
            )
        if np.any(a <= 0.0):
            raise InvalidParameter(f"{arg}: expected values > 0 [{unit}], got {a.tolist()}")
        return readonly(a)

    def _default_vlim(self, vlim: FloatArray | None, all_joints: list[str]) -> FloatArray | None:
        if vlim is None or vlim.shape != (len(all_joints),):
            return None
        idx = [all_joints.index(n) for n in self.actuated]
        out = vlim[idx]
        return out if np.all(out > 0.0) else None

    # -- the plant protocol ---------------------------------------------------------------------

    @property
    def time_constant(self) -> float:
        """The computed-torque servo's lag time constant ``1 / bandwidth`` [s]."""
        return 1.0 / self.bandwidth

    def reset(self, q0: FloatArray, dt: float) -> FloatArray:
        """Start a run at joint position ``q0``, at rest, with control period ``dt`` [s].

        Args:
            q0: State joint positions, shape (n,).
            dt: Control period [s]; a whole multiple of ``physics_dt`` (within 1e-6 relative).

        Returns:
            The true initial state (``q0`` as assembled), shape (n,).

        Raises:
            InvalidParameter: ``dt`` not a multiple of ``physics_dt``.
            InvalidInput: ``q0`` of the wrong shape, or an ``assemble`` result that is.
        """
        mj = self._mj
        dt = check_positive("dt", dt, unit="s")
        r = dt / self.physics_dt
        sub = round(r)
        if sub < 1 or abs(r - sub) > 1e-6 * max(1.0, r) or sub > _MAX_SUBSTEPS:
            raise InvalidParameter(
                f"dt: expected a whole multiple (1 … {_MAX_SUBSTEPS}) of physics_dt = "
                f"{self.physics_dt} s, got dt = {dt} s"
            )
        n = len(self.joints)
        q = real_array("q0", q0, (n,), what="joint positions")
        mj.mj_resetData(self.model, self.data)
        if self._assemble is not None:
            full = real_array("assemble(q)", self._assemble(q), (self.model.nq,), what="a qpos")
            self.data.qpos[:] = full
        else:
            self.data.qpos[self._qadr] = q
        mj.mj_forward(self.model, self.data)
        self._dt, self._sub, self._t = float(dt), int(sub), 0.0
        self._rows = {k: [] for k in ("t", "qpos", "qvel", "effort", "clipped", "nc", "depth")}
        self._log(False, 0, 0.0, np.zeros(len(self.actuated)))
        return self.state()

    def state(self) -> FloatArray:
        """The true state joint positions now, shape (n,)."""
        return np.array(self.data.qpos[self._qadr], dtype=float)

    def advance(self, v: FloatArray, t: float) -> FloatArray:
        """Hold the velocity reference ``v`` over one control period and simulate it.

        Args:
            v: Joint velocity reference of the state joints, shape (n,).
            t: Time at the start of the period [s].

        Returns:
            The true state at the end of the period, shape (n,).

        Raises:
            InvalidInput: the transmission's result has the wrong shape or is not finite, or
                the simulation diverged (MuJoCo's warnings, non-finite state).
        """
        mj, mdl, d = self._mj, self.model, self.data
        if not self._rows:
            raise InvalidInput("advance: expected reset(q0, dt) first, got no run started")
        ref = real_array("v", v, (len(self.joints),), what="joint velocity references")
        t = finite_scalar("t", t, unit="s", what="time")
        q = self.state()
        if self._transmission is not None:
            ref = real_array(
                "transmission(q, v)",
                self._transmission(q, ref),
                (len(self.actuated),),
                what="actuated velocity references",
            )
        ref = np.clip(ref, -self.max_speed, self.max_speed)
        clipped = False
        ncon = 0
        depth = 0.0
        effort = np.zeros(len(self.actuated))
        for s in range(self._sub):
            ts = t + s * self.physics_dt
            d.xfrc_applied[:] = 0.0
            for p in self.pushes:
                if p.start <= ts < p.start + p.duration:
                    d.xfrc_applied[self._bodies[p.body], :3] += p.force
                    d.xfrc_applied[self._bodies[p.body], 3:] += p.torque
            mj.mj_step1(mdl, d)
            if self.servo == "computed-torque":
                tau, sat = computed_torque(
                    mj, mdl, d, self._aadr, ref, bandwidth=self.bandwidth,
                    max_effort=self.max_effort, scratch=self._Mv,
                )  # fmt: skip
                clipped = clipped or sat
                d.qfrc_applied[:] = 0.0
                d.qfrc_applied[self._aadr] = tau
                effort = tau
            else:
                d.ctrl[:] = ref
            mj.mj_step2(mdl, d)
            if self.servo == "velocity":
                effort = np.array(d.actuator_force, dtype=float)
                lim = self.max_effort
                if np.any(np.abs(effort) >= lim * (1.0 - 1e-9)):
                    clipped = True
            c, dep = self._contacts()
            ncon = max(ncon, c)
            depth = max(depth, dep)
        if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
            raise InvalidInput(
                f"the physics diverged in the period starting at t = {t} s (non-finite state); "
                "lower physics_dt or the servo gains"
            )
        self._t = t + self._dt
        self._log(clipped, ncon, depth, effort)
        return self.state()

    def _contacts(self) -> tuple[int, float]:
        d = self.data
        if not self._obstacle_geoms or d.ncon == 0:
            return 0, 0.0
        count, depth = 0, 0.0
        obs = self._obstacle_geoms
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            if (g1 in obs) != (g2 in obs) and float(c.dist) < 0.0:
                count += 1
                depth = max(depth, -float(c.dist))
        return count, depth

    def _log(self, clipped: bool, ncon: int, depth: float, effort: FloatArray) -> None:
        r = self._rows
        r["t"].append(self._t)
        r["qpos"].append(np.array(self.data.qpos, dtype=float))
        r["qvel"].append(np.array(self.data.qvel[self._vadr], dtype=float))
        r["effort"].append(np.array(effort, dtype=float))
        r["clipped"].append(bool(clipped))
        r["nc"].append(int(ncon))
        r["depth"].append(float(depth))

    @property
    def record(self) -> PhysicsRecord:
        """The last run's :class:`PhysicsRecord`.

        Raises:
            InvalidInput: no run yet.
        """
        r = self._rows
        if not r:
            raise InvalidInput("record: expected a run first (simulate(..., plant=this plant))")
        return PhysicsRecord(
            t=readonly(np.array(r["t"])),
            qpos=readonly(np.array(r["qpos"])),
            qvel=readonly(np.array(r["qvel"])),
            effort=readonly(np.array(r["effort"])),
            clipped=readonly(np.array(r["clipped"], dtype=bool)),
            contacts=readonly(np.array(r["nc"], dtype=np.int64)),
            contact_depth=readonly(np.array(r["depth"])),
        )


document_inits(globals())
