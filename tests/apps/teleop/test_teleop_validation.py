"""Every public teleop input goes through velfence._validate: library errors naming the argument,
and every duration or count bounded before any work (no hang, no OverflowError)."""

from __future__ import annotations

import datetime
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from bad_inputs import HugeLen, RaisingArray
from velfence.apps.teleop import (
    Cylinder,
    Disk,
    FirstOrderServo,
    LaserRangeSensor,
    LaserStream,
    ModeManager,
    OperatorProfile,
    PDGravityServo,
    Scene,
    Session,
    SyntheticOperator,
    VoltageModel,
    angle_axis,
    damping,
    execute,
    moving_average,
    pick_and_place_scene,
    plane_from_points,
    rotation_from_angle_axis,
    run_task,
    scene_to_dicts,
    straight_line,
)
from velfence.apps.teleop.session import omni_to_puma, ready_pose
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError

BAD_SCALARS: list[Any] = [
    "12",
    b"12",
    {"a": 1},
    True,
    1j,
    datetime.datetime(2020, 1, 1),
    math.nan,
    math.inf,
    -math.inf,
    1e308,
    10**400,
    np.zeros(2),
]
BAD_VECTORS: list[Any] = [
    "12",
    b"12",
    {"a": 1},
    None,
    True,
    np.array([1j, 1j, 1j]),
    np.array(["a", 1, 2], dtype=object),
    datetime.datetime(2020, 1, 1),
    [[1.0, 2.0], [3.0]],
    np.zeros(0),
    [math.nan, 0.0, 0.0],
    [10**400, 0.0, 0.0],
    np.zeros((2, 2, 2)),
]

SCENE = pick_and_place_scene()
Q_READY, T_READY = ready_pose()
SENSOR = LaserRangeSensor()


def _pd() -> PDGravityServo:
    s = PDGravityServo(kp=100.0, inertia=1.0)
    s.reset([0.0, 0.0])
    return s


def _engaged() -> ModeManager:
    m = ModeManager()
    m.press("C", t=0.0, pose=T_READY, distance=None)
    return m


def _RAYCAST(x: Any) -> object:
    return SCENE.raycast((0.2, 0.58, 0.0), (0, 0, -1), max_range=x)


SCALAR_CALLS: list[tuple[str, Callable[[Any], object]]] = [
    ("slope_cm_per_v", lambda x: VoltageModel(slope_cm_per_v=x)),
    ("voltage_v", lambda x: VoltageModel().distance_m(x)),
    ("distance", lambda x: SENSOR.laser_point(T_READY, x)),
    ("true_distance", lambda x: SENSOR.sample_many(x, 3, np.random.default_rng(0))),
    ("t", lambda x: LaserStream(SENSOR).poll(x, T_READY, SCENE)),
    ("t0", lambda x: LaserStream(SENSOR, t0=x)),
    ("sample_rate", lambda x: LaserRangeSensor(sample_rate=x)),
    ("max_range", lambda x: LaserRangeSensor(max_range=x)),
    ("tol", lambda x: plane_from_points([0, 0, 0], [1, 0, 0], [0, 1, 0], tol=x)),
    ("radius", lambda x: Disk((0, 0, 0), (0, 0, 1), radius=x)),
    ("height", lambda x: Cylinder((0, 0, 0), radius=0.1, height=x)),
    ("max_range", _RAYCAST),
    ("dt", lambda x: _pd().step([0.1, 0.1], x)),
    ("angle", lambda x: rotation_from_angle_axis([0, 0, 1], x)),
    ("w", lambda x: damping(x)),
    ("t", lambda x: _engaged().control(t=x, pose=T_READY, linear=(0, 0, 0), angular=(0, 0, 0))),
    ("t", lambda x: ModeManager().press("C", t=x, pose=T_READY, distance=None)),
    ("distance", lambda x: ModeManager().press("A", t=0.0, pose=T_READY, distance=x)),
    ("tick", lambda x: SyntheticOperator(tick=x)),
    ("reaction", lambda x: OperatorProfile(reaction=x)),
    ("dt", lambda x: Session().advance(x)),
    ("time_limit", lambda x: run_task("unassisted", time_limit=x)),
    ("trace_rate", lambda x: run_task("unassisted", time_limit=0.05, trace_rate=x)),
    ("snapshot_rate", lambda x: run_task("unassisted", time_limit=0.05, snapshot_rate=x)),
]


