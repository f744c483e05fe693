"""Specs of velfence.shaping (and of the 2-D shaper methods shared with sim and cobot)."""

from __future__ import annotations

import numpy as np
from common import P2, P_ROWS, V2, V_ROWS, square
from harness import C, F, call

import velfence as vf
from velfence.mechanisms import PAPER_STOPS, Q_AUX

#: The methods every 2-D shaper has (ShaperBase).
SHAPER_2D = {
    "explain": lambda: call(P2, V2),
    "shape": lambda: call(P2, V2),
    "shape_batch": lambda: call(P_ROWS, V_ROWS),
    "zones_batch": lambda: call(P_ROWS, V_ROWS),
}
_DELTA = {"delta": "scalar", "speed": "nonneg"}
#: Documented exemptions (docs/reliability-inputs.md, "Documented exemptions").
_NO_CAP = "documented: math.inf (no cap) beyond the buffer"
_NONE = "documented: an empty sequence means none"
_PROFILE_METHODS = {
    "cap": F(lambda: call(0.1, 1.0), types=_DELTA, nonfinite={"out": _NO_CAP}),
    "zone": F(lambda: call(0.1), types=_DELTA),
}
_P3 = np.array([0.1, 0.02, 0.0])
_V3 = np.array([0.05, 0.01, 0.0])
_LINE_METHODS = {
    "explain": lambda: call(_P3, _V3),
    "shape": lambda: call(_P3, _V3),
    "shape_batch": lambda: call(np.array([_P3, _P3 * 0.5]), np.array([_V3, -_V3])),
}
_THETA = np.array([0.2, 0.1, 0.0])
_THETA_DOT = np.array([0.5, -0.2, 0.1])


_Q7 = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
_QD7 = np.array([0.3, -0.2, 0.1, 0.0, 0.5, -0.4, 0.2])


def _arm() -> object:
    from velfence.mechanisms import DHChain

    return DHChain.seven_dof(link_radius=0.04)


#: A link index is "tcp" or an int >= -1 (-1 the base): these kinds are valid links.
_LINK_INDEX = {
    "int_minus_1": "documented: -1 is the base",
    "int_zero": "documented: link 0",
    "int_for_flag": "documented: an int link index",
}


def _sphere() -> object:
    from velfence.filter import Sphere

    return Sphere("tcp", [0.0, 0.0, 0.05], radius=0.02)


def _limits() -> object:
    from velfence.filter import JointLimits

    lo = np.radians([-170.0, -120.0, -170.0, -120.0, -170.0, -120.0, -175.0])
    return JointLimits(lo, -lo, max_speed=np.full(7, 1.5), max_acceleration=np.full(7, 10.0))


def _box() -> object:
    from velfence.geometry.polytope import ConvexPolytope

    return ConvexPolytope.box([-0.3, -0.3, 0.8], [0.3, 0.3, 1.3])


def safety_filter() -> object:
    from velfence.filter import SafetyFilter, SphereObstacle, WorkspaceLimit

    return SafetyFilter(
        _arm(),  # type: ignore[arg-type]
        limits=_limits(),  # type: ignore[arg-type]
        workspace=WorkspaceLimit(_box(), buffer=0.05),
        obstacles=[SphereObstacle([0.0, 0.3, 0.6], radius=0.05)],
        attachments={"tool": _sphere()},  # detach("tool") has one to detach
        dt=0.002,
    )


def _sphere_obstacle() -> object:
    from velfence.filter import SphereObstacle

    return SphereObstacle([0.0, 0.3, 0.6], radius=0.05)


def _separation_parameters() -> object:
    from velfence.filter import SeparationParameters

    return SeparationParameters(
        reaction_time=0.1, stopping_time=0.3, max_deceleration=2.0, intrusion=0.1
    )


def _person() -> object:
    from velfence.filter import PersonCapsule

    return PersonCapsule(
        [0.9, 0.3, 0.2], b=[0.9, 0.3, 1.6], radius=0.15, velocity=[-1.0, 0.0, 0.0], name="torso"
    )


def _separation_rows() -> object:
    from velfence.filter import SeparationRows

    return SeparationRows(
        _separation_parameters(),  # type: ignore[arg-type]
        link_radius=np.full(7, 0.04),
        max_speed=np.full(7, 1.5),
        people=[_person()],  # type: ignore[list-item]
    )


