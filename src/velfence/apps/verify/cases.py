"""One case of a campaign: its scenario as plain data, the closed loop, the margins, shrinking.

A case is a :class:`Scenario`: everything that decides its run written out (the robot, the
filter's settings, the start, the joint limits, the workspace box, the spheres, the operator and
its seed, servo lag, latency, sensor noise and its seed, the pushes, the steps). :func:`sample`
draws the scenario of case ``i`` of family ``f`` from the seed ``SeedSequence(seed,
spawn_key=(f, i))`` (the ``i``-th child of the ``f``-th child of the campaign's
``SeedSequence``); :func:`run` runs it in closed loop on a kinematic plant
(:class:`KinematicPlant`) or on MuJoCo (:class:`velfence.apps.verify.plants.MujocoArm`) and
measures each property's margin at every step (``docs/verify.md``; one function per margin,
shared with the fast route :mod:`velfence.apps.verify.batch`); :func:`shrink` makes a failing
scenario smaller while it still fails; a scenario is written to and read from YAML
(:func:`write_scenario`, :func:`load_scenario`) and runs again bit for bit.

The operators are the closed-loop soak's (:func:`velfence.apps.soak_filter.soak_command`:
``wander`` its random commands, ``push`` its pushes at the nearest facet, ``wild`` the same
drawn anew every step) and the scripted Cartesian jog of :class:`velfence.sim.scenarios.TcpJog`
(``scripted``: targets around and beyond the box, pressing against its faces).
"""

from __future__ import annotations

import functools
import math
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal, Protocol

import numpy as np

from velfence._extras import missing

try:
    from pydantic import Field, Strict, ValidationError
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence._typing import FloatArray
from velfence.apps.soak_filter import any_start, clearance, soak_command
from velfence.apps.verify.campaign import PROPERTIES, Campaign, Properties
from velfence.errors import InvalidParameter, VelfenceError
from velfence.io.config import Number, StrictModel, describe_validation_error

__all__ = [
    "CaseResult",
    "Scenario",
    "case_seed",
    "load_scenario",
    "run",
    "sample",
    "shrink",
    "write_scenario",
]

#: Tool point of every robot in its flange frame [m] (the soak's 5 cm tool).
TOOL = (0.0, 0.0, 0.05)
#: Default joint speed limit when the campaign gives none [rad/s] (the soak's DH chains).
DEFAULT_MAX_SPEED = math.pi

Vec = Annotated[list[Number], Field(max_length=64)]


class BoxSpec(StrictModel):
    """The workspace box [m] and its buffer [m]."""

    lower: Annotated[list[Number], Field(min_length=3, max_length=3)]
    upper: Annotated[list[Number], Field(min_length=3, max_length=3)]
    buffer: Annotated[float, Strict(), Field(gt=0.0, le=10.0)]


class PushSpec(StrictModel):
    """A push: joint velocity ``velocity`` [rad/s] added to the plant for steps ``[start, end)``."""

    start: Annotated[int, Strict(), Field(ge=0)]
    end: Annotated[int, Strict(), Field(ge=0)]
    velocity: Vec


