"""Bad inputs to the runner, metrics, disturbances and scenarios raise library errors only."""

import datetime
import inspect
import math

import numpy as np
import pytest

import velfence as vf
from bad_inputs import BAD_VECTORS as COMMON_BAD_VECTORS
from velfence.apps.demo.script import default_script
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.sim import Disturbance, NoLimit, Trajectory, metrics, push, scenarios, simulate

SQUARE = vf.ConvexPolygon([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
BAD_VECTORS = {
    **COMMON_BAD_VECTORS,
    "nan": [math.nan, 0.0],
    "inf": [math.inf, 0.0],
}


def _stop(t: float, p: np.ndarray) -> np.ndarray:
    return np.zeros(2)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"duration": 1e308}, "duration"), ({"dt": 5e-324}, "dt"),
     ({"duration": 1e5, "dt": 1e-300}, "duration")],
)  # fmt: skip
def test_simulate_step_count_is_bounded_before_any_work(kwargs: dict[str, float], name: str):
    args = {"duration": 1.0, **kwargs}
    with pytest.raises(InvalidParameter, match=name):
        simulate(NoLimit(), _stop, [0.0, 0.0], **args)


@pytest.mark.parametrize("kind", sorted(BAD_VECTORS))
def test_simulate_p0_names_p0(kind: str):
    with pytest.raises(InvalidInput, match=r"^p0: "):
        simulate(NoLimit(), _stop, BAD_VECTORS[kind], duration=0.01)


@pytest.mark.parametrize("kind", ["str", "bytes", "dict", "ragged", "complex", "nan", "huge-int"])
def test_simulate_bad_command_output_names_the_callable(kind: str):
    bad = BAD_VECTORS[kind]
    with pytest.raises(InvalidInput, match=r"^command\(t, p\): .*step 0"):
        simulate(NoLimit(), lambda t, p: bad, [0.0, 0.0], duration=0.01)


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3", 10**400])
def test_simulate_seed(seed: object):
    with pytest.raises(InvalidParameter, match=r"^seed: "):
        simulate(NoLimit(), _stop, [0.0, 0.0], duration=0.01, seed=seed)  # type: ignore[arg-type]


def test_simulate_state_overflow_is_refused():
    with pytest.raises(InvalidInput, match="state overflowed"):
        simulate(NoLimit(), lambda t, p: np.array([1e150, 0.0]), [1e150, 0.0], duration=1e150,
                 dt=1e149)  # fmt: skip


@pytest.mark.parametrize("field", ["t", "p", "v_cmd", "v_out", "p_measured"])
@pytest.mark.parametrize("kind", ["nan", "inf", "str", "complex", "huge-int"])
def test_trajectory_refuses_non_finite_and_non_numbers(field: str, kind: str):
    z = np.zeros((2, 2))
    args: dict[str, object] = {"t": [0.0, 1.0], "p": z, "v_cmd": z, "v_out": z}
    bad = np.array([[math.nan, 0.0], [0.0, 0.0]]) if kind == "nan" else None
    if kind == "inf":
        bad = np.array([[0.0, math.inf], [0.0, 0.0]])
    if kind == "str":
        bad = "12"
    if kind == "complex":
        bad = np.zeros((2, 2), dtype=complex) + 1j
    if kind == "huge-int":
        bad = [[10**400, 0], [0, 0]]
    if field == "t":
        bad = {"nan": [0.0, math.nan], "inf": [0.0, math.inf]}.get(kind, bad)
        if kind == "huge-int":
            bad = [0, 10**400]
    args[field] = bad
    with pytest.raises(InvalidInput, match=rf"^{field}: "):
        Trajectory(**args)  # type: ignore[arg-type]


def test_trajectory_options_are_keyword_only_and_checked():
    z = np.zeros((2, 2))
    with pytest.raises(TypeError):
        Trajectory([0.0, 1.0], z, z, z, None)  # type: ignore[misc]
    with pytest.raises(InvalidInput, match=r"^zone: "):
        Trajectory(t=[0.0, 1.0], p=z, v_cmd=z, v_out=z, zone=[1.5, 2.5])
    with pytest.raises(InvalidInput, match=r"^name: "):
        Trajectory(t=[0.0, 1.0], p=z, v_cmd=z, v_out=z, name=3)  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", ["0", None, math.nan, 1j, 10**400, datetime.date(2020, 1, 1)])
@pytest.mark.parametrize("arg", ["t0", "t1"])
def test_trajectory_window_names_its_bounds(bad: object, arg: str):
    z = np.zeros((2, 2))
    traj = Trajectory(t=[0.0, 1.0], p=z, v_cmd=z, v_out=z)
    kw = {"t0": 0.0, "t1": 1.0, arg: bad}
    with pytest.raises(InvalidInput, match=rf"^{arg}: "):
        traj.window(**kw)  # type: ignore[arg-type]


@pytest.mark.parametrize("spacing", [5e-324, 1e-300])
def test_max_output_jump_grid_bounded_before_allocation(spacing: float):
    with pytest.raises(InvalidParameter, match=r"spacing .*more than 4000000 points"):
        metrics.max_output_jump(NoLimit(), SQUARE, spacing=spacing, commands=[[1.0, 0.0]])