def _cloud() -> object:
    """A few points around the 7-joint arm at ``_Q7`` [m]."""
    return np.array([[0.5, 0.1, 0.9], [0.45, 0.0, 1.1], [-0.3, 0.2, 0.4], [0.6, -0.2, 0.2]])


def _point_cloud_rows() -> object:
    from velfence.filter import PointCloudRows

    rows = PointCloudRows(
        voxel=0.05,
        link_radius=np.full(7, 0.04),
        max_speed=np.full(7, 1.5),
        buffer=0.5,
        spring_gain=5.0,
        decay=1.0,
    )
    rows.update(_cloud(), stamp=0.0)
    return rows


def _cloud_next_distances_call() -> object:
    ctx = _row_context()
    block = _point_cloud_rows().rows(ctx)  # type: ignore[attr-defined]
    return call(ctx.frame, block)  # type: ignore[attr-defined]


#: PointCloudRows.update: a sensor's NaN/inf points are dropped and counted
#: (docs/reliability-inputs.md, "Documented exemptions").
_CLOUD_NAN = "documented: non-finite points are dropped and counted (dropped_nonfinite)"


def _mode_limits() -> object:
    from velfence.filter import ModeLimits

    return ModeLimits(joint_scale=0.5, point_speeds={"tcp": 0.25})


def _mode_zone() -> object:
    from velfence.filter import ModeZone

    return ModeZone(_zone_box(), name="cell")  # type: ignore[arg-type]


def _slowdown_zone() -> object:
    from velfence.filter import SlowdownZone

    return SlowdownZone(_zone_box(), far_speed=1.0, near_speed=0.2, distance=0.5)  # type: ignore[arg-type]


def _approach_zone() -> object:
    from velfence.filter import ApproachZone

    return ApproachZone(_zone_box(), time_to_collision=0.5)  # type: ignore[arg-type]


def _zone_box() -> object:
    from velfence.geometry.polytope import ConvexPolytope

    return ConvexPolytope.box([0.0, -0.5, 0.0], [0.5, 0.5, 1.5])


def _mode_rows() -> object:
    from velfence.filter import ModeLimits, ModeRows, ModeZone

    return ModeRows(
        _arm(),
        modes={"reduced": ModeLimits(joint_scale=0.5, point_speeds={"tcp": 0.25})},
        zones=[ModeZone(_zone_box(), name="cell")],  # type: ignore[arg-type]
        max_speed=np.full(7, 1.5),
    )


def _slowdown_rows() -> object:
    from velfence.filter import SlowdownRows, SlowdownZone

    zone = SlowdownZone(_zone_box(), far_speed=1.0, near_speed=0.2, distance=0.5)  # type: ignore[arg-type]
    return SlowdownRows(_arm(), [zone])


def _approach_rows() -> object:
    from velfence.filter import ApproachRows, ApproachZone

    return ApproachRows(_arm(), [ApproachZone(_zone_box(), time_to_collision=0.5)])  # type: ignore[arg-type]


#: A mode's value is a string among "normal", "reduced", "stop" (or the SafetyMode member).
_MODE = "choice"


_RC = "a RowContext (or frame and RowBlock) the SafetyFilter builds each cycle, trusted"


def _row_context() -> object:
    from velfence.filter import RowContext
    from velfence.filter.kinematics import frame_of

    return RowContext(_Q7, np.zeros(7), None, 0.004, frame_of(_arm(), _Q7))  # type: ignore[arg-type]


def _next_distances_call() -> object:
    ctx = _row_context()
    block = _separation_rows().rows(ctx)  # type: ignore[attr-defined]
    return call(ctx.frame, block)  # type: ignore[attr-defined]


def _chain_frames() -> object:
    """The ChainFrames of a two-joint MJCF arm (MujocoRobot.chain_frames())."""
    from velfence.robots import MujocoRobot, dh_mjcf

    xml = dh_mjcf(
        [[0.0, 0.0, 0.5, 0.0], [0.3, 0.0, 0.0, 0.0]], joint_limits=[[-1.0, 1.0], [-2.0, 2.0]]
    )
    return MujocoRobot(xml=xml).chain_frames()


