"""Specs of velfence.mechanisms."""

from __future__ import annotations

import numpy as np
from common import Q6, pose
from harness import C, F, call

from velfence.mechanisms import PAPER_STOPS, CoSPM, CoSPMDesign

_THETA, _CHI = (np.asarray(a, dtype=float) for a in CoSPM().home())
_TC = F(lambda: call(_THETA, _CHI), types={"theta": "rows", "chi": "rows"})
_Q2 = np.array([0.1, 0.2])
_QD2 = np.array([0.3, -0.1])

_CHAIN_METHODS = {
    "clip_to_limits": None,
    "ee_jacobian": None,
    "end_effector": None,
    "joint_positions": None,
    "link_segments": None,
    "within_limits": None,
}


def _chain(q: np.ndarray) -> dict[str, F]:
    out: dict[str, F] = {m: F(lambda q=q: call(q)) for m in _CHAIN_METHODS}
    out["point_jacobian"] = F(lambda q=q: call(q, 1, 0.5), types={"t": "scalar", "link": "seed"})
    # the Kinematics protocol of the safety filter: a named point (a choice among robot.points)
    out["fk"] = F(lambda q=q: call(q, "joint1"), types={"point": "choice"})
    out["jacobian"] = F(lambda q=q: call(q, "joint1"), types={"point": "choice"})
    out["angular_jacobian"] = F(lambda q=q: call(q))
    out["kinematics"] = F(lambda q=q: call(q))
    out["chain_data"] = lambda: call()
    return out


_Q3 = np.array([0.3, 0.4, -0.2])
_Q6 = Q6.copy()

SPECS: dict[str, F | C] = {
    "mechanisms.SerialChain": C(abstract="Protocol: exercised through PlanarArm and DHChain"),
    "mechanisms.PlanarArm": C(
        lambda: call([1.0, 1.0, 1.0]),
        {**_chain(_Q3), "four_r": lambda: call(), "three_r": lambda: call()},
    ),
    "mechanisms.DHChain": C(
        F(
            lambda: call([[0.0, 0.0, 0.5, 0.0], [0.0, 0.0, 0.4, 0.0]]),
            accepts={"named_points": {"dict_empty": "documented: no extra named points"}},
        ),
        {
            **_chain(np.array([0.3, 0.4])),
            "frames": lambda: call([0.3, 0.4]),
            "puma560": lambda: call(),
            "seven_dof": lambda: call(),
            "ur5e": lambda: call(),
        },
    ),
    "mechanisms.Puma560": C(
        lambda: call(),
        {
            "configuration": lambda: call(_Q6),
            "angular_jacobian": lambda: call(_Q6),
            "kinematics": lambda: call(_Q6),
            "chain_data": lambda: call(),
            "fk": F(lambda: call(_Q6, "elbow"), types={"point": "choice"}),
            "ik": lambda: call(pose()),
            "ik_all": lambda: call(pose()),
            "ik_nearest": lambda: call(pose(), _Q6),
            "jacobian": F(lambda: call(_Q6, "wrist"), types={"point": "choice"}),
            "manipulability": lambda: call(_Q6),
            "position": lambda: call(_Q6),
            "within_limits": lambda: call(_Q6),
        },
    ),
    "mechanisms.CoSPMDesign": C(
        lambda: call(
            **{
                k: getattr(CoSPMDesign.table1(), k)
                for k in ("alpha1", "alpha2", "eta", "beta1", "beta2")
            }
        ),
        {"table1": lambda: call()},
    ),
    "mechanisms.CoSPM": C(
        lambda: call(),
        {  # chi, theta: one vector or a batch of rows, documented (3,) or (N, 3)
            "A": _TC,
            "B": _TC,
            "E": F(lambda: call(_CHI), types={"chi": "rows"}),
            "axes": _TC,
            "bearing_shift": F(
                lambda: call(_THETA, _CHI, 0.01),
                types={"eps": "scalar", "theta": "rows", "chi": "rows"},
            ),
            "forward_kinematics": F(lambda: call(_THETA), types={"theta": "rows"}),
            "geometric_model": _TC,
            "home": lambda: call(),
            "inverse_kinematics": F(lambda: call(_CHI), types={"chi": "rows"}),
            "jacobian": _TC,
            "representation": F(lambda: call(_CHI), types={"chi": "rows"}),
            "type1": _TC,
            "type2": _TC,
        },
    ),
    "mechanisms.Wrist": C(
        lambda: call(),
        {  # q, lengths: one vector or a batch of rows, documented (2,) or (N, 2)
            "actuator_lengths": F(lambda: call(_Q2), types={"q": "rows"}),
            "actuator_velocity": lambda: call(_Q2, _QD2),
            "default_polygon": lambda: call(),
            "default_polygon_edges": lambda: call(),
            "feasible": F(lambda: call(_Q2), types={"q": "rows"}),
            "feasible_grid": lambda: call([0.0, 0.1], [0.0, 0.1, 0.2]),
            "forward_kinematics": F(lambda: call([0.129, 0.129]), types={"lengths": "rows"}),
            "jacobian": F(lambda: call(_Q2), types={"q": "rows"}),
            "joint_velocity": lambda: call(_Q2, [0.01, -0.01]),
            "limit_values": F(lambda: call(_Q2), types={"q": "rows"}),
            "manipulability": F(lambda: call(_Q2), types={"q": "rows"}),
            "saturate": lambda: call(_Q2, _QD2),
            "saturation_factor": lambda: call(_Q2, _QD2),
            "singularity_measure": F(lambda: call(_Q2), types={"q": "rows"}),
            "wire_bend": F(lambda: call(_Q2), types={"q": "rows"}),
        },
    ),
    "mechanisms.WristGeometry": C(lambda: call(), {}),
    "mechanisms.RegionReport": C(record="output record of validate_region()"),
    "mechanisms.SingularGrid": C(record="output record of singular_curves()"),
    "mechanisms.WorkspaceMap": C(record="output record of workspace_map()"),
    "mechanisms.singular_curves": F(
        lambda: call(window=(-0.2, 0.2, -0.2, 0.2), step=0.1),
        types={"window": "vector", "theta3": "scalar"},
    ),
    "mechanisms.stops_polygon": F(lambda: call(PAPER_STOPS)),
    "mechanisms.validate_region": F(
        lambda: call(step=0.02),
        heavy="samples the whole region (seconds); only refusals are tried",
        types={"workspace": "vector", "banks": "vector", "theta3": "scalar"},
    ),
    "mechanisms.workspace_map": F(
        lambda: call(bank=(-0.2, 0.2), elevation=(-0.2, 0.2), step=0.1),
        types={"bank": "vector", "elevation": "vector"},
        nonfinite={
            f"out.{k}": "documented: NaN where unreachable (a range away from home)"
            for k in ("theta", "q", "det_a")
        },
    ),
}