@pytest.mark.parametrize("bad", BAD_SCALARS, ids=repr)
@pytest.mark.parametrize(("name", "call"), SCALAR_CALLS, ids=[n for n, _ in SCALAR_CALLS])
def test_bad_scalars_raise_library_errors_naming_the_argument(
    name: str, call: Callable[[Any], object], bad: Any
) -> None:
    if call is _RAYCAST and bad is math.inf:
        pytest.skip("raycast documents max_range=math.inf")
    if name == "w" and isinstance(bad, float) and bad == 1e308:
        pytest.skip("a huge manipulability is valid (no damping)")
    with pytest.raises(VelfenceError, match=rf"^{name}\b"):
        call(bad)


VECTOR_CALLS: list[tuple[str, Callable[[Any], object]]] = [
    ("origin", lambda x: SCENE.raycast(x, (0, 0, -1))),
    ("direction", lambda x: SCENE["cup"].intersect((0.2, 0.58, 0.0), x)),
    ("p", lambda x: SCENE.nearest(x)),
    ("p1", lambda x: plane_from_points(x, [1, 0, 0], [0, 1, 0])),
    ("center", lambda x: Disk(x, (0, 0, 1), radius=0.1)),
    ("v", omni_to_puma),
    ("axis", lambda x: rotation_from_angle_axis(x, 0.1)),
    ("linear", lambda x: _engaged().control(t=0.0, pose=T_READY, linear=x, angular=(0, 0, 0))),
    ("workspace", lambda x: SyntheticOperator(workspace=x)),
    ("q0", lambda x: FirstOrderServo(time_constant=0.01).reset(x)),
]


@pytest.mark.parametrize("bad", BAD_VECTORS, ids=repr)
@pytest.mark.parametrize(("name", "call"), VECTOR_CALLS, ids=[n for n, _ in VECTOR_CALLS])
def test_bad_vectors_raise_library_errors_naming_the_argument(
    name: str, call: Callable[[Any], object], bad: Any
) -> None:
    with pytest.raises(VelfenceError, match=rf"^{name}\b"):
        call(bad)


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (
            lambda: LaserStream(SENSOR).poll(1e308, T_READY, SCENE),
            InvalidInput,
            r"^t: .*<= 1e\+150",
        ),
        (lambda: LaserStream(SENSOR).poll(1e7, T_READY, SCENE), InvalidInput, r"^t: .* at most"),
        (lambda: _pd().step([0.1, 0.1], 1e308), InvalidInput, r"^dt"),
        (lambda: _pd().step([0.1, 0.1], 1e3), InvalidInput, r"^dt=.* steps; at most"),
        (lambda: Session().advance(1e308), InvalidInput, r"^dt"),
        (lambda: Session().advance(1e5), InvalidInput, r"^dt=.* steps; at most"),
        (lambda: run_task("unassisted", time_limit=1e308), InvalidParameter, r"^time_limit"),
        (lambda: run_task("unassisted", time_limit=1e9), InvalidParameter, r"^time_limit="),
        (lambda: run_task("unassisted", tick=5e-324), InvalidParameter, r"^time_limit="),
        (
            lambda: execute(
                straight_line(T_READY, T_READY), SENSOR_ROBOT, Q_READY, substeps=10**30
            ),
            InvalidParameter,
            r"^substeps: expected an int <=",
        ),
        (
            lambda: execute(straight_line(T_READY, T_READY), SENSOR_ROBOT, Q_READY, settle=10**30),
            InvalidParameter,
            r"^settle: expected an int <=",
        ),
        (
            lambda: straight_line(T_READY, _moved(1.0), spacing=1e-308),
            InvalidParameter,
            r"^spacing",
        ),
        (lambda: straight_line(T_READY, T_READY, rate=5e-324), InvalidParameter, r"^rate"),
        (lambda: list(SyntheticOperator().wait(1e308)), VelfenceError, r"^duration"),
        (
            lambda: SENSOR.sample_many(0.5, 10**30, np.random.default_rng(0)),
            InvalidInput,
            r"^n: expected an int <=",
        ),
    ],
)
def test_durations_and_counts_are_bounded_before_any_work(
    call: Callable[[], object], error: type[Exception], match: str
) -> None:
    with pytest.raises(error, match=match):
        call()


def _moved(dx: float) -> np.ndarray:
    T = np.array(T_READY)
    T[0, 3] += dx
    return T


SENSOR_ROBOT = Session().robot