_ROS2 = {
    "joint_limits": {
        "a": {
            "has_position_limits": True,
            "min_position": -1.0,
            "max_position": 1.0,
            "has_velocity_limits": True,
            "max_velocity": 1.0,
            "has_acceleration_limits": False,
            "max_acceleration": 0.0,
        }
    }
}


def profile() -> vf.ThreeZoneBraking:
    """A valid braking profile (max_speed above max_acceleration/gain, as the profile requires)."""
    return vf.ThreeZoneBraking(gain=4.0, max_speed=1.0, max_acceleration=2.0)


def box3() -> vf.ConvexPolytope:
    return vf.ConvexPolytope.box([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])


_PT3 = np.array([0.95, 0.2, -0.1])
_VT3 = np.array([0.5, -0.2, 0.1])
_POLYTOPE_METHODS = {
    "explain": lambda: call(_PT3, _VT3),
    "shape": lambda: call(_PT3, _VT3),
    "shape_batch": lambda: call(np.array([_PT3, -_PT3]), np.array([_VT3, _VT3])),
    "zones_batch": lambda: call(np.array([_PT3, -_PT3]), np.array([_VT3, _VT3])),
    "bound_rows": lambda: call(_PT3, _VT3),
}


def stop_limiter() -> vf.StopLimiter:
    return vf.StopLimiter(PAPER_STOPS, profile=profile(), transform=Q_AUX)


