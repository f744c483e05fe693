r"""Jerk of the Panda's commanded joint velocity through the fence-box, in MuJoCo.

The scene of :mod:`~velfence.apps.scenarios.fence_box` (the Panda model with capsule links, the
box, the sphere, the cell's joint-1 range, the operator's scripted jog and the 25 N push on the
wrist that shoves the TCP out of the box, which the filter's recovery rows then answer) with
the Panda's published speed, acceleration and jerk limits (:meth:`MujocoRobot.limits
<velfence.robots.MujocoRobot.limits>`, Franka's table "Limits for Panda"), three ways:

* ``"safety-filter-jerk-rows"``: the :class:`~velfence.filter.SafetyFilter` in twist mode with the
  joint limits, speeds, accelerations **and jerks** (the robot at rest before the first cycle:
  ``reset(velocity=0)``);
* ``"safety-filter-no-jerk-rows"``: the same filter without ``max_jerk``;
* ``"per-joint-clamp"``: resolved rate clamped per joint to the speed and position limits.

What is measured is the jerk of the **commanded** joint velocity (what a robot controller such as
Franka's checks against its limit), from the commands alone: the second difference of the
command sequence over :math:`\Delta t^2` (the zeros of the rest before the start included), per
joint, as a fraction of the joint's limit. A cycle whose jerk rows gave way
(``FilterResult.jerk_override``: position, workspace or obstacle rows, or the acceleration limit,
won) or that ended on the deadline fallback is *flagged*; every other cycle of the jerk-row run
holds the limit (``tests/apps/scenarios/test_jerk_scenario.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_flag, check_output_path, check_positive, describe
from velfence.apps.labels import method_label
from velfence.apps.scenarios.common import scenario_methods
from velfence.errors import InvalidParameter

__all__ = ["METHODS", "JerkRow", "JerkRun", "jerk_table", "plot_jerk", "run"]

#: The compared controllers, in table order.
METHODS: tuple[str, ...] = (
    "safety-filter-jerk-rows",
    "safety-filter-no-jerk-rows",
    "per-joint-clamp",
)


@dataclass(frozen=True, eq=False)
class JerkRun:
    """One controller's run.

    Attributes:
        method: One of :data:`METHODS`.
        t: Cycle times [s], shape (N,).
        command: Commanded joint velocity of each cycle [rad/s], shape (N, 7).
        jerk: Its jerk [rad/s³], shape (N, 7): ``(c_k - 2 c_{k-1} + c_{k-2}) / dt²`` with
            ``c_{-1} = c_{-2} = 0`` (at rest before the start).
        ratio: ``|jerk| / max_jerk`` per joint [1], shape (N, 7).
        flagged: Cycles whose jerk rows gave way or that used the deadline fallback, shape (N,)
            (always false for the runs without jerk rows).
        margin: The TCP's distance inside the box [m] (negative: outside), shape (N,).
        joint_violation: Largest joint position beyond its (cell) limit [rad], >= 0.
        contacts: Physics periods with a link touching the sphere.
    """

    method: str
    t: FloatArray
    command: FloatArray
    jerk: FloatArray
    ratio: FloatArray
    flagged: Any
    margin: FloatArray
    joint_violation: float
    contacts: int


@dataclass(frozen=True)
class JerkRow:
    """One line of the table (:func:`jerk_table`).

    Attributes:
        method: The controller.
        max_ratio: Largest ``|jerk| / limit`` over every cycle and joint [1].
        max_ratio_unflagged: The same over the cycles not flagged [1].
        flagged: Flagged cycles.
        over: Cycles with some joint over its jerk limit (beyond 1e-9 relative).
        cycles: Cycles in the run.
        penetration: Largest TCP distance outside the box [m] (0: contained).
        joint_violation: Largest joint position beyond its limit [rad].
        contacts: Physics periods in contact with the sphere.
    """

    method: str
    max_ratio: float
    max_ratio_unflagged: float
    flagged: int
    over: int
    cycles: int
    penetration: float
    joint_violation: float
    contacts: int


class _AtRest:
    """A SafetyFilter in twist mode that starts each run from rest (``reset(velocity=0)``)."""

    method = "safety-filter"
    stateful = True

    def __init__(self, safety_filter: Any) -> None:
        from velfence.filter.twist import TwistMode

        self.filter = safety_filter
        self._twist = TwistMode(safety_filter)

    def reset(self) -> None:
        self.filter.reset(velocity=np.zeros(self.filter.dof))

    def explain(self, position: Any, command: Any, /) -> Any:
        return self._twist.explain(position, command)

    def shape(self, position: Any, command: Any, /) -> FloatArray:
        return self._twist.shape(position, command)

    def shape_batch(self, positions: Any, commands: Any, /) -> FloatArray:
        return self._twist.shape_batch(positions, commands)


def run(
    *,
    speed: float = 0.25,
    duration: float | None = None,
    methods: Sequence[str] = METHODS,
    push: bool = True,
    on_step: Callable[[str, float], None] | None = None,
) -> dict[str, JerkRun]:
    """Run every controller through the fence-box script in MuJoCo (module docstring).

    Args:
        speed: Jog speed [m/s], > 0.
        duration: Simulated time [s], > 0; ``None``: the whole script (about 9 s at 0.25 m/s).
        methods: Which of :data:`METHODS` to run.
        push: Whether the fence-box's external push acts (25 N on the wrist for 0.4 s).
        on_step: Progress ``(method, fraction)``.

    Returns:
        The runs, by method, in the order given.

    Raises:
        InvalidParameter: a bad speed, duration, ``push`` or ``on_step``, or ``methods`` not a
            non-empty sequence of :data:`METHODS` names.
    """
    sp = check_positive("speed", speed, unit="m/s")
    if duration is not None:
        check_positive("duration", duration, unit="s")
    methods = scenario_methods(methods, METHODS)
    push = check_flag("push", push)
    if on_step is not None and not callable(on_step):
        raise InvalidParameter(f"on_step: expected a function or None, got {describe(on_step)}")
    from velfence.apps.scenarios.fence_box import (
        BANDWIDTH,
        BOX_LOWER,
        BOX_UPPER,
        BUFFER,
        CELL_JOINT1,
        DT,
        PHYSICS_DT,
        PUSH_DURATION,
        PUSH_FORCE,
        Q0,
        SPHERE_CENTER,
        SPHERE_RADIUS,
        script_phases,
    )
    from velfence.filter import SafetyFilter
    from velfence.filter.limits import JointLimits, SphereObstacle, WorkspaceLimit
    from velfence.geometry.polytope import ConvexPolytope
    from velfence.robots import panda
    from velfence.sim.arm_baselines import JointClamp
    from velfence.sim.metrics import joint_limit_violation
    from velfence.sim.physics import BodyPush, MujocoPlant
    from velfence.sim.runner import simulate
    from velfence.sim.scenarios import TcpJog

    robot = panda(radius=0.05)
    box = ConvexPolytope.box(np.array(BOX_LOWER), np.array(BOX_UPPER))
    q0 = np.array(Q0)
    phases = script_phases(robot.fk(q0), sp, dwell=0.4)
    total = phases[-1][2] if duration is None else check_positive("duration", duration, unit="s")
    lim = np.array(robot.joint_limits)
    lim[0] = CELL_JOINT1
    published = robot.limits()
    sphere = SphereObstacle(np.array(SPHERE_CENTER), radius=SPHERE_RADIUS, name="sphere")
    push_t0 = next(p for p in phases if p[3][2])[1] + 0.3  # as the fence-box scenario
    pushes = [
        BodyPush(
            body="link6", force=np.array(PUSH_FORCE), start=push_t0, duration=PUSH_DURATION
        )
    ] if push else []  # fmt: skip

    def limits(jerk: bool) -> JointLimits:
        return JointLimits(
            lim[:, 0], lim[:, 1], max_speed=published.max_speed,
            max_acceleration=published.max_acceleration,
            max_jerk=published.max_jerk if jerk else None,
        )  # fmt: skip

    def velfence(jerk: bool) -> Any:
        sf = SafetyFilter(
            robot,
            limits=limits(jerk),
            workspace=(WorkspaceLimit(box, point="tcp", buffer=BUFFER),),
            obstacles=(sphere,),
            dt=DT,
            obstacle_buffer=0.05,
        )
        return _AtRest(sf)

    arm: Any = robot  # (the clamp takes any arm with the kinematics it reads)

    make: dict[str, Callable[[], Any]] = {
        "safety-filter-jerk-rows": lambda: velfence(True),
        "safety-filter-no-jerk-rows": lambda: velfence(False),
        "per-joint-clamp": lambda: JointClamp(arm, limits=limits(False), dt=DT),
    }
    jmax = np.asarray(published.max_jerk, dtype=float)
    out: dict[str, JerkRun] = {}
    for name in methods:
        flags: list[bool] = []

        def record(k: int, t: float, res: Any, flags: list[bool] = flags) -> None:
            flags.append(
                bool(getattr(res, "jerk_override", False))
                or getattr(res, "deadline", None) is not None
            )

        plant = MujocoPlant(
            robot, bandwidth=BANDWIDTH, physics_dt=PHYSICS_DT, obstacles=[sphere], pushes=pushes
        )
        jog = TcpJog(robot.fk, [(p[2], p[3][0]) for p in phases], speed=sp)
        progress = None if on_step is None else (lambda f, name=name: on_step(name, f))
        tr = simulate(
            make[name](), jog, q0, duration=total, dt=DT, plant=plant, name=name,
            on_progress=progress, on_result=record,
        )  # fmt: skip
        cmd = np.asarray(tr.v_out, dtype=float)
        padded = np.vstack([np.zeros((2, cmd.shape[1])), cmd])
        jerk = (padded[2:] - 2.0 * padded[1:-1] + padded[:-2]) / DT**2
        tcp = np.array([robot.fk(q) for q in tr.p])
        margin = np.min(box.normals @ tcp.T - box.offsets[:, None], axis=0)
        out[name] = JerkRun(
            name, np.asarray(tr.t, dtype=float), cmd, jerk, np.abs(jerk) / jmax,
            np.array(flags[: cmd.shape[0]], dtype=bool), margin,
            joint_limit_violation(tr.p, lim[:, 0], lim[:, 1]), int(plant.record.contact_steps),
        )  # fmt: skip
    return out


def _check_runs(runs: Any) -> dict[str, JerkRun]:
    """``runs`` as :func:`run` returns them: a non-empty dict of name -> :class:`JerkRun`."""
    if not isinstance(runs, dict) or not runs:
        raise InvalidParameter(
            f"runs: expected a non-empty dict of method name -> JerkRun (jerk.run), got "
            f"{describe(runs)}"
        )
    for name, r in runs.items():
        if not isinstance(name, str) or not isinstance(r, JerkRun):
            raise InvalidParameter(
                f"runs: expected method name -> JerkRun (jerk.run), got {describe(name)} -> "
                f"{describe(r)}"
            )
    return runs


def jerk_table(runs: dict[str, JerkRun]) -> list[JerkRow]:
    """Max jerk, flagged cycles and containment of each run (:class:`JerkRow`).

    Raises:
        InvalidParameter: ``runs`` not a non-empty dict of name -> :class:`JerkRun`.
    """
    rows = []
    for name, r in _check_runs(runs).items():
        worst = r.ratio.max(axis=1)
        free = worst[~r.flagged]
        row = JerkRow(
            name,
            float(worst.max()),
            float(free.max()) if free.size else 0.0,
            int(np.count_nonzero(r.flagged)),
            int(np.count_nonzero(worst > 1.0 + 1e-9)),
            int(worst.shape[0]),
            max(0.0, -float(r.margin.min())),
            r.joint_violation,
            r.contacts,
        )
        rows.append(row)
    return rows


def plot_jerk(runs: dict[str, JerkRun], path: Path | str) -> Path:
    """``|jerk| / limit`` over time, one panel per method, one line per joint, flags marked.

    Log scale (the runs without jerk rows reach tens of times the limit); the limit is the line
    at 1, and the flagged cycles of the jerk-row run are marked on it.

    Args:
        runs: The runs (:func:`run`).
        path: The PNG to write.

    Returns:
        ``path``.

    Raises:
        InvalidParameter: bad ``runs`` (as :func:`jerk_table`) or ``path``.
    """
    runs = _check_runs(runs)
    out = check_output_path("path", path)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    k = len(runs)
    fig, axes = plt.subplots(
        k, 1, figsize=(11, 2.6 * k + 1.0), sharex=True, squeeze=False, layout="constrained"
    )
    floor = 1e-3
    top = max(2.0, max(float(r.ratio.max()) for r in runs.values()) * 1.5)
    for ax, (name, r) in zip(axes[:, 0], runs.items(), strict=True):
        for j in range(r.ratio.shape[1]):
            ax.plot(r.t, np.maximum(r.ratio[:, j], floor), lw=0.8, color=f"C{j}",
                    label=f"joint {j + 1}")  # fmt: skip
        ax.axhline(1.0, color="k", ls="--", lw=1.0, label="jerk limit (Franka, Panda)")
        if r.flagged.any():
            tf = r.t[r.flagged]
            ax.scatter(tf, np.full(tf.shape, 1.0), marker="v", s=22, color="#d62728", zorder=5,
                       label="flagged cycle (jerk rows gave way)")  # fmt: skip
        n_over = int(np.count_nonzero(r.ratio.max(axis=1) > 1.0 + 1e-9))
        ax.set_title(
            f"{method_label(name)}: max |jerk|/limit {r.ratio.max():.3g}, {n_over} cycles over, "
            f"{int(np.count_nonzero(r.flagged))} flagged", fontsize=10,
        )  # fmt: skip
        ax.set_yscale("log")
        ax.set_ylim(floor, top)
        ax.set_ylabel("|jerk| / limit [1]")
        ax.grid(alpha=0.3, which="both")
    axes[-1, 0].set_xlabel("time [s]")
    handles: dict[str, Any] = {}
    for ax in axes[:, 0]:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    fig.legend(list(handles.values()), list(handles), loc="outside right upper", fontsize=9)
    fig.suptitle("Commanded joint jerk, Panda through the fence-box (MuJoCo, 500 Hz)")
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
