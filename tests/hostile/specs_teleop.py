"""Specs of velfence.apps.teleop."""

from __future__ import annotations

import numpy as np
from common import Q6, pose, puma
from harness import C, F, call

from velfence.apps.teleop import (
    Box,
    LaserRangeSensor,
    ModeManager,
    OperatorProfile,
    Plane,
    ResolvedRate,
    Session,
    SyntheticOperator,
    door_scene,
    straight_line,
)

_P3 = np.array([0.1, 0.2, 0.3])
_D3 = np.array([0.0, 1.0, 0.0])
_RAY = lambda: call([0.0, 0.0, 0.0], [0.0, 1.0, 0.0])  # noqa: E731
#: Documented exemptions (docs/reliability-inputs.md, "Documented exemptions").
_MISS = {"out": "documented: math.inf on a miss"}
_NONE = "documented: an empty sequence means none"
_ANY_SHAPE = {
    k: "documented: elementwise, an array of any shape (empty gives empty)"
    for k in (
        *("added_axis", "three_d", "nested_too_deep"),
        *("empty_list", "empty_tuple", "empty_array", "empty_rows"),
    )
}
_CASE = {"key": {"choice_upper": "documented: keys are case-insensitive"}}
_PRIM = {"distance": lambda: call(_P3), "intersect": F(_RAY, nonfinite=_MISS)}


def _line():  # type: ignore[no-untyped-def]
    T0 = pose()
    T1 = T0.copy()
    T1[:3, 3] += [0.01, 0.0, 0.0]
    return straight_line(T0, T1)


def _rot() -> np.ndarray:
    c, s = np.cos(0.3), np.sin(0.3)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _session() -> Session:
    return Session()


def _observation():  # type: ignore[no-untyped-def]
    return Session().observe()


def _operator() -> SyntheticOperator:
    return SyntheticOperator(seed=0)


_SAMPLES = {10.0: [0.9] * 20 + [0.91] * 5, 20.0: [0.99] * 20 + [1.0] * 5}
_RNG = "a numpy Generator (validated by numpy)"
_OBS = lambda o: np.zeros(3)  # noqa: E731