def test_wrong_objects_are_refused_with_the_argument_named() -> None:
    with pytest.raises(InvalidParameter, match=r"^rng: expected a numpy.random.Generator"):
        SENSOR.sample(0.5, 0)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^scene: expected a Scene"):
        SENSOR.true_range(T_READY, "table")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^with_offset: expected True"):
        SENSOR.target_transform(T_READY, 0.5, with_offset="yes")  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"^true_distances\[1\]: expected"):
        LaserStream(SENSOR).run([0.5, "far"])  # type: ignore[list-item]
    with pytest.raises(InvalidInput, match=r"^true_distances: expected a sequence"):
        LaserStream(SENSOR).run(0.5)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^robot: expected a Puma560"):
        Session(robot=object())  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^modes: expected a ModeManager"):
        Session(modes="auto")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^servo: expected a JointServo"):
        Session(servo=3)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^servo: expected a JointServo"):
        execute(straight_line(T_READY, T_READY), SENSOR_ROBOT, Q_READY, servo=3)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^fixture_options: expected a mapping"):
        ModeManager(fixture_options=[1, 2])  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^toggle_off: expected True or False"):
        ModeManager(toggle_off="no")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^rainbow: expected True or False"):
        OperatorProfile(rainbow="yes")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^rng: expected a numpy.random.Generator"):
        OperatorProfile.draw(0)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^profile: expected an OperatorProfile"):
        run_task("assisted", {"reaction": 0.3})  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^subject: expected an int >= 0"):
        run_task("assisted", subject="A")  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"^dynamic: expected names"):
        scene_to_dicts(SCENE, dynamic=5)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match=r"^name: expected one of"):
        SCENE[{"cup": 1}]  # type: ignore[index]
    with pytest.raises(InvalidParameter, match=r"^window: expected a positive int"):
        moving_average([1.0, 2.0], window=True)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^time_constant: expected"):
        FirstOrderServo(time_constant=[[0.1], [0.1, 0.2]])
    with pytest.raises(InvalidInput, match=r"^R: expected"):
        angle_axis([[1j, 0, 0], [0, 1, 0], [0, 0, 1]])
    assert isinstance(Scene({"cup": SCENE["cup"]}), Scene)


@pytest.mark.parametrize(
    "make",
    [
        lambda: Disk((0, 0, 0), (0, 0, 1), 0.1),  # type: ignore[misc]
        lambda: Cylinder((0, 0, 0), 0.1, 0.2),  # type: ignore[misc]
        lambda: VoltageModel(126.0, -100.0),  # type: ignore[misc]
        lambda: ModeManager(SENSOR),  # type: ignore[misc]
        lambda: SyntheticOperator(OperatorProfile()),  # type: ignore[misc]
        lambda: OperatorProfile(0.3),  # type: ignore[misc]
    ],
)
def test_tuning_parameters_are_keyword_only(make: Callable[[], object]) -> None:
    with pytest.raises(TypeError, match="positional"):
        make()


# --- wave 2: behaviours validate when called; misbehaving array-likes; seeds and counts ---------


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda op: op.wait("0.1"), r"duration .*must be a number"),
        (lambda op: op.wait(1e100), r"duration=1e\+100 s with tick=0.02 s needs"),
        (lambda op: op.wait_until("yes"), r"predicate: expected a function, got str"),
        (lambda op: op.wait_until(lambda o: True, limit=0.0), r"limit must be finite and > 0"),
        (
            lambda op: op.stroke([0.01, 0.0], tol=0.001),
            r"d: expected shape \(3,\), got shape \(2,\)",
        ),
        (lambda op: op.stroke([1e3, 0.0, 0.0], tol=0.001), r"d: expected a displacement .*<= 100"),
        (lambda op: op.stroke([0.01, 0.0, 0.0], tol=0.0), r"tol must be finite and > 0"),
        (lambda op: op.index([0.0, 0.0, 0.0]), r"hand_d: expected a non-zero displacement"),
        (lambda op: op.turn([0.0, 0.0, 0.1], peak=0.3, a=-1.0, b=0.3, tol=0.01), r"a must be"),
        (
            lambda op: op.turn([0.0, 0.0, 0.1], peak=5e-324, a=0.4, b=0.3, tol=0.01),
            r"peak, a, b: a turn by 0.1 rad",
        ),
        (lambda op: op.reach(np.zeros(3), tol=0.01), r"target: expected a function, got ndarray"),
        (
            lambda op: op.reach(lambda o: np.zeros(3), tol=0.01, point="toe"),
            r"point: expected one of",
        ),
        (
            lambda op: op.reach(lambda o: np.zeros(3), tol=0.01, max_strokes=10**9),
            r"max_strokes: expected an int <= 10,000",
        ),
        (
            lambda op: op.orient(lambda o: np.eye(3), tol=0.05, error=float),
            r"error: expected a func",
        ),
        (
            lambda op: op.aim(RaisingArray(), tol=0.01),
            r"target: expected a point \[m\] of shape \(3,\), got <",
        ),
        (lambda op: op.vertical(float("nan")), r"tol must be finite"),
        (lambda op: op.press("q"), r"keys: expected keys among"),
        (lambda op: op.record("A", 3), r"keys: expected keys among .* got int"),
        (lambda op: op.start("plan"), r"plan: expected a function, got str"),
        (lambda op: op.start(lambda o: 3), r"plan: expected a function returning a behaviour"),
        (lambda op: op.act({"clutch": True}), r"obs: expected an Observation"),
    ],
)
def test_operator_behaviours_refuse_bad_arguments_when_called(
    call: Callable[[SyntheticOperator], Any], message: str
) -> None:
    # the error comes from the call itself, not many ticks later when a plan advances it
    with pytest.raises(VelfenceError, match=message):
        call(SyntheticOperator(seed=0))