class Scenario(StrictModel):
    """Everything one case's run depends on, as plain data (a reproducer's YAML).

    Args:
        robot: The DH chain (``seven_dof``, ``ur5e``, ``puma560``).
        rate: Control rate [Hz].
        filter_dt: The period given to the filter [s], or None (unset).
        joint_buffer: The filter's joint buffer [rad].
        obstacle_buffer: The filter's obstacle buffer [m].
        spring_gain: The filter's recovery gain [1/s].
        link_radius: Capsule radius of the links [m].
        max_iterations: The solve's iteration cap (None: the default).
        max_speed: Joint speed limits [rad/s].
        max_acceleration: Joint acceleration limits [rad/s²] or None.
        max_jerk: Joint jerk limits [rad/s³] or None.
        mode: ``twist`` (TCP velocity commands) or ``joint``.
        operator: ``wander``, ``push``, ``wild`` or ``scripted``.
        command_seed: Seed of the operator's draws.
        targets: The scripted jog's phases ``[t_end, x, y, z]`` [s, m].
        jog_speed: The scripted jog's speed [m/s].
        q0: Start [rad].
        lower: Lower joint limits [rad].
        upper: Upper joint limits [rad].
        box: The workspace box, or None.
        spheres: Sphere obstacles ``[x, y, z, radius]`` [m].
        lag: Servo time constant [s] (0: none).
        latency: Steps between the filter's output and the servo.
        noise: Standard deviation of the joint sensor noise [rad].
        noise_seed: Seed of the noise.
        pushes: External joint-velocity pushes.
        steps: Steps to run.
        properties: The properties checked.
        plant: ``kinematic`` (:func:`run`'s integrator) or ``mujoco``
            (:mod:`velfence.apps.verify.plants`).
    """

    robot: Literal["seven_dof", "ur5e", "puma560"]
    rate: Annotated[float, Strict(), Field(ge=1.0, le=1e5)]
    filter_dt: Annotated[float, Strict(), Field(gt=0.0, le=1.0)] | None
    joint_buffer: Annotated[float, Strict(), Field(gt=0.0)]
    obstacle_buffer: Annotated[float, Strict(), Field(gt=0.0)]
    spring_gain: Annotated[float, Strict(), Field(ge=0.0)]
    link_radius: Annotated[float, Strict(), Field(ge=0.0)]
    max_iterations: int | None = None
    max_speed: Vec
    max_acceleration: Vec | None = None
    max_jerk: Vec | None = None
    mode: Literal["twist", "joint"]
    operator: Literal["wander", "push", "wild", "scripted"]
    command_seed: Annotated[int, Strict(), Field(ge=0)]
    targets: list[Annotated[list[Number], Field(min_length=4, max_length=4)]] = Field(
        default_factory=list
    )
    jog_speed: Annotated[float, Strict(), Field(gt=0.0)] = 0.5
    q0: Vec
    lower: Vec
    upper: Vec
    box: BoxSpec | None = None
    spheres: list[Annotated[list[Number], Field(min_length=4, max_length=4)]] = Field(
        default_factory=list
    )
    lag: Annotated[float, Strict(), Field(ge=0.0)] = 0.0
    latency: Annotated[int, Strict(), Field(ge=0, le=10_000)] = 0
    noise: Annotated[float, Strict(), Field(ge=0.0)] = 0.0
    noise_seed: Annotated[int, Strict(), Field(ge=0)] = 0
    pushes: list[PushSpec] = Field(default_factory=list)
    steps: Annotated[int, Strict(), Field(ge=1, le=10**7)]
    properties: Properties
    plant: Literal["kinematic", "mujoco"] = "kinematic"


@dataclass(kw_only=True)
class CaseResult:
    """What one case measured.

    Attributes:
        family: The family's name.
        index: The case's index in its family.
        steps: Steps run.
        worst: Property -> ``(worst margin, step)`` over the run (only checked properties that
            were evaluated at least once).
        violated: The properties violated, in :data:`PROPERTIES` order.
        first: Property -> the first step that violated it.
        intervention_mean: Mean relative intervention ``|achieved - commanded| / |commanded|``.
        intervention_max: Its largest value.
        exceptions: Cycles that raised (counted as non-finite).
        trace: With ``record``: per-step arrays after each step (``containment``,
            ``joint_limits``, ``tcp`` [m], ``q`` [rad]) and ``dt`` [s].
    """

    family: str
    index: int
    steps: int
    worst: dict[str, tuple[float, int]]
    violated: list[str]
    first: dict[str, int]
    intervention_mean: float
    intervention_max: float
    exceptions: int
    trace: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """Plain data (the shard files)."""
        return {
            "family": self.family,
            "index": self.index,
            "steps": self.steps,
            "worst": {k: [v[0], v[1]] for k, v in self.worst.items()},
            "violated": self.violated,
            "first": self.first,
            "intervention_mean": self.intervention_mean,
            "intervention_max": self.intervention_max,
            "exceptions": self.exceptions,
        }


def case_seed(seed: int, family: int, index: int) -> np.random.SeedSequence:
    """The seed of case ``index`` of family ``family``.

    ``SeedSequence(seed).spawn(F)[family].spawn(N)[index]``, built directly (its ``spawn_key``
    is ``(family, index)``): the same seed without spawning the others.
    """
    return np.random.SeedSequence(seed, spawn_key=(family, index))


@functools.lru_cache(maxsize=16)
def chain(robot: str, link_radius: float) -> Any:
    """The robot's ``DHChain`` with capsule links and the 5 cm tool.

    One per ``(robot, link_radius)`` in a process: a ``DHChain`` is immutable and its
    kinematics keeps no state, so every case and filter of a campaign shares it (building one
    and validating its tables costs more than sampling a case's start).
    """
    from velfence.mechanisms.chain import DHChain

    build = {"seven_dof": DHChain.seven_dof, "ur5e": DHChain.ur5e, "puma560": DHChain.puma560}
    return build[robot](link_radius=link_radius, tool=TOOL)


