r"""Benchmark cases of the joint-space safety filter (``SafetyFilter``).

The problem: the 7-DoF arm
:meth:`DHChain.seven_dof() <velfence.mechanisms.chain.DHChain.seven_dof>` (capsule links of
radius 0.06 m) with its 14 joint-position bounds, 7 joint-velocity bounds (1.5 rad/s), a 6-facet
box for the TCP (:class:`~velfence.filter.WorkspaceLimit`) and two sphere obstacles near
the upper arm and the forearm; every cycle builds the rows from the forward kinematics and the
Jacobians of the TCP and of the links' critical points. Timed per zone (the filter's
classification), in joint mode (a joint-velocity command, continuous time and with ``dt`` =
4 ms) and in twist mode (a TCP velocity, damped least squares).

Beside it, on the same states:

* the filter's own rows (:attr:`FilterResult.rows`, prebuilt) solved as the QP
  ``min ½ xᵀ H x + fᵀ x s.t. G x >= b`` (joint mode ``H = I, f = -u``; twist mode
  ``H = JᵀJ + λ²I, f = -Jᵀ v``) through :func:`qpsolvers.solve_qp` (``solver="daqp"``) and
  ``daqp.solve``, with the largest difference to the filter's answer;
* the filter's row building alone (forward kinematics, Jacobians, distances, bounds);
* mink's ``solve_ik`` (when mink is installed: the ``peers`` extra) on an MJCF model of the
  same DH arm (:func:`seven_dof_mjcf`: capsule geoms, the obstacles as static spheres) with a
  ``ConfigurationLimit``, a ``VelocityLimit`` and a ``CollisionAvoidanceLimit`` (mink has no
  workspace-polytope limit, so its problem has no TCP-box rows), a posture task on ``q + u dt``
  (joint mode) or a position-only frame task on the TCP moved by ``v dt`` (twist mode), its
  ``dt`` = 4 ms. It solves a different (discrete-time, differently bounded) problem, so only its
  time is compared.
"""

from __future__ import annotations

import ctypes
import functools
import importlib.util
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence.apps.bench.cases import Step
from velfence.apps.bench.rows import FilterRow
from velfence.apps.bench.settings import BenchSettings
from velfence.apps.bench.timing import as_fields, time_calls
from velfence.geometry.polytope import ConvexPolytope

__all__ = [
    "MINK_DT",
    "MODES",
    "ROUTE_VF",
    "MinkIK",
    "Scenario",
    "cycles",
    "make_filter",
    "mink_ok",
    "scenario",
    "seven_dof_mjcf",
    "step_count",
    "zone_pools",
]

#: Command modes of the filter, timed side by side.
MODES: tuple[str, ...] = ("joint", "twist")

#: Control period of the discrete-time rows (``dt`` of the filter's dt row and of mink), s.
MINK_DT = 0.004

#: Route label of the filter itself (the ratios' denominator).
ROUTE_VF = "velfence SafetyFilter"
_ROUTE_ROWS = "velfence rows only"
_ROUTE_QPS = "qpsolvers+daqp (same rows)"
_ROUTE_DAQP = "daqp (same rows)"
_ROUTE_MINK = "mink solve_ik"

#: States (joint position, command) of one zone.
FilterPool = list[tuple[FloatArray, FloatArray]]


@dataclass(frozen=True)
class Scenario:
    """The benchmark problem: arm, limits, TCP box, obstacles and the nominal configuration.

    Attributes:
        arm: The 7-DoF DH chain (capsule radius 0.06 m).
        limits: Its joint limits (the arm's position limits, 1.5 rad/s, 10 rad/s²).
        workspace: The TCP box (6 facets, buffer 0.1 m).
        obstacles: Two spheres of radius 0.05 m.
        q0: Nominal configuration the states scatter about [rad], shape (7,).
    """

    arm: Any
    limits: Any
    workspace: Any
    obstacles: tuple[Any, ...]
    q0: FloatArray


