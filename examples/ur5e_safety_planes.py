"""A UR5e jogged into two tilted safety planes: the safety filter keeps the TCP on their side.

The permitted region is unbounded: the intersection of two half-spaces n_i·x >= off_i (a wall
tilted 15° from vertical and a floor tilted 10°), a ConvexPolytope with two facets. The operator
holds a constant TCP velocity into both planes for 3 s; the SafetyFilter in twist mode turns it
into joint velocities that slow the TCP to rest on the planes (2 ms period, kinematic plant).
"""

import numpy as np

from velfence.filter import JointLimits, SafetyFilter, WorkspaceLimit
from velfence.geometry import ConvexPolytope
from velfence.mechanisms import DHChain

DT = 2e-3  # control period [s]
STEPS = 1500  # 3 s
TWIST = np.array([-0.15, 0.05, -0.12])  # TCP velocity command [m/s]


def main() -> None:
    robot = DHChain.ur5e()
    q = np.array([0.0, -1.2, 1.5, -1.9, -1.57, 0.0])
    start = robot.fk(q)
    tilt_wall, tilt_floor = np.radians(15.0), np.radians(10.0)
    normals = np.array(
        [
            [np.cos(tilt_wall), 0.0, np.sin(tilt_wall)],  # the wall: inside towards +x
            [0.0, np.sin(tilt_floor), np.cos(tilt_floor)],  # the floor: inside upwards
        ]
    )
    # Both planes 8 cm (wall) and 10 cm (floor) from the start position.
    offsets = normals @ start - np.array([0.08, 0.10])
    planes = ConvexPolytope(normals, offsets, facet_names=("wall", "floor"))
    lo, hi = robot.joint_limits[:, 0], robot.joint_limits[:, 1]
    safety = SafetyFilter(
        robot,
        limits=JointLimits(lo, hi, max_speed=np.full(6, np.pi)),
        workspace=WorkspaceLimit(planes, point="tcp", buffer=0.04),
        dt=DT,
    )
    closest = np.full(2, np.inf)
    for _ in range(STEPS):
        q = q + DT * safety.filter_twist(q, TWIST)
        closest = np.minimum(closest, planes.signed_distances(robot.fk(q)))
    tcp = robot.fk(q)
    print(f"start tcp {np.round(start, 6).tolist()} m, command {TWIST.tolist()} m/s for 3 s")
    print(f"planes normals {np.round(normals, 6).tolist()} offsets {np.round(offsets, 6).tolist()}")
    print(f"min distance wall {closest[0]:.3e} m, floor {closest[1]:.3e} m")
    print(f"final tcp {np.round(tcp, 6).tolist()} m")


if __name__ == "__main__":
    main()