def _draw(rng: np.random.Generator, pair: list[float]) -> float:
    """A uniform draw from ``[low, high]``."""
    return float(rng.uniform(pair[0], pair[1]))


def _unit(rng: np.random.Generator, k: int) -> FloatArray:
    v = rng.normal(size=k)
    return np.asarray(v / np.linalg.norm(v), dtype=np.float64)


def sample(campaign: Campaign, family: int, index: int) -> Scenario:
    """The scenario of case ``index`` of family ``family`` (module docstring).

    Args:
        campaign: The campaign.
        family: The family's index.
        index: The case's index in the family.

    Returns:
        The :class:`Scenario` (the same for the same seed, family and index).

    Raises:
        InvalidParameter: ``family`` or ``index`` out of range.
    """
    if not 0 <= family < len(campaign.families):
        raise InvalidParameter(f"family: expected 0..{len(campaign.families) - 1}, got {family}")
    fam = campaign.families[family]
    if not 0 <= index < fam.cases:
        raise InvalidParameter(f"index: expected 0..{fam.cases - 1}, got {index}")
    rng = np.random.default_rng(case_seed(campaign.seed, family, index))
    f = campaign.filter
    robot = chain(campaign.robot, f.link_radius)
    n = int(robot.dof)
    lim0 = np.asarray(robot.joint_limits, dtype=np.float64)
    span = np.minimum(lim0[:, 1] - lim0[:, 0], 2.0 * math.pi)
    q = lim0[:, 0] + (lim0[:, 1] - lim0[:, 0] - span) / 2 + span * rng.uniform(0.1, 0.9, n)
    m0, m1 = fam.start_margin
    lo = np.maximum(lim0[:, 0], q - rng.uniform(m0, m1, n))
    hi = np.minimum(lim0[:, 1], q + rng.uniform(m0, m1, n))
    if rng.random() < fam.at_limit:
        for j in rng.choice(n, size=min(n, int(rng.integers(2, 4))), replace=False):
            if rng.random() < 0.5:
                lo[j] = q[j]
            else:
                hi[j] = q[j]
    p = np.asarray(robot.fk(q), dtype=np.float64)
    box: dict[str, Any] | None = None
    if fam.workspace.box:
        h0, h1 = fam.workspace.half_size
        lower = p - rng.uniform(h0, h1, 3)
        upper = p + rng.uniform(h0, h1, 3)
        if rng.random() < fam.workspace.touching:
            axis = int(rng.integers(0, 3))
            if rng.random() < 0.5:
                lower[axis] = p[axis]
            else:
                upper[axis] = p[axis]
        box = {"lower": lower.tolist(), "upper": upper.tolist(), "buffer": f.workspace_buffer}
    seg = np.asarray(robot.link_segments(q), dtype=np.float64)
    lrad = np.asarray(robot.link_radius, dtype=np.float64)
    spheres: list[list[float]] = []
    c0, c1 = fam.obstacles.count
    for _ in range(int(rng.integers(c0, c1 + 1))):
        for _try in range(20):
            L = int(rng.integers(1, seg.shape[0]))
            a = seg[L, 0] + rng.uniform(0.0, 1.0) * (seg[L, 1] - seg[L, 0])
            R = float(_draw(rng, fam.obstacles.radius))
            c = a + (R + float(lrad[L]) + float(_draw(rng, fam.obstacles.gap))) * _unit(rng, 3)
            if clearance(seg, lrad, c[None, :], np.array([R])) > 0.01:
                spheres.append([*c.tolist(), R])
                break
    mode = fam.mode
    if mode == "mixed":
        mode = "twist" if rng.random() < 0.5 else "joint"
    if fam.operator == "scripted":
        mode = "twist"
    targets: list[list[float]] = []
    if fam.operator == "scripted":
        t_total = fam.steps / campaign.rate
        k = int(rng.integers(2, 5))
        ends = np.sort(rng.uniform(0.0, t_total, k))
        ends[-1] = t_total + 1.0
        for t_end in ends:
            reach = rng.uniform(0.1, 0.5)  # beyond the box: presses on a face
            targets.append([float(t_end), *(p + reach * _unit(rng, 3)).tolist()])
    vmax = np.full(n, DEFAULT_MAX_SPEED if f.max_speed is None else f.max_speed)
    pushes: list[dict[str, Any]] = []
    if rng.random() < fam.pushes.probability:
        k0 = int(rng.integers(0, fam.steps))
        length = max(1, round(float(_draw(rng, fam.pushes.duration)) * campaign.rate))
        w = _unit(rng, n) * float(_draw(rng, fam.pushes.speed))
        pushes.append({"start": k0, "end": k0 + length, "velocity": w.tolist()})
    return Scenario(
        robot=campaign.robot,  # type: ignore[arg-type]
        rate=campaign.rate,
        filter_dt=campaign.filter_dt,
        joint_buffer=f.joint_buffer,
        obstacle_buffer=f.obstacle_buffer,
        spring_gain=f.spring_gain,
        link_radius=f.link_radius,
        max_iterations=f.max_iterations,
        max_speed=vmax.tolist(),
        max_acceleration=None if f.max_acceleration is None else [f.max_acceleration] * n,
        max_jerk=None if f.max_jerk is None else [f.max_jerk] * n,
        mode=mode,
        operator=fam.operator,
        command_seed=int(rng.integers(0, 2**63 - 1)),
        targets=targets,
        q0=q.tolist(),
        lower=lo.tolist(),
        upper=hi.tolist(),
        box=box,  # type: ignore[arg-type]
        spheres=spheres,
        lag=float(_draw(rng, fam.lag)),
        latency=int(rng.integers(fam.latency[0], fam.latency[1] + 1)),
        noise=float(_draw(rng, fam.noise)),
        noise_seed=int(rng.integers(0, 2**63 - 1)),
        pushes=pushes,  # type: ignore[arg-type]
        steps=fam.steps,
        properties=campaign.properties.model_dump(),  # type: ignore[arg-type]
        plant=fam.plant,  # type: ignore[arg-type]
    )