def scenario() -> Scenario:
    """The benchmark problem (deterministic).

    The TCP box reaches 5 cm past the TCP at ``q0`` in +x and +z (so those faces are near), the
    obstacles sit 4 cm and 6 cm from the surfaces of the upper arm and the forearm (inside the
    0.1 m obstacle buffer).
    """
    from velfence.filter import JointLimits, SphereObstacle, WorkspaceLimit
    from velfence.mechanisms.chain import DHChain

    radius = 0.06
    arm = DHChain.seven_dof(link_radius=radius)
    q0 = np.array([0.2, 0.5, 0.1, -1.2, 0.1, 0.8, 0.0])
    lim = arm.joint_limits
    limits = JointLimits(
        lower=lim[:, 0],
        upper=lim[:, 1],
        max_speed=np.full(7, 1.5),
        max_acceleration=np.full(7, 10.0),
        names=arm.joint_names,
    )
    p0 = np.asarray(arm.fk(q0), dtype=float)
    box = ConvexPolytope.box(p0 - np.array([0.4, 0.4, 0.6]), p0 + np.array([0.05, 0.4, 0.05]))
    segs = np.asarray(arm.link_segments(q0), dtype=float)
    obstacles = []
    for link, gap in ((2, 0.04), (4, -0.06)):  # the two long links: upper arm, forearm
        a, b = segs[link]
        side = np.cross(b - a, np.array([0.0, 0.0, 1.0]))
        side /= np.linalg.norm(side)
        r = 0.05
        center = (a + b) / 2.0 + math.copysign(radius + r + abs(gap), gap) * side
        obstacles.append(SphereObstacle(center=center, radius=r, name=f"sphere near link {link}"))
    return Scenario(arm, limits, WorkspaceLimit(box, buffer=0.1), tuple(obstacles), q0)


def make_filter(sc: Scenario, *, dt: float | None = None) -> Any:
    """The benchmark's :class:`SafetyFilter` of ``sc`` (obstacle buffer 0.1 m)."""
    from velfence.filter import SafetyFilter

    return SafetyFilter(
        sc.arm,
        limits=sc.limits,
        workspace=sc.workspace,
        obstacles=sc.obstacles,
        dt=dt,
        obstacle_buffer=0.1,
    )


def _explainer(flt: Any, mode: str) -> Callable[[FloatArray, FloatArray], Any]:
    fn: Callable[[FloatArray, FloatArray], Any] = (
        flt.explain if mode == "joint" else flt.explain_twist
    )
    return fn


def zone_pools(
    flt: Any, sc: Scenario, s: BenchSettings, mode: str, rng: np.random.Generator
) -> dict[str, FilterPool]:
    """Up to ``filter_states`` states per zone: ``q0`` scattered by 0.05 rad, random commands.

    Commands: standard normal times 0.5 rad/s (joint mode) or 0.2 m/s (twist mode). States
    whose problem needed a relaxation (``dropped``) are left out.
    """
    explain = _explainer(flt, mode)
    width = sc.arm.dof if mode == "joint" else 3
    scale = 0.5 if mode == "joint" else 0.2
    pools: dict[str, FilterPool] = {}
    for _ in range(60 * s.filter_states):
        q = sc.q0 + rng.normal(scale=0.05, size=sc.arm.dof)
        u = rng.normal(size=width) * scale
        r = explain(q, u)
        if r.dropped:
            continue
        pool = pools.setdefault(r.zone, [])
        if len(pool) < s.filter_states:
            pool.append((q, u))
    return dict(sorted(pools.items()))


def mink_ok() -> bool:
    """Whether mink (and MuJoCo) can be imported."""
    return all(importlib.util.find_spec(m) is not None for m in ("mink", "mujoco"))


def step_count(*, qp_ok: bool, with_mink: bool) -> int:
    """Progress steps of :func:`cycles`."""
    per_mode = 1 + qp_ok + with_mink
    return len(MODES) * per_mode + 1  # + the dt row of joint mode


def _quat_xz(alpha: float, theta: float) -> FloatArray:
    """Quaternion (w, x, y, z) of ``Rx(alpha) Rz(theta)``."""
    ca, sa = math.cos(alpha / 2.0), math.sin(alpha / 2.0)
    ct, st = math.cos(theta / 2.0), math.sin(theta / 2.0)
    return np.array([ca * ct, sa * ct, -sa * st, ca * st])


def _v(x: Sequence[float] | FloatArray) -> str:
    return " ".join(f"{float(c):.12g}" for c in x)


