r"""The arm-in-a-box demo: a 7-DoF arm jogged in Cartesian space, five ways of keeping it safe.

The scene (:func:`arm_box_scene`): the 7R arm of :meth:`~velfence.mechanisms.DHChain.seven_dof`
with capsule links of radius 0.05 m; its TCP (the flange centre) must stay in an axis-aligned box
(:meth:`~velfence.geometry.polytope.ConvexPolytope.box`); a sphere stands near the path; joint 0
(the base) has a narrowed range whose lower end the path crosses.

The operator (the library's :class:`~velfence.sim.scenarios.TcpJog`, built by :func:`arm_jog`)
is a scripted jog in Cartesian space: during phase ``k`` it
commands the TCP velocity :math:`v = \min(s, g\,\|e\|)\,e/\|e\|` towards the phase's target,
:math:`e = x^\star_k - x_{tcp}(q)`, with the jog speed ``s`` [m/s] and gain ``g`` [1/s]. The
phases (:func:`arm_script`): into a corner of the box, along a face (pressing it), past joint 0's
limit, past the sphere, to a final waypoint; each lasts its straight-line length over ``s`` plus a
dwell, so the script scales with the speed.

The loop is :func:`velfence.sim.simulate` on the joint state (kinematic plant
:math:`q_{k+1} = q_k + \Delta t\,\dot q_k`, :math:`\Delta t` = 1 ms) with the command in task
space: every controller maps ``(q, v)`` to :math:`\dot q` (the library's baselines,
:mod:`velfence.sim.arm_baselines`, and its :class:`~velfence.filter.SafetyFilter` through
:class:`~velfence.filter.TwistMode`). ``velfence demo --scenario arm-box`` runs it
(:func:`velfence.apps.demo.run_arm_demo`); until 0.2 it was ``velfence.sim.arm``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from velfence._deprecate import method_name, renamed_attribute
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_positive,
    describe,
    readonly,
)
from velfence.errors import InvalidParameter
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain
from velfence.shaping.base import Shaper
from velfence.sim.arm_baselines import DamperQP, JointClamp, ResolvedRate, ScalarScale
from velfence.sim.metrics import (
    box_penetration,
    face_sliding_ratio,
    joint_limit_violation,
    max_joint_acceleration,
    sphere_penetration,
    time_to_reach,
)
from velfence.sim.runner import Trajectory, simulate
from velfence.sim.scenarios import TcpJog

__all__ = [
    "ARM_METHODS",
    "ARM_SPEEDS",
    "ArmPhase",
    "ArmRun",
    "ArmScene",
    "ArmScript",
    "arm_box_scene",
    "arm_jog",
    "arm_methods",
    "arm_metrics",
    "arm_script",
    "build_arm_controllers",
    "run_arm",
]

#: The compared controllers, in table order: each is the ``.method`` its controller reports
#: (the names of ``docs/architecture.md``, "Vocabulary"; legends and tables show
#: :func:`velfence.apps.labels.method_label`). The names before 0.2 (``"no limit"``,
#: ``"per-joint clamp"``, ``"scalar scale"``, ``"damper QP"``, ``"velfence"``) are accepted as
#: input with a warning until 0.3.
ARM_METHODS: tuple[str, ...] = (
    "no-limit",
    "per-joint-clamp",
    "scalar-scale",
    "velocity-damper-qp",
    "safety-filter",
)
#: Jog speeds of the demo [m/s].
ARM_SPEEDS: tuple[float, ...] = (0.1, 0.25, 0.5)


@dataclass(frozen=True)
class ArmScene:
    """Robot, limits and obstacles of the arm-in-a-box scenario.

    Attributes:
        robot: The 7R arm with capsule links.
        box: The TCP's permitted box, a 3-D ConvexPolytope [m].
        box_lower: The box's lower corner, shape (3,), [m].
        box_upper: The box's upper corner, shape (3,), [m].
        sphere_center: Centre of the spherical obstacle, shape (3,), [m].
        sphere_radius: Its radius [m].
        lower: Lower joint limits, shape (n,), [rad].
        upper: Upper joint limits, shape (n,), [rad].
        max_speed: Joint speed limits, shape (n,), [rad/s] (``max_velocity``: its deprecated
            name, warns until 0.3).
        max_acceleration: Joint acceleration limits, shape (n,), [rad/s²].
        q0: Initial joint position, shape (n,), [rad] (TCP inside the box, at rest).
        dt: Control and integration period [s].
        buffer: Distance from a face where velfence starts slowing the TCP [m].
        obstacle_buffer: Clearance where the obstacle rows start acting [m].
    """

    robot: DHChain
    box: ConvexPolytope
    box_lower: FloatArray
    box_upper: FloatArray
    sphere_center: FloatArray
    sphere_radius: float
    lower: FloatArray
    upper: FloatArray
    max_speed: FloatArray
    max_acceleration: FloatArray
    q0: FloatArray
    dt: float = 1e-3
    buffer: float = 0.03
    obstacle_buffer: float = 0.05

    max_velocity = renamed_attribute("max_velocity", "max_speed")

    @property
    def tcp0(self) -> FloatArray:
        """TCP position at ``q0``, shape (3,), [m]."""
        return np.asarray(self.robot.end_effector(self.q0), dtype=float)


def arm_box_scene(*, dt: float = 1e-3) -> ArmScene:
    """The built-in scene (values in ``docs/arm_box.md``).

    Args:
        dt: Control period [s], > 0 (default 1 ms).
    """
    dt = check_positive("dt", dt, unit="s")
    hi = np.radians([170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0])
    lower, upper = -hi, hi.copy()
    lower[0] = -0.15  # joint 0 narrowed: the path along the face crosses this end
    box_lower = readonly(np.array([0.45, -0.25, 0.35]))
    box_upper = readonly(np.array([0.80, 0.25, 0.70]))
    robot = DHChain.seven_dof(joint_limits=np.stack([lower, upper], axis=1), link_radius=0.05)
    return ArmScene(
        robot=robot,
        box=ConvexPolytope.box(box_lower, box_upper),
        box_lower=box_lower,
        box_upper=box_upper,
        sphere_center=readonly(np.array([0.67, -0.02, 0.39])),
        sphere_radius=0.05,
        lower=readonly(lower),
        upper=readonly(upper),
        max_speed=readonly(np.radians([85.0, 85.0, 100.0, 75.0, 130.0, 135.0, 135.0])),
        max_acceleration=readonly(np.full(7, 20.0)),
        q0=readonly(np.array([0.0, 0.5, 0.0, 1.6, 0.0, -1.0, 0.0])),
        dt=dt,
    )


@dataclass(frozen=True)
class ArmPhase:
    """One phase of the jog script.

    Attributes:
        label: What the phase does.
        t0: Start time [s].
        t1: End time [s].
        target: The TCP target of the phase, shape (3,), [m] (may lie outside the box).
        face: Name of the box face the phase presses (for the sliding ratio), or ``""``.
    """

    label: str
    t0: float
    t1: float
    target: FloatArray
    face: str = ""


@dataclass(frozen=True)
class ArmScript:
    """The jog script at one speed.

    Attributes:
        speed: Jog speed [m/s].
        phases: The phases, back to back from ``t = 0``.
        duration: End of the last phase [s].
        final: The final waypoint, shape (3,), [m] (inside the box, clear of the sphere).
    """

    speed: float
    phases: tuple[ArmPhase, ...]
    duration: float
    final: FloatArray


#: (label, target [m], pressed face) of the built-in script.
_SCRIPT: tuple[tuple[str, tuple[float, float, float], str], ...] = (
    ("into the corner x_max, y_max, z_max", (0.86, 0.32, 0.76), ""),
    ("along the face x_max, past joint 0's limit", (0.84, -0.20, 0.50), "x_max"),
    ("past the sphere", (0.56, 0.16, 0.42), ""),
    ("to the final waypoint", (0.62, 0.10, 0.55), ""),
)


def _scene(scene: object) -> ArmScene:
    if not isinstance(scene, ArmScene):
        raise InvalidParameter(
            f"scene: expected an ArmScene (arm_box_scene()), got {describe(scene)}"
        )
    return scene


def arm_methods(methods: object) -> tuple[str, ...]:
    """Names from :data:`ARM_METHODS`, at least one; a name before 0.2 warns and is translated.

    Args:
        methods: A list or tuple of method names.

    Returns:
        The names, in the given order, each one of :data:`ARM_METHODS`.

    Raises:
        InvalidParameter: not a list of known names, or an empty one.
    """
    if isinstance(methods, (str, bytes)) or not isinstance(methods, (list, tuple)):
        raise InvalidParameter(
            f"methods: expected a list of names from {list(ARM_METHODS)}, got {describe(methods)}"
        )
    out = [method_name(m, what="arm-box method name", stacklevel=5) for m in methods]
    unknown = [m for m in out if not isinstance(m, str) or m not in ARM_METHODS]
    if unknown or not methods:
        raise InvalidParameter(
            f"methods: expected names from {list(ARM_METHODS)}, got {describe(unknown or methods)}"
        )
    return tuple(str(m) for m in out)


def arm_script(scene: ArmScene, speed: float, *, dwell: float = 0.4) -> ArmScript:
    """The built-in jog script at ``speed``.

    Phase ``k`` lasts ``|target_k - target_{k-1}| / speed + dwell`` (``target_{-1}`` = the TCP at
    ``q0``); the last phase gets twice the dwell.

    Args:
        scene: The scene (for the start position).
        speed: Jog speed [m/s], > 0.
        dwell: Extra time per phase [s], >= 0.

    Returns:
        The script (phases and total duration).

    Raises:
        InvalidParameter: not an :class:`ArmScene`, or a speed or dwell out of range.
    """
    scene = _scene(scene)
    speed = check_positive("speed", speed, unit="m/s")
    dwell = check_positive("dwell", dwell, allow_zero=True, unit="s")
    prev = scene.tcp0
    t = 0.0
    phases = []
    for k, (label, target, face) in enumerate(_SCRIPT):
        tg = np.array(target)
        dur = float(np.linalg.norm(tg - prev)) / speed + dwell * (
            2.0 if k == len(_SCRIPT) - 1 else 1.0
        )
        if not math.isfinite(t + dur):
            raise InvalidParameter(
                f"speed: {speed:g} m/s is too slow for a finite script (phase {k} would last "
                f"{dur:g} s)"
            )
        phases.append(ArmPhase(label, t, t + dur, readonly(tg), face))
        t += dur
        prev = tg
    return ArmScript(speed, tuple(phases), t, readonly(np.array(_SCRIPT[-1][1])))


def arm_jog(robot: DHChain, script: ArmScript, *, gain: float = 8.0) -> TcpJog:
    """The scripted Cartesian jog of ``script`` on the arm's TCP (module docstring).

    Args:
        robot: The arm (its TCP, ``robot.end_effector``, is jogged).
        script: The phases (:func:`arm_script`).
        gain: Approach gain near a target [1/s], > 0.

    Returns:
        The library's :class:`~velfence.sim.scenarios.TcpJog` with the script's phases and speed.

    Raises:
        InvalidParameter: not a :class:`~velfence.mechanisms.DHChain` or an
            :class:`ArmScript`, or a bad gain.
    """
    if not isinstance(robot, DHChain):
        raise InvalidParameter(f"robot: expected a DHChain, got {describe(robot)}")
    if not isinstance(script, ArmScript):
        raise InvalidParameter(
            f"script: expected an ArmScript (arm_script()), got {describe(script)}"
        )
    return TcpJog(
        robot.end_effector,
        [(ph.t1, ph.target) for ph in script.phases],
        speed=script.speed,
        gain=gain,
    )


def _limits(scene: ArmScene) -> Any:
    from velfence.filter import JointLimits

    return JointLimits(
        scene.lower, scene.upper, max_speed=scene.max_speed, max_acceleration=scene.max_acceleration
    )


def build_arm_controllers(
    scene: ArmScene, *, methods: Sequence[str] = ARM_METHODS
) -> dict[str, Shaper]:
    r"""The controllers of :data:`ARM_METHODS` (or a subset), built for ``scene``.

    Damper settings shared by the scalar scale and the QP: position gain 0.95, workspace gain 0.5,
    obstacle gain :math:`\xi` = 0.5 m/s, influence 0.1 m, safety clearance 0.

    Args:
        scene: The scene.
        methods: Names from :data:`ARM_METHODS`.

    Returns:
        Method -> controller.

    Raises:
        InvalidParameter: not an :class:`ArmScene`, or an unknown method name.
    """
    scene = _scene(scene)
    methods = arm_methods(methods)
    from velfence.filter import SafetyFilter, SphereObstacle, TwistMode, WorkspaceLimit

    limits = _limits(scene)
    sphere = SphereObstacle(scene.sphere_center, radius=scene.sphere_radius, name="sphere")
    common: dict[str, Any] = {"limits": limits, "dt": scene.dt}
    obstacles = (sphere,)
    make: dict[str, Callable[[], Shaper]] = {
        "no-limit": lambda: ResolvedRate(scene.robot, **common),
        "per-joint-clamp": lambda: JointClamp(scene.robot, **common),
        "scalar-scale": lambda: ScalarScale(scene.robot, obstacles=obstacles, **common),
        "velocity-damper-qp": lambda: DamperQP(
            scene.robot, workspace=scene.box, obstacles=obstacles, **common
        ),
        "safety-filter": lambda: TwistMode(
            SafetyFilter(
                scene.robot,
                limits=limits,
                workspace=(WorkspaceLimit(scene.box, point="tcp", buffer=scene.buffer),),
                obstacles=obstacles,
                dt=scene.dt,
                obstacle_buffer=scene.obstacle_buffer,
            )
        ),
    }
    return {m: make[m]() for m in methods}


@dataclass(frozen=True)
class ArmRun:
    """One controller's closed-loop run of the scenario.

    Attributes:
        trajectory: The run (``p`` = joint positions (N, n) [rad], ``v_cmd`` = TCP commands
            (N, 3) [m/s], ``v_out`` = joint velocities (N, n) [rad/s]).
        tcp: TCP positions, shape (N, 3), [m].
        segments: Link segments per row, shape (N, L, 2, 3), [m].
        active: Names of the binding rows per row (length N).
        dropped: Priority levels relaxed per row (the safety filter; empty for the baselines).
        speed: The jog speed [m/s].
    """

    trajectory: Trajectory
    tcp: FloatArray
    segments: FloatArray
    active: tuple[tuple[str, ...], ...]
    dropped: tuple[tuple[str, ...], ...]
    speed: float


def run_arm(
    scene: ArmScene,
    speed: float,
    *,
    methods: Sequence[str] = ARM_METHODS,
    controllers: Mapping[str, Shaper] | None = None,
    on_step: Callable[[str, float], None] | None = None,
) -> dict[str, ArmRun]:
    """Run every controller through the script at ``speed`` (same start, same operator).

    Args:
        scene: The scene.
        speed: Jog speed [m/s], > 0.
        methods: Which of :data:`ARM_METHODS` to run.
        controllers: Prebuilt controllers (default :func:`build_arm_controllers`).
        on_step: Progress ``(method, fraction)``, about 100 calls per run.

    Returns:
        Method -> :class:`ArmRun`.

    Raises:
        InvalidParameter: a bad scene, speed or method name, controllers that are not a mapping
            covering ``methods``, or an ``on_step`` that is not callable.
    """
    script = arm_script(scene, speed)
    methods = arm_methods(methods)
    if controllers is not None and (
        not isinstance(controllers, Mapping) or not set(methods) <= set(controllers)
    ):
        raise InvalidParameter(
            f"controllers: expected a mapping with an entry per method {list(methods)}, got "
            f"{describe(controllers)}"
        )
    if on_step is not None and (not callable(on_step) or isinstance(on_step, type)):
        raise InvalidParameter(f"on_step: expected a function or None, got {describe(on_step)}")
    ctrl = (
        dict(controllers)
        if controllers is not None
        else build_arm_controllers(scene, methods=methods)
    )
    out: dict[str, ArmRun] = {}
    for name in methods:
        active: list[tuple[str, ...]] = []
        dropped: list[tuple[str, ...]] = []

        def record(
            k: int, t: float, res: Any, active: list[Any] = active, dropped: list[Any] = dropped
        ) -> None:
            active.append(tuple(getattr(res, "active_names", ())))
            dropped.append(tuple(getattr(res, "dropped", ())))

        progress = None if on_step is None else (lambda f, name=name: on_step(name, f))
        jog = arm_jog(scene.robot, script)
        tcp_rows: list[FloatArray] = []
        seg_rows: list[FloatArray] = []

        def command(
            t: float,
            q: FloatArray,
            jog: TcpJog = jog,
            tcp_rows: list[FloatArray] = tcp_rows,
            seg_rows: list[FloatArray] = seg_rows,
        ) -> FloatArray:
            # The loop calls the operator once per row with that row's true position: the TCP
            # and the link segments of the record come from the pose the jog has just computed
            # (the chain keeps its last pose), not from a second pass over the rows.
            v = jog(t, q)
            frame = scene.robot.kinematics(q)
            tcp_rows.append(frame.point("tcp"))
            seg_rows.append(frame.segments())
            return v

        traj = simulate(
            ctrl[name],
            command,
            scene.q0,
            duration=script.duration,
            dt=scene.dt,
            name=name,
            on_progress=progress,
            on_result=record,
        )
        tcp = np.array(tcp_rows)
        segs = np.array(seg_rows)
        out[name] = ArmRun(
            traj, readonly(tcp), readonly(segs), tuple(active), tuple(dropped), speed
        )
    return out


def arm_metrics(
    scene: ArmScene, runs: Mapping[str, ArmRun], *, reach_tol: float = 0.005
) -> dict[str, dict[str, float]]:
    """The metrics of every run (definitions in :mod:`velfence.sim.metrics`).

    Keys: ``box_penetration`` [m], ``sphere_penetration`` [m], ``joint_limit_violation`` [rad],
    ``sliding_ratio`` (face phase), ``time_to_final`` [s], ``time_lost`` [s] (against
    ``"no-limit"`` when it ran, else ``nan``), ``max_joint_acceleration`` [rad/s²],
    ``dropped_cycles`` (cycles with a relaxed priority level).

    Args:
        scene: The scene.
        runs: Method -> run, all at the same speed.
        reach_tol: Distance to the final waypoint that counts as reached [m], > 0.

    Returns:
        Method -> metric name -> value.

    Raises:
        InvalidParameter: not an :class:`ArmScene`, ``runs`` not a mapping of :class:`ArmRun`,
            or a bad ``reach_tol``.
    """
    scene = _scene(scene)
    if not isinstance(runs, Mapping) or not all(isinstance(r, ArmRun) for r in runs.values()):
        raise InvalidParameter(
            f"runs: expected a mapping of method -> ArmRun (run_arm()), got {describe(runs)}"
        )
    reach_tol = check_positive("reach_tol", reach_tol, unit="m")
    out: dict[str, dict[str, float]] = {}
    for name, run in runs.items():
        script = arm_script(scene, run.speed)
        tr = run.trajectory
        face = next(p for p in script.phases if p.face)
        rows = (tr.t >= face.t0) & (tr.t < face.t1)
        m = {
            "box_penetration": box_penetration(run.tcp, scene.box),
            "sphere_penetration": sphere_penetration(
                run.segments, scene.robot.link_radius, scene.sphere_center, scene.sphere_radius
            ),
            "joint_limit_violation": joint_limit_violation(tr.p, scene.lower, scene.upper),
            "sliding_ratio": face_sliding_ratio(
                tr.t[rows], run.tcp[rows], tr.v_cmd[rows], scene.box, band=scene.buffer + 0.01
            ),
            "time_to_final": time_to_reach(
                tr.t, run.tcp, script.final, tol=reach_tol, after=script.phases[-1].t0
            ),
            "max_joint_acceleration": max_joint_acceleration(tr),
            "dropped_cycles": float(sum(1 for d in run.dropped if d)),
        }
        out[name] = m
    ref = out.get("no-limit", {}).get("time_to_final", math.nan)
    for m in out.values():
        m["time_lost"] = m["time_to_final"] - ref if math.isfinite(ref) else math.nan
    return out


document_inits(globals())