def build_filter(sc: Scenario, robot: Any) -> Any:
    """The scenario's ``SafetyFilter`` on ``robot``."""
    from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
    from velfence.geometry.polytope import ConvexPolytope

    limits = JointLimits(
        np.array(sc.lower),
        np.array(sc.upper),
        max_speed=np.array(sc.max_speed),
        max_acceleration=None if sc.max_acceleration is None else np.array(sc.max_acceleration),
        max_jerk=None if sc.max_jerk is None else np.array(sc.max_jerk),
    )
    ws = []
    if sc.box is not None:
        box = ConvexPolytope.box(np.array(sc.box.lower), np.array(sc.box.upper))
        ws.append(WorkspaceLimit(box, buffer=sc.box.buffer))
    obstacles = [SphereObstacle(np.array(s[:3]), radius=s[3]) for s in sc.spheres]
    return SafetyFilter(
        robot,
        limits=limits,
        workspace=ws,
        obstacles=obstacles,
        dt=sc.filter_dt,
        joint_buffer=sc.joint_buffer,
        obstacle_buffer=sc.obstacle_buffer,
        spring_gain=sc.spring_gain,
        max_iterations=sc.max_iterations,
    )


def tolerances(props: Properties) -> dict[str, float]:
    """Each checked property's tolerance (0 for those without one), in :data:`PROPERTIES` order."""
    out: dict[str, float] = {}
    for name in PROPERTIES:
        spec = getattr(props, name)
        if spec is not None:
            out[name] = float(getattr(spec, "tolerance", 0.0))
    return out


def draw_command(
    operator: str,
    rng: np.random.Generator,
    *,
    twist: bool,
    N: FloatArray,
    o: FloatArray,
    p: FloatArray,
    vmax: FloatArray,
    rate: float,
) -> tuple[FloatArray, int]:
    """The operator's next command and the steps it is held (``wander``, ``push``, ``wild``).

    The closed-loop soak's operator (:func:`velfence.apps.soak_filter.soak_command`): ``wander``
    its random commands, ``push`` its pushes at the nearest facet of the box ``N``, ``o`` from
    the TCP ``p``, ``wild`` either, drawn anew every step.
    """
    if operator == "wild":
        return soak_command(rng, twist=twist, N=N, o=o, p=p, vmax=vmax, rate=1.0,
                            push_probability=0.5)  # fmt: skip
    return soak_command(rng, twist=twist, N=N, o=o, p=p, vmax=vmax, rate=rate,
                        push_probability=1.0 if operator == "push" else 0.0)  # fmt: skip


def face_distances(N: FloatArray, o: FloatArray, p: FloatArray) -> FloatArray:
    """``N p - o`` of the box's facets (positive inside), shape ``(..., m)``.

    ``N`` (..., m, 3), ``o`` (..., m), ``p`` (..., 3): one point or a batch. A sum over x, y, z
    (for the box's axis normals exact, as a BLAS product is).
    """
    d = N[..., 0] * p[..., None, 0] + N[..., 1] * p[..., None, 1] + N[..., 2] * p[..., None, 2]
    return np.asarray(d - o)


