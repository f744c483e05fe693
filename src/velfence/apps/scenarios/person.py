r"""A person walks into the fence-box cell while the arm works: speed and separation in MuJoCo.

The arm, box, servo and controller loop are the fence-box scenario's
(:mod:`~velfence.apps.scenarios.fence_box`: :func:`velfence.robots.panda` with capsule links of
radius 0.05 m, the TCP box, the computed-torque servo at 25 rad/s, 2 kHz physics,
:class:`~velfence.filter.SafetyFilter` in twist mode), at 250 Hz control (:data:`DT`). The
operator is a task: the TCP visits four waypoints in the box in a loop at ``TASK_SPEED``, moving
on to the next one when within 5 mm.

The person (``docs/physics.md``) is two capsules, mocap bodies of the MuJoCo model: the body
(radius 0.2 m, axis 0.25–1.45 m above the floor) and the right arm (radius 0.05 m, 0.76 m from
the shoulder). The person walks from 2.2 m away toward the cell at up to 1.6 m/s (ISO 13855's
walking speed, accelerating and braking at 1.5 m/s²), stops in front of it, reaches toward the
arm's working area at up to 0.5 m/s, holds, withdraws the arm and walks away.

The robot knows the person in two ways, both fed from the simulation every period:

* a tracker: the two capsules as :class:`~velfence.filter.PersonCapsule` with their measured
  velocities (ground truth, plus an optional latency and position noise) into
  :class:`~velfence.filter.SeparationRows` (:data:`PARAMETERS`, advisory ISO/TS 15066 speed and
  separation monitoring);
* a depth sensor on the cell's corner (:class:`DepthSensor`: MuJoCo rays, ``mj_multiRay``, from
  a fixed pose, :data:`SENSOR_RATE` frames per second) into
  :class:`~velfence.filter.PointCloudRows`, whose self filter removes the arm's own returns.

The people run also switches the safety mode as a cobot's safety system does
(:class:`~velfence.filter.modes.ModeRows`): *Reduced* (:data:`REDUCED_LIMITS`: TCP at most
0.1 m/s, joints at half speed) while the tracked body's footprint is in :data:`REDUCED_ZONE`
(the floor around the box, as a safety laser scanner watches it), *Stop* while the tracked hand
is within :data:`STOP_DISTANCE` of the TCP, each a request of the tracker with its own
hysteresis band, and :data:`MODE_DWELL` in a mode before a laxer one.

Runs: ``"safety-filter-no-people"`` (the fence-box filter: box and joint limits only) and
``"safety-filter-people"`` (the same with the separation, point-cloud and mode rows). Further
row providers join the people rows through ``run(providers=...)``, one line.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence.apps.labels import method_label
from velfence.apps.reproduce.base import Check, Report, check_at_least, check_at_most
from velfence.apps.scenarios.common import PhysicsRun, ScenarioResult, scenario_methods
from velfence.apps.scenarios.fence_box import BANDWIDTH, BOX_LOWER, BOX_UPPER, PHYSICS_DT, Q0
from velfence.filter.modes import ModeLimits, ModeRows, SafetyMode
from velfence.filter.separation import PersonCapsule, SeparationParameters

__all__ = [
    "METHODS",
    "MODE_DWELL",
    "PARAMETERS",
    "REDUCED_LIMITS",
    "REDUCED_ZONE",
    "SENSOR_RATE",
    "STOP_DISTANCE",
    "TASK_SPEED",
    "DepthSensor",
    "PersonPath",
    "person_model",
    "plot_separation",
    "run",
]

#: The compared controllers, in table order.
METHODS: tuple[str, ...] = ("safety-filter-no-people", "safety-filter-people")
#: The speed and separation terms (advisory): ``T_r`` covers the tracker and one control period,
#: ``T_s`` and ``a_s`` the arm's stop, ``Z_d`` the tracker's and ``Z_r`` the arm's uncertainty.
PARAMETERS = SeparationParameters(
    reaction_time=0.1,
    stopping_time=0.2,
    max_deceleration=2.5,
    human_uncertainty=0.05,
    robot_uncertainty=0.01,
)
#: Printed by ``velfence sim --scenario person-cell`` with its results.
NOTICE = (
    "Speed and separation monitoring and the safety modes here are advisory, not a certified "
    "safety function: a cell with people needs the robot's own safety-rated stop "
    "(docs/separation.md)."
)

#: The TCP's task speed [m/s].
TASK_SPEED = 0.3
#: The task's waypoints in the box [m], visited in a loop.
WAYPOINTS: tuple[tuple[float, float, float], ...] = (
    (0.62, -0.20, 0.55),
    (0.62, 0.20, 0.55),
    (0.45, 0.20, 0.40),
    (0.45, -0.20, 0.40),
)
#: The control period [s] (the fence box's is 2 ms; the people rows run on the Python route).
DT = 4e-3
#: Depth frames per second.
SENSOR_RATE = 30.0
#: Voxel edge of the point-cloud rows [m].
VOXEL = 0.03
BODY_RADIUS = 0.2
ARM_RADIUS = 0.05
ARM_LENGTH = 0.76
SHOULDER = 1.30
_UP = np.array([0.0, 0.0, 1.0])
#: Where the person stops, the walking direction's start and the hand's reach target [m].
STAND = (0.95, -0.05)
START = (2.60, -1.45)
REACH = (0.70, 0.20, 0.62)
#: The margin figure's largest margin shown [m] (larger ones are drawn at it).
SHOWN_MARGIN = 0.3
#: A short version for the tests: the person starts 1.3 m away at once and holds 2 s, and the
#: task starts at its second waypoint (so the arm, slowed by Reduced, nears the held-out hand
#: there and Stop holds it).
SHORT: dict[str, Any] = {"start_time": 0.0, "start": (1.94, -0.89), "hold": 2.0}
SHORT_TASK_START = 1
#: The Reduced mode's limits: the TCP at most 0.1 m/s, every joint at half its speed limit.
REDUCED_LIMITS = ModeLimits(joint_scale=0.5, point_speeds={"tcp": 0.1})
#: The Reduced zone on the floor, (x_min, y_min, x_max, y_max) [m]: the box's footprint grown by
#: 0.5 m. The person is in it when the body's footprint (its radius around the foot) overlaps it.
REDUCED_ZONE = (BOX_LOWER[0] - 0.5, BOX_LOWER[1] - 0.5, BOX_UPPER[0] + 0.5, BOX_UPPER[1] + 0.5)
#: Stop while the hand's surface is this close to the TCP [m].
STOP_DISTANCE = 0.35
#: The hysteresis bands [m]: a request is released only this far beyond its trigger.
ZONE_EXIT = 0.1
STOP_EXIT = 0.05
#: Least time in a mode before a laxer one [s].
MODE_DWELL = 0.5
UNITS = {
    "min_separation_margin": "m",
    "lag_bound": "m",
    "min_separation": "m",
    "min_cloud_clearance": "m",
    "slowest_near": "m/s",
    "approach_inside": "m/s",
    "periods_inside": "periods",
    "waypoints_before": "count",
    "waypoints_after": "count",
    "resume_delay": "s",
    "time_normal": "s",
    "time_reduced": "s",
    "time_stop": "s",
    "mode_switches": "count",
    "reduced_delay": "s",
    "fastest_reduced": "m/s",
    "fastest_stop": "m/s",
    "normal_at_end": "s",
    "waypoints_after_normal": "count",
}


def _profile(distance: float, vmax: float, accel: float) -> tuple[float, Callable[[float], float]]:
    """Rest-to-rest trapezoid over ``distance``: its duration and ``tau -> s``."""
    ta = vmax / accel
    if accel * ta * ta >= distance:  # a triangle: never reaches vmax
        ta = math.sqrt(distance / accel)
        vmax = accel * ta
    tc = (distance - accel * ta * ta) / vmax
    total = 2.0 * ta + tc

    def s_of(tau: float) -> float:
        tau = min(max(tau, 0.0), total)
        if tau < ta:
            return 0.5 * accel * tau * tau
        if tau < ta + tc:
            return 0.5 * accel * ta * ta + vmax * (tau - ta)
        r = total - tau
        return distance - 0.5 * accel * r * r

    return total, s_of


def _rate(s_of: Callable[[float], float], tau: float) -> float:
    """The profile's speed at ``tau`` (a central difference of 0.1 ms; the profile is C¹)."""
    h = 5e-5
    return (s_of(tau + h) - s_of(tau - h)) / (2.0 * h)


