r"""The pick-and-place task of Khokar 2009 §7.2 (Figs. 72-75), run by a synthetic operator.

Start from the ready pose, go to the cup, grasp it, lift it clear of the folder and place it on the
cross of the orange sticky note (thesis §4.4). Two conditions, as in the thesis:

* **unassisted** (§6.1): everything by teleoperation — reach above the cup, orient the hand for a
  grasp from the top, descend, grasp, lift to a self-judged height (folder top plus the subject's
  ``lift_margin``), carry the cup over the folder on an inverted U or an arc ("rainbow", the
  subject's choice, §7.2), lower it onto the mark and release;
* **assisted** (laser-assisted traded control, §6.5): 'D' on the destination; three table points
  counter-clockwise, 'P' twice each; 'A' on the cup (autonomous approach to the 20 cm stand-off);
  'T' 'A' (autonomous alignment with the table normal) and 'T' 'A' to switch it off; minimal
  teleoperation and grasp; 'G' 'A' for each of the three legs (up 0.3 m, across, down to
  0.35 m above the mark), each followed by 'G' 'A' to switch the path mode off; minimal
  teleoperation and release.

:func:`run_task` drives a :class:`~velfence.apps.teleop.session.Session` with a
:class:`~velfence.apps.teleop.operator.SyntheticOperator` and returns a :class:`TaskRun` with the
measures of §7.2: task time, the end-effector (wrist-centre, frame 6) path, plus the counts a
simulation can add (clutch presses, index events, collisions, strokes).

Path measures (the thesis's Fig. 74 is qualitative: assisted paths "straight line", unassisted
"unsteady", "discontinuous", with "loops" near the pick-up point): ``path_length`` is the
wrist-centre path [m]; the path is cut into *motion segments* at every stop (speed below
5 mm/s for at least 0.15 s); ``segments`` counts them (stop-and-go) and ``straightness`` is
their summed chords over their summed lengths (1 for straight strokes); ``pickup_detour`` is the
wrist path travelled while the fingertips were within 0.15 m of the cup before the grasp, minus
the straight distance across that stretch (the loops).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any, Literal, get_args

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_choice, check_positive, check_positive_int, step_count
from velfence.apps.teleop.modes import ModeEvent, ModeManager
from velfence.apps.teleop.operator import Behaviour, OperatorProfile, SyntheticOperator
from velfence.apps.teleop.scene import Box, Cylinder, Disk, Plane, Scene, pick_and_place_scene
from velfence.apps.teleop.session import Observation, Session
from velfence.errors import InvalidParameter

#: Most operator ticks one run may take (``time_limit / tick``; 5.5 h at the default tick).
MAX_TICKS = 1_000_000

__all__ = [
    "CONDITIONS",
    "TABLE_POINTS",
    "TaskRecord",
    "TaskRun",
    "assisted_plan",
    "run_task",
    "unassisted_plan",
]


Condition = Literal["unassisted", "assisted"]
CONDITIONS: tuple[Condition, ...] = get_args(Condition)
"""The two conditions of §7.2."""

TABLE_POINTS = ((0.30, 0.50), (0.32, 0.68), (0.14, 0.70))
"""Nominal table points (x, y) [m] the operator records with 'P' — counter-clockwise seen from
above (the robot's approach direction), spread around the cup, clear of cup, folder and mark.
Each subject jitters them by up to 2 cm."""

GRASP_DEPTH_AIM = 0.03  # fingertips this far below the rim when grasping [m]
GRASP_ATTEMPTS = 6  # a synthetic subject gives up after this many missed grasps or placements
PICKUP_RADIUS = 0.15  # "near the pick-up point" for the pickup_detour measure [m]
MOVING_SPEED = 0.005  # wrist speed above which the arm counts as moving [m/s]
STOP_TIME = 0.15  # a pause at least this long separates two motion segments [s]


@dataclass(frozen=True)
class _Layout:
    cup: Cylinder
    destination: Disk
    folder: Box
    table: Plane

    @property
    def table_z(self) -> float:
        return float(self.table.point[2])

    @property
    def folder_top(self) -> float:
        return float(self.folder.top[2])


def _layout(scene: Scene) -> _Layout:
    if not all(name in scene for name in ("cup", "destination", "table")):
        raise InvalidParameter(
            f"scene: expected primitives 'cup', 'destination' and 'table', got {list(scene.names)}"
        )
    cup, dest, table = scene["cup"], scene["destination"], scene["table"]
    boxes = [p for _, p in scene.items() if isinstance(p, Box)]
    if not (isinstance(cup, Cylinder) and isinstance(dest, Disk) and isinstance(table, Plane)):
        raise InvalidParameter("scene: expected a Cylinder cup, a Disk destination, a Plane table")
    if not boxes:
        raise InvalidParameter("scene: expected a Box obstacle (the folder)")
    return _Layout(cup=cup, destination=dest, folder=boxes[0], table=table)


# ------------------------------------------------------------------------------------ plans
def _fixed(goal: FloatArray) -> Callable[[Observation], FloatArray]:
    def target(_: Observation) -> FloatArray:
        return goal

    return target


def _holding(op: SyntheticOperator) -> bool:
    """Whether the cup is held now (a call, so type checkers do not narrow across yields)."""
    return op.obs.holding


def _tilt(o: Observation) -> float:
    return math.acos(max(-1.0, min(1.0, -float(o.pose[2, 2]))))


def _grasp(op: SyntheticOperator, lay: _Layout) -> Behaviour:
    """Minimal (or full) teleoperation to a grasp from the top; retries a missed grasp."""
    height = lay.cup.height

    def above(o: Observation) -> FloatArray:
        return np.array([o.cup[0], o.cup[1], o.cup[2] + height + 0.05])

    def at(o: Observation) -> FloatArray:
        return np.array([o.cup[0], o.cup[1], o.cup[2] + height - GRASP_DEPTH_AIM])

    yield from op.reach(above, tol=0.02)
    for _attempt in range(GRASP_ATTEMPTS):
        if _tilt(op.obs) > math.radians(5.0):
            yield from op.vertical(math.radians(5.0))
        yield from op.reach(above, tol=0.01)
        yield from op.reach(at, tol=0.007)
        yield from op.press("H")
        yield from op.wait_until(lambda o: o.hand in ("closed", "open"), limit=5.0)
        yield from op.wait(op.tick)
        if op.obs.holding:
            return
        yield from op.press("H")  # missed: open again, back up and retry
        yield from op.wait_until(lambda o: o.hand == "open", limit=5.0)


def _place(op: SyntheticOperator, lay: _Layout) -> Behaviour:
    """Teleoperate the held cup onto the mark and release it; re-grasp and retry on a miss."""
    c = lay.destination.center
    z = lay.table_z
    for _attempt in range(GRASP_ATTEMPTS):
        if not _holding(op):
            yield from _grasp(op, lay)
            if not _holding(op):
                return
            yield from op.reach(
                lambda o: np.array([o.cup[0], o.cup[1], z + 0.04]), tol=0.01, point="cup"
            )
        yield from op.reach(lambda o: np.array([c[0], c[1], z + 0.04]), tol=0.012, point="cup")
        yield from op.reach(lambda o: np.array([c[0], c[1], z + 0.008]), tol=0.006, point="cup")
        yield from op.press("H")
        yield from op.wait_until(lambda o: o.hand in ("open", "closed"), limit=5.0)
        yield from op.wait(op.tick)
        if op.obs.done:
            return


def unassisted_plan(scene: Scene | None = None) -> Callable[[SyntheticOperator], Behaviour]:
    """The unassisted pick-and-place (§6.1; module docstring) as an operator plan."""
    lay = _layout(pick_and_place_scene() if scene is None else scene)

    def plan(op: SyntheticOperator) -> Behaviour:
        yield from op.wait(op.profile.reaction)
        yield from op.engage()
        yield from _grasp(op, lay)
        if not _holding(op):
            return  # gave up: the run ends not done
        clear = lay.folder_top + op.profile.lift_margin
        src = np.array(op.obs.cup[:2])
        dst = np.array(lay.destination.center[:2])
        mid = np.array(lay.folder.center[:2])
        via = [0.5 * (src + mid), 0.5 * (dst + mid)] if op.profile.rainbow else [src, dst]
        for xy in via:
            goal = np.array([xy[0], xy[1], clear])
            yield from op.reach(_fixed(goal), tol=0.025, point="cup")
        yield from _place(op, lay)

    return plan


def assisted_plan(scene: Scene | None = None) -> Callable[[SyntheticOperator], Behaviour]:
    """The laser-assisted traded-control pick-and-place (§6.5; module docstring)."""
    lay = _layout(pick_and_place_scene() if scene is None else scene)

    def autonomous(op: SyntheticOperator, *keys: str) -> Behaviour:
        yield from op.press(*keys)
        yield from op.wait(op.tick)
        yield from op.wait_until(lambda o: not o.busy, limit=120.0)

    def plan(op: SyntheticOperator) -> Behaviour:
        yield from op.wait(op.profile.reaction)
        yield from op.engage()
        dest = np.array(lay.destination.center)
        yield from op.aim(dest, tol=0.01)
        yield from op.record("D")
        z = lay.table_z
        for x, y in TABLE_POINTS:
            jitter = op.rng.uniform(-0.02, 0.02, 2)
            yield from op.aim(np.array([x + jitter[0], y + jitter[1], z]), tol=0.03)
            yield from op.record("P", "P")
        top = np.array([lay.cup.base_center[0], lay.cup.base_center[1], z + lay.cup.height])
        for _attempt in range(3):
            yield from op.aim(top, tol=0.015)
            yield from op.record("A")
            yield from op.wait(op.tick)
            if op.obs.busy:
                break
        yield from op.wait_until(lambda o: not o.busy, limit=120.0)
        yield from autonomous(op, "T", "A")
        yield from op.press("T", "A")  # switch the alignment mode off
        yield from _grasp(op, lay)
        if not _holding(op):
            return
        for _leg in range(3):
            yield from autonomous(op, "G", "A")
            yield from op.press("G", "A")  # switch the path mode off
        yield from _place(op, lay)

    return plan


# ------------------------------------------------------------------------------------ runs
@dataclass(frozen=True)
class TaskRecord:
    """Measures of one run (module docstring).

    Attributes:
        condition: ``"unassisted"`` or ``"assisted"``.
        subject: Subject index.
        run: Run index within the condition.
        time: Task time [s]: until the cup is placed (or the time limit).
        done: Whether the cup was placed on the mark.
        path_length: Wrist-centre path length [m].
        straightness: Length-weighted straightness of the motion segments (chord / length),
            in (0, 1].
        segments: Motion segments (stop-and-go count).
        pickup_detour: Wrist path near the pick-up point before the grasp, minus the straight
            distance across that stretch [m].
        collisions: Collision events (fingertips or held cup into the folder or the table).
        clutch_presses: Stylus-button presses and releases.
        index_events: Hand re-centrings at the Omni workspace edge.
        keys: Mode-key presses.
        strokes: Translation sub-movements.
        orient_strokes: Orientation sub-movements.
        aim_strokes: Laser-pointing sub-movements.
        autonomous_time: Time the arm moved autonomously [s].
        active_time: Time the operator moved the engaged master [s].
        missed_grasps: Hand closures that missed the cup.
    """

    condition: str
    subject: int
    run: int
    time: float
    done: bool
    path_length: float
    straightness: float
    segments: int
    pickup_detour: float
    collisions: int
    clutch_presses: int
    index_events: int
    keys: int
    strokes: int
    orient_strokes: int
    aim_strokes: int
    autonomous_time: float
    active_time: float
    missed_grasps: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-able fields."""
        return asdict(self)


@dataclass(frozen=True)
class TaskRun:
    """One run: its record, the wrist/fingertip trace, events and optional snapshots.

    Attributes:
        record: The measures.
        trace: Rows ``(t, x, y, z, tip_x, tip_y, tip_z, engaged, autonomous)`` (see
            :attr:`velfence.apps.teleop.session.Session.trace`), decimated to ``trace_rate``.
        events: Mode and hand events.
        snapshots: :meth:`Session.snapshot` dicts at the requested rate (empty if none).
        scene: :meth:`Session.scene_primitives` of the run's scene.
    """

    record: TaskRecord
    trace: FloatArray
    events: tuple[ModeEvent, ...]
    snapshots: tuple[dict[str, Any], ...]
    scene: tuple[dict[str, Any], ...]


def run_task(
    condition: str,
    profile: OperatorProfile | None = None,
    *,
    seed: int = 0,
    subject: int = 0,
    run: int = 0,
    scene: Scene | None = None,
    rate: float = 100.0,
    tick: float = 0.02,
    time_limit: float = 400.0,
    snapshot_rate: float | None = None,
    trace_rate: float = 20.0,
) -> TaskRun:
    """Run the pick-and-place once with a synthetic operator.

    Args:
        condition: ``"unassisted"`` or ``"assisted"``.
        profile: The subject (default the nominal :class:`OperatorProfile`).
        seed: Seed of the run (operator noise and laser noise), int ``>= 0``.
        subject: Subject index (recorded).
        run: Run index (recorded).
        scene: The scene (default :func:`~velfence.apps.teleop.scene.pick_and_place_scene`).
        rate: Session control rate [Hz] (the thesis's 200 Hz; 100 Hz default for speed — the
            autonomous segments keep their speed, the via points are twice as far apart).
        tick: Operator period [s].
        time_limit: Give up after this long [s] (``done`` is then ``False``).
        snapshot_rate: Take :meth:`Session.snapshot` at this rate [Hz] for animations; ``None``
            for none.
        trace_rate: Rate [Hz] of the stored trace (the measures use every control cycle).

    Returns:
        The :class:`TaskRun`.

    Raises:
        InvalidParameter: an unknown condition or bad rates.
    """
    check_choice("condition", condition, CONDITIONS)
    if profile is not None and not isinstance(profile, OperatorProfile):
        raise InvalidParameter(
            f"profile: expected an OperatorProfile or None, got {type(profile).__name__}"
        )
    check_positive_int("seed", seed, minimum=0, example=0)
    check_positive_int("subject", subject, minimum=0, example=0)
    check_positive_int("run", run, minimum=0, example=0)
    if scene is not None and not isinstance(scene, Scene):
        raise InvalidParameter(f"scene: expected a Scene or None, got {type(scene).__name__}")
    step_count("time_limit", time_limit, "tick", tick, max_steps=MAX_TICKS)
    check_positive("trace_rate", trace_rate, unit="Hz")
    if snapshot_rate is not None:
        step_count(
            "time_limit",
            time_limit,
            "1/snapshot_rate",
            1.0 / check_positive("snapshot_rate", snapshot_rate, unit="Hz"),
            max_steps=MAX_TICKS,
        )
    sc = pick_and_place_scene() if scene is None else scene
    rng = np.random.default_rng([int(seed), 1])
    session = Session(
        scene=sc,
        modes=ModeManager(rate=rate),
        rate=rate,
        seed=int(rng.integers(2**31)),
    )
    op = SyntheticOperator(profile=profile, seed=rng, tick=tick)
    op.start(assisted_plan(sc) if condition == "assisted" else unassisted_plan(sc))
    snaps: list[dict[str, Any]] = []
    next_snap = 0.0
    grasp_index: int | None = None
    t_done = math.nan
    while session.t < time_limit:
        if snapshot_rate is not None and session.t + 1e-9 >= next_snap:
            snaps.append(session.snapshot())
            next_snap += 1.0 / snapshot_rate
        obs = session.observe()
        if obs.done:
            t_done = obs.t
            break
        if grasp_index is None and obs.holding:
            grasp_index = len(session.trace) - 1
        if op.finished:
            break
        action = op.act(obs)
        for key in action.keys:
            session.press(key)
        session.jog(action.linear, action.angular)
        session.advance(tick)
    if snapshot_rate is not None:
        snaps.append(session.snapshot())
    tr = session.trace
    record = _record(condition, subject, run, session, op, tr, grasp_index, t_done)
    ratio = session.rate / trace_rate  # inf for a tiny trace_rate: keep first and last rows
    step = tr.shape[0] if not ratio < tr.shape[0] else max(1, round(ratio))
    keep = np.r_[np.arange(0, tr.shape[0], step), tr.shape[0] - 1]
    return TaskRun(
        record=record,
        trace=tr[np.unique(keep)],
        events=session.events,
        snapshots=tuple(snaps),
        scene=tuple(session.scene_primitives()),
    )


def _segments(P: FloatArray, rate: float) -> tuple[int, float]:
    """Motion segments of a sampled path: count and length-weighted straightness.

    A segment is a maximal stretch of motion (speed above :data:`MOVING_SPEED`) not interrupted
    by a stop of at least :data:`STOP_TIME`.
    """
    if P.shape[0] < 2:
        return 0, 1.0
    steps = np.linalg.norm(np.diff(P, axis=0), axis=1)
    moving = steps * rate > MOVING_SPEED
    min_stop = max(1, round(STOP_TIME * rate))
    bounds: list[tuple[int, int]] = []
    start: int | None = None
    still = 0
    for k, m in enumerate(moving):
        if m:
            if start is None:
                start = k
            still = 0
            end = k + 1
        elif start is not None:
            still += 1
            if still >= min_stop:
                bounds.append((start, end))
                start = None
    if start is not None:
        bounds.append((start, end))
    chord = sum(float(np.linalg.norm(P[b] - P[a])) for a, b in bounds)
    length = sum(float(steps[a:b].sum()) for a, b in bounds)
    return len(bounds), (chord / length if length > 0.0 else 1.0)


def _record(
    condition: str,
    subject: int,
    run: int,
    session: Session,
    op: SyntheticOperator,
    tr: FloatArray,
    grasp_index: int | None,
    t_done: float,
) -> TaskRecord:
    P = tr[:, 1:4]
    steps = np.linalg.norm(np.diff(P, axis=0), axis=1)
    length = float(steps.sum())
    n_seg, straight = _segments(P, session.rate)
    g = tr.shape[0] - 1 if grasp_index is None else grasp_index
    cup0 = session.scene["cup"]
    detour = 0.0
    if isinstance(cup0, Cylinder) and g > 0:
        centre = np.array(cup0.base_center) + np.array([0.0, 0.0, cup0.height])
        near = np.linalg.norm(tr[1 : g + 1, 4:7] - centre, axis=1) <= PICKUP_RADIUS
        if near.any():
            enter = int(np.argmax(near))
            detour = float(steps[:g][near].sum()) - float(np.linalg.norm(P[g] - P[enter]))
    auto = float(tr[:, 8].sum()) / session.rate
    done = bool(session.done)
    return TaskRecord(
        condition=condition,
        subject=int(subject),
        run=int(run),
        time=float(t_done) if done else float(session.t),
        done=done,
        path_length=length,
        straightness=min(straight, 1.0),
        segments=n_seg,
        pickup_detour=max(detour, 0.0),
        collisions=session.collisions,
        clutch_presses=op.stats.clutch_presses,
        index_events=op.stats.index_events,
        keys=op.stats.keys,
        strokes=op.stats.strokes,
        orient_strokes=op.stats.orient_strokes,
        aim_strokes=op.stats.aim_strokes,
        autonomous_time=auto,
        active_time=op.stats.active_time,
        missed_grasps=session.missed_grasps,
    )
