"""Specs of velfence.sim."""

from __future__ import annotations

import numpy as np
from common import command, square
from harness import C, F, call
from specs_shaping import SHAPER_2D

import velfence as vf
from velfence.geometry import Rectangle
from velfence.sim import Trajectory


def traj() -> Trajectory:
    """A short valid trajectory (50 steps inside the square, then out)."""
    t = np.linspace(0.0, 0.49, 50)
    p = np.column_stack([np.linspace(0.0, 1.2, 50), np.zeros(50)])
    v = np.tile([2.4, 0.0], (50, 1))
    return Trajectory(t, p, v, v)


def pressing_traj() -> Trajectory:
    """A valid trajectory sliding along the top edge while pushing up into it (a defined ratio)."""
    t = np.linspace(0.0, 0.49, 50)
    p = np.column_stack([np.linspace(-0.5, 0.5, 50), np.full(50, 0.98)])
    v_cmd = np.tile([2.0, 1.0], (50, 1))
    v_out = np.tile([2.0, 0.0], (50, 1))
    return Trajectory(t, p, v_cmd, v_out)


def shaper() -> vf.PolygonShaper:
    return vf.PolygonShaper(square(), buffer=0.2, accelerate=False)


_TRAJ_POLY = lambda: call(traj(), square())  # noqa: E731
_CMDS = np.array([[1.0, 0.0], [0.0, 1.0]])

#: Documented exemptions (docs/reliability-inputs.md, "Documented exemptions").
_WINDOW = {"t0": "nonneg", "t1": "positive"}
_ENDLESS = {"t1": {"inf": "documented: t1 = math.inf is a push that never ends"}}
_ENDLESS_OUT = {"out.pushes[0][1]": "documented: t1 = math.inf is a push that never ends"}
_NEVER = "documented: inf when the run never leaves the disc, nan when it never enters it"
_NO_PRESS = "documented: nan when no row presses with a tangential component"

SPECS: dict[str, F | C] = {
    "sim.NoLimit": C(lambda: call(), SHAPER_2D),
    "sim.HardStop": C(lambda: call(square(), dt=0.001), SHAPER_2D),
    "sim.AxisLimits": C(
        lambda: call(Rectangle(xmin=-1.0, xmax=1.0, ymin=-1.0, ymax=1.0), buffer=0.2),
        {**SHAPER_2D, "inscribed": lambda: call(square(), buffer=0.2)},
    ),
    "sim.Disturbance": C(
        F(
            lambda: call(pushes=((0.1, 0.2, 0.5, 0.0),)),
            types={"pushes": "vector"},
            accepts={
                "pushes": {
                    k: "documented: empty means no disturbance"
                    for k in ("empty_list", "empty_tuple", "empty_array", "empty_rows")
                }
            },
        ),
        {
            "push": F(
                lambda: call(0.1, 0.2, [0.5, 0.0]),
                types=_WINDOW,
                accepts=_ENDLESS,
                nonfinite=_ENDLESS_OUT,
            )
        },
    ),
    "sim.push": F(
        lambda: call(0.1, 0.2, [0.5, 0.0]), types=_WINDOW, accepts=_ENDLESS, nonfinite=_ENDLESS_OUT
    ),
    "sim.Trajectory": C(
        F(
            lambda: call([0.0, 0.1], [[0.0, 0.0], [0.1, 0.0]], [[1.0, 0.0]] * 2, [[1.0, 0.0]] * 2),
            accepts={"zone": {"str_array": "documented: zone labels are any strings"}},
        ),
        {"window": F(lambda: call(0.0, 0.2), types={"t0": "scalar", "t1": "scalar"})},
        instance=traj,
    ),
    "sim.simulate": F(lambda: call(shaper(), command, [0.0, 0.0], duration=0.05)),
    "sim.simulate_many": F(lambda: call({"exact": shaper()}, command, [0.0, 0.0], duration=0.05)),
    "sim.area_gain": F(lambda: call(square())),
    # deadband 0 is documented (>= 0): signs are then exact.
    "sim.chatter_rate": F(lambda: call(traj(), square(), band=0.1), types={"deadband": "nonneg"}),
    "sim.corner_escape_time": F(
        lambda: call(traj(), square(), 0, radius=0.2),
        types={"corner_index": "seed"},
        nonfinite={"out": _NEVER},
    ),
    "sim.max_output_jump": F(lambda: call(shaper(), square(), spacing=0.25, commands=_CMDS)),
    "sim.max_penetration": F(_TRAJ_POLY),
    # A pressing run: the ratio of a run that never presses is the documented nan.
    # deadband 0 is documented (>= 0): signs are then exact.
    "sim.sliding_ratio": F(
        lambda: call(pressing_traj(), square(), band=0.1),
        types={"deadband": "nonneg"},
        nonfinite={"out": _NO_PRESS},
    ),
    "sim.summarize": F(
        lambda: call(pressing_traj(), square(), band=0.1),
        types={"corner_index": "count"},
        nonfinite={"out['sliding_ratio']": _NO_PRESS, "out['corner_escape_time']": _NEVER},
    ),
    "sim.time_outside": F(_TRAJ_POLY),
}


def _robot() -> object:
    from velfence.robots import dh_mjcf

    return dh_mjcf(
        [[0.0, 0.0, 0.3, 0.0], [0.25, 0.0, 0.0, 0.0]], joint_limits=[[-2.0, 2.0], [-2.0, 2.0]]
    )


def _plant() -> vf.sim.MujocoPlant:
    plant = vf.sim.MujocoPlant(_robot(), physics_dt=5e-4)
    plant.reset(np.array([0.1, 0.2]), 1e-3)
    return plant


SPECS.update(
    {
        "sim.BodyPush": C(
            F(
                lambda: call(
                    body="link1", force=[1.0, 0.0, 0.0], torque=[0.0, 0.0, 0.1], start=0.1
                ),
                types={"body": "text", "start": "nonneg", "duration": "positive"},
            ),
            {"active": F(lambda: call(0.15), types={"t": "scalar"})},
        ),
        "sim.MujocoPlant": C(
            F(
                lambda: call(_robot(), bandwidth=30.0, physics_dt=5e-4, max_effort=50.0),
                types={
                    "robot": "path",
                    "kv": "vector",
                    "max_effort": "vector",
                    "max_speed": "vector",
                    "servo": "choice",
                },
                skip={
                    "obstacles": "SphereObstacle sequence, () valid: tests/sim/test_physics.py",
                    "pushes": "a sequence of BodyPush, () valid: tests/sim/test_physics.py",
                    "joints": "names checked against the model: tests/sim/test_physics.py",
                    "actuated": "names checked against the model: tests/sim/test_physics.py",
                },
            ),
            {
                "reset": F(lambda: call([0.1, 0.2], 1e-3), types={"dt": "positive"}),
                "advance": F(lambda: call([0.1, -0.1], 0.0), types={"t": "scalar"}),
                "state": lambda: call(),
            },
            instance=_plant,
        ),
        "sim.PhysicsRecord": C(record="a record the plant builds (MujocoPlant.record)"),
        "sim.DynamicPlant": C(abstract="a Protocol"),
    }
)
