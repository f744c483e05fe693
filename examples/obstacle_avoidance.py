"""A planar 3R arm tracks a line while configuration control keeps a link off an obstacle.

Scenario (i) of ``velfence reproduce obstacles``: the end effector goes straight down 2 m and
back with a smooth (cosine) profile; without the controller the elbow link would pass 0.07 m
from the obstacle, inside its 0.2 m sphere of influence.
"""

import numpy as np

from velfence import PlanarArm
from velfence.filter import SphereObstacle
from velfence.redundancy import ConfigurationController, cosine_line


def main() -> None:
    """Print every second: zone, clearance to the sphere of influence [mm], EE error [mm].

    A clearance of a few tenths of a millimetre below zero is the discrete-time overshoot of the
    1 kHz loop (``velfence reproduce obstacles`` bounds it); the line then says how far inside
    the sphere of influence that is and how far the link still is from the obstacle's body.
    """
    arm = PlanarArm.three_r()
    obstacle = SphereObstacle(center=np.array([1.5, -1.4]), radius=0.05, influence=0.2)
    ctrl = ConfigurationController(arm, [obstacle])
    line = cosine_line((2.0, 1.0), (0.0, -1.0), 2.0, 5.0, back=True)  # Y_d(t), Ẏ_d(t)
    q = np.array([-0.395014, 0.803931, 1.001739])  # end effector at (2, 1)
    dt = 1e-3
    for k in range(10_000):
        y_d, v_d = line(k * dt)
        r = ctrl.control(q, v_d + 10.0 * (y_d - arm.end_effector(q)))
        if k % 1000 == 0:
            clear = r.distances[0] - obstacle.influence  # [m], < 0: inside the sphere
            where = (
                f"  ({-clear * 1e3:.1f} mm inside the sphere of influence, "
                f"{(r.distances[0] - obstacle.radius) * 1e3:.0f} mm from the body)"
                if clear < 0
                else ""
            )
            print(
                f"t={k * dt:4.1f} s  {r.zone:<10s}  clearance d-rho {clear * 1e3:+7.1f} mm"
                f"  ee error {np.linalg.norm(y_d - arm.end_effector(q)) * 1e3:.2f} mm{where}"
            )
        q = q + dt * r.q_dot


if __name__ == "__main__":
    main()