def box_margin(N: FloatArray, o: FloatArray, p: FloatArray) -> Any:
    """The TCP's distance inside the box [m] (``inf`` without one): one point or a batch."""
    if N.shape[-2] == 0:
        return np.full(p.shape[:-1], np.inf)[()]
    return np.min(face_distances(N, o, p), axis=-1)


def joint_margin(q: FloatArray, lo: FloatArray, hi: FloatArray) -> Any:
    """The joints' distance inside their limits [rad]: one state or a batch."""
    return np.min(np.minimum(q - lo, hi - q), axis=-1)


def step_margin(m1: Any, m0: Any, tol: float) -> Any:
    """A step's containment or joint-limit margin from the margins before ``m0`` and after ``m1``.

    ``m1`` for a step that began inside (``m0 >= -tol``); for one that began outside, how much
    deeper it went: ``min(0, m1 - m0)``. Floats or arrays.
    """
    began_inside = np.asarray(m0) >= -tol
    if began_inside.all():  # (the usual step: m1 as it is)
        return np.array(m1, dtype=np.float64)[()]
    with np.errstate(invalid="ignore"):  # inf - inf where there is nothing to measure
        return np.where(began_inside, m1, np.minimum(0.0, m1 - m0))[()]


def jerk_margin(bound: float, x: FloatArray, prev: FloatArray, prev2: FloatArray,
                dt: float) -> Any:  # fmt: skip
    """The jerk bound minus the largest joint jerk of the outputs ``prev2, prev, x`` [rad/s³]."""
    return bound - np.max(np.abs(x - 2.0 * prev + prev2), axis=-1) / (dt * dt)


def face_tangent(N: FloatArray, o: FloatArray, p: FloatArray, cmd: FloatArray,
                 buffer: Any) -> FloatArray:  # fmt: skip
    """The command's part tangent to the box's nearest face (the progress property).

    Within ``buffer`` of the box's boundary, the command's push into its nearest face removed;
    elsewhere the command. One point or a batch (``N`` (..., m, 3), ``p`` and ``cmd`` (..., 3)).
    """
    d = face_distances(N, o, p)
    i = np.argmin(d, axis=-1)
    Ni = np.take_along_axis(N, i[..., None, None], axis=-2)[..., 0, :]
    into = np.vecdot(Ni, cmd)
    near = np.min(d, axis=-1) < buffer
    return np.asarray(np.where(near[..., None], cmd - np.minimum(0.0, into)[..., None] * Ni, cmd))


def progress_margin(along: Any, tangent: Any, length: Any, min_fraction: float) -> Any:
    """The progress margin of a held command: mean speed along it minus its required share [m/s].

    ``along`` the TCP's speeds along the command's tangent part summed over ``length`` steps,
    ``tangent`` that part's sizes summed likewise.
    """
    return (along - min_fraction * tangent) / length


class _Worst:
    """Running worst margin of each property (and its first violation)."""

    def __init__(self, props: Properties) -> None:
        self.tol = tolerances(props)
        self.worst: dict[str, tuple[float, int]] = {}
        self.first: dict[str, int] = {}

    def add(self, name: str, margin: float, step: int) -> None:
        if name not in self.tol:
            return
        w = self.worst.get(name)
        if w is None or margin < w[0]:
            self.worst[name] = (margin, step)
        if margin < -self.tol[name] and name not in self.first:
            self.first[name] = step


class Plant(Protocol):
    """What :func:`run`'s closed loop drives: the kinematic plant or MuJoCo's."""

    def state(self) -> tuple[FloatArray, FloatArray, float]:
        """The joints [rad], the TCP [m] and the containment margin [m] now."""
        ...

    def advance(self, reference: FloatArray, t: float) -> FloatArray:
        """Follow the velocity reference over the period from ``t``; the joints' velocity."""
        ...

    def displace(self, dq: FloatArray) -> None:
        """Move the joints by ``dq`` [rad] (a push's motion in one period)."""
        ...

    def extra_trace(self, steps: int) -> dict[str, Any]:
        """Per-step traces of the plant's own beyond the loop's (``record``)."""
        ...


