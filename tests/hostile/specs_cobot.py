"""Specs of velfence.cobot."""

from __future__ import annotations

import numpy as np
from common import P2, square
from harness import C, F, call
from specs_shaping import SHAPER_2D

from velfence.cobot import (
    CasterWall,
    Coupling,
    IdentityKinematics,
    PathFollower,
    SteeredWheel,
    TetrahedralCVT,
    r_theta_cobot,
)
from velfence.geometry import Circle

_R = np.array([1.2, 0.0])
_T = np.array([0.0, 1.0])
_PHI = lambda: call(0.3)  # noqa: E731
_CVT = {
    "angle_rate": F(_PHI, types={"phi": "scalar"}),
    "direction": F(_PHI, types={"phi": "scalar"}),
    "steering_angle": F(lambda: call(np.array([0.6, 0.8]))),
    "steering_rate": F(
        lambda: call(0.3, 0.5, 1.0),
        types={"phi": "scalar", "curvature": "scalar", "speed": "scalar"},
    ),
}
_KIN_R = lambda: call(np.array([0.8, 0.3]))  # noqa: E731
_KIN = {"hessian": _KIN_R, "jacobian": _KIN_R, "joints": _KIN_R, "position": _KIN_R}


def circle() -> Circle:
    return Circle([0.0, 0.0], radius=1.0)


def follower() -> PathFollower:
    f = PathFollower(circle(), gains=(4.0, 4.0))
    f.reset(_R, s_p=0.0, sp_d=1.0)
    return f


def intent(t: float, R: np.ndarray) -> np.ndarray:
    return np.array([1.0, 0.2])


def _trace():  # type: ignore[no-untyped-def]
    from velfence.sim.cobot import follow_in_ee

    return follow_in_ee(follower(), _R, _T, length=0.05, ds=0.01)


_COBOT_Q = np.array([0.8, 0.3])
_J = np.eye(2)
_H = np.zeros((2, 2, 2))

SPECS: dict[str, F | C] = {
    "cobot.CVT": C(abstract="Protocol: exercised through SteeredWheel and TetrahedralCVT"),
    "cobot.CobotKinematics": C(abstract="Protocol: exercised through its implementations"),
    "sim.HeadingController": C(abstract="Protocol: exercised through PathFollower"),
    "cobot.SteeredWheel": C(lambda: call(), _CVT),
    "cobot.TetrahedralCVT": C(
        # convention is a sign (+1 or -1, any real type): -1 is valid, so not a count or choice
        F(lambda: call(convention=1), types={"convention": "scalar"}),
        {**_CVT, "ratio": F(_PHI, types={"phi": "scalar"})},
    ),
    "cobot.IdentityKinematics": C(lambda: call(n=2), _KIN),
    "cobot.RThetaKinematics": C(lambda: call(), _KIN),
    "cobot.Coupling": C(
        F(
            lambda: call(TetrahedralCVT(), selection=np.diag([2.0, 1.0])),
            required=frozenset({"selection"}),
        ),
        {"maps": lambda: call(_COBOT_Q, _J, _H)},
    ),
    "cobot.Cobot": C(
        lambda: call(
            IdentityKinematics(n=2),
            [Coupling(SteeredWheel(), jacobian=lambda R: (np.eye(2), np.zeros((2, 2, 2))))],
        ),
        {
            "directions": lambda: call([0.3]),
            "heading": lambda: call(_COBOT_Q, [0.3]),
            "steering_angles": lambda: call(_COBOT_Q, _T),
            "steering_rates": F(
                # speed is the signed speed along T (pushing backwards is allowed)
                lambda: call(_COBOT_Q, [0.3], _T, [0.0, 0.0], 1.0),
                types={"speed": "scalar"},
            ),
        },
        instance=r_theta_cobot,
    ),
    "cobot.CasterWall": C(
        lambda: call(square(), buffer=0.2), {**SHAPER_2D, "line": lambda: call(P2, [1.0, 0.3])}
    ),
    "cobot.WallSteering": C(
        lambda: call(CasterWall(square(), buffer=0.2), intent),
        {
            "step": F(
                lambda: call([0.5, 0.2], [1.0, 0.0], 0.01, 0.0),
                # ds is the HeadingController protocol's arc length: 0 (human stopped) is valid
                types={"t": "nonneg", "ds": "nonneg"},
            )
        },
    ),
    "cobot.PathFollower": C(
        lambda: call(circle()),
        {
            "evaluate": lambda: call(_R, _T),
            "reset": F(lambda: call(_R, s_p=0.0), types={"s_p": "scalar"}),
            # ds = 0 is valid: the human stopped (the reference state is kept)
            "step": F(lambda: call(_R, _T, 0.01), types={"t": "nonneg", "ds": "nonneg"}),
        },
        instance=follower,
    ),
    "sim.CobotTrace": C(
        record="output record of follow_in_ee() and simulate_cobot()",
        instance=_trace,
        methods={
            "at_arc_length": lambda: call([0.0, 0.02]),
            "error_at": lambda: call([0.0, 0.02]),
            "to_trajectory": lambda: call(),
        },
    ),
    "cobot.FollowerOutput": C(record="output record of PathFollower.evaluate()"),
    "cobot.Heading": C(record="output record of Cobot.heading()"),
    "cobot.Steering": C(record="output record of Cobot.steering_rates()"),
    "cobot.WallSteeringOutput": C(record="output record of WallSteering.step()"),
    "sim.constant_speed": F(lambda: call(0.5), types={"u": "nonneg"}),
    "sim.pushing": F(lambda: call(intent)),
    "cobot.critically_damped": F(lambda: call(2.0)),
    "cobot.gains_from_poles": F(lambda: call(-2.0, -3.0)),
    "cobot.generalised_cross": F(lambda: call([[3.0, 4.0]])),
    "cobot.normalised_derivative": F(lambda: call([1.0, 0.0], [0.0, 2.0])),
    "cobot.map_tangent_curvature": F(lambda: call(np.eye(2), _T, [0.0, 0.0])),
    "cobot.joint_from_ee": F(lambda: call(_J, _H, _T, [0.0, 0.0])),
    "cobot.coupling_from_ee": F(lambda: call(_J, _H, _T, [0.0, 0.0])),
    "cobot.coupling_from_joint": F(lambda: call(np.eye(2), _T, [0.0, 0.0])),
    # convention is a sign (+1 or -1, any real type): -1 is valid, so not a count or choice
    "cobot.r_theta_cobot": F(lambda: call(r_o=0.5), types={"convention": "scalar"}),
    "cobot.unicycle": F(lambda: call()),
    "sim.follow_in_ee": F(lambda: call(follower(), _R, _T, length=0.05, ds=0.01)),
    "sim.simulate_cobot": F(
        lambda: call(
            r_theta_cobot(),
            follower(),
            [1.2, 0.0],
            r_theta_cobot().steering_angles([1.2, 0.0], _T),
            speed=lambda t, R, T: 0.5,
            duration=0.02,
            dt=0.01,
            heading0=_T,
        )
    ),
}