@pytest.mark.parametrize("kind", ["str", "dict", "ragged", "complex", "nan", "huge-int"])
def test_max_output_jump_commands(kind: str):
    bad = BAD_VECTORS[kind]
    with pytest.raises(InvalidParameter, match=r"^commands: "):
        metrics.max_output_jump(NoLimit(), SQUARE, spacing=0.5, commands=bad)


@pytest.mark.parametrize("index", [True, 1.0, "1", -1, 4, 10**400])
def test_corner_escape_time_index(index: object):
    z = np.zeros((2, 2))
    traj = Trajectory(t=[0.0, 1.0], p=z, v_cmd=z, v_out=z)
    with pytest.raises(InvalidParameter, match=r"^corner_index: "):
        metrics.corner_escape_time(traj, SQUARE, index, radius=0.1)  # type: ignore[arg-type]


@pytest.mark.parametrize("t1", ["12", True, 1j, math.nan, None])
def test_push_end_time(t1: object):
    with pytest.raises(InvalidParameter, match=r"t1"):
        push(0.0, t1, [1.0, 0.0])  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", ["str", "dict", "ragged", "complex", "nan", "huge-int", "bool"])
def test_push_velocity(kind: str):
    with pytest.raises(InvalidParameter, match=r"^velocity: "):
        push(0.0, 1.0, BAD_VECTORS[kind])


@pytest.mark.parametrize(
    "pushes",
    [((0.0, 1.0, "a", 0.0),), ((-1.0, 1.0, 0.0, 0.0),), ((1.0, 0.5, 0.0, 0.0),), ((0.0, 1.0),),
     "push", ((0.0, 1.0, math.nan, 0.0),)],
)  # fmt: skip
def test_disturbance_pushes_validated(pushes: object):
    with pytest.raises(InvalidParameter, match=r"pushes|t1"):
        Disturbance(pushes=pushes)  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        Disturbance(())  # type: ignore[misc]


@pytest.mark.parametrize("t", ["1", None, math.nan, 1j, 10**400])
def test_disturbance_call_time(t: object):
    with pytest.raises(InvalidInput, match=r"^t: "):
        push(0.0, 1.0, [1.0, 0.0])(t, np.zeros(2))  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"t": "0"}, "t"), ({"t": -1.0}, "t"), ({"target": "ab"}, "target"),
     ({"target": (math.nan, 0.0)}, "target"), ({"speed": 0.0}, "speed"), ({"speed": True}, "speed"),
     ({"speed": 1e308}, "speed")],
)  # fmt: skip
def test_waypoint_fields(kwargs: dict[str, object], name: str):
    args = {"t": 0.0, "target": (0.5, 0.5), "speed": 1.0, **kwargs}
    with pytest.raises(InvalidParameter, match=rf"^{name}"):
        scenarios.Waypoint(**args)  # type: ignore[arg-type]


def test_scenario_records_are_keyword_only():
    for cls in (scenarios.Waypoint, scenarios.Script, Disturbance):
        for p in inspect.signature(cls).parameters.values():
            assert p.kind is inspect.Parameter.KEYWORD_ONLY, (cls.__name__, p.name)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"start": "ab"}, "start"), ({"waypoints": ((0.0, (1.0, 1.0), 1.0),)}, "waypoints"),
     ({"pushes": ((0.0, 1.0, "ab"),)}, "pushes"), ({"duration": math.inf}, "duration"),
     ({"labels": (1, 2)}, "labels")],
)  # fmt: skip
def test_script_fields(kwargs: dict[str, object], name: str):
    wp = scenarios.Waypoint(t=0.0, target=(0.5, 0.5), speed=1.0)
    args = {"start": (0.0, 0.0), "waypoints": (wp,), "pushes": (), "duration": 1.0, **kwargs}
    with pytest.raises(InvalidParameter, match=rf"^{name}"):
        scenarios.Script(**args)  # type: ignore[arg-type]


@pytest.mark.parametrize("gain", ["6", True, 1j, math.nan, 10**400])
def test_operator_gain(gain: object):
    wp = scenarios.Waypoint(t=0.0, target=(0.5, 0.5), speed=1.0)
    with pytest.raises(InvalidParameter, match=r"^gain"):
        scenarios.WaypointOperator((wp,), gain=gain)  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", ["str", "dict", "ragged", "complex", "nan", "huge-int"])
def test_operator_position_and_constant_velocity(kind: str):
    wp = scenarios.Waypoint(t=0.0, target=(0.5, 0.5), speed=1.0)
    with pytest.raises(InvalidInput, match=r"^p: "):
        scenarios.WaypointOperator((wp,))(0.0, BAD_VECTORS[kind])  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^velocity: "):
        scenarios.constant(BAD_VECTORS[kind])  # type: ignore[arg-type]


@pytest.mark.parametrize("buffer", ["0.1", 1j, math.nan, 1e308, -1.0])
def test_default_script_buffer(buffer: object):
    with pytest.raises(InvalidParameter, match=r"^buffer"):
        default_script(SQUARE, buffer=buffer)  # type: ignore[arg-type]


def test_default_script_and_operator_from_refuse_other_types():
    with pytest.raises(VelfenceError):
        default_script("square", buffer=0.1)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match=r"^script: "):
        scenarios.operator_from({"waypoints": ()})  # type: ignore[arg-type]