def seven_dof_mjcf(arm: Any, obstacles: Sequence[Any]) -> str:
    """MJCF of a standard-DH chain with capsule links and static sphere obstacles.

    Body ``k`` is DH frame ``k`` turned by the joint offset; its hinge turns about its ``z``
    axis; its capsule runs from its origin to the next frame's, ``(a, 0, d)`` (a sphere for a
    zero-length link); the child sits there, turned by ``Rx(alpha)``. The site ``tcp`` is the
    tool point.

    Args:
        arm: A :class:`~velfence.mechanisms.chain.DHChain` (``dh``, ``tool``, ``joint_limits``,
            ``link_radius``, ``joint_names``).
        obstacles: :class:`~velfence.filter.SphereObstacle` entries.

    Returns:
        The MJCF text (geoms ``link0`` …, ``obstacle0`` …).
    """
    dh = np.asarray(arm.dh, dtype=float)
    radii = np.asarray(arm.link_radius, dtype=float).reshape(-1)
    lim = np.asarray(arm.joint_limits, dtype=float)
    names = tuple(arm.joint_names)
    tool = np.asarray(arm.tool, dtype=float)
    lines = [
        '<mujoco model="velfence DH arm">',
        '  <compiler angle="radian"/>',
        "  <worldbody>",
    ]
    for i, o in enumerate(obstacles):
        lines.append(
            f'    <geom name="obstacle{i}" type="sphere" size="{o.radius:.12g}" '
            f'pos="{_v(o.center)}"/>'
        )
    close = []
    quat = _quat_xz(0.0, float(dh[0, 3]))
    pos = np.zeros(3)
    for k in range(dh.shape[0]):
        a, alpha, d, _ = (float(x) for x in dh[k])
        pad = "    " + "  " * k
        lines.append(f'{pad}<body name="body{k}" pos="{_v(pos)}" quat="{_v(quat)}">')
        lines.append(f'{pad}  <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>')
        lines.append(
            f'{pad}  <joint name="{names[k]}" type="hinge" axis="0 0 1" '
            f'range="{lim[k, 0]:.12g} {lim[k, 1]:.12g}" limited="true"/>'
        )
        end = np.array([a, 0.0, d])
        r = f"{radii[k]:.12g}" if radii[k] > 0.0 else "0.001"
        if math.hypot(a, d) > 1e-9:
            lines.append(
                f'{pad}  <geom name="link{k}" type="capsule" fromto="0 0 0 {_v(end)}" size="{r}"/>'
            )
        else:
            lines.append(f'{pad}  <geom name="link{k}" type="sphere" size="{r}"/>')
        if k == dh.shape[0] - 1:
            ca, sa = math.cos(alpha), math.sin(alpha)
            rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
            lines.append(f'{pad}  <site name="tcp" pos="{_v(end + rx @ tool)}"/>')
        else:
            pos = end
            quat = _quat_xz(alpha, float(dh[k + 1, 3]))
        close.append(f"{pad}</body>")
    lines += close[::-1]
    lines += ["  </worldbody>", "</mujoco>"]
    return "\n".join(lines)