class KinematicPlant:
    """The kinematic plant: ``q <- q + dt a``, ``a`` a first-order lag of time constant ``lag``.

    Args:
        sc: The scenario.
        robot: Its ``DHChain``.
        N: The box's facet normals, shape (m, 3) (m = 0: no box).
        o: Their offsets, shape (m,).
    """

    def __init__(self, sc: Scenario, robot: Any, N: FloatArray, o: FloatArray) -> None:
        self.robot = robot
        self.dt = 1.0 / sc.rate
        self.alpha = 1.0 - math.exp(-self.dt / sc.lag) if sc.lag > 0.0 else 1.0
        self.N, self.o = N, o
        self.C = np.array([s[:3] for s in sc.spheres], dtype=np.float64).reshape(-1, 3)
        self.R = np.array([s[3] for s in sc.spheres], dtype=np.float64)
        self.lrad = np.asarray(robot.link_radius, dtype=np.float64)
        self.q = np.array(sc.q0)
        self.applied = np.zeros(int(robot.dof))

    def state(self) -> tuple[FloatArray, FloatArray, float]:
        """The joints, the TCP and the containment margin (one kinematics pass)."""
        frame = self.robot.kinematics(self.q)
        tcp = np.asarray(frame.point("tcp"), dtype=np.float64)
        gap = math.inf
        if self.C.shape[0]:
            gap = clearance(np.asarray(frame.segments()), self.lrad, self.C, self.R)
        return self.q, tcp, min(float(box_margin(self.N, self.o, tcp)), gap)

    def advance(self, reference: FloatArray, t: float) -> FloatArray:
        """One period of the lagged servo; its velocity [rad/s]."""
        self.applied = self.applied + self.alpha * (reference - self.applied)
        self.q = self.q + self.dt * self.applied
        return self.applied

    def displace(self, dq: FloatArray) -> None:
        """Move the joints by ``dq`` [rad]."""
        self.q = self.q + dq

    def extra_trace(self, steps: int) -> dict[str, Any]:
        """None."""
        return {}


