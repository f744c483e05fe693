r"""The Panda-like arm's TCP in a box, in MuJoCo: operator pushes, an external push, a sphere.

Scene (``docs/physics.md``): :func:`velfence.robots.panda` with capsule links of radius 0.05 m,
the TCP at the flange; the box :math:`[0.35, 0.65] \times [-0.25, 0.25] \times [0.30, 0.60]` m
(the TCP starts at (0.47, 0, 0.52) m); a sphere of radius 0.04 m at (0.55, -0.12, 0.48) m, a MuJoCo
geom the links can touch. The operator (:class:`~velfence.sim.scenarios.TcpJog`, speed
``speed``) jogs into the corner (x_max, y_max, z_min), along the face z_min pressing it, holds
near the face x_min while a 25 N push along −x acts on the flange body for 0.4 s, jogs through
the sphere to a target beyond x_max, and ends at a waypoint inside. Joint 1 (base rotation) is
limited to the cell's range :data:`CELL_JOINT1` (the corner targets need more), so the per-joint
clamp has something to clamp.

Controllers: ``"no-limit"`` (damped resolved rate), ``"per-joint-clamp"`` (resolved rate, joint
velocity and position limits), ``"safety-filter"`` (:class:`~velfence.filter.SafetyFilter`
in twist mode: box, joint limits, sphere) and ``"safety-filter-look-ahead"``
(:class:`~velfence.shaping.lookahead.LagCompensation` around it). The plant is the
computed-torque servo of :class:`~velfence.sim.physics.MujocoPlant` (bandwidth 25 rad/s, the
Panda's effort limits, 2 kHz physics, 500 Hz control).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence.apps.labels import method_label
from velfence.apps.reproduce.base import Check, Report, check_at_least, check_at_most
from velfence.apps.scenarios.common import PhysicsRun, ScenarioResult, scenario_methods
from velfence.geometry.polytope import ConvexPolytope
from velfence.sim.metrics import box_penetration, face_sliding_ratio, joint_limit_violation
from velfence.sim.runner import simulate
from velfence.sim.scenarios import TcpJog

__all__ = ["BOX_LOWER", "BOX_UPPER", "CELL_JOINT1", "METHODS", "run"]

#: The compared controllers, in table order.
METHODS: tuple[str, ...] = (
    "no-limit",
    "per-joint-clamp",
    "safety-filter",
    "safety-filter-look-ahead",
)
BOX_LOWER = (0.35, -0.25, 0.30)
BOX_UPPER = (0.65, 0.25, 0.60)
SPHERE_CENTER = (0.55, -0.12, 0.48)
SPHERE_RADIUS = 0.04
#: The cell's own range of joint 1 (base rotation) [rad], narrower than the arm's ±2.8973: a
#: layout limit like the joint position limits of a vendor safety configuration.
CELL_JOINT1 = (-0.2, 0.2)
Q0 = (0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8)
DT = 2e-3
PHYSICS_DT = 5e-4
BANDWIDTH = 25.0
BUFFER = 0.05
PUSH_FORCE = (-25.0, 0.0, 0.0)
PUSH_DURATION = 0.4
#: (label, target [m], pressed face, push during the phase)
_SCRIPT: tuple[tuple[str, tuple[float, float, float], str, bool], ...] = (
    ("into the corner x_max, y_max, z_min", (0.72, 0.32, 0.22), "", False),
    ("along the face z_min, pressing it", (0.45, -0.20, 0.22), "z_min", False),
    ("hold near x_min, pushed along -x", (0.40, -0.10, 0.40), "", True),
    ("through the sphere, past x_max", (0.70, -0.14, 0.56), "", False),
    ("to the final waypoint", (0.45, 0.15, 0.55), "", False),
)
UNITS = {
    "operator_penetration": "m",
    "push_penetration": "m",
    "recovery_time": "s",
    "sliding_ratio": "1",
    "joint_limit_violation": "rad",
    "operator_joint_violation": "rad",
    "contact_steps": "periods",
    "contact_depth": "m",
    "clipped_steps": "periods",
    "final_error": "m",
}


def script_phases(
    x0: FloatArray, speed: float, dwell: float
) -> list[tuple[str, float, float, Any]]:
    """The scenario's phases from the start point ``x0`` (internal API, shared with the viewer).

    Args:
        x0: Start TCP position [m], shape (3,).
        speed: TCP speed of each move [m/s].
        dwell: Pause after each move [s].

    Returns:
        ``(label, start [s], end [s], (target, face, pushed))`` for each phase, in time order.
    """
    out = []
    t, prev = 0.0, x0
    for k, (label, target, face, pushed) in enumerate(_SCRIPT):
        tg = np.array(target)
        dur = float(np.linalg.norm(tg - prev)) / speed + dwell
        if pushed:
            dur = max(dur, 2.0 * PUSH_DURATION + 0.6)
        if k == len(_SCRIPT) - 1:
            dur += dwell
        out.append((label, t, t + dur, (tg, face, pushed)))
        t += dur
        prev = tg
    return out


def build_controllers(
    robot: Any, box: ConvexPolytope, lim: FloatArray, methods: Sequence[str]
) -> dict[str, Any]:
    """The scenario's controller of each method (internal API, shared with the viewer).

    Args:
        robot: The arm (a :class:`~velfence.robots.MujocoRobot`).
        box: The TCP's workspace box.
        lim: Joint position limits [rad], shape (n, 2).
        methods: Names of the methods to build.

    Returns:
        The controller of each method, by name.
    """
    from velfence.filter import SafetyFilter
    from velfence.filter.limits import JointLimits, SphereObstacle, WorkspaceLimit
    from velfence.filter.twist import TwistMode
    from velfence.shaping.lookahead import LagCompensation
    from velfence.sim.arm_baselines import JointClamp, ResolvedRate

    vmax = np.asarray(getattr(robot, "velocity_limits", np.full(robot.dof, np.inf)), dtype=float)
    limits = JointLimits(lim[:, 0], lim[:, 1], max_speed=np.where(np.isfinite(vmax), vmax, 2.0))
    sphere = SphereObstacle(np.array(SPHERE_CENTER), radius=SPHERE_RADIUS, name="sphere")

    def joint_filter() -> Any:
        return SafetyFilter(
            robot,
            limits=limits,
            workspace=(WorkspaceLimit(box, point="tcp", buffer=BUFFER),),
            obstacles=(sphere,),
            dt=DT,
            obstacle_buffer=0.05,
        )

    def vf() -> Any:
        return TwistMode(joint_filter())

    def ahead() -> Any:
        f = joint_filter()
        return LagCompensation(TwistMode(f), time_constant=1.0 / BANDWIDTH, dt=DT, guard=f)

    make: dict[str, Callable[[], Any]] = {
        "no-limit": lambda: ResolvedRate(robot, limits=limits, dt=DT),
        "per-joint-clamp": lambda: JointClamp(robot, limits=limits, dt=DT),
        "safety-filter": vf,
        "safety-filter-look-ahead": ahead,
    }
    return {m: make[m]() for m in methods}


def run(
    *,
    speed: float = 0.25,
    methods: Sequence[str] = METHODS,
    on_step: Callable[[str, float], None] | None = None,
) -> ScenarioResult:
    """Run every controller through the script in MuJoCo (module docstring).

    Args:
        speed: Jog speed [m/s], > 0.
        methods: Which of :data:`METHODS` to run.
        on_step: Progress ``(method, fraction)``.

    Returns:
        The runs, metrics and named checks.
    """
    from velfence.filter.limits import SphereObstacle
    from velfence.robots import panda
    from velfence.sim.physics import BodyPush, MujocoPlant

    robot = panda(radius=0.05)
    box = ConvexPolytope.box(np.array(BOX_LOWER), np.array(BOX_UPPER))
    q0 = np.array(Q0)
    x0 = robot.fk(q0)
    phases = script_phases(x0, speed, dwell=0.4)
    duration = phases[-1][2]
    push_phase = next(p for p in phases if p[3][2])
    push_t0 = push_phase[1] + 0.3
    push = BodyPush(body="link6", force=np.array(PUSH_FORCE), start=push_t0, duration=PUSH_DURATION)
    sphere = SphereObstacle(np.array(SPHERE_CENTER), radius=SPHERE_RADIUS, name="sphere")
    lim = np.array(robot.joint_limits)
    lim[0] = CELL_JOINT1
    methods = scenario_methods(methods, METHODS)
    ctrl = build_controllers(robot, box, lim, methods)
    runs: dict[str, PhysicsRun] = {}
    for name in methods:
        plant = MujocoPlant(
            robot,
            bandwidth=BANDWIDTH,
            physics_dt=PHYSICS_DT,
            obstacles=[sphere],
            pushes=[push],
        )
        jog = TcpJog(robot.fk, [(p[2], p[3][0]) for p in phases], speed=speed)
        progress = None if on_step is None else (lambda f, name=name: on_step(name, f))
        tr = simulate(
            ctrl[name],
            jog,
            q0,
            duration=duration,
            dt=DT,
            plant=plant,
            name=name,
            on_progress=progress,
        )
        tcp = np.array([robot.fk(q) for q in tr.p])
        margin = np.min(box.normals @ tcp.T - box.offsets[:, None], axis=0)
        runs[name] = PhysicsRun(name, tr, plant.record, plant.model, tcp, {"margin": margin})
    metrics = _metrics(runs, box, phases, push_t0, lim)
    report = _report(metrics, speed)
    scene = {
        "polytope": box,
        "spheres": [(np.array(SPHERE_CENTER), SPHERE_RADIUS)],
        "push": (push_t0, push_t0 + PUSH_DURATION),
        "point": "TCP",
        "camera": {
            "lookat": (0.3, 0.0, 0.42),
            "distance": 1.75,
            "azimuth": 145.0,
            "elevation": -24.0,
        },
        "margin": ("TCP distance inside the box", "m", {"buffer": BUFFER, "wall": 0.0}),
    }
    return ScenarioResult("fence-box", runs, metrics, UNITS, report, scene)


def _metrics(
    runs: dict[str, PhysicsRun],
    box: ConvexPolytope,
    phases: list[tuple[str, float, float, Any]],
    push_t0: float,
    limits: FloatArray,
) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {}
    push_end = push_t0 + PUSH_DURATION
    face = next(p for p in phases if p[3][1])
    push_phase_end = next(p for p in phases if p[3][2])[2]
    final = np.array(_SCRIPT[-1][1])
    for name, r in runs.items():
        t, tcp = r.trajectory.t, r.point
        outside = -np.min(box.normals @ tcp.T - box.offsets[:, None], axis=0)
        op = (t < push_t0) | (t >= push_phase_end)
        pw = (t >= push_t0) & (t < push_phase_end)
        rows = (t >= face[1]) & (t < face[2])
        late = np.flatnonzero((t >= push_end) & (outside > 1e-4))
        rec = r.record
        if not np.any(outside[pw] > 1e-4):
            recovery = 0.0
        elif late.size and late[-1] >= np.flatnonzero(t < push_phase_end)[-1]:
            recovery = math.inf  # still outside when the phase ends
        else:
            recovery = float(t[late[-1]] - push_end) if late.size else 0.0
        out[name] = {
            "operator_penetration": box_penetration(tcp[op], box),
            "push_penetration": max(0.0, float(outside[pw].max())),
            "recovery_time": recovery,
            "sliding_ratio": face_sliding_ratio(
                t[rows], tcp[rows], r.trajectory.v_cmd[rows], box, band=BUFFER + 0.01
            ),
            "joint_limit_violation": joint_limit_violation(
                r.trajectory.p, limits[:, 0], limits[:, 1]
            ),
            "operator_joint_violation": joint_limit_violation(
                r.trajectory.p[op], limits[:, 0], limits[:, 1]
            ),
            "contact_steps": float(rec.contact_steps),
            "contact_depth": float(rec.contact_depth.max()),
            "clipped_steps": float(np.count_nonzero(rec.clipped)),
            "final_error": float(np.linalg.norm(tcp[-1] - final)),
        }
    return out


def _report(metrics: dict[str, dict[str, float]], speed: float) -> Report:
    src = "scenario: Panda-like TCP in a box, MuJoCo"
    checks: list[Check] = []
    for m in ("safety-filter", "safety-filter-look-ahead"):
        if m not in metrics:
            continue
        v = metrics[m]
        tol = 0.005 if m == "safety-filter" else 0.001
        checks += [
            check_at_most(
                f"{method_label(m)}: operator penetration [m]",
                src,
                tol,
                v["operator_penetration"],
                "servo lag eats the buffer; the look-ahead removes it",
            ),
            (
                check_at_most(
                    f"{method_label(m)}: obstacle contacts [periods]", src, 0.0, v["contact_steps"]
                )
                if m != "safety-filter"
                else check_at_most(
                    f"{method_label(m)}: deepest obstacle contact [m]",
                    src,
                    5e-4,
                    v["contact_depth"],
                    "servo lag: the plain filter grazes the sphere; the look-ahead keeps it off",
                )
            ),
            check_at_most(
                f"{method_label(m)}: joint limit violation, operator phases [rad]",
                src,
                6e-3 if m == "safety-filter" else 1e-6,
                v["operator_joint_violation"],
                "servo lag carries the plain filter past a joint limit it commands to stop at; "
                "the look-ahead stops it in time",
            ),
            check_at_least(
                f"{method_label(m)}: sliding ratio along z_min", src, 0.9, v["sliding_ratio"]
            ),
            check_at_most(
                f"{method_label(m)}: recovery after the push [s]", src, 1.0, v["recovery_time"]
            ),
            check_at_most(
                f"{method_label(m)}: TCP outside during the push [m]",
                src,
                0.06,
                v["push_penetration"],
                "a 25 N push on the wrist overpowers the velocity servo (about 50 mm with the "
                "Gaz et al. masses); the filter brings it back",
            ),
            check_at_most(
                f"{method_label(m)}: final waypoint error [m]", src, 0.01, v["final_error"]
            ),
        ]
    if "safety-filter-look-ahead" in metrics:
        checks.append(
            check_at_most(
                "velfence + look-ahead: joint limit violation, whole run [rad]",
                src,
                1e-6,
                metrics["safety-filter-look-ahead"]["joint_limit_violation"],
            )
        )
    if "no-limit" in metrics:
        v = metrics["no-limit"]
        checks += [
            check_at_least(
                "no limit leaves the box [m] (stated failure)", src, 0.05, v["operator_penetration"]
            ),
            check_at_least(
                "no limit hits the sphere [periods] (stated failure)", src, 1.0, v["contact_steps"]
            ),
        ]
        checks.append(
            check_at_least(
                "no limit exceeds the cell's joint-1 range [rad] (stated failure)",
                src,
                0.02,
                v["operator_joint_violation"],
            )
        )
    if "per-joint-clamp" in metrics:
        v = metrics["per-joint-clamp"]
        checks += [
            check_at_least(
                "per-joint clamp leaves the box [m] (stated failure)",
                src,
                0.05,
                v["operator_penetration"],
            ),
            check_at_most(
                "per-joint clamp: joint limit violation, operator phases [rad]",
                src,
                0.02,
                v["operator_joint_violation"],
                "it lands on the limit in one period; servo lag adds a little",
            ),
        ]
    return Report(f"sim fence-box ({speed} m/s)", tuple(checks))