SPECS: dict[str, F | C] = {
    "teleop.Characteristic": C(abstract="Protocol: exercised through TabulatedCharacteristic"),
    "teleop.JointServo": C(abstract="Protocol: exercised through FirstOrderServo, PDGravityServo"),
    "teleop.Plane": C(
        lambda: call([0.0, 1.0, 0.0], [0.0, -1.0, 0.0]),
        {**_PRIM, "signed_distance": lambda: call(_P3)},
    ),
    "teleop.Disk": C(lambda: call([0.0, 1.0, 0.0], [0.0, -1.0, 0.0], radius=0.1), _PRIM),
    "teleop.Cylinder": C(
        lambda: call([0.0, 1.0, 0.0], radius=0.05, height=0.1),
        {**_PRIM, "contains": lambda: call(_P3)},
    ),
    "teleop.Box": C(
        F(lambda: call([0.0, 1.0, 0.0], half_extents=[0.1, 0.1, 0.1])),
        {**_PRIM, "contains": lambda: call(_P3)},
    ),
    "teleop.Scene": C(
        lambda: call(
            {
                "wall": Plane([0.0, 1.0, 0.0], [0.0, -1.0, 0.0]),
                "box": Box([0.5, 0.5, 0.0], half_extents=[0.1, 0.1, 0.1]),
            }
        ),
        {
            "inside": lambda: call(_P3),
            "items": lambda: call(),
            "nearest": lambda: call(_P3),
            # documented >= 0
            "raycast": F(lambda: call([0.0, 0.0, 0.0], _D3), types={"max_range": "nonneg"}),
            "segment_hit": lambda: call([0.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
        },
    ),
    "teleop.Hit": C(record="output record of Scene.raycast()"),
    "teleop.door_scene": F(lambda: call()),
    "teleop.pick_and_place_scene": F(lambda: call()),
    "teleop.scene_to_dicts": F(
        lambda: call(door_scene()),
        types={"dynamic": "object"},
        accepts={"dynamic": {"empty_list": _NONE, "empty_tuple": _NONE}},
    ),
    "teleop.VoltageModel": C(
        lambda: call(),
        {
            "distance_cm": F(lambda: call(1.0), types={"voltage_v": "scalar"}),
            "distance_m": F(lambda: call(1.0), types={"voltage_v": "scalar"}),
            "distances_m": F(lambda: call([1.0, 1.2]), accepts={"voltages_v": _ANY_SHAPE}),
            "from_calibration": lambda: call([10.0, 20.0, 30.0], [0.9, 0.99, 1.07]),
            "voltage_v": F(lambda: call(0.3), types={"distance_m": "scalar"}),
            "voltages_v": F(lambda: call([0.3, 0.4]), accepts={"distances_m": _ANY_SHAPE}),
        },
    ),
    "teleop.TabulatedCharacteristic": C(
        lambda: call([10.0, 20.0, 30.0], [0.9, 0.99, 1.07]),
        {"voltage_v": F(lambda: call(0.2), types={"distance_m": "scalar"})},
    ),
    "teleop.LaserRangeSensor": C(
        # documented >= 0: a zero minimum range and a zero ADC step (no quantisation) are valid
        F(lambda: call(), types={"min_range": "nonneg", "quantum_v": "nonneg"}),
        {
            "beam": lambda: call(pose()),
            "in_range": F(lambda: call(1.0), types={"distance": "scalar"}),
            # a reading of 0 m (target at the window) is a valid reading
            "laser_point": F(lambda: call(pose(), 1.0), types={"distance": "nonneg"}),
            "sample": F(
                lambda: call(1.0, np.random.default_rng(0)),
                types={"true_distance": "nonneg"},  # documented >= 0 (below min_range: None)
                skip={"rng": _RNG},
            ),
            "sample_many": F(
                lambda: call(1.0, 5, np.random.default_rng(0)),
                types={"true_distance": "nonneg"},  # documented >= 0 (below min_range: None)
                skip={"rng": _RNG},
            ),
            # t0 is a clock origin: any finite time
            "stream": F(lambda: call(seed=0), types={"seed": "seed", "t0": "scalar"}),
            "target_transform": F(lambda: call(pose(), 1.0), types={"distance": "nonneg"}),
            "true_hit": lambda: call(pose(), door_scene()),
            "true_range": lambda: call(pose(), door_scene()),
        },
    ),
    "teleop.LaserStream": C(
        F(lambda: call(LaserRangeSensor(), seed=0), types={"seed": "seed", "t0": "scalar"}),
        {
            "observe": lambda: call(pose(), door_scene()),
            # times on the stream clock (t0 is any finite origin)
            "poll": F(lambda: call(0.01, pose(), door_scene()), types={"t": "scalar"}),
            "reset": F(lambda: call(t0=0.0), types={"t0": "scalar"}),
            "run": F(lambda: call([1.0, 1.1, None]), required=frozenset({"true_distances"})),
            "step": F(lambda: call(1.0), types={"true_distance": "nonneg"}),  # documented >= 0
        },
    ),
    "teleop.LaserReading": C(record="output record of LaserStream.step()"),
    "teleop.calibrate": F(lambda: call(_SAMPLES), types={"samples": "object"}),
    "teleop.frequent_level_mean": F(lambda: call([0.9] * 20 + [0.91] * 5)),
    "teleop.moving_average": F(
        lambda: call([1.0, 2.0, 3.0, 4.0], window=2),
        accepts={
            "samples": {
                k: "documented: windows along the last axis of an array of any leading shape"
                for k in ("added_axis", "three_d", "empty_rows")
            }
        },
    ),
    "teleop.plane_from_points": F(lambda: call([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])),
    "teleop.ResolvedRate": C(
        lambda: call(puma()),
        {
            "explain": lambda: call(Q6, [0.01, 0.0, 0.0, 0.0, 0.0, 0.0]),
            "step": lambda: call(Q6, [0.01, 0.0, 0.0, 0.0, 0.0, 0.0]),
        },
    ),
    "teleop.RateResult": C(record="output record of ResolvedRate.explain()"),
    "teleop.angle_axis": F(lambda: call(_rot())),
    "teleop.rotation_vector": F(lambda: call(_rot())),
    "teleop.rotation_from_angle_axis": F(
        lambda: call([0.0, 0.0, 1.0], 0.3), types={"angle": "scalar"}
    ),
    "teleop.damping": F(lambda: call(0.01), types={"w": "nonneg"}),
    "teleop.manipulability_of": F(lambda: call(np.eye(6))),
    "teleop.pose_error": F(lambda: call(pose(), pose())),
    "teleop.sr_inverse": F(lambda: call(np.eye(6), k=0.01), types={"k": "nonneg"}),
    "teleop.aligned_rotation": F(lambda: call(np.eye(3), [0.0, 0.0, 1.0])),
    "teleop.CartesianTrajectory": C(
        record="output record of straight_line()",
        instance=_line,
        # t is clamped into [0, duration] (documented): any finite time
        methods={"sample": F(lambda: call(0.01), types={"t": "scalar"})},
    ),
    # documented >= 0 (0: only exact zero translations count as pure rotations)
    "teleop.straight_line": F(lambda: call(pose(), _line().end), types={"min_distance": "nonneg"}),
    "teleop.execute": F(lambda: call(_line(), puma(), Q6)),
    "teleop.Execution": C(record="output record of execute()"),
    "teleop.FirstOrderServo": C(
        lambda: call(time_constant=0.01),
        {"reset": lambda: call(Q6), "step": lambda: call(Q6, 0.005)},
        instance=lambda: _reset_servo(),
    ),
    "teleop.PDGravityServo": C(
        lambda: call(kp=100.0, inertia=1.0),
        {"reset": lambda: call(Q6), "step": lambda: call(Q6, 0.005)},
        instance=lambda: _reset_servo(pd=True),
    ),
    "teleop.ModeManager": C(
        # documented >= 0: stopping at the spot, no scaling across, no settling wait are valid
        F(
            lambda: call(),
            types={"standoff": "nonneg", "across": "nonneg", "max_settle": "nonneg"},
            accepts={"fixture_options": {"dict_empty": "documented: no options, the defaults"}},
        ),
        {
            "control": lambda: call(
                t=0.0, pose=pose(), linear=[0.01, 0.0, 0.0], angular=[0.0, 0.0, 0.0]
            ),
            "press": F(
                lambda: call("A", t=0.0, pose=pose(), distance=0.5),
                # t: any finite time (event log clock); a reading of 0 m is documented valid (>= 0)
                types={"t": "scalar", "distance": "nonneg"},
                accepts=_CASE,
            ),
            "reset": lambda: call(),
        },
    ),
    "teleop.ModeEvent": C(record="output record of ModeManager.press()"),
    "teleop.Segment": C(record="internal motion segment exposed for inspection"),
    "teleop.Session": C(
        F(lambda: call(), types={"hand_time": "nonneg"}),  # documented >= 0: an instant hand
        {
            "advance": F(lambda: call(0.01), types={"dt": "nonneg"}),  # documented: 0 s is a no-op
            "jog": lambda: call([0.01, 0.0, 0.0], [0.0, 0.0, 0.0]),
            "observe": lambda: call(),
            "press": F(lambda: call("C"), accepts=_CASE),
            "reset": lambda: call(),
            "scene_primitives": lambda: call(),
            "snapshot": lambda: call(),
        },
        instance=_session,
    ),
    "teleop.Observation": C(record="output record of Session.observe()"),
    "teleop.OperatorProfile": C(
        # every time of the profile is documented >= 0 (an instant key press is a valid model)
        F(lambda: call(), types={"key_time": "nonneg", "clutch_time": "nonneg"}),
        {
            "draw": F(lambda: call(np.random.default_rng(0)), skip={"rng": _RNG}),
            "to_dict": lambda: call(),
        },
    ),
    "teleop.SyntheticOperator": C(
        F(lambda: call(profile=OperatorProfile(), seed=0), types={"seed": "seed"}),
        {
            "act": lambda: call(_observation()),
            "aim": lambda: call(np.array([0.0, 1.0, 0.0]), tol=0.01),
            "disengage": lambda: call(),
            "engage": lambda: call(),
            "index": lambda: call(np.array([0.01, 0.0, 0.0])),
            "orient": lambda: call(lambda o: np.eye(3), tol=0.05),
            "press": lambda: call("A"),
            "reach": lambda: call(_OBS, tol=0.01),
            "record": lambda: call("A"),
            "start": lambda: call(lambda op: op.wait(0.1)),
            "stroke": lambda: call(np.array([0.01, 0.0, 0.0]), tol=0.001),
            # a and b are Fitts-law coefficients [s], [s/bit]: zero is a valid value
            "turn": F(
                lambda: call(np.array([0.0, 0.0, 0.1]), peak=0.3, a=0.4, b=0.3, tol=0.01),
                types={"a": "nonneg", "b": "nonneg"},
            ),
            "vertical": lambda: call(0.05),
            # waiting 0 s is a valid one-tick no-op (plans compute their waits)
            "wait": F(lambda: call(0.1), types={"duration": "nonneg"}),
            "wait_until": lambda: call(lambda o: True),
        },
        instance=_operator,
    ),
    "teleop.TaskRecord": C(
        record="output record of run_task()",
        instance=lambda: _task_record(),
        methods={"to_dict": lambda: call()},
    ),
    "teleop.TaskRun": C(record="output record of run_task()"),
    "teleop.run_task": F(
        lambda: call("assisted", time_limit=5.0),
        heavy="a whole simulated trial (seconds of CPU)",
    ),
}


def _reset_servo(pd: bool = False):  # type: ignore[no-untyped-def]
    from velfence.apps.teleop import FirstOrderServo, PDGravityServo

    s = PDGravityServo(kp=100.0, inertia=1.0) if pd else FirstOrderServo(time_constant=0.01)
    s.reset(Q6)
    return s


def _task_record():  # type: ignore[no-untyped-def]
    from velfence.apps.teleop import TaskRecord

    fields = dict.fromkeys(TaskRecord.__dataclass_fields__, 0)
    fields.update(condition="assisted", done=True)
    return TaskRecord(**fields)


_ = ModeManager, ResolvedRate
