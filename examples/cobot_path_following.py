"""A cobot control loop: read the steering, steer toward a path, let the human set the speed.

The r-θ cobot of Gillespie, Colgate & Peshkin 1999 follows a rounded square; the human pushes at a
speed that varies and pauses. Each tick is what a real controller does: forward transformation
(steering angles -> allowed direction), path follower (-> curvature), inverse route (-> steering
rates). A passive virtual wall bounds the same cobot in caster mode.
"""

import numpy as np

from velfence import ConvexPolygon
from velfence.cobot import CasterWall, PathFollower, r_theta_cobot
from velfence.geometry import Polyline


def main() -> None:
    cobot = r_theta_cobot(r_o=0.5)
    square = Polyline([[0.6, -0.4], [1.4, -0.4], [1.4, 0.4], [0.6, 0.4]], closed=True,
                      corner_radius=0.15)  # fmt: skip
    follower = PathFollower(square, gains=(9.0, 6.0))  # double spatial pole at -3 /m
    R = np.array([1.0, -0.5])
    T = np.array([1.0, 0.0])
    follower.reset(R)
    q = cobot.kinematics.joints(R)
    phi = cobot.steering_angles(R, T)
    dt, s = 1e-3, 0.0
    for k in range(6000):
        t = k * dt
        u = 0.0 if 2.0 <= t < 2.5 else 0.5 + 0.3 * np.sin(t)  # the human's speed [m/s]
        heading = cobot.heading(q, phi, reference=T)  # measured direction (sign from motion)
        T = heading.T
        R = cobot.kinematics.position(q)
        out = follower.step(R, T, u * dt)  # the arc length travelled since the last tick
        rates = cobot.steering_rates(R, phi, T, out.kN, u).phi_dot
        # the plant: move along the allowed direction at the human's speed; steer
        q = q + cobot.kinematics.jacobian(R) @ T * (u * dt)
        phi = phi + rates * dt
        s += u * dt
        if k % 1000 == 0:
            print(f"t = {t:4.1f} s  s = {s:5.2f} m  |ΔR| = {np.linalg.norm(out.error):.2e} m")

    wall = CasterWall(ConvexPolygon([[0.5, -0.5], [1.5, -0.5], [1.5, 0.5], [0.5, 0.5]]), buffer=0.1)
    for p in ([1.0, 0.0], [1.45, 0.0], [1.5, 0.0]):
        print("caster wall at", p, "push (1, 0.2) ->", wall.shape(np.array(p), np.array([1, 0.2])))


if __name__ == "__main__":
    main()