SPECS: dict[str, F | C] = {
    "shaping.ApproachProfile": C(abstract="Protocol: exercised through its implementations"),
    "shaping.Shaper": C(abstract="Protocol: exercised through its implementations"),
    "shaping.ShapingResultProtocol": C(
        abstract="Protocol: satisfied by every shaper's explain() record"
    ),
    "shaping.LinearBuffer": C(F(lambda: call(buffer=0.2, spring_gain=4.0)), _PROFILE_METHODS),
    "shaping.ThreeZoneBraking": C(
        lambda: call(gain=4.0, max_speed=1.0, max_acceleration=2.0),
        {
            **_PROFILE_METHODS,
            "check_period": lambda: call(0.001),
            "from_actuator_limits": lambda: call(gain=4.0, max_speed=1.0, max_acceleration=2.0),
        },
    ),
    # accelerate=False: the numba batch kernel takes 10+ s to compile on this machine and only
    # ever sees arrays the validation layer has already checked; the flag itself is attacked.
    "shaping.PolygonShaper": C(
        F(
            lambda: call(square(), buffer=0.2, spring_gain=2.0, accelerate=False),
            required=frozenset({"buffer"}),
        ),
        {
            **SHAPER_2D,
            "bounds": lambda: call(P2, V2),
            "bound_rows": lambda: call(P2, V2),
        },
    ),
    # accelerate=False as for PolygonShaper (the compiled kernels see only validated arrays).
    "shaping.PolytopeShaper": C(
        F(
            lambda: call(box3(), buffer=0.2, spring_gain=2.0, accelerate=False),
            required=frozenset({"buffer"}),
        ),
        _POLYTOPE_METHODS,
    ),
    "shaping.PolytopeResult": C(record="output record of PolytopeShaper.explain()"),
    "shaping.RateLimiter": C(
        lambda: call(size=2, max_speed=1.0, max_acceleration=10.0, dt=0.001),
        {
            "bounds": lambda: call(),
            "hold": lambda: call(np.array([0.1, 0.2])),
            "reset": lambda: call([0.1, 0.2]),
            "step": lambda: call([0.5, 0.2]),
        },
    ),
    "shaping.StopLimiter": C(
        # limited is a pair of coordinate indices, not a real vector: float entries are refused
        F(
            lambda: call(PAPER_STOPS, profile=profile(), transform=Q_AUX),
            types={"limited": "object"},
        ),
        {
            "explain": lambda: call(_THETA, _THETA_DOT),
            "reset": lambda: call(),
            "shape": lambda: call(_THETA, _THETA_DOT),
            "shape_batch": lambda: call(np.array([_THETA, _THETA]), np.array([_THETA_DOT] * 2)),
        },
        instance=stop_limiter,
    ),
    "shaping.LineFixture": C(
        lambda: call([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
        {**_LINE_METHODS, "force": lambda: call(_P3)},
    ),
    "shaping.LineScaling": C(
        # across = 0 is documented (motion across the line suppressed): >= 0, not > 0
        F(lambda: call([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]), types={"across": "nonneg"}),
        _LINE_METHODS,
    ),
    "shaping.ShapingResult": C(
        record="output record built by every shaper's explain()",
        instance=lambda: vf.PolygonShaper(square(), buffer=0.2).explain(P2, V2),
    ),
    "shaping.FixtureResult": C(record="output record of LineFixture.explain()"),
    "shaping.ScalingResult": C(record="output record of LineScaling.explain()"),
    "shaping.StopResult": C(record="output record of StopLimiter.explain()"),
    "filter.Kinematics": C(abstract="Protocol: exercised through DHChain, PlanarArm, Puma560"),
    "filter.FilterResult": C(record="output record of SafetyFilter.explain()"),
    "filter.KinematicsFrame": C(abstract="Protocol: exercised through the robots' kinematics(q)"),
    "filter.RowProvider": C(abstract="Protocol: exercised through SafetyFilter(providers=...)"),
    "filter.RowBlock": C(record="rows of one provider, read by SafetyFilter (tests/filter)"),
    "filter.RowContext": C(record="one cycle's inputs, built by SafetyFilter for its providers"),
    "filter.ChainData": C(record="output record of DHChain.chain_data()"),
    "filter.CachedFrame": C(abstract="built by SafetyFilter per cycle on validated q"),
    "filter.JointPositionLimit": C(abstract="built by SafetyFilter from validated JointLimits"),
    "filter.JointVelocityLimit": C(abstract="built by SafetyFilter from validated JointLimits"),
    "filter.JointAccelerationLimit": C(abstract="built by SafetyFilter from validated limits"),
    "filter.JointJerkLimit": C(abstract="built by SafetyFilter from validated limits"),
    "filter.WorkspaceRows": C(abstract="built by SafetyFilter from a validated WorkspaceLimit"),
    "filter.ObstacleRows": C(abstract="built by SafetyFilter from validated SphereObstacles"),
    "filter.SelfCollisionRows": C(abstract="built by SafetyFilter from a validated SelfCollision"),
    "filter.AttachmentTable": C(abstract="built by SafetyFilter from validated Sphere/Capsule"),
    "filter.AttachmentWorkspaceRows": C(abstract="built by SafetyFilter from its AttachmentTable"),
    "filter.AttachmentObstacleRows": C(abstract="built by SafetyFilter from its AttachmentTable"),
    "filter.Sphere": C(
        F(
            lambda: call("tcp", [0.0, 0.0, 0.05], radius=0.02),
            types={"radius": "nonneg"},
            accepts={"link": _LINK_INDEX},
        )
    ),
    "filter.Capsule": C(
        F(
            lambda: call("tcp", [0.0, 0.0, 0.0], [0.0, 0.0, 0.1], radius=0.02),
            types={"radius": "nonneg"},
            accepts={"link": _LINK_INDEX},
        )
    ),
    "filter.SelfCollision": C(
        F(
            lambda: call(exclude=[(0, 3)], min_gap=2),
            accepts={
                "exclude": {
                    "empty_list": "documented: no pair excluded",
                    "empty_tuple": _NONE,
                    "empty_rows": "documented: an empty (0, 2) array excludes no pair",
                },
            },
        ),
        {"pairs": F(lambda: call([0.3, 0.3, 0.3, 0.3], radii=[0.05] * 4))},
    ),
    "filter.JointLimits": C(
        F(
            lambda: call(
                [-1.0, -2.0],
                [1.0, 2.0],
                max_speed=[1.0, 0.5],
                max_acceleration=[5.0, 4.0],
                max_jerk=[100.0, 200.0],
            ),
            types={"lower": "vector", "upper": "vector", "max_speed": "vector"},
            accepts={
                "lower": {"neg_inf_in_valid": "documented: -inf is no lower limit"},
                "upper": {"inf_in_valid": "documented: +inf is no upper limit"},
                "max_acceleration": {
                    "inf": "documented: inf is no acceleration limit",
                    "inf_in_valid": "documented: inf is no acceleration limit on that joint",
                },
                "max_jerk": {
                    "inf": "documented: inf is no jerk limit",
                    "inf_in_valid": "documented: inf is no jerk limit on that joint",
                },
            },
            nonfinite={
                "out.lower": "documented: -inf is no lower limit",
                "out.upper": "documented: +inf is no upper limit",
                "out.max_acceleration": "documented: inf is no acceleration limit",
                "out.max_jerk": "documented: inf is no jerk limit",
            },
        ),
        {
            "from_ros2_control": F(
                lambda: call(_ROS2, ["a"]), types={"mapping": "object", "joint_names": "object"}
            )
        },
    ),
    "filter.WorkspaceLimit": C(F(lambda: call(_box(), buffer=0.05), types={"point": "text"})),
    "filter.SeparationParameters": C(
        F(
            lambda: call(
                reaction_time=0.1,
                stopping_time=0.3,
                max_deceleration=2.0,
                human_speed=1.6,
                intrusion=0.1,
                human_uncertainty=0.05,
                robot_uncertainty=0.02,
            ),
            types={
                "reaction_time": "positive",
                "stopping_time": "nonneg",
                "max_deceleration": "positive",
                "human_speed": "nonneg",
                "intrusion": "nonneg",
                "human_uncertainty": "nonneg",
                "robot_uncertainty": "nonneg",
            },
            # exactly one of max_deceleration and stopping_distance (None for the other)
            required=frozenset({"max_deceleration"}),
        )
    ),
    "filter.PersonCapsule": C(
        F(
            lambda: call(
                [0.9, 0.3, 0.2], b=[0.9, 0.3, 1.6], radius=0.15, velocity=[-1.0, 0.0, 0.0]
            ),
            types={"radius": "nonneg", "name": "text"},
        )
    ),
    "filter.SeparationRows": C(
        F(
            lambda: call(
                _separation_parameters(),
                link_radius=np.full(7, 0.04),
                max_speed=np.full(7, 1.5),
                people=[_person()],
            ),
            types={"parameters": "object", "link_radius": "vector", "max_speed": "vector"},
            accepts={
                "people": {"empty_list": _NONE, "empty_tuple": _NONE},
            },
        ),
        {
            "update": F(
                lambda: call([_person()], stamp=1.0),
                accepts={"people": {"empty_list": _NONE, "empty_tuple": _NONE}},
            ),
            "rows": F(lambda: call(_row_context()), skip={"ctx": _RC}),
            "next_distances": F(
                _next_distances_call,  # type: ignore[arg-type]
                skip={"frame": _RC, "block": _RC},
            ),
        },
        instance=_separation_rows,
    ),
    "filter.PointCloudRows": C(
        F(
            lambda: call(
                voxel=0.05,
                link_radius=np.full(7, 0.04),
                max_speed=np.full(7, 1.5),
                buffer=0.5,
                spring_gain=5.0,
                decay=1.0,
            ),
            types={"link_radius": "vector", "max_speed": "vector"},
        ),
        {
            "update": F(
                lambda: call(_cloud(), stamp=1.0),
                types={"points": "rows"},
                accepts={
                    "points": {
                        "nan_in_valid": _CLOUD_NAN,
                        "inf_in_valid": _CLOUD_NAN,
                        "neg_inf_in_valid": _CLOUD_NAN,
                    }
                },
            ),
            "rows": F(lambda: call(_row_context()), skip={"ctx": _RC}),
            "select": F(lambda: call(_row_context()), skip={"ctx": _RC}),
            "next_distances": F(
                _cloud_next_distances_call,  # type: ignore[arg-type]
                skip={"frame": _RC, "block": _RC},
            ),
        },
        instance=_point_cloud_rows,
    ),
    "filter.SafetyMode": C(
        record="an enum: its members are constants; SafetyMode(value) refuses any other value "
        "with InvalidParameter (tests/filter/test_mode_zones.py)"
    ),
    "filter.ModeEvent": C(record="output record ModeRows builds for each mode switch"),
    "filter.ModeLimits": C(
        F(
            lambda: call(joint_scale=0.5, max_speed=np.full(7, 1.0), point_speeds={"tcp": 0.25}),
            types={"joint_scale": "nonneg", "max_speed": "vector", "point_speeds": "object"},
            accepts={
                "max_speed": {"inf_in_valid": "documented: inf is no cap on that joint"},
                "point_speeds": {
                    "dict_empty": "documented: an empty mapping means no Cartesian cap",
                    "dict_xy": "documented: any point names; ModeRows checks them on its robot",
                },
            },
            nonfinite={"out.max_speed": "documented: inf is no cap on that joint"},
        )
    ),
    "filter.ModeZone": C(
        F(
            lambda: call(_zone_box(), mode="stop", name="cell", points=("tcp", "elbow")),
            types={"polytope": "object", "mode": _MODE, "name": "text", "points": "object"},
        )
    ),
    "filter.ModeRows": C(
        F(
            lambda: call(
                _arm(),
                modes={"reduced": _mode_limits()},
                zones=[_mode_zone()],
                points=("tcp", "elbow"),
                max_speed=np.full(7, 1.5),
                enter_depth=0.01,
                exit_distance=0.02,
                dwell=0.1,
                history=100,
            ),
            types={
                "robot": "object",
                "modes": "object",
                "zones": "object",
                "points": "object",
                "max_speed": "vector",
                "enter_depth": "nonneg",
                "exit_distance": "nonneg",
                "dwell": "nonneg",
                "history": "count",
            },
            # joint_scale 0.5 in the valid call's limits needs max_speed (None: refused)
            required=frozenset({"max_speed"}),
            accepts={
                "zones": {"empty_list": _NONE, "empty_tuple": _NONE},
                "modes": {"dict_empty": "documented: a missing mode has no caps"},
            },
        ),
        {
            "update": F(
                lambda: call(_Q7, time=1.0), types={"position": "vector", "time": "scalar"}
            ),
            "request": F(
                lambda: call("reduced", source="light curtain"),
                types={"mode": _MODE, "source": "text"},
            ),
            "rows": F(lambda: call(_row_context()), skip={"ctx": _RC}),
        },
        instance=_mode_rows,
    ),
    "filter.SlowdownZone": C(
        F(
            lambda: call(
                _zone_box(), far_speed=1.0, near_speed=0.2, distance=0.5, point="tcp", name="s"
            ),
            types={
                "polytope": "object",
                "far_speed": "nonneg",
                "near_speed": "nonneg",
                "distance": "positive",
                "point": "text",
                "name": "text",
            },
        ),
        {
            "speed_cap": F(
                lambda: call(0.1),
                types={"distance": "scalar"},
                nonfinite={"out": "documented: inf (no cap) beyond the band"},
            )
        },
        instance=lambda: _slowdown_rows().zones[0],  # type: ignore[attr-defined]
    ),
    "filter.SlowdownRows": C(
        F(
            lambda: call(_arm(), [_slowdown_zone()]),
            types={"robot": "object", "zones": "object"},
            accepts={"zones": {"empty_list": _NONE, "empty_tuple": _NONE}},
        ),
        {"rows": F(lambda: call(_row_context()), skip={"ctx": _RC})},
        instance=_slowdown_rows,
    ),
    "filter.ApproachZone": C(
        F(
            lambda: call(_zone_box(), time_to_collision=0.5, point="tcp", name="table"),
            types={
                "polytope": "object",
                "time_to_collision": "positive",
                "point": "text",
                "name": "text",
            },
        )
    ),
    "filter.ApproachRows": C(
        F(
            lambda: call(_arm(), [_approach_zone()]),
            types={"robot": "object", "zones": "object"},
            accepts={"zones": {"empty_list": _NONE, "empty_tuple": _NONE}},
        ),
        {"rows": F(lambda: call(_row_context()), skip={"ctx": _RC})},
        instance=_approach_rows,
    ),
    "filter.speed_cap_directions": F(lambda: call(3), types={"dim": "count"}),
    "filter.LinkClearances": C(record="output record of link_clearances()"),
    "filter.link_clearances": F(
        lambda: call(_arm(), [_sphere_obstacle()], np.array([_Q7, _Q7])),
        types={"robot": "object", "obstacles": "object", "positions": "vector"},
    ),
    "filter.separation_distance": F(
        lambda: call(1.0, parameters=_separation_parameters(), human_speed=1.2),
        types={"robot_speed": "scalar", "parameters": "object", "human_speed": "nonneg"},
    ),
    "filter.max_approach_speed": F(
        lambda: call(1.0, parameters=_separation_parameters(), human_speed=1.2, dt=0.01),
        types={"distance": "scalar", "parameters": "object", "human_speed": "nonneg"},
    ),
    # radius 0 is documented (>= 0): a point obstacle; influence None: no sphere of influence.
    "filter.SphereObstacle": C(
        F(
            lambda: call([0.0, 0.3, 0.6], radius=0.05, influence=0.3),
            types={"radius": "nonneg", "influence": "positive"},
        )
    ),
    "filter.SafetyFilter": C(
        F(
            lambda: call(_arm(), limits=_limits(), dt=0.002),
            types={"robot": "object", "limits": "object", "weights": "vector"},
            skip={"providers": "a RowProvider sequence, () valid: tests/filter"},
            accepts={
                "obstacles": {"empty_list": _NONE, "empty_tuple": _NONE},
                "workspace": {"empty_list": _NONE, "empty_tuple": _NONE},
                "attachments": {
                    "dict_empty": "documented: no attachments",
                    "empty_list": "documented: no attachments",
                    "empty_tuple": "documented: no attachments",
                },
                "self_collision": {
                    "true": "documented: True guards every default pair",
                    "false": "documented: False (the default) guards none",
                },
            },
        ),
        {
            "attach": lambda: call("held", _sphere()),
            "detach": F(lambda: call("tool"), types={"name": "choice"}),
            "explain": lambda: call(_Q7, _QD7),
            "filter": lambda: call(_Q7, _QD7),
            "explain_twist": F(lambda: call(_Q7, [0.1, 0.0, 0.2]), types={"point": "choice"}),
            "filter_twist": F(lambda: call(_Q7, [0.1, 0.0, 0.2]), types={"point": "choice"}),
            "reset": F(lambda: call(velocity=np.zeros(7)), types={"velocity": "vector"}),
            "shape": lambda: call(_Q7, _QD7),
            "shape_batch": lambda: call(np.array([_Q7, _Q7]), np.array([_QD7, -_QD7])),
            "filter_batch": F(
                lambda: call(
                    np.array([_Q7, -_Q7]),
                    np.array([_QD7, -_QD7]),
                    previous=np.array([_QD7, 0.5 * _QD7]),
                    threads=1,
                ),
                types={"threads": "seed"},  # 0 is valid: one thread per online core
            ),
        },
        instance=safety_filter,
    ),
    "filter.ChainFrames": C(
        record="output record of MujocoRobot.chain_frames()",
        methods={
            "fk": F(lambda: call(np.array([0.3, -0.4]), "tcp"), types={"point": "choice"}),
        },
        instance=_chain_frames,
    ),
    "filter.FilterBatch": C(
        record="output record of SafetyFilter.filter_batch()",
        methods={"stage_names": F(lambda: call(1), types={"row": "seed"})},
        instance=lambda: safety_filter().filter_batch(  # type: ignore[attr-defined]
            np.array([_Q7, -_Q7]), np.array([_QD7, -_QD7]), threads=1
        ),
    ),
}


def _lagged() -> vf.LagCompensation:
    inner = vf.PolygonShaper(square(), buffer=0.2, accelerate=False)
    return vf.LagCompensation(inner, time_constant=0.02, dt=0.001)


SPECS["shaping.LagCompensation"] = C(
    F(
        lambda: call(
            vf.PolygonShaper(square(), buffer=0.2, accelerate=False), time_constant=0.02, dt=1e-3
        ),
        types={"shaper": "object"},
    ),
    {
        "explain": lambda: call([0.1, 0.2], [1.0, 0.0]),
        "shape": lambda: call([0.1, 0.2], [1.0, 0.0]),
        "shape_batch": lambda: call([[0.1, 0.2]], [[1.0, 0.0]]),
        "reset": lambda: call(),
    },
    instance=_lagged,
)