def test_operator_callbacks_are_checked_while_running() -> None:
    session = Session()
    op = SyntheticOperator(seed=0)
    op.start(lambda o: o.wait_until(lambda obs: "yes"))  # type: ignore[arg-type, return-value]
    with pytest.raises(InvalidInput, match=r"predicate: expected a function returning True"):
        op.act(session.observe())
    op.start(lambda o: o.reach(lambda obs: "here", tol=0.01))  # type: ignore[arg-type, return-value]
    obs = session.observe()

    def run() -> None:
        for _ in range(100):  # the reaction pause, then the first look at the target
            op.act(obs)

    with pytest.raises(InvalidInput, match=r"target: expected a position"):
        run()


def test_operator_plans_run_after_eager_validation() -> None:
    op = SyntheticOperator(seed=0)
    op.start(lambda o: o.wait(0.0))
    session = Session()
    op.act(session.observe())
    assert op.act(session.observe()).keys == ()
    assert op.finished


@pytest.mark.parametrize("bad", [RaisingArray(), HugeLen(), np.array([np.longdouble("1e4000")])])
def test_misbehaving_array_likes_are_refused_by_name(bad: Any) -> None:
    with _no_warning(), pytest.raises(InvalidInput, match=r"^p: expected"):
        Scene({"floor": Cylinder((0, 0, 0), radius=0.1, height=0.1)}).nearest(bad)


class _no_warning:  # noqa: N801 (used like a function)
    def __enter__(self) -> None:
        import warnings

        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()
        warnings.simplefilter("error")

    def __exit__(self, *exc: object) -> None:
        self._ctx.__exit__(*exc)


@pytest.mark.parametrize("seed", [np.timedelta64(1, "s"), 10**400, -1, 2.0, True, "3"], ids=repr)
def test_seeds_are_ints_in_the_numpy_range(seed: Any) -> None:
    with pytest.raises(InvalidParameter, match=r"seed: expected an int in \[0, 2\*\*63 - 1\]"):
        Session(seed=seed)
    with pytest.raises(InvalidParameter, match=r"seed: expected an int in \[0, 2\*\*63 - 1\] or"):
        LaserRangeSensor().stream(seed=seed)


def test_counts_refuse_time_deltas() -> None:
    with pytest.raises(InvalidParameter, match=r"window: expected a positive int, got"):
        moving_average([1.0, 2.0, 3.0], window=np.timedelta64(2, "s"))  # type: ignore[arg-type]


def test_laser_stream_run_is_bounded_and_not_empty() -> None:
    stream = LaserRangeSensor().stream(seed=0)
    with pytest.raises(InvalidInput, match=r"true_distances: expected 1 to 100,000 distances"):
        stream.run([])
    with pytest.raises(InvalidInput, match=r"true_distances: expected 1 to 100,000 distances"):
        stream.run(np.zeros(1_000_000))


def test_mode_manager_refuses_readings_beyond_the_laser_range() -> None:
    pose = Session().observe().pose
    with pytest.raises(InvalidInput, match=r"distance: expected a reading in \[0, 5.3\] m"):
        ModeManager().press("A", t=0.0, pose=pose, distance=1e30)