@dataclass(frozen=True)
class PersonPath:
    """The person's script: walk in, reach, hold, withdraw, walk out (module docstring).

    Attributes:
        start_time: When the person starts walking [s].
        start: Where the walk starts, (x, y) [m] on the floor.
        stand: Where the person stops in front of the cell, (x, y) [m].
        reach: The hand's target [m], shape (3,).
        walk_speed: Top walking speed [m/s] (ISO 13855's 1.6).
        reach_speed: Top hand speed while reaching [m/s].
        accel: Acceleration and braking of the walk and the reach [m/s²].
        hold: How long the hand stays at ``reach`` [s].
    """

    start_time: float = 1.0
    start: tuple[float, float] = START
    stand: tuple[float, float] = STAND
    reach: tuple[float, float, float] = REACH
    walk_speed: float = 1.6
    reach_speed: float = 0.5
    accel: float = 1.5
    hold: float = 2.5
    _c: dict[str, Any] = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        from velfence._validate import check_positive, real_array
        from velfence.errors import InvalidParameter

        put = object.__setattr__
        for name in ("walk_speed", "reach_speed", "accel", "hold"):
            put(self, name, check_positive(name, getattr(self, name)))
        put(self, "start_time", check_positive("start_time", self.start_time, allow_zero=True))
        a = real_array("start", self.start, (2,), error=InvalidParameter, max_abs=100.0)
        b = real_array("stand", self.stand, (2,), error=InvalidParameter, max_abs=100.0)
        reach = real_array("reach", self.reach, (3,), error=InvalidParameter, max_abs=100.0)
        length = float(np.linalg.norm(b - a))
        if length < 1e-3:
            raise InvalidParameter(f"start, stand: expected 1 mm apart or more, got {length} m")
        put(self, "start", (float(a[0]), float(a[1])))
        put(self, "stand", (float(b[0]), float(b[1])))
        put(self, "reach", (float(reach[0]), float(reach[1]), float(reach[2])))
        c = self._c
        heading = (b - a) / length
        side = np.array([heading[1], -heading[0], 0.0])  # the walker's right
        shoulder0 = np.array([b[0], b[1], SHOULDER]) + 0.22 * side
        target = np.asarray(self.reach, dtype=float) - shoulder0
        target /= np.linalg.norm(target)
        angle = float(np.arccos(np.clip(-target[2], -1.0, 1.0)))
        down = np.array([0.0, 0.0, -1.0])
        axis = np.cross(down, target)
        axis /= max(float(np.linalg.norm(axis)), 1e-12)
        tw, walk = _profile(length, self.walk_speed, self.accel)
        tr, swing = _profile(angle * ARM_LENGTH, self.reach_speed, self.accel)
        t = self.start_time
        marks = {"walk in": t, "arrived": t + tw}
        marks["reached"] = marks["arrived"] + tr
        marks["withdraw"] = marks["reached"] + self.hold
        marks["withdrawn"] = marks["withdraw"] + tr
        marks["gone"] = marks["withdrawn"] + tw
        c.update(
            a=a, b=b, heading=heading, side=side, down=down, axis=axis, perp=np.cross(axis, down),
            walk=walk, swing=swing, tr=tr, angle=angle, marks=marks,
        )  # fmt: skip

    @property
    def times(self) -> dict[str, float]:
        """The script's instants [s]: walk in, arrived, reached, withdraw, withdrawn, gone."""
        return dict(self._c["marks"])

    def pose(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """The body's floor point, the shoulder and the hand [m], and the body's velocity [m/s].

        Args:
            t: Time [s].

        Returns:
            ``(foot, shoulder, hand, velocity)``, each shape (3,); the hand's velocity is
            :meth:`hand_velocity`.
        """
        c = self._c
        m = c["marks"]
        if t < m["arrived"]:
            tau, p0, u = t - m["walk in"], c["a"], c["heading"]
        else:
            tau, p0, u = t - m["withdrawn"], c["b"], -c["heading"]
        s, v = c["walk"](tau), _rate(c["walk"], tau)
        foot = np.array([p0[0] + s * u[0], p0[1] + s * u[1], 0.0])
        vel = np.array([v * u[0], v * u[1], 0.0])
        shoulder = foot + _UP * SHOULDER + 0.22 * c["side"]
        phi, _ = self._swing(t)
        d = c["down"] * math.cos(phi) + c["perp"] * math.sin(phi)
        return foot, shoulder, shoulder + ARM_LENGTH * d, vel

    def _swing(self, t: float) -> tuple[float, float]:
        """The arm's angle from hanging down [rad] and its rate [rad/s]."""
        c = self._c
        m = c["marks"]
        if t < m["withdraw"]:
            tau = t - m["arrived"]
            return c["swing"](tau) / ARM_LENGTH, _rate(c["swing"], tau) / ARM_LENGTH
        tau = t - m["withdraw"]
        return (
            c["angle"] - c["swing"](tau) / ARM_LENGTH,
            -_rate(c["swing"], tau) / ARM_LENGTH,
        )

    def hand_velocity(self, t: float) -> FloatArray:
        """The hand's velocity [m/s], shape (3,): the walk plus the swing."""
        c = self._c
        phi, w = self._swing(t)
        _, _, _, vel = self.pose(t)
        tangent = -c["down"] * math.sin(phi) + c["perp"] * math.cos(phi)
        out: FloatArray = vel + ARM_LENGTH * w * tangent
        return out

    def capsules(self, t: float) -> tuple[PersonCapsule, PersonCapsule]:
        """The body and the arm at time ``t`` [s], with their velocities (the hand's for the arm).

        Args:
            t: Time [s].

        Returns:
            ``(body, arm)`` as :class:`~velfence.filter.PersonCapsule` in the robot's base
            frame.
        """
        t = float(t)
        foot, shoulder, hand, vel = self.pose(t)
        body = PersonCapsule(
            foot + _UP * 0.25,
            b=foot + _UP * 1.45,
            radius=BODY_RADIUS,
            velocity=vel,
            name="body",
        )
        arm = PersonCapsule(
            shoulder, b=hand, radius=ARM_RADIUS, velocity=self.hand_velocity(t), name="arm"
        )
        return body, arm


def person_model(robot: Any) -> str:
    """The robot's MJCF with the person's two capsules as mocap bodies (geom group 3).

    The person's geoms collide with nothing (``contype = conaffinity = 0``: the separation is
    measured, not felt) and sit in geom group 3, which MuJoCo's renderer hides by default (the
    video draws the person where the script puts it); MuJoCo's rays see them.

    Args:
        robot: A :class:`~velfence.robots.MujocoRobot`.

    Returns:
        The MJCF document.
    """
    import mujoco

    spec = mujoco.MjSpec.from_string(robot.xml)
    for name, radius, half, offset in (
        ("person_body", BODY_RADIUS, 0.6, 0.0),
        ("person_arm", ARM_RADIUS, 0.5 * ARM_LENGTH, -0.5 * ARM_LENGTH),
    ):
        body = spec.worldbody.add_body()
        body.name = name
        body.mocap = True
        body.pos = [5.0, 5.0, 0.0]
        g = body.add_geom()
        g.name = name
        g.type = mujoco.mjtGeom.mjGEOM_CAPSULE
        g.size = [radius, half, 0.0]
        g.pos = [0.0, 0.0, offset]
        g.contype = 0
        g.conaffinity = 0
        g.group = 3
        g.rgba = [0.95, 0.6, 0.2, 1.0]
    xml: str = spec.to_xml()
    return xml


def place_person(model: Any, data: Any, path: PersonPath, t: float) -> None:
    """Move the mocap bodies of :func:`person_model` to the person at ``t`` (internal API)."""
    import mujoco

    foot, shoulder, hand, _ = path.pose(t)
    body = int(model.body_mocapid[model.body("person_body").id])
    data.mocap_pos[body] = foot + _UP * 0.85
    data.mocap_quat[body] = (1.0, 0.0, 0.0, 0.0)
    arm = int(model.body_mocapid[model.body("person_arm").id])
    data.mocap_pos[arm] = shoulder
    quat = np.zeros(4)
    mujoco.mju_quatZ2Vec(quat, shoulder - hand)  # the body's -z points from shoulder to hand
    data.mocap_quat[arm] = quat


@dataclass(frozen=True)
class DepthSensor:
    """A fixed depth sensor: a grid of MuJoCo rays (``mj_multiRay``) from one point.

    Attributes:
        origin: The sensor's position [m], shape (3,).
        target: The point its optical axis goes through [m], shape (3,).
        width: Rays per row.
        height: Rows.
        fov: Horizontal field of view [deg] (the vertical one follows the aspect ratio).
        max_range: Returns beyond this distance [m] are dropped.
        noise: Standard deviation of the range noise [m] (0: exact).
    """

    origin: tuple[float, float, float] = (1.7, 1.3, 2.1)
    target: tuple[float, float, float] = (0.75, -0.25, 0.7)
    width: int = 96
    height: int = 72
    fov: float = 55.0
    max_range: float = 5.0
    noise: float = 0.0

    def __post_init__(self) -> None:
        from velfence._validate import check_positive, check_positive_int, real_array
        from velfence.errors import InvalidParameter

        put = object.__setattr__
        o = real_array("origin", self.origin, (3,), error=InvalidParameter, max_abs=100.0)
        c = real_array("target", self.target, (3,), error=InvalidParameter, max_abs=100.0)
        if (
            float(np.linalg.norm(c - o)) < 1e-6
            or float(np.linalg.norm(np.cross(c - o, _UP))) < 1e-6
        ):
            raise InvalidParameter(
                "target: expected a point away from origin, not straight up/down"
            )
        put(self, "origin", (float(o[0]), float(o[1]), float(o[2])))
        put(self, "target", (float(c[0]), float(c[1]), float(c[2])))
        put(self, "width", check_positive_int("width", self.width, maximum=4096))
        put(self, "height", check_positive_int("height", self.height, maximum=4096))
        fov = check_positive("fov", self.fov, unit="deg")
        if fov >= 170.0:
            raise InvalidParameter(f"fov: expected a field of view below 170 deg, got {fov}")
        put(self, "fov", fov)
        put(self, "max_range", check_positive("max_range", self.max_range, unit="m"))
        put(self, "noise", check_positive("noise", self.noise, allow_zero=True, unit="m"))

    def directions(self) -> FloatArray:
        """Unit ray directions in the world frame, shape (width·height, 3)."""
        o, c = np.asarray(self.origin, float), np.asarray(self.target, float)
        fwd = (c - o) / np.linalg.norm(c - o)
        right = np.cross(fwd, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, fwd)
        tx = math.tan(math.radians(self.fov) / 2.0)
        ty = tx * self.height / self.width
        u = np.linspace(-tx, tx, self.width)
        v = np.linspace(-ty, ty, self.height)
        U, V = np.meshgrid(u, v)
        d = fwd[None, :] + U.reshape(-1, 1) * right[None, :] + V.reshape(-1, 1) * up[None, :]
        out: FloatArray = d / np.linalg.norm(d, axis=1, keepdims=True)
        return out

    def scan(
        self, model: Any, data: Any, rng: np.random.Generator | None = None
    ) -> tuple[FloatArray, np.ndarray[Any, np.dtype[np.int32]]]:
        """The points the rays hit [m], shape (M, 3), and the geom each hit, shape (M,).

        ``data`` must hold the current kinematics (``mj_kinematics`` after moving the bodies).

        Args:
            model: The ``mujoco.MjModel``.
            data: Its ``mujoco.MjData``.
            rng: Draws the range noise (needed when ``noise > 0``).

        Returns:
            ``(points, geom ids)``; rays that hit nothing within ``max_range`` give no point.
        """
        import mujoco

        dirs = self.directions()
        n = dirs.shape[0]
        geomid = np.full(n, -1, dtype=np.int32)
        dist = np.full(n, -1.0)
        origin = np.asarray(self.origin, dtype=float)
        mujoco.mj_multiRay(
            model, data, origin, dirs.ravel(), None, 1, -1, geomid, dist, None, n, self.max_range
        )
        hit = (geomid >= 0) & (dist >= 0.0)
        r = dist[hit]
        if self.noise > 0.0 and rng is not None:
            r = r + rng.normal(0.0, self.noise, size=r.shape)
        pts: FloatArray = origin[None, :] + r[:, None] * dirs[hit]
        return pts, geomid[hit]


def in_reduced_zone(foot: Any) -> float:
    """How far the body's footprint is outside :data:`REDUCED_ZONE` [m] (<= 0: in it).

    The distance from the foot's (x, y) to the zone's rectangle minus the body's radius.
    """
    x0, y0, x1, y1 = REDUCED_ZONE
    dx = max(x0 - float(foot[0]), 0.0, float(foot[0]) - x1)
    dy = max(y0 - float(foot[1]), 0.0, float(foot[1]) - y1)
    return math.hypot(dx, dy) - BODY_RADIUS


class _Cell:
    """The plant for :func:`velfence.sim.simulate`: the MuJoCo arm, the person and the sensors.

    Every period it moves the person (mocap), advances the arm's plant, and at the period's end
    feeds the tracker's capsules to ``separation`` and, at the sensor's rate, a depth frame to
    ``cloud``; with ``modes`` it requests Reduced while the tracked body is in the Reduced zone
    and Stop while the tracked hand is near the TCP (``tcp``: the TCP of a joint position),
    then calls ``modes.update`` once; it logs what the metrics need.
    """

    def __init__(
        self,
        plant: Any,
        path: PersonPath,
        sensor: DepthSensor,
        *,
        separation: Any | None,
        cloud: Any | None,
        latency: float,
        tracker_noise: float,
        seed: int,
        modes: ModeRows | None = None,
        tcp: Callable[[FloatArray], Any] | None = None,
    ) -> None:
        self.plant, self.path, self.sensor = plant, path, sensor
        self.separation, self.cloud = separation, cloud
        self.modes, self.tcp = modes, tcp
        self.mode_log: list[tuple[float, SafetyMode]] = []
        self._asked = {"person in zone": False, "hand near TCP": False}
        self.latency, self.tracker_noise = latency, tracker_noise
        self.model = plant.model
        self._rng = np.random.default_rng(seed)
        self._person_geoms = {int(self.model.geom(n).id) for n in ("person_body", "person_arm")}
        self.frames: list[tuple[float, FloatArray]] = []  # (stamp, person points)
        self.frame_sizes: list[tuple[int, int]] = []  # (all points, person points)
        self._next_frame = 0.0

    @property
    def record(self) -> Any:
        return self.plant.record

    @property
    def time_constant(self) -> float:
        return float(self.plant.time_constant)

    def _switch_mode(
        self, t: float, q: FloatArray, body: PersonCapsule, arm: PersonCapsule
    ) -> None:
        """One ``update`` (the period's clock), then the tracker's requests with their bands.

        A stricter request applies at once, stamped with this period's time; a release lets
        the mode relax at the next ``update`` that the dwell allows.
        """
        modes = self.modes
        if modes is None:
            return
        modes.update(q, time=t)
        foot = np.asarray(body.a) - _UP * 0.25
        out = in_reduced_zone(foot)
        hand = np.asarray(arm.b)
        gap = math.inf
        if self.tcp is not None:
            gap = float(np.linalg.norm(hand - np.asarray(self.tcp(q)))) - ARM_RADIUS
        for source, mode, dist, trigger, band in (
            ("person in zone", SafetyMode.REDUCED, out, 0.0, ZONE_EXIT),
            ("hand near TCP", SafetyMode.STOP, gap, STOP_DISTANCE, STOP_EXIT),
        ):
            if not self._asked[source] and dist <= trigger:
                self._asked[source] = True
                modes.request(mode, source=source)
            elif self._asked[source] and dist > trigger + band:
                self._asked[source] = False
                modes.request(SafetyMode.NORMAL, source=source)
        self.mode_log.append((t, modes.mode))

    def _sense(self, t: float, q: FloatArray) -> None:
        import mujoco

        mdl, d = self.model, self.plant.data
        place_person(mdl, d, self.path, t)
        mujoco.mj_kinematics(mdl, d)
        seen = max(0.0, t - self.latency)
        body, arm = self.path.capsules(seen)
        if self.tracker_noise > 0.0:
            s = self.tracker_noise
            body, arm = (
                PersonCapsule(
                    np.asarray(p.a) + self._rng.normal(0.0, s, 3),
                    b=np.asarray(p.b) + self._rng.normal(0.0, s, 3),
                    radius=p.radius,
                    velocity=p.velocity,
                    name=p.name,
                )
                for p in (body, arm)
            )
        if self.separation is not None:
            self.separation.update([body, arm], stamp=t)
        self._switch_mode(t, q, body, arm)
        if t + 1e-9 >= self._next_frame:
            pts, gid = self.sensor.scan(mdl, d, self._rng)
            person = np.isin(gid, list(self._person_geoms))
            self.frames.append((t, pts[person]))
            self.frame_sizes.append((len(pts), int(np.count_nonzero(person))))
            if self.cloud is not None:
                self.cloud.update(pts, stamp=t)
            self._next_frame += 1.0 / SENSOR_RATE

    def reset(self, q0: FloatArray, dt: float) -> FloatArray:
        q = np.asarray(self.plant.reset(q0, dt), dtype=float)
        self.frames, self.frame_sizes, self._next_frame = [], [], 0.0
        self.mode_log = []
        self._dt = dt
        self._sense(0.0, q)
        return q

    def advance(self, v: FloatArray, t: float) -> FloatArray:
        place_person(self.model, self.plant.data, self.path, t)
        q = np.asarray(self.plant.advance(v, t), dtype=float)
        self._sense(t + self._dt, q)
        return q


class _Task:
    """The TCP's task: to each waypoint in turn at ``speed`` (a :class:`TcpJog` per waypoint)."""

    def __init__(self, fk: Callable[[FloatArray], Any], speed: float, first: int = 0) -> None:
        from velfence.sim.scenarios import TcpJog

        self.fk = fk
        self.jogs = [TcpJog(fk, [(1e9, w)], speed=speed) for w in WAYPOINTS]
        self.k = first
        self.reached: list[float] = []

    def __call__(self, t: float, q: FloatArray) -> FloatArray:
        w = np.asarray(WAYPOINTS[self.k % len(WAYPOINTS)])
        if float(np.linalg.norm(np.asarray(self.fk(q)) - w)) < 0.005:
            self.reached.append(float(t))
            self.k += 1
        out: FloatArray = np.asarray(self.jogs[self.k % len(WAYPOINTS)](t, q), dtype=float)
        return out


def build_controller(
    robot: Any,
    *,
    people: bool,
    providers: Sequence[Any] = (),
    modes: bool = True,
) -> tuple[Any, Any | None, Any | None, ModeRows | None]:
    """The twist-mode filter of one run and its separation, point-cloud and mode rows (internal).

    Args:
        robot: The arm.
        people: Whether the filter gets the separation and point-cloud rows (and the mode rows).
        providers: Further row providers, after the people's.
        modes: Whether the people run gets the mode rows (:data:`REDUCED_LIMITS`, no zones of
            their own: the tracker's requests switch them, :data:`MODE_DWELL`).

    Returns:
        ``(shaper, separation rows or None, point-cloud rows or None, mode rows or None)``.
    """
    from velfence.filter import PointCloudRows, SafetyFilter, SeparationRows
    from velfence.filter.limits import JointLimits, WorkspaceLimit
    from velfence.filter.twist import TwistMode
    from velfence.geometry.polytope import ConvexPolytope

    box = ConvexPolytope.box(np.array(BOX_LOWER), np.array(BOX_UPPER))
    lim = np.array(robot.joint_limits)
    limits = JointLimits(lim[:, 0], lim[:, 1], max_speed=np.asarray(robot.velocity_limits))
    rows: list[Any] = []
    sep = cloud = None
    mode_rows = None
    if people:
        sep = SeparationRows(PARAMETERS, link_radius=robot.link_radius, max_speed=limits.max_speed)
        cloud = PointCloudRows(
            voxel=VOXEL,
            link_radius=robot.link_radius,
            max_speed=limits.max_speed,
            buffer=0.05,
            spring_gain=1.0,
            decay=0.1,
            # The half diagonal, plus one frame of the arm's motion (0.3 m/s / 30 Hz) and 1 cm.
            self_margin=0.5 * math.sqrt(3.0) * VOXEL + TASK_SPEED / SENSOR_RATE + 0.01,
        )
        rows += [sep, cloud]
        if modes:
            mode_rows = ModeRows(
                robot,
                modes={SafetyMode.REDUCED: REDUCED_LIMITS},
                max_speed=limits.max_speed,
                dwell=MODE_DWELL,
            )
            rows.append(mode_rows)
    rows += list(providers)
    f = SafetyFilter(
        robot,
        limits=limits,
        workspace=(WorkspaceLimit(box, point="tcp", buffer=0.05),),
        providers=rows,
        dt=DT,
    )
    return TwistMode(f), sep, cloud, mode_rows


def run(
    *,
    methods: Sequence[str] = METHODS,
    path: PersonPath | None = None,
    duration: float | None = None,
    sensor: DepthSensor | None = None,
    latency: float = 0.0,
    tracker_noise: float = 0.0,
    providers: Sequence[Any] = (),
    modes: bool = True,
    task_start: int = 0,
    on_step: Callable[[str, float], None] | None = None,
) -> ScenarioResult:
    """Run the arm with and without the people rows while the person comes and goes.

    Args:
        methods: Which of :data:`METHODS` to run.
        path: The person's script (default :class:`PersonPath`).
        duration: Simulated time [s] (default: until 2 s after the person has gone).
        sensor: The depth sensor (default :class:`DepthSensor`).
        latency: The tracker's latency [s], >= 0: the rows get the person as it was then.
        tracker_noise: Standard deviation of the tracker's position noise [m], >= 0.
        providers: Further row providers of the people run's filter (after the people's).
        modes: Whether the people run switches the safety mode (Normal, Reduced, Stop; module
            docstring), default ``True``.
        task_start: The index of the task's first waypoint (0–3).
        on_step: Progress ``(method, fraction)``.

    Returns:
        The runs, metrics and named checks.
    """
    from velfence._validate import check_flag, check_positive, check_positive_int
    from velfence.robots import panda
    from velfence.sim.physics import MujocoPlant
    from velfence.sim.runner import simulate

    methods = scenario_methods(methods, METHODS)
    path = PersonPath() if path is None else path
    sensor = DepthSensor() if sensor is None else sensor
    latency = check_positive("latency", latency, allow_zero=True, unit="s")
    tracker_noise = check_positive("tracker_noise", tracker_noise, allow_zero=True, unit="m")
    modes = check_flag("modes", modes)
    end = path.times["gone"] + 2.0 if duration is None else duration
    end = check_positive("duration", end, unit="s")
    first = check_positive_int("task_start", task_start, minimum=0, maximum=len(WAYPOINTS) - 1)
    robot = panda(radius=0.05)
    xml = person_model(robot)
    q0 = np.array(Q0)
    runs: dict[str, PhysicsRun] = {}
    for name in methods:
        people = name == "safety-filter-people"
        shaper, sep, cloud, mode_rows = build_controller(
            robot, people=people, providers=providers if people else (), modes=bool(modes)
        )
        plant = MujocoPlant(
            xml,
            bandwidth=BANDWIDTH,
            physics_dt=PHYSICS_DT,
            max_speed=np.asarray(robot.velocity_limits),
        )
        cell = _Cell(
            plant,
            path,
            sensor,
            separation=sep,
            cloud=cloud,
            latency=latency,
            tracker_noise=tracker_noise,
            seed=0,
            modes=mode_rows,
            tcp=robot.fk,
        )
        task = _Task(robot.fk, TASK_SPEED, first)
        active: list[tuple[str, ...]] = []

        def log(k: int, t: float, res: Any, active: list[tuple[str, ...]] = active) -> None:
            active.append(tuple(res.active_names))

        progress = None if on_step is None else (lambda f, name=name: on_step(name, f))
        tr = simulate(
            shaper,
            task,
            q0,
            duration=end,
            dt=DT,
            plant=cell,
            name=name,
            on_progress=progress,
            on_result=log,
        )
        tcp = np.array([robot.fk(q) for q in tr.p])
        extra: dict[str, Any] = {
            "active": active,
            "reached": list(task.reached),
            "frames": cell.frames,
            "frame_sizes": cell.frame_sizes,
            "removed_self": 0 if cloud is None else cloud.removed_self,
        }
        if mode_rows is not None:
            extra["mode"] = [m.value for _t, m in cell.mode_log]
            extra["mode_events"] = list(mode_rows.history)
            extra["mode_switches"] = mode_rows.switches
        runs[name] = PhysicsRun(name, tr, plant.record, plant.model, tcp, extra)
    metrics = {n: _metrics(r, robot, path) for n, r in runs.items()}
    report = _report(metrics, latency=latency)
    scene = {
        "polytope": _box(),
        "point": "TCP",
        "person": lambda times: _person_segments(path, times),
        "camera": {
            "lookat": (0.8, 0.0, 0.75),
            "distance": 2.4,
            "azimuth": -105.0,
            "elevation": -20.0,
        },
        "margin": (
            "separation minus S, least over links and body parts (drawn up to 0.3 m)",
            "m",
            {"S (zero margin)": 0.0, "servo lag bound −T·v̄_r": -_largest_bound(metrics)},
        ),
        "figures": {f"{SCENARIO}_separation.png": plot_separation},
        "events": path.times,
    }
    return ScenarioResult(SCENARIO, runs, metrics, UNITS, report, scene)


SCENARIO = "person-cell"


def _person_segments(path: PersonPath, times: Any) -> tuple[FloatArray, FloatArray]:
    """The body's and the arm's axes at ``times`` [m], shape (N, 2, 2, 3), and their radii."""
    out = np.empty((len(times), 2, 2, 3))
    for k, t in enumerate(times):
        foot, shoulder, hand, _ = path.pose(float(t))
        out[k, 0] = (foot + _UP * 0.25, foot + _UP * 1.45)
        out[k, 1] = (shoulder, hand)
    return out, np.array([BODY_RADIUS, ARM_RADIUS])


def _box() -> Any:
    from velfence.geometry.polytope import ConvexPolytope

    return ConvexPolytope.box(np.array(BOX_LOWER), np.array(BOX_UPPER))


def _largest_bound(metrics: dict[str, dict[str, float]]) -> float:
    b = metrics.get("safety-filter-people", next(iter(metrics.values())))["lag_bound"]
    return float(b)


def separation_series(run: PhysicsRun, robot: Any, path: PersonPath) -> dict[str, FloatArray]:
    """Per period: the true separation, S, their margin, and the arm's approach speed.

    Computed from the recorded joint path and the person's script, independently of the
    filter's rows: for every link and body part the closest points of the two axes
    (:func:`~velfence.geometry.closest_points_segments`), the surface distance ``d``, the link
    point's approach speed ``v_r`` (the same material point one period later, from the recorded
    joint path), the body part's directed speed ``v_h = max(0, n·v)``, and
    ``S = separation_distance(v_r, human_speed=v_h)``. Every fifth period is evaluated, and
    every period within five of one whose margin is below 0.3 m; the others are NaN. Pairs more
    than 1.5 m apart are left out (their margin is above 0.9 m).

    Returns:
        ``t``, ``separation`` (least ``d``), ``S`` (of that pair), ``margin`` (least ``d − S``
        over the pairs), ``approach`` (the largest ``v_r`` over the pairs), ``inside`` (the
        largest ``v_r`` of the pairs within ``S`` at rest, NaN when none is) and ``speed`` (the
        largest link-point speed), each shape (N,).
    """
    from velfence.filter.separation import separation_distance
    from velfence.geometry.primitives import closest_points_segments

    t, Q = run.trajectory.t, run.trajectory.p
    n = len(t)
    segs = np.array([np.asarray(robot.link_segments(q), dtype=float) for q in Q])  # (N, L, 2, 3)
    radius = np.asarray(robot.link_radius, dtype=float)
    half = 0.5 * np.linalg.norm(segs[:, :, 1] - segs[:, :, 0], axis=2)  # (N, L)
    mid = 0.5 * (segs[:, :, 0] + segs[:, :, 1])
    out = {k: np.full(n, np.nan) for k in ("separation", "S", "margin", "approach", "inside")}

    def evaluate(k: int) -> None:
        sep = margin = math.inf
        S_sep = approach = 0.0
        inside = -math.inf
        nxt = segs[min(k + 1, n - 1)]
        h = float(t[min(k + 1, n - 1)] - t[k]) or 1.0
        for part in path.capsules(float(t[k])):
            pa, pb = np.asarray(part.a), np.asarray(part.b)
            vel = np.asarray(part.velocity)
            reach = 0.5 * float(np.linalg.norm(pb - pa))
            gaps = np.linalg.norm(mid[k] - 0.5 * (pa + pb), axis=1) - half[k] - reach
            for i in np.flatnonzero(gaps < 1.5):
                a, b = segs[k, i]
                x, y, s, _ = closest_points_segments(a, b, pa, pb)
                dist = float(np.linalg.norm(x - y))
                if dist < 1e-12:
                    continue
                nrm = (x - y) / dist
                d = dist - radius[i] - part.radius
                x1 = nxt[i, 0] + s * (nxt[i, 1] - nxt[i, 0])
                vr = float(-(nrm @ (x1 - x)) / h)
                vh = max(0.0, float(nrm @ vel))
                S = separation_distance(vr, parameters=PARAMETERS, human_speed=vh)
                approach = max(approach, vr)
                margin = min(margin, d - S)
                if d <= separation_distance(0.0, parameters=PARAMETERS, human_speed=vh):
                    inside = max(inside, vr)
                if d < sep:
                    sep, S_sep = d, S
        if math.isfinite(sep):
            out["separation"][k], out["S"][k] = sep, S_sep
            out["margin"][k], out["approach"][k] = margin, approach
            out["inside"][k] = inside if math.isfinite(inside) else np.nan

    coarse = range(0, n, 5)
    for k in coarse:
        evaluate(k)
    close = [k for k in coarse if out["margin"][k] < 0.3]
    for k in sorted({j for c in close for j in range(max(c - 5, 0), min(c + 6, n))}):
        if not np.isfinite(out["margin"][k]):
            evaluate(k)
    speed = np.zeros(n)
    if n > 1:
        step = np.linalg.norm(np.diff(segs, axis=0), axis=3).max(axis=(1, 2)) / np.diff(t)
        speed[:-1] = step
        speed[-1] = step[-1]
    return {"t": t, **out, "speed": speed}


def _cloud_clearance(run: PhysicsRun, robot: Any) -> float:
    """The least distance from the links' surfaces to the latest depth frame's person points."""
    from velfence.geometry.primitives import points_segments_distances

    frames = run.extra["frames"]
    stamps = np.array([f[0] for f in frames])
    radius = np.asarray(robot.link_radius, dtype=float)
    best = math.inf
    for k, (t, q) in enumerate(zip(run.trajectory.t, run.trajectory.p, strict=True)):
        j = int(np.searchsorted(stamps, t + 1e-9) - 1)
        pts = frames[max(j, 0)][1]
        if len(pts) == 0 or k % 2:
            continue
        segs = np.asarray(robot.link_segments(q), dtype=float)
        _, clear = points_segments_distances(pts, segs[:, 0], segs[:, 1], radii=radius)
        best = min(best, float(clear.min()))
    return best


def _metrics(run: PhysicsRun, robot: Any, path: PersonPath) -> dict[str, float]:
    series = separation_series(run, robot, path)
    run.extra.update(series)
    run.extra["evaluated"] = np.isfinite(series["margin"])
    # Drawn as lines: a period left out between evaluated ones (at most 5 periods from one) is
    # interpolated; pairs more than 1.5 m apart stay NaN (not drawn); the margin figure shows
    # margins up to SHOWN_MARGIN.
    near = np.convolve(np.isfinite(series["margin"]), np.ones(11), mode="same") > 0
    for key in ("separation", "S", "margin"):
        y = series[key]
        ok = np.isfinite(y)
        if ok.any():
            y = np.where(near, np.interp(series["t"], series["t"][ok], y[ok]), np.nan)
        run.extra[key] = np.minimum(y, SHOWN_MARGIN) if key == "margin" else y
    t = series["t"]
    m = path.times
    tcp_speed = np.zeros(len(t))
    tcp_speed[:-1] = np.linalg.norm(np.diff(run.point, axis=0), axis=1) / np.diff(t)
    run.extra["tcp_speed"] = tcp_speed
    near = (t >= m["reached"]) & (t <= m["withdraw"])
    reached = np.array(run.extra["reached"])
    before = int(np.count_nonzero(reached < m["walk in"]))
    after = reached[reached > m["gone"]]
    lag = 1.0 / BANDWIDTH
    bound = lag * float(np.nanmax(series["approach"]))
    out = {
        "min_separation_margin": float(np.nanmin(series["margin"])),
        "lag_bound": bound,
        "min_separation": float(np.nanmin(series["separation"])),
        "min_cloud_clearance": _cloud_clearance(run, robot),
        "slowest_near": float(tcp_speed[near].min()) if near.any() else math.nan,
        "approach_inside": float(np.nanmax(series["inside"]))
        if np.isfinite(series["inside"]).any()
        else 0.0,
        "periods_inside": float(np.count_nonzero(np.isfinite(series["inside"]))),
        "waypoints_before": float(before),
        "waypoints_after": float(len(after)),
        "resume_delay": float(after[0] - m["gone"]) if len(after) else math.inf,
    }
    if "mode" in run.extra:
        out.update(_mode_metrics(run, path, series["speed"]))
    return out


#: How long after a switch the servo may still be faster than the new mode's caps [s]: four
#: time constants of the servo's lag (the excess speed has fallen to e⁻⁴, under 2 %).
MODE_GRACE = 4.0 / BANDWIDTH


def mode_series(run: PhysicsRun) -> list[str]:
    """The mode of every recorded period of a run with the mode rows (its value, ``"normal"``)."""
    t = run.trajectory.t
    log = run.extra["mode"]
    stamps = np.arange(len(log)) * DT
    k = np.clip(np.searchsorted(stamps, np.asarray(t) + 1e-9) - 1, 0, len(log) - 1)
    return [log[int(j)] for j in k]


def _mode_metrics(run: PhysicsRun, path: PersonPath, speed: FloatArray) -> dict[str, float]:
    """Time in each mode, the switches, and the speeds each mode held (from the recorded path)."""
    t = np.asarray(run.trajectory.t)
    mode = np.array(mode_series(run))
    run.extra["mode_per_period"] = mode
    events = run.extra["mode_events"]
    # Since the last switch into the period's mode: the servo's grace applies after it.
    since = np.full(len(t), -math.inf)
    for e in events:
        since[t >= e.time - 1e-9] = e.time
    settled = t - since >= MODE_GRACE
    tcp = run.extra["tcp_speed"]
    red = (mode == SafetyMode.REDUCED.value) & settled
    stop = (mode == SafetyMode.STOP.value) & settled
    entered = [float(x) for x in t if in_reduced_zone(path.pose(float(x))[0]) <= 0.0]
    first = events[0] if events else None
    ok_first = first is not None and (first.previous, first.mode) == (
        SafetyMode.NORMAL,
        SafetyMode.REDUCED,
    )
    delay = first.time - entered[0] if ok_first and entered and first is not None else math.inf
    last = events[-1] if events else None
    normal_end = (
        float(t[-1] - last.time) if last is not None and last.mode is SafetyMode.NORMAL else 0.0
    )
    reached = np.array(run.extra["reached"])
    after = reached[reached > last.time] if last is not None and normal_end > 0.0 else []
    return {
        "time_normal": float(np.count_nonzero(mode == "normal")) * DT,
        "time_reduced": float(np.count_nonzero(mode == "reduced")) * DT,
        "time_stop": float(np.count_nonzero(mode == "stop")) * DT,
        "mode_switches": float(run.extra["mode_switches"]),
        "reduced_delay": float(delay),
        "fastest_reduced": float(tcp[red].max()) if red.any() else 0.0,
        "fastest_stop": float(speed[stop].max()) if stop.any() else math.inf,
        "normal_at_end": normal_end,
        "waypoints_after_normal": float(len(after)),
    }


#: At most this many mode switches in a run: one visit of the person enters and leaves the
#: Reduced zone once (Normal→Reduced, Reduced→Normal) and brings the hand near the TCP at most
#: once (→Stop, Stop→Reduced); more would be chatter.
MAX_SWITCHES = 4
#: The arm at rest while Stop holds: its fastest link point [m/s] (finite differences of the
#: recorded path; the servo holds a zero command to well under this).
STOP_SPEED = 0.005


def _report(metrics: dict[str, dict[str, float]], *, latency: float = 0.0) -> Report:
    src = "scenario: a person walks into the fence-box cell, MuJoCo"
    checks: list[Check] = []
    m = "safety-filter-people"
    if m in metrics and "mode_switches" in metrics[m]:
        v = metrics[m]
        cap = REDUCED_LIMITS.point_speeds["tcp"]
        checks += [
            check_at_most(
                f"{method_label(m)}: Normal→Reduced after the person enters the zone [s]",
                src,
                DT + latency,
                v["reduced_delay"],
                "the first switch is Normal→Reduced, within a control period of the entry "
                "(plus the tracker's latency)",
            ),
            check_at_most(
                f"{method_label(m)}: mode switches",
                src,
                float(MAX_SWITCHES),
                v["mode_switches"],
                "no chatter: one visit enters and leaves each trigger once",
            ),
            check_at_most(
                f"{method_label(m)}: fastest TCP while Reduced [m/s]",
                src,
                cap,
                v["fastest_reduced"],
                f"the Reduced cap, from {MODE_GRACE:g} s after the switch (the servo lag)",
            ),
            check_at_most(
                f"{method_label(m)}: fastest link point while Stop holds [m/s]",
                src,
                STOP_SPEED,
                v["fastest_stop"],
                f"at rest, from {MODE_GRACE:g} s after the switch (the servo lag)",
            ),
            check_at_least(
                f"{method_label(m)}: waypoints reached in Normal after the person left",
                src,
                1.0,
                v["waypoints_after_normal"],
                "back to Normal at the end, and the task resumes",
            ),
        ]
    if m in metrics:
        v = metrics[m]
        checks += [
            check_at_least(
                f"{method_label(m)}: least separation minus S [m]",
                src,
                -v["lag_bound"],
                v["min_separation_margin"],
                "the servo lag bound T·max v_r (docs/physics.md)",
            ),
            check_at_least(
                f"{method_label(m)}: least clearance to the depth points [m]",
                src,
                0.0,
                v["min_cloud_clearance"],
            ),
            check_at_most(
                f"{method_label(m)}: slowest TCP speed while the hand is held out [m/s]",
                src,
                0.5 * TASK_SPEED,
                v["slowest_near"],
                "the arm slows down beside the hand",
            ),
            check_at_most(
                f"{method_label(m)}: fastest link approach within S at rest [m/s]",
                src,
                1e-3,
                v["approach_inside"],
                "no link approaches a body part closer than S(0) (0 when none is that close)",
            ),
            check_at_least(
                f"{method_label(m)}: waypoints reached after the person left",
                src,
                1.0,
                v["waypoints_after"],
                "the task resumes",
            ),
        ]
    m = "safety-filter-no-people"
    if m in metrics:
        checks.append(
            check_at_most(
                "without the people rows the arm comes within S [m] (stated failure)",
                src,
                0.0,
                metrics[m]["min_separation_margin"],
            )
        )
    return Report("sim person-cell", tuple(checks))


def plot_separation(result: ScenarioResult, path: Any) -> Any:
    """Separation against S over time, the arm's speed with the safety mode, the active rows.

    Args:
        result: The scenario's result.
        path: The PNG to write.

    Returns:
        The path.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from velfence.apps.scenarios.output import COLORS

    fig, (ax1, ax2, ax3) = plt.subplots(
        3, 1, figsize=(13, 8.5), sharex=True, gridspec_kw={"height_ratios": [3, 2, 1.4]},
        layout="constrained",
    )  # fmt: skip
    events = result.scene.get("events", {})
    for i, (name, r) in enumerate(result.runs.items()):
        c = COLORS.get(name, f"C{i}")
        t = r.extra["t"]
        lbl = method_label(name)
        ax1.plot(t, r.extra["separation"], color=c, lw=2.0 - 0.6 * i, label=f"separation, {lbl}")
        ax1.plot(t, r.extra["S"], color=c, ls=":", lw=1.4, label=f"S of that pair, {lbl}")
        ax2.plot(t, r.extra["tcp_speed"], color=c, lw=1.6 - 0.4 * i, label=f"TCP speed, {lbl}")
    ax1.axhline(0.0, color="k", lw=0.8, label="contact (separation 0)")
    script = "person: " + ", ".join(events) + " (in order)"
    for k, when in enumerate(events.values()):
        for ax in (ax1, ax2, ax3):
            first = ax is ax1 and k == 0
            ax.axvline(when, color="0.5", lw=0.7, ls="--", label=script if first else None)
    ax1.set_ylim(bottom=-0.05)
    ax1.set_ylabel("distance [m]")
    ax1.set_title("person-cell: least arm–person separation and its S (pairs within 1.5 m)")
    ax2.set_ylabel("TCP speed [m/s]")
    people = result.runs.get("safety-filter-people")
    if people is not None and "mode_per_period" in people.extra:
        mode = np.asarray(people.extra["mode_per_period"])
        for value, color in (("reduced", "gold"), ("stop", "red")):
            ax2.fill_between(
                people.trajectory.t, 0.0, 1.0, where=mode == value, step="post", color=color,
                alpha=0.18, transform=ax2.get_xaxis_transform(),
                label=f"mode {value} ({method_label('safety-filter-people')})",
            )  # fmt: skip
        ax2.axhline(
            REDUCED_LIMITS.point_speeds["tcp"], color="darkgoldenrod", lw=1.0, ls="-.",
            label="Reduced TCP cap",
        )  # fmt: skip
    kinds = ("separation", "point cloud", "workspace", "joint", "mode")
    if people is not None:
        t = people.trajectory.t
        for j, kind in enumerate(kinds):
            # The mode rows' names start "mode ..." and may name a joint: they count as "mode".
            on = np.array(
                [
                    any(kind in a and (kind == "mode") == a.startswith("mode ") for a in act)
                    for act in people.extra["active"]
                ]
            )
            ax3.fill_between(
                t, j - 0.4, j + 0.4, where=on, step="post", color=f"C{j}", label=f"{kind} rows"
            )
        ax3.set_yticks(range(len(kinds)), [f"{k}" for k in kinds])
    ax3.set_ylabel("active rows\n(people run) [kind]")
    ax3.set_xlabel("time [s]")
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
    handles, labels = [], []
    for ax in (ax1, ax2, ax3):
        h, lab = ax.get_legend_handles_labels()
        handles += h
        labels += lab
    fig.legend(handles, labels, loc="outside right upper", fontsize=8)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