@any_start()
def run(
    sc: Scenario,
    *,
    family: str = "",
    index: int = 0,
    record: bool = False,
    stop_at_failure: bool = False,
) -> CaseResult:
    """Run a scenario in closed loop and measure every property's margin at every step.

    The plant is kinematic (:class:`KinematicPlant`): ``q ← q + dt (a + w)`` with ``a`` the
    servo's velocity (a first-order lag of time constant ``lag`` behind the filter's output
    delayed by ``latency`` steps) and ``w`` the pushes; a scenario with ``plant: mujoco`` runs
    the same loop on MuJoCo (:class:`velfence.apps.verify.plants.MujocoArm`, the ``physics``
    extra). The filter sees ``q`` plus Gaussian noise of standard deviation ``noise``. Margins
    (``docs/verify.md``): *containment* the smallest of the TCP's distance inside the box and
    the links' clearance to the spheres after the step [m] (for a step that began outside: how
    much deeper it went, 0 if not); *joint_limits* likewise for the joints [rad]; *finite* -1
    for a non-finite output or an exception; *deadline* -1 for a deadline fallback; *jerk* the
    bound minus the output's jerk [rad/s³]; *progress* the mean TCP speed along the held
    command's part tangent to the nearest face, minus ``min_fraction`` of that part's size
    [m/s], once ``window`` seconds of a held twist command have passed.

    Args:
        sc: The scenario.
        family: The family's name (for the result).
        index: The case's index (for the result).
        record: Keep per-step traces (for figures).
        stop_at_failure: Stop at the first violation (shrinking).

    Returns:
        The :class:`CaseResult`.

    Raises:
        MissingExtra: a MuJoCo scenario without MuJoCo (``pip install 'velfence[physics]'``).
    """
    robot = chain(sc.robot, sc.link_radius)
    flt = build_filter(sc, robot)
    n = int(robot.dof)
    dt = 1.0 / sc.rate
    twist = sc.mode == "twist"
    props = sc.properties
    worst = _Worst(props)
    if sc.box is not None:
        from velfence.geometry.polytope import ConvexPolytope

        P = ConvexPolytope.box(np.array(sc.box.lower), np.array(sc.box.upper))
        N, o = np.asarray(P.normals, dtype=np.float64), np.asarray(P.offsets, dtype=np.float64)
    else:
        N, o = np.zeros((0, 3)), np.zeros(0)
    plant: Plant
    if sc.plant == "mujoco":  # the MuJoCo plant (velfence.apps.verify.plants)
        from velfence.apps.verify.plants import MujocoArm

        plant = MujocoArm(sc, tool=TOOL)
        if flt.stateful:  # the arm starts at rest: the first output is a step from zero velocity
            flt.reset(velocity=np.zeros(n))
    else:
        plant = KinematicPlant(sc, robot, N, o)
    rng = np.random.default_rng(sc.command_seed)
    noise_rng = np.random.default_rng(sc.noise_seed)
    vmax = np.array(sc.max_speed)
    lo, hi = np.array(sc.lower), np.array(sc.upper)
    jog = None
    if sc.operator == "scripted" and sc.targets:
        from velfence.sim.scenarios import TcpJog

        jog = TcpJog(
            lambda qq: robot.fk(qq),
            [(t[0], np.array(t[1:])) for t in sc.targets],
            speed=sc.jog_speed,
        )
    pushes = [(ps.start, ps.end, np.array(ps.velocity)) for ps in sc.pushes]
    pending: deque[FloatArray] = deque(np.zeros(n) for _ in range(sc.latency))
    jerk_max = None if props.jerk is None else props.jerk.max
    prog = props.progress if twist else None
    window = 0 if prog is None else max(1, round(prog.window * sc.rate))
    tc = worst.tol.get("containment", 0.0)
    tj = worst.tol.get("joint_limits", 0.0)

    q, p, cm0 = plant.state()
    jm0 = float(joint_margin(q, lo, hi))
    prev: FloatArray | None = None
    prev2: FloatArray | None = None
    cmd = np.zeros(3 if twist else n)
    hold = 0
    seg_len = 0
    seg_along = seg_tan = 0.0
    misses = 0
    exceptions = 0
    inter_sum = inter_max = 0.0
    tr_c: list[float] = []
    tr_j: list[float] = []
    tr_p: list[FloatArray] = []
    tr_q: list[FloatArray] = []
    steps = 0
    for k in range(sc.steps):
        qm = q + noise_rng.normal(0.0, sc.noise, n) if sc.noise > 0.0 else q
        pm = p if sc.noise == 0.0 else np.asarray(robot.fk(qm), dtype=np.float64)
        if jog is not None:
            cmd = np.asarray(jog(k * dt, qm), dtype=np.float64)
        elif hold <= 0:
            cmd, hold = draw_command(sc.operator, rng, twist=twist, N=N, o=o, p=pm, vmax=vmax,
                                     rate=sc.rate)  # fmt: skip
            seg_len, seg_along, seg_tan = 0, 0.0, 0.0
        hold -= 1
        try:
            x = np.asarray(flt.filter_twist(qm, cmd) if twist else flt.filter(qm, cmd))
            ok = bool(np.all(np.isfinite(x)))
        except Exception:  # counted as a violation of "finite"; the campaign goes on
            exceptions += 1
            x, ok = np.zeros(n), False
        if not ok:
            x = np.zeros(n)
        worst.add("finite", 0.0 if ok else -1.0, k)
        missed = int(flt.deadline_misses)
        worst.add("deadline", -1.0 if missed > misses else 0.0, k)
        misses = missed
        if jerk_max is not None and prev is not None and prev2 is not None:
            worst.add("jerk", float(jerk_margin(jerk_max, x, prev, prev2, dt)), k)
        prev2, prev = prev, x
        if sc.latency:
            pending.append(x)
            xd = pending.popleft()
        else:
            xd = x
        try:
            qdot = plant.advance(xd, k * dt)
        except VelfenceError:  # the physics diverged: a non-finite state, the case ends here
            exceptions += 1
            worst.add("finite", -1.0, k)
            steps = k + 1
            break
        q1, p1, cm1 = plant.state()
        jm1 = float(joint_margin(q1, lo, hi))
        worst.add("containment", float(step_margin(cm1, cm0, tc)), k)
        worst.add("joint_limits", float(step_margin(jm1, jm0, tj)), k)
        vt = (p1 - p) / dt
        achieved = vt if twist else qdot
        cn = float(np.linalg.norm(cmd))
        rel = float(np.linalg.norm(achieved - cmd)) / cn if cn > 1e-9 else 0.0
        inter_sum += rel
        inter_max = max(inter_max, rel)
        if prog is not None and N.shape[0] and cn > 1e-9:
            ct = face_tangent(N, o, p, cmd, sc.box.buffer)  # type: ignore[union-attr]
            tn = float(np.linalg.norm(ct))
            if tn > 1e-3:
                seg_len += 1
                seg_along += float(vt @ ct) / tn
                seg_tan += tn
                if seg_len >= window:
                    margin = progress_margin(seg_along, seg_tan, seg_len, prog.min_fraction)
                    worst.add("progress", margin, k)
        w = None
        for a, b, v in pushes:
            if a <= k < b:
                w = v if w is None else w + v
        if w is not None:
            plant.displace(dt * w)
            q1, p1, cm1 = plant.state()
            jm1 = float(joint_margin(q1, lo, hi))
        if record:
            tr_c.append(cm1)
            tr_j.append(jm1)
            tr_p.append(p1)
            tr_q.append(q1)
        q, p, cm0, jm0 = q1, p1, cm1, jm1
        steps = k + 1
        if stop_at_failure and worst.first:
            break
    trace: dict[str, Any] = {}
    if record:
        trace = {
            "containment": np.array(tr_c),
            "joint_limits": np.array(tr_j),
            "tcp": np.array(tr_p).reshape(-1, 3),
            "q": np.array(tr_q).reshape(-1, n),
            **plant.extra_trace(len(tr_q)),
            "dt": dt,
        }
    violated = [name for name in PROPERTIES if name in worst.first]
    return CaseResult(
        family=family,
        index=index,
        steps=steps,
        worst=worst.worst,
        violated=violated,
        first=worst.first,
        intervention_mean=inter_sum / max(steps, 1),
        intervention_max=inter_max,
        exceptions=exceptions,
        trace=trace,
    )