class MinkIK:
    """mink's ``solve_ik`` on the MJCF model of the scenario, one call per cycle.

    Args:
        sc: The scenario (arm, limits, obstacles): mink gets a ``ConfigurationLimit``, a
            ``VelocityLimit`` and a ``CollisionAvoidanceLimit`` (links vs spheres, detection
            distance 0.1 m) on the same arm and obstacles.
        mode: ``"joint"`` (a posture task on ``q + u dt``) or ``"twist"`` (the TCP position).
    """

    def __init__(self, sc: Scenario, mode: str) -> None:
        import mink
        import mujoco

        self.mink = mink
        self.mode = mode
        self.model = mujoco.MjModel.from_xml_string(seven_dof_mjcf(sc.arm, sc.obstacles))
        self.config = mink.Configuration(self.model)
        n_links = int(sc.arm.n_links)
        vmax = {
            name: float(v) for name, v in zip(sc.arm.joint_names, sc.limits.max_speed, strict=True)
        }
        self.limits = [
            mink.ConfigurationLimit(self.model),
            mink.VelocityLimit(self.model, vmax),
            mink.CollisionAvoidanceLimit(
                self.model,
                geom_pairs=[
                    (
                        [f"link{k}" for k in range(n_links)],
                        [f"obstacle{i}" for i in range(len(sc.obstacles))],
                    )
                ],
                minimum_distance_from_collisions=0.0,
                collision_detection_distance=0.1,
            ),
        ]
        self.task: Any
        if mode == "joint":
            self.task = mink.PostureTask(self.model, cost=1.0)
        else:
            self.task = mink.FrameTask("tcp", "site", position_cost=1.0, orientation_cost=0.0)

    def tcp_error(self, sc: Scenario, qs: Sequence[FloatArray]) -> float:
        """Largest distance between the model's TCP and ``DHChain.fk`` over ``qs``, m."""
        err = 0.0
        for q in qs:
            self.config.update(q)
            site = self.config.get_transform_frame_to_world("tcp", "site").translation()
            err = max(err, float(np.max(np.abs(site - np.asarray(sc.arm.fk(q))))))
        return err

    def __call__(self, q: FloatArray, cmd: FloatArray) -> Any:
        """One ``solve_ik`` at joints ``q`` [rad] for the command ``cmd`` (joint or TCP)."""
        mink = self.mink
        self.config.update(q)
        if self.mode == "joint":
            self.task.set_target(q + cmd * MINK_DT)
        else:
            T = self.config.get_transform_frame_to_world("tcp", "site")
            self.task.set_target(
                mink.SE3.from_rotation_and_translation(
                    T.rotation(), T.translation() + cmd * MINK_DT
                )
            )
        return mink.solve_ik(
            self.config, [self.task], MINK_DT, "daqp", damping=1e-12, limits=self.limits
        )