def _first(r: CaseResult, props: list[str]) -> int | None:
    """The first step violating one of ``props``, or None."""
    steps = [r.first[p] for p in props if p in r.first]
    return min(steps) if steps else None


def shrink(sc: Scenario, *, max_runs: int = 200) -> Scenario:
    """A smaller scenario that still violates a property the given one violates.

    Tried in order, each kept only if the run (of the original length, cut after its first
    violation) still fails: drop the spheres one by one; drop the pushes (else halve them); no
    sensor noise (else halve it); no latency; no servo lag (else halve it); the start rounded to
    2 then 1 decimals. The result ends at the step of its first violation. At most ``max_runs``
    runs.

    Args:
        sc: A failing scenario.
        max_runs: Most runs spent shrinking.

    Returns:
        The shrunk scenario.

    Raises:
        InvalidParameter: the scenario does not fail.
    """
    base = run(sc, stop_at_failure=True)
    if not base.violated:
        raise InvalidParameter("scenario: it violates no property; nothing to shrink")
    props = base.violated
    runs = 0

    def attempt(candidate: Scenario) -> Scenario | None:
        """The candidate cut after its first violation, or None if it no longer fails."""
        nonlocal runs
        if runs >= max_runs:
            return None
        runs += 1
        first = _first(run(candidate, stop_at_failure=True), props)
        return None if first is None else candidate.model_copy(update={"steps": first + 1})

    first = _first(base, props)
    cur = sc.model_copy(update={"steps": (first or 0) + 1})
    full = sc.steps

    def trial(**update: Any) -> bool:
        nonlocal cur
        got = attempt(cur.model_copy(update={**update, "steps": full}))
        if got is not None:
            cur = got
        return got is not None

    i = 0
    while i < len(cur.spheres):
        if not trial(spheres=cur.spheres[:i] + cur.spheres[i + 1 :]):
            i += 1
    if cur.pushes and not trial(pushes=[]):
        for _ in range(6):
            half = [
                ps.model_copy(update={"velocity": [v / 2 for v in ps.velocity]})
                for ps in cur.pushes
            ]
            if not trial(pushes=half):
                break
    for name, zero in (("noise", 0.0), ("latency", 0), ("lag", 0.0)):
        if getattr(cur, name) and not trial(**{name: zero}) and name != "latency":
            for _ in range(6):
                if not trial(**{name: getattr(cur, name) / 2}):
                    break
    for digits in (2, 1):
        trial(q0=[round(v, digits) for v in cur.q0])
    return cur


def write_scenario(sc: Scenario, path: str | Path, *, comment: str = "") -> Path:
    """Write a scenario as YAML (``velfence verify --replay PATH`` runs it again).

    Args:
        sc: The scenario.
        path: The file (written atomically).
        comment: Lines written as a YAML comment on top.

    Returns:
        ``path``.
    """
    import yaml

    p = Path(path)
    head = "".join(f"# {line}\n" for line in comment.splitlines())
    text = yaml.safe_dump(sc.model_dump(mode="json"), sort_keys=False, width=100)
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(head + text)
    tmp.replace(p)
    return p


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario written by :func:`write_scenario` (validated).

    Args:
        path: The YAML file.

    Returns:
        The :class:`Scenario`.

    Raises:
        InvalidParameter: a missing or malformed file, an invalid scenario (naming the field).
    """
    from velfence.io.shaper_config import load_yaml

    data = load_yaml(path)
    try:
        return Scenario.model_validate(data)
    except ValidationError as err:
        raise InvalidParameter(f"{path}: {describe_validation_error(err, Scenario)}") from None