def _qp_problem(
    flt: Any, sc: Scenario, mode: str, q: FloatArray, cmd: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(H, f, G, b)`` of the filter's cycle: ``min ½ xᵀHx + fᵀx s.t. G x >= b`` (finite rows)."""
    r = _explainer(flt, mode)(q, cmd)
    G, b = r.rows
    keep = np.isfinite(b)
    n = sc.arm.dof
    if mode == "joint":
        H, f = np.eye(n), -np.asarray(cmd, dtype=float)
    else:
        J = np.asarray(sc.arm.jacobian(q), dtype=float)
        H = J.T @ J + flt.damping**2 * np.eye(n)
        f = -(J.T @ cmd)
    return H, np.array(f), np.array(G[keep]), np.array(b[keep])


def _error(flt: Any, mode: str, pool: FilterPool, xs: Sequence[Any]) -> float:
    out = flt.filter if mode == "joint" else flt.filter_twist
    err = 0.0
    for (q, cmd), x in zip(pool, xs, strict=True):
        if x is None:
            return math.inf
        err = max(err, float(np.max(np.abs(out(q, cmd) - np.asarray(x)))))
    return err


def _rows_mean(flt: Any, mode: str, pool: FilterPool) -> float:
    explain = _explainer(flt, mode)
    return float(np.mean([len(explain(q, c).constraint_names) for q, c in pool]))


def cycles(s: BenchSettings, step: Step, qp_ok: bool, notes: list[str]) -> list[FilterRow]:
    """The safety filter per zone and mode, beside the same QP, its row building and mink.

    Args:
        s: The settings (``filter_calls``, ``filter_states``, ``warmup``, ``seed``).
        step: The progress hook.
        qp_ok: Whether qpsolvers and daqp are installed (else the QP rows are skipped).
        notes: Appended to: the mink model's check, or why mink was skipped.

    Returns:
        One row per (mode, route, zone), and the joint-mode ``dt`` row per zone.
    """
    sc = scenario()
    flt = make_filter(sc)
    rng = np.random.default_rng(s.seed + 20)
    calls, warm = s.filter_calls, min(s.warmup, 2)
    with_mink = mink_ok()
    if not with_mink:
        notes.append(
            "mink (or MuJoCo) is not installed: the mink solve_ik rows are skipped "
            "(pip install 'velfence[peers]')."
        )
    out: list[FilterRow] = []
    for mode in MODES:
        step(f"safety filter: 7-DoF, {mode} mode")
        pools = zone_pools(flt, sc, s, mode, rng)
        fn = flt.filter if mode == "joint" else flt.filter_twist
        base: dict[str, FilterRow] = {}
        for zone, pool in pools.items():
            t = time_calls(fn, pool, calls=calls, warmup=warm)
            row = FilterRow(
                **as_fields(t), mode=mode, route=ROUTE_VF, zone=zone, states=len(pool),
                rows=_rows_mean(flt, mode, pool), ratio=1.0,
            )  # fmt: skip
            base[zone] = row
            out.append(row)
            if mode == "joint":
                # The filter's own row building, timed alone, with the pose's kinematics as the
                # filter computes them (once per cycle) included.
                def build(q: Any, u: Any, f: Any = flt) -> Any:
                    return f._build_rows(q, u, None)

                args = [(q, u) for q, u in pool]
                t = time_calls(build, args, calls=calls, warmup=warm)
                out.append(
                    FilterRow(
                        **as_fields(t),
                        mode=mode,
                        route=_ROUTE_ROWS,
                        zone=zone,
                        states=len(pool),
                        rows=row.rows,
                        ratio=t.median_us / row.median_us,
                    )
                )
        if mode == "joint":
            step(f"safety filter: 7-DoF, joint mode, dt {MINK_DT * 1e3:g} ms")
            fdt = make_filter(sc, dt=MINK_DT)
            for zone, pool in pools.items():
                t = time_calls(fdt.filter, pool, calls=calls, warmup=warm)
                out.append(
                    FilterRow(
                        **as_fields(t),
                        mode=f"joint, dt {MINK_DT * 1e3:g} ms",
                        route=ROUTE_VF,
                        zone=zone,
                        states=len(pool),
                        rows=_rows_mean(fdt, "joint", pool),
                        ratio=t.median_us / base[zone].median_us,
                    )
                )
        if qp_ok:
            step(f"safety filter: 7-DoF, {mode} mode, QP peers")
            out += _qp_rows(flt, sc, mode, pools, base, calls, warm)
        if with_mink:
            step(f"safety filter: 7-DoF, {mode} mode, mink")
            solver = MinkIK(sc, mode)
            if mode == "joint":
                qs = [q for p in pools.values() for q, _ in p]
                notes.append(
                    "mink model: the MJCF TCP matches DHChain.fk to "
                    f"{solver.tcp_error(sc, qs):.1e} m over the benchmark states; mink's "
                    f"problem has the joint, velocity and obstacle limits (dt {MINK_DT:g} s) "
                    "but no TCP-box rows."
                )
            for zone, pool in pools.items():
                t = time_calls(solver, pool, calls=calls, warmup=warm)
                out.append(
                    FilterRow(
                        **as_fields(t),
                        mode=mode,
                        route=_ROUTE_MINK,
                        zone=zone,
                        states=len(pool),
                        rows=math.nan,
                        ratio=t.median_us / base[zone].median_us,
                    )
                )
    return out


def _qp_rows(
    flt: Any,
    sc: Scenario,
    mode: str,
    pools: dict[str, FilterPool],
    base: dict[str, FilterRow],
    calls: int,
    warm: int,
) -> list[FilterRow]:
    """The filter's rows through qpsolvers and daqp, per zone."""
    import daqp
    import qpsolvers

    solve_qp = functools.partial(qpsolvers.solve_qp, solver="daqp")
    out: list[FilterRow] = []
    for zone, pool in pools.items():
        probs = [_qp_problem(flt, sc, mode, q, c) for q, c in pool]
        qs = [(H, f, -G, -b) for H, f, G, b in probs]
        ds = [
            (
                np.array(H),
                np.array(f),
                np.ascontiguousarray(G),
                np.full(b.shape[0], 1e30),
                np.array(b),
                np.zeros(b.shape[0], dtype=ctypes.c_int),
            )
            for H, f, G, b in probs
        ]
        x_qps = [solve_qp(*a) for a in qs]
        x_daqp = [daqp.solve(*a)[0] for a in ds]
        rows = float(np.mean([b.shape[0] for *_, b in probs]))
        vf = base[zone].median_us
        for route, fn, args, xs in (
            (_ROUTE_QPS, solve_qp, qs, x_qps),
            (_ROUTE_DAQP, daqp.solve, ds, x_daqp),
        ):
            t = time_calls(fn, args, calls=calls, warmup=warm)
            out.append(
                FilterRow(
                    **as_fields(t),
                    mode=mode,
                    route=route,
                    zone=zone,
                    states=len(pool),
                    rows=rows,
                    ratio=t.median_us / vf,
                    max_error=_error(flt, mode, pool, xs),
                )
            )
    return out
